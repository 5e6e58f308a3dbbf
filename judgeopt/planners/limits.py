"""The limits a conditioned generator takes as inputs, and the ranges it (and refinement, and the
sweep's random limit sets) draws them from. Light to import: the command line offers their
defaults at start-up."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from judgeopt.planners.problem import Problem, ProblemError
from judgeopt.tasks import DEFAULT_TASK, get_task

#: the limits a conditioned generator reads, in input order
CONDITION_NAMES = ("qdot_max", "f_min", "f_max")


@dataclass(frozen=True)
class LimitRanges:
    """The limit ranges a conditioned generator is trained over (uniform, independently per
    trajectory) and trusted in. Defaults: q̇_max from 0.25 m/s (y_obj = 0.28 m is reachable
    from 0.214 m/s) to the paper's 1.0; f_min in [5, 10] N and f_max in [15, 25] N contain the
    paper's 7.5 and 22.5 N, always keep f_min < f_max (by 5 N at least) and stay inside the
    0-30 N the judge's demonstrations pressed with."""

    qdot_max: tuple[float, float] = (0.25, 1.0)
    f_min: tuple[float, float] = (5.0, 10.0)
    f_max: tuple[float, float] = (15.0, 25.0)

    def __post_init__(self) -> None:
        for name in CONDITION_NAMES:
            v = getattr(self, name)
            if len(v) != 2 or not all(np.isfinite(v)) or not v[0] <= v[1]:
                raise ProblemError(f"{name} range {list(v)} must be lo,hi with lo <= hi")
            object.__setattr__(self, name, (float(v[0]), float(v[1])))
        if not self.f_min[1] < self.f_max[0]:
            raise ProblemError(f"f_min range {list(self.f_min)} must lie below the f_max range {list(self.f_max)} "
                               "(every sampled f_min < f_max)")
        task = get_task(DEFAULT_TASK)
        speed, force = task.demonstrated_bound("velocity")[1], task.demonstrated_bound("force")
        for name, (lo, hi) in (("qdot_max", (0.0, speed)), ("f_min", force), ("f_max", force)):
            v = getattr(self, name)
            if v[0] < lo or v[1] > hi or (name == "qdot_max" and v[0] <= lo):
                raise ProblemError(f"{name} range {list(v)} leaves [{lo:g}, {hi:g}], what the demonstrations cover "
                                   "(the judge has seen nothing beyond it); narrow the range")

    def to_dict(self) -> dict[str, list[float]]:
        return {k: list(getattr(self, k)) for k in CONDITION_NAMES}

    @classmethod
    def from_dict(cls, d: dict) -> "LimitRanges":
        return cls(**{k: tuple(d[k]) for k in CONDITION_NAMES})

    def array(self) -> np.ndarray:
        """(3, 2): [lo, hi] per limit in CONDITION_NAMES order."""
        return np.array([getattr(self, k) for k in CONDITION_NAMES], dtype=float)

    def contains(self, problem: Problem, tol: float = 1e-9) -> bool:
        return all(lo - tol <= getattr(problem, k) <= hi + tol for k, (lo, hi) in zip(CONDITION_NAMES, self.array()))

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """(n, 3) limits, each uniform in its range."""
        return np.stack([rng.uniform(lo, hi, n) for lo, hi in self.array()], axis=1)

    def check(self, problem: Problem) -> None:
        """Every limit in the ranges must fit the problem's other limits and reach every terminal
        position of its environment ranges (else training would chase infeasible plans)."""
        lo_q, hi_q = self.qdot_max
        if lo_q <= problem.qdot_min or lo_q < max(problem.qdot0, problem.qdot_end):
            raise ProblemError(f"qdot_max range {list(self.qdot_max)} must lie above qdot_min = {problem.qdot_min} "
                               f"and the start/terminal velocities")
        slow = problem.with_overrides(qdot_max=lo_q)
        ends = ([problem.q_end] if not isinstance(problem.q_end, str)
                else list(np.atleast_1d(problem.environment["y_obj"])))
        reach = slow.reachable_range()
        if max(ends) > reach[1] + 1e-12:
            raise ProblemError(f"qdot_max = {lo_q} (the bottom of its range) cannot reach q_end = {max(ends)} m in "
                               f"{problem.steps} steps (reach {reach[1]:.4g} m); raise the range's lower end")


#: limit ranges wider than any shipped problem, down to forces and speeds under which no scoop
#: succeeds at high friction (q̇_max from what reaches y_obj = 0.28 m): refinement's default,
#: the sweep's random limit sets, and the shipped refined conditioned generator's ranges
WIDE_LIMITS = LimitRanges(qdot_max=(0.22, 1.2), f_min=(0.0, 10.0), f_max=(11.0, 30.0))


def limits_of(problem: Problem) -> np.ndarray:
    """The conditioned limits of a problem, in CONDITION_NAMES order."""
    return np.array([getattr(problem, k) for k in CONDITION_NAMES], dtype=float)
