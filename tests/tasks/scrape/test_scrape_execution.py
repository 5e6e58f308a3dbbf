"""The scrape stepped sample by sample is its replay, bit for bit, in the nominal and in a
perturbed world; the force measured so far is averaged over the steps taken."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.tasks import get_task

pytestmark = pytest.mark.slow
ENV = {"x_obj": 0.3, "y_obj": 0.12, "mu": 0.4}


def _plan():
    task = get_task("scrape")
    return task.plan(task.random_command(np.random.default_rng(3), ENV))


@pytest.mark.parametrize("world", [{}, {"x_obj_offset": 0.01, "sensor_noise": 0.5}])
def test_stepping_in_pieces_is_the_replay(world):
    sim = get_task("scrape").simulator()
    plan = _plan()
    sim.perturb(world, seed=2)
    replay = sim.simulate(plan, ENV)
    sim.perturb(world, seed=2)
    run = sim.execute(plan, ENV)
    for k in (3, 9, 20):
        run.advance(plan, k)
        m = run.measured()
        assert len(m) == k + 1
        np.testing.assert_array_equal(m[:, :4], replay.response[:k + 1, :4])
        np.testing.assert_array_equal(m[:-1, 4], replay.response[:k, 4])  # the last sample's window is not complete
    out = run.outcome()
    np.testing.assert_array_equal(out.response, replay.response)
    assert out.success == replay.success and out.details["puck_end"] == replay.details["puck_end"]
    sim.close()
