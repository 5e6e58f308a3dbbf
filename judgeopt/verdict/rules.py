"""The verdict a plan gets, from numbers alone: the p judgeopt stands behind (the judge's, or a
calibrated one where a calibration covers the plan), and the word for it (likely, uncertain,
unlikely, outside the judge's data, breaks a hard limit); which plan of several to run.

Why here, apart from the planners: every planner's result, every stored evaluation row and the
service's answers are judged by these same rules, and the rules read a result's fields only
(a PlanResult or its JSON row), so they import nothing of the planners.
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

from judgeopt.verdict.risk import HOLD_TOL, calibration_applies, capped

#: below this success probability a plan is "unlikely"; at or above it "likely" where no held-out
#: evidence sets a higher threshold for the planner (judgeopt.verdict.risk: "risk unchecked")
LIKELY = 0.5
#: the verdict between "unlikely" and "likely": p >= LIKELY, below the threshold the held-out evidence
#: sets for the planner at the risk asked for (or no threshold holds that risk)
UNCERTAIN = "uncertain"
#: the verdict on a plan whose request lies outside what the judge learnt from, where no
#: calibration fitted on replayed outcomes covers it: its p is a number nobody checked
OUTSIDE = "outside the judge's data"
#: the verdict on a plan that breaks a hard constraint by more than HOLD_TOL, whatever its p: a plan
#: the robot must not run is never "likely"
BREAKS = "breaks a hard limit"
#: what judge / success p / verdict mean, for `solve --explain` and the table's legend
LEGEND = ("judge: the judge's own probability that the plan succeeds; success p: the probability judgeopt stands "
          "behind: 'calibrated' where a calibration fitted on replayed outcomes of this planner covers the plan "
          "(limits, environment and the judge's p; it raises a judge's p below 0.5 only as far as held-out outcomes "
          "back), else the judge's, marked uncalibrated; verdict: likely at success p at or above the threshold "
          "that held-out replayed plans of this planner, on this arm and with the same kind of p (calibrated or the "
          "judge's own), set for the risk asked for (--risk; where none were "
          f"replayed, at p >= {LIKELY}, risk unchecked), {UNCERTAIN} between {LIKELY} and that threshold, "
          f"unlikely below {LIKELY}, or '{OUTSIDE}' where the request lies outside the ranges the judge "
          f"learnt from and no calibration covers it, or '{BREAKS}' where the plan breaks a hard limit by more than "
          f"{HOLD_TOL:g} in its units, whatever its p; simulated: the plan replayed in the physics simulation")


def stood_behind(predicted: float | None, calibrated: float | None, covers: bool,
                 raise_floor: float) -> tuple[float | None, str]:
    """The probability the tool stands behind, and its source: the calibrated one where a
    calibration fitted on replayed outcomes of this planner setting covers the environment (and
    limits), else the judge's own (never checked against outcomes there; a judge is most
    over-confident exactly where a planner maximised it). A calibration map is not trusted
    outside the ranges it was fitted on: it extrapolates its success rate, not the physics; and
    it lifts a judge's p below 0.5 no higher than `raise_floor`, the lower bound held-out
    outcomes of such lifted plans give (judgeopt.verdict.risk; none: no lift)."""
    if calibration_applies(calibrated, covers):
        return capped(predicted, float(calibrated), raise_floor), "calibrated"
    return (None, "") if predicted is None else (float(predicted), "judge")


def breaks(worst_violation: float | None) -> bool:
    """Whether a plan whose worst constraint residual is this breaks a hard limit (beyond HOLD_TOL)."""
    return worst_violation is not None and worst_violation > HOLD_TOL


def verdict_of(p: float | None, source: str = "", outside: Sequence[str] | None = None,
               broken: bool = False, likely_at: float | None = LIKELY) -> str | None:
    """BREAKS where the plan breaks a hard limit (`broken`), whatever p; OUTSIDE where `outside`
    names what lies beyond the judge's data and p is the judge's own (a calibrated p was checked
    there); else "unlikely" below LIKELY, "likely" at p >= `likely_at` (the held-out evidence's
    threshold at the risk asked for; LIKELY where there is no evidence), UNCERTAIN between them or
    where `likely_at` is None (evidence, but no threshold holds the risk); None without a p."""
    if p is None:
        return None
    if broken:
        return BREAKS
    if outside and source != "calibrated":
        return OUTSIDE
    if p < LIKELY:
        return "unlikely"
    return "likely" if likely_at is not None and p >= likely_at else UNCERTAIN


def _get(r: Any, key: str) -> Any:
    return r.get(key) if isinstance(r, Mapping) else getattr(r, key)


def recommended(results: Sequence[Any]) -> Any | None:
    """The plan a user should run, of PlanResults or their JSON rows: among plans with a verdict,
    those that hold the hard constraints (HOLD_TOL) first, then those whose verdict is not OUTSIDE,
    then those whose p was calibrated on replayed outcomes (a judge's own p, highest exactly where a
    planner maximised it, is no rival to a checked one), then those called likely (at the risk asked
    for: an uncertain plan's higher p carries no stated risk), then the highest p judgeopt stands behind
    (success_probability, never the judge's own); ties go to the first listed. None: no plan."""
    judged = [r for r in results if _get(r, "verdict") is not None]
    if not judged:
        return None

    def rank(r: Any) -> tuple[bool, bool, bool, bool, float]:
        return (not breaks(_get(r, "max_constraint_violation")), _get(r, "verdict") != OUTSIDE,
                _get(r, "probability_source") == "calibrated", _get(r, "verdict") == "likely",
                _get(r, "success_probability"))

    return max(judged, key=rank)  # max keeps the first of equal ranks


def overall_verdict(results: Sequence[Any]) -> str:
    """The verdict on the plan to run: "infeasible" where the limits admit no plan, else the
    recommended plan's verdict ("unlikely" where no planner made a plan)."""
    if any(_get(r, "status") == "infeasible" for r in results):
        return "infeasible"
    top = recommended(results)
    return "unlikely" if top is None else _get(top, "verdict")


def assess(result: Any) -> Any:
    """Set a planned result's (a PlanResult's) success_probability and probability_source (stood_behind)."""
    if result.plan is not None:
        result.success_probability, result.probability_source = stood_behind(
            result.predicted_success, result.info.get("calibrated_success"), bool(result.info.get("calibration_covers")),
            result.info.get("raise_floor", 0.0))
    return result
