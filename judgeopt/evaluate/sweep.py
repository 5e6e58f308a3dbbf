"""`judgeopt evaluate sweep`: held-out limit sets, where a scoop is possible and where it is not.

For every limit set and seeded environment (the same environments for every set): the two
planners and the CEM baseline (each plan replayed, with its success probability and verdict),
the no-judge baseline (random plans that satisfy the limits) and a feasibility search scored by
the simulator itself. An environment counts as feasible when any of them succeeded; where none
did, the honest statement is "no successful plan found in N tries". Per limit set this gives
what a user needs to trust a verdict: success where success was found possible, the verdict
where it was not, and whether the probabilities match the outcomes.

A set may hold constraints beyond the limits too ([constraints]: a_max, jerk_max, fdot_max,
window bounds): the generator never saw them, the direct solve (warm-started from it) holds
them, and every plan's worst violation is reported per set and planner beside how many plans
held every constraint to HELD_TOL. `random_constraint_sets` draws held-out ones that bind on
the generator's plans at the problem's limits (ConstraintRanges and the drawing of one set live in
judgeopt.planners.constraint_ranges, which `judgeopt refine --sample-constraints` draws from too).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from judgeopt.evaluate.report import HELD_TOL, cell, violation_cells, violations
from judgeopt.evaluate.tables import Row
from judgeopt.planners.base import REGISTRY, planner_names
from judgeopt.planners.constraint_ranges import CONSTRAINT_DRAWS, ConstraintRanges, draw_constraints  # noqa: F401
from judgeopt.planners.constraint_ranges import corners
from judgeopt.planners.problem import SECTIONS, Problem, ProblemError, load_problem
from judgeopt.planners.constraints import is_constraint_key
from judgeopt.verdict.risk import HOLD_TOL

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: the default held-out limit sets: none is a shipped problem's, one (q̇_max 0.6 with f_max 18 N)
#: leaves some high-friction scoops without any successful plan
DEFAULT_LIMIT_SETS = ("qdot_max=0.6,f_max=18", "qdot_max=0.3,f_min=5,f_max=25", "qdot_max=0.8,f_min=10,f_max=30",
                      "f_min=7.5,f_max=14", "qdot_max=0.5,f_min=3,f_max=12", "qdot_max=0.9,f_min=6,f_max=16")


@dataclass(frozen=True)
class LimitSet:
    """A label and the problem fields it overrides: limits, and [constraints] (bounds: a tuple of
    NAME:LO:HI@T0:T1 strings)."""

    label: str
    overrides: tuple[tuple[str, object], ...]


#: [constraints] fields a set may give one number each (a position axis' or force channel's all alike)
CONSTRAINT_NUMBERS = ("a_max", "jerk_max", "fdot_max", "joint_limit_scale")
def _constraint_pairs(problem: Problem) -> list[tuple[str, object]]:
    from judgeopt.planners.constraints import describe

    return [(k, tuple(v) if k == "bounds" else v) for k, v in describe(problem.constraints).items()]


def _label(pairs: list[tuple[str, object]]) -> str:
    return ", ".join(", ".join(v) if k == "bounds" else f"{k} {v:g}" for k, v in pairs)


def parse_limit_set(text: str) -> LimitSet:
    """`qdot_max=0.6,f_max=18,a_max=2,bound=f:0:12@0:0.4` (limit and [constraints] fields; bound
    repeatable), or a problem file whose limits and constraints are taken whole."""
    from judgeopt.planners.constraints import Bound, ConstraintError

    names = SECTIONS["limits"]
    if text.endswith(".toml"):
        from judgeopt.files import resolve

        p = load_problem(resolve(text))
        return LimitSet(Path(text).stem, tuple((k, float(getattr(p, k))) for k in names) + tuple(_constraint_pairs(p)))
    pairs: list[tuple[str, object]] = []
    bounds: list[str] = []
    allowed = (*names, *CONSTRAINT_NUMBERS, "bound")
    for item in filter(None, (t.strip() for t in text.split(","))):
        name, _, value = item.partition("=")
        name = name.strip().replace("-", "_")
        name = "bound" if name == "bounds" else name
        if name not in allowed:
            raise ProblemError(f"limit set {text!r}: {name!r} is not a limit or constraint; use {', '.join(allowed)} "
                               "(e.g. qdot_max=0.6,f_max=18,a_max=2,bound=f:0:12@0:0.4) or a problem .toml file")
        if name == "bound":
            try:
                bounds.append(Bound.parse(value.strip()).text)
            except ConstraintError as exc:
                raise ProblemError(f"limit set {text!r}: {exc}") from None
            continue
        try:
            x = float(value)
        except ValueError:
            raise ProblemError(f"limit set {text!r}: {value!r} is not a number for {name}") from None
        if name in CONSTRAINT_NUMBERS and not x > 0:
            raise ProblemError(f"limit set {text!r}: {name} = {value.strip()} must be a positive number")
        pairs.append((name, x))
    if bounds:
        pairs.append(("bounds", tuple(bounds)))
    if not pairs:
        raise ProblemError(f"limit set {text!r} names no limit or constraint (e.g. qdot_max=0.6,f_max=18 or "
                           "a_max=2,bound=f:0:12@0:0.4)")
    return LimitSet(_label(pairs), tuple(pairs))


def random_limit_sets(k: int, seed: int, ranges=None) -> list[LimitSet]:
    """k limit sets (q̇_max, f_min, f_max) drawn from `ranges` (default: the wide ranges
    refinement samples), seeded."""
    from judgeopt.planners.limits import CONDITION_NAMES, WIDE_LIMITS

    if k < 1:
        raise ProblemError(f"--random-limits {k}: need at least one limit set")
    draws = (ranges or WIDE_LIMITS).sample(np.random.default_rng([seed, 4241]), k)
    return [parse_limit_set(",".join(f"{n}={v:.3g}" for n, v in zip(CONDITION_NAMES, d))) for d in draws]


def random_constraint_sets(k: int, seed: int, problem: Problem, ranges: ConstraintRanges = ConstraintRanges(),
                           envs: list[dict[str, float]] | None = None) -> list[LimitSet]:
    """k constraint sets drawn (seeded) from `ranges`, each feasible at the problem's limits for
    every environment in `envs` (default: the corners of its environment ranges): one
    judgeopt.planners.constraint_ranges.draw_constraints per set from one rng, which redraws a set
    that is not feasible, up to CONSTRAINT_DRAWS times."""
    if k < 1:
        raise ProblemError(f"--random-constraints {k}: need at least one constraint set")
    rng = np.random.default_rng([seed, 4243])
    envs = envs if envs is not None else corners(problem)
    out = []
    for _ in range(k):
        try:
            overrides = draw_constraints(rng, problem, ranges, envs)
        except ProblemError as exc:
            raise ProblemError(f"--random-constraints: {exc}") from None
        pairs = list(overrides.items())
        out.append(LimitSet(_label(pairs), tuple(pairs)))
    return out


def sweep_methods() -> tuple[str, ...]:
    """The planners a sweep runs by default: the paper's and the baselines (PlannerSpec.paper, .baseline)."""
    return tuple(n for n, s in REGISTRY.items() if s.paper or s.baseline)


