"""The scrape: the UR5's spatula, held slightly front-edge-up so it rests on its heel, presses on
a rigid plate and pushes a heavy wedge-sided puck over the plate's front edge into a tray.

Two position axes (x, y in the plate plane), their velocities, and the pressing force; the
environment is the puck's position (x_obj, y_obj) and the puck-plate friction mu. What decides
the outcome (measured, docs/tasks.md): the blade must meet the puck within about 5 cm of its
centre (x matters through the aim), push it far enough (the end of y), and press hard enough
while in contact, or the wedge lifts the blade over the puck; the force needed grows with mu
and with the pushing speed. None of it is a formula of the plan: only the simulator tells.

The simulator (PyBullet, Pinocchio) loads only when `simulator()` is called.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from judgeopt.tasks.base import EnvVar, Task, TaskSimulator
from judgeopt.trajectory import Channel

CHANNELS = (
    Channel("x", "m", "position"), Channel("y", "m", "position"),
    Channel("xdot", "m/s", "velocity", of="x"), Channel("ydot", "m/s", "velocity", of="y"),
    Channel("f", "N", "force"),
)
ENV_VARS = (
    EnvVar("x_obj", "m", physical=(0.16, 0.44), sampled=(0.20, 0.40), description="the puck centre's x (across the plate)"),
    EnvVar("y_obj", "m", physical=(0.06, 0.18), sampled=(0.10, 0.16),
           description="the puck centre's y (the plate's front edge is at y = 0.24 m)"),
    EnvVar("mu", "", physical=(0.05, 1.0), sampled=(0.2, 0.7), description="puck-plate friction coefficient"),
)
#: where every plan starts, at rest (TCP x, y in m)
START = (0.30, 0.0)
#: commandable ranges: TCP x; TCP y (the blade's front edge stays 5 mm inside the plate edge); force
X_RANGE = (0.16, 0.44)
Y_RANGE = (-0.05, 0.1855)
F_RANGE = (0.0, 30.0)
#: the demonstrations' speed limit: faster pushes throw the blade up whatever the force
V_MAX = 0.6


@dataclass(frozen=True)
class ScrapeSettings:
    """Everything about the scrape's simulation but the environment (defaults: the shipped scene)."""

    commands: Any = None  # judgeopt.tasks.scrape.commands.ScrapeCommandConfig
    scene: Any = None  # judgeopt.tasks.scrape.scene.ScrapeConfig

    def __post_init__(self) -> None:
        from judgeopt.tasks.scrape.commands import ScrapeCommandConfig
        from judgeopt.tasks.scrape.scene import ScrapeConfig

        if self.commands is None:
            object.__setattr__(self, "commands", ScrapeCommandConfig())
        if self.scene is None:
            object.__setattr__(self, "scene", ScrapeConfig())


class ScrapeTask(Task):
    name = "scrape"
    description = "push a wedge-sided puck off a plate into a tray with a pressed, slightly tilted spatula"
    channels = CHANNELS
    env_vars = ENV_VARS
    default_judge = "models/scrape/judge"

    def settings(self) -> ScrapeSettings:
        return ScrapeSettings()

    def demonstrated(self) -> dict[str, tuple[float, float]]:
        return {"x": X_RANGE, "y": Y_RANGE, "xdot": (-V_MAX, V_MAX), "ydot": (-V_MAX, V_MAX), "f": F_RANGE}

    def random_command(self, rng: np.random.Generator, env: Mapping[str, float],
                       settings: ScrapeSettings | None = None) -> np.ndarray:
        from judgeopt.tasks.scrape.commands import random_command

        return random_command(rng, env, (settings or ScrapeSettings()).commands)

    def simulator(self, settings: ScrapeSettings | None = None) -> TaskSimulator:
        from judgeopt.tasks.scrape.scene import ScrapeSimulator

        return ScrapeSimulator((settings or ScrapeSettings()).scene)

    def explain(self, details: Mapping[str, Any]) -> str:
        return (f"the puck moved {100 * details['pushed']:.1f} cm along y, the blade rose at most "
                f"{1000 * details['blade_max_lift']:.1f} mm; it ended {'in' if details['in_tray'] else 'outside'} "
                "the tray")
