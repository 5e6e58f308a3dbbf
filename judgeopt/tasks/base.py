"""What judgeopt needs from a task, and nothing more.

A task is a contact-rich motion whose success only a simulator (or the real world) can tell:
its signal channels (positions, their velocities, forces), its environment variables, how the
environment fixes the motion's end, random demonstration commands, and `simulate`. The judge,
the planners, the datasets and the command line work through this interface, so a new task is
a new subclass (docs/tasks.md), not a change to them.
"""

from __future__ import annotations

import functools

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from judgeopt.errors import UsageError
from judgeopt.trajectory import DEFAULT_DT, DEFAULT_HORIZON, Channel, Plan

class TaskError(UsageError, ValueError):
    """An unknown task, or data, a model or a plan made for another task."""


class EnvironmentRangeError(UsageError, ValueError):
    """An environment value outside what the task's simulator accepts."""


@dataclass(frozen=True)
class EnvVar:
    """An environment variable: its physical range (what the simulator accepts), the range
    demonstrations are drawn from by default, and the value a simulated world has where a
    problem does not give it (a judge that does not read the variable still needs a world
    that has one)."""

    name: str
    unit: str
    physical: tuple[float, float]
    sampled: tuple[float, float]
    description: str = ""
    nominal: float | None = None  # None: the sampled range's midpoint

    def __post_init__(self) -> None:
        lo, hi = self.physical
        if not (lo <= self.sampled[0] <= self.sampled[1] <= hi):
            raise TaskError(f"environment variable {self.name!r}: sampled range {self.sampled} not within {self.physical}")
        if not lo <= self.default <= hi:
            raise TaskError(f"environment variable {self.name!r}: nominal {self.nominal} not within {self.physical}")

    @property
    def default(self) -> float:
        """The simulated world's value where a problem leaves the variable out."""
        return float(self.nominal) if self.nominal is not None else 0.5 * (self.sampled[0] + self.sampled[1])


@dataclass(frozen=True)
class Perturbation:
    """A way the world may differ from the one a plan was made for, unseen by the planner: a
    misestimated environment value, or a scene parameter the environment vector does not name
    (the object's mass, the mat's stiffness, the controller's gains, the force sensor's bias).

    `value` is a factor of the nominal (`unit` "x", nominal 1) or an offset from it (nominal 0);
    `physical` is what the task's simulator accepts (a randomisation range must lie in it);
    `values` are the ones `judgeopt evaluate robustness` replays by default. The same names are
    what `judgeopt collect --randomize NAME=LO,HI` draws per demonstration."""

    name: str
    unit: str
    physical: tuple[float, float]
    values: tuple[float, ...]
    description: str = ""
    nominal: float = 0.0
    #: the environment variable this one misestimates (the plan is made for the told value, the
    #: world has the told value times or plus this one); empty: a parameter of the scene
    env: str = ""

    def __post_init__(self) -> None:
        lo, hi = self.physical
        if self.unit == "x" and self.nominal != 1.0:
            raise TaskError(f"perturbation {self.name!r}: a factor (unit 'x') is nominal at 1")
        if not (lo <= self.nominal <= hi) or not all(lo <= v <= hi for v in self.values):
            raise TaskError(f"perturbation {self.name!r}: nominal {self.nominal} and values {self.values} must lie in "
                            f"its physical range {self.physical}")

    def label(self, value: float) -> str:
        """`NAME x2` for a factor, `NAME +0.03 m` where the value may be negative, else `NAME 0.5 N`."""
        if self.unit == "x":
            return f"{self.name} x{value:g}"
        sign = "+" if self.physical[0] < 0 else ""  # an offset either way shows its sign
        return f"{self.name} {value:{sign}g}{' ' + self.unit if self.unit else ''}"

    def apply(self, told: float, value: float) -> float:
        """The true value of a misestimated environment variable told `told`."""
        return told * value if self.unit == "x" else told + value


