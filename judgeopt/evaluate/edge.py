"""`judgeopt evaluate edge`: the planners' probabilities checked where outcomes flip.

A user probes the edge of the possible: they tighten a limit until scoops start to fail. There
a printed probability is worth most and is hardest to get right, and random limit sweeps put
few plans there. Per seeded environment this finds the edge with the simulator's own
feasibility search (`feasibility.search`, bisected along one limit, e.g. f_max: the lowest
value at which it finds a successful plan), then plans at settings around it (the edge plus
`offsets`, in the limit's units, towards the easier side) with every planner, replays each
plan, and reports per planner: "likely" plans that failed, "unlikely" ones that succeeded,
the expected calibration error and a reliability diagram; and per setting whether the overall
verdict (the recommended plan's) said "likely" where no plan succeeded.

The search can miss a feasible plan, so the edge found is where success was *found*; plans
below it may still succeed, and those count as "unlikely and succeeded" where called unlikely.
Chunks of environments are written to OUT/partial/ as they finish (a rerun resumes), in the
rows `judgeopt calibrate` reads, so an edge sweep on one seed can fit a calibration and one on
another seed can test it.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

import numpy as np

from judgeopt.evaluate.feasibility import SearchConfig, search
from judgeopt.evaluate.report import cell, verdict_stats
from judgeopt.planners.problem import Problem, ProblemError
from judgeopt.verdict.rules import overall_verdict

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: equal-width bins of the edge sweep's reliability diagram and ECE (p spreads out at the edge)
EDGE_BINS = tuple(np.linspace(0.0, 1.0, 11))


@dataclass(frozen=True)
class EdgeConfig:
    """Which limit moves a setting across the edge, where to look for it, and where to plan."""

    limit: str = "f_max"
    span: tuple[float, float] | None = None  # (hard end, easy end); default: the task's wide range of the limit
    resolution: float = 1.0  # the bisection stops when the edge is known to this (the limit's units)
    offsets: tuple[float, ...] = (-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0)  # towards the easier side
    search: SearchConfig = field(default_factory=lambda: SearchConfig(population=8, iterations=6))


def edge_direction(problem: Problem, cfg: EdgeConfig) -> tuple[int, tuple[float, float]]:
    """+1 where a larger value of the limit makes the task easier (f_max, q̇_max), -1 where a
    smaller one does (f_min); and the span searched, hard end first. One-line errors for a
    limit the task cannot relax and a task without a feasibility search."""
    from judgeopt.session.suggest import relaxations
    from judgeopt.tasks import get_task

    task = get_task(problem.task)
    if not task.graded_outcome:
        raise ProblemError(f"task {task.name!r} has no feasibility search (its simulator grades no near miss: "
                           "Task.graded_outcome), so no edge can be found; use `judgeopt evaluate sweep` instead")
    relax = {r.name: r for r in relaxations(task)}
    if cfg.limit not in relax:
        raise ProblemError(f"--edge-limit {cfg.limit}: choose one of {', '.join(relax)} (the limits whose "
                           "relaxation makes a plan easier)")
    direction = relax[cfg.limit].direction
    if cfg.span is not None:
        lo, hi = cfg.span
    elif task.wide_limits and cfg.limit in task.wide_limits:
        lo, hi = task.wide_limits[cfg.limit]
    else:
        raise ProblemError(f"task {task.name!r} declares no wide range of {cfg.limit}: give --edge-span LO,HI")
    hard, easy = (lo, hi) if direction > 0 else (hi, lo)
    return direction, (float(hard), float(easy))


def find_edge(problem: Problem, env: dict[str, float], sim, seed: int, cfg: EdgeConfig) -> dict:
    """Bisect the limit between the span's hard and easy ends for the first value at which the
    feasibility search finds a successful plan. `edge` None: none found even at the easy end."""
    direction, (hard, easy) = edge_direction(problem, cfg)
    probes: list[dict] = []

    def found(value: float) -> bool:
        try:
            p = problem.with_overrides(**{cfg.limit: value})
        except ProblemError:  # contradicts another limit: nothing can be planned there
            probes.append({"value": value, "found": False, "tries": 0})
            return False
        r = search(p, env, sim, seed, cfg.search)
        probes.append({"value": value, "found": r["status"] == "found", "tries": r["tries"]})
        return r["status"] == "found"

    if not found(easy):
        return {"edge": None, "probes": probes}
    if found(hard):
        return {"edge": hard, "probes": probes, "below_span": True}
    while abs(easy - hard) > cfg.resolution:
        mid = 0.5 * (hard + easy)
        hard, easy = (hard, mid) if found(mid) else (mid, easy)
    return {"edge": easy, "probes": probes}


def settings_around(problem: Problem, edge: float | None, cfg: EdgeConfig) -> list[tuple[float, float]]:
    """(offset, value) pairs to plan at: the edge plus each offset towards the easier side,
    those that contradict the problem's other limits left out. No edge found: the offsets
    below the easy end (where every plan should be called unlikely)."""
    direction, (hard, easy) = edge_direction(problem, cfg)
    base = easy if edge is None else edge
    out = []
    for off in cfg.offsets:
        if edge is None and off >= 0:
            continue
        value = round(base + direction * off, 6)
        try:
            problem.with_overrides(**{cfg.limit: value})
        except ProblemError:
            continue
        out.append((off, value))
    return out


def edge_chunk(problem: Problem, cfg: EdgeConfig, methods: tuple[str, ...], envs: np.ndarray, first: int, seed: int,
               models_dir: str) -> list[dict]:
    """Find each environment's edge and plan (and replay) every method at the settings around it."""
    import torch

    from judgeopt.evaluate.batch import planners, simulator

    torch.set_num_threads(1)
    sim = simulator(problem.task, problem.robot)
    base = planners(problem, methods, None, models_dir)
    rows = []
    for i, e in enumerate(envs):
        env = dict(zip(problem.env_names, map(float, e)))
        edge = find_edge(problem, env, sim, seed, cfg)
        for off, value in settings_around(problem, edge["edge"], cfg):
            try:
                loaded = base.with_limits(**{cfg.limit: value})
            except ProblemError as exc:  # e.g. no generator covers it and only the amortised one was asked for
                rows.append({"method": None, "env_index": first + i, "environment": env, "status": "skipped",
                             "message": str(exc), "edge": edge["edge"], "offset": off, cfg.limit: value})
                continue
            for r in loaded.solve(env, simulator=sim):
                if r.method in methods:
                    row = r.to_json()
                    for k in ("t", *row.get("channels", ())):  # the plan itself is not needed to score it
                        row.pop(k, None)
                    rows.append({**row, "env_index": first + i, "edge": edge["edge"], "edge_probes": edge["probes"],
                                 "offset": off, "edge_limit": cfg.limit, "edge_value": value})
    return rows


