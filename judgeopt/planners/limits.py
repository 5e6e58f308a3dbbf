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
    trajectory) and trusted in. Defaults (the default task's): q̇_max from 0.25 m/s (the farthest
    sampled end, 0.28 m, is reachable from 0.214 m/s) to the paper's 1.0; f_min in [5, 10] N and f_max in [15, 25] N contain the
    paper's 7.5 and 22.5 N, always keep f_min < f_max (by 5 N at least) and stay inside the
    0-30 N the judge's demonstrations pressed with."""

    qdot_max: tuple[float, float] = (0.25, 1.0)
    f_min: tuple[float, float] = (5.0, 10.0)
    f_max: tuple[float, float] = (15.0, 25.0)
    task: str = DEFAULT_TASK  # whose demonstrations bound the ranges

    def __post_init__(self) -> None:
        for name in CONDITION_NAMES:
            v = getattr(self, name)
            if len(v) != 2 or not all(np.isfinite(v)) or not v[0] <= v[1]:
                raise ProblemError(f"{name} range {list(v)} must be lo,hi with lo <= hi")
            object.__setattr__(self, name, (float(v[0]), float(v[1])))
        if not self.f_min[1] < self.f_max[0]:
            raise ProblemError(f"f_min range {list(self.f_min)} must lie below the f_max range {list(self.f_max)} "
                               "(every sampled f_min < f_max)")
        task = get_task(self.task)
        speed, force = task.demonstrated_bound("velocity")[1], task.demonstrated_bound("force")
        for name, (lo, hi) in (("qdot_max", (0.0, speed)), ("f_min", force), ("f_max", force)):
            v = getattr(self, name)
            if v[0] < lo or v[1] > hi or (name == "qdot_max" and v[0] <= lo):
                raise ProblemError(f"{name} range {list(v)} leaves [{lo:g}, {hi:g}], what the demonstrations cover "
                                   "(the judge has seen nothing beyond it); narrow the range")

    def to_dict(self) -> dict:
        """The ranges (and the task, where it is not the default one: older files stay as they were)."""
        return {**{k: list(getattr(self, k)) for k in CONDITION_NAMES},
                **({"task": self.task} if self.task != DEFAULT_TASK else {})}

    @classmethod
    def from_dict(cls, d: dict) -> "LimitRanges":
        return cls(**{k: tuple(d[k]) for k in CONDITION_NAMES}, task=d.get("task", DEFAULT_TASK))

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
        position of its environment ranges on every axis (else training would chase infeasible plans)."""
        if problem.task != self.task:
            raise ProblemError(f"limit ranges of task {self.task!r} for a problem of task {problem.task!r}")
        lo_q = self.qdot_max[0]
        if np.any(lo_q <= problem.vec("qdot_min")) or np.any(lo_q < np.maximum(problem.vec("qdot0"), problem.vec("qdot_end"))):
            raise ProblemError(f"qdot_max range {list(self.qdot_max)} must lie above qdot_min = {problem.qdot_min} "
                               f"and the start/terminal velocities")
        slow = problem.with_overrides(qdot_max=lo_q)
        lows, highs = ({k: np.min(v) for k, v in problem.environment.items()},
                       {k: np.max(v) for k, v in problem.environment.items()})
        ends = np.stack([problem.terminal_positions(lows), problem.terminal_positions(highs)])
        for axis in range(problem.n_axes):
            reach = slow.reachable_range(axis)
            e = ends[:, axis][~np.isnan(ends[:, axis])]
            if len(e) and (e.max() > reach[1] + 1e-12 or e.min() < reach[0] - 1e-12):
                raise ProblemError(f"qdot_max = {lo_q} (the bottom of its range) cannot reach q_end = "
                                   f"{e.max():.4g} m on axis {axis} in {problem.steps} steps (reach {reach[0]:.4g} to "
                                   f"{reach[1]:.4g} m); raise the range's lower end")


def wide_limits(task: str = DEFAULT_TASK) -> "LimitRanges":
    """The task's wide limit ranges (`Task.wide_limits`): refinement's and the sweep's default draws."""
    ranges = get_task(task).wide_limits
    if ranges is None:
        raise ProblemError(f"task {task!r} declares no wide limit ranges: give --qdot-max-range, --f-min-range and "
                           "--f-max-range")
    return LimitRanges(**ranges, task=task)


#: limit ranges wider than any shipped problem, down to forces and speeds under which no scoop
#: succeeds at high friction (q̇_max from what reaches the farthest sampled end): refinement's default,
#: the sweep's random limit sets, and the shipped refined conditioned generator's ranges
WIDE_LIMITS = wide_limits(DEFAULT_TASK)


def limits_of(problem: Problem) -> np.ndarray:
    """The conditioned limits of a problem, in CONDITION_NAMES order."""
    return np.array([getattr(problem, k) for k in CONDITION_NAMES], dtype=float)


def coverage_notes(problem: Problem, judge_meta: dict) -> list[str]:
    """Where the limits let a force channel go but the judge's training data never went (less
    than a fifth of the allowed range overlaps what was recorded): the judge's p there is a
    guess, a generator trained through it gets no gradient, and a recording imported with the
    wrong sign is the usual cause. Judges saved without their data's range give no note."""
    data = judge_meta.get("train_data")  # a dict from train-judge; judges saved by other code may hold anything
    ranges = (data.get("ranges") if isinstance(data, dict) else None) or {}
    notes = []
    for c in get_task(problem.task).channels_of("force"):
        if c.name not in ranges:
            continue
        lo, hi = ranges[c.name]
        f_min, f_max = float(np.min(problem.vec("f_min"))), float(np.max(problem.vec("f_max")))
        overlap = max(0.0, min(hi, f_max) - max(lo, f_min))
        if overlap < 0.2 * (f_max - f_min):
            notes.append(f"the limits allow {c.name} in [{f_min:g}, {f_max:g}] {c.unit}, but the judge's training data "
                         f"has {c.name} in [{lo:.3g}, {hi:.3g}] {c.unit}: its success probability there is a guess and "
                         "a generator cannot learn through it; if the recordings press with the other sign, re-import "
                         f"them with --scale {c.name}=-1")
    return notes