def sweep_rows(problem: Problem, sets: list[LimitSet], vary: tuple[str, tuple[float, float]] | None,
               models_dir: str = "models", methods: tuple[str, ...] | None = None,
               baselines: bool = True) -> tuple[list[Row], list[str]]:
    """Rows for run_table (planners, no-judge, search per set) and notes on what was left out
    (a planner that needs a generator where none covers a set's limits). `methods`: default
    sweep_methods(). A limit set that contradicts the problem's other fields is an error naming
    the set; one whose limits make some environments unreachable is run (those are reported
    infeasible)."""
    from judgeopt.planners.loaded import choose_models

    rows, notes = [], []
    for ls in sets:
        try:
            p = problem.with_overrides(**dict(ls.overrides))
        except ProblemError as exc:
            raise ProblemError(f"limit set '{ls.label}': {exc}") from None
        for m in methods or sweep_methods():
            if "generator" in REGISTRY[m].needs and choose_models(p, (m,), None, None, models_dir).generator is None:
                notes.append(f"{ls.label}: no generator in {models_dir}/ covers these limits, so no {m} row")
                continue
            rows.append(Row(ls.label, m, None, vary, overrides=ls.overrides))
        if baselines:
            rows += [Row(ls.label, m, None, vary, overrides=ls.overrides) for m in ("nojudge", "search")]
    return rows, notes


