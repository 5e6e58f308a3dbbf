"""A sampling baseline against the same judge: the cross-entropy method over spline commands.

Why it is here: it tells whether the gradient-based planners earn their keep. It needs no
gradient and no training, only batched judge evaluations, and it holds the limits the way a
sampling planner can: by construction where possible, by a penalty where not.

A candidate plan is K velocity knots and K force knots, each a number in [0, 1] mapped onto
the limits. Velocities are linear between the knots (at rest at both ends), then a half-sine
bump is added so the integrated position ends exactly at q_end, then clipped to the velocity
limits; forces are a monotone (PCHIP) interpolation of their knots, so they stay inside
[f_min, f_max]. Positions are integrated with the planners' shared point-mass model, so the
dynamics hold exactly. What clipping can break (the terminal position) and the position
limits are scored as a penalty, and measured on the returned plan like every other planner.
Each iteration keeps the best `elite` fraction and refits a diagonal Gaussian to it.
"""

from __future__ import annotations

from abc import abstractmethod
from typing import Any, ClassVar

import time
import zlib
from dataclasses import dataclass

import numpy as np

from judgeopt.judge.model import Judge
from judgeopt.planners.dynamics import channel_order, positions
from judgeopt.planners.base import Planner
from judgeopt.planners.problem import Problem
from judgeopt.planners.result import PlanResult, constraint_residuals, infeasible_result
from judgeopt.trajectory import Plan


def pchip(*args, **kwargs):
    """scipy's PchipInterpolator, imported when the baseline runs (scipy.interpolate costs 0.3-0.5 s
    to import, which every `judgeopt solve` would pay)."""
    from scipy.interpolate import PchipInterpolator

    return PchipInterpolator(*args, **kwargs)


def env_key(problem: Problem, env: dict[str, float]) -> int:
    """A number from the environment's values, mixed into a sampling planner's seed so that a plan
    does not depend on which other plans ran first."""
    return zlib.crc32(np.asarray([env[n] for n in problem.env_names], dtype=np.float64).tobytes())


@dataclass(frozen=True)
class CEMConfig:
    knots: int = 6  # per signal (velocity, force)
    population: int = 256
    elite: float = 0.1  # fraction refitted each iteration
    iterations: int = 10
    init_std: float = 0.3  # in the knots' [0, 1] units
    min_std: float = 0.02  # keeps the search from collapsing early
    penalty: float = 1e3  # logit units per metre (or m/s) of violation
    seed: int = 0


