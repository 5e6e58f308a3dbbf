"""judgeopt refine: rounds resume, outcomes become demonstrations, models/ changes only on request."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from judgeopt.files import REPO, resolve
from judgeopt.data.dataset import load
from judgeopt.judge.store import load_meta as load_judge_meta
from judgeopt.planners.problem import ProblemError, load_problem
from judgeopt.refine.loop import RefineConfig, install, refine

ROOT = REPO  # the source checkout


def test_config_is_checked():
    with pytest.raises(ProblemError, match="at least 1"):
        RefineConfig(rounds=0)
    with pytest.raises(ProblemError, match="generator_epochs"):
        RefineConfig(methods=("amortized",))


def test_install_needs_a_finished_round(tmp_path):
    with pytest.raises(ProblemError, match="no finished refinement round"):
        install(tmp_path, "x", tmp_path / "models")


@pytest.mark.slow
def test_one_round_aggregates_fine_tunes_resumes_and_installs(tmp_path):
    problem = load_problem(resolve("problems/paper_sim.toml"))
    cfg = RefineConfig(rounds=1, n=2, judge_epochs=1, chunk=1)
    args = (problem, ROOT / "data" / "train.h5", ROOT / "models" / "judge_demos_tcn", None, tmp_path / "out", cfg)
    figs = refine(*args, n_jobs=1, progress=False)
    assert [(f["round"], f["method"], f["n"]) for f in figs] == [(1, "direct", 2)]
    outcomes = load(tmp_path / "out" / "round_1" / "outcomes.h5")
    assert outcomes.n == 2 and set(outcomes.labels) <= {0, 1} and outcomes.responses.shape == (2, 31, 3)
    summary = json.loads((tmp_path / "out" / "round_1" / "summary.json").read_text())
    meta = json.loads(Path(summary["judge"] + ".json").read_text())
    assert meta["fine_tuned_from"].endswith("judge_demos_tcn") and meta["train_data"]["planner_outcomes"] == 2
    # the environments it learnt from: the demonstrations', the round's (within them) and its starting judge's
    from judgeopt.judge.data_ranges import env_ranges_of, union

    envs = union(env_ranges_of(load(ROOT / "data" / "train.h5")), env_ranges_of(outcomes),
                 load_judge_meta(ROOT / "models" / "judge_demos_tcn")["train_data"]["env_ranges"])
    assert meta["train_data"]["env_ranges"] == envs == {"y_obj": [0.1, 0.28], "mu": [1.0, 3.0]}
    assert "limit_ranges" not in meta["train_data"]  # no limits sampled, none recorded
    # a rerun finds the round finished and recomputes nothing
    (tmp_path / "out" / "round_1" / "partial").rename(tmp_path / "moved")
    assert refine(*args, n_jobs=1, progress=False) == figs
    files = install(tmp_path / "out", "refined", tmp_path / "models")
    assert [f.name for f in files] == ["judge_refined.pt", "judge_refined.json"]
    from judgeopt.judge.store import load_judge

    load_judge(tmp_path / "models" / "judge_refined")  # the hash still matches after the copy
    from judgeopt.files import OverwriteError

    with pytest.raises(OverwriteError, match="judge_refined.pt exists"):  # an installed model is never lost
        install(tmp_path / "out", "refined", tmp_path / "models")
    assert install(tmp_path / "out", "refined", tmp_path / "models", overwrite=True) == files
    sub = install(tmp_path / "out", "scrape/refined", tmp_path / "models")  # a task's own folder
    assert sub[0] == tmp_path / "models" / "scrape" / "judge_refined.pt"


def test_generator_fine_tuning_starts_from_a_copy():
    import torch

    from judgeopt.judge.store import load_judge
    from judgeopt.planners.generator_train import GeneratorTrainConfig, train_generator
    from judgeopt.planners.store import load_generator

    problem = load_problem(resolve("problems/paper_sim.toml"))
    judge, _ = load_judge(ROOT / "models" / "judge_demos_tcn")
    init, _ = load_generator(ROOT / "models" / "generator_paper_sim")
    before = {k: v.clone() for k, v in init.state_dict().items()}
    tuned, _ = train_generator(problem, judge, tc=GeneratorTrainConfig(epochs=2, progress=False), init=init)
    assert all(torch.equal(before[k], v) for k, v in init.state_dict().items())  # the original is untouched
    w0, w1 = before["net.0.weight"], tuned.state_dict()["net.0.weight"]
    assert not torch.equal(w0, w1) and (w1 - w0).abs().max() < 0.05  # moved, but from there


@pytest.mark.slow
def test_a_round_with_sampled_limits_plans_each_environment_under_its_own(tmp_path):
    from judgeopt.planners.limits import WIDE_LIMITS

    problem = load_problem(resolve("problems/paper_sim.toml"))
    cfg = RefineConfig(rounds=1, n=3, judge_epochs=1, chunk=3, limit_ranges=WIDE_LIMITS)
    refine(problem, ROOT / "data" / "train.h5", ROOT / "models" / "judge_demos_tcn", None, tmp_path, cfg, n_jobs=1,
           progress=False)
    rows = json.loads(next((tmp_path / "round_1" / "partial").glob("*.json")).read_text())
    limits = [r["limits"] for r in rows]
    assert len({json.dumps(lim, sort_keys=True) for lim in limits}) == len(rows) >= 1  # one draw per environment
    for r, lim in zip(rows, limits):
        for name, (lo, hi) in WIDE_LIMITS.to_dict().items():
            assert lo <= lim[name] <= hi
        qdot, f = [c[1] for c in r["command"]], [c[2] for c in r["command"]]
        assert max(qdot) <= lim["qdot_max"] + 1e-6 and lim["f_min"] - 1e-6 <= min(f) <= max(f) <= lim["f_max"] + 1e-6
    judge_meta = json.loads((tmp_path / "round_1" / "judge.json").read_text())
    # the recorded configuration gives the same ranges back (a resumed or repeated run samples the same limits)
    assert RefineConfig(limit_ranges=judge_meta["refine_config"]["limit_ranges"]).limit_ranges == WIDE_LIMITS
    # what the judge learnt under (judgeopt.judge.data_ranges): these limits, its starting judge's had none
    from judgeopt.judge.data_ranges import limit_ranges_in

    assert limit_ranges_in(judge_meta) == {k: tuple(v) for k, v in WIDE_LIMITS.to_dict().items()}
    assert judge_meta["train_data"]["limit_ranges"] == {k: list(v) for k, v in WIDE_LIMITS.to_dict().items()}
