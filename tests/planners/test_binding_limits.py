"""The direct solve's limits where they BIND: each case is built so the plan the solve would make
without the limit crosses it, so the plan must end exactly on it (within Ipopt's interior-point
margin) and never beyond. The judge here is indifferent (a constant logit above the target), so
the solve's answer is the warm start's nearest plan within the limits, known by construction:
a guess pressing 4 N under f_min = 10 N must come back pressing 10 N, one at 0.875 m/s under
q̇_max = 0.4 m/s must touch 0.4 m/s, and so on. The limit set in each case is the problem's field
checked against the plan's own values, not against the solve's residuals."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import min_jerk_plan
from judgeopt.files import REPO
from judgeopt.planners.direct import DirectPlanner
from judgeopt.planners.problem import InfeasibleProblemError, Problem
from judgeopt.tasks.scoop import scoop_plan

ENV = {"y_obj": 0.25, "mu": 2.0}
BASE = Problem(judge="models/judge_demos_tcn")  # q in [-0.2, 0.4], q̇ in [-0.05, 1.0], f in [7.5, 22.5], p_target 0.98
#: how close "touches" is: Ipopt's barrier keeps an interior point this near its bound (mu_init 1e-5)
TOUCH = 1e-3
#: how far beyond a bound a plan may end: none (Ipopt projects its last point into the bounds)
CROSS = 1e-9


@pytest.fixture(scope="module")
def judge():
    from judgeopt.judge.store import load_judge

    return load_judge(REPO / "models" / "judge_demos_tcn")[0]


@pytest.fixture(scope="module")
def planner(judge, indifferent):
    return DirectPlanner(BASE, judge, indifferent)


def solve(planner, problem, guess):
    """Through with_limits where only limits change (the shipped re-planning path), else a fresh build."""
    if problem.q_end == BASE.q_end:
        p = planner.with_limits(problem)
    else:
        p = DirectPlanner(problem, planner.judge, planner.cjudge)
    r = p.solve(ENV, guess=guess)
    assert r.status == "solved", r.message
    return r.plan


def backwards_first(y_back: float = 0.05) -> object:
    """A min-jerk scoop that first dips y_back m behind its start (at up to about 0.25 m/s backwards)."""
    g = min_jerk_plan(-0.03, 0.25, 1.2, 12.0)
    y = g.y.copy()
    y[1:8] -= y_back * np.sin(np.linspace(0, np.pi, 7))
    return scoop_plan(0.05, y, np.gradient(y, 0.05), g.f)


@pytest.mark.parametrize("case", ["f_min", "f_max", "qdot_max", "qdot_min", "q_min", "q_max"])
def test_each_limit_binds_and_is_never_crossed(planner, case):
    if case == "f_min":  # pressing 4 N: below the floor of 10 N
        problem, guess = BASE.with_overrides(f_min=10.0), min_jerk_plan(-0.03, 0.25, 1.2, 4.0)
        values, bound, side = lambda p: p.f, 10.0, -1
    elif case == "f_max":  # pressing 30 N: above the ceiling of 20 N
        problem, guess = BASE.with_overrides(f_max=20.0), min_jerk_plan(-0.03, 0.25, 1.2, 30.0)
        values, bound, side = lambda p: p.f, 20.0, 1
    elif case == "qdot_max":  # 0.28 m in 0.6 s: a peak of 0.875 m/s under a limit of 0.4
        problem, guess = BASE.with_overrides(qdot_max=0.4), min_jerk_plan(-0.03, 0.25, 0.6, 12.0)
        values, bound, side = lambda p: p.ydot, 0.4, 1
    elif case == "qdot_min":  # backing up at about 0.25 m/s under a limit of -0.05 m/s
        problem, guess = BASE.with_overrides(qdot_min=-0.05), backwards_first()
        values, bound, side = lambda p: p.ydot, -0.05, -1
    elif case == "q_min":  # backing up to -0.08 m, behind a limit of -0.05 m
        problem, guess = BASE.with_overrides(qdot_min=-0.5, q_min=-0.05), backwards_first()
        values, bound, side = lambda p: p.y, -0.05, -1
    else:  # to 0.36 m with a free end, beyond a limit of 0.30 m
        problem, guess = BASE.with_overrides(q_end="free", q_max=0.3), min_jerk_plan(-0.03, 0.36, 1.2, 12.0)
        values, bound, side = lambda p: p.y, 0.3, 1
    guess_values = values(guess)
    assert side * (guess_values.max() if side > 0 else guess_values.min()) > side * bound + 0.01  # it would cross
    plan = solve(planner, problem, guess)
    v = values(plan)
    extreme = v.max() if side > 0 else v.min()
    assert side * (extreme - bound) <= CROSS, (case, extreme)  # never beyond
    assert abs(extreme - bound) <= TOUCH * max(1.0, abs(bound)), (case, extreme)  # on it


@pytest.mark.parametrize("qdot_end", [0.0, 0.05])
def test_the_terminal_state_is_met_exactly_from_a_guess_that_stops_short(planner, qdot_end):
    """The guess ends at rest at 0.20 m; q_end = y_obj = 0.25 m and q̇_end (at rest, or still
    moving at 5 cm/s: not the start's velocity) are equalities."""
    problem = BASE.with_overrides(qdot_end=qdot_end)
    plan = DirectPlanner(problem, planner.judge, planner.cjudge).solve(
        ENV, guess=min_jerk_plan(-0.03, 0.20, 1.2, 12.0)).plan
    assert plan.y[-1] == pytest.approx(0.25, abs=1e-9) and plan.ydot[-1] == pytest.approx(qdot_end, abs=1e-9)
    assert plan.y[0] == -0.03 and plan.ydot[0] == 0.0  # the start is the problem's


def test_a_guess_within_every_limit_is_kept(planner):
    """The counter-check: where no limit binds the solve has no reason to move the guess."""
    guess = min_jerk_plan(-0.03, 0.25, 1.2, 12.0)
    plan = solve(planner, BASE, guess)
    span = np.array([0.6, 1.05, 15.0])  # each channel's allowed range: q, q̇, f
    assert np.all(np.abs(plan.as_array() - guess.as_array()).max(0) <= 0.01 * span)
    assert np.abs(plan.f - 12.0).max() < 1e-3


def test_the_reach_is_the_trapezoid_rule_at_the_velocity_limit(planner):
    """With q̇ <= 0.2 m/s over 30 steps of 50 ms, starting and ending at rest, the trapezoid rule
    (dynamics.py) reaches at most 29 * 0.05 * 0.2 = 0.29 m: from -0.03 m, y_obj = 0.26 m. The
    solve gets there with every inner velocity at the limit; 2 mm further is refused as out of reach."""
    problem = BASE.with_overrides(qdot_max=0.2)
    lo, hi = problem.reachable_range()
    assert hi == pytest.approx(-0.03 + 29 * 0.05 * 0.2, abs=1e-12)
    assert lo == pytest.approx(-0.03 - 29 * 0.05 * 0.05, abs=1e-12)
    p = planner.with_limits(problem)
    r = p.solve({"y_obj": 0.26, "mu": 2.0}, guess=min_jerk_plan(-0.03, 0.26, 1.2, 12.0))
    assert r.status == "solved" and r.plan.y[-1] == pytest.approx(0.26, abs=1e-9)
    assert np.all(np.abs(r.plan.ydot[1:-1] - 0.2) < 1e-5) and r.plan.ydot.max() <= 0.2 + CROSS
    with pytest.raises(InfeasibleProblemError, match="out of reach"):
        problem.check_feasible({"y_obj": 0.262, "mu": 2.0})
