"""Ranges of [constraints] (a_max, jerk_max, fdot_max and an early force cap) and the seeded
drawing of one feasible constraint set from them.

Two consumers draw from here: `judgeopt evaluate sweep --random-constraints` (held-out sets,
each feasible for every environment of the sweep) and `judgeopt refine --sample-constraints`
(one set per environment of a round, feasible for that environment, so the judge sees the
outcomes of plans made under constraints it was never trained on). A set is a dict of problem
overrides, {a_max, jerk_max, fdot_max, bounds}, for Problem.with_overrides or
Planners.with_limits (the direct solve swaps its bounds without a rebuild).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np

from judgeopt.planners.problem import InfeasibleProblemError, Problem, ProblemError

#: the fields a drawn set overrides, in the order they are drawn and labelled
CONSTRAINT_FIELDS = ("a_max", "jerk_max", "fdot_max", "bounds")

#: redraws of one constraint set before giving up on the ranges
CONSTRAINT_DRAWS = 20

_RANGE_NAMES = ("a_max", "jerk_max", "fdot_max", "force_cap", "force_cap_until")


@dataclass(frozen=True)
class ConstraintRanges:
    """Where constraint sets are drawn from (uniform, independently): each set limits the
    acceleration, the jerk and the force rate, and caps the force early in the motion,
    F:0:HI@0:T1 on the task's first force channel. The defaults bind on the generator's plans for
    paper_sim at its limits (30 environments: max |a| 2.7-10.5 m/s², median 7.5; max |jerk|
    46-134 m/s³, median 113; max |ḟ| 33-139 N/s, median 66; force in the first 0.4 s up to
    22.4 N), so each set is active on nearly every plan the generator makes."""

    a_max: tuple[float, float] = (2.0, 6.0)  # m/s²
    jerk_max: tuple[float, float] = (20.0, 80.0)  # m/s³
    fdot_max: tuple[float, float] = (20.0, 60.0)  # N/s
    force_cap: tuple[float, float] = (10.0, 18.0)  # N: HI of the early force bound
    force_cap_until: tuple[float, float] = (0.2, 0.6)  # s: T1 of the early force bound (on the time grid)

    def __post_init__(self) -> None:
        for name in _RANGE_NAMES:
            v = getattr(self, name)
            if len(v) != 2 or not all(np.isfinite(v)) or not 0 < v[0] <= v[1]:
                raise ProblemError(f"{name} range {list(v)} must be lo,hi with 0 < lo <= hi")
            object.__setattr__(self, name, (float(v[0]), float(v[1])))

    def to_dict(self) -> dict[str, list[float]]:
        return {k: list(getattr(self, k)) for k in _RANGE_NAMES}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "ConstraintRanges":
        return cls(**{k: tuple(d[k]) for k in _RANGE_NAMES if k in d})


def corners(problem: Problem) -> list[dict[str, float]]:
    """The environment ranges' corners: the terminal positions they give span every environment's
    (a linear program's feasible ends form an interval)."""
    values = [v if isinstance(v, tuple) else (v,) for v in problem.environment.values()]
    return [dict(zip(problem.environment, c)) for c in itertools.product(*values)]


def _draw_once(rng: np.random.Generator, problem: Problem, ranges: ConstraintRanges, force: str) -> dict[str, Any]:
    """One set, unchecked; numbers to 3 significant figures (as a label shows them)."""
    from judgeopt.planners.constraints import Bound

    a, j, fd, cap = (rng.uniform(*getattr(ranges, n)) for n in ("a_max", "jerk_max", "fdot_max", "force_cap"))
    until = max(1, round(rng.uniform(*ranges.force_cap_until) / problem.dt)) * problem.dt
    three = lambda x: float(f"{x:.3g}")  # noqa: E731
    return {"a_max": three(a), "jerk_max": three(j), "fdot_max": three(fd),
            "bounds": (Bound.parse(f"{force}:0:{cap:.3g}@0:{until:.3g}").text,)}


def draw_constraints(rng: np.random.Generator, problem: Problem, ranges: ConstraintRanges | None = None,
                     envs: list[dict[str, float]] | None = None, draws: int = CONSTRAINT_DRAWS) -> dict[str, Any]:
    """One constraint set {a_max, jerk_max, fdot_max, bounds} drawn from `ranges` (default
    ConstraintRanges()) with `rng`, feasible on `problem` (its limits and other fields) for every
    environment in `envs` (default: the corners of its environment ranges), checked with
    judgeopt.planners.feasible.check; a set that is not is drawn again, up to `draws` times, then
    ProblemError. The rng advances by the draws made, so successive calls give successive sets."""
    from judgeopt.planners.feasible import check

    ranges = ranges if ranges is not None else ConstraintRanges()
    force = next((c.name for c in problem.channel_spec if c.kind == "force"), None)
    if force is None:
        raise ProblemError(f"constraint sets cap a force channel early; {problem.name} has none")
    envs = envs if envs is not None else corners(problem)
    why = ""
    for _ in range(draws):
        overrides = _draw_once(rng, problem, ranges, force)
        p = problem.with_overrides(**overrides)
        try:
            for env in envs:
                check(p, env)
        except InfeasibleProblemError as exc:
            why = str(exc)
            continue
        return overrides
    raise ProblemError(f"no feasible constraint set in {draws} draws from {ranges} at the limits of "
                       f"{problem.source or problem.name} (the last: {why}); widen the ranges")


def describe_set(overrides: dict[str, Any]) -> str:
    """`a_max 2.19, jerk_max 71.8, fdot_max 26.1, f:0:12.4@0:0.3`."""
    return ", ".join(", ".join(v) if k == "bounds" else f"{k} {v:g}" for k, v in overrides.items())
