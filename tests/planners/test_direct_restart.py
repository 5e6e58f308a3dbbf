"""Under [constraints], a cold start the judge likes best may lead the solve nowhere: a case found
on a held-out constraint set (an object near the start under an early force cap), where the task
command the judge scored highest led to p 0.36 and a failed scoop, and the min-jerk guess to
p_target and a success in simulation. The direct solve then gives the min-jerk guess its own solve."""

from __future__ import annotations

import math

import pytest

from judgeopt.files import REPO
from judgeopt.planners.cold_start import cold_start, default_guess
from judgeopt.planners.direct import DirectOptions, DirectPlanner
from judgeopt.planners.problem import Problem

PROBLEM = Problem(judge="models/judge_refined", a_max=4.6, jerk_max=53.9, fdot_max=35.0, bounds=["f:0:12@0:0.45"])
ENV = {"y_obj": 0.10737523430851505, "mu": 2.3412488293872604}


@pytest.fixture(scope="module")
def planners():
    from judgeopt.judge.casadi_fn import build_casadi_judge
    from judgeopt.judge.store import load_judge

    judge = load_judge(REPO / "models" / "judge_refined")[0]
    cj = build_casadi_judge(judge)
    return judge, DirectPlanner(PROBLEM, judge, cj), DirectPlanner(PROBLEM, judge, cj, DirectOptions(repair_guess=True))


def test_the_min_jerk_guess_gets_its_own_solve_where_the_judges_favourite_falls_short(planners):
    judge, direct, from_guess = planners
    target = math.log(PROBLEM.p_target / (1 - PROBLEM.p_target))
    favourite, how = cold_start(PROBLEM, ENV, judge, default_guess(PROBLEM, ENV), target)
    assert how.startswith("best of")  # the judge preferred a task command to the min-jerk guess
    alone = from_guess.solve(ENV, guess=favourite)
    assert alone.predicted_success < PROBLEM.p_target - 0.1  # from it, the solve falls well short
    r = direct.solve(ENV)
    assert r.predicted_success >= PROBLEM.p_target - 1e-3
    assert r.info["warm_start"].startswith("min-jerk guess (from the best of")
    assert max(r.residuals.values()) <= 1e-6  # every constraint held
