"""Stored rows re-scored by a calibration's evidence (judgeopt.verdict.rows.rescore), on evidence built by
hand: "likely" at p >= 0.95 for the direct planner, drawn over q̇_max 0.3-0.9 and the UR5 only."""

from __future__ import annotations

import pytest

from judgeopt.verdict.risk import Evidence, evidence_key
from judgeopt.verdict.rows import rescore

SHA = "0123456789abcdef0123"
EVIDENCE = {evidence_key("direct", SHA): Evidence(
    "direct", SHA, 0.95, [{"threshold": 0.5, "n": 300, "failures": 10, "bound": 0.055},
                          {"threshold": 0.95, "n": 200, "failures": 0, "bound": 0.015}],
    {"n": 0, "successes": 0, "floor": 0.0}, plans=300, ranges={"qdot_max": [0.3, 0.9], "mu": [1.0, 3.0]})}


def _row(p: float, qdot_max: float = 0.6, **extra) -> dict:
    return {"method": "direct", "judge_sha256": SHA, "predicted_success": p, "success_probability": p,
            "probability_source": "judge", "max_constraint_violation": 0.0, "environment": {"mu": 2.0},
            "limits": {"qdot_max": qdot_max}, **extra}


@pytest.mark.parametrize("p, verdict", [(0.96, "likely"), (0.9, "uncertain"), (0.4, "unlikely")])
def test_inside_the_evidence_a_row_is_likely_only_above_its_threshold(p, verdict):
    rows = [_row(p)]
    rescore(rows, {}, EVIDENCE, 0.02)
    assert rows[0]["verdict"] == verdict and rows[0]["likely_at"] == 0.95


@pytest.mark.parametrize("p, verdict", [(0.96, "likely"), (0.9, "uncertain")])
def test_a_row_beyond_the_evidence_is_unchecked_and_held_to_the_threshold_set_inside(p, verdict):
    rows = [_row(p, qdot_max=1.0)]  # the evidence was drawn up to 0.9 m/s
    rescore(rows, {}, EVIDENCE, 0.02)
    assert rows[0]["verdict"] == verdict and rows[0]["likely_at"] == 0.95
    assert "unchecked here" in rows[0]["risk"]["evidence"] and "qdot_max 1 (0.3-0.9)" in rows[0]["risk"]["evidence"]


def test_a_row_beyond_the_evidence_is_never_likely_at_a_risk_no_threshold_holds_inside():
    rows = [_row(0.999, qdot_max=1.0)]
    rescore(rows, {}, EVIDENCE, 0.001)
    assert rows[0]["verdict"] == "uncertain" and rows[0]["likely_at"] is None
    assert "no threshold holds a 0.1 % risk" in rows[0]["risk"]["evidence"]


def test_a_row_on_another_arm_is_not_judged_by_the_default_arms_evidence():
    rows = [_row(0.9, robot="kinova")]
    rescore(rows, {}, EVIDENCE, 0.02)
    assert rows[0]["verdict"] == "uncertain" and "robot kinova (ur5)" in rows[0]["risk"]["evidence"]
    assert "unchecked here" in rows[0]["risk"]["evidence"]


def test_a_risk_no_threshold_holds_calls_nothing_likely():
    rows = [_row(0.999)]
    rescore(rows, {}, EVIDENCE, 0.001)
    assert rows[0]["verdict"] == "uncertain" and rows[0]["likely_at"] is None


def test_a_row_without_limits_or_an_arm_is_the_default_arm_s_and_checked():
    rows = [{k: v for k, v in _row(0.96).items() if k != "limits"}]
    rescore(rows, {}, EVIDENCE, 0.02)
    assert rows[0]["verdict"] == "likely" and rows[0]["risk"]["n"] == 200
    assert "unchecked" not in rows[0]["risk"]["evidence"]
