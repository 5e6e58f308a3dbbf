"""What a planner is, and the registry the rest of judgeopt reads its planners from.

A planner turns one environment (and optionally a warm start) into a `PlanResult`; it may change
its limits without being rebuilt (`with_limits`). Each planner has an entry in `REGISTRY`, added
with `register(PlannerSpec(...))`: its name (the CLI's `--method` choices, the evaluations' rows
and the calibration settings read them), what it needs, which models its outcomes depend on and
where its class is. The built-in planners are registered the same way, in
`judgeopt.planners.builtin` (imported with the package, so they come first), and built the same
way: `PlannerSpec.make(context)` calls the class's `build(context)`. A planner that needs the
simulator (a `ClosedLoopPlanner`, e.g. the receding planner) plans while its plan is executed: it
runs after the others are replayed, from their results.

A planner of one's own reaches every consumer three ways: its module calls `register` when it is
imported (`judgeopt solve --plugin MODULE`, or MODULE in $JUDGEOPT_PLUGINS: `load_plugins`), or an
installed package declares it (`register_installed`). Plugins are imported at run time, when a planner
not registered yet is asked for, never to build the parser.

Light to import: the command line reads the names at start-up (a class given as "module:Class"
is imported when the planner is first built).
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import json
import os
import sys
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Iterable, Iterator

from judgeopt.errors import JudgeoptError
from judgeopt.planners.problem import LIMIT_NAMES, SECTIONS, Problem, ProblemError

if TYPE_CHECKING:
    from judgeopt.planners.result import PlanResult

#: `--method` values that name several planners: those run when none is named (PlannerSpec.default), every one
GROUPS = ("default", "all")
#: older spellings of a group, still accepted
GROUP_ALIASES = {"both": "default"}
#: what a planner may need to be built or to run
NEEDS = ("judge", "generator", "simulator")
#: the models a planner's outcomes may depend on (its calibration setting hashes their weights)
MODELS = ("judge", "generator", "ensemble", "trust_model")
#: problem fields only some planners read: a planner's setting holds those its entry `reads`
PLANNER_OPTIONS = ("objective", "p_target", "replan_period", "replan_trigger")
#: where a warm-started planner (the direct solve) starts: the plan of the planner its entry names
#: (the generator's, where one covers the limits), or cold
WARM_STARTS = ("generator", "none")


@dataclass
class BuildContext:
    """What a planner is built from: the problem, its judge, the generator found for its limits
    (None: no generator covers them), the planners its entry `uses` (by name), the CasADi backend
    asked for (None: the default), and the notes the user is shown (a build may add to them)."""

    problem: Any  # judgeopt.planners.problem.Problem
    judge: Any  # judgeopt.judge.model.Judge
    judge_meta: dict
    generator: Any = None  # judgeopt.planners.generator.Generator
    casadi_backend: str | None = None
    notes: list[str] = field(default_factory=list)
    uses: dict[str, "Planner"] = field(default_factory=dict)


class Planner(ABC):
    """One way of planning for a problem: `solve` for an environment, from a warm start if given."""

    method: ClassVar[str]
    #: True: `for_env_set` gives one plan judged over a set of environments (a variable given as a range)
    plans_env_sets: ClassVar[bool] = False

    def __init__(self, problem: Any, judge: Any):
        self.problem, self.judge = problem, judge

    @classmethod
    def build(cls, context: BuildContext) -> "Planner":
        """The planner for the context's problem; by default from the problem and the judge alone."""
        return cls(context.problem, context.judge)

    @abstractmethod
    def solve(self, env: dict[str, float], guess: Any = None) -> "PlanResult":
        """A plan for `env`, with its predicted success, status, residuals and timing."""

    def warm_start_plan(self, env: dict[str, float], guess: Any = None) -> Any:
        """Its plan for `env` where it only warm-starts another planner (its own result is not
        reported), made without what only a reported result carries (the judge's p, residuals);
        None (the default): `solve` is run and its plan taken."""
        return None

    def with_limits(self, problem: Any) -> "Planner | None":
        """The same planner for a problem that differs only in its limits; None (the default):
        it is built again for them."""
        return None

    def warm_up(self, cold: bool = False) -> float:
        """Pay what a first solve in a process pays on its own before any plan is timed; the
        seconds it took (`cold`: the solve will start without a warm start)."""
        return 0.0

    def for_env_set(self, samples: int, case: str) -> "Planner":
        """The planner for one plan judged over `samples` environments at once, in their worst
        `case` or on average (only where `plans_env_sets`)."""
        raise ProblemError(f"planner {self.method!r} plans for one environment; it cannot plan over a set")

    def details(self, result: "PlanResult") -> list[str]:
        """Lines `judgeopt solve` prints about this planner's result below the table: where the arm's
        joint limits are held (joint_limit_scale), the joint nearest its scaled limit, or furthest over it."""
        scale = getattr(self.problem, "joint_limit_scale", None)
        if scale is None or result.plan is None:
            return []
        from judgeopt.planners.joint_limits import joint_map

        joints = joint_map(self.problem)
        joint, quantity, ratio = joints.binding(result.plan, scale)
        where = "over" if ratio > 1.0 + 1e-6 else "the nearest"
        # where it binds: the limit's value at which every joint holds
        advice = joints.advice(result.plan, scale, float(self.problem.vec("f_min")[0]))
        return [f"{result.method}, joints: {joint}'s {quantity} is {where} its limit x {scale:g}, at {ratio:.0%} of it"
                + (f": {advice}" if advice else "")]


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
    """A planner's registry entry: what every consumer reads instead of its name."""

    name: str
    description: str
    #: the Planner subclass, or where to find it ("module:Class", imported when first built: the
    #: command line reads names only); built by its `build(context)`
    build: type[Planner] | str | None = None
    #: what it is built from or runs in (NEEDS): without a generator covering the limits it is left
    #: out; with "simulator" it is a ClosedLoopPlanner
    needs: tuple[str, ...] = ("judge",)
    #: planners it is built on, loaded and reported with it (`--method receding` also runs "direct")
    uses: tuple[str, ...] = ()
    #: the planner whose plan starts its search (its `guess`), run for that even where not asked for;
    #: a guess given to `Planners.solve` replaces it, `--warm-start none` drops it
    warm_start: str | None = None
    #: the models its outcomes depend on (MODELS): its calibration setting and description name them
    models: tuple[str, ...] = ("judge",)
    #: the PLANNER_OPTIONS it reads (the others are left out of its calibration setting)
    reads: tuple[str, ...] = ()
    #: run when no planner is named (`--method default`, the library's solve, `evaluate robustness`)
    default: bool = False
    #: one of the paper's planners (Furuta et al. 2020): a row of the task's paper tables
    paper: bool = False
    #: a baseline compared beside the paper's planners (`evaluate sweep`, the scoop's compare table)
    baseline: bool = False

    @property
    def closed_loop(self) -> bool:
        return "simulator" in self.needs

    def planner_class(self) -> type[Planner]:
        """`build`, imported where it is given as "module:Class"."""
        if not isinstance(self.build, str):
            return self.build
        module, _, attr = self.build.partition(":")
        found: Any = importlib.import_module(module)
        for part in attr.split("."):
            found = getattr(found, part)
        return found

    def make(self, context: BuildContext) -> Planner:
        """The planner built for `context`."""
        return self.planner_class().build(context)

    def check(self) -> None:
        """A one-line error naming the fix for an entry the rest of judgeopt could not use."""
        bad = {"needs": set(self.needs) - set(NEEDS), "models": set(self.models) - set(MODELS),
               "reads": set(self.reads) - set(PLANNER_OPTIONS)}
        for key, allowed in (("needs", NEEDS), ("models", MODELS), ("reads", PLANNER_OPTIONS)):
            if bad[key]:
                raise ProblemError(f"planner {self.name!r}: {key} {sorted(bad[key])} unknown; choose from "
                                   f"{', '.join(allowed)}")
        unknown = [m for m in (*self.uses, *filter(None, [self.warm_start])) if m not in REGISTRY]
        if unknown:
            raise ProblemError(f"planner {self.name!r} is built on {', '.join(unknown)}: register "
                               f"{'it' if len(unknown) == 1 else 'them'} first")
        if self.build is None or (not isinstance(self.build, str) and not
                                  (isinstance(self.build, type) and issubclass(self.build, Planner))):
            raise ProblemError(f"planner {self.name!r}: give build=YourPlanner (a Planner subclass) or "
                               f"build=\"module:YourPlanner\"")


