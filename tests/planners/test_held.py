"""The generator's plan held to every limit (planners/held.py): the nearest plan that holds them.

With a judge indifferent to the plan, the projection's answers are known by construction: a plan
that holds every limit is its own nearest; the force channel is coupled to nothing but its bounds
(no force-rate limit set), so the nearest force profile to one that crosses f_max is the crossing one
clipped to f_max; and a plan that misses its terminal position ends on it after the projection,
with its motion moved no further than the miss. The real judge's case checks the registry's path:
`held` is warm-started from the generator's plan, keeps most of it, and holds every limit."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.files import REPO
from judgeopt.planners.direct import DirectPlanner
from judgeopt.planners.held import HeldPlanner, projection_problem
from judgeopt.planners.problem import Problem
from judgeopt.planners.toolkit import min_jerk_plan, plan_from_velocities
from judgeopt.verdict.rules import breaks

ENV = {"y_obj": 0.2, "mu": 2.0}
BASE = Problem(judge="models/judge_demos_tcn")  # paper_sim's limits: f in [7.5, 22.5] N, q̇ up to 1 m/s


@pytest.fixture(scope="module")
def judge():
    from judgeopt.judge.store import load_judge

    return load_judge(REPO / "models" / "judge_demos_tcn")[0]


@pytest.fixture(scope="module")
def held(judge, indifferent):
    """HeldPlanner over a judge whose logit is 5 whatever the plan: the pure projection."""
    return HeldPlanner(BASE, DirectPlanner(projection_problem(BASE), judge, indifferent))


def channels(plan):
    return plan.values[:, 0], plan.values[:, 1], plan.values[:, 2]


def test_a_plan_that_holds_every_limit_is_its_own_nearest(held):
    """The min-jerk move ends 3e-7 m short of y_obj (its velocity is sampled); held once, it holds every
    limit to rounding, and held again it does not move (to Ipopt's tolerance, 1e-5 in m, m/s and N)."""
    once = held.solve(ENV, guess=min_jerk_plan(BASE, ENV))
    assert once.status == "solved" and once.method == "held" and once.max_constraint_violation < 1e-9
    twice = held.solve(ENV, guess=once.plan)
    assert np.abs(twice.plan.values - once.plan.values).max() < 1e-5
    assert "the generator's plan, held" in twice.message


def test_a_force_over_its_limit_is_clipped_to_it(held):
    """Force samples 10-19 at 25 N, 2.5 N over f_max: the nearest plan presses at 22.5 N there and
    leaves the motion and the other forces as they were."""
    plan = min_jerk_plan(BASE, ENV)
    f = np.full(31, 15.0)
    f[10:20] = 25.0
    over = plan_from_velocities(BASE, plan.values[:, 1], f)
    r = held.solve(ENV, guess=over)
    y, ydot, force = channels(r.plan)
    assert np.abs(force - np.clip(f, 7.5, 22.5)).max() < 1e-3  # Ipopt stops 2e-4 N inside the bound
    assert np.abs(y - plan.values[:, 0]).max() < 1e-5 and np.abs(ydot - plan.values[:, 1]).max() < 1e-5
    assert r.max_constraint_violation <= 1e-6


def test_a_missed_end_is_reached_and_the_motion_moves_no_further_than_the_miss(held):
    """The min-jerk move with its velocity scaled by 1.02 overshoots y_obj by 2 % of the way
    (4.6 mm, beyond the 1 mm a plan may break a limit by); held, it ends at y_obj, at rest, and no
    sample moved by more than the overshoot."""
    plan = min_jerk_plan(BASE, ENV)
    fast = plan_from_velocities(BASE, 1.02 * plan.values[:, 1], plan.values[:, 2])
    miss = fast.values[-1, 0] - ENV["y_obj"]
    assert miss > 4e-3
    r = held.solve(ENV, guess=fast)
    y, ydot, _ = channels(r.plan)
    assert abs(y[-1] - ENV["y_obj"]) < 1e-6 and abs(ydot[-1]) < 1e-6
    assert np.abs(y - fast.values[:, 0]).max() <= miss + 1e-6
    assert r.max_constraint_violation <= 1e-6


def test_without_a_warm_start_the_min_jerk_motion_is_held(held):
    r = held.solve(ENV)
    assert np.abs(r.plan.values - min_jerk_plan(BASE, ENV).values).max() < 1e-5  # its 3e-7 m miss, closed
    assert "no warm start" in r.message


@pytest.mark.slow
def test_held_from_the_registry_holds_the_generators_plan_to_its_limits():
    """`--method held` on the edge band's setting where the generator's plan misses its end by 2.9 mm:
    the held plan holds every limit and keeps the generator's motion to within a few millimetres."""
    from judgeopt import api

    report = api.solve(methods=["amortized", "held"], simulate=False, suggest=False, qdot_max=0.6, f_max=13.0,
                       y_obj=0.22, mu=2.2)
    gen, r = (next(x for x in report.results if x.method == m) for m in ("amortized", "held"))
    assert gen.residuals["q_end"] > 1e-3
    assert r.max_constraint_violation <= 1e-6
    y0, y1 = gen.plan.values[:, 0], r.plan.values[:, 0]
    assert np.abs(y1 - y0).max() <= gen.residuals["q_end"] + 1e-6


def test_a_p_min_out_of_reach_is_a_broken_limit(judge, held):
    """p_min stays hard in the projection: with the judge at p = sigmoid(5) = 0.9933 for every plan,
    p_min 0.999 cannot be met, and the held plan reports it broken by the difference."""
    problem = BASE.with_overrides(p_min=0.999)
    d = held.direct
    strict = HeldPlanner(problem, DirectPlanner(projection_problem(problem), d.judge, d.cjudge))
    r = strict.solve(ENV, guess=min_jerk_plan(BASE, ENV))
    expected = 0.999 - 1.0 / (1.0 + np.exp(-5.0))
    assert r.residuals["p_min"] == pytest.approx(expected, abs=1e-9)
    assert breaks(r.max_constraint_violation)  # the verdict: "breaks a hard limit", whatever its p
