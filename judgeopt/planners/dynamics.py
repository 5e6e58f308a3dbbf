"""The point-mass model both planners share: piecewise-constant acceleration along each axis.

Per step k = 1..N, with a_k the acceleration over [t_{k-1}, t_k]:
    q̇_k = q̇_{k-1} + a_k dt,    q_k = q_{k-1} + dt (q̇_{k-1} + q̇_k) / 2.
This is exact for constant acceleration, so the sampled (q, q̇) are consistent with the cubic
Hermite interpolation the controller uses (Plan.resample reproduces the quadratic pieces).
`step` and `step_residuals` are written once, with arithmetic only, so the same lines serve
numpy arrays, torch tensors and CasADi expressions: the generator's rollouts (torch and numpy)
integrate with `step`, the direct solve's equality constraints are `step_residuals`, and the
checks below use the same trapezoid, so plans from either planner are directly comparable.
"""

from __future__ import annotations

import numpy as np

from judgeopt.planners.problem import Problem
from judgeopt.trajectory import Plan


def step(q, v, a, dt: float):
    """One step of the model, for numpy, torch or CasADi alike: (q_k, q̇_k) from (q_{k-1}, q̇_{k-1}) and a_k."""
    v_next = v + a * dt
    return q + 0.5 * dt * (v + v_next), v_next


def step_residuals(q0, v0, q1, v1, a, dt: float):
    """How far (q1, v1) is from one step of the model from (q0, v0) with a: velocity, position."""
    return v1 - v0 - a * dt, q1 - q0 - 0.5 * dt * (v0 + v1)


def positions(q0, qdot: np.ndarray, dt: float) -> np.ndarray:
    """Positions at the samples from the velocities at the samples (the trapezoid rule above),
    along the last axis; q0 broadcasts over any leading (batch) axes."""
    qdot = np.asarray(qdot, dtype=float)
    steps = np.cumsum(0.5 * dt * (qdot[..., :-1] + qdot[..., 1:]), axis=-1)
    return q0 + np.concatenate([np.zeros(qdot.shape[:-1] + (1,)), steps], axis=-1)


def integrate(q0: float, qdot0: float, acc: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(q, q̇) at the N + 1 sample times from the N accelerations."""
    acc = np.asarray(acc, dtype=float)
    qdot = qdot0 + np.concatenate([[0.0], np.cumsum(acc) * dt])
    return positions(q0, qdot, dt), qdot


def accelerations(qdot: np.ndarray, dt: float) -> np.ndarray:
    return np.diff(np.asarray(qdot, dtype=float), axis=0) / dt


def dynamics_residual(q: np.ndarray, qdot: np.ndarray, dt: float) -> float:
    """Worst violation of the position update given the velocities (0 for integrated plans)."""
    q, qdot = np.asarray(q, float), np.asarray(qdot, float)
    _, position = step_residuals(q[:-1], qdot[:-1], q[1:], qdot[1:], 0.0, dt)
    return float(np.max(np.abs(position), initial=0.0))


def plan_from_parts(problem: Problem, q: np.ndarray, v: np.ndarray, f: np.ndarray) -> Plan:
    """A plan from (N + 1, axes) positions and velocities and (N + 1, forces) forces, its columns
    in the task's channel order."""
    return Plan.from_array(problem.dt, np.concatenate([q, v, f], axis=1)[:, channel_order(problem)],
                           problem.channel_spec)


def channel_order(problem: Problem) -> list[int]:
    """For each of the task's channels, its column in [positions, velocities, forces]."""
    chans = problem.channel_spec
    pos = [c.name for c in chans if c.kind == "position"]
    forces = [c.name for c in chans if c.kind == "force"]
    return [pos.index(c.name) if c.kind == "position" else len(pos) + pos.index(c.of) if c.kind == "velocity"
            else 2 * len(pos) + forces.index(c.name) for c in chans]