def _by_env(rs: list[dict]) -> dict[int, list[dict]]:
    out: dict[int, list[dict]] = {}
    for r in rs:
        out.setdefault(r["env_index"], []).append(r)
    return out


def _mean(values) -> float | None:
    values = [float(v) for v in values]
    return float(np.mean(values)) if values else None


def held_constraints(result: dict) -> bool:
    """Whether a result's plan held every one of [constraints] to HOLD_TOL (the paper's boxes are
    the planners' own to report)."""
    return all(v <= HOLD_TOL for k, v in (result.get("residuals") or {}).items() if is_constraint_key(k))


def summarise_sweep(sets: list[LimitSet], rows: list[Row], results: dict[str, list[dict]],
                    methods: tuple[str, ...] | None = None) -> list[dict]:
    """One line per (limit set, planner asked for: default sweep_methods()), with the set's
    feasibility figures repeated."""
    asked = [m for m in planner_names() if m in (methods or sweep_methods())]
    out = []
    for ls in sets:
        mine = {r.method: _by_env(results[r.key]) for r in rows if r.name == ls.label}
        envs = sorted({e for per in mine.values() for e in per})
        infeasible = {e for e in envs if any(r["status"] == "infeasible" for per in mine.values()
                                             for r in per.get(e, []))}
        # a success is a witness only where its plan held [constraints] (a planner that never saw them
        # succeeding by breaking them shows nothing about what is possible under them)
        found = {e for e in envs if any(r.get("simulated_success") and held_constraints(r)
                                        for per in mine.values() for r in per.get(e, []))}
        none_found = [e for e in envs if e not in found and e not in infeasible]
        tries = [r["tries"] for e in none_found for r in mine.get("search", {}).get(e, [])]
        nojudge = [r["simulated_success"] for per in mine.get("nojudge", {}).values() for r in per
                   if r.get("simulated_success") is not None]
        base = {"limit_set": ls.label, "environments": len(envs), "infeasible_before_solving": len(infeasible),
                "feasible_found": len(found), "none_found": len(none_found),
                "search_tries_where_none_found": int(min(tries)) if tries else None,
                "nojudge_success_pct": 100 * _mean(nojudge) if nojudge else None}
        for m in asked:
            if m not in mine:  # asked for, and no generator covers the limits
                out.append({**base, "method": m, "planned": 0})
                continue
            res = {e: rs[0] for e, rs in mine[m].items() if rs[0].get("success_probability") is not None}
            feas = [res[e]["simulated_success"] for e in found if e in res]
            none = [res[e] for e in none_found if e in res]
            p = [r["success_probability"] for r in res.values()]
            sim = [r["simulated_success"] for r in res.values()]
            out.append({**base, "method": m, "planned": len(res), **violations([rs[0] for rs in mine[m].values()]),
                        "success_where_feasible": int(sum(feas)), "feasible_planned": len(feas),
                        "success_where_feasible_pct": 100 * _mean(feas) if feas else None,
                        "simulated_pct": 100 * _mean(sim) if sim else None,
                        "success_probability_mean": _mean(p),
                        "gap_pct": 100 * (_mean(p) - _mean(sim)) if p else None,
                        "p_where_none_found": _mean(r["success_probability"] for r in none),
                        "unlikely_where_none_found_pct": 100 * _mean(r["verdict"] == "unlikely" for r in none)
                        if none else None,
                        "verdict_accuracy_pct": 100 * _mean((r["verdict"] == "likely") == r["simulated_success"]
                                                            for r in res.values()) if res else None,
                        "calibrated_share": _mean(r["probability_source"] == "calibrated" for r in res.values())})
    return out


