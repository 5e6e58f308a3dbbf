"""[constraints] (judgeopt.planners.constraints, the feasibility check in judgeopt.planners.feasible)
against figures that do not come from the code under test: residuals of small hand-made plans
whose violation is worked out by hand, window samples counted by hand (with dt = 0.05's float
rounding), and infeasible sets whose answer is known by construction (rest-to-rest under an
acceleration limit covers at most a T^2 / 4, a force window outside [f_min, f_max], two windows
a force-rate limit cannot join, a window that excludes the given start)."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from judgeopt.planners.constraints import (TIME_TOL, Bound, ConstraintError, Constraints, describe, per_channel,
                                           rates, residuals, validate)
from judgeopt.planners.feasible import check, conflict
from judgeopt.planners.problem import InfeasibleProblemError, Problem
from judgeopt.tasks import get_task
from judgeopt.trajectory import Plan

DT = 0.05
SCOOP = get_task("scoop").channels  # y, ydot, f
SCRAPE = get_task("scrape").channels  # x, y, xdot, ydot, f
N = 30  # the scoop problems' horizon: 1.5 s
ENV = {"y_obj": 0.25, "mu": 2.0}


def scoop(y=None, ydot=None, f=None, n: int = 6) -> Plan:
    """A scoop plan of n + 1 samples, zeros (f: 10 N) where a column is not given."""
    m = next((len(c) for c in (y, ydot, f) if c is not None), n + 1)
    y = np.zeros(m) if y is None else np.asarray(y, float)
    ydot = np.zeros(m) if ydot is None else np.asarray(ydot, float)
    f = np.full(m, 10.0) if f is None else np.asarray(f, float)
    return Plan.from_columns(DT, SCOOP, y, ydot, f)


# -- residuals by hand -------------------------------------------------------------------------
def test_acceleration_residual_is_the_worst_step_change_over_dt_beyond_a_max():
    """q̇ = 0, 0.1, 0.3, 0.3, 0.25 at dt 0.05: accelerations 2, 4, 0, -1 m/s²; a_max 3 is crossed by
    exactly 1 m/s², a_max 4 is met exactly (0), a_max 3.5 by 0.5."""
    plan = scoop(ydot=[0, 0.1, 0.3, 0.3, 0.25])
    np.testing.assert_allclose(rates(plan)["a_max"][:, 0], [2, 4, 0, -1], atol=1e-12)
    assert residuals(Constraints(a_max=3.0), plan)["a_max"] == pytest.approx(1.0, abs=1e-12)
    assert residuals(Constraints(a_max=3.5), plan)["a_max"] == pytest.approx(0.5, abs=1e-12)
    assert residuals(Constraints(a_max=4.0 + 1e-9), plan)["a_max"] == 0.0


def test_a_deceleration_counts_as_much_as_an_acceleration():
    """q̇ = 0.3, 0.3, 0.1: a = 0, -4 m/s²; under a_max 2.5 the braking crosses by 1.5 (|a|, not a)."""
    plan = scoop(ydot=[0.3, 0.3, 0.1])
    assert residuals(Constraints(a_max=2.5), plan)["a_max"] == pytest.approx(1.5, abs=1e-12)


def test_jerk_residual_is_the_change_of_acceleration_over_dt():
    """Accelerations 2, 4, 0, -1 m/s² (as above): jerks 40, -80, -20 m/s³. jerk_max 50 is crossed
    by 30 (the -80), jerk_max 80 by nothing; the jerk has one sample fewer than the acceleration."""
    plan = scoop(ydot=[0, 0.1, 0.3, 0.3, 0.25])
    np.testing.assert_allclose(rates(plan)["jerk_max"][:, 0], [40, -80, -20], atol=1e-9)
    assert residuals(Constraints(jerk_max=50.0), plan)["jerk_max"] == pytest.approx(30.0, abs=1e-9)
    assert residuals(Constraints(jerk_max=80.0 + 1e-7), plan)["jerk_max"] == 0.0


def test_force_rate_residual_is_the_worst_force_step_over_dt():
    """f = 10, 10.5, 12, 11, 11 N: rates 10, 30, -20, 0 N/s. fdot_max 20 is crossed by 10, 25 by 5,
    30 is met exactly."""
    plan = scoop(f=[10, 10.5, 12, 11, 11])
    np.testing.assert_allclose(rates(plan)["fdot_max"][:, 0], [10, 30, -20, 0], atol=1e-9)
    assert residuals(Constraints(fdot_max=20.0), plan)["fdot_max"] == pytest.approx(10.0, abs=1e-9)
    assert residuals(Constraints(fdot_max=25.0), plan)["fdot_max"] == pytest.approx(5.0, abs=1e-9)
    assert residuals(Constraints(fdot_max=30.0 + 1e-9), plan)["fdot_max"] == 0.0


def test_only_the_constraints_that_are_set_have_a_residual():
    """No [constraints]: no entry at all (records of old problems read as before); a rate limit
    held with room to spare: 0, not a negative margin."""
    plan = scoop(ydot=[0, 0.1, 0.2], f=[10, 10.1, 10.2])
    assert residuals(Constraints(), plan) == {}
    out = residuals(Constraints(a_max=100.0, jerk_max=1e6, fdot_max=100.0), plan)
    assert out == {"a_max": 0.0, "jerk_max": 0.0, "fdot_max": 0.0}


def test_window_residual_counts_only_samples_inside_the_window():
    """y:0:0.1@0.1:0.2 covers samples 2, 3, 4 (t = 0.1, 0.15, 0.2). y = 0.13 at sample 2 crosses HI by
    0.03; the 0.5 at samples 1 and 5 (t = 0.05, 0.25) lie outside the window and count for nothing;
    y = -0.02 at sample 4 is 0.02 under LO, less than 0.03."""
    y = [0, 0.5, 0.13, 0.05, -0.02, 0.5, 0.5]
    plan = scoop(y=y)
    out = residuals(Constraints(bounds=["y:0:0.1@0.1:0.2"]), plan)
    assert out == {"bound y:0:0.1@0.1:0.2": pytest.approx(0.03, abs=1e-12)}
    out = residuals(Constraints(bounds=["y:0:0.1@0.15:0.2"]), plan)  # sample 2 left out: the -0.02 is the worst
    assert out["bound y:0:0.1@0.15:0.2"] == pytest.approx(0.02, abs=1e-12)
    held = residuals(Constraints(bounds=["y:-0.02:0.13@0.1:0.2"]), plan)  # exactly at both edges
    assert held["bound y:-0.02:0.13@0.1:0.2"] == 0.0


def test_window_residual_on_a_velocity_and_a_force_channel_includes_sample_0():
    """A bound with no window covers every sample, the first included: q̇_0 = 0.2 against
    ydot:-inf:0.1 is 0.1 over; f_0 = 3 against f:5:inf is 2 under (sample 0 of the force is planned)."""
    plan = scoop(ydot=[0.2, 0, 0, 0], f=[3, 10, 10, 10])
    out = residuals(Constraints(bounds=["ydot:-inf:0.1", "f:5:inf"]), plan)
    assert out == {"bound ydot:-inf:0.1": pytest.approx(0.1, abs=1e-12), "bound f:5:inf": pytest.approx(2.0, abs=1e-12)}


def test_rate_limits_per_axis_on_a_two_axis_task():
    """scrape (x, y): ẋ = 0, 0.1 (a = 2 m/s²), ẏ = 0, 0.2 (a = 4 m/s²). a_max = [3, 3]: only y crosses,
    by 1; a_max = [1, 5]: only x crosses, by 1; one value applies to both axes."""
    z = np.zeros(2)
    plan = Plan.from_columns(DT, SCRAPE, z, z, [0, 0.1], [0, 0.2], [10, 10])
    assert residuals(Constraints(a_max=[3.0, 3.0]), plan)["a_max"] == pytest.approx(1.0)
    assert residuals(Constraints(a_max=[1.0, 5.0]), plan)["a_max"] == pytest.approx(1.0)
    assert residuals(Constraints(a_max=[2.0, 4.0]), plan)["a_max"] == pytest.approx(0.0, abs=1e-12)
    assert residuals(Constraints(a_max=3.5), plan)["a_max"] == pytest.approx(0.5)


# -- Bound.parse ---------------------------------------------------------------------------------
@pytest.mark.parametrize("text, expected", [
    ("f:0:12@0:0.4", Bound("f", 0.0, 12.0, 0.0, 0.4)),
    ("f:0:12", Bound("f", 0.0, 12.0, 0.0, None)),  # no window: the whole motion
    ("y:0.05:inf@0.6:1.5", Bound("y", 0.05, math.inf, 0.6, 1.5)),
    ("y:-inf:0.3", Bound("y", -math.inf, 0.3)),
    ("ydot:-INF:+Inf", Bound("ydot", -math.inf, math.inf)),
    ("  f : 1 : 2 @ 0.1 : 0.2  ", Bound("f", 1.0, 2.0, 0.1, 0.2)),  # spaces around every part
    ("f:.5:1e1@0:1.5", Bound("f", 0.5, 10.0, 0.0, 1.5)),
    ("f:-1.5E-1:+2.:0", None),  # a third number without @: malformed (checked below)
])
def test_bound_parse(text, expected):
    """Each text read by hand: name, LO, HI and window (t1 None: to the end)."""
    if expected is None:
        with pytest.raises(ConstraintError, match="must read NAME:LO:HI@T0:T1"):
            Bound.parse(text)
        return
    assert Bound.parse(text) == expected


@pytest.mark.parametrize("text", ["", "f", "f:0", "f:0:1@0.2", "f:0:1@a:b", "1f:0:1", "f:nan:1", "f:0:1@0:1:2",
                                  "f:0;1", "f 0 1", None, 5, ["f:0:1"]])
def test_a_malformed_bound_names_the_format(text):
    """What is not NAME:LO:HI@T0:T1 (or not text at all) is refused with the format and an example."""
    with pytest.raises(ConstraintError, match=r"must read NAME:LO:HI@T0:T1, e\.g\. f:0:12@0:0\.4"):
        Bound.parse(text)


@pytest.mark.parametrize("text, written", [("f:0:12@0:0.4", "f:0:12@0:0.4"), ("f:0:12", "f:0:12"),
                                           ("y: 0.050 : inf", "y:0.05:inf"), ("f:0:12@0.2:1.5", "f:0:12@0.2:1.5"),
                                           ("y:-inf:0.3@0:0", "y:-inf:0.3@0:0")])
def test_a_bound_is_written_back_as_given(text, written):
    """The name a conflict and a residual give a bound is its text, tidied (%g)."""
    assert Bound.parse(text).text == written


# -- window samples --------------------------------------------------------------------------------
@pytest.mark.parametrize("window, samples", [
    ("0:0.4", list(range(0, 9))),  # 0.4 / 0.05 = 8.000000000000002: sample 8 still counts
    ("0.4:0.4", [8]),
    ("0.15:0.15", [3]),  # 3 * 0.05 = 0.15000000000000002 > 0.15
    ("0.35:0.7", list(range(7, 15))),  # 7 * 0.05 = 0.35000000000000003, 14 * 0.05 = 0.7000000000000001
    ("0.1:0.3", [2, 3, 4, 5, 6]),  # 6 * 0.05 = 0.30000000000000004
    ("1.5:1.5", [30]),  # the last sample alone
    ("0:0", [0]),  # the first alone
    ("0.01:0.09", [1]),
    ("0.051:0.099", []),  # between samples 1 and 2: none (check refuses it)
])
def test_window_samples_at_the_edges(window, samples):
    """Samples t_k = k dt with T0 <= t_k <= T1, counted by hand: a sample exactly on an edge is in,
    even where k * 0.05 rounds a few ulps beyond the edge."""
    b = Bound.parse(f"f:0:1@{window}")
    assert b.samples(N, DT).tolist() == samples


def test_no_window_is_every_sample_and_the_tolerance_is_tiny():
    """No window: samples 0..N. An edge 10 TIME_TOL from a sample leaves it out (the tolerance is
    for rounding, not a margin)."""
    assert Bound.parse("f:0:1").samples(N, DT).tolist() == list(range(N + 1))
    assert Bound("f", 0, 1, 0.4 + 10 * TIME_TOL, 0.5).samples(N, DT).tolist() == [9, 10]
    assert Bound("f", 0, 1, 0.3, 0.4 - 10 * TIME_TOL).samples(N, DT).tolist() == [6, 7]
    assert Bound("f", 0, 1, 0.4 - 0.5 * TIME_TOL, 0.4 + 0.5 * TIME_TOL).samples(N, DT).tolist() == [8]


# -- Bound.check and validate ----------------------------------------------------------------------
@pytest.mark.parametrize("text, says", [
    ("f:12:0", "LO = 12 is above HI = 0; swap them"),
    ("zz:0:1", "no channel 'zz'; the task's channels are y, ydot, f"),
    ("f:0:1@0:1.6", "window [0, 1.6] s lies outside the horizon [0, 1.5] s"),
    ("f:0:1@-0.1:0.5", "lies outside the horizon"),
    ("f:0:1@1.6:1.7", "lies outside the horizon"),
    ("f:0:1@0.4:0.2", "starts at 0.4 s after it ends at 0.2 s; give T0 <= T1"),
    ("f:0:1@0.051:0.099", "no sample (every 0.05 s) lies in the window; widen it"),
    ("f:inf:inf", "LO must be below inf and HI above -inf"),
    ("f:-inf:-inf", "LO must be below inf and HI above -inf"),
    ("f:0:1@0:inf", "lies outside the horizon"),
])
def test_a_bound_that_cannot_mean_anything_says_how_to_fix_it(text, says):
    with pytest.raises(ConstraintError, match=re.escape(says)):
        Bound.parse(text).check(SCOOP, N, DT)


@pytest.mark.parametrize("text", ["f:0:1@0:1.5", "f:0:1@1.5:1.5", "f:3:3", "f:0:1@0:0", "y:-inf:inf",
                                  f"f:0:1@0:{1.5 + 0.5 * TIME_TOL!r}"])
def test_bounds_at_the_edges_of_what_is_allowed_pass(text):
    """The whole horizon, its last or first sample alone, LO = HI, no bound on either side."""
    Bound.parse(text).check(SCOOP, N, DT)


def test_per_channel():
    """One value for every channel, a list one each, None: inf everywhere; the wrong count, zero,
    negative, nan, a bool or text are refused naming the field."""
    np.testing.assert_array_equal(per_channel(None, 2, "a_max"), [np.inf, np.inf])
    np.testing.assert_array_equal(per_channel(2, 3, "a_max"), [2.0, 2.0, 2.0])
    np.testing.assert_array_equal(per_channel([1, 2.5], 2, "a_max"), [1.0, 2.5])
    np.testing.assert_array_equal(per_channel((1, math.inf), 2, "a_max"), [1.0, np.inf])
    assert per_channel(2, 1, "a_max").dtype == float
    with pytest.raises(ConstraintError, match=r"a_max = \[1, 2, 3\] has 3 values; give one, or one for each of 2"):
        per_channel([1, 2, 3], 2, "a_max")
    for bad in (0, 0.0, -1, math.nan, True, "2", [1, 0]):
        with pytest.raises(ConstraintError, match="jerk_max = .* must be a positive number"):
            per_channel(bad, 2, "jerk_max")
    assert per_channel(1e-300, 1, "a_max")[0] == 1e-300


def test_validate_names_each_bad_field():
    """validate: the rate limits per axis (a_max, jerk_max) and per force channel (fdot_max),
    bounds a list, each bound checked, joint_limit_scale positive and finite."""
    ok = Constraints(a_max=1.0, jerk_max=[5.0], fdot_max=20.0, bounds=["f:0:12@0:0.4"], joint_limit_scale=0.8)
    validate(ok, SCOOP, N, DT)
    validate(Constraints(a_max=[1.0, 2.0], fdot_max=[3.0]), SCRAPE, N, DT)
    cases = [(Constraints(a_max=[1.0, 2.0]), "a_max = .* has 2 values"),  # scoop has one axis
             (Constraints(jerk_max=[1.0, 2.0]), "jerk_max = .* has 2 values"),
             (Constraints(fdot_max=[1.0, 2.0]), "fdot_max = .* has 2 values"),  # one force channel
             (Constraints(fdot_max=-1.0), "fdot_max = -1.0 must be a positive number"),
             (Constraints(bounds="f:0:1"), "bounds = 'f:0:1' must be a list of NAME:LO:HI@T0:T1 strings"),
             (Constraints(bounds=["f:1:0"]), "swap them"),
             (Constraints(joint_limit_scale=0.0), "joint_limit_scale = 0.0 must be a positive number"),
             (Constraints(joint_limit_scale=-0.5), "joint_limit_scale = -0.5 must be a positive number"),
             (Constraints(joint_limit_scale=math.inf), "joint_limit_scale = inf must be a positive number"),
             (Constraints(joint_limit_scale=math.nan), "joint_limit_scale = nan must be a positive number"),
             (Constraints(joint_limit_scale=True), "joint_limit_scale = True must be a positive number"),
             (Constraints(joint_limit_scale="1"), "joint_limit_scale = '1' must be a positive number")]
    for c, says in cases:
        with pytest.raises(ConstraintError, match=says):
            validate(c, SCOOP, N, DT)
    validate(Constraints(a_max=[1.0, 2.0]), SCRAPE, N, DT)  # two axes there
    with pytest.raises(ConstraintError, match="fdot_max = .* has 2 values"):
        validate(Constraints(fdot_max=[1.0, 2.0]), SCRAPE, N, DT)


def test_is_set_and_describe():
    """Nothing set: not set, nothing described (records of old problems unchanged); each field
    alone makes the set non-empty and is described by its name."""
    assert not Constraints().is_set() and describe(Constraints()) == {}
    for k, v in (("a_max", 1.0), ("jerk_max", 2.0), ("fdot_max", 3.0), ("joint_limit_scale", 0.5),
                 ("bounds", ["f:0:1"])):
        c = Constraints(**{k: v})
        assert c.is_set(), k
        assert describe(c) == {k: v}
    assert Constraints(bounds=["f:0:1", "y:0:1@0:0.5"]).parsed_bounds() == [Bound("f", 0, 1), Bound("y", 0, 1, 0, 0.5)]


# -- conflict: infeasible sets known by construction -------------------------------------------------
def problem(**kw) -> Problem:
    """The default scoop problem (q0 = -0.03 m at rest, q̇ in [-0.05, 1], f in [7.5, 22.5] N, 30 steps
    of 0.05 s, q_end = y_obj, at rest) with [constraints] fields."""
    return Problem(**kw)


A_MAX = 0.5
#: rest to rest under |a| <= a_max in T = 1.5 s covers at most a_max T^2 / 4 (accelerate half the
#: time, brake the other half; the switch at t = 0.75 s is sample 15, and the trapezoid rule is exact
#: for constant acceleration), peak speed a_max T / 2 = 0.375 m/s, inside q̇_max
REACH = A_MAX * 1.5 ** 2 / 4  # 0.28125 m


@pytest.mark.parametrize("gap", [1e-4, 1e-6])
def test_rest_to_rest_beyond_a_max_T2_over_4_is_infeasible_and_names_the_three(gap):
    """q_end = q0 + a_max T²/4 + gap: infeasible, and the irreducible set is exactly the end position,
    the end velocity (without rest at the end one could go further) and the acceleration limit."""
    env = {"y_obj": -0.03 + REACH + gap, "mu": 2.0}
    pr = problem(a_max=A_MAX)
    assert conflict(pr, env) == ["terminal.q_end", "terminal.qdot_end", f"constraints.a_max = {A_MAX:g}"]
    with pytest.raises(InfeasibleProblemError, match="terminal.q_end and terminal.qdot_end and "
                       r"constraints.a_max = 0.5 cannot all hold") as exc:
        check(pr, env)
    assert exc.value.conflict == ["terminal.q_end", "terminal.qdot_end", "constraints.a_max = 0.5"]


@pytest.mark.parametrize("gap", [1e-4, 1e-6])
def test_rest_to_rest_within_a_max_T2_over_4_is_feasible(gap):
    """The same, gap short of the reach: feasible (None), and check passes."""
    env = {"y_obj": -0.03 + REACH - gap, "mu": 2.0}
    pr = problem(a_max=A_MAX)
    assert conflict(pr, env) is None
    check(pr, env)


def test_rest_from_k_needs_the_reach_in_k_steps():
    """Resting at y_obj from sample k: the motion has k dt seconds, reach a_max (k dt)² / 4. With
    a_max 1 and 0.28 m to go, k = 22 (1.1 s: 0.3025 m) is feasible, k = 21 (1.05 s: 0.2756 m) is
    not; the rest fixes the end state itself, so the pair is the limit and the rest."""
    pr = problem(a_max=1.0)
    env = {"y_obj": 0.25, "mu": 2.0}
    assert conflict(pr, env, rest_from=22) is None
    names = conflict(pr, env, rest_from=21)
    assert names == ["constraints.a_max = 1", "rest from t = 1.05 s"]
    with pytest.raises(InfeasibleProblemError, match=r"rest from t = 1\.05 s"):
        check(pr, env, rest_from=21)
    check(pr, env, rest_from=22)


def test_rest_from_without_any_constraint_runs_the_program_too():
    """No [constraints], rest_from given: the linear program still runs. 0.28 m needs at least 0.28 m /
    1 m/s = 0.28 s plus the trapezoid's half steps: resting from sample 3 (0.15 s) is impossible, from 10
    (0.5 s) possible."""
    pr = problem()
    assert not pr.constraints.is_set()
    with pytest.raises(InfeasibleProblemError, match="rest from t = 0.15 s"):
        check(pr, ENV, rest_from=3)
    check(pr, ENV, rest_from=10)


def test_a_force_window_outside_f_min_f_max_names_the_pair():
    """f in [0, 5] N over 0.5-1 s against f_min = 7.5 N: the box and the window, nothing else."""
    pr = problem(bounds=["f:0:5@0.5:1"])
    assert conflict(pr, ENV) == ["limits.f_min/f_max", "bound f:0:5@0.5:1"]
    with pytest.raises(InfeasibleProblemError, match="limits.f_min/f_max and bound f:0:5@0.5:1 cannot both hold"):
        check(pr, ENV)
    assert conflict(problem(bounds=["f:0:7.5@0.5:1"]), ENV) is None  # touching f_min: feasible


@pytest.mark.parametrize("fdot, feasible", [(19.9, False), (20.1, True), (20.0, True)])
@pytest.mark.parametrize("first, second", [("f:8:10@0:0.5", "f:20:22@1:1.5"), ("f:20:22@0:0.5", "f:8:10@1:1.5")])
def test_two_force_windows_a_force_rate_limit_cannot_join(fdot, feasible, first, second):
    """f <= 10 N up to 0.5 s (sample 10), f >= 20 N from 1 s (sample 20), or the other way round (a
    fall): 10 N in 10 steps of 0.05 s needs 20 N/s either way. Below that, exactly the three are
    named (not the box: both windows lie inside it)."""
    pr = problem(fdot_max=fdot, bounds=[first, second])
    names = conflict(pr, ENV)
    if feasible:
        assert names is None
    else:
        assert names == [f"constraints.fdot_max = {fdot:g}", f"bound {first}", f"bound {second}"]


@pytest.mark.parametrize("bound", ["y:0:0.1@0:0.2", "ydot:0.1:1@0:0.5", "y:0:0.4"])
def test_a_window_excluding_the_start_is_named_alone(bound):
    """y_0 = q0 = -0.03 m and q̇_0 = 0 are given, not planned: a window that covers sample 0 and
    excludes them conflicts with the start state alone, and the message says so. From sample 2 on
    (t = 0.1 s) the window is reachable: y_2 <= -0.03 + 0.05 (0/2 + 1 + 1/2) = 0.045 m."""
    pr = problem(bounds=[bound])
    assert conflict(pr, ENV) == [f"bound {bound}"]
    with pytest.raises(InfeasibleProblemError, match=f"bound {bound} and the start state cannot both hold"):
        check(pr, ENV)
    later = bound.replace("@0:", "@0.1:") if "@" in bound else bound + "@0.1:1.5"
    assert conflict(problem(bounds=[later]), ENV) is None


def test_a_position_window_one_step_after_the_start_is_out_of_reach():
    """y_1 = q0 + dt/2 (q̇_0 + q̇_1) <= -0.03 + 0.025 * 1 = -0.005 m (trapezoid rule, q̇ <= 1): y >= 0 at
    t = 0.05 s conflicts with the velocity limit, y >= -0.005 does not."""
    assert conflict(problem(bounds=["y:0:0.1@0.05:0.05"]), ENV) == ["limits.qdot_min/qdot_max",
                                                                    "bound y:0:0.1@0.05:0.05"]
    assert conflict(problem(bounds=["y:-0.005:0.1@0.05:0.05"]), ENV) is None


def test_a_position_window_against_the_terminal_position():
    """y in [0.3, 0.4] at t = 1.5 s against q_end = y_obj = 0.25: exactly that pair."""
    pr = problem(bounds=["y:0.3:0.4@1.5:1.5"])
    assert conflict(pr, ENV) == ["terminal.q_end", "bound y:0.3:0.4@1.5:1.5"]
    assert conflict(pr, {"y_obj": 0.3, "mu": 2.0}) is None


@pytest.mark.parametrize("bound", ["y:0.45:0.5@1:1.1", "y:0.45:0.5@1.45:1.45", "y:-0.3:-0.25@1.45:1.45"])
def test_a_position_window_beyond_the_position_limits(bound):
    """q in [-0.2, 0.4], the end free, q̇ in [-1, 1] (so speed alone does not exclude the window:
    by 1 s the arm can be 0.9 m away): y in [0.45, 0.5] over 1-1.1 s or at the last-but-one sample,
    or y <= -0.25 there, conflicts with the position box alone."""
    pr = problem(q_end="free", qdot_min=-1.0, bounds=[bound])
    assert conflict(pr, ENV) == ["limits.q_min/q_max", f"bound {bound}"]


@pytest.mark.parametrize("t", ["0.5:0.6", "1.45:1.45", "0.05:0.05"])
def test_a_velocity_window_against_the_velocity_limit(t):
    """q̇ >= 1.2 m/s against q̇_max = 1 m/s, over 0.5-0.6 s, at the last-but-one sample or the first
    planned one: the box on q̇ and the window."""
    assert conflict(problem(bounds=[f"ydot:1.2:2@{t}"]), ENV) == ["limits.qdot_min/qdot_max", f"bound ydot:1.2:2@{t}"]


def test_a_velocity_window_against_the_velocity_limit_over_a_span():
    """q̇ >= 1.2 m/s over 0.5-0.6 s against q̇_max = 1 m/s: the box on q̇ and the window."""
    assert conflict(problem(bounds=["ydot:1.2:2@0.5:0.6"]), ENV) == ["limits.qdot_min/qdot_max",
                                                                    "bound ydot:1.2:2@0.5:0.6"]


@pytest.mark.parametrize("jerk, feasible", [(0.99, False), (1.0, True)])
def test_jerk_limit_too_small_to_arrive(jerk, feasible):
    """Rest to rest under |jerk| <= j, the accelerations at the ends free (the state before the
    start is not the plan's): the farthest plan ramps its acceleration down linearly, a_k = A -
    j dt (k - 1) with A = j dt (N - 1) / 2 (rest at the end). Summed by hand with the trapezoid
    rule it covers 0.2809 m at j = 1 and 0.2781 m at j = 0.99; y_obj - q0 = 0.28 m lies between.
    Infeasible: exactly the end position, the end velocity and the jerk limit."""
    names = conflict(problem(jerk_max=jerk), ENV)
    if feasible:
        assert names is None
    else:
        assert names == ["terminal.q_end", "terminal.qdot_end", "constraints.jerk_max = 0.99"]


def test_an_unbounded_side_and_a_feasible_set_are_none():
    """inf on one side, every limit set loosely: feasible."""
    pr = problem(a_max=5.0, jerk_max=200.0, fdot_max=200.0, bounds=["f:-inf:20@0:0.4", "y:-0.1:inf"])
    assert conflict(pr, ENV) is None
    check(pr, ENV)


def test_a_two_axis_problem_holds_each_axis_to_its_own_limit():
    """scrape, x from 0.3 to 0.4 m and y from 0 to 0 in 1.5 s, rest to rest: x needs a_max >= 0.1 /
    (1.5² / 4) = 0.178 m/s², y needs none. a_max = [0.1, 100]: x's limit and ends are named;
    a_max = [100, 0.001]: feasible (y stays)."""
    from judgeopt.planners.problem import load_problem

    pr = load_problem("problems/scrape.toml").with_overrides(q_end=[0.4, 0.0])
    env = pr.nominal_env()
    assert conflict(pr.with_overrides(a_max=[100.0, 1e-3]), env) is None
    assert conflict(pr.with_overrides(a_max=[0.18, 1e-3]), env) is None
    assert conflict(pr.with_overrides(a_max=[0.1, 100.0]), env) == ["terminal.q_end", "terminal.qdot_end",
                                                                     "constraints.a_max = 0.1"]


# -- corners the hand-made plans above do not reach ---------------------------------------------------
def test_a_window_held_with_room_to_spare_is_0_not_a_negative_margin():
    """y = 0 everywhere inside y:-1:1: residual 0.0 (not -1)."""
    assert residuals(Constraints(bounds=["y:-1:1"]), scoop()) == {"bound y:-1:1": 0.0}


def test_a_one_step_plan_has_no_jerk_and_no_jerk_residual():
    """Two samples: one acceleration, no jerk at all; its residual is 0, not an error."""
    plan = scoop(ydot=[0, 1.0])
    assert rates(plan)["jerk_max"].shape == (0, 1)
    assert residuals(Constraints(jerk_max=1.0, a_max=30.0), plan) == {"jerk_max": 0.0, "a_max": 0.0}


def test_a_rate_limit_with_the_wrong_count_is_named_in_the_residuals_too():
    """a_max for two axes on a one-axis plan: refused naming a_max."""
    with pytest.raises(ConstraintError, match=r"^a_max = \[1.0, 2.0\] has 2 values"):
        residuals(Constraints(a_max=[1.0, 2.0]), scoop())


@pytest.mark.parametrize("lo, hi", [(math.nan, 1.0), (0.0, math.nan), (math.nan, math.nan)])
def test_a_bound_with_nan_is_refused(lo, hi):
    """nan cannot be written (the format has no nan), but a Bound built in code is checked too."""
    with pytest.raises(ConstraintError, match="swap them"):
        Bound("f", lo, hi).check(SCOOP, N, DT)


def test_the_whole_infeasible_message():
    """The message a user reads, word for word (a pair: 'both'; the start state: named as such)."""
    with pytest.raises(InfeasibleProblemError) as exc:
        check(problem(bounds=["f:0:5@0.5:1"]), ENV)
    assert str(exc.value) == ("limits.f_min/f_max and bound f:0:5@0.5:1 cannot both hold (on the "
                              "motion model from the start state); relax one")
    with pytest.raises(InfeasibleProblemError) as exc:
        check(problem(bounds=["y:0:0.4"]), ENV)
    assert str(exc.value) == ("bound y:0:0.4 and the start state cannot both hold (on the motion model "
                              "from the start state); relax one")


def test_a_group_intersects_its_bounds_and_skips_infinite_rows():
    """The linear program's named groups: bounds on one variable keep the tightest side of each
    ([1, 3], [2, 5] and [0, 4]: [2, 3]); a row with an infinite side adds no inequality for it."""
    from judgeopt.planners.feasible import _Group

    g = _Group("g")
    g.bound(0, 1.0, 3.0)
    g.bound(0, 2.0, 5.0)
    g.bound(0, 0.0, 4.0)
    g.bound(1, -np.inf, 4.0)
    assert (g.lo, g.hi) == ({0: 2.0, 1: -np.inf}, {0: 3.0, 1: 4.0})
    g.row({0: 1.0, 2: -2.0}, 3, np.inf, -1.0)  # only the lower side: -x0 + 2 x2 <= 1
    g.row({1: 1.0}, 3, 2.0)  # only the upper side (lo defaults to -inf)
    assert len(g.A) == 2 and g.b == [1.0, 2.0]
    np.testing.assert_array_equal(g.A[0], [-1.0, 0.0, 2.0])
    np.testing.assert_array_equal(g.A[1], [0.0, 1.0, 0.0])
