"""The paper's evaluation tables, measured in simulation: which rows, and how they are run.

A table is a list of rows; a row is a planner (or the random baseline) with a judge, on
environments drawn from a range. Rows of one table that share a range share the very same
environments (seeded), so differences between rows are the planners', not the draws'.
Work is split into chunks of environments, run in parallel processes (or on a Dask cluster),
and each finished chunk is written to OUT/partial/ at once: a rerun skips what is done.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from judgeopt.evaluate.batch import plan_chunk
from judgeopt.files import atomic_write
from judgeopt.parallel import run_chunks
from judgeopt.planners.problem import Problem
from judgeopt.tasks import get_task

Y_RANGE = get_task("scoop").env_ranges()["y_obj"]  # the paper's Table 4 / 5 object positions


@dataclass(frozen=True)
class Row:
    """One line of a table: `method` in amortized | direct | cem | random, with `judge` (a model
    path); `overrides` change problem fields for this row only (an ablation)."""

    name: str
    method: str
    judge: str | None
    mu: tuple[float, float] | None = (1.0, 3.0)  # None: the problem's own environment ranges (any task)
    paper: float | None = None  # the paper's success rate for this row, in %
    overrides: tuple[tuple[str, object], ...] = ()

    @property
    def key(self) -> str:
        slug = "".join(c if c.isalnum() else "_" for c in self.name)
        return f"{slug}__{self.method}__" + ("env" if self.mu is None else f"mu{self.mu[0]:g}-{self.mu[1]:g}")

    @property
    def env_label(self) -> str:
        return "the problem's" if self.mu is None else f"mu in [{self.mu[0]:g}, {self.mu[1]:g}]"


def table4() -> list[Row]:
    """Paper Table 4: what the judge knows, against random actions (mu in [1, 3])."""
    rows = []
    for name, judge, paper in (("proposed (y_obj, mu)", "models/judge_default", 100.0),
                               ("judge sees y_obj only", "models/judge_yobj_only", 90.0),
                               ("inverted labels", "models/judge_inverted", 0.0)):
        rows += [Row(name, m, judge, paper=paper) for m in ("amortized", "direct")]
    rows.append(Row("random actions", "random", None, paper=28.0))
    # not in the paper: random plans that do satisfy the limits and end at y_obj (what the limits alone give)
    rows.append(Row("no judge (random plans within the limits)", "nojudge", None))
    return rows


TABLE5_RANGES = (((1.0, 3.0), 100.0), ((3.0, 3.5), 100.0), ((0.5, 1.0), 100.0), ((3.5, 4.0), 81.0),
                 ((0.05, 0.5), 45.0))


def table5() -> list[Row]:
    """Paper Table 5: friction inside and outside the training range, both planners."""
    return [Row(f"mu in [{lo:g}, {hi:g}]", m, "models/judge_default", (lo, hi), paper)
            for (lo, hi), paper in TABLE5_RANGES for m in ("amortized", "direct")]


#: the remedies of docs/remedies.md, one at a time, each against the plain planner (name, method, judge, overrides)
ENSEMBLE = (("ensemble", "models/judge_ensemble"), ("pessimism", 1.0))
ABLATIONS = (("amortized + ensemble in its loss (mean - 1 std)", "amortized", "models/judge_default", ENSEMBLE),
             ("direct + ensemble (mean - 1 std)", "direct", "models/judge_default", ENSEMBLE),
             ("direct + trust region (D <= 8.5)", "direct", "models/judge_default", (("trust_region", 8.5),)),
             ("amortized, refined judge (and a generator trained against it)", "amortized", "models/judge_refined", ()),
             ("direct, refined judge", "direct", "models/judge_refined", ()))


def compare() -> list[Row]:
    """The planners side by side on the same instances (amortised, direct, the CEM sampling
    baseline, all against the default judge), then each remedy alone. With an ensemble both
    planners use its pessimistic score: the generator is the one trained against it (found by
    its metadata), and it also warm-starts the direct solve."""
    rows = [Row(m, m, "models/judge_default") for m in ("amortized", "direct", "cem")]
    return rows + [Row(name, method, judge, overrides=o) for name, method, judge, o in ABLATIONS]


def planners() -> list[Row]:
    """Any task: both planners and the CEM against the problem's judge, and random plans within
    the limits, in the problem's own environment ranges."""
    return [Row(m, m, None, None) for m in ("amortized", "direct", "cem")] + [
        Row("no judge (random plans within the limits)", "nojudge", None, None)]


