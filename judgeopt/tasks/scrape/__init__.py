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

from judgeopt.tasks.base import Task, TaskSimulator
from judgeopt.tasks.scrape.spec import (CHANNELS, DEMO_PANELS, ENV_VARS, F_RANGE, PERTURBATIONS, START, TRIAL_SPREAD,
                                        V_MAX, X_RANGE, Y_RANGE)

__all__ = ["CHANNELS", "ENV_VARS", "F_RANGE", "PERTURBATIONS", "START", "V_MAX", "X_RANGE", "Y_RANGE", "ScrapeSettings",
           "ScrapeTask"]


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
    # fine-tuned on the planners' replayed outcomes under many limits (docs/remedies.md); the judge
    # trained on demonstrations only is models/scrape/judge_demos
    default_judge = "models/scrape/judge_refined"
    # the push needs 5 N at mu 0.2 and 28 N at mu 0.7 (docs/tasks.md): f_max from 3 N fails often
    wide_limits = {"qdot_max": (0.2, V_MAX), "f_min": (0.0, 2.0), "f_max": (3.0, F_RANGE[1])}
    # the world unlike the model: friction and the puck's place misestimated, mass, gains, sensor
    perturbations = PERTURBATIONS
    trial_spread = TRIAL_SPREAD
    demo_panels = DEMO_PANELS
    graded_outcome = True
    outcome_measures = (("pushed", "how far the puck was pushed along y", "cm", 100.0),
                        ("blade_max_lift", "the blade's highest rise while pushing", "mm", 1000.0))

    def settings(self) -> ScrapeSettings:
        return ScrapeSettings()

    def demonstrated(self) -> dict[str, tuple[float, float]]:
        return {"x": X_RANGE, "y": Y_RANGE, "xdot": (-V_MAX, V_MAX), "ydot": (-V_MAX, V_MAX), "f": F_RANGE}

    def random_command(self, rng: np.random.Generator, env: Mapping[str, float],
                       settings: ScrapeSettings | None = None) -> np.ndarray:
        from judgeopt.tasks.scrape.commands import random_command

        return random_command(rng, env, (settings or ScrapeSettings()).commands)

    def simulator(self, settings: ScrapeSettings | None = None, render: bool = False) -> TaskSimulator:
        from judgeopt.tasks.scrape.world import ScrapeWorldSimulator

        return ScrapeWorldSimulator((settings or ScrapeSettings()).scene)

    def explain(self, details: Mapping[str, Any]) -> str:
        return (f"the puck moved {100 * details['pushed']:.1f} cm along y, the blade rose at most "
                f"{1000 * details['blade_max_lift']:.1f} mm; it ended {'in' if details['in_tray'] else 'outside'} "
                "the tray (a success needs: in the tray)")
