"""What judgeopt needs from a task, and nothing more.

A task is a contact-rich motion whose success only a simulator (or the real world) can tell:
its signal channels (positions, their velocities, forces), its environment variables, how the
environment fixes the motion's end, random demonstration commands, and `simulate`. The judge,
the planners, the datasets and the command line work through this interface, so a new task is
a new subclass (docs/tasks.md), not a change to them.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from judgeopt.trajectory import DEFAULT_DT, DEFAULT_HORIZON

KINDS = ("position", "velocity", "force")


class TaskError(ValueError):
    """An unknown task, or data, a model or a plan made for another task."""


class EnvironmentRangeError(ValueError):
    """An environment value outside what the task's simulator accepts."""


@dataclass(frozen=True)
class Channel:
    """One signal of a plan and of a response. A velocity names the position it is the rate of."""

    name: str
    unit: str
    kind: str  # one of KINDS
    of: str | None = None  # for a velocity: its position channel

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise TaskError(f"channel {self.name!r}: kind {self.kind!r} is not one of {KINDS}")
        if (self.kind == "velocity") != (self.of is not None):
            raise TaskError(f"channel {self.name!r}: a velocity names its position (of=...), nothing else does")


@dataclass(frozen=True)
class EnvVar:
    """An environment variable: its physical range (what the simulator accepts) and the range
    demonstrations are drawn from by default."""

    name: str
    unit: str
    physical: tuple[float, float]
    sampled: tuple[float, float]
    description: str = ""

    def __post_init__(self) -> None:
        lo, hi = self.physical
        if not (lo <= self.sampled[0] <= self.sampled[1] <= hi):
            raise TaskError(f"environment variable {self.name!r}: sampled range {self.sampled} not within {self.physical}")


@dataclass
class Outcome:
    """What a simulated (or executed) plan gave: its label, the measured response on the plan's
    channels and sample times, and task-specific details (object rise, offsets, ...)."""

    success: bool
    response: np.ndarray
    details: dict[str, Any] = field(default_factory=dict)


class TaskSimulator(ABC):
    """One simulator instance per process (it may hold a physics client)."""

    @abstractmethod
    def simulate(self, plan: np.ndarray, env: Mapping[str, float], record: int = 0) -> Outcome:
        """Replay `plan` ((horizon + 1, channels) at the task's dt) in environment `env`."""


class Task(ABC):
    """A task: subclass it, fill in the class attributes and the two abstract methods."""

    name: str
    description: str
    channels: tuple[Channel, ...]
    env_vars: tuple[EnvVar, ...]
    horizon: int = DEFAULT_HORIZON
    dt: float = DEFAULT_DT

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

    def channels_of(self, kind: str) -> tuple[Channel, ...]:
        return tuple(c for c in self.channels if c.kind == kind)

    def env_ranges(self, which: str = "sampled") -> dict[str, tuple[float, float]]:
        return {v.name: getattr(v, which) for v in self.env_vars}

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

    def check_channels(self, names: tuple[str, ...] | list[str], what: str) -> None:
        if tuple(names) != self.channel_names:
            raise TaskError(f"{what} has channels {', '.join(names)}; task {self.name!r} has "
                            f"{', '.join(self.channel_names)}")

    # -- what a task must provide ------------------------------------------------------------
    def terminal(self, env: Mapping[str, float]) -> dict[str, float]:
        """Position channels whose end value the environment fixes (default: none)."""
        return {}

    @abstractmethod
    def random_command(self, rng: np.random.Generator, env: Mapping[str, float]) -> np.ndarray:
        """A random demonstration command, (horizon + 1, channels); deterministic given `rng`."""

    @abstractmethod
    def simulator(self) -> TaskSimulator:
        """A new simulator of the task's scene."""

    def describe(self) -> dict[str, Any]:
        return {"name": self.name, "description": self.description,
                "channels": [{"name": c.name, "unit": c.unit, "kind": c.kind, **({"of": c.of} if c.of else {})}
                             for c in self.channels],
                "env_names": list(self.env_names),
                "environment": [{"name": v.name, "unit": v.unit, "physical": list(v.physical),
                                 "sampled": list(v.sampled), "description": v.description} for v in self.env_vars],
                "horizon": self.horizon, "dt": self.dt}
