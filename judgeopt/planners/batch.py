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


def _worker(problem: Problem, methods: tuple[str, ...], models_dir: str):
    from judgeopt.planners.solve import Planners
    from judgeopt.sim.rollout import Simulator

    key = json.dumps([problem.to_dict(), methods, models_dir], sort_keys=True)
    if key not in _WORKERS:
        if "sim" not in _WORKERS:
            _WORKERS["sim"] = Simulator()
        _WORKERS[key] = Planners.load(problem, methods, models_dir=models_dir)
    return _WORKERS[key], _WORKERS["sim"]


def _run(problem: Problem, methods: tuple[str, ...], models_dir: str, envs: np.ndarray, simulate: bool) -> list[dict]:
    import torch

    torch.set_num_threads(1)
    planners, sim = _worker(problem, methods, models_dir)
    rows = []
    for e in envs:
        for r in planners.solve(dict(zip(problem.env_names, map(float, e))), simulator=sim if simulate else None):
            d = r.to_json()
            d["q_mean_force"] = float(np.mean(r.plan.f)) if r.plan is not None else None
            rows.append(d)
    return rows


def plan_many(problem: Problem, envs: np.ndarray, methods: Sequence[str] = ("amortized", "direct"),
              simulate: bool = True, n_jobs: int = -1, models_dir: str = "models", chunk: int = 5,
              progress: bool = True) -> list[dict]:
    """One JSON-style row per (environment, method), in environment order."""
    from judgeopt.data.collect import _backend

    envs = np.asarray(envs, dtype=float)
    parts = [envs[i:i + chunk] for i in range(0, len(envs), chunk)]
    jobs = (delayed(_run)(problem, tuple(methods), models_dir, p, simulate) for p in parts)
    out: list[list[dict]] = []
    with _backend(None, n_jobs):
        it = Parallel(return_as="generator")(jobs)
        if progress:
            from tqdm import tqdm

            it = tqdm(it, total=len(parts), desc=f"plan {problem.name} q̇_max={problem.qdot_max}", unit="chunk")
        out = list(it)
    return [row for part in out for row in part]
