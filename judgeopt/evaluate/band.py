"""`judgeopt evaluate band`: the printed verdict checked on settings drawn across the edge band.

An edge sweep (evaluate/edge.py) plans at offsets around an edge it bisected for, on a few
limits at a time; a user asks anywhere. Here each setting draws every limit and environment
variable named in the band uniformly from its range (independently, seeded by the setting's
index, so a rerun or another chunking draws the same settings), and a share of the settings
also draws a constraint set (force-rate, jerk and acceleration limits and an early force cap,
planners/constraint_ranges.py), so constrained plans stand on the same footing. Every default
planner plans each setting; each plan is replayed in simulation. Given a judge ensemble, each
plan also carries its members' probabilities (`ensemble_p`), so whether their disagreement
foretells failure can be measured on the same outcomes.

Rows are those `judgeopt calibrate` reads (one per plan, the plan's samples included, so another
judge can be scored on the same plans: scripts/band_judge_accuracy.py), written per chunk to
OUT/partial/ as they finish; a rerun resumes.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from judgeopt.planners.problem import LIMIT_NAMES, Problem, ProblemError

if TYPE_CHECKING:
    from matplotlib.figure import Figure


@dataclass(frozen=True)
class BandConfig:
    """Where settings are drawn: (name, lo, hi) per limit or environment variable (the others
    keep the problem's value; an environment variable not named is drawn from the problem's
    range), and the share of settings that also draw a constraint set."""

    ranges: tuple[tuple[str, float, float], ...]
    constrained: float = 0.0

    def check(self, problem: Problem) -> None:
        """One line per mistake: an unknown name, an empty range, a share outside [0, 1]."""
        known = set(LIMIT_NAMES) | set(problem.env_names)
        for name, lo, hi in self.ranges:
            if name not in known:
                raise ProblemError(f"--band {name}: not a limit or environment variable of {problem.name} "
                                   f"(choose from {', '.join(sorted(known))})")
            if not (np.isfinite(lo) and np.isfinite(hi) and lo <= hi):
                raise ProblemError(f"--band {name}={lo:g},{hi:g}: need finite LO <= HI")
        if not 0.0 <= self.constrained <= 1.0:
            raise ProblemError(f"--constrained {self.constrained:g}: a share of the settings, from 0 to 1")


def default_band(task_name: str) -> BandConfig:
    """The task's edge band (Task.edge_band), or a one-line error naming --band."""
    from judgeopt.tasks import get_task

    task = get_task(task_name)
    if not task.edge_band:
        raise ProblemError(f"task {task.name!r} declares no edge band: give --band NAME=LO,HI ...")
    return BandConfig(tuple((k, float(lo), float(hi)) for k, (lo, hi) in task.edge_band.items()))


def draw_setting(problem: Problem, cfg: BandConfig, seed: int, index: int) -> dict[str, Any]:
    """Setting `index` of the band: {"limits": {...}, "environment": {...}, "constraints": {...}},
    from its own generator (seed, index). A draw whose limits contradict each other (f_min above
    the drawn f_max) is drawn again, up to 20 times."""
    from judgeopt.planners.constraint_ranges import draw_constraints

    rng = np.random.default_rng([seed, index])
    for _ in range(20):
        values = {name: float(rng.uniform(lo, hi)) for name, lo, hi in cfg.ranges}
        limits = {k: round(v, 4) for k, v in values.items() if k in LIMIT_NAMES}
        try:
            p = problem.with_overrides(**limits)
        except ProblemError:
            continue
        env = p.env_dict(p.sample_env(rng, 1)[0])
        env.update({k: round(v, 4) for k, v in values.items() if k in env})
        constraints = {}
        if rng.random() < cfg.constrained:
            with contextlib.suppress(ProblemError):  # no feasible set at these limits: the setting stays unconstrained
                constraints = draw_constraints(rng, p, envs=[env])
        return {"limits": limits, "environment": env, "constraints": constraints}
    raise ProblemError(f"the band {cfg.ranges} gives contradicting limits in 20 draws; narrow it")


def ensemble_probabilities(members: Sequence[Any], plan, env: dict[str, float]) -> list[float]:
    """Each member judge's probability that the plan succeeds."""
    from judgeopt.planners.direct import judge_env

    return [float(m.predict_proba(plan.as_array()[None], judge_env(m, env)[None])[0]) for m in members]