TABLES = {"table4": table4, "table5": table5, "compare": compare, "planners": planners}


def environments(problem: Problem, row: Row, n: int, seed: int) -> np.ndarray:
    """The row's environments: seeded by the mu range only, so rows with the same range share them
    (no range: the problem's own environment ranges, the same for every row)."""
    if row.mu is None:
        return problem.sample_env(np.random.default_rng([seed, 0, 0]), n)
    p = problem.with_overrides(y_obj=list(Y_RANGE), mu=list(row.mu))
    rng = np.random.default_rng([seed, int(round(row.mu[0] * 1000)), int(round(row.mu[1] * 1000))])
    return p.sample_env(rng, n)


def _write_json(path: Path, data) -> None:
    atomic_write(path, json.dumps(data).encode())


def run_table(problem: Problem, rows: list[Row], n: int, seed: int, out: Path, n_jobs: int = -1,
              scheduler: str | None = None, chunk: int = 10, models_dir: str = "models",
              progress: bool = True) -> dict[str, list[dict]]:
    """Every row over n environments; results per row key, resumable from out/partial/."""
    partial = Path(out) / "partial"
    # chunks are named by the problem's content too: another problem never reuses them
    tag = hashlib.sha256(json.dumps(problem.to_dict(), sort_keys=True).encode()).hexdigest()[:8]
    todo, done, stale = [], {}, 0
    for row in rows:
        envs = environments(problem, row, n, seed)
        setting = _setting(problem, row, models_dir)
        for first in range(0, n, chunk):
            path = partial / f"{row.key}__{first:05d}_n{n}_s{seed}_p{tag}.json"
            cached = json.loads(path.read_text()) if path.exists() else None
            # a model retrained in place (same path, new weights) or a better-matching generator
            # added since: the cached plans are another setting's, so plan again
            if cached is not None and setting and any(r.get("setting", setting) != setting for r in cached):
                cached, stale = None, stale + 1
            if cached is not None:
                done[path] = cached
            else:
                todo.append((path, row, envs[first:first + chunk], first))
    if stale and progress:
        print(f"{stale} cached chunks were planned with other models than there are now: planning them again")
    done.update(run_chunks([(path, _plan_row, (problem, row, e, first, seed, models_dir)) for path, row, e, first in todo],
                           _write_json, n_jobs=n_jobs, scheduler=scheduler, progress=progress,
                           desc=f"evaluate ({len(done)} chunks already done)"))
    results: dict[str, list[dict]] = {row.key: [] for row in rows}
    for path, result in done.items():
        results[path.name.rsplit("__", 1)[0]] += result
    for key in results:
        results[key].sort(key=lambda r: r["env_index"])
    return results


def _setting(problem: Problem, row: Row, models_dir: str) -> str | None:
    """The row's calibration.setting_id with the models there are now (None: a baseline without one)."""
    from judgeopt.planners.solve import METHODS, choose_models

    if row.method not in METHODS:
        return None
    p = problem.with_overrides(**dict(row.overrides)) if row.overrides else problem
    return choose_models(p, (row.method,), row.judge, None, models_dir).settings((row.method,))[row.method]


def _plan_row(problem: Problem, row: Row, envs: np.ndarray, first: int, seed: int, models_dir: str) -> list[dict]:
    if row.overrides:
        problem = problem.with_overrides(**dict(row.overrides))
    if row.method in SIMULATOR_ROWS:
        return _simulator_rows(problem, row.method, envs, first, seed)
    return plan_chunk(problem, (row.method,), models_dir, envs, True, row.judge, first, seed)


#: rows that need no judge: random constraint-satisfying plans, and a search scored by the simulator
SIMULATOR_ROWS = ("nojudge", "search")
NOJUDGE_PLANS = 8  # random plans per environment in a "nojudge" row


def _simulator_rows(problem: Problem, method: str, envs: np.ndarray, first: int, seed: int) -> list[dict]:
    from judgeopt.evaluate.feasibility import nojudge_rows, search
    from judgeopt.evaluate.batch import simulator

    rows = []
    for i, e in enumerate(envs):
        env = dict(zip(problem.env_names, map(float, e)))
        found = (nojudge_rows(problem, env, simulator(problem.task), NOJUDGE_PLANS, seed) if method == "nojudge"
                 else [search(problem, env, simulator(problem.task), seed)])
        rows += [{**r, "env_index": first + i} for r in found]
    return rows
