"""A rollout stepped sample by sample is the rollout: the same response and outcome bit for bit,
and a command changed mid-way changes only what comes after."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.tasks import get_task
from judgeopt.trajectory import Plan

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def sim():
    s = get_task("scoop").simulator()
    yield s
    s.close()


def _plan(f: float = 15.0, end: float = 0.19) -> Plan:
    t = np.arange(31) * 0.05
    s = np.clip(t / 1.2, 0, 1)
    y = -0.03 + (end + 0.03) * (10 * s**3 - 15 * s**4 + 6 * s**5)
    v = np.gradient(y, t)
    return get_task("scoop").plan(np.stack([y, v, np.full(31, f)], axis=1))


def test_stepping_in_pieces_is_the_rollout(sim):
    plan = _plan()
    whole = sim.run(plan, 0.19, 2.0)
    run = sim.start(plan, 0.19, 2.0)
    for k in (1, 2, 7, 12, 30):
        run.advance(plan, k)
        assert run.k == k + 1
        np.testing.assert_array_equal(run.measured()[-1], [whole.y[k], whole.ydot[k], whole.f[k]])
    out = run.finish()
    np.testing.assert_array_equal(out.as_array(), whole.as_array())
    assert out.success == whole.success and out.info["object_end"] == whole.info["object_end"]


def test_a_new_command_changes_only_what_follows(sim):
    first, second = _plan(15.0), _plan(8.0)
    a = sim.start(first, 0.19, 2.0)
    a.advance(first, 10)
    a.advance(second, 30)
    ref = sim.run(first, 0.19, 2.0)
    x = a.finish().as_array()
    np.testing.assert_array_equal(x[:11], ref.as_array()[:11])  # measured before the new command took effect
    assert abs(x[20, 2] - 8.0) < 3.0 and abs(ref.f[20] - 15.0) < 3.0  # then the arm presses what it is told
    with pytest.raises(ValueError, match="period and horizon"):
        sim.start(first, 0.19, 2.0).advance(Plan(0.1, first.values[::2], first.channels), 3)


def test_an_execution_in_a_perturbed_world_is_its_replay():
    sim = get_task("scoop").simulator()
    plan = _plan()
    world = {"y_obj_offset": 0.02, "sensor_noise": 0.5, "mu_factor": 1.5}
    sim.perturb(world, seed=3)
    replay = sim.simulate(plan, {"y_obj": 0.19, "mu": 2.0})
    sim.perturb(world, seed=3)
    run = sim.execute(plan, {"y_obj": 0.19, "mu": 2.0})
    run.advance(plan, 12)
    out = run.outcome()
    np.testing.assert_array_equal(out.response, replay.response)
    assert out.success == replay.success
    sim.close()