def band_chunk(problem: Problem, cfg: BandConfig, methods: tuple[str, ...], first: int, count: int, seed: int,
               models_dir: str, ensemble: str | None = None) -> list[dict]:
    """Plan every method at settings first .. first + count - 1 and replay each plan."""
    import torch

    from judgeopt.evaluate.batch import planners, simulator
    from judgeopt.files import resolve
    from judgeopt.parallel import worker_cache

    torch.set_num_threads(1)
    sim = simulator(problem.task, problem.robot)
    base = planners(problem, methods, None, models_dir)
    members = []
    if ensemble:
        from judgeopt.judge.ensemble import load_ensemble

        members = worker_cache(f"ensemble:{ensemble}", lambda: load_ensemble(resolve(ensemble))[0])
    rows = []
    for i in range(first, first + count):
        s = draw_setting(problem, cfg, seed, i)
        common = {"env_index": i, "band_limits": s["limits"], "band_constraints": s["constraints"]}
        try:
            loaded = base.with_limits(**s["limits"], **s["constraints"])
        except ProblemError as exc:
            rows.append({"method": None, "environment": s["environment"], "status": "skipped", "message": str(exc),
                         **common})
            continue
        for r in loaded.solve(s["environment"], simulator=sim):
            if r.method not in methods:
                continue
            row = r.to_json()
            if members and r.plan is not None:
                row["ensemble_p"] = ensemble_probabilities(members, r.plan, r.env)
            rows.append({**row, **common})  # with the plan (31 samples): another judge can be scored on it
    return rows


def run_band(problem: Problem, cfg: BandConfig, methods: tuple[str, ...], n: int, seed: int, out: Path,
             n_jobs: int = -1, scheduler: str | None = None, chunk: int = 5, models_dir: str = "models",
             ensemble: str | None = None, progress: bool = True) -> list[dict]:
    """Every setting's rows, resumable from OUT/partial/ (chunks named by the problem, the band,
    the methods and the models folder: another sweep never reuses them)."""
    from judgeopt.evaluate.stored import refuse_other_runs
    from judgeopt.parallel import run_json_chunks

    cfg.check(problem)
    draw_setting(problem, cfg, seed, 0)  # a band that contradicts the problem fails here, before any work
    blob = json.dumps([problem.to_dict(), asdict(cfg), list(methods), models_dir, ensemble], sort_keys=True,
                      default=str)
    tag = hashlib.sha256(blob.encode()).hexdigest()[:8]
    work = [(Path(out) / "partial" / f"band__{start:05d}_c{min(chunk, n - start)}_s{seed}_p{tag}.json", band_chunk,
             (problem, cfg, methods, start, min(chunk, n - start), seed, models_dir, ensemble))
            for start in range(0, n, chunk)]
    refuse_other_runs(path for path, _, _ in work)
    done = run_json_chunks(work, n_jobs=n_jobs, scheduler=scheduler, progress=progress, desc="band")
    return sorted((r for rs in done for r in rs), key=lambda r: r["env_index"])


def summarise_band(rows: Sequence[dict], methods: Sequence[str]) -> dict:
    """Per planner (evaluate.report.verdict_stats), and per setting for the plan to run (the
    recommended plan): called likely and failed; where any plan succeeded, called likely and
    succeeded; where none succeeded, called likely. The same again over the settings that drew a
    constraint set (`constrained_only`), so constrained plans are checked on their own."""
    every = _verdicts(rows, methods)
    constrained = _verdicts([r for r in rows if r.get("band_constraints")], methods)
    return {**every, "constrained": constrained["settings"], "constrained_only": constrained}


def _verdicts(rows: Sequence[dict], methods: Sequence[str]) -> dict:
    """summarise_band's figures over these rows."""
    from judgeopt.evaluate.report import verdict_stats
    from judgeopt.verdict.rules import recommended
    from judgeopt.verdict.risk import upper_bound

    settings: dict[int, list[dict]] = {}
    for r in rows:
        if r.get("method") and r.get("simulated_success") is not None:
            settings.setdefault(r["env_index"], []).append(r)
    tops = [(rs, recommended(rs)) for rs in settings.values()]
    some = [(rs, t) for rs, t in tops if any(r["simulated_success"] for r in rs)]
    likely = [t for _, t in tops if t is not None and t["verdict"] == "likely"]
    failed = sum(not t["simulated_success"] for t in likely)
    return {"planners": verdict_stats(rows, methods, tuple(np.linspace(0.0, 1.0, 11))), "settings": len(settings),
            "to_run": {"likely": len(likely), "likely_failed": failed,
                       "likely_failed_bound_pct": 100 * upper_bound(failed, len(likely)) if likely else None,
                       "some_succeeded": len(some),
                       "likely_and_succeeded": sum(t is not None and t["verdict"] == "likely" and t["simulated_success"]
                                                   for _, t in some),
                       "none_succeeded": len(tops) - len(some),
                       "likely_where_none_succeeded": sum(t is not None and t["verdict"] == "likely"
                                                          for rs, t in tops if not any(r["simulated_success"] for r in rs))}}


