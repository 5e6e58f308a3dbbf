"""What a planner is, and the registry the rest of judgeopt reads its planners from.

A planner turns one environment (and optionally a warm start) into a `PlanResult`; it may change
its limits without being rebuilt (`with_limits`). Each planner has an entry in `REGISTRY`: its
name (the CLI's `--method` choices, the evaluation's rows and calibration settings read them),
what it needs, and how it is built from a problem and its judge. The three built-in planners
are built by `judgeopt.planners.solve.Planners.load`, which shares one generator between them and
lets the generator's plan warm-start the direct solve; a planner added with `register` is built
by its own `build` and runs after them.

Light to import: the command line reads the names at start-up.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, ClassVar

from judgeopt.planners.problem import ProblemError

if TYPE_CHECKING:
    from judgeopt.planners.result import PlanResult

#: `--method` values that name several planners or a mode, not one planner
RESERVED = ("both", "all", "receding")


class Planner(ABC):
    """One way of planning for a problem: `solve` for an environment, from a warm start if given."""

    method: ClassVar[str]

    @abstractmethod
    def solve(self, env: dict[str, float], guess: Any = None) -> "PlanResult":
        """A plan for `env`, with its predicted success, status, residuals and timing."""

    def with_limits(self, problem: Any) -> "Planner":
        """The same planner for a problem that differs only in its limits."""
        raise ProblemError(f"planner {self.method!r} cannot change its limits without being rebuilt")


@dataclass(frozen=True)
class PlannerSpec:
    """A planner's registry entry."""

    name: str
    description: str
    #: what it is built from: "judge", "generator"
    needs: tuple[str, ...] = ("judge",)
    #: (problem, judge model) -> Planner; None for the built-ins, which `Planners.load` builds
    build: Callable[[Any, Any], Planner] | None = None


REGISTRY: dict[str, PlannerSpec] = {}


def register(spec: PlannerSpec) -> PlannerSpec:
    """Add a planner: its name becomes a `--method` choice, an evaluation row and a setting."""
    if spec.name in REGISTRY or spec.name in RESERVED or not spec.name.isidentifier():
        raise ProblemError(f"planner name {spec.name!r} is taken or not a plain name (taken: "
                           f"{', '.join([*REGISTRY, *RESERVED])})")
    REGISTRY[spec.name] = spec
    return spec


def unregister(name: str) -> None:
    REGISTRY.pop(name, None)


def planner_names() -> tuple[str, ...]:
    """Every registered planner, built-ins first."""
    return tuple(REGISTRY)


register(PlannerSpec("amortized", "the paper's generator (eqs. 2-4): a plan in a millisecond, limits held softly",
                     ("judge", "generator")))
register(PlannerSpec("direct", "Ipopt over the judge's CasADi function, every limit and the terminal state hard, "
                     "warm-started from the generator's plan"))
register(PlannerSpec("cem", "the sampling baseline: cross-entropy search over spline commands, the same judge"))
