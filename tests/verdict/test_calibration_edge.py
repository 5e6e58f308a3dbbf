"""The calibrated probability where outcomes flip: monotone in the judge, trusted only near what
it was fitted on (in the joint space of inputs and the judge's p), refused for another judge or
another format version."""

from __future__ import annotations

import json

import numpy as np
import pytest

from judgeopt.verdict.calibration import (COVER_QUANTILE, NEIGHBOURS, RANGE_MARGIN, VERSION, Calibrator, CalibrationError, fit, for_judge, load_calibration, save_calibration)


def _inverse_band(n: int, seed: int = 0):
    """Outcomes that *fall* with the judge's p inside a friction band (a judge wrong-way round
    there) and follow it elsewhere: an unconstrained map learns a negative slope in the band."""
    rng = np.random.default_rng(seed)
    env = np.column_stack([rng.uniform(0.1, 0.28, n), rng.uniform(1.0, 3.0, n)])
    pred = rng.uniform(0.01, 0.99, n)
    band = (env[:, 1] > 1.8) & (env[:, 1] < 2.4)
    y = rng.random(n) < np.where(band, 1.0 - pred, pred)
    return env, pred, y


def test_the_calibrated_p_never_rises_while_the_judges_falls_at_the_same_setting():
    env, pred, y = _inverse_band(1500)
    cal = fit("s", "direct", "t", ["y_obj", "mu"], env, pred, y)
    judge_p = np.linspace(0.001, 0.999, 60)
    for mu in (1.2, 2.0, 2.1, 2.8):  # in the band the outcomes fall with the judge's p; the map may only flatten
        p = cal.predict(np.tile([[0.2, mu]], (len(judge_p), 1)), judge_p)
        assert np.all(np.diff(p) >= -1e-12), mu
    outside = cal.predict(np.tile([[0.2, 1.2]], (2, 1)), [0.05, 0.95])
    assert outside[1] - outside[0] > 0.5  # outside the band it still follows the judge
    # measured against scikit-learn's maps on the same folds, recorded beside it
    assert set(cal.alternatives) == {"logistic_unconstrained", "isotonic_judge_only"}


def test_coverage_is_judged_in_the_joint_space_not_axis_by_axis():
    """Fitted only where mu rises with y_obj: a corner inside both ranges is far from every fitted plan."""
    rng = np.random.default_rng(1)
    u = rng.uniform(0, 1, 800)
    env = np.column_stack([0.1 + 0.18 * u, 1.0 + 2.0 * u + rng.normal(0, 0.02, 800)])
    cal = fit("s", "direct", "t", ["y_obj", "mu"], env, np.full(800, 0.95), rng.random(800) < 0.9)
    assert cal.covers([[0.19, 2.0]], [0.95])[0]  # on the diagonal
    assert not cal.covers([[0.27, 1.1]], [0.95])[0]  # inside each range, off the diagonal


def test_a_judges_p_far_from_the_fitted_ones_is_not_covered():
    """The issue's case: fitted on plans the judge scored about 0.99, asked about one it scores 0.002."""
    rng = np.random.default_rng(2)
    env = np.column_stack([rng.uniform(0.1, 0.28, 600), rng.uniform(1, 3, 600)])
    cal = fit("s", "amortized", "t", ["y_obj", "mu"], env, rng.uniform(0.97, 0.999, 600), rng.random(600) < 0.9)
    assert cal.covers([[0.2, 2.0]], [0.99])[0]
    assert not cal.covers([[0.2, 2.0]], [0.002])[0]
    assert cal.covers([[0.2, 2.0]], [0.9999])[0]  # saturated: the same verdict as 0.99
    assert not cal.annotate({"y_obj": 0.2, "mu": 2.0}, 0.002)["calibration_covers"]


def _hand_made(radius: float = 0.1) -> Calibrator:
    """Inputs y_obj in [0, 1] and mu in [0, 10]; fitted points, by construction, stacked at the
    corners and edges' middles (six copies each), judge p 0.5; coverage radius `radius`."""
    corners = [[a, b, 0.5] for a in (0.0, 0.5, 1.0) for b in (0.0, 0.5, 1.0)]
    return Calibrator("s", "direct", "t", ["y_obj", "mu"], [0.0, 0.0], [1.0, 10.0], 3, [0.0] * 14, 1.0, 54, 27,
                      0.1, 0.2, points=[c for c in corners for _ in range(6)], cover_radius=radius)


