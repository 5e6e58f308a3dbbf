"""Summaries of an evaluated table: Markdown, CSV and a bar chart beside the paper's figures."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from judgeopt.evaluate.tables import Row
from judgeopt.files import atomic_write, save_figure
from judgeopt.formats.table_csv import write_records


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson interval of a success rate: honest error bars for 100 trials."""
    if n == 0:
        return (math.nan, math.nan)
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return (max(0.0, c - h), min(1.0, c + h))  # inside [0, 1] already, but for rounding at 0 and n


def cell(v, fmt: str, suffix: str = "") -> str:
    """A table cell: the value formatted, or "-" where there is none (None or NaN)."""
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:{fmt}}{suffix}"


#: a plan holds a constraint when its residual is at most this (in the constraint's units): the
#: target the direct solve is held to on [constraints] it was given
HELD_TOL = 1e-6
#: residuals every plan has; any other is of the problem's [constraints]
BASE_RESIDUALS = frozenset({"q_min", "q_max", "qdot_min", "qdot_max", "f_min", "f_max", "q_end", "qdot_end", "start",
                            "dynamics"})


def violations(rows: list[dict]) -> dict:
    """Over the plans among `rows` (result rows with residuals): the worst constraint violation and
    the constraint it is of, and how many plans held every constraint (limits, terminal state, model
    and [constraints]) to HELD_TOL."""
    checked = [r for r in rows if r.get("max_constraint_violation") is not None]
    worst = max(checked, key=lambda r: r["max_constraint_violation"], default=None)
    return {"violation_max": None if worst is None else float(worst["max_constraint_violation"]),
            "worst_constraint": None if worst is None else worst.get("worst_constraint"),
            "held_plans": sum(r["max_constraint_violation"] <= HELD_TOL for r in checked),
            "plans_checked": len(checked)}


def violation_cells(s: dict) -> str:
    """The two Markdown cells of `violations`: worst violation (its constraint), plans that held every one."""
    if not s.get("plans_checked"):
        return "| - | - |"
    worst = f"{s['violation_max']:.1e}" + (f" ({s['worst_constraint']})" if s["violation_max"] > HELD_TOL
                                          and s.get("worst_constraint") else "")
    return f"| {worst} | {s['held_plans']}/{s['plans_checked']} |"


#: reliability bins: the planners' predictions crowd near 1, so the upper bins are narrow
BINS = (0.0, 0.5, 0.8, 0.9, 0.95, 0.98, 0.99, 1.0)


def reliability(pred: np.ndarray, outcome: np.ndarray, bins=BINS) -> list[dict]:
    """Per bin of predicted success: count, mean predicted, observed rate (simulated)."""
    pred, outcome = np.asarray(pred, float), np.asarray(outcome, float)
    idx = np.clip(np.digitize(pred, bins[1:-1], right=True), 0, len(bins) - 2)
    return [{"lo": bins[b], "hi": bins[b + 1], "n": int((idx == b).sum()),
             "predicted": float(pred[idx == b].mean()), "observed": float(outcome[idx == b].mean())}
            for b in range(len(bins) - 1) if (idx == b).any()]


def calibration_error(pred: np.ndarray, outcome: np.ndarray, bins=BINS) -> float:
    """Expected calibration error: the count-weighted |predicted - observed| over the bins."""
    cells = reliability(pred, outcome, bins)
    n = sum(c["n"] for c in cells)
    return float(sum(c["n"] * abs(c["predicted"] - c["observed"]) for c in cells) / n) if n else math.nan


def _judged(rs: list[dict]) -> list[dict]:
    return [r for r in rs if r.get("predicted_success") is not None and r.get("simulated_success") is not None]


def summarise(rows: list[Row], results: dict[str, list[dict]]) -> list[dict]:
    out = []
    for row in rows:
        rs = [r for r in results[row.key] if r.get("simulated_success") is not None]
        k, n = sum(r["simulated_success"] for r in rs), len(rs)
        lo, hi = wilson(k, n)
        judged = _judged(rs)
        pred = [r["predicted_success"] for r in judged]
        sim = [float(r["simulated_success"]) for r in judged]
        # only where the map covers the environment and limits: outside, `solve` prints the judge's p, not the map's
        cal = [r for r in judged if r.get("calibrated_success") is not None and r.get("calibration_covers")]
        cpred = [r["calibrated_success"] for r in cal]
        csim = [float(r["simulated_success"]) for r in cal]
        out.append({"row": row.name, "method": row.method, "judge": row.judge or "-",
                    "environment": row.env_label, "n": n, "successes": k,
                    "success_pct": 100 * k / n if n else math.nan, "ci95_low_pct": 100 * lo, "ci95_high_pct": 100 * hi,
                    "paper_pct": row.paper,
                    "predicted_mean": float(np.mean(pred)) if pred else None,
                    "calibration_gap_pct": 100 * float(np.mean(pred) - np.mean(sim)) if pred else None,
                    "ece": calibration_error(pred, sim) if pred else None,
                    "calibrated_mean": float(np.mean(cpred)) if cal else None,
                    "calibrated_gap_pct": 100 * float(np.mean(cpred) - np.mean(csim)) if cal else None,
                    "calibrated_ece": calibration_error(cpred, csim) if cal else None,
                    "calibration_fitted_on_these_envs": sum(bool(r.get("calibration_fitted_on_env")) for r in cal),
                    "violation_max": max((r["max_constraint_violation"] for r in rs), default=None),
                    "constraints_set": any(set(r.get("residuals") or ()) - BASE_RESIDUALS for r in results[row.key]),
                    **{k: v for k, v in violations(results[row.key]).items() if k != "violation_max"},
                    "time_median_s": float(np.median([r["solve_time_s"] for r in rs])) if rs else None})
    return out


