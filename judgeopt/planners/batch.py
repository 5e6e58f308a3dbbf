"""Plan and replay many environments in parallel processes (joblib; a Dask cluster through
joblib's dask backend when given a scheduler address, as collection does).

Each worker process loads the judge, the generator and the simulator once and keeps them
(the l4casadi library is cached on disk by model hash, so workers do not rebuild it).
"""

from __future__ import annotations

import json
from typing import Any, Sequence

import numpy as np
from joblib import Parallel, delayed

from judgeopt.planners.problem import Problem

_WORKERS: dict[str, Any] = {}


def _simulator():
    from judgeopt.sim.rollout import Simulator

    if "sim" not in _WORKERS:
        _WORKERS["sim"] = Simulator()
    return _WORKERS["sim"]


def _planners(problem: Problem, methods: tuple[str, ...], models_dir: str, judge: str | None):
    from judgeopt.planners.solve import Planners

    key = json.dumps([problem.to_dict(), methods, models_dir, judge], sort_keys=True)
    if key not in _WORKERS:
        _WORKERS[key] = Planners.load(problem, methods, judge=judge, models_dir=models_dir)
    return _WORKERS[key]


def _random_rows(problem: Problem, envs: np.ndarray, first: int, seed: int, simulate: bool) -> list[dict]:
    """The paper's "random actions" baseline: the demonstration generator's random scoops."""
    from judgeopt.data.commands import random_command
    from judgeopt.planners.result import PlanResult, constraint_residuals

    rows = []
    for i, e in enumerate(envs):
        env = dict(zip(problem.env_names, map(float, e)))
        plan = random_command(np.random.default_rng([seed, first + i]), env["y_obj"])
        r = PlanResult("random", env, plan, None, "sampled", 0.0, constraint_residuals(problem, plan, env))
        if simulate:
            r.simulated_success = bool(_simulator().run(plan, env["y_obj"], env["mu"]).success)
        rows.append({**r.to_json(), "env_index": first + i})
    return rows


def _run(problem: Problem, methods: tuple[str, ...], models_dir: str, envs: np.ndarray, simulate: bool,
         judge: str | None = None, first: int = 0, seed: int = 0) -> list[dict]:
    import torch

    torch.set_num_threads(1)
    if methods == ("random",):
        return _random_rows(problem, envs, first, seed, simulate)
    planners = _planners(problem, methods, models_dir, judge)
    sim = _simulator() if simulate else None
    rows = []
    for i, e in enumerate(envs):
        for r in planners.solve(dict(zip(problem.env_names, map(float, e))), simulator=sim):
            rows.append({**r.to_json(), "env_index": first + i})
    return rows


def plan_many(problem: Problem, envs: np.ndarray, methods: Sequence[str] = ("amortized", "direct"),
              simulate: bool = True, n_jobs: int = -1, models_dir: str = "models", chunk: int = 5,
              progress: bool = True, judge: str | None = None) -> list[dict]:
    """One JSON-style row per (environment, method), in environment order."""
    from judgeopt.data.collect import _backend

    envs = np.asarray(envs, dtype=float)
    parts = [envs[i:i + chunk] for i in range(0, len(envs), chunk)]
    jobs = (delayed(_run)(problem, tuple(methods), models_dir, p, simulate, judge, i * chunk)
            for i, p in enumerate(parts))
    out: list[list[dict]] = []
    with _backend(None, n_jobs):
        it = Parallel(return_as="generator")(jobs)
        if progress:
            from tqdm import tqdm

            it = tqdm(it, total=len(parts), desc=f"plan {problem.name} q̇_max={problem.qdot_max}", unit="chunk")
        out = list(it)
    return [row for part in out for row in part]
