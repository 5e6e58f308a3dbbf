"""The verdicts of stored result rows (PlanResult.to_json dicts, as evaluations keep them), as a
calibration and its held-out evidence say now: rows planned before either was fitted, or under
another risk, are re-scored, so every report counts the verdicts `solve` would print."""

from __future__ import annotations

from typing import Any

from judgeopt.robots import DEFAULT_ROBOT
from judgeopt.verdict.calibration import calibrate_rows
from judgeopt.verdict.risk import annotate
from judgeopt.verdict.rules import LIKELY, breaks, stood_behind, verdict_of


def reassess(rows: list[dict]) -> None:
    """`assess` for result rows (PlanResult.to_json dicts), e.g. after calibrate_rows added a
    calibrated probability to plans made before the calibration existed."""
    for r in rows:
        if r.get("success_probability") is None:  # no plan (or no judge): nothing to stand behind
            continue
        r["success_probability"], r["probability_source"] = stood_behind(
            r.get("predicted_success"), r.get("calibrated_success"), bool(r.get("calibration_covers")),
            r.get("raise_floor", 0.0))
        r["verdict"] = verdict_of(r["success_probability"], r["probability_source"], r.get("outside_judge_data"),
                                  breaks(r.get("max_constraint_violation")), r.get("likely_at", LIKELY))


def rescore(rows: list[dict], calibrators: dict, evidence: dict, risk: float, plan_model: Any = None) -> None:
    """Each row's p and verdict as the given calibration (its calibrators and plan model) and its
    evidence say at `risk` (rows planned before either was fitted say what they say now)."""
    calibrate_rows(rows, calibrators, plan_model)
    for r in rows:
        if r.get("method"):
            annotate(r, evidence, r["method"], r.get("judge_sha256"),
                     {**r.get("limits", {}), **r["environment"], "robot": r.get("robot", DEFAULT_ROBOT)}, risk)
    reassess(rows)