REGISTRY: dict[str, PlannerSpec] = {}


def register(spec: PlannerSpec) -> PlannerSpec:
    """Add a planner: its name becomes a `--method` choice, an evaluation row and a setting."""
    taken = (*REGISTRY, *GROUPS, *GROUP_ALIASES)
    if spec.name in taken or not spec.name.isidentifier():
        raise ProblemError(f"planner name {spec.name!r} is taken or not a plain name (taken: {', '.join(taken)})")
    spec.check()
    REGISTRY[spec.name] = spec
    return spec


def unregister(name: str) -> None:
    REGISTRY.pop(name, None)


#: installed packages' planners: `[project.entry-points."judgeopt.planners"] NAME = "pkg.module:SPEC"`, SPEC a
#: PlannerSpec; registered when judgeopt.planners is imported, so worker processes see them too
ENTRY_POINT_GROUP = "judgeopt.planners"


def register_installed(found: Iterable[Any] | None = None) -> list[str]:
    """Register every installed package's planner (`found`: entry points, default the group's) not
    already registered; the names registered. One that does not load or is no PlannerSpec is a
    one-line error naming the package's entry."""
    from importlib.metadata import entry_points

    added = []
    for ep in entry_points(group=ENTRY_POINT_GROUP) if found is None else found:
        if ep.name in REGISTRY:
            continue
        try:
            spec = ep.load()
        except Exception as exc:  # noqa: BLE001 -- an installed package's import error, said in one line
            raise ProblemError(f"planner entry point {ep.name} = {ep.value!r} does not load ({type(exc).__name__}: "
                               f"{exc}); fix or uninstall the package that declares it") from None
        if not isinstance(spec, PlannerSpec) or spec.name != ep.name:
            raise ProblemError(f"planner entry point {ep.name} = {ep.value!r} must name a PlannerSpec called "
                               f"{ep.name!r}")
        register(spec)
        added.append(spec.name)
    return added


