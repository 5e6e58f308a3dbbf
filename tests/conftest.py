import os

import numpy as np
import pytest

os.environ.setdefault("OMP_NUM_THREADS", "1")


@pytest.fixture(scope="session")
def sim():
    """One simulator for the whole session: building the scene costs a fraction of a second,
    and rollouts are independent of each other (tested)."""
    from judgeopt.tasks.scoop.rollout import Simulator

    s = Simulator()
    yield s
    s.close()


def min_jerk_plan(y0: float, y1: float, t_move: float, force: float, horizon: int = 30, dt: float = 0.05):
    from judgeopt.tasks.scoop import scoop_plan

    t = np.arange(horizon + 1) * dt
    s = np.clip(t / t_move, 0, 1)
    y = y0 + (y1 - y0) * (10 * s**3 - 15 * s**4 + 6 * s**5)
    yd = (y1 - y0) * (30 * s**2 - 60 * s**3 + 30 * s**4) / t_move * (t <= t_move)
    return scoop_plan(dt, y, yd, np.full(horizon + 1, force))
