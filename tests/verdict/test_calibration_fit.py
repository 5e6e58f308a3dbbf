"""The calibration's fit on outcomes whose answer is known by construction: the monotone map's
optimum, the cross-validated constant rate, the alternatives it is measured against, the penalty
it chooses, and what `fit_from_rows` takes from evaluation rows."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.optimize import brentq

from judgeopt.verdict.calibration import L2_GRID, _alternatives, _fit_monotone, fit, fit_from_rows


def _xz(z):
    """Features of a calibration whose inputs never varied: 1 and the judge's logit."""
    return np.column_stack([np.ones(len(z)), z])


# -- the monotone map --------------------------------------------------------------------------

def test_outcomes_unrelated_to_the_judge_and_the_input_give_the_rate_and_nothing_else():
    """Four cells (z -1 or 1, a bump 0.2 or 1), 4 successes in 5 in each: the optimum is the bias
    log(0.8 / 0.2), unpenalised, and every other weight 0 (the slope's at its bound)."""
    z = np.repeat([-1.0, 1.0, -1.0, 1.0], 5)
    b = np.repeat([0.2, 0.2, 1.0, 1.0], 5)
    y = np.tile([1.0, 1.0, 1.0, 1.0, 0.0], 4)
    w = _fit_monotone(np.column_stack([np.ones(20), z, b, z * b]), y, 10.0, 1)
    assert w == pytest.approx([np.log(4.0), 0.0, 0.0, 0.0], abs=1e-6)


@pytest.mark.parametrize("l2", [0.03, 1.0])
def test_the_map_is_solved_to_its_optimum_among_many_inputs(l2):
    """Ten cells of 5 plans, 4 successes in each, the judge's logit -1 or 1 and eight inputs each
    constant within a cell: the gradient vanishes at the bias log 4 and every other weight 0, so
    that is the optimum, and the fit reaches it to 1e-5 (scipy's default tolerances stop 1e-4 away)."""
    cols = np.random.default_rng(4).uniform(0, 1, (10, 8))
    z = np.where(np.arange(10) % 2, 1.0, -1.0)
    X = np.repeat(np.column_stack([np.ones(10), z, cols]), 5, axis=0)
    w = _fit_monotone(X, np.tile([1.0, 1.0, 1.0, 1.0, 0.0], 10), l2, 4)
    assert w == pytest.approx(np.r_[np.log(4.0), np.zeros(9)], abs=1e-5)


@pytest.mark.parametrize("l2", [0.5, 3.0, 30.0])
def test_separable_outcomes_give_the_slope_where_the_penalty_balances_the_loss(l2):
    """10 failures at z = -1 and 10 successes at z = 1: by symmetry the bias is 0, and the slope s
    solves l2 s = 20 sigmoid(-s), the gradient of 20 log(1 + e^-s) + l2 s^2 / 2."""
    z = np.repeat([-1.0, 1.0], 10)
    s = brentq(lambda s: l2 * s - 20 / (1 + np.exp(s)), 0, 50)
    assert _fit_monotone(_xz(z), (z > 0).astype(float), l2, 0) == pytest.approx([0.0, s], abs=1e-7)


# -- the alternatives, on folds given by hand (point i and i + 5 in fold i) ------------------------

FOLDS = np.tile(np.arange(5), 2)
Z = np.repeat([-1.0, 1.0], 5)


def test_the_unconstrained_logistic_on_separable_outcomes():
    """Each training fold: 4 failures at z = -1, 4 successes at z = 1, so the intercept is 0 and the
    weight w solves w = 8 C sigmoid(-w), C = 1 / l2 (scikit-learn's form); every held-out plan is
    then predicted right at sigmoid(w)."""
    l2 = 4.0
    w = brentq(lambda w: w - 8 / l2 / (1 + np.exp(w)), 0, 50)
    got = _alternatives(_xz(Z), Z, (Z > 0).astype(float), FOLDS, l2)
    assert got["logistic_unconstrained"] == pytest.approx(np.log1p(np.exp(-w)), abs=2e-5)
    assert got["isotonic_judge_only"] == 0.001  # -log(0.999): isotonic clipped at 1e-3 from 0 and 1


def test_isotonic_regression_on_the_judge_alone_held_out():
    """z = -1: 5 failures; z = 1: 4 successes and a failure. Held out, a plan at z = -1 is predicted
    0 (clipped to 1e-3); the failure at z = 1 from 4 successes (1, clipped to 0.999); each success
    at z = 1 from 3 successes and the failure (0.75)."""
    y = np.array([0, 0, 0, 0, 0, 0, 1, 1, 1, 1], float)
    want = (5 * -np.log(0.999) - np.log(0.001) + 4 * -np.log(0.75)) / 10
    assert _alternatives(_xz(Z), Z, y, FOLDS, 4.0)["isotonic_judge_only"] == round(want, 5)
    # the success at z = 2 (fold 4) lies beyond its training fold's z (at most 1): predicted as the
    # largest, 1 (held at 0.999), as every other plan is predicted right
    z = np.array([-1, -1, -1, -1, -1, 1, 1, 1, 1, 2], float)
    assert _alternatives(_xz(z), z, (z > 0).astype(float), FOLDS, 4.0)["isotonic_judge_only"] == 0.001


