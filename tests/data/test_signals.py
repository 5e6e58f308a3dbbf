"""The position fit the importer derives velocity and motion onset from, against signals whose
noise and motion are known by construction."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.data.signals import VELOCITY_NOISE, motion_span, noise_level, smooth


@pytest.mark.parametrize("sigma", [0.0002, 0.001, 0.003])
def test_the_noise_level_is_measured_through_a_motion(sigma):
    t = np.arange(0, 3, 1 / 120)
    y = 0.2 * np.sin(2 * t) + np.random.default_rng(0).normal(0, sigma, t.size)
    assert noise_level(y) == pytest.approx(sigma, rel=0.1)


def test_the_window_leaves_the_velocity_noise_it_aims_for():
    t = np.arange(0, 4, 1 / 120)
    rng = np.random.default_rng(1)
    residuals = [smooth(t, rng.normal(0, 0.001, t.size)).v for _ in range(20)]  # at rest: all of it is noise
    measured = float(np.std(np.concatenate(residuals)))
    s = smooth(t, rng.normal(0, 0.001, t.size))
    assert measured <= VELOCITY_NOISE * 1.1 and measured == pytest.approx(s.velocity_noise, rel=0.15)
    assert np.std(np.diff(rng.normal(0, 0.001, t.size)) * 120) > 0.15  # a plain derivative: 0.17 m/s


def test_onset_and_end_of_a_noisy_reach():
    t = np.arange(0, 4, 1 / 120)
    s = np.clip((t - 1.0) / 1.5, 0, 1)
    y = -0.1 + 0.35 * (10 * s**3 - 15 * s**4 + 6 * s**5) + np.random.default_rng(2).normal(0, 0.001, t.size)
    onset, end = motion_span(smooth(t, y))
    assert onset == pytest.approx(1.0, abs=0.05) and end == pytest.approx(2.5, abs=0.1)
    assert motion_span(smooth(t, np.random.default_rng(3).normal(0, 0.001, t.size))) is None  # never moves
