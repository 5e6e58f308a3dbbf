"""The sampling baseline's search done by a maintained library: CMA-ES (the `cmaes` package).

Why it is here: the hand-written cross-entropy method (`judgeopt.planners.cem`) refits a
diagonal Gaussian to its elite; CMA-ES adapts a full covariance and its step size, which is
what a well-kept library gives for free. This planner searches exactly the CEM's space of plans
(`SplineCommands`: knots in [0, 1] mapped onto the limits) with exactly its score (the judge's
logit minus a penalty on the terminal-position and position-limit violations) and the same
number of judge evaluations (population x iterations, each generation judged in one batch), so
the two can be measured side by side (benchmarks/bench_sampling.py).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from judgeopt.judge.model import Judge
from judgeopt.planners.base import Planner
from judgeopt.planners.cem import CEMConfig, SplineCommands, env_key
from judgeopt.planners.problem import Problem
from judgeopt.planners.result import PlanResult, constraint_residuals, infeasible_result
from judgeopt.trajectory import Plan


@dataclass(frozen=True)
class CMAESConfig:
    """The CEM's space, budget and score (its defaults), CMA-ES's own step size."""

    knots: int = CEMConfig.knots
    population: int = CEMConfig.population  # judged in one batch per generation
    iterations: int = CEMConfig.iterations  # generations at most (fewer where CMA-ES says it has converged)
    sigma: float = CEMConfig.init_std  # initial step size, in the knots' [0, 1] units
    penalty: float = CEMConfig.penalty
    seed: int = CEMConfig.seed


def env_seed(seed: int, problem: Problem, env: dict[str, float]) -> int:
    """A seed from the config's and the environment's: a plan does not depend on which plans ran
    before it (as the CEM's)."""
    return int(np.random.default_rng([seed, env_key(problem, env)]).integers(2**31 - 1))


class CMAESPlanner(Planner):
    """CMA-ES over spline commands, scored by the judge's logit (the CEM's space and score)."""

    method = "cmaes"

    def __init__(self, problem: Problem, judge: Judge, config: CMAESConfig | None = None):
        self.problem, self.judge, self.config = problem, judge, config or CMAESConfig()
        self.commands = SplineCommands(problem, self.config.knots)

    def with_limits(self, problem: Problem) -> "CMAESPlanner":
        return CMAESPlanner(problem, self.judge, self.config)

    def score(self, z: np.ndarray, q_end: np.ndarray, e: np.ndarray) -> np.ndarray:
        """(B, dim) knots -> the CEM's score: judge logit minus penalty x violation (higher is better)."""
        x, penalty = self.commands.decode(z, q_end)
        return self.judge.predict_logit(x, e[:len(z)]) - self.config.penalty * penalty

    def solve(self, env: dict[str, float], guess: Any = None) -> PlanResult:
        from cmaes import CMA

        from judgeopt.planners.direct import judge_env

        pr, cfg = self.problem, self.config
        env = pr.env_dict(env)
        t0 = time.perf_counter()
        if (infeasible := infeasible_result(self.method, pr, env)) is not None:
            return infeasible
        q_end = pr.terminal_positions(env)
        e = np.repeat(judge_env(self.judge, env)[None], cfg.population, axis=0)
        dim = self.commands.dim
        opt = CMA(mean=np.full(dim, 0.5), sigma=cfg.sigma, bounds=np.tile([0.0, 1.0], (dim, 1)),
                  seed=env_seed(cfg.seed, pr, env), population_size=cfg.population)
        best_z, best_score, generations = np.full((1, dim), 0.5), -np.inf, 0
        while generations < cfg.iterations and not opt.should_stop():
            z = np.stack([opt.ask() for _ in range(opt.population_size)])
            score = self.score(z, q_end, e)
            i = int(np.argmax(score))
            if score[i] > best_score:
                best_score, best_z = float(score[i]), z[i:i + 1]
            opt.tell([(zi, -float(s)) for zi, s in zip(z, score)])  # cmaes minimises
            generations += 1
        x, _ = self.commands.decode(best_z, q_end)
        plan = Plan.from_array(pr.dt, x[0], pr.channel_spec)
        elapsed = time.perf_counter() - t0
        prob = float(self.judge.predict_proba(x, e[:1])[0])
        return PlanResult(self.method, env, plan, prob, "sampled", elapsed, constraint_residuals(pr, plan, env),
                          iterations=generations,
                          message=f"CMA-ES: {generations} x {cfg.population} judged samples (limits by construction, "
                                  "terminal position by penalty)")
