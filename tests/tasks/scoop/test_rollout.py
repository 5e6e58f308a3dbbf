"""Replaying plans: deterministic, outcomes that depend on the motion, clear errors for bad plans."""

import numpy as np
import pytest

from conftest import min_jerk_plan
from judgeopt.tasks.scoop.rollout import RolloutConfig
from judgeopt.tasks.scoop.scene import EnvironmentRangeError
from judgeopt.tasks.scoop import scoop_plan
from judgeopt.trajectory import PlanError


def test_rollouts_are_deterministic_and_independent(sim):
    a = sim.run(min_jerk_plan(-0.03, 0.19, 0.8, 14.0), 0.19, 1.7)
    sim.run(min_jerk_plan(-0.03, 0.25, 0.5, 25.0), 0.25, 3.0)  # something else in between
    b = sim.run(min_jerk_plan(-0.03, 0.19, 0.8, 14.0), 0.19, 1.7)
    assert np.array_equal(a.as_array(), b.as_array())
    assert a.success == b.success and a.object_rise == b.object_rise


def test_commands_of_any_duration_are_replayed(sim):
    """N·dt need not be the planner's 1.5 s: a 2.2 s command at the controller's 1 ms, and at 50 ms."""
    for dt, horizon in ((1e-3, 2200), (0.05, 44)):
        r = sim.run(min_jerk_plan(-0.1, 0.25, 1.8, 8.0, horizon=horizon, dt=dt), 0.246, 0.5)
        assert r.as_array().shape == (horizon + 1, 3) and abs(r.y[-1] - 0.25) < 0.005 and r.f[-1] > 5.0


def test_responses_follow_the_commands(sim):
    plan = min_jerk_plan(-0.03, 0.19, 1.0, 15.0)
    r = sim.run(plan, 0.28, 2.0)
    assert r.as_array().shape == (plan.horizon + 1, 3)
    assert np.abs(r.y - plan.y).max() < 0.01  # position within 1 cm
    assert np.abs(r.f[5:] - plan.f[5:]).max() < 3.0  # force within 3 N once pressing


def test_outcome_depends_on_how_hard_the_blade_presses(sim):
    """Same path, same environment: a firm press gets under the object, a light one pushes it."""
    firm = sim.run(min_jerk_plan(-0.03, 0.19, 0.9, 22.0), 0.19, 2.0)
    light = sim.run(min_jerk_plan(-0.03, 0.19, 0.9, 5.0), 0.19, 2.0)
    assert firm.success and firm.info["on_blade"] and not firm.info["on_plate"]
    assert firm.object_rise > RolloutConfig().success_rise
    assert not light.success and light.object_shift > 0.03  # pushed ahead


def test_outcome_depends_on_friction(sim):
    """At a medium press, a slippery object is scooped and a sticky one is pushed."""
    plan = min_jerk_plan(-0.03, 0.19, 0.9, 12.0)
    assert sim.run(plan, 0.19, 1.0).success
    assert not sim.run(plan, 0.19, 3.0).success


def test_stopping_short_of_the_object_fails(sim):
    assert not sim.run(min_jerk_plan(-0.03, 0.09, 0.9, 22.0), 0.19, 2.0).success


@pytest.mark.parametrize(
    "make, words",
    [
        (lambda p: scoop_plan(p.dt, p.y, p.ydot, np.where(np.arange(31) == 4, np.nan, p.f)), ["'f'", "non-finite", "4"]),
        (lambda p: scoop_plan(p.dt, p.y, p.ydot[:-1], p.f), ["equal length"]),
        (lambda p: scoop_plan(p.dt, p.y + 0.5, p.ydot, p.f), ["commanded y", "reachable range"]),
        (lambda p: scoop_plan(p.dt, p.y, p.ydot, p.f + 100.0), ["commanded f", "reachable range"]),
        (lambda p: scoop_plan(-1.0, p.y, p.ydot, p.f), ["dt"]),
    ],
)
def test_bad_plans_get_clear_errors(sim, make, words):
    with pytest.raises(PlanError) as err:
        sim.run(make(min_jerk_plan(-0.03, 0.19, 1.0, 10.0)), 0.19, 2.0)
    for w in words:
        assert w in str(err.value)


def test_bad_environment_gets_a_clear_error(sim):
    with pytest.raises(EnvironmentRangeError, match=r"mu = 9.0 is outside .*\[0.01, 5.0\]"):
        sim.run(min_jerk_plan(-0.03, 0.19, 1.0, 10.0), 0.19, 9.0)


def test_plan_resampling_keeps_samples_and_velocity():
    p = min_jerk_plan(-0.03, 0.19, 1.0, 10.0)
    t, x = p.resample(1e-3)
    y, yd, f = x[:, 0], x[:, 1], x[:, 2]
    every = round(p.dt / 1e-3)
    assert np.allclose(y[::every], p.y) and np.allclose(yd[::every], p.ydot) and np.allclose(f[::every], p.f)
    assert np.allclose(np.gradient(y, 1e-3)[5:-5], yd[5:-5], atol=2e-3)
