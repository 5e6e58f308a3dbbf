"""constraint_residuals and the simulator's range check against figures worked out by hand: a plan
built to miss every limit by a chosen amount, with start and terminal values that differ from each
other (so a residual measured against the wrong field shows), and commands exactly on the
reachable range's ends (accepted) or just beyond (refused)."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.planners.problem import Problem
from judgeopt.planners.result import constraint_residuals
from judgeopt.tasks.scoop import scoop_plan
from judgeopt.tasks.scoop.rollout import check_plan
from judgeopt.trajectory import PlanError

DT = 0.05


def test_every_residual_is_the_amount_it_was_built_to_miss():
    # start at rest at -0.03 m is asked; end at y_obj = 0.2 m moving at 0.1 m/s (not at rest)
    problem = Problem(q0=-0.03, qdot0=0.0, q_end="y_obj", qdot_end=0.1, q_min=-0.2, q_max=0.4, qdot_min=-0.05,
                      qdot_max=1.0, f_min=7.5, f_max=22.5)
    env = {"y_obj": 0.2, "mu": 2.0}
    y = np.linspace(-0.029, 0.204, 31)  # starts 1 mm off, ends 4 mm past the object
    y[10], y[20] = -0.21, 0.43  # 1 cm under q_min, 3 cm over q_max
    v = np.full(31, 0.3)
    # 2 mm/s off at the start; 3 cm/s under q̇_min, 0.2 m/s over q̇_max; 2 cm/s off at the end
    v[0], v[5], v[15], v[-1] = 0.002, -0.08, 1.2, 0.12
    f = np.full(31, 12.0)
    f[3], f[0] = 5.0, 25.0  # 2.5 N under f_min, 2.5 N over f_max (on the first sample)
    r = constraint_residuals(problem, scoop_plan(DT, y, v, f), env)
    trapezoid = np.abs(np.diff(y) - 0.5 * DT * (v[:-1] + v[1:])).max()  # the model's position update, by hand
    expected = {"q_min": 0.01, "q_max": 0.03, "qdot_min": 0.03, "qdot_max": 0.2, "f_min": 2.5, "f_max": 2.5,
                "q_end": 0.004, "qdot_end": 0.02, "start": 0.002, "dynamics": trapezoid}
    assert set(r) == set(expected)
    for k, x in expected.items():
        assert r[k] == pytest.approx(x, abs=1e-12), k


def test_a_plan_within_every_limit_has_no_residual_but_dynamics():
    problem = Problem(qdot_end=0.1)
    y = np.linspace(-0.03, 0.2, 31)
    v = np.full(31, 0.23 / 1.5)
    v[0], v[-1] = 0.0, 0.1
    r = constraint_residuals(problem, scoop_plan(DT, y, v, np.full(31, 7.5)), {"y_obj": 0.2, "mu": 2.0})
    assert all(r[k] == 0.0 for k in r if k != "dynamics"), r  # f exactly at f_min is within


@pytest.mark.parametrize("y_end, f_end, ok", [
    (0.45, 60.0, True), (-0.25, 0.0, True),  # exactly the ends of the reachable range [-0.25, 0.45] m, [0, 60] N
    (0.4501, 30.0, False), (0.2, 60.01, False), (-0.2501, 10.0, False), (0.2, -0.01, False),
])
def test_the_simulators_reachable_range_is_closed(y_end, f_end, ok):
    y = np.linspace(0.0, y_end, 31)
    f = np.full(31, 10.0)
    f[-1] = f_end
    plan = scoop_plan(DT, y, np.gradient(y, DT), f)
    if ok:
        check_plan(plan)
    else:
        with pytest.raises(PlanError, match="reachable range"):
            check_plan(plan)
