"""The risk behind "likely": bounds known in closed form, thresholds on outcomes built to set them."""

from __future__ import annotations

import math

import pytest

from judgeopt.verdict.risk import (GRID, Evidence, annotate, capped, evidence_key, fit_evidence, lower_bound,
                                   upper_bound, whose)


def test_clopper_pearson_bounds_match_their_closed_forms():
    # no failure in n: (1 - u)^n = 0.05; one in two: P(X <= 1) = 1 - u^2 = 0.05; all failed: 1
    for n in (1, 10, 149, 216):
        assert upper_bound(0, n) == pytest.approx(1 - 0.05 ** (1 / n))
    assert upper_bound(1, 2) == pytest.approx(math.sqrt(0.95))
    assert upper_bound(3, 3) == 1.0 and upper_bound(0, 0) == 1.0
    assert upper_bound(0, 149) < 0.02 < upper_bound(0, 148)  # 149 clean plans are the fewest that bound 2 %
    assert lower_bound(10, 10) == pytest.approx(0.05 ** (1 / 10)) and lower_bound(0, 10) == 0.0
    assert upper_bound(0, 100, 0.99) == pytest.approx(1 - 0.01 ** (1 / 100))


def _row(p, success, method="direct", **kw):
    return {"method": method, "judge_sha256": "ab" * 32, "predicted_success": p, "simulated_success": success,
            "max_constraint_violation": 0.0, "environment": {"y_obj": 0.2, "mu": 2.0},
            "limits": {"qdot_max": 0.5, "f_max": 13.0}, **kw}


def _judges(rows, **kw):
    """The evidence of the judge's own p (rows without a covering calibration), of the one planner in `rows`."""
    (ev,) = [e for e in fit_evidence(rows, **kw).values() if e.kind == "judge"]
    return ev


def test_the_threshold_is_the_lowest_whose_bound_holds_the_risk():
    # 200 plans at p 0.996 all succeed, 100 at p 0.92 fail 10 times: from p >= 0.95 up, 0 of 200 failed
    rows = [_row(0.996, True)] * 200 + [_row(0.92, i >= 10) for i in range(100)]
    (key, ev), = [(k, e) for k, e in fit_evidence(rows).items() if e.plans]
    assert key == evidence_key("direct", "ab" * 32, kind="judge") and ev.plans == 300
    assert ev.at(0.02)["threshold"] == 0.95 and (ev.at(0.02)["n"], ev.at(0.02)["failures"]) == (200, 0)
    assert ev.at(0.005) is None  # 200 clean plans bound the rate at 1.5 %, no lower
    assert ev.at(0.06)["threshold"] == GRID[0]  # 10 of 300 failed: 5.2 % bound
    assert "0 failed" in ev.describe(0.02) and "never called likely" in ev.describe(0.005)


def test_plans_that_break_a_limit_or_lie_outside_the_data_unchecked_are_no_evidence():
    rows = ([_row(0.999, True)] * 150 + [_row(0.999, False, max_constraint_violation=0.5)] * 50
            + [_row(0.999, False, outside_judge_data=["mu = 4"])] * 50)
    ev = _judges(rows)
    assert ev.grid[-1]["n"] == 150 and ev.grid[-1]["failures"] == 0 and ev.at(0.02) is not None


def test_a_calibrated_lift_of_a_low_judge_p_goes_only_as_far_as_such_lifts_succeeded():
    lifted = [_row(0.3, i < 4, calibrated_success=0.9, calibration_covers=True) for i in range(19)]
    clean = [_row(0.999, True, calibrated_success=0.999, calibration_covers=True)] * 200
    ev = fit_evidence(lifted + clean)[evidence_key("direct", "ab" * 32, kind="calibrated")]
    assert (ev.raised["n"], ev.raised["successes"]) == (19, 4)
    assert ev.raise_floor == pytest.approx(lower_bound(4, 19), abs=1e-6) and ev.raise_floor < 0.3
    assert capped(0.3, 0.9, ev.raise_floor) == 0.3  # the evidence does not back the lift
    assert capped(0.3, 0.9, 0.6) == 0.6 and capped(0.3, 0.2, 0.6) == 0.2  # lowering is free
    assert capped(0.7, 0.95, 0.0) == 0.95  # a judge's p at or above 0.5 is not a lift across it
    assert ev.grid[0]["n"] == 200  # the lifted plans, back at their judge's p, are not called likely
    # a calibrated p over a judge's p already at 0.5 or above is no lift; a judge's p of exactly 0.5 neither
    others = [_row(0.9, False, calibrated_success=0.95, calibration_covers=True)] * 7
    others += [_row(0.5, False, calibrated_success=0.9, calibration_covers=True)] * 3
    assert fit_evidence(lifted + others)[evidence_key("direct", "ab" * 32, kind="calibrated")].raised["n"] == 19


