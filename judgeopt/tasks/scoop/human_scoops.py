"""Human-like scoops: what a person with a force-sensing spatula does (paper V-B), as a command
the scoop's simulator replays.

A reach is not a spline through random points: people move in smooth, bell-shaped strokes and
correct with a second, overlapping one. Each scoop here is two minimum-jerk submovements (a
primary stroke to near the object, a correction that ends somewhere around it or beyond), from
rest to rest, lasting 0.9-2.2 s; the pressing force rises from nothing after the onset, wobbles
slowly around a peak of up to ~14 N (paper Fig. 13), and is let go as the stroke ends, when the
person lifts the spatula. The command is sampled at the controller's 1 ms, so a recording can
be made of every millisecond of the response.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from judgeopt.tasks.scoop.spec import scoop_plan
from judgeopt.trajectory import Plan

#: the controller's period (s): commands are sampled at it
STEP = 1e-3


@dataclass(frozen=True)
class HumanScoopConfig:
    """Ranges every scoop draws its parameters from, uniformly."""

    start: tuple[float, float] = (-0.115, -0.085)  # m: where the stroke starts (Table 8: q0 = -0.1)
    end_offset: tuple[float, float] = (-0.08, 0.07)  # m: where it ends, from y_obj (short of it, or on past it)
    duration: tuple[float, float] = (0.9, 2.2)  # s: the stroke, rest to rest
    primary_share: tuple[float, float] = (0.7, 0.9)  # of the duration: the primary stroke
    correction_share: tuple[float, float] = (0.3, 0.5)  # of the duration: the correction, ending with the stroke
    correction: tuple[float, float] = (-0.02, 0.05)  # m: the distance the correction adds
    peak_force: tuple[float, float] = (1.5, 14.0)  # N
    rise_share: tuple[float, float] = (0.15, 0.4)  # of the duration: force from 0 to its level
    release_share: tuple[float, float] = (0.1, 0.25)  # of the duration: force back to 0 at the end
    wobble: float = 0.2  # the force's slow variation around its level, +- this share


@dataclass(frozen=True)
class HumanScoop:
    """One drawn scoop: its parameters, enough to make the command again."""

    start: float
    end: float
    duration: float
    primary: float  # s
    correction_time: float  # s
    correction: float  # m
    peak_force: float
    rise: float  # s
    release: float  # s
    wobble: tuple[float, float, float]  # force level factors at 1/4, 1/2, 3/4 of the stroke


def draw_scoop(rng: np.random.Generator, y_obj: float, cfg: HumanScoopConfig = HumanScoopConfig()) -> HumanScoop:
    """One scoop's parameters for an object at y_obj; deterministic given the generator's state."""
    u = lambda r: float(rng.uniform(*r))  # noqa: E731 (one draw per range, in this order)
    start, end, duration = u(cfg.start), y_obj + u(cfg.end_offset), round(u(cfg.duration) / STEP) * STEP  # whole ms
    primary, correction_time, correction = duration * u(cfg.primary_share), duration * u(cfg.correction_share), \
        u(cfg.correction)
    peak, rise, release = u(cfg.peak_force), duration * u(cfg.rise_share), duration * u(cfg.release_share)
    wobble = tuple(float(w) for w in 1.0 + rng.uniform(-cfg.wobble, cfg.wobble, 3))
    return HumanScoop(start, end, duration, primary, correction_time, correction, peak, rise, release, wobble)


def _min_jerk(t: np.ndarray, t0: float, length: float) -> tuple[np.ndarray, np.ndarray]:
    """The minimum-jerk profile from 0 to 1 over [t0, t0 + length], and its rate."""
    s = np.clip((t - t0) / length, 0.0, 1.0)
    return 10 * s**3 - 15 * s**4 + 6 * s**5, (30 * s**2 - 60 * s**3 + 30 * s**4) / length


def scoop_command(s: HumanScoop, step: float = STEP) -> Plan:
    """The scoop as a command at `step`: position and velocity of the two strokes, the force."""
    from scipy.interpolate import PchipInterpolator  # here: drawing stays light

    n = int(round(s.duration / step))
    t = np.arange(n + 1) * step
    end = t[-1]  # the stroke's duration in whole steps: it ends at rest at its last sample
    p1, v1 = _min_jerk(t, 0.0, s.primary)
    p2, v2 = _min_jerk(t, end - s.correction_time, s.correction_time)
    travel = s.end - s.start - s.correction
    y = s.start + travel * p1 + s.correction * p2
    ydot = travel * v1 + s.correction * v2
    up, _ = _min_jerk(t, 0.0, s.rise)
    down, _ = _min_jerk(t, end - s.release, s.release)
    level = PchipInterpolator(np.linspace(0.0, end, 5), [1.0, *s.wobble, 1.0])(t)
    f = s.peak_force * up * (1.0 - down) * level / max(s.wobble + (1.0,))
    return scoop_plan(step, y, ydot, np.maximum(f, 0.0))  # 1 - down is -1e-16 where rounding puts down above 1
