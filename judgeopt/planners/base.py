"""What a planner is, and the registry the rest of judgeopt reads its planners from.

A planner turns one environment (and optionally a warm start) into a `PlanResult`; it may change
its limits without being rebuilt (`with_limits`). Each planner has an entry in `REGISTRY`: its
name (the CLI's `--method` choices, the evaluation's rows and calibration settings read them),
what it needs, and how it is built from a problem and its judge. The three built-in planners
are built by `judgeopt.planners.solve.Planners.load`, which shares one generator between them and
lets the generator's plan warm-start the direct solve; a planner added with `register` is built
by its own `build` (given the planners it `uses`) and runs after them. A planner that needs the
simulator (a `ClosedLoopPlanner`, e.g. the receding planner) plans while its plan is executed:
it runs after the others are replayed, from their results.

Light to import: the command line reads the names at start-up.
"""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, ClassVar

from judgeopt.planners.problem import ProblemError

if TYPE_CHECKING:
    from judgeopt.planners.result import PlanResult

#: `--method` values that name several planners, not one
RESERVED = ("both", "all")


class Planner(ABC):
    """One way of planning for a problem: `solve` for an environment, from a warm start if given."""

    method: ClassVar[str]

    @abstractmethod
    def solve(self, env: dict[str, float], guess: Any = None) -> "PlanResult":
        """A plan for `env`, with its predicted success, status, residuals and timing."""

    def with_limits(self, problem: Any) -> "Planner":
        """The same planner for a problem that differs only in its limits."""
        raise ProblemError(f"planner {self.method!r} cannot change its limits without being rebuilt")


class ClosedLoopPlanner(Planner):
    """A planner that plans during execution: `run` executes in the simulator, from the open-loop
    planners' results for the same environment, and returns the executed plan as a result."""

    def solve(self, env: dict[str, float], guess: Any = None) -> "PlanResult":
        raise ProblemError(f"planner {self.method!r} plans while its plan is executed: run it with a simulator "
                           f"(judgeopt solve --method {self.method}, without --no-simulate)")

    @abstractmethod
    def run(self, simulator: Any, results: list["PlanResult"], env: dict[str, float],
            world: dict[str, float]) -> "PlanResult":
        """Execute in `world` (the simulated one, which may differ from `env`, what was said)."""


@dataclass(frozen=True)
class PlannerSpec:
    """A planner's registry entry."""

    name: str
    description: str
    #: what it is built from or runs in: "judge", "generator", "simulator" (a ClosedLoopPlanner)
    needs: tuple[str, ...] = ("judge",)
    #: (problem, judge model, **the planners it uses by name) -> Planner, or where to find it
    #: ("module:Class.method", imported when first built: the command line reads names only);
    #: None for the built-ins, which `Planners.load` builds
    build: Callable[..., Planner] | str | None = None
    #: planners it is built on, loaded with it (`--method receding` also runs "direct")
    uses: tuple[str, ...] = ()

    @property
    def closed_loop(self) -> bool:
        return "simulator" in self.needs

    def builder(self) -> Callable[..., Planner]:
        """`build`, imported where it is given as "module:attribute"."""
        if not isinstance(self.build, str):
            return self.build
        module, _, attr = self.build.partition(":")
        found: Any = importlib.import_module(module)
        for part in attr.split("."):
            found = getattr(found, part)
        return found


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


def with_uses(methods: tuple[str, ...] | list[str]) -> tuple[str, ...]:
    """`methods` with the planners each is built on, those first (e.g. receding -> direct, receding)."""
    return tuple(dict.fromkeys(u for m in methods for u in (*(REGISTRY[m].uses if m in REGISTRY else ()), m)))


def planner_names() -> tuple[str, ...]:
    """Every registered planner, built-ins first."""
    return tuple(REGISTRY)


register(PlannerSpec("amortized", "the paper's generator (eqs. 2-4): a plan in a millisecond, limits held softly",
                     ("judge", "generator")))
register(PlannerSpec("direct", "Ipopt over the judge's CasADi function, every limit and the terminal state hard, "
                     "warm-started from the generator's plan"))
register(PlannerSpec("cem", "the sampling baseline: cross-entropy search over spline commands, the same judge"))


register(PlannerSpec("receding", "the direct solve re-run during execution, every [solver] replan_period, from what "
                     "the arm measured", ("judge", "simulator"), "judgeopt.planners.receding:RecedingPlanner.built",
                     uses=("direct",)))
