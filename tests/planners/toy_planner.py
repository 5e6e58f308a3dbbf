"""A planner of one's own, whole: the min-jerk move to the terminal state, pressing at the
middle force, judged by the problem's judge. With one line,

    register(PlannerSpec("toy", "the min-jerk move", "toy_planner:Straight"))

it is a `judgeopt solve --method` choice, a row of every evaluation and a calibration setting
(tests/planners/test_registry.py)."""

from __future__ import annotations

import time

from judgeopt.planners.base import Planner, PlannerSpec
from judgeopt.planners.cold_start import default_guess
from judgeopt.planners.result import PlanResult, constraint_residuals


class Straight(Planner):
    """Built from the problem and the judge (Planner's own `build`); no judge is asked to plan."""

    method = "toy"

    def solve(self, env, guess=None):
        t0 = time.perf_counter()
        env = self.problem.env_dict(env)
        plan = default_guess(self.problem, env)
        p = float(self.judge.predict_proba(plan.as_array()[None], [[env[k] for k in self.judge.config.env_names]])[0])
        return PlanResult(self.method, env, plan, p, "solved", time.perf_counter() - t0,
                          constraint_residuals(self.problem, plan, env))

    def with_limits(self, problem):
        return Straight(problem, self.judge)


#: what an installed package's entry point names (`[project.entry-points."judgeopt.planners"] toy_installed =
#: "toy_planner:SPEC"`)
SPEC = PlannerSpec("toy_installed", "the min-jerk move, from an installed package", "toy_planner:Straight")