@dataclass
class Outcome:
    """What a simulated (or executed) plan gave: its label, the measured response on the plan's
    channels and sample times, and task-specific details (object rise, offsets, ...)."""

    success: bool
    response: np.ndarray
    details: dict[str, Any] = field(default_factory=dict)
    # how close a failure came, for searches scored by the simulator: above 1 only on success
    progress: float = 0.0


@dataclass(frozen=True)
class ArmModel:
    """A task's arm as the planners' joint-limit constraints see it (judgeopt.planners.joint_limits):
    the tool moves along the plan's position axes at a pose the task fixes, and presses along one
    direction: the joint velocities follow from the Jacobian, the torques from gravity, the pressing
    force and the arm's inertia along the motion (the contact's moment left out)."""

    model: Any  # pinocchio.Model of the arm (and its tool), the one the simulator's controller uses
    tool_frame: int  # the frame the plan's positions move (Pinocchio frame id)
    joints: tuple[str, ...]  # the actuated joints, in the model's velocity order
    #: positions (one per axis) -> the tool frame's pose (pinocchio.SE3) in the model's world
    pose: Callable[[np.ndarray], Any]
    #: positions, a starting configuration (None: the task's home posture) -> joint angles at `pose`
    ik: Callable[[np.ndarray, np.ndarray | None], np.ndarray]
    #: (axes, 3): each position axis's direction in the world (per unit position)
    axes: np.ndarray
    #: (3,): the force the tool exerts on the environment per unit of the plan's force channel (world)
    force_axis: np.ndarray

    @functools.cached_property
    def data(self) -> Any:
        """One pinocchio.Data for the computations on this arm, made once (making one costs 20 us,
        as much as a Jacobian): scratch space that each computation fills before it reads, so one
        process's planners share it; not for threads."""
        return self.model.createData()


def with_setting(settings: Any, key: str, text: str) -> Any:
    """`settings` with the field at dotted `key` (e.g. "commands.constant_force_share") set to
    `text`, parsed as the field's current type."""
    import dataclasses

    head, _, rest = key.partition(".")
    if settings is None or not dataclasses.is_dataclass(settings) or head not in {f.name for f in dataclasses.fields(settings)}:
        known = [f.name for f in dataclasses.fields(settings)] if dataclasses.is_dataclass(settings) else []
        raise TaskError(f"no setting {key!r} (settings here: {', '.join(known) or 'none'})")
    current = getattr(settings, head)
    if rest:
        return dataclasses.replace(settings, **{head: with_setting(current, rest, text)})
    if dataclasses.is_dataclass(current):
        raise TaskError(f"setting {key!r} is a group: name one of its fields ({key}.FIELD)")
    try:
        if isinstance(current, bool):
            value: Any = {"true": True, "false": False}[text.lower()]
        elif isinstance(current, (int, float, str)):
            value = type(current)(text)
        elif isinstance(current, tuple):
            value = tuple(type(current[0])(v) for v in text.split(","))
        else:
            raise TaskError(f"setting {key!r} ({type(current).__name__}) cannot be set from the command line")
    except (KeyError, ValueError):
        raise TaskError(f"setting {key!r} = {text!r}: expected a value like {current!r}") from None
    if any(isinstance(v, float) and not math.isfinite(v) for v in (value if isinstance(value, tuple) else (value,))):
        raise TaskError(f"setting {key!r} = {text!r}: expected a finite number like {current!r}")
    return dataclasses.replace(settings, **{head: value})


