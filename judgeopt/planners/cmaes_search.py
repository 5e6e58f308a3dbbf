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

from dataclasses import dataclass

import numpy as np

from judgeopt.planners.cem import CEMConfig, SplineSearch


@dataclass(frozen=True)
class CMAESConfig:
    """The CEM's space, budget and score (its defaults), CMA-ES's own step size."""

    knots: int = CEMConfig.knots
    population: int = CEMConfig.population  # judged in one batch per generation
    iterations: int = CEMConfig.iterations  # generations at most (fewer where CMA-ES says it has converged)
    sigma: float = CEMConfig.init_std  # initial step size, in the knots' [0, 1] units
    penalty: float = CEMConfig.penalty
    seed: int = CEMConfig.seed


class CMAESPlanner(SplineSearch):
    """CMA-ES over spline commands, scored by the judge's logit (the CEM's space and score)."""

    method = "cmaes"
    Config = CMAESConfig
    label = "CMA-ES"

    def search(self, q_end: np.ndarray, e: np.ndarray, seed: int) -> tuple[np.ndarray, int]:
        from cmaes import CMA

        cfg, dim = self.config, self.commands.dim
        opt = CMA(mean=np.full(dim, 0.5), sigma=cfg.sigma, bounds=np.tile([0.0, 1.0], (dim, 1)),
                  seed=int(np.random.default_rng([cfg.seed, seed]).integers(2**31 - 1)),
                  population_size=cfg.population)
        best_z, best_score, generations = np.full((1, dim), 0.5), -np.inf, 0
        while generations < cfg.iterations and not opt.should_stop():
            z = np.stack([opt.ask() for _ in range(opt.population_size)])
            score = self.score(z, q_end, e)
            i = int(np.argmax(score))
            if score[i] > best_score:
                best_score, best_z = float(score[i]), z[i:i + 1]
            opt.tell([(zi, -float(s)) for zi, s in zip(z, score)])  # cmaes minimises
            generations += 1
        return best_z, generations