def markdown_sweep(summary: list[dict], title: str) -> str:
    lines = [f"### {title}", "",
             "| limit set | feasible found | no success found (search tries) | no-judge | planner "
             "| success where feasible | mean p | p - simulated | p where none found | 'unlikely' where none found "
             f"| verdict accuracy | p calibrated | worst violation | held every constraint ({HELD_TOL:g}) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in summary:
        infeasible = f", {s['infeasible_before_solving']} infeasible before solving" if s["infeasible_before_solving"] else ""
        tries = f" ({s['search_tries_where_none_found']}+ tries)" if s["search_tries_where_none_found"] else ""
        head = (f"| {s['limit_set']} | {s['feasible_found']}/{s['environments']}{infeasible} | {s['none_found']}{tries} "
                f"| {cell(s['nojudge_success_pct'], '.0f', ' %')} | {s['method']} ")
        if not s["planned"]:
            lines.append(head + "| no generator for these limits | | | | | | | | |")
            continue
        lines.append(head + f"| {s['success_where_feasible']}/{s['feasible_planned']} "
                     f"({cell(s['success_where_feasible_pct'], '.0f', ' %')}) | {cell(s['success_probability_mean'], '.3f')} "
                     f"| {cell(s['gap_pct'], '+.0f', ' pts')} | {cell(s['p_where_none_found'], '.3f')} "
                     f"| {cell(s['unlikely_where_none_found_pct'], '.0f', ' %')} | {cell(s['verdict_accuracy_pct'], '.0f', ' %')} "
                     f"| {cell(s['calibrated_share'], '.0%')} " + violation_cells(s))
    lines += ["", "Feasible found: environments where any planner, a random constraint-satisfying plan or the "
              "simulator-scored search succeeded. Where none did, the search found no successful plan in the tries "
              "shown: that is not a proof that none exists. p: the success probability the tool reports (calibrated "
              "where a calibration covers the setting, else the judge's); verdict accuracy: 'likely' matched success "
              "and 'unlikely' failure in simulation. Worst violation: the largest residual of any constraint (limits, "
              "terminal state, motion model, and [constraints]'s rate limits and window bounds) over the set's plans, "
              "in that constraint's units, with the constraint; held: plans whose every residual is at most "
              f"{HELD_TOL:g}. The generator never saw [constraints]; the direct solve holds them (starting cold "
              "where the generator's plan breaks them: repaired from it, the plan lands where the judge is over-"
              "confident)."]
    return "\n".join(lines) + "\n"


def plot_sweep(summary: list[dict], title: str) -> Figure:
    """Per limit set: success where a successful plan was found, and 'unlikely' where none was."""
    from matplotlib.figure import Figure

    sets = list(dict.fromkeys(s["limit_set"] for s in summary))
    methods = list(dict.fromkeys(s["method"] for s in summary))
    fig = Figure(figsize=(17, 4))
    axes = fig.subplots(1, 3)
    width = 0.8 / (len(methods) + 1)
    x = np.arange(len(sets))
    for j, m in enumerate(methods):
        ss = [next((s for s in summary if s["limit_set"] == ls and s["method"] == m), {}) for ls in sets]
        axes[0].bar(x + j * width, [s.get("success_where_feasible_pct") or 0 for s in ss], width, label=m)
        axes[1].bar(x + j * width, [s.get("unlikely_where_none_found_pct") or 0 for s in ss], width, label=m)
        axes[2].bar(x + j * width, [100 * s["held_plans"] / s["plans_checked"] if s.get("plans_checked") else 0
                                    for s in ss], width, label=m)
    first = [next(s for s in summary if s["limit_set"] == ls) for ls in sets]
    axes[0].bar(x + len(methods) * width, [s.get("nojudge_success_pct") or 0 for s in first], width,
                label="no judge", color="0.6")
    axes[0].set_ylabel("success where a successful plan was found [%]")
    axes[1].set_ylabel("verdict 'unlikely' where none was found [%]")
    axes[2].set_ylabel(f"plans holding every constraint to {HELD_TOL:g} [%]")
    for ax in axes:
        ax.set_xticks(x + width * len(methods) / 2, sets, rotation=20, ha="right", fontsize=7)
        ax.set_ylim(0, 105)
        ax.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return fig
