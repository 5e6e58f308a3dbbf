"""The command line as a user meets it: JSON for scripts, one-line errors for bad input."""

import json
import subprocess
import sys

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.data import dataset as D


@pytest.fixture
def tiny(tmp_path):
    rng = np.random.default_rng(0)
    ds = D.Dataset(rng.normal(size=(4, 31, 3)), rng.normal(size=(4, 31, 3)), np.array([1, 0, 0, 1]),
                   np.array([[0.1, 1.0], [0.1, 1.0], [0.19, 2.0], [0.19, 2.0]]), 0.05, ("y_obj", "mu"),
                   meta={"seed": 5, "command": "judgeopt collect --out x", "source": "simulation"})
    return D.save(ds, tmp_path / "tiny.h5")


def test_inspect_json_has_the_documented_keys(tiny):
    out = subprocess.run([sys.executable, "-m", "judgeopt.cli", "inspect", str(tiny), "--json"],
                         capture_output=True, text=True, check=True).stdout
    s = json.loads(out)  # stdout is exactly one JSON object (no simulator banner)
    assert {"n", "success_ratio", "horizon", "dt", "env_names", "command"} <= set(s)
    assert s["n"] == 4 and s["success_ratio"] == 0.5 and s["horizon"] == 30 and s["dt"] == 0.05
    assert s["command"] == "judgeopt collect --out x"
    assert [row["n"] for row in s["per_env"]] == [2, 2]


def test_inspect_prints_a_summary(tiny, capsys):
    assert main(["inspect", str(tiny)]) == 0
    text = capsys.readouterr().out
    assert "success ratio  : 0.500" in text and "y_obj=0.1" in text


def test_inspect_shows_what_made_an_imported_dataset_and_never_none(tmp_path, capsys):
    x = np.zeros((2, 31, 3))
    meta = {"source": "import-demos", "command": "judgeopt import-demos rec/ --out x.h5"}  # no seed, no version
    ds = D.Dataset(x, x.copy(), np.array([1, 0]), np.array([[0.246], [0.246]]), 0.05, ("y_obj",), meta=meta)
    assert main(["inspect", str(D.save(ds, tmp_path / "imported.h5"))]) == 0
    text = capsys.readouterr().out
    assert "None" not in text and "(source: import-demos)" in text
    assert "made by        : judgeopt import-demos rec/ --out x.h5" in text
    D.save(D.Dataset(x, x.copy(), np.array([1, 0]), np.array([[0.246], [0.246]]), 0.05, ("y_obj",)), tmp_path / "bare.h5")
    assert main(["inspect", str(tmp_path / "bare.h5")]) == 0
    text = capsys.readouterr().out
    assert "None" not in text and "made by" not in text


def test_inspect_says_how_a_refined_judge_was_made_and_never_none(capsys):
    """A judge made by `refine` has no training command: inspect names the round, the judge it
    continued and the replayed plans it saw, as its JSON records them."""
    from judgeopt.files import resolve

    meta = json.loads(resolve("models/judge_refined.json").read_text())
    assert main(["inspect", "models/judge_refined"]) == 0
    text = capsys.readouterr().out
    assert "None" not in text
    assert f"made by        : {meta['source']}, continuing {meta['fine_tuned_from']}" in text
    assert f"{meta['train_data']['planner_outcomes']} replayed plans x{meta['train_data']['weight']}" in text
    assert f"installed from : {meta['installed_from']}" in text


@pytest.mark.parametrize(
    "argv, message",
    [
        (["collect", "--out", "x.h5", "--range", "mu=3,1"], "lower bound 3.0 is above upper bound 1.0"),
        (["collect", "--out", "x.h5", "--range", "y_obj=0.1,0.9"], "y_obj = 0.9 is outside"),
        (["collect", "--out", "x.h5", "--grid", "mu=1,2"], "give --per-env"),
        (["collect", "--out", "x.h5", "--range", "zeta=1,2"], "zeta: not an environment variable of task 'scoop'"),
        (["collect", "--out", "x.h5", "--task", "wipe"], "unknown task 'wipe': known tasks are scoop"),
        (["collect", "--out", "x.h5", "--set", "commands.nope=1"], "no setting 'nope'"),
        (["collect", "--out", "x.h5", "--set", "commands.constant_force_share=lots"], "expected a value like 0.0"),
        (["collect", "--out", "x.h5", "--n", "0"], "--n must be a positive"),
    ],
)
def test_bad_input_is_one_clear_line_and_exit_2(argv, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_a_missing_input_file_is_exit_5(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["inspect", "nope.h5"]) == 5
    err = capsys.readouterr().err
    assert "no such file" in err and len(err.strip().splitlines()) == 1


def test_render_rejects_an_index_out_of_range(tiny, capsys, tmp_path):
    assert main(["render", "--data", str(tiny), "--index", "9", "--out", str(tmp_path)]) == 2
    assert "out of range" in capsys.readouterr().err


def test_every_subcommand_has_help():
    for cmd in ("collect", "inspect", "render", "plot-data"):
        r = subprocess.run([sys.executable, "-m", "judgeopt.cli", cmd, "--help"], capture_output=True, text=True)
        assert r.returncode == 0 and "usage: judgeopt " + cmd in r.stdout