@pytest.mark.parametrize("axis,end", [(0, 0), (0, 1), (1, 0), (1, 1)])
def test_points_just_beyond_each_fitted_range_are_not_covered_even_next_to_fitted_plans(axis, end):
    cal = _hand_made()
    width = (1.0, 10.0)[axis]
    edge = (0.0, (1.0, 10.0)[axis])[end]
    sign = 1 if end else -1
    assert RANGE_MARGIN == 0.02  # the documented margin: 2 % of a range's width
    for share, covered in ((0.5, True), (1.5, False)):
        x = [0.5, 5.0]
        x[axis] = edge + sign * share * 0.02 * width
        assert bool(cal.covers([x], [0.5])[0]) is covered, (x, share)


def test_coverage_is_judged_per_plan():
    cal = _hand_made()
    assert cal.covers([[0.5, 5.0], [0.5, 12.0], [0.0, 0.0]], [0.5, 0.5, 0.5]).tolist() == [True, False, True]


def test_coverage_radius_binds_at_its_value():
    """Six fitted copies at (0.5, 5), judge p 0.5: the NEIGHBOURS-th is at the query's distance."""
    cal = _hand_made(radius=0.2)
    assert cal.covers([[0.5 + 0.19, 5.0]], [0.5])[0]  # 0.19 scaled units from the nearest six
    assert not cal.covers([[0.5 + 0.21, 5.0]], [0.5])[0]
    assert NEIGHBOURS <= 6 and 0 < COVER_QUANTILE < 1


def test_the_radius_is_the_quantile_of_the_fitted_plans_own_neighbour_distances():
    env = np.column_stack([np.linspace(0.1, 0.28, 101), np.full(101, 2.0)])
    cal = fit("s", "direct", "t", ["y_obj", "mu"], env, np.full(101, 0.9), np.arange(101) % 3 > 0)
    # evenly spaced along y_obj (mu never varied): the 5th neighbour is 3 spacings away inside
    assert cal.cover_radius == pytest.approx(3 / 100, rel=1e-3)
    by_pairs = fit("s", "direct", "t", ["y_obj", "mu"], env, np.full(101, 0.9), np.arange(101) % 3 > 0,
                   groups=[str(i // 2) for i in range(101)])  # plans in pairs of one setting: the partner is left out
    # the first of a pair: its partner left out, the 5th other is 4 spacings away (the second's: 3)
    assert by_pairs.cover_radius == pytest.approx(4 / 100, rel=1e-3)
    assert not cal.covers([[0.2, 2.1]], [0.9])[0]  # mu never varied: another value is another setting


def test_a_calibration_of_an_older_or_newer_version_or_another_judge_is_refused_in_one_line(tmp_path):
    env, pred, y = _inverse_band(100)
    cal = fit("s", "direct", "t", ["y_obj", "mu"], env, pred, y, judge_sha256="a" * 64)
    path = save_calibration(tmp_path / "cal.json", {"s": cal})
    assert load_calibration(path)["s"].judge_sha256 == "a" * 64
    doc = json.loads(path.read_text())
    for version, words in ((1, "refit it with `judgeopt calibrate"), (VERSION + 1, "newer")):
        (tmp_path / f"v{version}.json").write_text(json.dumps({**doc, "format_version": version}))
        with pytest.raises(CalibrationError, match=words) as err:
            load_calibration(tmp_path / f"v{version}.json")
        assert str(tmp_path / f"v{version}.json") in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(CalibrationError, match="another judge") as err:
        for_judge(load_calibration(path), "b" * 64, path)
    assert str(path) in str(err.value) and "--calibration" in str(err.value)
    assert set(for_judge(load_calibration(path), "a" * 64, path)) == {"s"}
    with pytest.raises(CalibrationError, match="a folder"):
        load_calibration(tmp_path)
    for damage in ({"points": [[0.1, 0.2]]}, {"weights": [0.0] * 3}, {"points": []}):  # 2 numbers where 3 are needed
        bad = dict(doc)
        bad["settings"] = {"s": {**doc["settings"]["s"], **damage}}
        (tmp_path / "bad.json").write_text(json.dumps(bad))
        with pytest.raises(CalibrationError, match="wrong size"):
            load_calibration(tmp_path / "bad.json")
