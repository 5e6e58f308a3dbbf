"""Constraints beyond the paper's boxes: acceleration, jerk and force-rate limits, and bounds on any
channel over a window of time. Each is linear in the plan, so the direct solve holds it exactly
(a variable bound or a linear row) and an infeasible set is found before any solve, by a linear
program per axis that then names the conflicting pair (`conflict`).

Definitions, on the shared point-mass model (dynamics.py): the acceleration is the piecewise-
constant a_k = (q̇_k - q̇_{k-1}) / dt, k = 1..N; the jerk is its change between steps, (a_{k+1} - a_k) / dt,
k = 1..N-1 (the state before the start and after the end is not the plan's to shape); the force
rate is (f_{k+1} - f_k) / dt, k = 0..N-1. A window bound NAME:LO:HI@T0:T1 holds channel NAME within
[LO, HI] at every sample t_k = k dt with T0 <= t_k <= T1 (sample 0 of a position or velocity is the
given start). Residuals are in the constraint's own units, >= 0, 0 where held.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from judgeopt.errors import UsageError
from judgeopt.trajectory import Channel, Plan

#: a sample lies in a window when within this of its edges (s): 0.4 s is sample 8 at dt = 0.05
TIME_TOL = 1e-9
#: the written form of a window bound
BOUND_FORMAT = "NAME:LO:HI@T0:T1"
_NUMBER = r"[-+]?(?:inf|(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?)"
_BOUND = re.compile(rf"^\s*(?P<name>[A-Za-z_]\w*)\s*:\s*(?P<lo>{_NUMBER})\s*:\s*(?P<hi>{_NUMBER})\s*"
                    rf"(?:@\s*(?P<t0>{_NUMBER})\s*:\s*(?P<t1>{_NUMBER})\s*)?$", re.IGNORECASE)
#: the rate limits: field -> (what it limits, unit per the channel's unit)
RATE_LIMITS = {"a_max": "acceleration", "jerk_max": "jerk", "fdot_max": "force rate"}
#: the residuals of the arm's joint limits (planners/joint_limits.py)
JOINT_KEYS = ("joint_velocity", "joint_torque")


class ConstraintError(UsageError, ValueError):
    """A constraint written wrongly (problem.py turns it into a ProblemError naming the file)."""


@dataclass(frozen=True)
class Bound:
    """Channel `name` within [lo, hi] over t0 <= t <= t1 (t1 None: to the end of the horizon)."""

    name: str
    lo: float
    hi: float
    t0: float = 0.0
    t1: float | None = None

    @classmethod
    def parse(cls, text: str) -> "Bound":
        """From NAME:LO:HI@T0:T1 (the window may be left out: the whole motion; inf for no bound)."""
        m = _BOUND.match(text) if isinstance(text, str) else None
        if m is None:
            raise ConstraintError(f"bound {text!r} must read {BOUND_FORMAT}, e.g. f:0:12@0:0.4 or y:0.05:inf@0.6:1.5 "
                                  "(inf: no bound on that side; the window may be left out)")
        lo, hi = float(m["lo"]), float(m["hi"])
        t0, t1 = (float(m["t0"]), float(m["t1"])) if m["t0"] is not None else (0.0, None)
        return cls(m["name"], lo, hi, t0, t1)

    @property
    def text(self) -> str:
        window = "" if self.t0 == 0.0 and self.t1 is None else f"@{self.t0:g}:{self.t1:g}"
        return f"{self.name}:{self.lo:g}:{self.hi:g}{window}"

    def samples(self, steps: int, dt: float) -> np.ndarray:
        """Indices k of the samples t_k = k dt inside the window."""
        t = np.arange(steps + 1) * dt
        end = t[-1] if self.t1 is None else self.t1
        return np.flatnonzero((t >= self.t0 - TIME_TOL) & (t <= end + TIME_TOL))

    def check(self, channels: Sequence[Channel], steps: int, dt: float) -> None:
        """Raise ConstraintError where the bound cannot mean anything: LO > HI, an unknown
        channel, a window outside the horizon or with no sample in it."""
        names = [c.name for c in channels]
        if self.name not in names:
            raise ConstraintError(f"bound {self.text}: no channel {self.name!r}; the task's channels are "
                                  f"{', '.join(names)}")
        if math.isnan(self.lo) or math.isnan(self.hi) or self.lo > self.hi:
            raise ConstraintError(f"bound {self.text}: LO = {self.lo:g} is above HI = {self.hi:g}; swap them")
        if self.lo == math.inf or self.hi == -math.inf:
            raise ConstraintError(f"bound {self.text}: LO must be below inf and HI above -inf")
        horizon = steps * dt
        end = horizon if self.t1 is None else self.t1
        if not (self.t0 >= -TIME_TOL and end <= horizon + TIME_TOL and math.isfinite(self.t0) and math.isfinite(end)):
            raise ConstraintError(f"bound {self.text}: window [{self.t0:g}, {end:g}] s lies outside the horizon "
                                  f"[0, {horizon:g}] s; give T0:T1 within it")
        if self.t0 > end:
            raise ConstraintError(f"bound {self.text}: window starts at {self.t0:g} s after it ends at {end:g} s; "
                                  "give T0 <= T1")
        if not len(self.samples(steps, dt)):
            raise ConstraintError(f"bound {self.text}: no sample (every {dt:g} s) lies in the window; widen it")


@dataclass(frozen=True)
class Constraints:
    """A problem's [constraints] (path constraints beyond the boxes): rate limits per position axis
    (a_max in m/s², jerk_max in m/s³) or force channel (fdot_max in N/s), one value for all or
    one each; window bounds as BOUND_FORMAT strings; the arm's joint limits scaled by
    joint_limit_scale (None: not held). None: no limit."""

    a_max: float | list[float] | None = None
    jerk_max: float | list[float] | None = None
    fdot_max: float | list[float] | None = None
    bounds: list[str] = field(default_factory=list)
    joint_limit_scale: float | None = None

    def parsed_bounds(self) -> list[Bound]:
        return [Bound.parse(b) for b in self.bounds]

    def is_set(self) -> bool:
        """Whether anything beyond the paper's boxes is asked for."""
        return any(getattr(self, k) is not None for k in (*RATE_LIMITS, "joint_limit_scale")) or bool(self.bounds)