class SplineCommands:
    """Plans from (axes + forces) K numbers in [0, 1]: K velocity knots per axis and K knots per
    force channel, mapped onto the limits (the module docstring). Shared by the CEM baseline,
    the no-judge baseline and the feasibility search in simulation, so all three search the same
    space of plans."""

    def __init__(self, problem: Problem, knots: int):
        self.problem, self.knots = problem, knots
        n, k = problem.steps, knots
        s = np.linspace(0.0, 1.0, n + 1)
        # linear interpolation from [rest, knots..., rest] onto the samples, as a matrix
        nodes = np.linspace(0.0, 1.0, k + 2)
        self._vel_basis = np.stack([np.interp(s, nodes, np.eye(k + 2)[j]) for j in range(k + 2)], axis=1)
        self._bump = np.sin(np.pi * s)
        self._force_nodes = np.linspace(0.0, 1.0, k)
        self._s = s

    @property
    def dim(self) -> int:
        return (self.problem.n_axes + self.problem.n_forces) * self.knots

    def decode(self, z: np.ndarray, q_end: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """(B, dim) knots in [0, 1] -> (B, N + 1, channels) plans in the task's channel order, and
        each one's penalty (terminal position errors plus position-limit violations, in m).
        `q_end`: the end per axis (nan: free)."""
        pr, k, dt = self.problem, self.knots, self.problem.dt
        ends_q = np.atleast_1d(np.asarray(q_end, dtype=float))
        lim = {n: pr.vec(n) for n in ("q0", "qdot0", "qdot_end", "qdot_min", "qdot_max", "q_min", "q_max",
                                      "f_min", "f_max")}
        bump_travel = 0.5 * dt * (self._bump[:-1] + self._bump[1:]).sum()
        qs, vs, fs = [], [], []
        penalty = np.zeros(len(z))
        for i in range(pr.n_axes):
            vk = lim["qdot_min"][i] + z[:, i * k:(i + 1) * k] * (lim["qdot_max"][i] - lim["qdot_min"][i])
            ends = np.column_stack([np.full(len(z), lim["qdot0"][i]), vk, np.full(len(z), lim["qdot_end"][i])])
            v = ends @ self._vel_basis.T
            if not np.isnan(ends_q[i]):  # a half-sine correction so the position ends there
                travel = 0.5 * dt * (v[:, :-1] + v[:, 1:]).sum(axis=1)
                v = v + ((ends_q[i] - lim["q0"][i] - travel) / bump_travel)[:, None] * self._bump
            v = np.clip(v, lim["qdot_min"][i], lim["qdot_max"][i])
            v[:, 0], v[:, -1] = lim["qdot0"][i], lim["qdot_end"][i]
            q = positions(lim["q0"][i], v, dt)
            terminal = np.abs(q[:, -1] - ends_q[i]) if not np.isnan(ends_q[i]) else 0.0
            penalty = penalty + (terminal + np.maximum(q - lim["q_max"][i], 0).max(1)
                                 + np.maximum(lim["q_min"][i] - q, 0).max(1))
            qs.append(q)
            vs.append(v)
        for j in range(pr.n_forces):
            first = (pr.n_axes + j) * k
            fk = lim["f_min"][j] + z[:, first:first + k] * (lim["f_max"][j] - lim["f_min"][j])
            fs.append(pchip(self._force_nodes, fk, axis=1)(self._s))
        return np.stack(qs + vs + fs, axis=2)[:, :, channel_order(pr)], penalty


class SplineSearch(Planner):
    """A sampling search over `SplineCommands` with its own `Config` (knots among its fields): the
    CEM here, CMA-ES in judgeopt.planners.cmaes_search. New limits need only new commands."""

    Config: ClassVar[type]

    def __init__(self, problem: Problem, judge: Judge, config: Any = None):
        self.problem, self.judge, self.config = problem, judge, config or self.Config()
        self.commands = SplineCommands(problem, self.config.knots)

    #: the search's name in a result's message
    label: ClassVar[str]

    def with_limits(self, problem: Problem) -> "SplineSearch":
        return type(self)(problem, self.judge, self.config)

    def score(self, z: np.ndarray, q_end: np.ndarray, e: np.ndarray) -> np.ndarray:
        """(B, dim) knots -> judge logit minus penalty x violation (higher is better)."""
        x, penalty = self.commands.decode(z, q_end)
        return self.judge.predict_logit(x, e[:len(z)]) - self.config.penalty * penalty

    @abstractmethod
    def search(self, q_end: np.ndarray, e: np.ndarray, seed: int) -> tuple[np.ndarray, int]:
        """The best knots found, (1, dim), and the iterations run, for one environment (its
        terminal positions, its judge inputs repeated population times, a seed of its own)."""

    def solve(self, env: dict[str, float], guess: Any = None) -> PlanResult:
        from judgeopt.planners.direct import judge_env

        pr, cfg = self.problem, self.config
        env = pr.env_dict(env)
        t0 = time.perf_counter()
        if (infeasible := infeasible_result(self.method, pr, env)) is not None:
            return infeasible
        q_end = pr.terminal_positions(env)
        e = np.repeat(judge_env(self.judge, env)[None], cfg.population, axis=0)
        best_z, iterations = self.search(q_end, e, env_key(pr, env))
        x, _ = self.commands.decode(best_z, q_end)
        plan = Plan.from_array(pr.dt, x[0], pr.channel_spec)
        elapsed = time.perf_counter() - t0
        prob = float(self.judge.predict_proba(x, e[:1])[0])
        return PlanResult(self.method, env, plan, prob, "sampled", elapsed, constraint_residuals(pr, plan, env),
                          iterations=iterations,
                          message=f"{self.label}: {iterations} x {cfg.population} judged samples (limits by "
                                  "construction, terminal position by penalty)")


class CEMPlanner(SplineSearch):
    """Cross-entropy search over spline commands, scored by the judge's logit."""

    method = "cem"
    Config = CEMConfig
    label = "CEM"

    def search(self, q_end: np.ndarray, e: np.ndarray, seed: int) -> tuple[np.ndarray, int]:
        cfg = self.config
        rng = np.random.default_rng([cfg.seed, seed])
        dim = self.commands.dim
        mean, std = np.full(dim, 0.5), np.full(dim, cfg.init_std)
        n_elite = max(2, int(round(cfg.elite * cfg.population)))
        best_z, best_score = mean[None], -np.inf
        for _ in range(cfg.iterations):
            z = np.clip(mean + std * rng.standard_normal((cfg.population, dim)), 0.0, 1.0)
            z[0] = np.clip(mean, 0.0, 1.0)  # the current mean is always a candidate
            score = self.score(z, q_end, e)
            order = np.argsort(-score)
            if score[order[0]] > best_score:
                best_score, best_z = float(score[order[0]]), z[order[:1]]
            elite = z[order[:n_elite]]
            mean, std = elite.mean(0), np.maximum(elite.std(0), cfg.min_std)
        return best_z, cfg.iterations