def markdown(summary: list[dict], title: str) -> str:
    """The table; with a column of plans that held every constraint where the problem has [constraints]."""
    held = any(s.get("constraints_set") for s in summary)
    lines = [f"### {title}", "",
             "| row | planner | environment | simulated success | 95 % CI | paper | mean predicted | predicted - simulated | ECE "
             "| calibrated | calibrated - simulated | worst violation | " + (f"held every constraint ({HELD_TOL:g}) | "
                                                                           if held else "") + "median time |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|" + ("---|" if held else "") + "---|"]
    reused = sum(s["calibration_fitted_on_these_envs"] for s in summary)
    for s in summary:
        pred = f"{s['predicted_mean']:.3f}" if s["predicted_mean"] is not None else "-"
        gap = f"{s['calibration_gap_pct']:+.0f} pts" if s["calibration_gap_pct"] is not None else "-"
        ece = f"{s['ece']:.3f}" if s["ece"] is not None else "-"
        cmean = f"{s['calibrated_mean']:.3f}" if s["calibrated_mean"] is not None else "-"
        cgap = f"{s['calibrated_gap_pct']:+.0f} pts" if s["calibrated_gap_pct"] is not None else "-"
        viol = f"{s['violation_max']:.1e}" if s["violation_max"] is not None else "-"
        if held:
            cells = violation_cells(s)  # "| worst (its constraint) | held/checked |"
            viol = cells[2:-2]
        t = s["time_median_s"]
        tt = "-" if t is None or s["method"] == "random" else (f"{t * 1e3:.2f} ms" if t < 1 else f"{t:.2f} s")
        paper = f"{s['paper_pct']:g} %" if s["paper_pct"] is not None else "-"
        lines.append(f"| {s['row']} | {s['method']} | {s['environment']} | {s['successes']}/{s['n']} ({s['success_pct']:.0f} %) "
                     f"| {s['ci95_low_pct']:.0f}-{s['ci95_high_pct']:.0f} % | {paper} | {pred} | {gap} | {ece} | {cmean} | {cgap} "
                     f"| {viol} | {tt} |")
    if reused:  # the calibration saw some of these very environments: not a held-out test
        lines += ["", f"Warning: {reused} of these plans' environments were among those the calibration was fitted on; "
                  "its figures here are not held out (evaluate with another --seed)."]
    return "\n".join(lines) + "\n"


def write_report(summary: list[dict], out: Path, name: str, title: str,
                 results: dict[str, list[dict]] | None = None, rows: list[Row] | None = None) -> list[Path]:
    """Markdown, CSV and bar chart; with the per-plan results, also the reliability diagram."""
    out = Path(out)
    md = out / f"{name}.md"
    atomic_write(md, markdown(summary, title))
    csv_path = write_records(out / f"{name}.csv", summary)
    files = [md, csv_path, save_figure(plot(summary, title), out / f"{name}.png")]
    if results is not None and rows is not None:
        files.append(save_figure(plot_reliability(rows, results, title), out / f"{name}_reliability.png"))
    return files


def _label(row: Row) -> str:
    return row.name if row.name == row.method else f"{row.name} / {row.method}"


def zoomed_range(values: list[float], step: float = 0.05) -> tuple[float, float]:
    """Axis limits around `values` in [0, 1], widened to multiples of `step` with a margin: the
    planners' predictions crowd near 1, and on 0-1 axes their reliability points overlap."""
    if not values:
        return (0.0, 1.0)
    lo = max(0.0, math.floor((min(values) - 0.4 * step) / step) * step)
    hi = min(1.0, math.ceil((max(values) + 0.4 * step) / step) * step)
    pad = 0.02 * (hi - lo)
    return (lo - pad, hi + pad)


