"""Suggestions over [constraints]: which constraints a user could relax, how far the search may go,
and how a suggestion reads (the search itself re-plans; tests/planners/test_solve.py covers it)."""

from __future__ import annotations

import math

import pytest

from judgeopt.planners.problem import Problem
from judgeopt.planners.result import PlanResult
from judgeopt.session.suggest import RATE_REACH, RATE_RESOLUTION, Suggestion, constraint_relaxations


def test_only_the_constraints_that_are_set_and_finite_are_relaxed_up_to_their_reach():
    p = Problem(a_max=2.0, fdot_max=math.inf, joint_limit_scale=0.8)
    rx = {r.name: r for r in constraint_relaxations(p)}
    assert set(rx) == {"a_max", "joint_limit_scale"}  # jerk_max unset, fdot_max inf: nothing to relax
    a = rx["a_max"]
    assert (a.direction, a.resolution, a.bound, a.unit) == (+1, pytest.approx(RATE_RESOLUTION * 2.0),
                                                            pytest.approx(RATE_REACH * 2.0), "m/s^2")
    j = rx["joint_limit_scale"]
    assert (j.direction, j.bound) == (+1, 1.0)  # never past the arm's own limits


def test_a_scale_at_the_arms_own_limits_and_per_axis_lists_are_not_relaxed():
    assert constraint_relaxations(Problem(joint_limit_scale=1.0, a_max=[2.0])) == ()
    assert constraint_relaxations(Problem()) == ()


def _result(p: float) -> PlanResult:
    r = PlanResult("direct", {}, None, p, "solved", 0.0)
    r.success_probability, r.probability_source = p, "judge"
    return r


def test_a_suggestion_names_what_to_relax_by_how_much_and_what_binds():
    s = Suggestion("joint_limit_scale", 0.93, 0.8, "x the arm's limits", _result(0.9), 0.95, 1.0,
                   "shoulder_pan_joint's velocity binds, at 100% of its scaled limit")
    text = s.text()
    assert text.startswith("likely with joint_limit_scale >= 0.93 x the arm's limits (now 0.8; shoulder_pan_joint")
    assert s.relative_change == pytest.approx(0.13 / 0.8)
    dropped = Suggestion("bound f:0:9", math.nan, math.nan, "", _result(0.7), 0.7, math.nan)
    assert dropped.text().startswith("likely without bound f:0:9: p = 0.70")
    assert dropped.relative_change == math.inf  # after any suggestion that keeps the bound
    assert dropped.to_json()["value"] is None


def test_the_message_where_nothing_helps_lists_every_relaxation_tried():
    from judgeopt.session.suggest import searched

    assert searched(Problem()) == ["f_max", "qdot_max", "f_min"]
    assert searched(Problem(fdot_max=20.0, bounds=["f:0:9"])) == ["f_max", "qdot_max", "f_min", "fdot_max",
                                                                   "without bound f:0:9"]
