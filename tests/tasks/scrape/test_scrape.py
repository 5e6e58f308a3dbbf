"""The scrape's physics, as docs/tasks.md states it: deterministic, force and friction decide."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.tasks import get_task
from judgeopt.tasks.scrape import START, Y_RANGE


@pytest.fixture(scope="module")
def scrape():
    task = get_task("scrape")
    sim = task.simulator()
    yield task, sim
    sim.close()


def straight(force: float, x_end: float = 0.27, y_end: float = Y_RANGE[1], t_end: float = 1.0) -> np.ndarray:
    """A minimum-jerk straight push from the start, pressing with a constant force."""
    t = np.arange(31) * 0.05
    s = np.clip(t / t_end, 0, 1)
    pos, vel = 10 * s**3 - 15 * s**4 + 6 * s**5, (30 * s**2 - 60 * s**3 + 30 * s**4) / t_end * (t <= t_end)
    return np.stack([START[0] + (x_end - START[0]) * pos, START[1] + (y_end - START[1]) * pos,
                     (x_end - START[0]) * vel, (y_end - START[1]) * vel, np.full_like(t, force)], axis=1)


def test_rollouts_are_deterministic_and_measure_every_channel(scrape):
    task, sim = scrape
    env = {"x_obj": 0.27, "y_obj": 0.13, "mu": 0.45}
    a, b = sim.simulate(straight(20.0), env), sim.simulate(straight(20.0), env)
    assert a.success == b.success and np.array_equal(a.response, b.response)
    assert a.response.shape == (31, 5) and abs(a.response[-1, 1] - Y_RANGE[1]) < 0.01


@pytest.mark.slow
def test_pressing_force_and_friction_decide(scrape):
    task, sim = scrape
    low, high = ({"x_obj": 0.27, "y_obj": 0.13, "mu": mu} for mu in (0.3, 0.6))
    assert not sim.simulate(straight(2.0), low).success  # too light: the blade rides over the puck
    assert sim.simulate(straight(12.0), low).success
    assert not sim.simulate(straight(12.0), high).success  # more friction needs more force
    assert sim.simulate(straight(25.0), high).success
    assert not sim.simulate(straight(25.0, x_end=0.40), {**high, "x_obj": 0.20}).success  # the blade misses it


def test_random_demonstrations_stay_within_the_demonstrated_ranges(scrape):
    task, _ = scrape
    rng = np.random.default_rng(0)
    demo = task.demonstrated()
    for _ in range(20):
        x = task.random_command(rng, {"x_obj": 0.3, "y_obj": 0.12, "mu": 0.4})
        assert np.hypot(x[:, 2], x[:, 3]).max() <= demo["xdot"][1] + 1e-9
        for j, c in enumerate(task.channel_names):
            assert demo[c][0] - 1e-9 <= x[:, j].min() and x[:, j].max() <= demo[c][1] + 1e-9