def test_a_training_fold_of_one_outcome_predicts_its_rate():
    """The only success is in fold 4: that fold is predicted from 8 failures (0, held at 1e-6 by
    the log loss); the others as in the isotonic case, 0 at z = -1 and 1 in 4 at z = 1."""
    y = np.zeros(10)
    y[9] = 1.0
    got = _alternatives(_xz(Z), Z, y, FOLDS, 4.0)
    fold4 = -np.log(1e-6) - np.log1p(-1e-6)
    assert got["isotonic_judge_only"] == round((4 * -np.log(0.999) + 4 * -np.log(0.75) + fold4) / 10, 5)
    assert got["logistic_unconstrained"] > fold4 / 10  # the fold of one outcome alone costs that


# -- fit --------------------------------------------------------------------------------------

def test_twenty_outcomes_are_enough_and_the_fit_is_quiet_repeatable_and_records_its_inputs():
    env = np.column_stack([np.linspace(0.1, 0.28, 20), np.linspace(1.0, 3.0, 20)[::-1]])
    pred, y = np.linspace(0.05, 0.95, 20), np.arange(20) % 3 > 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # `judgeopt calibrate` prints no optimiser's or scikit-learn's warnings
        cal = fit("s", "cem", "cem, judge j", ["y_obj", "mu"], env, pred, y, sources=["ev/b", "ev/a", "ev/b"])
    assert (cal.method, cal.description, cal.sources, cal.n, cal.successes) == ("cem", "cem, judge j",
                                                                                ["ev/a", "ev/b"], 20, 13)
    assert cal.bumps == 9 and len(cal.weights) == 2 + 2 * 9 * 2  # docs/remedies.md: 9 bumps per input
    again = fit("s", "cem", "cem, judge j", ["y_obj", "mu"], env, pred, y)
    assert (again.weights, again.cv_log_loss, again.alternatives) == (cal.weights, cal.cv_log_loss, cal.alternatives)
    points = np.array(cal.points)  # each input on its fitted range's scale, then the judge's p
    assert points.min(0) == pytest.approx([0.0, 0.0, 0.05]) and points.max(0) == pytest.approx([1.0, 1.0, 0.95])


@pytest.mark.parametrize("odd_one", [0.0, 1.0])
def test_the_constant_rates_loss_is_held_out_too(odd_one):
    """25 plans, one of them the only failure (or success): the fold that holds it is predicted
    from the 20 others alike (held at 0.999, or 1e-3), the other 4 folds from 19 in 20. The map
    loses to that rate, so the calibration reports the rate, 24 in 25."""
    env = np.column_stack([np.linspace(0.1, 0.28, 25), np.full(25, 2.0)])
    y = np.full(25, 1.0 - odd_one)
    y[7] = odd_one
    cal = fit("s", "direct", "t", ["y_obj", "mu"], env, np.full(25, 0.9), y)
    assert cal.base_log_loss == pytest.approx((4 * -np.log(0.999) - np.log(0.001) + 20 * -np.log(0.95)) / 25,
                                              rel=1e-12)
    assert cal.constant and cal.predict(env[:2], [0.9, 0.1]) == pytest.approx([abs(odd_one - 0.96)] * 2)


@pytest.mark.parametrize("odd_one", [0.0, 1.0])
def test_a_rate_beyond_one_in_a_thousand_is_reported_as_one_in_a_thousand(odd_one):
    """One failure (or success) in 1005 plans: the rate reported is held at 0.999 (or 0.001), as
    the constant predictor's, not 1004 in 1005."""
    env = np.tile([0.2, 2.0], (1005, 1))
    y = np.full(1005, 1.0 - odd_one)
    y[3] = odd_one
    cal = fit("s", "direct", "t", ["y_obj", "mu"], env, np.full(1005, 0.99), y)
    assert cal.constant and cal.predict(env[:1], [0.99])[0] == pytest.approx(0.999 if odd_one == 0 else 0.001,
                                                                             abs=1e-9)


def test_the_alternatives_measure_the_judges_own_p():
    """Outcomes that follow the judge exactly (p 0.9 succeeded, 0.1 failed): isotonic regression on
    the judge's p alone gets every held-out plan right, at its clip (-log 0.999)."""
    rng = np.random.default_rng(0)
    y = np.arange(40) % 2 == 0
    cal = fit("s", "direct", "t", ["y_obj", "mu"], np.column_stack([rng.uniform(0.1, 0.28, 40), np.full(40, 2.0)]),
              np.where(y, 0.9, 0.1), y)
    assert cal.alternatives["isotonic_judge_only"] == 0.001