def test_the_evidence_speaks_inside_its_ranges_only():
    rows = [_row(0.999, True, environment={"y_obj": 0.1 + i / 1000, "mu": 2.0}) for i in range(200)]
    evidence = fit_evidence(rows)
    inside, beyond = {}, {}
    annotate(inside, evidence, "direct", "ab" * 32, {"qdot_max": 0.5, "f_max": 13.0, "y_obj": 0.2, "mu": 2.0})
    assert inside["likely_at"] == 0.5 and inside["risk"]["n"] == 200
    annotate(beyond, evidence, "direct", "ab" * 32, {"qdot_max": 0.5, "f_max": 13.0, "y_obj": 0.35, "mu": 2.0})
    assert beyond["likely_at"] == 0.5 and "y_obj 0.35 (0.1-0.299)" in beyond["risk"]["evidence"]
    other = {"likely_at": 0.7, "raise_floor": 0.4, "risk": {"risk": 0.02}}
    annotate(other, evidence, "direct", "cd" * 32, {"y_obj": 0.2})  # another judge: none, and nothing stale kept
    assert other == {}


def test_evidence_round_trips_through_its_dict():
    ev = _judges([_row(0.999, True)] * 30)
    assert Evidence.from_dict(ev.to_dict()) == ev


def test_what_a_result_carries_word_for_word():
    rows = [_row(0.996, True)] * 200 + [_row(0.92, i >= 10) for i in range(100)]
    ev = _judges(rows, confidence=0.9)
    row = ev.at(0.02)
    assert row == {"threshold": 0.95, "n": 200, "failures": 0, "bound": round(1 - 0.1 ** (1 / 200), 6)}
    assert ev.describe(0.02) == ("likely at p >= 0.95: of 200 held-out plans of direct with the judge's own p "
                                 "there, 0 failed "
                                 f"(90 % upper bound {100 * row['bound']:.1f} % <= risk 2 %)")
    best = min(ev.grid, key=lambda g: g["bound"])
    assert ev.describe(0.001) == ("no threshold holds a 0.1 % risk on 300 held-out plans of direct with the judge's "
                                  "own p (the best: "
                                  f"p >= {best['threshold']:g}, 0 of 200 failed, 90 % bound {100 * best['bound']:.1f} %), "
                                  "so it is never called likely at that risk")
    target = {"raise_floor": 0.3, "likely_at": 0.1, "risk": {}, "kept": 1}
    annotate(target, {evidence_key("direct", "ab" * 32): ev}, "direct", "ab" * 32, {"y_obj": 0.2}, 0.02)
    assert target == {"kept": 1, "raise_floor": 0.0, "likely_at": 0.95,
                      "risk": {"risk": 0.02, "confidence": 0.9, **row, "evidence": ev.describe(0.02)}}
    annotate(target, {evidence_key("direct", "ab" * 32): ev}, "direct", "ab" * 32, {"y_obj": 0.2}, 0.001)
    assert target["likely_at"] is None and target["risk"]["evidence"] == ev.describe(0.001)
    far = {}
    annotate(far, {evidence_key("direct", "ab" * 32): ev}, "direct", "ab" * 32, {"qdot_max": 0.9}, 0.02)
    assert far == {"likely_at": 0.95, "risk": {
        "risk": 0.02, "evidence": "unchecked here: 'likely' is p >= 0.95, the threshold set where they were drawn, as "
                                  "the held-out plans of direct with the judge's own p were drawn inside other ranges "
                                  "(qdot_max 0.9 (0.5-0.5))"}}
    annotate(far, {evidence_key("direct", "ab" * 32): ev}, "direct", "ab" * 32, {"qdot_max": 0.9}, 0.001)
    assert far == {"likely_at": None, "risk": {
        "risk": 0.001, "evidence": "unchecked here, as the held-out plans of direct with the judge's own p were drawn "
                                   "inside other ranges (qdot_max 0.9 (0.5-0.5)); where they were drawn no threshold "
                                   "holds a 0.1 % risk, so it is never called likely"}}


