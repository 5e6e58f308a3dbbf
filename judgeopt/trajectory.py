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

from judgeopt.errors import BadInput

DEFAULT_DT = 0.05
DEFAULT_HORIZON = 30

#: the scoop's channels (the first task's; datasets and judges made before tasks use them)
CHANNELS = ("y", "ydot", "f")
UNITS = {"y": "m", "ydot": "m/s", "f": "N"}
KINDS = ("position", "velocity", "force")


class PlanError(BadInput, ValueError):
    """A plan of the wrong shape, with non-finite values, or outside what the arm can do."""


@dataclass(frozen=True)
class Channel:
    """One signal of a plan and of a response. A velocity names the position it is the rate of."""

    name: str
    unit: str
    kind: str  # one of KINDS
    of: str | None = None  # for a velocity: its position channel

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise PlanError(f"channel {self.name!r}: kind {self.kind!r} is not one of {KINDS}")
        if (self.kind == "velocity") != (self.of is not None):
            raise PlanError(f"channel {self.name!r}: a velocity names its position (of=...), nothing else does")


@dataclass(frozen=True, eq=False)
class Plan:
    """Commanded signals at t_k = k dt: `values` (N + 1, C), one column per channel (a task's
    positions, their velocities and forces). A column is also an attribute: plan.y, plan.f."""

    dt: float
    values: np.ndarray
    channels: tuple[Channel, ...]

    def __post_init__(self) -> None:
        if not (math.isfinite(self.dt) and self.dt > 0):
            raise PlanError(f"sample period dt = {self.dt!r} must be a positive number of seconds")
        names = [c.name for c in self.channels]
        x = np.asarray(self.values, dtype=float)
        if x.ndim != 2 or x.shape[1] != len(names) or x.shape[0] < 2:
            raise PlanError(f"a plan array must have shape (N + 1 >= 2, {len(names)}) for [{', '.join(names)}], "
                            f"got {x.shape}")
        for j, name in enumerate(names):
            bad = np.flatnonzero(~np.isfinite(x[:, j]))
            if bad.size:
                k = int(bad[0])
                raise PlanError(f"plan channel {name!r} has a non-finite value {x[k, j]!r} at sample {k}")
        x.setflags(write=False)
        object.__setattr__(self, "values", x)
        object.__setattr__(self, "channels", tuple(self.channels))

    def __getattr__(self, name: str) -> np.ndarray:
        if name.startswith("__") or name in ("values", "channels", "dt"):
            raise AttributeError(name)
        for j, c in enumerate(self.channels):
            if c.name == name:
                return self.values[:, j]
        raise AttributeError(f"the plan has no channel {name!r} (it has {', '.join(c.name for c in self.channels)})")

    @classmethod
    def from_columns(cls, dt: float, channels: tuple[Channel, ...], *columns: np.ndarray) -> "Plan":
        """A plan from one 1-D array per channel, in channel order."""
        arrays = [np.asarray(c, dtype=float) for c in columns]
        if len(arrays) != len(channels) or any(a.ndim != 1 for a in arrays):
            raise PlanError(f"give one 1-D array per channel ({', '.join(c.name for c in channels)})")
        lengths = {c.name: len(a) for c, a in zip(channels, arrays)}
        if len(set(lengths.values())) != 1:
            raise PlanError(f"plan channels must have equal length >= 2, got {lengths}")
        return cls(dt, np.stack(arrays, axis=1), channels)

    @classmethod
    def from_array(cls, dt: float, x: np.ndarray, channels: tuple[Channel, ...]) -> "Plan":
        return cls(dt, np.asarray(x, dtype=float), channels)

    @property
    def horizon(self) -> int:
        return len(self.values) - 1

    @property
    def t(self) -> np.ndarray:
        return np.arange(self.horizon + 1) * self.dt

    def as_array(self) -> np.ndarray:
        """(N + 1, C) in channel order (a copy)."""
        return np.array(self.values)

    def columns(self, kind: str) -> list[int]:
        """Column indices of the channels of `kind`; velocities in the order of their positions."""
        if kind == "velocity":
            pos = [c.name for c in self.channels if c.kind == "position"]
            return [next(j for j, c in enumerate(self.channels) if c.of == p) for p in pos]
        return [j for j, c in enumerate(self.channels) if c.kind == kind]

    def resample(self, step: float) -> tuple[np.ndarray, np.ndarray]:
        """(t, values) at a finer step (the controller's 1 ms): cubic Hermite in each position
        through the sampled positions and velocities (so each velocity stays its derivative),
        linear in every other channel."""
        n = int(round(self.horizon * self.dt / step))
        t = np.arange(n + 1) * step
        k = np.minimum((t / self.dt).astype(int), self.horizon - 1)
        s = (t - k * self.dt) / self.dt
        out = np.empty((n + 1, len(self.channels)))
        for j in range(len(self.channels)):  # linear first; positions and velocities replaced below
            out[:, j] = (1 - s) * self.values[k, j] + s * self.values[k + 1, j]
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        dh00, dh10, dh01, dh11 = 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s
        for jp, jv in zip(self.columns("position"), self.columns("velocity")):
            y0, y1 = self.values[k, jp], self.values[k + 1, jp]
            v0, v1 = self.values[k, jv] * self.dt, self.values[k + 1, jv] * self.dt
            out[:, jp] = h00 * y0 + h10 * v0 + h01 * y1 + h11 * v1
            out[:, jv] = (dh00 * y0 + dh10 * v0 + dh01 * y1 + dh11 * v1) / self.dt
        return t, out
