"""`judgeopt evaluate robustness`: plans made for the nominal world, replayed unchanged in worlds
that differ from it, one perturbation at a time (a planner that plans while executing, such as the
receding planner, is run again in each world: it re-plans there from what it measures).

Each planner plans every seeded environment once per velocity limit, for the world it is told
(the nominal one): that is `evaluate planners`' run (judgeopt.evaluate.tables.run_table, the
same chunks in OUT/partial/, the nominal replay with it). Each plan is then replayed, as it is,
under each perturbation the task declares (`Task.perturbations`; the scoop's: friction and the
object's position misestimated, the object's mass and size, the mat, the real robot's gains, the
force sensor's bias and noise), through the task simulator's `perturb`. Replays run in chunks
through judgeopt.parallel and are kept in OUT/replays/, named by the plans they replay, so an
interrupted run resumes and a re-planned chunk is replayed again.
"""

from __future__ import annotations

import hashlib
import json
import math
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from judgeopt.evaluate.report import wilson
from judgeopt.files import atomic_write
from judgeopt.parallel import run_chunks, worker_cache
from judgeopt.planners.base import REGISTRY
from judgeopt.planners.problem import Problem
from judgeopt.tasks import Task, get_task
from judgeopt.tasks.tables import Row
from judgeopt.trajectory import PlanError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

@dataclass(frozen=True)
class Case:
    """One world: the nominal one (`value` None), or one perturbation at one value."""

    name: str
    value: float | None
    label: str

    @property
    def world(self) -> dict[str, float]:
        return {} if self.value is None else {self.name: self.value}

    @property
    def slug(self) -> str:
        if self.value is None:
            return "nominal"
        return f"{self.name}_{self.value:g}".replace("-", "m").replace(".", "p")


NOMINAL = Case("nominal", None, "nominal")


def robustness_cases(task: Task, selected: list[tuple[str, tuple[float, ...] | None]] | None = None) -> list[Case]:
    """The nominal world, then each selected perturbation (default: every one the task declares)
    at each of its values (default: the declared ones); an unknown name or a value outside the
    scene's range is a one-line error naming the known ones or the range."""
    if not task.perturbations:
        from judgeopt.tasks import TaskError

        raise TaskError(f"task {task.name!r} declares no perturbations (Task.perturbations; docs/tasks.md)")
    chosen = selected or [(p.name, None) for p in task.perturbations]
    cases = [NOMINAL]
    for name, values in chosen:
        p = task.perturbation(name)
        for v in values if values is not None else p.values:
            task.check_perturbation({name: v})
            case = Case(name, float(v), p.label(float(v)))
            if case not in cases:
                cases.append(case)
    return cases


def robustness_rows(problem: Problem, qdot_maxes: tuple[float, ...], methods: tuple[str, ...],
                    models_dir: str = "models") -> tuple[list[Row], list[str]]:
    """One row per (velocity limit, planner); a planner that needs a generator where none covers a
    limit is left out with a note (as the sweep does)."""
    from judgeopt.planners.loaded import choose_models

    rows, notes = [], []
    for q in qdot_maxes:
        p = problem.with_overrides(qdot_max=float(q))
        for m in methods:
            if "generator" in REGISTRY[m].needs and choose_models(p, (m,), None, None, models_dir).generator is None:
                notes.append(f"q̇_max {q:g}: no generator in {models_dir}/ covers these limits, so no {m} row")
                continue
            rows.append(Row(f"{m}, qdot_max {q:g}", m, None, overrides=(("qdot_max", float(q)),)))
    return rows, notes


def plan_of(task: Task, row: dict[str, Any], dt: float):
    """A saved plan row (PlanResult.to_json) as the task's Plan."""
    values = np.stack([np.asarray(row[c], dtype=float) for c in row["channels"]], axis=1)
    return task.plan(values, dt)