class TaskSimulator(ABC):
    """One simulator instance per process (it may hold a physics client)."""

    def perturb(self, values: Mapping[str, float], seed: int | Sequence[int] = 0) -> None:
        """Run the following rollouts in a world that differs from the nominal one by `values`
        (perturbation name -> value, checked by `Task.check_perturbation`; a name left out is
        nominal, `{}` is the nominal world); `seed` (an int or ints, as numpy's default_rng takes)
        seeds their random part (sensor noise) anew for each rollout, and `simulate(plan, env)`
        then replays a plan made for `env` in that world. A task that declares perturbations
        overrides this."""
        if any(float(v) != 0.0 for v in values.values()):
            raise TaskError(f"this simulator cannot perturb its world (asked for {', '.join(values)})")

    def execute(self, plan: Any, env: Mapping[str, float], record: int = 0) -> Any:
        """Start executing `plan` in `env`, to be stepped: an object with `advance(plan, k)`
        (control steps up to planner sample k of a possibly re-planned command), `k` (samples
        measured), `measured()` ((k, channels) responses so far), and `outcome()` (the rest of
        the plan, then the task's success test). A task that can be stepped overrides this."""
        raise TaskError(f"task {type(self).__name__} cannot be executed step by step (no TaskSimulator.execute); "
                        "plan open loop instead")

    @abstractmethod
    def simulate(self, plan: Any, env: Mapping[str, float], record: int = 0) -> Outcome:
        """Replay `plan` (a Plan, or a (horizon + 1, channels) array at the task's dt) in
        environment `env`; `record` > 0 keeps every record-th physics step for rendering."""


