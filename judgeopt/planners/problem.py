"""A planning problem: start state, limits, terminal state, horizon, environment, loss weights.

Problems live in TOML files in their task's folder (`judgeopt/tasks/<task>/problems/`; a shipped
file is found as `problems/<name>.toml` from anywhere, judgeopt.files.resolve). A file may name
`base = "other.toml"` and change only some values: `paper_sim_slow.toml` is `paper_sim.toml`
with q̇_max = 0.4. `base` is looked up next to the file, then as the CLI finds a name (a shipped
`problems/NAME.toml`, with or without `problems/`), so a copied file keeps its base. Every field
can also be overridden by name (`with_overrides`, and the CLI's `--qdot-max 0.4`, and one option
per environment variable, `--NAME 0.2`).

Environment values are a number (fixed) or a [lo, hi] range. Training the generator and
evaluation sample ranges; a single solve uses a fixed value, else the range's midpoint.
[environment] holds what the planners and the judge read; [world] the task's other variables,
which only the simulated world has (a judge may read fewer variables than the simulator
needs: paper_real.toml's); a variable in neither has the task's nominal value (`world_env`).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import tomllib
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from judgeopt.errors import BadInput, Infeasible, UsageError
from judgeopt.files import PACKAGE, resolve
from judgeopt.planners.constraints import ConstraintError, Constraints, describe
from judgeopt.planners.constraints import validate as validate_constraints
from judgeopt.formats.frame import FrameError, TaskFrame, task_frame
from judgeopt.robots import DEFAULT_ROBOT, get_robot
from judgeopt.robots.spec import RobotError
from judgeopt.tasks import DEFAULT_TASK, TaskError, get_task
from judgeopt.trajectory import DEFAULT_DT, DEFAULT_HORIZON

#: a terminal position left to the planner
FREE = "free"
#: the direct solve's objectives (Problem.objective); min_time: the earliest rest at the terminal
#: state with the judge at p_target (planners/min_time.py)
OBJECTIVES = ("target", "log_p", "min_time")
#: fields holding one value per position axis (or one for all), and one per force channel
AXIS_FIELDS = ("q0", "qdot0", "q_min", "q_max", "qdot_min", "qdot_max", "q_end", "qdot_end", "end_margin")
FORCE_FIELDS = ("f_min", "f_max")


class ProblemError(UsageError, ValueError):
    """A problem file or override that is malformed or inconsistent."""


class ProblemFileError(BadInput, ProblemError):
    """A problem file that cannot be read, or holds values that are wrong (the message names the file)."""


class InfeasibleProblemError(Infeasible, ProblemError):
    """Constraints that no trajectory can satisfy; `conflict` names them."""

    def __init__(self, message: str, conflict: list[str]):
        super().__init__(message)
        self.conflict = conflict


EnvValue = float | tuple[float, float]

# TOML section -> fields it holds (each field has one name, so overrides name it without its section)
SECTIONS: dict[str, tuple[str, ...]] = {
    "horizon": ("steps", "dt"),
    "start": ("q0", "qdot0"),
    "limits": ("q_min", "q_max", "qdot_min", "qdot_max", "f_min", "f_max"),
    "terminal": ("q_end", "qdot_end", "end_margin"),
    "cost": ("acc_weight", "force_rate_weight"),
    "solver": ("objective", "p_target", "p_min", "max_iter", "tol", "pessimism", "trust_region", "replan_period",
               "replan_trigger"),
    "generator": ("P", "Q", "R"),
    "models": ("judge", "generator_model", "ensemble", "trust_model", "calibration"),
    "constraints": ("a_max", "jerk_max", "fdot_max", "bounds", "joint_limit_scale"),
}
#: how a model named without its suffix may lie on disk (a judge's .pt and .json, a folder, a file)
MODEL_SUFFIXES = ("", ".json", ".pt")
#: field -> its section
SECTION_OF: dict[str, str] = {k: section for section, names in SECTIONS.items() for k in names}
#: sections read in their old place, with a note: old section -> the fields it held
OLD_SECTIONS: dict[str, tuple[str, ...]] = {"weights": ("P", "Q", "R", "acc_weight", "force_rate_weight")}


class ProblemDeprecation(FutureWarning):
    """A problem file that still works but holds a field in its old place (shown once per file and field)."""


class ProblemUnits(UserWarning):
    """A limit beyond any plausible motion in the task's units (`--qdot-max 400`: mm/s for m/s?): planned
    as given, never changed silently, but said once, with the value it likely meant."""


#: limits checked against the plausible magnitudes of their channel's kind (judgeopt.data.recording.LIMITS)
UNIT_CHECKED = {"q_min": "position", "q_max": "position", "qdot_min": "velocity", "qdot_max": "velocity",
                "f_min": "force", "f_max": "force"}
#: a unit mistaken for the task's SI one, by the SI unit: (its name, its size in the SI unit)
SMALLER_UNIT = {"m": ("mm", 1e-3), "m/s": ("mm/s", 1e-3), "N": ("mN", 1e-3)}
#: the position, velocity and force limits (bounds a planner can change without being rebuilt)
LIMIT_NAMES = SECTIONS["limits"]
#: what each field means, with its unit (the command line's help; position fields per axis of the task)
FIELD_HELP: dict[str, str] = {
    "steps": "planning steps N",
    "dt": "sample period in s",
    "q0": "start position in m",
    "qdot0": "start velocity in m/s",
    "q_min": "lowest position in m",
    "q_max": "highest position in m",
    "qdot_min": "lowest velocity in m/s",
    "qdot_max": "highest velocity in m/s",
    "f_min": "lowest commanded force in N",
    "f_max": "highest commanded force in N",
    "q_end": "end position in m, the name of the environment variable whose value it is, or free",
    "qdot_end": "end velocity in m/s",
    "end_margin": "end this far (m) past the environment variable q_end names, within q_max: margin for what the "
                  "judge cannot see (a stiffer mat, an object further than told); 0: at it",
    "P": "weight of the judge's log-probability (eq. 3)",
    "Q": "generator: weight of limit violations (eq. 4)",
    "R": "generator: weight of the terminal error (eq. 4)",
    "acc_weight": "direct solve: weight of squared acceleration, per (m/s^2)^2 s",
    "force_rate_weight": "direct solve: weight of squared force rate, per (N/s)^2 s",
    "objective": "direct solve: target (least effort and change to the warm start, p >= p_target), log_p (eq. 3) "
                 "or min_time (the earliest rest at the terminal state with p >= p_target)",
    "p_target": "direct solve, objective target: the judge's probability the plan must reach",
    "p_min": "direct solve: hard lower bound on the judge's probability",
    "max_iter": "direct solve: Ipopt iterations",
    "tol": "direct solve: Ipopt tolerance",
    "pessimism": "direct solve: k in mean - k std of the ensemble's logits",
    "trust_region": "direct solve: largest distance to the demonstrations (Mahalanobis)",
    "replan_period": "receding planner: seconds between re-plans during execution (a multiple of dt)",
    "replan_trigger": "receding planner: judge (re-solve only when the judge, reading what was measured and the "
                      "plan's rest, falls below p_target) or always (re-solve every period)",
    "judge": "judge model (path stem or models/NAME)",
    "generator_model": "the generator that goes with the judge (path stem or models/NAME), used where it fits the "
                       "limits and the judge; otherwise (or left empty) one is found by its metadata",
    "ensemble": "ensemble folder for pessimistic planning",
    "trust_model": "trust-region model (path stem)",
    "calibration": "calibration file (JSON) for the predicted success",
    "a_max": "direct solve: largest |acceleration| in m/s^2 (per axis, or one for all)",
    "jerk_max": "direct solve: largest |jerk| in m/s^3, the change of acceleration between steps",
    "fdot_max": "direct solve: largest |force rate| in N/s",
    "bounds": "direct solve: a channel's bounds over a window, NAME:LO:HI@T0:T1 (e.g. f:0:12@0:0.4)",
    "joint_limit_scale": "direct solve: hold the arm's joint velocity and torque limits times this (1: the URDF's)",
}


@dataclass(frozen=True)
class Motion:
    """What is planned (the model, constraints and cost): the task, horizon, start, limits,
    terminal state, the smoothing cost both planners minimise, and the environment. Units: m,
    m/s, N, s; defaults are the paper's Table 3 (simulation).

    Position, velocity and terminal fields hold one value per position axis of the task, or one
    value for every axis; f_min and f_max one per force channel, or one for all. q_end is a
    number, the name of an environment variable or "free"; by default the default task's
    (`Task.default_q_end`)."""

    task: str = DEFAULT_TASK
    # the arm that runs the plan (judgeopt.robots): its simulation, and its joint limits held (joint_limit_scale 1
    # unless set) for any arm but the default, whose shipped plans were made without them
    robot: str = DEFAULT_ROBOT
    steps: int = DEFAULT_HORIZON
    dt: float = DEFAULT_DT
    q0: float | list[float] = -0.03
    qdot0: float | list[float] = 0.0
    q_min: float | list[float] = -0.2
    q_max: float | list[float] = 0.4
    qdot_min: float | list[float] = -0.05
    qdot_max: float | list[float] = 1.0
    f_min: float | list[float] = 7.5
    f_max: float | list[float] = 22.5
    q_end: float | str | list[float | str] = field(default_factory=lambda: get_task(DEFAULT_TASK).default_q_end)
    qdot_end: float | list[float] = 0.0
    # the plan ends this far past the position an environment variable gives (a q_end naming one), capped at q_max:
    # an open-loop scoop on a stiffer mat or at an object further than told still ends under it (docs/constraints.md)
    end_margin: float | list[float] = 0.0
    # smoothing (acceleration in (m/s^2)^2 s, force rate in (N/s)^2 s): keeps both planners away from
    # bang-bang plans the controller cannot follow
    acc_weight: float = 1e-3
    force_rate_weight: float = 1e-6
    environment: dict[str, EnvValue] = field(default_factory=lambda: get_task(DEFAULT_TASK).env_ranges())
    # the task's variables the planners do not read, as the simulated world has them ([world])
    world: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class SolverOptions:
    """How the direct solve and the receding planner run (judgeopt's solver options; the direct solve is Ipopt through CasADi)."""

    # "target" reaches p >= p_target with the least effort and the least change to its warm start (a
    # well-posed optimum, a few iterations; docs/planners.md); "log_p" maximises the judge, eq. (3): -P log y_judge
    objective: str = "target"
    p_target: float = 0.98
    p_min: float | None = None  # optional hard constraint y_judge >= p_min
    max_iter: int = 300
    tol: float = 1e-6
    # remedies against exploiting the judge (off unless set): maximise mean - pessimism * std of an ensemble's
    # logits; keep the plan within `trust_region` (Mahalanobis distance) of the demonstrations
    pessimism: float = 1.0
    trust_region: float | None = None
    replan_period: float = 0.1  # the receding planner's: the direct solve re-run every this many seconds
    # ... when the judge asks for it ("judge"), or every time ("always": measured worse when the world differs from
    # what was said, benchmarks/bench_receding.py; docs/planners.md)
    replan_trigger: str = "judge"


@dataclass(frozen=True)
class GeneratorWeights:
    """The amortised generator's training loss, eq. (4): P on -log y_judge (eq. 3), Q on squared
    limit violations, R on squared terminal errors (hard in the direct solve)."""

    P: float = 1.0
    Q: float = 1000.0
    R: float = 1000.0


@dataclass(frozen=True)
class ModelRefs:
    """Which trained files the planners load (names as `judgeopt.files.resolve` finds them)."""

    judge: str = ""  # empty: the task's default judge
    ensemble: str | None = None  # ensemble folder for pessimistic planning
    trust_model: str = "models/trust_region_default"
    # predicted success recalibrated on the planners' replayed outcomes (judgeopt calibrate); used where
    # the file has the planner's setting, ignored where it is missing
    calibration: str | None = "models/calibration_default.json"
    # the generator trained for this problem against its judge (judgeopt.planners.store.find_generator checks it
    # fits); empty: one is found by its metadata (`judgeopt models` lists which)
    generator_model: str = ""


#: the problem's parts (attribute -> class); every field of a part is also read from the problem by name
PARTS: dict[str, type] = {"motion": Motion, "solver": SolverOptions, "generator": GeneratorWeights, "models": ModelRefs,
                          "constraints": Constraints}
#: field name -> the part holding it
PART_OF: dict[str, str] = {f.name: part for part, cls in PARTS.items() for f in dataclasses.fields(cls)}
#: every field by name, in the order of the flat records (Problem.to_dict) written before the split
FIELDS: tuple[str, ...] = ("name", "description", "task", "robot", "steps", "dt", "q0", "qdot0", "q_min", "q_max", "qdot_min",
                           "qdot_max", "f_min", "f_max", "q_end", "qdot_end", "end_margin", "environment", "world", "P", "Q", "R",
                           "acc_weight", "force_rate_weight", "objective", "p_target", "p_min", "max_iter", "tol",
                           "replan_period", "replan_trigger", "judge", "ensemble", "pessimism", "trust_region",
                           "trust_model", "calibration", "generator_model", "a_max", "jerk_max", "fdot_max", "bounds",
                           "joint_limit_scale", "frame", "source")
#: each field's type, for parsing overrides from text
FIELD_TYPES: dict[str, Any] = {f.name: f.type for cls in PARTS.values() for f in dataclasses.fields(cls)}


@dataclass(frozen=True, init=False)
class Problem:
    """A planning problem in parts, the way acados groups its problem object: `motion` (what is
    planned), `solver` (options of the direct solve and the receding planner), `generator` (the
    generator's training weights), `models` (the files the planners load) and `frame` (where the
    plan's axes lie for a robot: [frame], judgeopt.formats.frame; not part of what is planned).

    Every field of a part is also read, overridden (`with_overrides`) and given to the
    constructor by name: `Problem(qdot_max=0.4).qdot_max == Problem().motion.qdot_max`."""

    name: str
    description: str
    motion: Motion
    solver: SolverOptions
    generator: GeneratorWeights
    models: ModelRefs
    constraints: Constraints
    frame: dict[str, Any] | None
    source: str  # the file it came from (for messages and provenance)

    def __init__(self, name: str = "unnamed", description: str = "", motion: Motion | None = None,
                 solver: SolverOptions | None = None, generator: GeneratorWeights | None = None,
                 models: ModelRefs | None = None, constraints: Constraints | None = None,
                 frame: dict[str, Any] | None = None, source: str = "", **fields: Any) -> None:
        given = {"motion": motion, "solver": solver, "generator": generator, "models": models,
                 "constraints": constraints}
        unknown = [k for k in fields if k not in PART_OF]
        if unknown:
            raise TypeError(f"unknown problem field(s) {unknown}")
        for part, cls in PARTS.items():
            mine = {k: v for k, v in fields.items() if PART_OF[k] == part}
            value = given[part] or cls()
            object.__setattr__(self, part, dataclasses.replace(value, **mine) if mine else value)
        for k, v in (("name", name), ("description", description), ("frame", frame), ("source", source)):
            object.__setattr__(self, k, v)
        self.__post_init__()

    def __post_init__(self) -> None:
        if self.objective == "min-time":  # as the command line spells it
            object.__setattr__(self, "solver", dataclasses.replace(self.solver, objective="min_time"))
        self.validate()
        if self.robot != DEFAULT_ROBOT and self.joint_limit_scale is None:  # planned for that arm: its limits held
            object.__setattr__(self, "constraints", dataclasses.replace(self.constraints, joint_limit_scale=1.0))
        if not self.judge:
            object.__setattr__(self, "models", dataclasses.replace(self.models, judge=get_task(self.task).default_judge))

    # -- validation -----------------------------------------------------------------
    def validate(self) -> None:
        where = f" in {self.source}" if self.source else ""
        try:
            task = get_task(self.task)
        except TaskError as exc:
            raise ProblemError(f"{exc}{where}") from None
        try:
            get_robot(self.robot)
        except RobotError as exc:
            raise ProblemError(f"{exc}{where}") from None
        for name in ("dt", "P", "Q", "R", "acc_weight", "force_rate_weight", "tol"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ProblemError(f"{name} = {v!r}{where} must be a finite number")
        n_axes, n_forces = len(task.channels_of("position")), len(task.channels_of("force"))
        for name in AXIS_FIELDS + FORCE_FIELDS:
            v = getattr(self, name)
            count = n_forces if name in FORCE_FIELDS else n_axes
            values = v if isinstance(v, (list, tuple)) else [v]
            if isinstance(v, (list, tuple)) and len(v) != count:
                raise ProblemError(f"{name} = {list(v)}{where} has {len(v)} values; task {task.name!r} has {count} "
                                   f"{'force channels' if name in FORCE_FIELDS else 'position axes'} (or give one value)")
            for x in values:
                if name == "q_end" and isinstance(x, str):
                    if x != FREE and x not in self.environment:
                        raise ProblemError(f"q_end = {x!r}{where} must be a number, \"{FREE}\" or an environment "
                                           f"variable ({', '.join(self.environment)})")
                elif isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                    raise ProblemError(f"{name} = {v!r}{where} must be a finite number (or a list of them)")
        if not isinstance(self.steps, int) or isinstance(self.steps, bool) or self.steps < 1:
            raise ProblemError(f"steps = {self.steps!r}{where} must be a positive whole number (the horizon N)")
        if self.dt <= 0:
            raise ProblemError(f"dt = {self.dt}{where} must be positive (seconds per step)")
        for lo, hi in (("q_min", "q_max"), ("qdot_min", "qdot_max"), ("f_min", "f_max")):
            if not np.all(self._vec(lo, task) < self._vec(hi, task)):
                raise ProblemError(f"{lo} = {getattr(self, lo)} must be below {hi} = {getattr(self, hi)}{where}")
        if np.any(self._vec("f_min", task) < 0):
            raise ProblemError(f"f_min = {self.f_min}{where} must not be negative: a contact force presses, it "
                               "cannot pull (0 lets the tool lift off)")
        for name in ("P", "Q", "R", "acc_weight", "force_rate_weight", "tol"):
            if getattr(self, name) < 0:
                raise ProblemError(f"weight {name} = {getattr(self, name)}{where} must not be negative")
        if not np.all((self._vec("q_min", task) <= self._vec("q0", task)) & (self._vec("q0", task) <= self._vec("q_max", task))):
            raise ProblemError(f"start position q0 = {self.q0} is outside [q_min, q_max] = "
                               f"[{self.q_min}, {self.q_max}]{where}")
        if not np.all((self._vec("qdot_min", task) <= self._vec("qdot0", task))
                      & (self._vec("qdot0", task) <= self._vec("qdot_max", task))):
            raise ProblemError(f"start velocity qdot0 = {self.qdot0} is outside [qdot_min, qdot_max] = "
                               f"[{self.qdot_min}, {self.qdot_max}]{where}")
        if self.objective not in OBJECTIVES:
            raise ProblemError(f"objective = {self.objective!r}{where}: choose one of {', '.join(OBJECTIVES)}")
        if not (isinstance(self.p_target, (int, float)) and 0.0 < self.p_target < 1.0):
            raise ProblemError(f"p_target = {self.p_target!r}{where} must lie strictly between 0 and 1")
        if self.p_min is not None and not (0.0 < self.p_min < 1.0):
            raise ProblemError(f"p_min = {self.p_min}{where} must lie strictly between 0 and 1 (or be left out)")
        if not (isinstance(self.pessimism, (int, float)) and self.pessimism >= 0):
            raise ProblemError(f"pessimism = {self.pessimism!r}{where} must be >= 0 (std of the ensemble's logits "
                               "subtracted; inf: the minimum)")
        if self.trust_region is not None and not self.trust_region > 0:
            raise ProblemError(f"trust_region = {self.trust_region}{where} must be a positive distance (or left out)")
        if not isinstance(self.max_iter, int) or self.max_iter < 1:
            raise ProblemError(f"max_iter = {self.max_iter!r}{where} must be a positive whole number")
        if not isinstance(self.generator_model, str):
            raise ProblemError(f"generator_model = {self.generator_model!r}{where} must be a model path such as "
                               "\"models/generator_paper_sim\" (or \"\" to let its metadata find one)")
        margin = self._vec("end_margin", task)
        if np.any(margin < 0):
            raise ProblemError(f"end_margin = {self.end_margin}{where} must be >= 0 (m past the object)")
        ends = self.q_end if isinstance(self.q_end, (list, tuple)) else [self.q_end] * n_axes
        if any(m and not (isinstance(e, str) and e != FREE) for m, e in zip(margin, ends)):
            raise ProblemError(f"end_margin = {self.end_margin}{where} applies to an end an environment variable gives "
                               f"(q_end = {self.q_end!r}); move a numeric q_end itself, or set end_margin = 0")
        if self.objective == "min_time" and np.any(np.isnan(self.terminal_positions(
                {k: 0.0 for k in self.environment}))):
            raise ProblemError(f"objective = min_time{where} needs a terminal position on every axis (q_end is "
                               f"{self.q_end!r}): the time is when the motion rests there; set q_end")
        try:
            validate_constraints(self.constraints, task.channels, self.steps, self.dt)
        except ConstraintError as exc:
            raise ProblemError(f"{exc}{where}") from None
        if not self.environment:
            raise ProblemError(f"the environment{where} names no variables")
        unknown = [k for k in self.environment if k not in task.env_names]
        if unknown:  # a subset is allowed: a real setup may not know every variable (paper_real.toml)
            raise ProblemError(task.not_a_variable(f"environment {', '.join(unknown)}{where}"))
        for k, v in self.environment.items():
            if isinstance(v, tuple):
                if not (len(v) == 2 and all(math.isfinite(x) for x in v) and v[0] <= v[1]):
                    raise ProblemError(f"environment {k} = {list(v)}{where} must be [lo, hi] with lo <= hi")
            elif not math.isfinite(v):
                raise ProblemError(f"environment {k} = {v!r}{where} must be a finite number")
        for k, v in self.world.items():
            if k not in task.env_names:
                raise ProblemError(task.not_a_variable(f"world {k}{where}"))
            if k in self.environment:
                raise ProblemError(f"{k}{where} is in both [environment] (what the planners read) and [world] "
                                   "(what only the simulated world has): keep one")
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ProblemError(f"world {k} = {v!r}{where} must be a finite number (the simulated world has one value)")
        self.task_frame()
        for hint in self.unit_hints():
            warnings.warn(hint, ProblemUnits, stacklevel=2)

    def unit_hints(self) -> list[str]:
        """A line per limit beyond any plausible motion of its kind (10 m/s, 1000 N, 5 m; the
        importer's LIMITS): most likely a value in mm/s, mm or another unit than the task's."""
        from judgeopt.data.recording import LIMITS

        task = get_task(self.task)
        hints = []
        for name, kind in UNIT_CHECKED.items():  # not "in FILE": the value may be an override of the file's
            channels = task.channels_of(kind)
            unit = channels[0].unit if channels else ""
            values = [float(x) for x in np.atleast_1d(np.asarray(getattr(self, name), dtype=float))]
            worst = max(values, key=abs)
            if abs(worst) <= LIMITS[kind]:
                continue
            small = SMALLER_UNIT.get(unit)
            meant = (f"; if {worst:g} was in {small[0]}, give {worst * small[1]:g}" if small else "")
            shown = f"{values[0]:g}" if len(values) == 1 else "[" + ", ".join(f"{x:g}" for x in values) + "]"
            hints.append(f"{name} = {shown} {unit} is beyond any plausible {kind} ({LIMITS[kind]:g} {unit}): the "
                         f"limits are in the task's units ({unit}){meant}")
        return hints

    def task_frame(self) -> TaskFrame:
        """The checked task frame, defaults filled in (a bad one names the file and the field)."""
        try:
            return task_frame(self.frame, get_task(self.task))
        except FrameError as exc:
            raise ProblemError(f"{self.source or 'problem'}: {exc}") from None

    # -- per axis ---------------------------------------------------------------------
    def _vec(self, name: str, task=None) -> np.ndarray:
        task = task or get_task(self.task)
        count = len(task.channels_of("force" if name in FORCE_FIELDS else "position"))
        v = getattr(self, name)
        return np.array(v if isinstance(v, (list, tuple)) else [v] * count, dtype=float)

    def vec(self, name: str) -> np.ndarray:
        """A position, velocity or force field as one value per axis (or force channel)."""
        return self._vec(name)

    @property
    def n_axes(self) -> int:
        return len(get_task(self.task).channels_of("position"))

    @property
    def n_forces(self) -> int:
        return len(get_task(self.task).channels_of("force"))

    def terminal_positions(self, env: dict[str, float]) -> np.ndarray:
        """Per axis: the end position the plan must reach (nan: free)."""
        ends = self.q_end if isinstance(self.q_end, (list, tuple)) else [self.q_end] * self.n_axes
        margin, q_max = self.vec("end_margin"), self.vec("q_max")
        # the margin goes no further than q_max (an end already beyond it stays, to be reported)
        return np.array([np.nan if e == FREE else float(env[e]) + min(margin[i], max(0.0, q_max[i] - float(env[e])))
                         if isinstance(e, str) else float(e) for i, e in enumerate(ends)])

    # -- the environment --------------------------------------------------------------
    @property
    def env_names(self) -> tuple[str, ...]:
        return tuple(self.environment)

    @property
    def channels(self) -> tuple[str, ...]:
        """The task's channel names, the plan's columns."""
        return get_task(self.task).channel_names

    @property
    def channel_spec(self) -> tuple:
        """The task's channels (trajectory.Channel), for building plans."""
        return get_task(self.task).channels

    def world_env(self, env: dict[str, float]) -> dict[str, float]:
        """The simulated world's full environment for a planned `env`: the task's variables the
        problem does not plan for from [world], else the task's nominal values."""
        task = get_task(self.task)
        full = {**task.env_defaults(), **self.world, **env}
        return {k: float(full[k]) for k in task.env_names}

    def nominal_env(self) -> dict[str, float]:
        """Fixed values as given, ranges at their midpoint (what a single solve uses by default)."""
        return {k: (0.5 * (v[0] + v[1]) if isinstance(v, tuple) else float(v)) for k, v in self.environment.items()}

    def sample_env(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """(n, E) environments: ranges sampled uniformly, fixed values repeated."""
        cols = [rng.uniform(v[0], v[1], n) if isinstance(v, tuple) else np.full(n, float(v))
                for v in self.environment.values()]
        return np.stack(cols, axis=1)

    def env_range(self, name: str) -> tuple[float, float]:
        """The range an environment variable is drawn from (a fixed value: that value twice)."""
        v = self.environment[name]
        return (float(v[0]), float(v[1])) if isinstance(v, tuple) else (float(v), float(v))

    def env_dict(self, env: Any) -> dict[str, float]:
        """A full environment from a mapping or a vector in `env_names` order, checked."""
        if isinstance(env, dict):
            missing = [k for k in self.env_names if k not in env]
            if missing:
                raise ProblemError(f"environment is missing {missing} (the problem needs {list(self.env_names)})")
            out = {k: float(env[k]) for k in self.env_names}
        else:
            v = np.asarray(env, dtype=float).ravel()
            if v.size != len(self.env_names):
                raise ProblemError(f"environment has {v.size} values, the problem needs {list(self.env_names)}")
            out = dict(zip(self.env_names, map(float, v)))
        bad = [k for k, v in out.items() if not math.isfinite(v)]
        if bad:
            raise ProblemError(f"environment values {bad} are not finite")
        return out

    def terminal_position(self, env: dict[str, float]) -> float:
        """The end position of a one-axis task (nan: free)."""
        return float(self.terminal_positions(env)[0])

    @property
    def horizon_time(self) -> float:
        return self.steps * self.dt

    # -- feasibility ------------------------------------------------------------------
    def reachable_range(self, axis: int = 0) -> tuple[float, float]:
        """Positions of `axis` reachable at the horizon with the terminal velocity, under the
        velocity limits. The plan integrates q with the trapezoid rule (dynamics.py), so
        q_N - q_0 = dt (q̇_0/2 + sum_{k=1}^{N-1} q̇_k + q̇_N/2): extremes with every inner q̇_k at a limit."""
        q0, qd0, qd_end, qd_min, qd_max, q_min, q_max = (float(self.vec(k)[axis]) for k in (
            "q0", "qdot0", "qdot_end", "qdot_min", "qdot_max", "q_min", "q_max"))
        ends = self.dt * (0.5 * qd0 + 0.5 * qd_end)
        inner = self.dt * (self.steps - 1)
        lo, hi = q0 + ends + inner * qd_min, q0 + ends + inner * qd_max
        return max(lo, q_min), min(hi, q_max)

    def check_feasible(self, env: dict[str, float]) -> None:
        """Raise InfeasibleProblemError naming the limits in conflict (no solver needed): the boxes
        and the terminal state; judgeopt.planners.feasible.check adds [constraints]."""
        names = [c.name for c in get_task(self.task).channels_of("position")]
        ends = self.terminal_positions(env)
        for i, q_end in enumerate(ends):
            axis = f" ({names[i]})" if len(names) > 1 else ""
            q0, q_min, q_max, qd_end, qd_min, qd_max = (float(self.vec(k)[i]) for k in (
                "q0", "q_min", "q_max", "qdot_end", "qdot_min", "qdot_max"))
            if not np.isnan(q_end) and not (q_min <= q_end <= q_max):
                raise InfeasibleProblemError(
                    f"terminal position q_end{axis} = {q_end:.4g} m lies outside the position limits "
                    f"[q_min, q_max] = [{q_min}, {q_max}] m", ["terminal.q_end", "limits.q_min/q_max"])
            if not (qd_min <= qd_end <= qd_max):
                raise InfeasibleProblemError(
                    f"terminal velocity qdot_end{axis} = {qd_end} m/s lies outside the velocity limits "
                    f"[qdot_min, qdot_max] = [{qd_min}, {qd_max}] m/s", ["terminal.qdot_end", "limits.qdot_min/qdot_max"])
            if np.isnan(q_end):
                continue
            lo, hi = self.reachable_range(i)
            if not (lo - 1e-12 <= q_end <= hi + 1e-12):
                side = "qdot_max" if q_end > hi else "qdot_min"
                raise InfeasibleProblemError(
                    f"terminal position q_end{axis} = {q_end:.4g} m is out of reach: starting at q0 = {q0} m "
                    f"with velocity limits [{qd_min}, {qd_max}] m/s, {self.steps} steps of "
                    f"{self.dt} s reach only [{lo:.4g}, {hi:.4g}] m; raise {side}, lengthen the horizon, "
                    f"or move q_end", ["terminal.q_end", f"limits.{side}", "horizon.steps"])

    # -- variants ----------------------------------------------------------------------
    def with_overrides(self, **values: Any) -> "Problem":
        """A copy with fields replaced (None values ignored); environment variables by name: one the
        problem plans for changes [environment], any other of the task's sets the simulated world's
        value ([world])."""
        values = {k: v for k, v in values.items() if v is not None}
        env, world = dict(self.environment), dict(self.world)
        fields = set(FIELDS)
        task_vars = get_task(self.task).env_names
        changes: dict[str, Any] = {}
        for k, v in values.items():
            if k in fields and k not in ("environment", "world"):
                changes[k] = v
            elif k in env:
                env[k] = _env_value(k, v, self.source)
            elif k in task_vars:
                x = _env_value(k, v, self.source)
                if isinstance(x, tuple):
                    raise ProblemError(f"{k} = {v!r}: the planners of {self.source or self.name} do not read {k}, "
                                       f"so it is the simulated world's one value; give a number (or add {k} to "
                                       "[environment] to plan for a range)")
                world[k] = x
            else:
                raise ProblemError(f"unknown problem field {k!r}; fields: "
                                   f"{sorted(fields - {'environment', 'world', 'source'})}, environment: {sorted(env)}"
                                   f"{f', world: {sorted(set(task_vars) - set(env))}' if set(task_vars) - set(env) else ''}")
        try:
            return dataclasses.replace(self, environment=env, world=world, **changes)
        except ProblemError as exc:  # the file was valid: the change is what is wrong, not the file
            if not self.source:
                raise
            raise ProblemError(str(exc).replace(f" in {self.source}", f" (changed from {self.source})")) from None

    def limits_key(self) -> dict[str, Any]:
        """Everything a trained generator depends on except the environment values."""
        key = {k: getattr(self, k) for k in ("steps", "dt", "q0", "qdot0", "q_min", "q_max", "qdot_min", "qdot_max",
                                              "f_min", "f_max", "q_end", "qdot_end")}
        if np.any(self.vec("end_margin")):  # a generator trained without the margin does not plan with it
            key["end_margin"] = self.end_margin
        return key

    def without_environment(self) -> dict[str, Any]:
        """to_dict but for the environment: what planners are built for (each plans for whatever
        environment it is given), so problems equal here are served by the same planners
        (Planners.in_environment; the service's Prepared.planners_key)."""
        return {k: v for k, v in self.to_dict().items() if k != "environment"}

    def to_dict(self) -> dict[str, Any]:
        """Every field by name, as records and setting ids have held it since before the split
        (the frame left out: where a plan goes, not what is planned; plan JSON records it)."""
        d = {k: copy.deepcopy(getattr(self, k)) for k in FIELDS if k != "frame"}
        if not self.generator_model:  # records of problems without one read as before
            del d["generator_model"]
        if not self.world:  # records of problems without one read as before
            del d["world"]
        if self.robot == DEFAULT_ROBOT:  # records of problems made before arms were chosen read as before
            del d["robot"]
        if not np.any(self.vec("end_margin")):  # records of problems without one read as before
            del d["end_margin"]
        kept = describe(self.constraints)
        for k in SECTIONS["constraints"]:  # records of problems without constraints read as before
            if k not in kept:
                del d[k]
        d["environment"] = {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.environment.items()}
        return d

    def parts(self) -> dict[str, dict[str, Any]]:
        """The problem part by part (motion, solver, generator, models, frame)."""
        return {**{part: dataclasses.asdict(getattr(self, part)) for part in PARTS}, "frame": self.frame}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "Problem":
        """From `to_dict`'s flat form (or a problem file read flat)."""
        d = dict(d)
        d["environment"] = {k: _env_value(k, v, d.get("source", "")) for k, v in d.get("environment", {}).items()}
        d["world"] = {k: float(v) if isinstance(v, int) and not isinstance(v, bool) else v
                      for k, v in d.get("world", {}).items()}
        return cls(**d)


def _read_by_name(part: str, name: str) -> property:
    return property(lambda self: getattr(getattr(self, part), name), doc=f"{part}.{name}")


for _name, _part in PART_OF.items():
    setattr(Problem, _name, _read_by_name(_part, _name))


def _env_value(name: str, v: Any, source: str) -> EnvValue:
    if isinstance(v, (list, tuple)):
        if len(v) != 2:
            raise ProblemError(f"environment {name} = {v!r}{' in ' + source if source else ''} must be a number or [lo, hi]")
        return (float(v[0]), float(v[1]))
    if isinstance(v, str):
        parts = v.split(",")
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            raise ProblemError(f"environment {name} = {v!r} must be a number or lo,hi") from None
        return _env_value(name, vals[0] if len(vals) == 1 else vals, source)
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ProblemError(f"environment {name} = {v!r}{' in ' + source if source else ''} must be a number or [lo, hi]")
    return float(v)


def _read_toml(path: Path, seen: tuple[Path, ...] = ()) -> dict[str, Any]:
    if path in seen:
        raise ProblemError(f"{path}: `base` files form a cycle ({' -> '.join(map(str, seen + (path,)))})")
    if path.is_dir():
        raise ProblemError(f"{path} is a folder; give a problem file (.toml), e.g. problems/paper_sim.toml")
    if not path.exists():
        raise ProblemError(f"{path}: no such problem file (shipped ones: problems/paper_sim.toml, problems/scrape.toml, "
                           "... in judgeopt/tasks/*/problems/)")
    try:
        raw = tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ProblemError(f"{path}: not a problem file, not valid TOML ({exc}); give one like "
                           "problems/paper_sim.toml") from None
    if not raw:
        raise ProblemError(f"{path}: an empty problem file; start it with base = \"problems/paper_sim.toml\" "
                           "and give what differs")
    flat: dict[str, Any] = {}
    if "base" in raw:
        flat = _read_toml(_base_path(path, raw.pop("base")), seen + (path,))
    for key, value in raw.items():
        if key in SECTIONS or key in OLD_SECTIONS:
            if not isinstance(value, dict):
                raise ProblemError(f"{path}: [{key}] must be a table")
            for k, v in value.items():
                if k in OLD_SECTIONS.get(key, ()):
                    warnings.warn(f"{path}: [{key}] {k} is read from its old place; move it to [{SECTION_OF[k]}]",
                                  ProblemDeprecation, stacklevel=2)
                elif k in SECTION_OF and k not in SECTIONS.get(key, ()):
                    raise ProblemError(f"{path}: {k} belongs in [{SECTION_OF[k]}], not [{key}]: move it there")
                elif k not in SECTIONS.get(key, ()):
                    raise ProblemError(f"{path}: unknown key {k!r} in [{key}]; allowed: {list(SECTIONS[key])}")
                flat[k] = _model_path(path, v) if key == "models" else v
        elif key == "environment":
            if not isinstance(value, dict):
                raise ProblemError(f"{path}: [environment] must be a table")
            flat["environment"] = dict(value)  # a derived file replaces the whole environment
        elif key == "world":
            if not isinstance(value, dict):
                raise ProblemError(f"{path}: [world] must be a table")
            flat["world"] = {**flat.get("world", {}), **value}  # a derived file changes only the keys it gives
        elif key == "frame":
            if not isinstance(value, dict):
                raise ProblemError(f"{path}: [frame] must be a table")
            flat["frame"] = {**flat.get("frame", {}), **value}  # a derived file changes only the keys it gives
        elif key in ("name", "description", "task", "robot"):
            flat[key] = value
        else:
            raise ProblemError(f"{path}: unknown key {key!r}; allowed: name, description, task, robot, base, environment, world, "
                               f"frame, {', '.join(f'[{s}]' for s in SECTIONS)}")
    if "environment" in raw and "world" in flat:  # planned for here: the base's world value gives way
        mine = raw.get("world", {})
        flat["world"] = {k: v for k, v in flat["world"].items() if k not in flat["environment"] or k in mine}
    return flat


def _model_path(path: Path, value: Any) -> Any:
    """A model named in a problem file: beside the file if it is there (a file outside the checkout
    naming its own `models/x`), else kept as written for `resolve` (the shipped models)."""
    if not isinstance(value, str) or not value or Path(value).is_absolute():
        return value
    local = path.parent / value
    return str(local) if any(local.with_name(local.name + s).exists() for s in MODEL_SUFFIXES) else value


def _base_path(path: Path, base: Any) -> Path:
    """A problem file's `base`: next to the file, else as the command line finds a name (a shipped
    `problems/NAME.toml`, given with or without `problems/`)."""
    if not isinstance(base, str) or not base:
        raise ProblemError(f"{path}: base = {base!r} must be a file name (e.g. \"problems/paper_sim.toml\")")
    local = path.parent / base
    if local.exists():
        return local.resolve()
    try:
        return find_problem(base).resolve()
    except ProblemError:
        raise ProblemError(f"{path}: base = {base!r} not found next to the file ({local}) nor among the shipped "
                           "problems (problems/paper_sim.toml, problems/scrape.toml, ...)") from None


def find_problem(name: str | Path) -> Path:
    """A problem file: the path as given if it exists, else a shipped one by name, with or without
    `problems/` and `.toml` ("paper_sim", "problems/paper_sim.toml")."""
    p = Path(name)
    if p.exists():
        return p
    stem = p.as_posix().removeprefix("problems/")
    for candidate in (p, Path(f"problems/{stem}"), Path(f"problems/{stem}.toml")):
        found = resolve(candidate)
        if found.exists():
            return found
    shipped = sorted(f.stem for f in (PACKAGE / "tasks").glob("*/problems/*.toml"))
    raise ProblemFileError(f"problem {str(name)!r} not found: give a path to a TOML file or a shipped name "
                           f"({', '.join(shipped)})")


def load_problem(path: str | Path) -> Problem:
    """Read and validate a problem file (a path, or a shipped name: `find_problem`); every error is
    a ProblemFileError naming the file."""
    p = find_problem(path)
    try:
        flat = _read_toml(p.resolve())
        flat.setdefault("name", p.stem)
        flat["source"] = str(path)
        return Problem.from_dict(flat)
    except TypeError as exc:  # a wrong type the dataclass cannot hold
        raise ProblemFileError(f"{path}: {exc}") from None
    except ProblemFileError:
        raise
    except ProblemError as exc:
        raise ProblemFileError(str(exc) if str(path) in str(exc) else f"{path}: {exc}") from None
