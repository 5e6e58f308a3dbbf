"""The risk behind "likely": a threshold on the printed p, chosen from held-out replayed outcomes.

A calibration map is fitted on some sweeps; one step away from them it can be wrong
(issue 43: 15-18 % of plans called likely failed on settings drawn across the edge band). So
"likely" is not p >= 0.5. Per planner and judge, plans replayed on settings the calibration was
NOT fitted on (`judgeopt evaluate band`) are the evidence: for each threshold t of a fixed grid,
the plans that hold their limits and would be called likely at p >= t, and how many failed. A
request at risk r is called likely at the smallest t whose one-sided Clopper-Pearson upper bound
on the failure rate (at the evidence's confidence, 95 % by default) is <= r; where no t is, the
planner cannot say likely at that risk ("uncertain"). A planner and judge with no evidence has
no stated risk: its verdict says so ("risk unchecked").

Evidence is kept apart by the kind of p (`KINDS`): a calibrated p and the judge's own (a plan no
calibration covers, e.g. one planned under a constraint set) are different numbers, and one
threshold shared between them let the judge's own p borrow the calibrated p's record: every
plan called likely that failed on the arms' held-out bands (seeds 606, 707) had the judge's own p.

The calibrated p may raise a judge's p below 0.5 only as far as the evidence's lower confidence
bound on the success rate of the plans it raised so (`raise_floor`): on the band, 4 of 19 such
plans succeeded where the map said 0.8-0.9.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, Iterable, Mapping

import numpy as np

from judgeopt.robots import DEFAULT_ROBOT

#: the default risk: at most this failure rate among plans called likely, as an upper confidence bound
RISK = 0.02
#: the default confidence of the bounds
CONFIDENCE = 0.95
#: the thresholds a risk may select (fixed, so the choice cannot be tuned to single outcomes)
GRID = (0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.97, 0.98, 0.99, 0.995, 0.999)
#: a value further than this share of a range's width beyond it lies outside it (the evidence's, a fit's)
RANGE_MARGIN = 0.02
#: below this judge p a calibrated p above it is a raise the evidence must back (the verdict's "likely" line)
RAISE_FROM = 0.5
#: a plan holds its hard constraints when its worst residual is at most this (in the constraint's units);
#: one that breaks them is never likely, and the plan recommended to run holds them where any does
HOLD_TOL = 1e-3


def upper_bound(failures: int, n: int, confidence: float = CONFIDENCE) -> float:
    """One-sided Clopper-Pearson upper bound on a rate seen `failures` times in `n` (1.0 for n = 0)."""
    from scipy.special import betaincinv

    if n == 0 or failures >= n:
        return 1.0
    return float(betaincinv(failures + 1, n - failures, confidence))


def lower_bound(successes: int, n: int, confidence: float = CONFIDENCE) -> float:
    """One-sided Clopper-Pearson lower bound on a rate seen `successes` times in `n` (0.0 for none)."""
    return 1.0 - upper_bound(n - successes, n, confidence) if successes else 0.0


#: the kinds of p evidence is kept for, apart: a calibrator's p, the judge's own (rules.stood_behind's sources),
#: and a plan model's (judgeopt.verdict.plan_model; printed as calibrated, its threshold its own)
KINDS = ("calibrated", "judge", "plans")
#: what a row's `calibrated_by` says where a plan model's p stands (a calibrator's rows carry none)
PLAN_MODEL = "plan model"


def evidence_key(method: str, judge_sha256: str | None, robot: str = DEFAULT_ROBOT, kind: str = "") -> str:
    """Evidence is per planner, judge, arm and kind of p (KINDS; "": both, as stored before they were kept
    apart), over every limit and constraint set it was drawn at (the default arm's keys read as before
    arms were chosen)."""
    key = f"{method}@{(judge_sha256 or 'unknown')[:16]}"
    key = key if robot == DEFAULT_ROBOT else f"{key}@{robot}"
    return f"{key}#{kind}" if kind else key


def whose(key: str) -> str:
    """The planner, judge and arm of an evidence key (evidence_key without its kind of p)."""
    return key.split("#", 1)[0]


def calibration_applies(calibrated: float | None, covers: Any) -> bool:
    """Whether a plan is judged by its calibrated p: there is one, and the calibration covers the
    plan (rules.stood_behind stands behind it; kind_of names it)."""
    return calibrated is not None and bool(covers)


def kind_of(row: Mapping[str, Any]) -> str:
    """The kind of p a plan's result (its info, or its JSON row) is judged by: "plans" where a plan model's
    p stands, "calibrated" where a calibrator covers it, else the judge's own."""
    if not calibration_applies(row.get("calibrated_success"), row.get("calibration_covers")):
        return "judge"
    return "plans" if row.get("calibrated_by") == PLAN_MODEL else "calibrated"


