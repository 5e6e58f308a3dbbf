"""scripts/band_ranking.py counts, by construction, the successes a threshold could call likely before it
admits a failure."""

from __future__ import annotations

import importlib.util

import numpy as np

from judgeopt.files import REPO


def _script():
    spec = importlib.util.spec_from_file_location("band_ranking", REPO / "scripts" / "band_ranking.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_successes_are_counted_above_each_failure_and_a_tie_counts_against_the_score():
    ranked = _script().ranked_successes
    y = np.array([True, True, False, True, False])
    assert ranked(np.array([0.9, 0.8, 0.7, 0.6, 0.5]), y) == [2, 3, 3]
    assert ranked(np.array([0.5, 0.6, 0.7, 0.8, 0.9]), y) == [0, 1, 3]
    assert ranked(np.array([0.9, 0.9, 0.9, 0.1, 0.1]), y) == [0, 2, 3]  # the failure tied at 0.9 comes first
