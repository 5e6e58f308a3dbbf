"""A planner of one's own, whole: the min-jerk move to the terminal state, pressing at the
middle force, judged by the problem's judge. With one line,

    register(PlannerSpec("toy", "the min-jerk move", "toy_planner:Straight"))

it is a `judgeopt solve --method` choice, a row of every evaluation and a calibration setting
(tests/planners/test_registry.py)."""

from __future__ import annotations

import time

from judgeopt.planners.base import Planner, PlannerSpec
from judgeopt.planners.toolkit import min_jerk_plan, plan_result


class Straight(Planner):
    """Built from the problem and the judge (Planner's own `build`); no judge is asked to plan."""

    method = "toy"

    def solve(self, env, guess=None):
        started = time.perf_counter()
        return plan_result(self, env, min_jerk_plan(self.problem, env), started)

    def with_limits(self, problem):
        return Straight(problem, self.judge)


#: what an installed package's entry point names (`[project.entry-points."judgeopt.planners"] toy_installed =
#: "toy_planner:SPEC"`)
SPEC = PlannerSpec("toy_installed", "the min-jerk move, from an installed package", "toy_planner:Straight")