def test_the_edges_of_each_rule():
    assert capped(0.5, 0.9, 0.0) == 0.9  # a judge's 0.5 is not below 0.5: no lift across it
    assert capped(None, 0.9, 0.0) == 0.9 and capped(0.49, 0.49, 0.0) == 0.49
    ev = Evidence("direct", None, 0.95, [{"threshold": 0.9, "n": 10, "failures": 0, "bound": 0.02}], {})
    assert ev.at(0.02)["threshold"] == 0.9 and ev.at(0.0199) is None  # a bound equal to the risk holds it
    assert ev.raise_floor == 0.0 and evidence_key("direct", None) == "direct@unknown"
    assert evidence_key("direct", "0123456789abcdef0123") == "direct@0123456789abcdef"
    ev.ranges = {"f_max": [10.0, 20.0], "mu": [2.0, 2.0]}
    assert ev.outside({"f_max": 20.19, "mu": 2.0}) == [] and ev.outside({"f_max": 9.81}) == []  # 2 % of the width
    assert ev.outside({"f_max": 20.3, "mu": 2.0 + 1e-6}) == ["f_max 20.3 (10-20)", "mu 2 (2-2)"]
    assert ev.outside({"f_max": [30.0], "other": 5.0}) == []  # per-axis values and names it never saw: not judged
    assert Evidence.from_dict({"method": "m", "judge_sha256": None, "confidence": 0.95, "grid": [], "raised": {}}).plans == 0


def test_which_rows_count():
    base = [_row(0.999, True)] * 150
    extra = [{**_row(0.999, False), "method": None}, {**_row(0.999, False), "simulated_success": None},
             {**_row(None, False)}]
    assert _judges(base + extra).plans == 150  # no method, outcome or p: not a plan
    # a calibrated p counts only where the calibration covers the plan (and says a number)
    uncovered = [_row(0.3, False, calibrated_success=0.999, calibration_covers=False)] * 20
    nothing = [_row(0.3, False, calibration_covers=True)] * 20
    ev = _judges(base + uncovered + nothing)
    assert ev.grid[-1] == {"threshold": 0.999, "n": 150, "failures": 0, "bound": round(upper_bound(0, 150), 6)}
    assert ev.raised["n"] == 0
    exactly = [_row(0.3, True, calibrated_success=0.5, calibration_covers=True)] * 5  # lifted to exactly 0.5
    assert fit_evidence(base + exactly)[evidence_key("direct", "ab" * 32, kind="calibrated")].raised == {
        "n": 5, "successes": 5,
                                                                       "floor": round(lower_bound(5, 5), 6)}
    at_tol = [_row(0.999, False, max_constraint_violation=1e-3)] * 3  # at the tolerance: holds, so it counts
    assert _judges(base + at_tol).grid[-1]["failures"] == 3
    mixed = [_row(0.999, True, limits={"qdot_max": 0.4, "f_min": 7.5})] + [_row(0.999, True)] * 3
    assert set(_judges(mixed).ranges) == {"qdot_max", "y_obj", "mu"}  # those all have
    second = [_row(0.999, True), _row(0.999, True, limits={"qdot_max": 0.4}), _row(0.999, True)]  # no f_max in one
    assert set(_judges(second).ranges) == {"qdot_max", "y_obj", "mu"}
    two = fit_evidence([_row(0.999, True)] * 3 + [_row(0.999, True, method="amortized", judge_sha256="cd" * 32)])
    assert {k: (e.method, e.judge_sha256, e.plans) for k, e in two.items()} == {
        "direct@abababababababab#judge": ("direct", "ab" * 32, 3), "direct@abababababababab#calibrated": ("direct", "ab" * 32, 0),
        "amortized@cdcdcdcdcdcdcdcd#judge": ("amortized", "cd" * 32, 1),
        "amortized@cdcdcdcdcdcdcdcd#calibrated": ("amortized", "cd" * 32, 0)}
    assert {whose(k) for k in two} == {"direct@abababababababab", "amortized@cdcdcdcdcdcdcdcd"}


def test_the_default_risk_and_confidence_are_the_documented_two_and_ninety_five():
    from judgeopt.verdict import risk

    assert (risk.RISK, risk.CONFIDENCE, risk.RAISE_FROM) == (0.02, 0.95, 0.5)


def test_each_kind_of_p_sets_its_own_threshold():
    # calibrated p: 200 clean plans at 0.9; the judge's own p: 200 plans at 0.999, 8 of them failed. One
    # threshold for both (as stored before they were kept apart) would let the judge's p ride on the others'
    cal = [_row(0.6, True, calibrated_success=0.9, calibration_covers=True)] * 200
    own = [_row(0.999, i >= 8) for i in range(200)]
    ev = fit_evidence(cal + own)
    c, j = ev[evidence_key("direct", "ab" * 32, kind="calibrated")], ev[evidence_key("direct", "ab" * 32, kind="judge")]
    assert (c.plans, j.plans) == (200, 200) and c.at(0.02)["threshold"] == GRID[0] and j.at(0.02) is None
    assert "with a calibrated p" in c.describe() and "with the judge's own p" in j.describe()
    values = {"qdot_max": 0.5, "f_max": 13.0, "y_obj": 0.2, "mu": 2.0}
    covered, uncovered = {"calibrated_success": 0.95, "calibration_covers": True}, {"calibrated_success": 0.95}
    annotate(covered, ev, "direct", "ab" * 32, values)
    annotate(uncovered, ev, "direct", "ab" * 32, values)
    assert covered["likely_at"] == GRID[0] and uncovered["likely_at"] is None
    # a kind no plan had is never likely (not "risk unchecked")
    only = fit_evidence(cal)
    none_own = {}
    annotate(none_own, only, "direct", "ab" * 32, values)
    assert none_own["likely_at"] is None and "on 0 held-out plans of direct with the judge's own p" in \
        none_own["risk"]["evidence"]


