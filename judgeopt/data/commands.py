"""Random scooping commands (paper IV-B): splines through random points in (y, f_z) space.

Each command starts at rest at q0, moves forward through random intermediate positions to a
random end near the object, and stops there; the pressing force follows its own spline
through random levels. The randomness spans what a demonstrator might do: fast or slow,
light or heavy, stopping short of the object or going past it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicHermiteSpline, PchipInterpolator

from judgeopt.trajectory import DEFAULT_DT, DEFAULT_HORIZON, Plan


@dataclass(frozen=True)
class RandomCommandConfig:
    dt: float = DEFAULT_DT
    horizon: int = DEFAULT_HORIZON
    q0: float = -0.03  # start position (m), paper Table 3
    knots: int = 4  # random points between start and end
    motion_time: tuple[float, float] = (0.45, 1.4)  # s, time to reach the end point
    end_offset: tuple[float, float] = (-0.08, 0.08)  # m, end position relative to y_obj
    y_limits: tuple[float, float] = (-0.2, 0.4)  # m, paper Table 3
    force: tuple[float, float] = (0.0, 30.0)  # N


def random_command(rng: np.random.Generator, y_obj: float, cfg: RandomCommandConfig = RandomCommandConfig()) -> Plan:
    t_end = rng.uniform(*cfg.motion_time)
    y_end = float(np.clip(y_obj + rng.uniform(*cfg.end_offset), cfg.q0 + 0.05, cfg.y_limits[1]))
    tk = np.concatenate([[0.0], np.sort(rng.uniform(0.1, 0.9, cfg.knots)) * t_end, [t_end]])
    yk = np.concatenate([[cfg.q0], np.sort(rng.uniform(cfg.q0, y_end, cfg.knots)), [y_end]])
    fk = rng.uniform(*cfg.force, cfg.knots + 2)
    # monotone slopes inside (no overshoot), at rest at both ends
    slopes = PchipInterpolator(tk, yk).derivative()(tk)
    slopes[0] = slopes[-1] = 0.0
    ys = CubicHermiteSpline(tk, yk, slopes)
    fs = PchipInterpolator(tk, fk)
    t = np.arange(cfg.horizon + 1) * cfg.dt
    tc = np.minimum(t, t_end)
    moving = t <= t_end
    return Plan(cfg.dt, ys(tc), np.where(moving, ys.derivative()(tc), 0.0), np.clip(fs(tc), *cfg.force))