def run_edge(problem: Problem, cfg: EdgeConfig, methods: tuple[str, ...], n: int, seed: int, out: Path,
             vary: tuple[str, tuple[float, float]] | None = None, n_jobs: int = -1, scheduler: str | None = None,
             chunk: int = 2, models_dir: str = "models", progress: bool = True) -> list[dict]:
    """Every environment's rows, resumable from OUT/partial/ (chunks named by the problem, the
    configuration and the methods: another sweep never reuses them)."""
    from judgeopt.evaluate.tables import Row, environments
    from judgeopt.evaluate.stored import refuse_other_runs
    from judgeopt.parallel import run_json_chunks

    edge_direction(problem, cfg)  # a bad limit or task fails here, before any work
    envs = environments(problem, Row("edge", "edge", None, vary), n, seed)
    blob = json.dumps([problem.to_dict(), asdict(cfg), list(methods), models_dir], sort_keys=True, default=str)
    tag = hashlib.sha256(blob.encode()).hexdigest()[:8]
    work = [(Path(out) / "partial" / f"edge_{cfg.limit}__{start:05d}_n{n}_s{seed}_p{tag}.json", edge_chunk,
             (problem, cfg, methods, envs[start:start + chunk], start, seed, models_dir)) for start in range(0, n, chunk)]
    refuse_other_runs(path for path, _, _ in work)
    done = run_json_chunks(work, n_jobs=n_jobs, scheduler=scheduler, progress=progress, desc="edge sweep")
    return sorted((r for rs in done for r in rs), key=lambda r: (r["env_index"], r.get("offset", 0)))


