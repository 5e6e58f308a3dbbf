"""The point-mass model both planners share: piecewise-constant acceleration along y.

Per step k = 1..N, with a_k the acceleration over [t_{k-1}, t_k]:
    q̇_k = q̇_{k-1} + a_k dt,    q_k = q_{k-1} + dt (q̇_{k-1} + q̇_k) / 2.
This is exact for constant acceleration, so the sampled (q, q̇) are consistent with the cubic
Hermite interpolation the controller uses (Plan.resample reproduces the quadratic pieces).
The same equations are the direct solve's equality constraints and the generator's
autoregressive integration, so plans from either are directly comparable.
"""

from __future__ import annotations

import numpy as np


def integrate(q0: float, qdot0: float, acc: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(q, q̇) at the N + 1 sample times from the N accelerations."""
    acc = np.asarray(acc, dtype=float)
    qdot = qdot0 + np.concatenate([[0.0], np.cumsum(acc) * dt])
    q = q0 + np.concatenate([[0.0], np.cumsum(0.5 * dt * (qdot[:-1] + qdot[1:]))])
    return q, qdot


def accelerations(qdot: np.ndarray, dt: float) -> np.ndarray:
    return np.diff(np.asarray(qdot, dtype=float)) / dt


def dynamics_residual(q: np.ndarray, qdot: np.ndarray, dt: float) -> float:
    """Worst violation of the position update given the velocities (0 for integrated plans)."""
    q, qdot = np.asarray(q, float), np.asarray(qdot, float)
    return float(np.max(np.abs(np.diff(q) - 0.5 * dt * (qdot[:-1] + qdot[1:])), initial=0.0))