def test_evidence_stored_before_the_kinds_were_kept_apart_speaks_for_both():
    mixed = Evidence("direct", "ab" * 32, 0.95, [{"threshold": 0.9, "n": 200, "failures": 0, "bound": 0.015}], {})
    for row in ({}, {"calibrated_success": 0.95, "calibration_covers": True}):
        annotate(row, {evidence_key("direct", "ab" * 32): mixed}, "direct", "ab" * 32, {"y_obj": 0.2})
        assert row["likely_at"] == 0.9 and "held-out plans of direct there" in row["risk"]["evidence"]
    # a kind's own evidence wins over the mixed one
    own = Evidence("direct", "ab" * 32, 0.95, [{"threshold": 0.9, "n": 10, "failures": 0, "bound": 0.26}], {}, kind="judge")
    row = {}
    annotate(row, {evidence_key("direct", "ab" * 32): mixed, evidence_key("direct", "ab" * 32, kind="judge"): own},
             "direct", "ab" * 32, {"y_obj": 0.2})
    assert row["likely_at"] is None


def test_the_kind_of_p_is_the_source_the_verdict_stands_behind():
    """kind_of (which threshold) and rules.stood_behind (which p is printed) name the same kind."""
    from judgeopt.verdict.risk import kind_of
    from judgeopt.verdict.rules import stood_behind

    for calibrated in (None, 0.7):
        for covers in (True, False, None):
            _, source = stood_behind(0.9, calibrated, covers, 0.0)
            assert kind_of({"calibrated_success": calibrated, "calibration_covers": covers}) == source


def test_the_ends_of_each_range_and_the_arms_are_named_in_full():
    """A value exactly at a range's end plus its margin is inside; an arm the evidence was not replayed
    on is named with every arm it was; several ranges left are named each."""
    from judgeopt.verdict.calibration import RANGE_MARGIN

    ev = Evidence("direct", None, 0.95, [{"threshold": 0.9, "n": 200, "failures": 0, "bound": 0.015}], {},
                  ranges={"f_max": [10.0, 20.0]}, robots=["ur5", "panda"])
    tol = 1e-9 + RANGE_MARGIN * (20.0 - 10.0)
    assert ev.outside({"f_max": 10.0 - tol}) == [] and ev.outside({"f_max": 20.0 + tol}) == []
    assert ev.outside({}) == []  # no arm named: the default arm's, which the evidence was replayed on
    assert ev.outside({"robot": "xarm7", "f_max": 30.0}) == ["robot xarm7 (ur5, panda)", "f_max 30 (10-20)"]
    target = {}
    annotate(target, {evidence_key("direct", None): ev}, "direct", None, {"robot": "xarm7", "f_max": 30.0})
    assert target["risk"]["evidence"].endswith("inside other ranges (robot xarm7 (ur5, panda), f_max 30 (10-20))")


def test_the_lift_floor_is_bounded_at_the_confidence_asked_for():
    lifted = [_row(0.3, i < 4, calibrated_success=0.9, calibration_covers=True) for i in range(19)]
    ev = fit_evidence(lifted, confidence=0.8)[evidence_key("direct", "ab" * 32, kind="calibrated")]
    assert ev.raise_floor == pytest.approx(lower_bound(4, 19, 0.8), abs=1e-6)
    assert ev.raise_floor > lower_bound(4, 19, 0.95)  # a lower confidence bounds it tighter


def test_rows_without_limits_or_a_judge_s_hash_are_counted_each_under_its_own_key():
    rows = ([{k: v for k, v in _row(0.999, True).items() if k != "limits"}] * 3
            + [_row(0.999, False, judge_sha256=None)] * 2)
    evidence = fit_evidence(rows)
    mine, unknown = evidence[evidence_key("direct", "ab" * 32, kind="judge")], evidence[evidence_key("direct", None, kind="judge")]
    assert (mine.plans, mine.grid[-1]["failures"], sorted(mine.ranges)) == (3, 0, ["mu", "y_obj"])
    assert (unknown.plans, unknown.grid[-1]["failures"]) == (2, 2)
    assert list(evidence) == sorted(evidence)  # stored in the order of their keys