def markdown_band(summary: dict, title: str, command: str) -> str:
    lines = [f"### {title}", "", f"`{command}`", "",
             f"{summary['settings']} settings ({summary['constrained']} with a constraint set).", "",
             *_verdict_lines(summary)]
    if 0 < summary["constrained"] < summary["settings"]:  # a share constrained: those alone too
        lines += ["", f"#### The {summary['constrained']} settings with a constraint set alone", "",
                  *_verdict_lines(summary["constrained_only"])]
    lines += ["", "Bounds: one-sided Clopper-Pearson upper bounds on the failure rate among plans called likely."]
    return "\n".join(lines) + "\n"


def _verdict_lines(v: dict) -> list[str]:
    """The planners' table and the plan to run's sentence of one _verdicts."""
    from judgeopt.evaluate.report import cell

    t = v["to_run"]
    lines = ["| planner | plans | succeeded | 'likely' | 'likely' and failed (95 % bound) | 'uncertain' | 'unlikely' "
             "| 'unlikely' and succeeded | breaks a hard limit | outside the judge's data | calibrated p | ECE |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in v["planners"]:
        lines.append(f"| {s['method']} | {s['plans']} | {s['successes']} ({cell(s['success_pct'], '.0f', ' %')}) "
                     f"| {s['likely']} | {s['likely_failed']} ({cell(s['likely_failed_pct'], '.1f', ' %')}; "
                     f"<= {cell(s['likely_failed_bound_pct'], '.1f', ' %')}) | {s['uncertain']} | {s['unlikely']} "
                     f"| {s['unlikely_succeeded']} | {s['breaks_limits']} | {s['outside_judge_data']} "
                     f"| {s['calibrated']} | {cell(s['ece'], '.3f')} |")
    some = t["some_succeeded"]
    return lines + ["", f"The plan to run (the recommended one): called likely in {t['likely']} settings, "
                    f"{t['likely_failed']} of them failed (95 % upper bound "
                    f"{cell(t['likely_failed_bound_pct'], '.1f', ' %')}). Where any plan succeeded "
                    f"({some} settings), it was called likely and succeeded in {t['likely_and_succeeded']}"
                    f" ({cell(100 * t['likely_and_succeeded'] / some if some else None, '.0f', ' %')})."
                    f" Where none succeeded ({t['none_succeeded']}), it was called likely in "
                    f"{t['likely_where_none_succeeded']}."]


def plot_band(summary: dict, title: str) -> "Figure":
    """Left: the reliability diagram per planner. Right: each planner's verdicts, split by outcome."""
    from matplotlib.figure import Figure

    from judgeopt.evaluate.report import cell

    fig = Figure(figsize=(11, 4.2))
    ax, ax2 = fig.subplots(1, 2)
    ax.plot([0, 1], [0, 1], color="0.6", lw=1, ls="--", label="calibrated")
    for s in summary["planners"]:
        cells = s["reliability"]
        if cells:
            ax.plot([c["predicted"] for c in cells], [c["observed"] for c in cells], marker="o",
                    label=f"{s['method']} (ECE {cell(s['ece'], '.3f')})")
    ax.set(xlabel="success p printed", ylabel="observed success in simulation", xlim=(-0.02, 1.02), ylim=(-0.02, 1.02))
    ax.legend(fontsize=7)
    parts = (("likely, succeeded", lambda s: s["likely"] - s["likely_failed"], "tab:green"),
             ("likely, FAILED", lambda s: s["likely_failed"], "tab:red"),
             ("uncertain", lambda s: s["uncertain"], "tab:olive"),
             ("unlikely", lambda s: s["unlikely"], "tab:gray"),
             ("breaks a hard limit", lambda s: s["breaks_limits"], "tab:purple"),
             ("outside the data", lambda s: s["outside_judge_data"], "tab:blue"))
    names = [s["method"] for s in summary["planners"]]
    bottom = np.zeros(len(names))
    for label, count, color in parts:
        v = np.array([count(s) for s in summary["planners"]], float)
        ax2.bar(names, v, bottom=bottom, label=label, color=color)
        bottom += v
    ax2.set_ylabel("plans")
    ax2.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return fig
