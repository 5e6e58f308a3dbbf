"""Plan and replay many environments in parallel processes (joblib; a Dask cluster through
joblib's dask backend when given a scheduler address, as collection does).

Each worker process loads the judge, the generator and the simulator once and keeps them
(the l4casadi library is cached on disk by model hash, so workers do not rebuild it).
"""

from __future__ import annotations

import json
from typing import Sequence

import numpy as np
from joblib import Parallel, delayed

from judgeopt.parallel import backend, stop_workers_on_sigterm, worker_cache
from judgeopt.planners.problem import Problem
from judgeopt.robots import DEFAULT_ROBOT


def simulator(task: str, robot: str = DEFAULT_ROBOT):
    """This process's simulator of the task's shipped scene, with the arm `robot`."""
    from judgeopt.api import simulator as new_simulator

    return worker_cache(f"sim:{task}:{robot}", lambda: new_simulator(task, robot))


def planners(problem: Problem, methods: tuple[str, ...], judge: str | None = None, models_dir: str = "models",
             generator: str | None = None):
    """This process's planners for the problem and models (loaded once per process)."""
    from judgeopt.planners.loaded import Planners

    key = json.dumps(["planners", problem.to_dict(), methods, models_dir, judge, generator], sort_keys=True)
    return worker_cache(key, lambda: Planners.load(problem, methods, judge=judge, generator=generator,
                                                   models_dir=models_dir))


def _random_rows(problem: Problem, envs: np.ndarray, first: int, seed: int, simulate: bool) -> list[dict]:
    """The paper's "random actions" baseline: the task's random demonstration commands."""
    from judgeopt.planners.result import PlanResult, constraint_residuals
    from judgeopt.tasks import get_task

    task = get_task(problem.task)
    rows = []
    for i, e in enumerate(envs):
        env = dict(zip(problem.env_names, map(float, e)))
        plan = task.plan(task.random_command(np.random.default_rng([seed, first + i]), env))
        r = PlanResult("random", env, plan, None, "sampled", 0.0, constraint_residuals(problem, plan, env))
        if simulate:
            r.simulated_success = bool(simulator(problem.task, problem.robot).simulate(plan, problem.world_env(env)).success)
        rows.append({**r.to_json(), "env_index": first + i})
    return rows


def plan_chunk(problem: Problem, methods: tuple[str, ...], models_dir: str, envs: np.ndarray, simulate: bool,
               judge: str | None = None, first: int = 0, seed: int = 0) -> list[dict]:
    """Plan (and replay) each environment: one JSON-style row per (environment, method)."""
    import torch

    torch.set_num_threads(1)
    if methods == ("random",):
        return _random_rows(problem, envs, first, seed, simulate)
    loaded = planners(problem, methods, judge, models_dir)
    sim = simulator(problem.task, problem.robot) if simulate else None
    rows = []
    for i, e in enumerate(envs):
        for r in loaded.solve(dict(zip(problem.env_names, map(float, e))), simulator=sim):
            if r.method in methods:  # not the planners a closed-loop one is built on
                rows.append({**r.to_json(), "env_index": first + i})
    return rows


def plan_many(problem: Problem, envs: np.ndarray, methods: Sequence[str] | None = None,
              simulate: bool = True, n_jobs: int = -1, models_dir: str = "models", chunk: int = 5,
              progress: bool = True, judge: str | None = None) -> list[dict]:
    """One JSON-style row per (environment, method: default the default planners), in environment order."""
    from judgeopt.planners.base import default_planners

    methods = default_planners() if methods is None else methods
    envs = np.asarray(envs, dtype=float)
    parts = [envs[i:i + chunk] for i in range(0, len(envs), chunk)]
    jobs = (delayed(plan_chunk)(problem, tuple(methods), models_dir, p, simulate, judge, i * chunk)
            for i, p in enumerate(parts))
    out: list[list[dict]] = []
    with stop_workers_on_sigterm(), backend(None, n_jobs):
        it = Parallel(return_as="generator")(jobs)
        if progress:
            from tqdm import tqdm

            it = tqdm(it, total=len(parts), desc=f"plan {problem.name} q̇_max={problem.qdot_max}", unit="chunk")
        out = list(it)
    return [row for part in out for row in part]