def per_channel(value: float | list[float] | None, count: int, name: str) -> np.ndarray:
    """A rate limit as one value per axis (or force channel); inf where not set."""
    if value is None:
        return np.full(count, np.inf)
    values = list(value) if isinstance(value, (list, tuple)) else [value] * count
    if len(values) != count:
        raise ConstraintError(f"{name} = {value} has {len(values)} values; give one, or one for each of {count}")
    for v in values:
        if isinstance(v, bool) or not isinstance(v, (int, float)) or math.isnan(v) or not v > 0:
            raise ConstraintError(f"{name} = {value!r} must be a positive number (or inf, or left out)")
    return np.array(values, dtype=float)


def validate(c: Constraints, channels: Sequence[Channel], steps: int, dt: float) -> None:
    """Raise ConstraintError for a [constraints] that is malformed; infeasible sets are
    `conflict`'s to find (they depend on the environment's terminal position)."""
    n_axes = sum(ch.kind == "position" for ch in channels)
    n_forces = sum(ch.kind == "force" for ch in channels)
    for name in RATE_LIMITS:
        per_channel(getattr(c, name), n_forces if name == "fdot_max" else n_axes, name)
    if not isinstance(c.bounds, (list, tuple)):
        raise ConstraintError(f"bounds = {c.bounds!r} must be a list of {BOUND_FORMAT} strings")
    for b in c.parsed_bounds():
        b.check(channels, steps, dt)
    s = c.joint_limit_scale
    if s is not None and (isinstance(s, bool) or not isinstance(s, (int, float)) or not (s > 0 and math.isfinite(s))):
        raise ConstraintError(f"joint_limit_scale = {s!r} must be a positive number (1: the arm's own limits; "
                              "0.8: 80 % of them)")


# -- residuals ---------------------------------------------------------------------------
def is_constraint_key(name: str) -> bool:
    """Whether a residual's name is one of [constraints]' (not the paper's boxes or the model)."""
    return name in RATE_LIMITS or name in JOINT_KEYS or name.startswith("bound ")


def rates(plan: Plan) -> dict[str, np.ndarray]:
    """The plan's accelerations (N, axes), jerks (N - 1, axes) and force rates (N, forces)."""
    v, f = (plan.values[:, plan.columns(kind)] for kind in ("velocity", "force"))
    a = np.diff(v, axis=0) / plan.dt
    return {"a_max": a, "jerk_max": np.diff(a, axis=0) / plan.dt, "fdot_max": np.diff(f, axis=0) / plan.dt}


def residuals(c: Constraints, plan: Plan) -> dict[str, float]:
    """Worst violation of each constraint that is set, in its own units (>= 0)."""
    out: dict[str, float] = {}
    for name, values in rates(plan).items():
        limit = getattr(c, name)
        if limit is not None:
            lim = per_channel(limit, values.shape[1], name)
            out[name] = float(max(0.0, np.max(np.abs(values) - lim, initial=0.0)))
    names = [ch.name for ch in plan.channels]
    for b in c.parsed_bounds():
        x = plan.values[b.samples(plan.horizon, plan.dt), names.index(b.name)]
        out[f"bound {b.text}"] = float(max(0.0, np.max(x - b.hi), np.max(b.lo - x)))
    return out


def describe(c: Constraints) -> dict[str, Any]:
    """The constraints that are set, by name (for records: nothing when none is)."""
    return {k: v for k, v in (("a_max", c.a_max), ("jerk_max", c.jerk_max), ("fdot_max", c.fdot_max),
                              ("bounds", list(c.bounds)), ("joint_limit_scale", c.joint_limit_scale)) if v}
