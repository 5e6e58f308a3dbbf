"""Random scrape demonstrations: smooth x-y paths from the start towards the puck and past it,
pressing at one random level with a small smooth variation.

Why a level and not independent random force knots: what decides the outcome is whether the
force dips while the blade is on the puck's slope; with independent knots that is random and
the force's effect hides in the data (measured: success 17 / 14 / 14 % by thirds of the mean
force). With a level, heavy and light pressing both appear throughout a push.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from judgeopt.tasks.scrape.spec import F_RANGE, START, V_MAX, X_RANGE, Y_RANGE
from judgeopt.trajectory import DEFAULT_DT, DEFAULT_HORIZON


@dataclass(frozen=True)
class ScrapeCommandConfig:
    dt: float = DEFAULT_DT
    horizon: int = DEFAULT_HORIZON
    knots: int = 3  # random points between start and end
    aim: float = 0.06  # m: the end's x is x_obj +- aim
    end_y: tuple[float, float] = (0.10, Y_RANGE[1])  # m
    mean_speed: tuple[float, float] = (0.1, 0.3)  # m/s: path length over time to reach the end
    wander: float = 0.015  # m: interior x knots around the straight line
    force_variation: float = 4.0  # N: knots within +- this of the level


def random_command(rng: np.random.Generator, env: Mapping[str, float],
                   cfg: ScrapeCommandConfig = ScrapeCommandConfig()) -> np.ndarray:
    """(horizon + 1, 5) [x, y, xdot, ydot, f], at rest at both ends; redrawn until the peak speed
    is at most V_MAX and the path stays in range. Deterministic given the generator's state."""
    from scipy.interpolate import CubicHermiteSpline, PchipInterpolator  # here: the config alone stays light

    t = np.arange(cfg.horizon + 1) * cfg.dt
    for _ in range(1000):
        x0, y0 = START
        xe = float(np.clip(env["x_obj"] + rng.uniform(-cfg.aim, cfg.aim), *X_RANGE))
        ye = rng.uniform(*cfg.end_y)
        te = float(np.clip(np.hypot(xe - x0, ye - y0) / rng.uniform(*cfg.mean_speed), 0.3, (cfg.horizon - 1) * cfg.dt))
        tk = np.concatenate([[0.0], np.sort(rng.uniform(0.1, 0.9, cfg.knots)) * te, [te]])
        yk = np.concatenate([[y0], np.sort(rng.uniform(y0, ye, cfg.knots)), [ye]])
        xk = np.clip(x0 + (xe - x0) * tk / te + np.concatenate([[0.0], rng.uniform(-cfg.wander, cfg.wander, cfg.knots),
                                                                 [0.0]]), *X_RANGE)
        fk = rng.uniform(*F_RANGE) + rng.uniform(-cfg.force_variation, cfg.force_variation, cfg.knots + 2)
        tc = np.minimum(t, te)
        cols = []
        for pk in (xk, yk):  # monotone slopes inside (no overshoot), at rest at both ends
            slopes = PchipInterpolator(tk, pk).derivative()(tk)
            slopes[0] = slopes[-1] = 0.0
            spline = CubicHermiteSpline(tk, pk, slopes)
            cols.append((spline(tc), np.where(t <= te, spline.derivative()(tc), 0.0)))
        f = np.clip(PchipInterpolator(tk, fk)(tc), *F_RANGE)
        plan = np.stack([cols[0][0], cols[1][0], cols[0][1], cols[1][1], f], axis=1)
        if (np.hypot(plan[:, 2], plan[:, 3]).max() <= V_MAX and X_RANGE[0] <= plan[:, 0].min()
                and plan[:, 0].max() <= X_RANGE[1] and Y_RANGE[0] <= plan[:, 1].min() and plan[:, 1].max() <= Y_RANGE[1]):
            return plan
    raise RuntimeError(f"no random scrape command under {V_MAX} m/s within range in 1000 draws")
