"""The one trajectory representation every stage shares: samples at the planner's rate.

A plan or a response has N + 1 samples at t_k = k dt, k = 0..N (the start state included).
Default: dt = 0.05 s and N = 30 (a 1.5 s motion). Why: the judge is unrolled over N steps
in CasADi, so its build time and gradient cost grow with N (shared/notes/dependencies.md:
N = 100 costs about 100 s to build and 0.2 s per gradient); 1.5 s leaves room to cover the
longest scoop (0.31 m) under the paper's slowest limit (0.4 m/s) with acceleration and
braking, and 50 ms still resolves the scoop's impact phase for the controller, which
interpolates the plan to 1 ms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

DEFAULT_DT = 0.05
DEFAULT_HORIZON = 30

#: the channels of a plan (commands) and of a response, in this order, with units
CHANNELS = ("y", "ydot", "f")
UNITS = {"y": "m", "ydot": "m/s", "f": "N"}


class PlanError(ValueError):
    """A plan of the wrong shape, with non-finite values, or outside what the arm can do."""


@dataclass(frozen=True)
class Plan:
    """Commanded TCP position y (m), velocity ydot (m/s) and pressing force f (N)."""

    dt: float
    y: np.ndarray
    ydot: np.ndarray
    f: np.ndarray

    def __post_init__(self) -> None:
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise PlanError(f"sample period dt = {self.dt!r} must be a positive number of seconds")
        arrays = {}
        for name in CHANNELS:
            a = np.asarray(getattr(self, name), dtype=float)
            if a.ndim != 1:
                raise PlanError(f"plan channel {name!r} must be 1-D, got shape {a.shape}")
            if not np.all(np.isfinite(a)):
                k = int(np.flatnonzero(~np.isfinite(a))[0])
                raise PlanError(f"plan channel {name!r} has a non-finite value {a[k]!r} at sample {k}")
            arrays[name] = a
            object.__setattr__(self, name, a)
        lengths = {n: len(a) for n, a in arrays.items()}
        if len(set(lengths.values())) != 1 or lengths["y"] < 2:
            raise PlanError(f"plan channels must have equal length >= 2, got {lengths}")

    @property
    def horizon(self) -> int:
        return len(self.y) - 1

    @property
    def t(self) -> np.ndarray:
        return np.arange(self.horizon + 1) * self.dt

    def as_array(self) -> np.ndarray:
        """(N + 1, 3) array of [y, ydot, f]."""
        return np.stack([self.y, self.ydot, self.f], axis=1)

    @classmethod
    def from_array(cls, dt: float, x: np.ndarray) -> "Plan":
        x = np.asarray(x, dtype=float)
        if x.ndim != 2 or x.shape[1] != 3:
            raise PlanError(f"a plan array must have shape (N + 1, 3) for [y, ydot, f], got {x.shape}")
        return cls(dt, x[:, 0], x[:, 1], x[:, 2])

    def resample(self, step: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Commands at a finer step (the controller's 1 ms): cubic Hermite in y through the
        sampled positions and velocities (so ydot stays its derivative), linear in f."""
        n = int(round(self.horizon * self.dt / step))
        t = np.arange(n + 1) * step
        k = np.minimum((t / self.dt).astype(int), self.horizon - 1)
        s = (t - k * self.dt) / self.dt
        y0, y1 = self.y[k], self.y[k + 1]
        v0, v1 = self.ydot[k] * self.dt, self.ydot[k + 1] * self.dt
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        y = h00 * y0 + h10 * v0 + h01 * y1 + h11 * v1
        dh00, dh10, dh01, dh11 = 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s
        ydot = (dh00 * y0 + dh10 * v0 + dh01 * y1 + dh11 * v1) / self.dt
        f = (1 - s) * self.f[k] + s * self.f[k + 1]
        return t, y, ydot, f
