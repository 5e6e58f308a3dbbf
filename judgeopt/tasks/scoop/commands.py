"""Random scooping commands (paper IV-B): splines through random points in (y, f_z) space.

Each command starts at rest at q0, moves forward through random intermediate positions to a
random end near the object, and stops there; the pressing force follows its own spline
through random levels. The randomness spans what a demonstrator might do: fast or slow,
light or heavy, stopping short of the object or going past it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from judgeopt.tasks.scoop.spec import scoop_plan
from judgeopt.trajectory import DEFAULT_DT, DEFAULT_HORIZON, Plan


@dataclass(frozen=True)
class RandomCommandConfig:
    dt: float = DEFAULT_DT
    horizon: int = DEFAULT_HORIZON
    q0: float = -0.03  # start position (m), paper Table 3
    knots: int = 4  # random points between start and end
    mean_speed: tuple[float, float] = (0.22, 0.7)  # m/s, distance over time to reach the end
    end_offset: tuple[float, float] = (-0.12, 0.10)  # m, end position relative to y_obj
    y_limits: tuple[float, float] = (-0.2, 0.4)  # m, paper Table 3
    force: tuple[float, float] = (0.0, 30.0)  # N
    max_speed: float = 1.5  # m/s: splines whose peak exceeds it are redrawn (a UR5 tool's range)
    # Share of commands whose force stays near one level (uniform in `force`, knots within
    # +-constant_force_spread of it): independent knots rarely stay below 15 N throughout,
    # yet light constant pressing is what a planner under a low f_max must judge.
    constant_force_share: float = 0.0
    constant_force_spread: float = 1.5  # N


def random_command(rng: np.random.Generator, y_obj: float, cfg: RandomCommandConfig = RandomCommandConfig()) -> Plan:
    """One random command for an object at y_obj; deterministic given the generator's state."""
    for _ in range(1000):
        plan = _draw(rng, y_obj, cfg)
        if np.abs(plan.ydot).max() <= cfg.max_speed:
            return plan
    raise RuntimeError(f"no random command under {cfg.max_speed} m/s in 1000 draws: widen mean_speed or max_speed")


def _draw(rng: np.random.Generator, y_obj: float, cfg: RandomCommandConfig) -> Plan:
    from scipy.interpolate import CubicHermiteSpline, PchipInterpolator  # here: the config alone stays light

    y_end = float(np.clip(y_obj + rng.uniform(*cfg.end_offset), cfg.q0 + 0.05, cfg.y_limits[1]))
    t_end = float(np.clip((y_end - cfg.q0) / rng.uniform(*cfg.mean_speed), 0.3, (cfg.horizon - 1) * cfg.dt))
    tk = np.concatenate([[0.0], np.sort(rng.uniform(0.1, 0.9, cfg.knots)) * t_end, [t_end]])
    yk = np.concatenate([[cfg.q0], np.sort(rng.uniform(cfg.q0, y_end, cfg.knots)), [y_end]])
    fk = rng.uniform(*cfg.force, cfg.knots + 2)
    if cfg.constant_force_share > 0 and rng.uniform() < cfg.constant_force_share:  # no draw at share 0: old data reproduce
        level = rng.uniform(*cfg.force)
        fk = np.clip(level + rng.uniform(-cfg.constant_force_spread, cfg.constant_force_spread, fk.size), *cfg.force)
    # monotone slopes inside (no overshoot), at rest at both ends
    slopes = PchipInterpolator(tk, yk).derivative()(tk)
    slopes[0] = slopes[-1] = 0.0
    ys = CubicHermiteSpline(tk, yk, slopes)
    fs = PchipInterpolator(tk, fk)
    t = np.arange(cfg.horizon + 1) * cfg.dt
    tc = np.minimum(t, t_end)
    moving = t <= t_end
    return scoop_plan(cfg.dt, ys(tc), np.where(moving, ys.derivative()(tc), 0.0), np.clip(fs(tc), *cfg.force))
