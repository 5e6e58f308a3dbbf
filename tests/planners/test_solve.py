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
