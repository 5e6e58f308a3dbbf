"""Atomic writes: the new file replaces the old one whole, with the mode an ordinary new file gets."""

from __future__ import annotations

import ast
import os
import stat

import numpy as np
import pytest

from judgeopt.data import dataset as D
from judgeopt.files import REPO, atomic_path, atomic_write


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.fixture(params=[0o022, 0o027])
def umask(request):
    old = os.umask(request.param)
    yield request.param
    os.umask(old)


def test_written_files_get_the_mode_of_an_ordinary_new_file(tmp_path, umask):
    with open(tmp_path / "plain", "w") as fh:  # what the OS gives any new file under this umask
        fh.write("x")
    atomic_write(tmp_path / "a.json", "{}")
    ds = D.Dataset(np.zeros((2, 3, 3)), np.zeros((2, 3, 3)), np.array([0, 1]), np.zeros((2, 1)), 0.05, ("y_obj",))
    D.save(ds, tmp_path / "d.h5")
    assert _mode(tmp_path / "a.json") == _mode(tmp_path / "d.h5") == _mode(tmp_path / "plain")


def test_a_failed_write_keeps_the_old_file_and_leaves_nothing_behind(tmp_path):
    target = tmp_path / "model.json"
    target.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half of the new")
            raise RuntimeError("crash while writing")
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json"]


def test_temporary_files_are_made_in_one_place():
    """A writer that makes its own temporary file skips the rename and the mode: use atomic_path."""
    makers = {"mkstemp", "NamedTemporaryFile", "mktemp"}
    found = []
    for path in (REPO / "judgeopt").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Attribute) and node.attr in makers and path.name != "files.py":
                found.append(f"{path.relative_to(REPO)}:{node.lineno}")
    assert not found


def test_a_build_cache_that_cannot_be_written_is_one_line_naming_judgeopt_cache(tmp_path):
    """A file where the cache folder belongs (as root, permissions would not stop a write): the
    cache's folder, a library's temporary build folder and the command all say to move the cache."""
    import subprocess
    import sys

    import casadi as cs

    from judgeopt.cbuild import compiled_library
    from judgeopt.errors import ExitCode
    from judgeopt.files import OutputWriteError, make_cache_dir

    blocker = tmp_path / "afile"
    blocker.write_text("")
    with pytest.raises(OutputWriteError, match=r"afile is a file, not a folder; .* with \$JUDGEOPT_CACHE") as exc:
        make_cache_dir(blocker / "cache")
    assert exc.value.exit_code == ExitCode.BAD_INPUT
    x = cs.SX.sym("x")
    with pytest.raises(OutputWriteError, match=r"\$JUDGEOPT_CACHE"):
        compiled_library([cs.Function("double_it", [x], [2 * x])], blocker / "cache" / "k", "double_it")
    res = subprocess.run([sys.executable, "-m", "judgeopt", "solve", "--qdot-max", "0.4", "--method", "direct",
                          "--no-simulate", "--no-suggest"], capture_output=True, text=True,
                         env={**os.environ, "JUDGEOPT_CACHE": str(blocker / "cache")})
    assert res.returncode == ExitCode.BAD_INPUT and "Traceback" not in res.stderr, res.stderr[-2000:]
    assert res.stderr.splitlines()[-1].startswith(f"judgeopt solve: error: cannot write {blocker}/cache/")
    assert res.stderr.splitlines()[-1].endswith("choose a writable folder with $JUDGEOPT_CACHE")