def replay_chunk(task_name: str, case: Case, plans: list[dict], seed: int, dt: float,
                 problem: Problem | None = None, models_dir: str = "models") -> list[dict]:
    """Replay each planned row (a PlanResult.to_json with env_index) unchanged in `case`'s world:
    one row each with the success, the world's environment and the outcome's numeric details.
    Sensor noise is seeded by (seed, environment). A planner that plans while executing (its
    rows need `problem`, the row's) is run again in that world instead: it re-plans there."""
    task = get_task(task_name)
    sim = worker_cache(f"robustness:{task_name}", task.simulator)
    out = []
    try:
        for r in plans:
            env = {k: float(v) for k, v in r["environment"].items()}
            row = {"env_index": r["env_index"], "method": r["method"], "case": case.label, "environment": env,
                   "world": task.true_env(env, case.world)}
            if "channels" not in r:  # no plan (infeasible limits): nothing to replay
                out.append({**row, "success": None})
                continue
            sim.perturb(case.world, seed=[seed, r["env_index"]])
            if REGISTRY.get(r["method"]) is not None and REGISTRY[r["method"]].closed_loop:
                from judgeopt.evaluate.batch import planners

                assert problem is not None, "a closed-loop row is run again: replay_chunk needs its problem"
                done = next(x for x in planners(problem, (r["method"],), models_dir=models_dir).solve(env, simulator=sim)
                            if x.method == r["method"])
                success, details = done.simulated_success, {k[4:]: v for k, v in done.info.items()
                                                            if k.startswith("sim_") and k != "sim_refused"}
            else:
                try:
                    outcome = sim.simulate(plan_of(task, r, dt), env)
                except PlanError as exc:
                    out.append({**row, "success": False, "refused": str(exc)})
                    continue
                success, details = outcome.success, outcome.details
            details = {k: (float(v) if not isinstance(v, bool) else v) for k, v in details.items()
                       if isinstance(v, (bool, int, float))}
            out.append({**row, "success": bool(success), "details": details})
    finally:
        sim.perturb({})
    return out


def _nominal_rows(plans: list[dict]) -> list[dict]:
    """The planning run's own nominal replays, in the replay rows' form."""
    out = []
    for r in plans:
        details = {k[4:]: v for k, v in r.items() if k.startswith("sim_") and k != "sim_refused"}
        out.append({"env_index": r["env_index"], "method": r["method"], "case": NOMINAL.label,
                    "environment": r["environment"], "world": r["environment"], "success": r.get("simulated_success"),
                    "details": details})
    return out


def run_replays(problem: Problem, rows: list[Row], plans: dict[str, list[dict]], cases: list[Case], n: int,
                seed: int, out: Path, chunk: int = 10, n_jobs: int = -1, scheduler: str | None = None,
                progress: bool = True, models_dir: str = "models") -> dict[tuple[str, str], list[dict]]:
    """Every row's plans replayed in every case's world: {(row key, case slug): rows}, resumable
    from OUT/replays/ (a file per chunk, named by the plans it replays)."""
    folder = Path(out) / "replays"
    results: dict[tuple[str, str], list[dict]] = {}
    todo, done = [], {}
    for row in rows:
        ps = plans[row.key]
        for case in cases:
            if case.value is None:
                results[(row.key, case.slug)] = _nominal_rows(ps)
                continue
            results[(row.key, case.slug)] = []
            for first in range(0, len(ps), chunk):
                part = ps[first:first + chunk]
                tag = hashlib.sha256(json.dumps([[r.get(c) for c in ("environment", "t", *r.get("channels", ()))]
                                                 for r in part], sort_keys=True).encode()).hexdigest()[:10]
                path = folder / f"{row.key}__{case.slug}__{first:05d}_n{n}_s{seed}_{tag}.json"
                if path.exists():
                    done[path] = ((row.key, case.slug), json.loads(path.read_text()))
                else:
                    todo.append((path, (row.key, case.slug), case, part))
    where = {path: key for path, key, _, _ in todo}

    def save(path: Path, result: list[dict]) -> None:
        atomic_write(path, json.dumps(result).encode())

    overrides = {row.key: problem.with_overrides(**dict(row.overrides)) for row in rows}
    fresh = run_chunks([(path, replay_chunk, (problem.task, case, part, seed, problem.dt, overrides[key[0]], models_dir))
                        for path, key, case, part in todo], save, n_jobs=n_jobs, scheduler=scheduler, progress=progress,
                       desc=f"replay ({len(done)} chunks already done)")
    for path, (key, rs) in done.items():
        results[key] += rs
    for path, rs in fresh.items():
        results[where[path]] += rs
    for rs in results.values():
        rs.sort(key=lambda r: r["env_index"])
    return results