class Task(ABC):
    """A task: subclass it, fill in the class attributes and the two abstract methods."""

    name: str
    description: str
    channels: tuple[Channel, ...]
    env_vars: tuple[EnvVar, ...]
    horizon: int = DEFAULT_HORIZON
    dt: float = DEFAULT_DT
    #: the judge a problem of this task plans against unless it names another
    default_judge: str = ""
    #: the grid of environments demonstrations are collected on with `collect --per-env` (optional)
    demo_grid: dict[str, tuple[float, ...]] | None = None
    #: the environment variable `judgeopt plot-data` splits demonstrations by, one panel between each
    #: pair of these edges, so that variable's effect shows (optional; None: one panel of all)
    demo_panels: tuple[str, tuple[float, ...]] | None = None
    #: where a problem's plans end unless its file gives q_end: a number, the name of an environment
    #: variable (the plan ends where the environment puts it) or "free" (the planner's choice)
    default_q_end: float | str = "free"
    #: ranges of q̇_max, f_min and f_max (lo, hi) wider than any shipped problem, down to limits
    #: under which the task fails: what refinement and the sweep draw limits from (optional)
    wide_limits: dict[str, tuple[float, float]] | None = None
    #: ranges of limits and environment variables (lo, hi) where the task's scoops start to fail:
    #: where `judgeopt evaluate band` draws settings to check the verdict on (optional)
    edge_band: dict[str, tuple[float, float]] | None = None
    #: how the world may differ from the one a plan is made for (`Perturbation`); the task's
    #: simulator applies them (`TaskSimulator.perturb`). Empty: none declared
    perturbations: tuple[Perturbation, ...] = ()
    #: per perturbation, the half-width of a lab's trial-to-trial spread around its nominal value
    #: (`judgeopt evaluate trials`, judgeopt.evaluate.trials). Empty: every trial the nominal world
    trial_spread: Mapping[str, float] = MappingProxyType({})
    #: whether the simulator's Outcome.progress grades how near a failed rollout came to success: the
    #: feasibility search climbs it, and `evaluate edge` needs that search to find where outcomes flip
    graded_outcome: bool = False
    #: numeric outcome details (key, label, unit, scale) `evaluate robustness` reports besides success
    outcome_measures: tuple[tuple[str, str, str, float], ...] = ()

    # -- names -----------------------------------------------------------------------------
    @property
    def channel_names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.channels)

    @property
    def units(self) -> dict[str, str]:
        return {c.name: c.unit for c in self.channels}

    @property
    def env_names(self) -> tuple[str, ...]:
        return tuple(v.name for v in self.env_vars)

    def not_a_variable(self, what: str) -> str:
        """The one line for `what` (an option, a request's field) naming no environment variable of this task."""
        return f"{what}: not an environment variable of task {self.name!r} (it has {', '.join(self.env_names)})"

    def channels_of(self, kind: str) -> tuple[Channel, ...]:
        return tuple(c for c in self.channels if c.kind == kind)

    def env_ranges(self, which: str = "sampled") -> dict[str, tuple[float, float]]:
        return {v.name: getattr(v, which) for v in self.env_vars}

    def env_defaults(self) -> dict[str, float]:
        """Each variable's value in a simulated world where a problem does not give it."""
        return {v.name: v.default for v in self.env_vars}

    # -- checks ----------------------------------------------------------------------------
    def check_env(self, env: Mapping[str, float]) -> dict[str, float]:
        """The environment as floats in the task's order; one clear error for a missing or
        out-of-range value."""
        missing = [n for n in self.env_names if n not in env]
        if missing:
            raise TaskError(f"task {self.name!r} needs environment values {', '.join(missing)} "
                            f"(it has {', '.join(self.env_names)}; got {', '.join(env) or 'none'})")
        out = {}
        for v in self.env_vars:
            x = float(env[v.name])
            lo, hi = v.physical
            if not (math.isfinite(x) and lo <= x <= hi):
                raise EnvironmentRangeError(f"{v.name} = {x!r} is outside the {self.name} scene's physical range "
                                            f"[{lo}, {hi}]")
            out[v.name] = x
        return out

    def perturbation(self, name: str) -> Perturbation:
        """The perturbation called `name`; a one-line error naming the known ones otherwise."""
        for p in self.perturbations:
            if p.name == name:
                return p
        known = ", ".join(p.name for p in self.perturbations) or "none"
        raise TaskError(f"{name!r} is not a perturbation of task {self.name!r} (known: {known})")

    def check_perturbation(self, values: Mapping[str, float]) -> dict[str, float]:
        """`values` (name -> value) as floats, every name known and every value in its physical range."""
        out = {}
        for name, value in values.items():
            p, x = self.perturbation(name), float(value)
            lo, hi = p.physical
            if not (math.isfinite(x) and lo <= x <= hi):
                raise TaskError(f"{p.label(x)} is outside what the {self.name} scene accepts for {name}: "
                                f"[{lo:g}, {hi:g}] ({p.unit or 'offset'}; nominal {p.nominal:g})")
            out[name] = x
        return out

    def true_env(self, env: Mapping[str, float], values: Mapping[str, float]) -> dict[str, float]:
        """The environment the world has when a plan was told `env`, under perturbations `values`:
        each misestimated variable's true value, clipped to the simulator's physical range."""
        out = {k: float(v) for k, v in env.items()}
        ranges = self.env_ranges("physical")
        for name, value in values.items():
            p = self.perturbation(name)
            if p.env:
                lo, hi = ranges[p.env]
                out[p.env] = min(max(p.apply(out[p.env], float(value)), lo), hi)
        return out

    def check_randomization(self, ranges: Mapping[str, tuple[float, float]], option: str = "--randomize"
                            ) -> dict[str, tuple[float, float]]:
        """Ranges to draw perturbations from per demonstration: each name known, LO < HI, both
        within the perturbation's physical range; a one-line error naming the value and the fix."""
        out = {}
        for name, (lo, hi) in ranges.items():
            p = self.perturbation(name)
            plo, phi = p.physical
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise TaskError(f"{option} {name}={lo:g},{hi:g}: give finite numbers LO,HI")
            if lo > hi:
                raise TaskError(f"{option} {name}={lo:g},{hi:g}: the range is reversed; write the lower bound first "
                                f"({name}={hi:g},{lo:g})")
            if lo == hi:
                elo, ehi = (min(p.values), max(p.values)) if len(set(p.values)) > 1 else (plo, phi)
                raise TaskError(f"{option} {name}={lo:g},{hi:g}: the range is empty; give LO < HI (e.g. "
                                f"{name}={elo:g},{ehi:g})")
            if lo < plo or hi > phi:
                raise TaskError(f"{option} {name}={lo:g},{hi:g}: outside the {self.name} scene's physical range "
                                f"[{plo:g}, {phi:g}] for {name}; give a range within it")
            out[name] = (float(lo), float(hi))
        return out

    def check_channels(self, names: tuple[str, ...] | list[str], what: str) -> None:
        if tuple(names) != self.channel_names:
            raise TaskError(f"{what} has channels {', '.join(names)}; task {self.name!r} has "
                            f"{', '.join(self.channel_names)}")

    # -- what a task must provide ------------------------------------------------------------
    def terminal(self, env: Mapping[str, float]) -> dict[str, float]:
        """Position channels whose end value the environment fixes (default: none)."""
        return {}

    def settings(self) -> Any:
        """The task's own settings (scene, controller, random commands): a frozen dataclass whose
        defaults are the shipped ones; recorded in every dataset the task's simulator makes."""
        return None

    @abstractmethod
    def random_command(self, rng: np.random.Generator, env: Mapping[str, float], settings: Any = None) -> np.ndarray:
        """A random demonstration command, (horizon + 1, channels); deterministic given `rng`."""

    @abstractmethod
    def simulator(self, settings: Any = None, render: bool = False) -> TaskSimulator:
        """A new simulator of the task's scene (default settings when None); `render`: one a
        camera can draw (`render`), which takes longer to build."""

    def robot_settings(self, robot: str, settings: Any = None) -> Any:
        """The task's settings (None: the shipped ones) with its arm `robot` (judgeopt.robots): the
        field `scene.robot` where the task's scene has one; a TaskError where it runs one arm only."""
        from judgeopt.robots import DEFAULT_ROBOT, get_robot

        settings = self.settings() if settings is None else settings
        if not hasattr(getattr(settings, "scene", None), "robot"):
            if robot == DEFAULT_ROBOT:
                return settings
            raise TaskError(f"task {self.name!r} runs on the {DEFAULT_ROBOT} only; leave --robot out")
        get_robot(robot)  # a one-line error for an unknown arm
        return with_setting(settings, "scene.robot", robot)

    def arm_model(self, problem: Any = None) -> ArmModel | None:
        """The arm that executes `problem`'s plans, for the direct solve's joint-limit constraints
        (judgeopt.planners.joint_limits); None (the default): the task has none to offer."""
        return None

    def explain(self, details: Mapping[str, Any]) -> str:
        """One line on a simulated outcome's details (what `solve` prints after a replay)."""
        return ", ".join(f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {v}" for k, v in details.items())

    def render(self, plan: Any, env: Mapping[str, float], out: Any, caption: str = "", simulator: Any = None) -> Any:
        """Replay `plan` and save it as a GIF at `out`; returns the rollout's result (tasks with
        a renderer override this; `simulator`: one to reuse)."""
        raise TaskError(f"task {self.name!r} has no renderer")

    def tables(self) -> dict[str, Any]:
        """The task's own evaluation tables (name -> judgeopt.evaluate.tables.Table), besides the
        `planners` table every task has."""
        return {}

    def demonstrated(self) -> dict[str, tuple[float, float]]:
        """Per channel, the range the task's random demonstrations command: what a judge trained
        on them has seen, so what limits may be relaxed to. Default: unbounded."""
        return {c.name: (-math.inf, math.inf) for c in self.channels}

    def demonstrated_bound(self, kind: str) -> tuple[float, float]:
        """The demonstrated range of the first channel of `kind` (position, velocity, force)."""
        return self.demonstrated()[self.channels_of(kind)[0].name]

    def plan(self, values: np.ndarray, dt: float | None = None) -> Plan:
        """A (horizon + 1, channels) array as this task's Plan (at the task's dt by default)."""
        return Plan(self.dt if dt is None else dt, values, self.channels)

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "description": self.description,
                "channels": [{"name": c.name, "unit": c.unit, "kind": c.kind, **({"of": c.of} if c.of else {})}
                             for c in self.channels],
                "env_names": list(self.env_names),
                "environment": [{"name": v.name, "unit": v.unit, "physical": list(v.physical),
                                 "sampled": list(v.sampled), "description": v.description} for v in self.env_vars],
                "perturbations": [{"name": p.name, "unit": p.unit, "nominal": p.nominal, "physical": list(p.physical),
                                   "values": list(p.values), "env": p.env or None, "description": p.description}
                                  for p in self.perturbations],
                "horizon": self.horizon, "dt": self.dt}
