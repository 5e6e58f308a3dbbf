"""The calibration's parts, each against a figure worked out by hand: the judge's logit, the log
loss, the bumps, the k-th distance, coverage at its radius, the fingerprint of an environment, what
`describe` prints, and the messages and checks of the file."""

from __future__ import annotations

import hashlib
import json
import warnings

import numpy as np
import pytest

from judgeopt.verdict.calibration import (LOGIT_CLIP, Calibrator, CalibrationError, _kth_distance_to_others, _log_loss,
                                          _logit, calibrate_rows, describe, env_fingerprint, for_judge, kth_distance,
                                          load_calibration_file, read_calibration_file, save_calibration)
from judgeopt.verdict.risk import Evidence


def _calibrator(low, high, bumps=3, points=None, radius=0.0, **kw) -> Calibrator:
    """Inputs a and b over [low, high]; weights of the right size, all zero."""
    varying = sum(h > lo for lo, h in zip(low, high))
    return Calibrator("s", "direct", "t", ["a", "b"], list(low), list(high), bumps, [0.0] * (2 + 2 * bumps * varying),
                      1.0, 40, 20, 0.5, 0.6, points=points or [[0.5] * (varying + 1)] * 6, cover_radius=radius, **kw)


def test_the_judges_logit_is_exact_inside_and_held_at_the_clip_where_it_saturates():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a judge's p of exactly 0 or 1 (float32 saturates) warns of nothing
        z = _logit(np.array([0.0, 1e-6, 0.5, 0.9, 1.0]))
    assert LOGIT_CLIP == 12.0
    assert z.tolist() == pytest.approx([-12.0, -12.0, 0.0, np.log(9.0), 12.0], rel=1e-12)


def test_the_log_loss_holds_a_certain_wrong_prediction_at_one_in_a_million():
    # a success predicted at 0 and a failure at 1 cost -log(1e-6) each, the right ones -log(1 - 1e-6)
    got = _log_loss(np.array([0.0, 1.0, 1.0, 0.0]), np.array([1.0, 0.0, 1.0, 0.0]))
    assert got == pytest.approx((2 * np.log(1e6) - 2 * np.log1p(-1e-6)) / 4, rel=1e-9)
    assert _log_loss(np.array([0.8, 0.5]), np.array([1.0, 0.0])) == pytest.approx(-(np.log(0.8) + np.log(0.5)) / 2)


def test_the_bumps_are_gaussians_one_spacing_wide_at_evenly_spaced_centres():
    # three bumps over a in [2, 4]: centres 2, 3 and 4, one spacing (1) wide; b never varied: no bumps along it
    cal = _calibrator([2.0, 5.0], [4.0, 5.0], bumps=3)
    e = np.exp
    assert cal.basis([[3.0, 5.0], [2.5, 5.0]]) == pytest.approx(
        np.array([[e(-0.5), 1.0, e(-0.5)], [e(-0.125), e(-0.125), e(-1.125)]]), rel=1e-12)
    # two bumps: centres at the ends, the range wide
    two = _calibrator([2.0, 5.0], [4.0, 5.0], bumps=2)
    assert two.basis([[3.0, 5.0]]) == pytest.approx(np.array([[e(-0.125)] * 2]))
    # the features: 1, the judge's logit over its clip, the bumps, and the bumps times that logit
    z = np.log(9.0) / 12
    b = [e(-0.5), 1.0, e(-0.5)]
    assert cal.features([[3.0, 5.0]], [0.9]) == pytest.approx(np.array([[1.0, z, *b, *(z * np.array(b))]]))


def test_a_calibration_whose_inputs_never_varied_maps_the_judges_logit_alone():
    cal = _calibrator([2.0, 5.0], [2.0, 5.0])
    assert cal.basis([[2.0, 5.0], [2.0, 5.0]]).shape == (2, 0)
    assert cal.features([[2.0, 5.0]], [0.9]) == pytest.approx(np.array([[1.0, np.log(9.0) / 12]]))


def test_the_kth_distance_is_exact_for_more_queries_than_one_chunk():
    """Points at 0, 1, ..., 299 on a line (shuffled), queries at -0.1 j: the k-th nearest is at 0.1 j + k - 1."""
    x = np.random.default_rng(4).permutation(300).astype(float)
    points = np.column_stack([x, np.zeros(300)])
    j = np.arange(600)
    query = np.column_stack([-0.1 * j, np.zeros(600)])
    for k in (1, 2, 5, 9):
        assert kth_distance(query, points, k) == pytest.approx(0.1 * j + k - 1, abs=1e-9), k
    two = np.array([[0.0, 0.0], [1.0, 0.0]])
    assert kth_distance(query[:3], two, 5) == pytest.approx([1.0, 1.1, 1.2])  # fewer points than k: the farthest


def test_a_single_group_has_no_other_to_be_near():
    assert np.isinf(_kth_distance_to_others(np.zeros((3, 2)), np.array(["a", "a", "a"]))).all()


def test_a_plan_exactly_at_the_radius_is_covered():
    """Six fitted points at a = 1.5 (a in [1, 2]), b never varied, judge p 0.5, radius 0.25: a plan at a = 1.75
    is 0.25 away on the range's scale (exact in binary), as is one at judge p 0.75."""
    cal = _calibrator([1.0, 5.0], [2.0, 5.0], radius=0.25)
    assert cal.covers([[1.75, 5.0], [1.5, 5.0], [1.5, 5.0], [1.25, 5.0]], [0.5, 0.75, 0.8, 0.5]).tolist() == [
        True, True, False, True]
    assert not cal.covers([[1.8, 5.0]], [0.5])[0]