def plot_reliability(rows: list[Row], results: dict[str, list[dict]], title: str) -> Figure:
    """Predicted against simulated success per planner row (marker area ~ plans in the bin), the
    axes zoomed to the points (the same range on both, so the diagonal is the calibrated line)."""
    fig = Figure(figsize=(5.5, 5))
    ax = fig.subplots()
    points: list[float] = []
    for row in rows:
        judged = _judged(results.get(row.key, []))
        if not judged:
            continue
        cells = reliability([r["predicted_success"] for r in judged], [r["simulated_success"] for r in judged])
        ece = calibration_error([r["predicted_success"] for r in judged], [r["simulated_success"] for r in judged])
        ax.plot([c["predicted"] for c in cells], [c["observed"] for c in cells], marker="o", lw=1,
                label=f"{_label(row)} (ECE {ece:.2f})")
        ax.scatter([c["predicted"] for c in cells], [c["observed"] for c in cells],
                   s=[8 + 2 * c["n"] for c in cells], alpha=0.3)
        points += [c[k] for c in cells for k in ("predicted", "observed")]
    lo, hi = zoomed_range(points)
    ax.plot([lo, hi], [lo, hi], color="0.6", lw=1, ls="--", label="calibrated")
    ax.set_xlabel("predicted success (judge)")
    ax.set_ylabel("simulated success rate")
    ax.set_xlim(lo, hi)
    ax.set_ylim(lo, hi)
    ax.set_aspect("equal")
    ax.set_title("reliability: " + title, fontsize=8)
    ax.legend(fontsize=6, loc="upper left")
    fig.tight_layout()
    return fig


def plot(summary: list[dict], title: str) -> Figure:
    """Simulated success per row with its 95 % interval, beside the paper's figure."""
    labels = [f"{s['row']}\n{s['method']}" for s in summary]
    x = np.arange(len(summary))
    ours = np.array([s["success_pct"] for s in summary])
    err = np.clip([[s["success_pct"] - s["ci95_low_pct"] for s in summary],
                   [s["ci95_high_pct"] - s["success_pct"] for s in summary]], 0, None)  # rounding at 0 % / 100 %
    paper = np.array([np.nan if s["paper_pct"] is None else s["paper_pct"] for s in summary])
    fig = Figure(figsize=(max(6, 1.0 * len(summary)), 4))
    ax = fig.subplots()
    ax.bar(x - 0.2, ours, 0.4, yerr=err, capsize=3, label="judgeopt (simulated, 95 % CI)")
    ax.bar(x + 0.2, paper, 0.4, color="0.7", label="paper")
    ax.set_xticks(x, labels, fontsize=7, rotation=30, ha="right")
    ax.set_ylabel("success rate [%]")
    ax.set_ylim(0, 105)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _rate(k: int, n: int) -> float | None:
    return 100.0 * k / n if n else None


def verdict_stats(rows: Sequence[dict], methods: Sequence[str], bins: Sequence[float]) -> list[dict]:
    """Per planner, over replayed plans with a verdict: plans, successes, likely / likely and failed
    (with the Clopper-Pearson upper bound on that rate), uncertain, unlikely / unlikely and
    succeeded, the outside-the-data, limit-breaking and calibrated counts, mean p, ECE and the
    reliability cells."""
    from judgeopt.verdict.rules import BREAKS, OUTSIDE, UNCERTAIN
    from judgeopt.verdict.risk import upper_bound

    planned = [r for r in rows if r.get("method") and r.get("verdict") is not None
               and r.get("simulated_success") is not None]
    per = []
    for m in methods:
        rs = [r for r in planned if r["method"] == m]
        p = np.array([r["success_probability"] for r in rs], float)
        sim = np.array([float(r["simulated_success"]) for r in rs])
        likely = [r for r in rs if r["verdict"] == "likely"]
        unlikely = [r for r in rs if r["verdict"] == "unlikely"]
        failed = sum(not r["simulated_success"] for r in likely)
        per.append({"method": m, "plans": len(rs), "successes": int(sim.sum()),
                    "likely": len(likely), "likely_failed": failed, "likely_failed_pct": _rate(failed, len(likely)),
                    "likely_failed_bound_pct": 100 * upper_bound(failed, len(likely)) if likely else None,
                    "uncertain": sum(r["verdict"] == UNCERTAIN for r in rs),
                    "unlikely": len(unlikely), "unlikely_succeeded": sum(bool(r["simulated_success"]) for r in unlikely),
                    "outside_judge_data": sum(r["verdict"] == OUTSIDE for r in rs),
                    "breaks_limits": sum(r["verdict"] == BREAKS for r in rs),
                    "calibrated": sum(r.get("probability_source") == "calibrated" for r in rs),
                    "mean_p": float(p.mean()) if len(p) else None, "success_pct": _rate(int(sim.sum()), len(rs)),
                    "ece": calibration_error(p, sim, bins) if len(p) else None,
                    "reliability": reliability(p, sim, bins) if len(p) else []})
    return per