def _stats(values: list[float], scale: float) -> dict[str, float | None]:
    if not values:
        return {"mean": None, "min": None, "max": None}
    v = scale * np.asarray(values, dtype=float)
    return {"mean": float(v.mean()), "min": float(v.min()), "max": float(v.max())}


def summarise_robustness(task: Task, rows: list[Row], cases: list[Case],
                         results: dict[tuple[str, str], list[dict]]) -> list[dict]:
    """One line per (world, velocity limit, planner): successes, their 95 % interval, what the
    perturbation lost and gained against the nominal world, and where the object ended (the
    task's outcome measures: mean, min and max in their units)."""
    out = []
    for case in cases:
        for row in rows:
            rs = [r for r in results[(row.key, case.slug)] if r.get("success") is not None]
            nominal = {r["env_index"]: r.get("success") for r in results[(row.key, NOMINAL.slug)]}
            k, n = sum(bool(r["success"]) for r in rs), len(rs)
            lo, hi = wilson(k, n)
            told = [r for r in rs if any(r["world"][e] != r["environment"][e] for e in r["environment"])]
            p = None if case.value is None else task.perturbation(case.name)
            clipped = 0
            if p is not None and p.env:
                clipped = sum(not math.isclose(r["world"][p.env], p.apply(r["environment"][p.env], case.value),
                                               abs_tol=1e-12) for r in rs)
            line = {"world": case.label, "perturbation": case.name, "value": case.value,
                    "method": row.method, "qdot_max": dict(row.overrides)["qdot_max"], "n": n, "successes": k,
                    "success_pct": 100 * k / n if n else math.nan, "ci95_low_pct": 100 * lo, "ci95_high_pct": 100 * hi,
                    "lost": sum(bool(nominal.get(r["env_index"])) and not r["success"] for r in rs),
                    "gained": sum(not nominal.get(r["env_index"]) and bool(r["success"]) for r in rs),
                    "refused": sum("refused" in r for r in rs), "true_env_differs": len(told),
                    "true_env_clipped": clipped}
            for key, _, unit, scale in task.outcome_measures:
                s = _stats([r["details"][key] for r in rs if key in r.get("details", {})], scale)
                line.update({f"{key}_{stat}_{unit}": v for stat, v in s.items()})
            out.append(line)
    return out


def _column(s: dict) -> str:
    return f"{s['method']}, q̇_max {s['qdot_max']:g}"


def markdown_robustness(task: Task, summary: list[dict], title: str) -> str:
    columns = list(dict.fromkeys(_column(s) for s in summary))
    worlds = list(dict.fromkeys(s["world"] for s in summary))
    cell = {(s["world"], _column(s)): s for s in summary}
    head = "| world | " + " | ".join(columns) + " |"
    rule = "|---|" + "---|" * len(columns)
    lines = [f"### {title}", "", "Simulated success (95 % interval; lost / gained against the nominal world):", "",
             head, rule]
    for w in worlds:
        cells = []
        for c in columns:
            s = cell.get((w, c))
            if s is None or not s["n"]:
                cells.append("-")
                continue
            change = "" if w == NOMINAL.label else f"; -{s['lost']} / +{s['gained']}"
            cells.append(f"{s['successes']}/{s['n']} ({s['success_pct']:.0f} %, {s['ci95_low_pct']:.0f}-"
                         f"{s['ci95_high_pct']:.0f}{change})")
        lines.append(f"| {w} | " + " | ".join(cells) + " |")
    for key, label, unit, _ in task.outcome_measures:
        lines += ["", f"Where it ended: {label} [{unit}], mean (min to max):", "", head, rule]
        for w in worlds:
            cells = []
            for c in columns:
                s = cell.get((w, c))
                mean = s.get(f"{key}_mean_{unit}") if s else None
                cells.append("-" if mean is None else
                             f"{mean:.2f} ({s[f'{key}_min_{unit}']:.2f} to {s[f'{key}_max_{unit}']:.2f})")
            lines.append(f"| {w} | " + " | ".join(cells) + " |")
    clipped = sorted({s["world"] for s in summary if s["true_env_clipped"]})
    lines += ["", "Each planner plans once per environment for the nominal world; the same plan is replayed unchanged "
              "in each world (a closed-loop planner, e.g. receding, executes again there, re-planning from what "
              "it measures). A misestimated environment variable: the plan was made for the told value, the world "
              "has the perturbed one."]
    if clipped:
        lines.append(f"In {', '.join(clipped)} the true value was clipped to the scene's physical range for some "
                     "environments (true_env_clipped in the CSV).")
    return "\n".join(lines) + "\n"


