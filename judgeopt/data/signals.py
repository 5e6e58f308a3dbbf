"""One recorded position stream made usable: its noise level, a smoothed position and velocity,
and where the motion starts and ends.

Why: a motion-capture position carries about 1 mm of noise, and its plain derivative is noise
(0.16 m/s RMS at 120 Hz with the tool at rest). A Savitzky-Golay fit whose window is chosen from
the measured noise gives a velocity whose noise is known, and the same fit finds motion onset
and end without triggering on noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: velocity noise the smoothing window aims for (m/s): about 1 % of the scoop's fastest plans
VELOCITY_NOISE = 0.01
#: the longest smoothing window (s): longer would round off a human's accelerations
MAX_WINDOW = 0.25
#: a motion has started (or not yet ended) once the position, smoothed over MAX_WINDOW, is this far from rest (m),
#: or 5 of its noise levels
MOTION_STEP = 0.002  # a tool left alone still creeps by a millimetre or two
#: below this speed (m/s), or 3 velocity noise levels (smoothed over MAX_WINDOW), the tool is taken to be at rest
REST_SPEED = 0.003


@dataclass(frozen=True)
class Smoothed:
    """A position stream on a uniform grid, fitted: what the importer reads velocity and onset from."""

    t: np.ndarray  # uniform times, s
    y: np.ndarray  # smoothed position
    v: np.ndarray  # smoothed velocity
    noise: float  # white-noise level of the raw position (same unit)
    window: float  # Savitzky-Golay window, s
    velocity_noise: float  # what that window leaves of `noise` in the velocity
    raw: np.ndarray  # the position on the uniform grid, unsmoothed (for `motion_span`)


def uniform(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """(t, y) on a uniform grid at the median period (unchanged where already uniform to 1 %)."""
    h = float(np.median(np.diff(t)))
    if np.ptp(np.diff(t)) <= 0.01 * h:
        return t, y, h
    tu = t[0] + np.arange(int(np.floor((t[-1] - t[0]) / h + 1e-9)) + 1) * h
    return tu, np.interp(tu, t, y), h


def noise_level(y: np.ndarray) -> float:
    """Robust white-noise level of a smooth signal: second differences of white noise have
    variance 6 sigma^2, and their median absolute value ignores the few samples where the
    motion itself accelerates."""
    if len(y) < 5:
        return 0.0
    d2 = np.diff(y, 2)
    return float(np.median(np.abs(d2 - np.median(d2))) / 0.6745 / np.sqrt(6.0))


def half_window(noise: float, h: float, n: int, target: float = VELOCITY_NOISE,
                longest: float = MAX_WINDOW) -> int:
    """The smallest half-width m (window 2m + 1 samples) whose local-slope estimate leaves at
    most `target` of velocity noise: sigma_v = sigma / (h sqrt(sum i^2)), sum i^2 = m(m+1)(2m+1)/3;
    at most `longest` s and the stream's length."""
    cap = max(1, min(int(longest / (2 * h)), (n - 1) // 2))
    for m in range(1, cap + 1):
        if noise / (h * np.sqrt(m * (m + 1) * (2 * m + 1) / 3.0)) <= target:
            return m
    return cap


def smooth(t: np.ndarray, y: np.ndarray, target: float = VELOCITY_NOISE) -> Smoothed:
    """Savitzky-Golay (quadratic) fit of a position stream, its window chosen from its noise."""
    tu, yu, h = uniform(t, y)
    sigma = noise_level(yu)
    if len(yu) < 3:
        v = np.full(len(yu), (yu[-1] - yu[0]) / max(tu[-1] - tu[0], h))
        return Smoothed(tu, yu, v, sigma, 0.0, 0.0, yu)
    m = half_window(sigma, h, len(yu), target)
    ys, v = _fit(yu, m, h)
    return Smoothed(tu, ys, v, sigma, (2 * m + 1) * h, float(_slope_noise(sigma, m, h)), yu)


def _fit(y: np.ndarray, m: int, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Quadratic Savitzky-Golay fit over 2m + 1 samples: position and its rate."""
    from scipy.signal import savgol_filter  # deferred: scipy takes a second to import, and the CLI imports this

    w = 2 * m + 1
    order = min(2, w - 1)
    return savgol_filter(y, w, order, mode="interp"), savgol_filter(y, w, order, deriv=1, delta=h, mode="interp")


def _slope_noise(sigma: float, m: int, h: float) -> float:
    return sigma / (h * np.sqrt(m * (m + 1) * (2 * m + 1) / 3.0))


def _detection_window(s: Smoothed) -> tuple[int, float]:
    """Half-width (samples) and period of the longest fit, the one motion is read from."""
    h = float(s.t[1] - s.t[0]) if len(s.t) > 1 else 1.0
    return max(1, min(int(MAX_WINDOW / (2 * h)), (len(s.raw) - 1) // 2)), h


def motion_step(s: Smoothed) -> float:
    """How far from rest the position must be to count as moving: MOTION_STEP, or 5 noise levels
    of the longest fit."""
    m, _ = _detection_window(s)
    return max(MOTION_STEP, 5 * s.noise / np.sqrt(m + 0.5))


def motion_span(s: Smoothed) -> tuple[float, float] | None:
    """(onset, end) of the motion in s, or None when the tool never leaves rest. Read from a fit
    over the longest window (MAX_WINDOW: a human's slow start and slow last correction stand out
    from its lower noise): the first and last samples farther than MOTION_STEP (or 5 noise
    levels of that fit) from the rest at either end, each widened to where the speed drops to
    REST_SPEED (or 3 of its velocity-noise levels)."""
    m, h = _detection_window(s)
    y, v = (s.y, s.v) if len(s.raw) < 3 else _fit(s.raw, m, h)
    step = motion_step(s)
    rest = max(REST_SPEED, 3 * _slope_noise(s.noise, m, h))
    edge = max(1, min(m, len(y) // 4))  # the rest at either end: the fit's edges are its least certain samples
    moving_from_start = np.abs(y - np.median(y[:edge])) > step
    moving_to_end = np.abs(y - np.median(y[-edge:])) > step
    if not moving_from_start.any():
        return None
    i = int(np.argmax(moving_from_start))
    while i > 0 and abs(v[i - 1]) > rest:
        i -= 1
    j = len(y) - 1 - int(np.argmax(moving_to_end[::-1]))
    while j < len(y) - 1 and abs(v[j + 1]) > rest:
        j += 1
    return float(s.t[i]), float(s.t[max(j, i)])