@dataclass
class Evidence:
    """One planner's (and judge's) held-out outcomes, reduced to what a verdict needs."""

    method: str
    judge_sha256: str | None
    confidence: float
    grid: list[dict[str, float]]  # [{threshold, n, failures, bound}], thresholds ascending
    raised: dict[str, float]  # {n, successes, floor}: plans whose judge p < RAISE_FROM and calibrated p >= it
    plans: int = 0
    ranges: dict[str, list[float]] = field(default_factory=dict)  # each limit's and variable's [lo, hi] in the plans
    sources: list[str] = field(default_factory=list)  # the evaluation folders it was counted from
    #: the arms the plans were replayed on (evidence stored before arms were chosen: the default's)
    robots: list[str] = field(default_factory=lambda: [DEFAULT_ROBOT])
    #: the kind of p its plans were judged by (KINDS; "": both, as stored before they were kept apart)
    kind: str = ""

    @property
    def subject(self) -> str:
        """Its planner, in words with the kind of p: what a threshold is a threshold on."""
        of = {"calibrated": " with a calibrated p", "judge": " with the judge's own p",
              "plans": " with a plan model's p"}.get(self.kind, "")
        return self.method + of

    @property
    def raise_floor(self) -> float:
        return float(self.raised.get("floor", 0.0))

    def outside(self, values: Mapping[str, Any]) -> list[str]:
        """The limits and variables (of `values`) beyond the ranges the evidence was drawn over, as
        `f_max 22.5 (11-15.5)`: the risk it states was measured inside them only."""
        robot = values.get("robot", DEFAULT_ROBOT)
        out = [] if robot in self.robots else [f"robot {robot} ({', '.join(self.robots)})"]
        for k, (lo, hi) in self.ranges.items():
            v = values.get(k)
            tol = 1e-9 + RANGE_MARGIN * (hi - lo)
            if isinstance(v, (int, float)) and not lo - tol <= v <= hi + tol:
                out.append(f"{k} {v:g} ({lo:g}-{hi:g})")
        return out

    def at(self, risk: float = RISK) -> dict[str, float] | None:
        """The grid row that sets "likely" at this risk (the lowest threshold whose bound is <= the
        risk), or None where none is."""
        return next((g for g in self.grid if g["bound"] <= risk), None)  # no plans: bound 1

    def describe(self, risk: float = RISK) -> str:
        row = self.at(risk)
        pct = f"{100 * self.confidence:g} %"
        if row is None:
            best = min(self.grid, key=lambda g: g["bound"])
            return (f"no threshold holds a {100 * risk:g} % risk on {self.plans} held-out plans of {self.subject} "
                    f"(the best: p >= {best['threshold']:g}, {int(best['failures'])} of {int(best['n'])} failed, "
                    f"{pct} bound {100 * best['bound']:.1f} %), so it is never called likely at that risk")
        return (f"likely at p >= {row['threshold']:g}: of {int(row['n'])} held-out plans of {self.subject} there, "
                f"{int(row['failures'])} failed ({pct} upper bound {100 * row['bound']:.1f} % <= risk {100 * risk:g} %)")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "Evidence":
        return cls(**{k: d[k] for k in cls.__dataclass_fields__ if k in d})


