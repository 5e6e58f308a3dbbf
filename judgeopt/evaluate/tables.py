"""Evaluation tables, measured in simulation: which rows, and how they are run.

A table is a list of rows; a row is a planner (or a baseline) with a judge, on environments
drawn from the problem's ranges or one varied range. `planners` serves any task; a task adds
its own tables (the scoop: the paper's, in judgeopt/tasks/scoop/tables.py). Rows of one table that share a range share the very same
environments (seeded), so differences between rows are the planners', not the draws'.
Work is split into chunks of environments, run in parallel processes (or on a Dask cluster),
and each finished chunk is written to OUT/partial/ at once: a rerun skips what is done.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from judgeopt.evaluate.batch import plan_chunk
from judgeopt.files import atomic_write
from judgeopt.parallel import run_chunks
from judgeopt.planners.problem import Problem
from judgeopt.tasks import get_task
from judgeopt.tasks.tables import PlannerNames, Row, Table


def table_planners() -> PlannerNames:
    """The registered planners, as a table's rows name them (every one, the paper's, the baselines)."""
    from judgeopt.planners.base import REGISTRY

    return PlannerNames(tuple(REGISTRY), tuple(n for n, s in REGISTRY.items() if s.paper),
                        tuple(n for n, s in REGISTRY.items() if s.baseline))


def planners(names: PlannerNames) -> list[Row]:
    """Any task: every registered planner against the problem's judge, and random plans within
    the limits, in the problem's own environment ranges."""
    return [Row(m, m, None) for m in names.every] + [Row("no judge (random plans within the limits)", "nojudge", None)]


def tables(task: str) -> dict[str, Table]:
    """The tables for a task's problems: `planners` for every task, and the task's own (the
    scoop's: the paper's Tables 4 and 5 and the planner comparison)."""
    return {"planners": Table(planners, "Planners on the same instances: {name} (task {task}), q̇_max = {qdot_max}, "
                                        "f in [{f_min}, {f_max}], environment {env}"), **get_task(task).tables()}


def environments(problem: Problem, row: Row, n: int, seed: int) -> np.ndarray:
    """The row's environments: seeded by its varied range only, so rows with the same range share
    them (no range: the problem's own environment ranges, the same for every row)."""
    if row.vary is None:
        return problem.sample_env(np.random.default_rng([seed, 0, 0]), n)
    name, (lo, hi) = row.vary
    rng = np.random.default_rng([seed, int(round(lo * 1000)), int(round(hi * 1000))])
    return problem.with_overrides(**{name: [lo, hi]}).sample_env(rng, n)


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
    from judgeopt.planners.base import REGISTRY
    from judgeopt.planners.loaded import choose_models

    if row.method not in REGISTRY:
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
        found = (nojudge_rows(problem, env, simulator(problem.task, problem.robot), NOJUDGE_PLANS, seed) if method == "nojudge"
                 else [search(problem, env, simulator(problem.task, problem.robot), seed)])
        rows += [{**r, "env_index": first + i} for r in found]
    return rows