def test_an_environment_is_told_by_its_values_to_nine_decimals():
    # the form stored in calibration files (`fitted_on`): the first 12 hex digits of the JSON list's SHA-256
    assert env_fingerprint([0.2, 2.0]) == hashlib.sha256(b"[0.2, 2.0]").hexdigest()[:12]
    assert env_fingerprint([0.2 + 4e-10, 2.0]) == env_fingerprint([0.2, 2.0])  # float noise of a round trip
    assert env_fingerprint([0.2 + 6e-10, 2.0]) != env_fingerprint([0.2, 2.0])


def test_describe_rounds_what_calibrate_and_inspect_print():
    cal = Calibrator("s1", "direct", "direct, judge j", ["y_obj", "mu"], [0.12345, 1.0], [0.27651, 3.2], 9, [], 0.3, 80,
                     60, 0.123456, 0.654321, cover_radius=0.0123456,
                     alternatives={"logistic_unconstrained": 0.5, "isotonic_judge_only": 0.61})
    assert describe(cal) == {"setting": "s1", "description": "direct, judge j", "n": 80, "success_pct": 75.0,
                             "ranges": {"y_obj": [0.123, 0.277], "mu": [1.0, 3.2]}, "cv_log_loss": 0.1235,
                             "constant_log_loss": 0.6543, "l2": 0.3, "logistic_unconstrained_log_loss": 0.5,
                             "isotonic_judge_only_log_loss": 0.61, "cover_radius": 0.0123}


def test_another_judges_calibration_names_both_judges_by_12_hex_digits():
    cal = _calibrator([1.0, 5.0], [2.0, 5.0], judge_sha256="0123456789abcdef" * 4)
    with pytest.raises(CalibrationError) as err:
        for_judge({"s": cal}, "fedcba9876543210" * 4, "cal.json")
    assert "(weights ['0123456789ab'], this one fedcba987654)" in str(err.value)


def test_a_row_without_a_calibrator_loses_everything_an_earlier_one_wrote():
    row = {"setting": "x", "predicted_success": 0.9, "environment": {"a": 1.5, "b": 5.0}, "calibrated_success": 0.8,
           "calibration_covers": True, "calibration_fitted_on_env": True}
    calibrate_rows([row], {"s": _calibrator([1.0, 5.0], [2.0, 5.0])})
    assert row == {"setting": "x", "predicted_success": 0.9, "environment": {"a": 1.5, "b": 5.0}}


def test_a_file_of_another_kind_or_with_a_damaged_threshold_table_is_refused(tmp_path):
    other = tmp_path / "judge.json"
    other.write_text(json.dumps({"format": "judgeopt-judge", "format_version": 1}))
    with pytest.raises(CalibrationError, match="not a judgeopt calibration file"):
        load_calibration_file(other)
    ev = Evidence("direct", None, 0.95, [{"threshold": 0.5, "n": 10, "failures": 0, "bound": 0.26}],
                  {"n": 0, "successes": 0, "floor": 0.0})
    path = save_calibration(tmp_path / "cal.json", {"s": _calibrator([1.0, 5.0], [2.0, 5.0])}, {"direct": ev})
    assert load_calibration_file(path)[1]["direct"].grid == ev.grid
    doc = json.loads(path.read_text())
    for grid in ([], [{"threshold": 0.5, "n": 10, "failures": 0}]):
        doc["evidence"]["direct"]["grid"] = grid
        path.write_text(json.dumps(doc))
        with pytest.raises(CalibrationError, match="malformed evidence .evidence direct has no threshold table."):
            load_calibration_file(path)


def test_a_calibration_file_is_read_again_only_once_it_changed(tmp_path):
    path = save_calibration(tmp_path / "cal.json", {"s": _calibrator([1.0, 5.0], [2.0, 5.0])})
    first = read_calibration_file(path)
    assert read_calibration_file(path) is first and first[0]["s"] == load_calibration_file(path)[0]["s"]
    save_calibration(path, {"s": _calibrator([1.0, 5.0], [3.0, 5.0]), "t": _calibrator([1.0, 5.0], [2.0, 5.0])})
    again = read_calibration_file(path)
    assert again is not first and again[0]["s"].env_high == [3.0, 5.0] and set(again[0]) == {"s", "t"}
    with pytest.raises(CalibrationError, match="no such calibration file"):
        read_calibration_file(tmp_path / "gone.json")


def test_a_plan_exactly_at_a_range_s_end_plus_its_margin_is_inside():
    """a over [1, 2] (margin 2 % of the width), b never varied; a huge radius, so the ranges alone decide."""
    from judgeopt.verdict.calibration import RANGE_MARGIN

    cal = _calibrator([1.0, 5.0], [2.0, 5.0], radius=10.0)
    tol = 1e-9 + RANGE_MARGIN * (2.0 - 1.0)
    assert cal.covers([[1.0 - tol, 5.0], [2.0 + tol, 5.0]], [0.5, 0.5]).tolist() == [True, True]
    assert cal.covers([[2.0 + 1.001 * tol, 5.0]], [0.5]).tolist() == [False]


def test_two_calibration_files_are_cached_apart_even_when_their_stamps_agree(tmp_path):
    """The same size and modification time: each file is still its own (kept by its resolved path)."""
    import os

    a = save_calibration(tmp_path / "a.json", {"s": _calibrator([1.0, 5.0], [2.0, 5.0])})
    b = save_calibration(tmp_path / "b.json", {"s": _calibrator([1.0, 5.0], [3.0, 5.0])})
    assert a.stat().st_size == b.stat().st_size
    os.utime(b, ns=(a.stat().st_atime_ns, a.stat().st_mtime_ns))
    assert read_calibration_file(a)[0]["s"].env_high == [2.0, 5.0]
    assert read_calibration_file(b)[0]["s"].env_high == [3.0, 5.0]