#: modules whose import registers planners, comma-separated (`JUDGEOPT_PLUGINS=mylab.planners,other`):
#: imported by `load_plugins`, when a planner not registered yet is asked for and by `judgeopt solve`
PLUGINS_ENV = "JUDGEOPT_PLUGINS"


def plugin_modules(given: Iterable[str] = ()) -> list[str]:
    """`given`, then the modules $JUDGEOPT_PLUGINS names, each once."""
    named = [*given, *os.environ.get(PLUGINS_ENV, "").split(",")]
    return list(dict.fromkeys(m.strip() for m in named if m.strip()))


@contextlib.contextmanager
def _current_folder_searched() -> Iterator[None]:
    """The current folder on the import path, last, as `python -m` has it (the `judgeopt` script does not)."""
    here = os.getcwd()
    added = here not in sys.path and "" not in sys.path
    if added:
        sys.path.append(here)
    try:
        yield
    finally:
        if added and here in sys.path:
            sys.path.remove(here)


def load_plugins(modules: Iterable[str] = ()) -> list[str]:
    """Import `modules` and those $JUDGEOPT_PLUGINS names, so that their `register(...)` lines run
    (each once: Python imports a module once); the planner names they added. The current folder is
    searched too. A module that does not import, or whose planner is refused, is a one-line error
    naming it."""
    before = set(REGISTRY)
    for module in plugin_modules(modules):
        try:
            with _current_folder_searched():
                importlib.import_module(module)
        except JudgeoptError as exc:  # its register(...) refused (a name taken, an entry incomplete)
            raise ProblemError(f"plugin {module}: {exc}") from None
        except Exception as exc:  # noqa: BLE001 -- the user's module's import error, said in one line
            said = str(exc).splitlines()[0] if str(exc) else ""
            raise ProblemError(f"plugin {module!r} does not import ({type(exc).__name__}: {said}); give a module on "
                               "the Python path or in the current folder whose import registers its planners "
                               "(judgeopt.planners.base.register)") from None
    return [n for n in REGISTRY if n not in before]