def summarise_edge(rows: Sequence[dict], methods: Sequence[str]) -> dict:
    """Per planner: plans, successes, likely / likely and failed, unlikely / unlikely and
    succeeded, the outside-the-data and uncalibrated counts, mean p, ECE and the reliability
    cells; per setting (environment and offset): the overall verdict where no plan succeeded."""
    per = verdict_stats(rows, methods, EDGE_BINS)
    groups: dict[str, list[dict]] = {}  # a setting: its environment and every limit (sweeps at several q̇_max share indices)
    edges: dict[str, float | None] = {}  # an environment under the limits other than the one bisected
    for r in rows:
        if not r.get("method"):  # a setting no planner could plan at (no generator for the amortised one alone)
            continue
        others = {k: v for k, v in r["limits"].items() if k != r["edge_limit"]}
        edges[json.dumps([r["environment"], others], sort_keys=True, default=str)] = r["edge"]
        groups.setdefault(json.dumps([r["environment"], r["limits"]], sort_keys=True, default=str), []).append(r)
    none_succeeded = [rs for rs in groups.values() if not any(r.get("simulated_success") for r in rs)]
    verdicts = [overall_verdict(rs) for rs in none_succeeded]
    return {"planners": per, "settings": len(groups), "environments": len(edges),
            "edges_found": sum(e is not None for e in edges.values()),
            "edge_values": sorted(e for e in edges.values() if e is not None),
            "none_succeeded": len(none_succeeded), "likely_where_none_succeeded": verdicts.count("likely")}


def markdown_edge(summary: dict, title: str, command: str) -> str:
    e = summary["edge_values"]
    where = f"{min(e):.1f} to {max(e):.1f} (median {np.median(e):.1f})" if e else "-"
    lines = [f"### {title}", "", f"`{command}`", "",
             f"{summary['environments']} environments, an edge found in {summary['edges_found']} (the limit's value "
             f"at the edge: {where}); {summary['settings']} settings around it.", "",
             "| planner | plans | succeeded | 'likely' | 'likely' and failed | 'unlikely' | 'unlikely' and succeeded "
             "| outside the judge's data | breaks a hard limit | calibrated p | mean p | ECE |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in summary["planners"]:
        lines.append(f"| {s['method']} | {s['plans']} | {s['successes']} ({cell(s['success_pct'], '.0f', ' %')}) "
                     f"| {s['likely']} | {s['likely_failed']} ({cell(s['likely_failed_pct'], '.1f', ' %')}) "
                     f"| {s['unlikely']} | {s['unlikely_succeeded']} | {s['outside_judge_data']} | {s['breaks_limits']} "
                     f"| {s['calibrated']} "
                     f"| {cell(s['mean_p'], '.3f')} | {cell(s['ece'], '.3f')} |")
    lines += ["", f"Settings where no plan succeeded: {summary['none_succeeded']}; the overall verdict (the "
              f"recommended plan's) said 'likely' in {summary['likely_where_none_succeeded']} of them.", "",
              "p: the success probability judgeopt prints (calibrated where a calibration covers the plan, else the "
              "judge's own); ECE over 10 equal-width bins of p. The edge is where the simulator-scored search first "
              "found a successful plan: a search can miss, so some plans below it succeed."]
    return "\n".join(lines) + "\n"


def plot_edge(summary: dict, rows: Sequence[dict], title: str) -> "Figure":
    """Left: the reliability diagram per planner (observed success against p, marker size the
    count). Right: success and p against the distance from the edge."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 4.2))
    ax, ax2 = fig.subplots(1, 2)
    ax.plot([0, 1], [0, 1], color="0.6", lw=1, ls="--", label="calibrated")
    for s in summary["planners"]:
        cells = s["reliability"]
        if not cells:
            continue
        line, = ax.plot([c["predicted"] for c in cells], [c["observed"] for c in cells], marker="o",
                        label=f"{s['method']} (ECE {cell(s['ece'], '.3f')})")
        ax.scatter([c["predicted"] for c in cells], [c["observed"] for c in cells],
                   s=[10 + 2 * c["n"] for c in cells], color=line.get_color(), alpha=0.4)
    ax.set_xlabel("success p printed")
    ax.set_ylabel("observed success in simulation")
    ax.set_xlim(-0.02, 1.02)
    ax.set_ylim(-0.02, 1.02)
    ax.legend(fontsize=7)
    for s in summary["planners"]:
        rs = [r for r in rows if r.get("method") == s["method"] and r.get("simulated_success") is not None
              and r.get("success_probability") is not None]
        offs = sorted({r["offset"] for r in rs})
        if not offs:
            continue
        ax2.plot(offs, [np.mean([r["simulated_success"] for r in rs if r["offset"] == o]) for o in offs], marker="o",
                 label=f"{s['method']}: succeeded")
        ax2.plot(offs, [np.mean([r["success_probability"] for r in rs if r["offset"] == o]) for o in offs],
                 ls="--", marker="x", label=f"{s['method']}: mean p")
    limit = next((r["edge_limit"] for r in rows if r.get("edge_limit")), "limit")
    ax2.set_xlabel(f"{limit} beyond the edge found (towards the easier side)")
    ax2.set_ylabel("share")
    ax2.set_ylim(-0.02, 1.02)
    ax2.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return fig