def test_outcomes_unrelated_to_anything_choose_the_heaviest_penalty():
    rng = np.random.default_rng(0)
    env = np.column_stack([rng.uniform(0.1, 0.28, 100), np.full(100, 2.0)])
    cal = fit("s", "direct", "t", ["y_obj", "mu"], env, rng.uniform(0.1, 0.9, 100), rng.random(100) < 0.5)
    assert cal.l2 == L2_GRID[-1] == 1000.0


# -- fit_from_rows ------------------------------------------------------------------------------

def _rows(setting, n_env, method="direct", judges=("a" * 64,), f_max=15.0, family=None):
    """Two plans in each of n_env environments (y_obj evenly over [0.1, 0.28]), under one limit set."""
    out = []
    for i, y_obj in enumerate(np.repeat(np.linspace(0.1, 0.28, n_env), 2)):
        out.append({"setting": setting, "family": family, "method": method, "environment": {"y_obj": y_obj, "mu": 2.0},
                    "limits": {"qdot_max": 0.5, "f_max": f_max}, "predicted_success": 0.9,
                    "simulated_success": i % 3 > 0, "judge_sha256": judges[i % len(judges)]})
    return out


def test_fit_from_rows_takes_settings_of_50_replayed_outcomes_with_their_judge_and_description():
    s1 = _rows("s1", 25)
    damaged = [{**s1[0], "predicted_success": None}, {**s1[0], "simulated_success": None},
               {k: v for k, v in s1[0].items() if k != "setting"}]
    rows = _rows("s3", 25)[:49] + s1 + damaged + _rows("s2", 25, method="cem", judges=("a" * 64, "b" * 64))
    cals = fit_from_rows(rows, {"s1": "direct, judge j; q̇_max 0.5, f in [7.5, 15]"}, ["y_obj", "mu"],
                         sources=["ev/b", "ev/a"])
    assert set(cals) == {"s1", "s2"}  # 50 outcomes are enough, 49 too few; the damaged rows are not counted
    s1, s2 = cals["s1"], cals["s2"]
    assert (s1.n, s1.env_names, s1.method, s2.method) == (50, ["y_obj", "mu"], "direct", "cem")
    assert (s1.description, s2.description) == ("direct, judge j; q̇_max 0.5, f in [7.5, 15]", "cem")
    assert (s1.judge_sha256, s2.judge_sha256, s1.sources) == ("a" * 64, None, ["ev/a", "ev/b"])
    # the plans of one environment are one group: the 5th nearest plan of another environment is 2
    # spacings (of 24) away inside, 3 at either end; their 95 % quantile is 3 spacings
    assert s1.cover_radius == pytest.approx(3 / 24, rel=1e-9)


def test_fit_from_rows_over_limits_has_the_limits_as_inputs_and_the_settings_as_groups():
    """25 settings of one family, f_max evenly over [11, 20], two plans each, all in one environment."""
    f_max = np.linspace(11.0, 20.0, 25)
    rows = [r for i, f in enumerate(f_max) for r in _rows(f"s{i}", 1, f_max=f, family="fam")]
    descriptions = {f"s{i}": f"direct, judge j; q̇_max 0.5, f in [7.5, {f:g}]" for i, f in enumerate(f_max)}
    (cal,) = fit_from_rows(rows, descriptions, ["y_obj", "mu"], over_limits=True).values()
    assert (cal.setting, cal.env_names) == ("fam", ["y_obj", "mu", "qdot_max", "f_max"])
    assert cal.description == "direct, judge j, over limits"
    assert cal.cover_radius == pytest.approx(3 / 24, rel=1e-9)  # as above, along f_max


def test_a_family_is_described_by_its_first_setting_and_rows_without_limits_are_read():
    """Two settings of one family whose descriptions differ beyond their limits: the first row's names it.
    Rows that carry no limits (a task without them) fit over the environment alone."""
    rows = _rows("s1", 25, family="fam") + _rows("s2", 25, family="fam")
    descriptions = {"s1": "direct, judge j; q̇_max 0.5, f in [7.5, 13]", "s2": "direct, judge k; q̇_max 0.5, f in [7.5, 13]"}
    (cal,) = fit_from_rows(rows, descriptions, ["y_obj", "mu"], over_limits=True).values()
    assert cal.description == "direct, judge j, over limits"
    bare = [{k: v for k, v in r.items() if k != "limits"} for r in rows]
    (cal,) = fit_from_rows(bare, descriptions, ["y_obj", "mu"], over_limits=True).values()
    assert cal.env_names == ["y_obj", "mu"] and cal.n == 100
