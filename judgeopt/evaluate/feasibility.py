"""What is possible under a limit set, asked of the simulator itself, and the no-judge baseline.

Both search the CEM baseline's space of plans (`SplineCommands`): velocity knots mapped onto
[q̇_min, q̇_max], forces a monotone spline inside [f_min, f_max], a half-sine correction so the
plan ends at q_end. So every plan they try satisfies the limits by construction.

- No-judge baseline: random plans from that space, replayed. Its success rate is what the
  limits alone give; a judge's worth is its distance from this rate.
- Feasibility search: a cross-entropy search whose score is the rollout's own outcome (success
  first, then how far the object rose and how close to the blade centre it ended). It stops at
  the first success. A search can miss a feasible plan, so its negative answer is "no
  successful plan found in N tries", never "impossible".
"""

from __future__ import annotations

import zlib
from dataclasses import asdict, dataclass

import numpy as np

from judgeopt.planners.cem import SplineCommands
from judgeopt.planners.problem import InfeasibleProblemError, Problem
from judgeopt.trajectory import Plan

TERMINAL_TOL = 1e-3  # m: a random plan that misses q_end by more does not satisfy the constraints


@dataclass(frozen=True)
class SearchConfig:
    knots: int = 6
    population: int = 12
    iterations: int = 8  # at most population x iterations rollouts per environment
    elite: int = 3
    init_std: float = 0.3
    min_std: float = 0.05


def env_rng(problem: Problem, env: dict[str, float], seed: int, stream: int) -> np.random.Generator:
    """Seeded by the environment's values, so a result does not depend on which ran before."""
    key = zlib.crc32(np.asarray([env[n] for n in problem.env_names], dtype=np.float64).tobytes())
    return np.random.default_rng([seed, stream, key])


def _valid(commands: SplineCommands, q_end: np.ndarray, n: int, draw) -> tuple[np.ndarray, np.ndarray]:
    """n knot vectors from draw(n) whose plans end within TERMINAL_TOL of q_end (clipping to the
    velocity limits can spoil a draw's end), and their plans; fewer only if 50 n draws miss."""
    zs, xs = [], []
    for _ in range(50):
        z = draw(n)
        x, penalty = commands.decode(z, q_end)
        ok = penalty <= TERMINAL_TOL
        zs.append(z[ok])
        xs.append(x[ok])
        if sum(len(a) for a in zs) >= n:
            break
    return np.concatenate(zs)[:n], np.concatenate(xs)[:n]


def random_plans(problem: Problem, env: dict[str, float], n: int, seed: int, knots: int = 6) -> list[Plan]:
    """n random plans, uniform in the knots, that satisfy the limits and end at q_end."""
    commands = SplineCommands(problem, knots)
    rng = env_rng(problem, env, seed, 101)
    _, x = _valid(commands, problem.terminal_positions(env), n, lambda k: rng.uniform(0.0, 1.0, (k, commands.dim)))
    return [Plan.from_array(problem.dt, xi, problem.channel_spec) for xi in x]


def nojudge_rows(problem: Problem, env: dict[str, float], sim, n: int, seed: int) -> list[dict]:
    """One row per random constraint-satisfying plan, replayed."""
    try:
        problem.check_feasible(env)
    except InfeasibleProblemError as exc:
        return [{"method": "nojudge", "environment": env, "status": "infeasible", "message": str(exc),
                 "simulated_success": None}]
    rows = []
    for i, plan in enumerate(random_plans(problem, env, n, seed)):
        out = sim.simulate(plan, problem.world_env(env))
        rows.append({"method": "nojudge", "environment": env, "status": "sampled", "try": i,
                     "simulated_success": bool(out.success), "predicted_success": None,
                     "max_constraint_violation": 0.0, "solve_time_s": 0.0})
    return rows


def search(problem: Problem, env: dict[str, float], sim, seed: int, cfg: SearchConfig = SearchConfig()) -> dict:
    """A sim-scored cross-entropy search for one successful plan; stops at the first."""
    try:
        problem.check_feasible(env)
    except InfeasibleProblemError as exc:
        return {"method": "search", "environment": env, "status": "infeasible", "message": str(exc),
                "simulated_success": None, "tries": 0}
    commands = SplineCommands(problem, cfg.knots)
    rng = env_rng(problem, env, seed, 202)
    q_end = problem.terminal_positions(env)
    mean, std = np.full(commands.dim, 0.5), np.full(commands.dim, cfg.init_std)
    tries = 0
    for _ in range(cfg.iterations):
        z, x = _valid(commands, q_end, cfg.population,
                      lambda k: np.clip(mean + std * rng.standard_normal((k, commands.dim)), 0.0, 1.0))
        scores = np.full(len(z), -np.inf)
        for j in range(len(z)):
            out = sim.simulate(Plan.from_array(problem.dt, x[j], problem.channel_spec), problem.world_env(env))
            tries += 1
            scores[j] = out.progress
            if out.success:
                return {"method": "search", "environment": env, "status": "found", "simulated_success": True,
                        "tries": tries, "plan": x[j].tolist(), "config": asdict(cfg)}
        if len(z):
            elite = z[np.argsort(-scores)[:cfg.elite]]
            mean, std = elite.mean(0), np.maximum(elite.std(0), cfg.min_std)
    return {"method": "search", "environment": env, "status": "not_found", "simulated_success": False,
            "tries": tries, "config": asdict(cfg),
            "message": f"no successful plan found in {tries} tries"}