def plot_robustness(task: Task, summary: list[dict], title: str) -> Figure:
    """Success per world and planner (95 % intervals), and the first outcome measure's mean
    with its range."""
    from matplotlib.figure import Figure

    columns = list(dict.fromkeys(_column(s) for s in summary))
    worlds = list(dict.fromkeys(s["world"] for s in summary))
    cell = {(s["world"], _column(s)): s for s in summary}
    panels = 1 + bool(task.outcome_measures)
    fig = Figure(figsize=(max(8, 0.55 * len(worlds) * (1 + len(columns) / 4)), 3.6 * panels))
    axes = np.atleast_1d(fig.subplots(panels, 1, sharex=True))
    x = np.arange(len(worlds))
    width = 0.8 / max(1, len(columns))
    for j, c in enumerate(columns):
        ss = [cell.get((w, c)) for w in worlds]
        pct = np.array([s["success_pct"] if s and s["n"] else np.nan for s in ss])
        err = np.clip([[s["success_pct"] - s["ci95_low_pct"] if s and s["n"] else 0 for s in ss],
                       [s["ci95_high_pct"] - s["success_pct"] if s and s["n"] else 0 for s in ss]], 0, None)
        axes[0].bar(x + j * width, pct, width, yerr=err, capsize=2, label=c.replace("q̇_max", "qdot_max"))
        if panels > 1:
            key, label, unit, _ = task.outcome_measures[0]
            mean = np.array([np.nan if not s or s.get(f"{key}_mean_{unit}") is None else s[f"{key}_mean_{unit}"]
                             for s in ss])
            lo = np.array([np.nan if not s or s.get(f"{key}_min_{unit}") is None else s[f"{key}_min_{unit}"] for s in ss])
            hi = np.array([np.nan if not s or s.get(f"{key}_max_{unit}") is None else s[f"{key}_max_{unit}"] for s in ss])
            axes[1].errorbar(x + j * width, mean, yerr=[np.nan_to_num(mean - lo), np.nan_to_num(hi - mean)], fmt="o",
                             ms=3, capsize=2)
    axes[0].axhline(95, color="0.5", lw=0.8, ls="--")
    axes[0].set_ylabel("simulated success [%]")
    axes[0].set_ylim(0, 125)
    axes[0].set_yticks(range(0, 101, 20))
    axes[0].legend(fontsize=7, ncol=min(4, len(columns)), loc="upper center")
    if panels > 1:
        key, label, unit, _ = task.outcome_measures[0]
        axes[1].axhline(0, color="0.5", lw=0.8)
        axes[1].set_ylabel(textwrap.fill(f"{label} [{unit}], mean and range", 40), fontsize=7)
    axes[-1].set_xticks(x + width * (len(columns) - 1) / 2, worlds, rotation=30, ha="right", fontsize=7)
    axes[0].set_title(textwrap.fill(title.replace("q̇_max", "qdot_max"), 120), fontsize=8)
    fig.tight_layout()
    return fig
