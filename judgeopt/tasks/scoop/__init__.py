"""The scoop (paper IV): a UR5 with a spatula slides under a pancake-like object on a soft plate
and lifts it, under the hybrid position/force controller. One position axis y along the
scooping line, its velocity, and the pressing force; the environment is the object's position
y_obj and the spatula-object friction mu; the scoop ends at the object.

The simulator (PyBullet, Pinocchio) loads only when `simulator()` is called.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from judgeopt.tasks.base import Task, TaskSimulator
from judgeopt.tasks.scoop.spec import (CHANNELS, DEMO_PANELS, ENV_VARS, PAPER_GRID, PERTURBATIONS, TRIAL_SPREAD,
                                       scoop_plan)
from judgeopt.trajectory import Plan

__all__ = ["CHANNELS", "ENV_VARS", "PAPER_GRID", "PERTURBATIONS", "ScoopSettings", "ScoopTask", "scoop_plan"]


@dataclass(frozen=True)
class ScoopSettings:
    """Everything about the scoop's simulation but the environment. Fields default to the
    shipped scene (their classes hold the one definition of each value)."""

    commands: Any = None  # judgeopt.tasks.scoop.commands.RandomCommandConfig
    scene: Any = None  # judgeopt.tasks.scoop.scene.SceneConfig
    controller: Any = None  # judgeopt.sim.controller.ControllerConfig
    rollout: Any = None  # judgeopt.tasks.scoop.rollout.RolloutConfig

    def __post_init__(self) -> None:
        from judgeopt.sim.controller import ControllerConfig
        from judgeopt.tasks.scoop.commands import RandomCommandConfig
        from judgeopt.tasks.scoop.rollout import RolloutConfig
        from judgeopt.tasks.scoop.scene import SceneConfig

        for name, cls in (("commands", RandomCommandConfig), ("scene", SceneConfig), ("controller", ControllerConfig),
                          ("rollout", RolloutConfig)):
            if getattr(self, name) is None:
                object.__setattr__(self, name, cls())


class ScoopTask(Task):
    name = "scoop"
    description = "scoop a pancake-like object off a soft plate with a spatula (Furuta et al. 2020)"
    channels = CHANNELS
    env_vars = ENV_VARS
    demo_grid = PAPER_GRID
    demo_panels = DEMO_PANELS
    # the scoop ends under the object
    default_q_end = "y_obj"
    # fine-tuned on the planners' replayed outcomes (docs/remedies.md); the paper's judge,
    # trained on demonstrations only, is models/judge_demos_tcn
    default_judge = "models/judge_refined"
    # q̇_max from what reaches y_obj = 0.28 m; below f_max ~ 15 N no scoop succeeds at high friction
    wide_limits = {"qdot_max": (0.22, 1.2), "f_min": (0.0, 10.0), "f_max": (11.0, 30.0)}
    # where scoops start to fail: pressing at most 11-15.5 N, at any speed limit, anywhere, on any friction
    # the judge was trained on and a little beyond (mu 3.0-3.2)
    edge_band = {"qdot_max": (0.3, 1.0), "f_max": (11.0, 15.5), "y_obj": (0.12, 0.27), "mu": (1.0, 3.2)}
    # the world unlike the model: friction and position misestimated, mass, size, mat, gains, sensor
    perturbations = PERTURBATIONS
    trial_spread = TRIAL_SPREAD
    graded_outcome = True
    outcome_measures = (("object_ahead", "the object's centre ahead of the blade centre", "cm", 100.0),
                        ("object_bottom", "the object's lowest point above the plate", "cm", 100.0))

    def terminal(self, env: Mapping[str, float]) -> dict[str, float]:
        return {"y": float(env["y_obj"])}

    def settings(self) -> ScoopSettings:
        return ScoopSettings()

    def demonstrated(self) -> dict[str, tuple[float, float]]:
        from judgeopt.tasks.scoop.commands import RandomCommandConfig

        c = RandomCommandConfig()
        return {"y": c.y_limits, "ydot": (-c.max_speed, c.max_speed), "f": c.force}

    def explain(self, details: Mapping[str, Any]) -> str:
        from judgeopt.tasks.scoop.rollout import RolloutConfig

        rc = RolloutConfig()
        test = (f"clear of the plate by {100 * rc.success_clearance:g} cm" if rc.success_test == "clear"
                else f"rise >= {100 * rc.success_rise:g} cm")
        bottom = (f" (its lowest point {100 * details['object_bottom']:.1f} cm above the plate)"
                  if "object_bottom" in details else "")
        return (f"the object rose {100 * details['object_rise']:.1f} cm{bottom} and ended "
                f"{100 * details['offset_from_blade']:.1f} cm from the blade centre, "
                f"{'on' if details['on_blade'] else 'off'} the blade (a success needs: {test}, "
                f"on the blade, off the plate, within {100 * rc.max_overhang:g} cm)")

    def render(self, plan: Any, env: Mapping[str, float], out: Any, caption: str = "", simulator: Any = None):
        from judgeopt.tasks.scoop.render import render_rollout

        plan = plan if isinstance(plan, Plan) else self.plan(plan)
        sim = simulator or self.simulator(render=True)
        return render_rollout(sim, plan, float(env["y_obj"]), float(env["mu"]), out, caption=caption)

    def tables(self) -> dict[str, Any]:
        from judgeopt.tasks.scoop.tables import TABLES

        return dict(TABLES)

    def random_command(self, rng: np.random.Generator, env: Mapping[str, float],
                       settings: ScoopSettings | None = None) -> np.ndarray:
        from judgeopt.tasks.scoop.commands import RandomCommandConfig, random_command

        # not ScoopSettings(): its scene and controller import PyBullet and Pinocchio, which a
        # planner's cold start (commands only) never needs
        cfg = settings.commands if settings is not None else RandomCommandConfig()
        return random_command(rng, float(env["y_obj"]), cfg).as_array()

    def arm_model(self, problem: Any = None) -> Any:
        """The problem's arm (default the UR5) + spatula along the scooping line (tasks/scoop/arm_path.py;
        loads Pinocchio)."""
        from judgeopt.robots import DEFAULT_ROBOT
        from judgeopt.tasks.scoop.arm_path import scoop_arm
        from judgeopt.tasks.scoop.scene import SceneConfig

        return scoop_arm(SceneConfig(robot=getattr(problem, "robot", DEFAULT_ROBOT)))

    def simulator(self, settings: ScoopSettings | None = None, render: bool = False) -> TaskSimulator:
        from judgeopt.tasks.scoop.world import WorldSimulator

        s = settings or ScoopSettings()
        return WorldSimulator(s.scene, s.controller, s.rollout, visual_shapes=render)
