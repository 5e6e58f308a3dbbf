"""One point-mass model for numpy, torch and CasADi: the same step, the same residuals, checked
against the closed form of a constant acceleration."""

from __future__ import annotations

import casadi as cs
import numpy as np
import torch

from judgeopt.planners.dynamics import integrate, step, step_residuals


def test_a_step_is_exact_for_constant_acceleration_in_every_backend():
    q0, v0, a, dt = 0.1, 0.2, 3.0, 0.05
    exact = (q0 + v0 * dt + 0.5 * a * dt**2, v0 + a * dt)
    for cast in (float, np.float64, lambda x: torch.tensor(x, dtype=torch.float64), cs.DM):
        q, v = step(cast(q0), cast(v0), cast(a), dt)
        assert abs(float(q) - exact[0]) < 1e-15 and abs(float(v) - exact[1]) < 1e-15
        dv, dq = step_residuals(cast(q0), cast(v0), q, v, cast(a), dt)
        assert abs(float(dv)) < 1e-15 and abs(float(dq)) < 1e-15


def test_integration_over_a_horizon_is_the_stepped_one():
    acc = np.random.default_rng(0).normal(size=30)
    q, v = integrate(-0.03, 0.0, acc, 0.05)
    qs, vs = [-0.03], [0.0]
    for a in acc:
        qn, vn = step(qs[-1], vs[-1], a, 0.05)
        qs.append(qn)
        vs.append(vn)
    np.testing.assert_allclose(q, qs, atol=1e-12)
    np.testing.assert_allclose(v, vs, atol=1e-12)
