"""Planners.solve replays its plans in the simulated world, which has what the judge does not read."""

from __future__ import annotations

from judgeopt.files import resolve
from judgeopt.planners.problem import load_problem
from judgeopt.planners.loaded import Planners
from judgeopt.tasks.base import Outcome


class Recorder:
    """Stands in for the simulator: remembers the environment each plan was replayed in."""

    def __init__(self):
        self.envs = []

    def simulate(self, plan, env, record=0):
        self.envs.append(dict(env))
        return Outcome(True, plan.as_array())


def test_plans_of_a_judge_that_reads_y_obj_only_are_replayed_at_the_worlds_friction():
    problem = load_problem(resolve("problems/paper_real.toml")).with_overrides(mu=0.7)
    sim = Recorder()
    results = Planners.load(problem, ("direct",)).solve({"y_obj": 0.246}, simulator=sim)
    assert sim.envs == [{"y_obj": 0.246, "mu": 0.7}] and results[0].simulated_success


def test_planners_in_another_environment_plan_as_planners_loaded_for_it():
    """A new object position needs no new planners: the plans and the suggestions' re-plans under
    relaxed limits (Planners.with_limits from the new environment) equal a load for that problem's."""
    import numpy as np
    import pytest

    from judgeopt.planners.problem import ProblemError
    from judgeopt.session.solve import solve

    base = load_problem(resolve("problems/paper_sim.toml")).with_overrides(f_max=11)
    loaded = Planners.load(base, ("amortized", "direct"))
    moved = base.with_overrides(y_obj=0.21, mu=2.9)
    reused, fresh = solve(loaded.in_environment(moved)), solve(Planners.load(moved, ("amortized", "direct")))
    assert reused.env == fresh.env == {"y_obj": 0.21, "mu": 2.9}
    for a, b in zip(reused.results, fresh.results, strict=True):
        assert np.array_equal(a.plan.values, b.plan.values) and a.predicted_success == b.predicted_success
    assert fresh.suggestions, "f_max 11 at mu 2.9 should be unlikely, and a relaxation should be found"
    assert [(s.limit, s.value) for s in reused.suggestions] == [(s.limit, s.value) for s in fresh.suggestions]
    with pytest.raises(ProblemError, match="more than their environment"):
        loaded.in_environment(base.with_overrides(qdot_max=0.8))