def annotate(target: dict[str, Any], evidence: Mapping[str, Evidence], method: str, judge_sha256: str | None,
             values: Mapping[str, Any], risk: float = RISK) -> None:
    """What a plan's result (its info, or its JSON row, its calibration already annotated) carries from
    the evidence of its planner, judge, arm and kind of p (kind_of) at `risk`, where its limits and environment (`values`) lie inside the evidence's
    ranges: raise_floor, likely_at (None: no threshold holds the risk) and risk (the row that sets
    it, described). Where there is no evidence, nothing: "likely" stays p >= 0.5, its risk unchecked.
    Where the plan lies outside the evidence's ranges, its risk is unchecked too, but "likely" is held to
    the threshold set inside them, and never where none holds there: an edge the evidence missed (the
    arms' constrained bands of seed 818 at q̇_max 0.300-0.315 m/s: 7 of 24 such plans failed at p >= 0.5)
    is no safer than the band it borders. What an earlier annotation wrote is dropped first."""
    for key in ("raise_floor", "likely_at", "risk"):
        target.pop(key, None)
    robot = values.get("robot", DEFAULT_ROBOT)
    # this kind of p's, else both kinds' (stored before they were kept apart); none on this arm: the
    # default arm's, whose `outside` then says the plans were replayed on another arm
    ev = next((evidence[k] for arm in (robot, DEFAULT_ROBOT) for kind in (kind_of(target), "")
               if (k := evidence_key(method, judge_sha256, arm, kind)) in evidence), None)
    if ev is None:
        return
    beyond = ev.outside(values)
    row = ev.at(risk)
    if beyond:  # unchecked here, and never held to less than where it was checked
        where = f"the held-out plans of {ev.subject} were drawn inside other ranges ({', '.join(beyond)})"
        if row is None:
            target.update(likely_at=None, risk={"risk": risk, "evidence": f"unchecked here, as {where}; where they "
                                                f"were drawn no threshold holds a {100 * risk:g} % risk, so it is never "
                                                "called likely"})
        else:
            target.update(likely_at=row["threshold"], risk={
                "risk": risk, "evidence": f"unchecked here: 'likely' is p >= {row['threshold']:g}, the threshold set "
                                          f"where they were drawn, as {where}"})
        return
    target.update(raise_floor=ev.raise_floor, likely_at=None if row is None else row["threshold"],
                  risk={"risk": risk, "confidence": ev.confidence, **(row or {}), "evidence": ev.describe(risk)})


def capped(predicted: float | None, calibrated: float, floor: float) -> float:
    """The calibrated p, where it raises a judge p below RAISE_FROM no higher than `floor` (or the judge's own)."""
    if predicted is None or predicted >= RAISE_FROM or calibrated <= predicted:
        return calibrated
    return min(calibrated, max(predicted, floor))


def fit_evidence(rows: Iterable[Mapping[str, Any]], confidence: float = CONFIDENCE,
                 grid: Iterable[float] = GRID) -> dict[str, Evidence]:
    """Per planner, judge, arm and kind of p (both kinds, even where one had no plans: its p is then
    never likely, not unchecked), from replayed result rows whose calibrated p was computed by the
    calibration the evidence is stored with (calibration.calibrate_rows). Counted: plans with a
    p that hold their limits and lie inside the judge's data or a calibration's cover."""
    by: dict[tuple[str, str | None, str, str], list[Mapping[str, Any]]] = {}
    for r in rows:
        if r.get("method") and r.get("simulated_success") is not None and r.get("predicted_success") is not None:
            whose_ = (r["method"], r.get("judge_sha256"), r.get("robot", DEFAULT_ROBOT))
            for kind in ("calibrated", "judge"):  # a plan model's kind only where its p stood
                by.setdefault((*whose_, kind), [])
            by.setdefault((*whose_, kind_of(r)), []).append(r)
    out = {}
    for (method, sha, robot, kind), rs in sorted(by.items(), key=lambda kv: evidence_key(*kv[0])):
        y = np.array([bool(r["simulated_success"]) for r in rs], bool)
        judge = np.array([r["predicted_success"] for r in rs], float)
        covered = kind in ("calibrated", "plans")
        cal = np.array([r["calibrated_success"] for r in rs], float) if covered else judge
        raised = covered & (judge < RAISE_FROM) & (cal >= RAISE_FROM)
        floor = lower_bound(int(y[raised].sum()), int(raised.sum()), confidence)
        p = np.array([capped(j, c, floor) for j, c in zip(judge, cal)], float)
        eligible = np.array([(r.get("max_constraint_violation") or 0.0) <= HOLD_TOL
                             and (covered or not r.get("outside_judge_data")) for r in rs], bool)
        table = []
        for t in sorted(grid):
            s = eligible & (p >= t)
            n, k = int(s.sum()), int((~y[s]).sum())
            table.append({"threshold": float(t), "n": n, "failures": k, "bound": round(upper_bound(k, n, confidence), 6)})
        values = [{**{k: v for k, v in r.get("limits", {}).items() if isinstance(v, (int, float))}, **r["environment"]}
                  for r in rs]
        common = set(values[0]).intersection(*values[1:]) if values else set()
        out[evidence_key(method, sha, robot, kind)] = Evidence(
            method, sha, confidence, table,
            {"n": int(raised.sum()), "successes": int(y[raised].sum()), "floor": round(floor, 6)}, plans=len(rs),
            ranges={k: [float(min(v[k] for v in values)), float(max(v[k] for v in values))] for k in sorted(common)},
            robots=[robot], kind=kind)
    return out
