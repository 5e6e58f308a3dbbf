"""judgeopt as a user installs it: a wheel, in a fresh virtual environment beside an installed
torch, run from a folder that is not the checkout, finds its shipped problems and models."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

from judgeopt.files import REPO


def _run(*cmd, **kw) -> subprocess.CompletedProcess:
    r = subprocess.run(list(map(str, cmd)), capture_output=True, text=True, **kw)
    assert r.returncode == 0, f"{' '.join(map(str, cmd))} failed ({r.returncode}):\n{r.stdout}\n{r.stderr}"
    return r


def _wheel(tmp_path: Path) -> Path:
    """A wheel built from a copy of what git would ship, so nothing left in build/ can leak into it."""
    src = tmp_path / "src"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", "*.history.*", "*.png")
    shutil.copytree(REPO / "judgeopt", src / "judgeopt", ignore=ignore)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(REPO / name, src / name)
    _run(sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w", tmp_path / "dist", src)
    return next((tmp_path / "dist").glob("judgeopt-*.whl"))


def test_the_wheel_says_the_package_is_typed(tmp_path):
    """PEP 561: py.typed (and the stub that types the lazy top-level names) ship in the wheel."""
    import zipfile

    names = set(zipfile.ZipFile(_wheel(tmp_path)).namelist())
    assert {"judgeopt/py.typed", "judgeopt/__init__.pyi"} <= names


@pytest.mark.slow
def test_the_wheel_solves_from_another_folder(tmp_path):
    wheel = _wheel(tmp_path)

    # a fresh environment that sees the installed torch (and the rest) but not the checkout
    venv = tmp_path / "venv"
    _run(Path(sys.base_prefix) / "bin" / "python3", "-m", "venv", "--without-pip", venv)
    py = venv / "bin" / "python"
    purelib = _run(py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])").stdout.strip()
    Path(purelib, "beside_installed.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    _run(py, "-m", "pip", "install", "-q", "--no-index", wheel)  # dependencies must be met by what is installed

    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "JUDGEOPT_MODELS")}
    where = _run(py, "-c", "import judgeopt, judgeopt.files as f; print(judgeopt.__file__); print(f.resolve('models/judge_refined.json'))",
                 cwd=elsewhere, env=env).stdout.split()
    assert all(Path(w).is_relative_to(venv) for w in where), where
    r = _run(venv / "bin" / "judgeopt", "solve", "--qdot-max", "0.4", "--no-simulate", "--json", cwd=elsewhere, env=env)
    out = json.loads(r.stdout)
    assert {p["method"] for p in out["results"]} == {"amortized", "direct"}
    assert all(p["max_constraint_violation"] < 1e-2 for p in out["results"])
    assert Path(out["judge"]).is_relative_to(venv)
    assert not list(elsewhere.iterdir()), "solve wrote into the working folder"


def test_the_wheel_carries_the_models_running_needs_and_no_experiment(tmp_path):
    """Every shipped model travels in the wheel; those kept only to reproduce a table or an
    experiment (models/experiments/, docs/models.md) stay in the checkout."""
    import zipfile

    packed = {n for n in zipfile.ZipFile(_wheel(tmp_path)).namelist() if n.startswith("judgeopt/models/")}
    models = REPO / "judgeopt" / "models"
    wanted = {f"judgeopt/models/{p.relative_to(models).as_posix()}" for p in models.rglob("*")
              if p.suffix in (".pt", ".json") and ".history" not in p.name and "experiments" not in p.parts}
    assert packed == wanted, (sorted(packed - wanted), sorted(wanted - packed))
    assert any("/experiments/" in str(p) for p in models.rglob("*.pt")), "no experiment model to leave out"
