"""judgeopt refine with a robot: a round's plans written for execution, the labelled executions
read back instead of replays, bad or missing recordings reported and the rest kept."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.data.dataset import load, save
from judgeopt.files import REPO, resolve
from judgeopt.planners.problem import ProblemError, load_problem
from judgeopt.refine.loop import RefineConfig, refine

CFG = RefineConfig(rounds=1, n=3, judge_epochs=1, chunk=3)
needs_data = pytest.mark.skipif(not (REPO / "data" / "train.h5").exists(), reason="needs data/train.h5")


def small_train(tmp_path: Path) -> Path:
    """200 demonstrations: one epoch of fine-tuning in a second."""
    ds = load(REPO / "data" / "train.h5")
    return save(ds.subset(np.arange(ds.n) < 200), tmp_path / "train.h5")


def label(csv_text: str) -> str:
    """The 'robot': a plan succeeds when it presses no harder than 15 N (a rule the test can check)."""
    rows = [line.split(",") for line in csv_text.splitlines()[1:]]
    return "success" if max(float(r[3]) for r in rows) <= 15.0 else "failure"


@needs_data
def test_a_round_runs_on_recorded_executions(tmp_path, capsys):
    problem = load_problem(resolve("problems/paper_sim.toml"))
    args = (problem, small_train(tmp_path), REPO / "models" / "judge_demos_tcn", None, tmp_path / "out", CFG)
    assert refine(*args, n_jobs=1, progress=False, plans_only=True) == []
    plans = tmp_path / "out" / "round_1" / "plans"
    manifest = json.loads((plans / "manifest.json").read_text())
    entries = manifest["plans"]
    assert manifest["round"] == 1 and len(entries) == 3 and {e["method"] for e in entries} == {"direct"}
    assert all((plans / e["json"]).exists() and (plans / e["csv"]).exists() for e in entries)
    assert set(entries[0]["environment"]) == {"y_obj", "mu"}
    # the simulator path does not silently replan a round a robot owns
    with pytest.raises(ProblemError, match="written for a robot"):
        refine(*args, n_jobs=1, progress=False)
    # the robot's recordings: the plan's own CSV with a label; one file broken, one never recorded
    runs = tmp_path / "runs"
    runs.mkdir()
    good, broken, missing = entries
    text = (plans / good["csv"]).read_text()
    lines = text.splitlines()
    (runs / f"{good['id']}.csv").write_text("\n".join([lines[0] + ",label"]
                                                       + [r + "," + label(text) for r in lines[1:]]) + "\n")
    bad = (plans / broken["csv"]).read_text().splitlines()
    bad = [bad[0] + ",label"] + [r + ",success" for r in bad[1:]]
    bad[5] = bad[5].replace(bad[5].split(",")[3], "n/a", 1)
    (runs / f"{broken['id']}.csv").write_text("\n".join(bad) + "\n")
    left_out = []
    figs = refine(*args, n_jobs=1, progress=False, outcomes=runs, on_error=left_out.append)
    assert len(left_out) == 2
    assert f"{broken['id']}.csv, row 6, column 'f'" in left_out[0] and "'n/a' is not a number" in left_out[0]
    assert f"{missing['id']}.csv: no recording of plan {missing['id']}" in left_out[1]
    outcomes = load(tmp_path / "out" / "round_1" / "outcomes.h5")
    assert outcomes.n == 1 and outcomes.labels.tolist() == [int(label(text) == "success")]
    assert outcomes.env[0].tolist() == pytest.approx([good["environment"]["y_obj"], good["environment"]["mu"]])
    plan = np.array(json.loads((plans / good["json"]).read_text())["plan"]["f"])
    np.testing.assert_allclose(outcomes.commands[0][:, 2], plan)
    np.testing.assert_allclose(outcomes.responses[0][:, 2], plan, atol=1e-6)  # recorded as commanded here
    summary = json.loads((tmp_path / "out" / "round_1" / "summary.json").read_text())
    assert summary["outcomes_left_out"] == left_out and [(f["round"], f["n"]) for f in figs] == [(1, 1)]
    judge_meta = json.loads(Path(summary["judge"] + ".json").read_text())
    assert judge_meta["train_data"]["planner_outcomes"] == 1  # the dataset grew by the one good recording


@needs_data
def test_outcomes_without_written_plans_are_refused(tmp_path, capsys):
    rc = main(["refine", "--outcomes", str(tmp_path), "--out", str(tmp_path / "out"), "--train",
               str(REPO / "data" / "train.h5"), "--rounds", "1", "--n", "1"])
    err = capsys.readouterr().err
    assert rc != 0 and "round 1 has no plans written to execute" in err and "--plans-only" in err