def unknown(names: Iterable[str]) -> list[str]:
    """Those of `names` no planner is registered as, once the plugins are imported (only where
    one is missing: a worker process finds its parent's $JUDGEOPT_PLUGINS planners this way)."""
    names = list(names)
    if any(n not in REGISTRY for n in names):
        load_plugins()
    return [n for n in names if n not in REGISTRY]


def spec_of(name: str) -> PlannerSpec:
    """The registry entry of `name` (a plugin's imported where needed); a one-line error naming the
    registered ones otherwise."""
    if unknown([name]):
        raise ProblemError(f"unknown planner {name!r}; choose from {', '.join(REGISTRY)} (or register it: "
                           f"judgeopt.planners.base.register, in a module given to --plugin or ${PLUGINS_ENV})")
    return REGISTRY[name]


def planner_names(open_loop: bool = False) -> tuple[str, ...]:
    """Every registered planner, built-ins first (`open_loop`: those that plan before execution)."""
    return tuple(n for n, s in REGISTRY.items() if not (open_loop and s.closed_loop))


def default_planners() -> tuple[str, ...]:
    """The planners run when none is named (PlannerSpec.default)."""
    return tuple(n for n, s in REGISTRY.items() if s.default)


def group(name: str, simulate: bool = True) -> tuple[str, ...]:
    """The planners a group (GROUPS, or an alias of one) names; without `simulate`, those that
    plan while executing are left out."""
    name = GROUP_ALIASES.get(name, name)
    if name not in GROUPS:
        raise ProblemError(f"{name!r} is not a group of planners; choose from {', '.join(GROUPS)}")
    names = default_planners() if name == "default" else planner_names()
    return tuple(n for n in names if simulate or not REGISTRY[n].closed_loop)


def with_uses(methods: tuple[str, ...] | list[str]) -> tuple[str, ...]:
    """`methods` with the planners each is built on, those first (e.g. receding -> direct, receding)."""
    return tuple(dict.fromkeys(u for m in methods for u in (*(REGISTRY[m].uses if m in REGISTRY else ()), m)))


def to_build(methods: tuple[str, ...] | list[str]) -> tuple[str, ...]:
    """`methods` with what each is built on and the planner that warm-starts it, in registry
    order: a planner is registered after those, so each comes after what it needs."""
    found: set[str] = set()
    todo = list(methods)
    while todo:
        s = spec_of(todo.pop())
        if s.name not in found:
            found.add(s.name)
            todo += [*s.uses, *filter(None, [s.warm_start])]
    return tuple(n for n in REGISTRY if n in found)


def setting_id(method: str, problem: Problem, shas: dict[str, str], over_limits: bool = False,
               over_constraints: bool = False) -> str:
    """What a planner's outcomes depend on besides the environment: the method, the models'
    weights (by hash, not by path) and every limit and solver option. `over_limits`: the same
    without the limits, the key of a calibrator that takes the limits as inputs. `over_constraints`:
    without the limits and the constraint set either, the key of a calibrator fitted on plans drawn
    under many constraint sets (each set is a setting of its own, too few plans to fit on alone)."""
    # the task is left out: the judge's hash already tells tasks apart (and ids fitted before tasks stay valid)
    skip = {"name", "description", "source", "task", "environment", *SECTIONS["models"]}
    skip |= set(LIMIT_NAMES) if over_limits or over_constraints else set()
    skip |= set(SECTIONS["constraints"]) if over_constraints else set()
    # the options only some planners read (the direct solve's target, the receding planner's period): its own
    spec = REGISTRY.get(method)
    skip |= set(PLANNER_OPTIONS) - set(spec.reads if spec is not None else ())
    p = {k: v for k, v in problem.to_dict().items() if k not in skip}
    kind = {"over_limits": over_limits or None} | ({"over_constraints": True} if over_constraints else {})
    blob = json.dumps({"method": method, "problem": p, "models": shas, **kind},
                      sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]
