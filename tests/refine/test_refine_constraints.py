"""judgeopt refine --sample-constraints (issue 36): each environment of a round is planned under its
own seeded [constraints] set, drawn from judgeopt.planners.constraint_ranges and feasible for it."""

from __future__ import annotations

import json

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.files import REPO, resolve
from judgeopt.planners.constraint_ranges import ConstraintRanges, draw_constraints
from judgeopt.planners.feasible import check
from judgeopt.planners.limits import CONDITION_NAMES, WIDE_LIMITS
from judgeopt.planners.problem import ProblemError, load_problem
from judgeopt.refine.loop import RefineConfig, _round_envs, _round_limits, refine, round_constraints

PROBLEM = load_problem(resolve("problems/paper_sim.toml"))


def _env(e):
    return dict(zip(PROBLEM.env_names, map(float, e)))


def test_per_environment_sets_are_seeded_and_feasible():
    cfg = RefineConfig(n=6, seed=36, constraint_ranges=ConstraintRanges())
    sets = round_constraints(PROBLEM, cfg, 1)
    assert sets == round_constraints(PROBLEM, cfg, 1)  # same seed and round: the same sets
    assert sets != round_constraints(PROBLEM, RefineConfig(n=6, seed=37, constraint_ranges=ConstraintRanges()), 1)
    assert sets != round_constraints(PROBLEM, cfg, 2)  # another round, other sets
    assert len({json.dumps(s, sort_keys=True) for s in sets}) == 6  # one draw per environment
    r = ConstraintRanges()
    for s, e in zip(sets, _round_envs(PROBLEM, 36, 1, 6)):
        assert set(s) == {"a_max", "jerk_max", "fdot_max", "bounds"} and len(s["bounds"]) == 1
        for name in ("a_max", "jerk_max", "fdot_max"):
            assert getattr(r, name)[0] <= s[name] <= getattr(r, name)[1]
        check(PROBLEM.with_overrides(**s), _env(e))  # feasible for its environment
    # sampling constraints leaves the round's environments as they were; without it, no sets
    assert round_constraints(PROBLEM, RefineConfig(n=6, seed=36), 1) is None


def test_with_sampled_limits_each_set_is_feasible_at_its_environments_limits():
    cfg = RefineConfig(n=5, seed=3, limit_ranges=WIDE_LIMITS, constraint_ranges=ConstraintRanges())
    limits = _round_limits(cfg, 1)
    assert np.array_equal(limits, _round_limits(RefineConfig(n=5, seed=3, limit_ranges=WIDE_LIMITS), 1))
    for s, e, lim in zip(round_constraints(PROBLEM, cfg, 1), _round_envs(PROBLEM, 3, 1, 5), limits):
        check(PROBLEM.with_overrides(**dict(zip(CONDITION_NAMES, map(float, lim))), **s), _env(e))


def test_draw_constraints_redraws_and_says_when_no_set_is_feasible():
    rng = np.random.default_rng(0)
    with pytest.raises(ProblemError, match="no feasible constraint set in 20 draws.*widen the ranges"):
        draw_constraints(rng, PROBLEM, ConstraintRanges(a_max=(0.01, 0.02)))
    with pytest.raises(ProblemError, match="0 < lo <= hi"):
        ConstraintRanges(fdot_max=(30.0, 20.0))


def test_the_ranges_round_trip_through_the_saved_config():
    from dataclasses import asdict

    cfg = RefineConfig(constraint_ranges=ConstraintRanges(a_max=(1.0, 3.0)))
    saved = json.loads(json.dumps(asdict(cfg)))  # as the round's judge metadata holds it
    assert RefineConfig(constraint_ranges=saved["constraint_ranges"]).constraint_ranges == cfg.constraint_ranges


def test_sample_constraints_on_the_command_line(monkeypatch, tmp_path):
    import judgeopt.refine.loop as loop

    seen = {}

    def fake_refine(problem, train, judge, generator, out, cfg, **kwargs):
        seen["cfg"] = cfg
        return []

    monkeypatch.setattr(loop, "refine", fake_refine)
    monkeypatch.setattr(loop, "install", lambda *a, **k: [])
    argv = ["refine", "--rounds", "1", "--n", "2", "--quiet", "--out", str(tmp_path / "r"), "--plans-only"]
    main(argv + ["--sample-constraints"])
    assert seen["cfg"].constraint_ranges == ConstraintRanges()
    main(argv)
    assert seen["cfg"].constraint_ranges is None


@pytest.mark.slow
def test_a_round_with_sampled_constraints_plans_each_environment_under_its_own(tmp_path):
    from judgeopt.planners.result import constraint_residuals
    from judgeopt.trajectory import Plan

    cfg = RefineConfig(rounds=1, n=2, judge_epochs=1, chunk=2, constraint_ranges=ConstraintRanges())
    refine(PROBLEM, REPO / "data" / "train.h5", REPO / "models" / "judge_demos_tcn", None, tmp_path, cfg, n_jobs=1,
           progress=False)
    rows = json.loads(next((tmp_path / "round_1" / "partial").glob("*.json")).read_text())
    sets = round_constraints(PROBLEM, cfg, 1)
    assert rows and all(r["constraints"] == json.loads(json.dumps(sets[r["env_index"]])) for r in rows)
    for r in rows:  # the direct solve held its environment's set
        s = {k: tuple(v) if k == "bounds" else v for k, v in r["constraints"].items()}
        p = PROBLEM.with_overrides(**s)
        plan = Plan.from_array(p.dt, np.array(r["command"]), p.channel_spec)
        assert max(constraint_residuals(p, plan, _env(r["env"])).values()) <= 1e-5
    meta = json.loads((tmp_path / "round_1" / "judge.json").read_text())
    assert meta["train_data"]["constraint_ranges"] == ConstraintRanges().to_dict()
    assert RefineConfig(constraint_ranges=meta["refine_config"]["constraint_ranges"]).constraint_ranges == \
        ConstraintRanges()
