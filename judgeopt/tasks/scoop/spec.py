"""The scoop's channels, environment and demonstration grid: what the rest of the scoop's
modules (scene, rollout, commands) and the task share, in a module that imports none of them."""

from __future__ import annotations

import numpy as np

from judgeopt.tasks.base import EnvVar
from judgeopt.trajectory import Channel, Plan

CHANNELS = (Channel("y", "m", "position"), Channel("ydot", "m/s", "velocity", of="y"), Channel("f", "N", "force"))
ENV_VARS = (
    EnvVar("y_obj", "m", physical=(0.05, 0.35), sampled=(0.10, 0.28),
           description="the object centre's position along the scooping line (paper Table 3)"),
    EnvVar("mu", "", physical=(0.01, 5.0), sampled=(1.0, 3.0),
           description="spatula-object friction coefficient (paper Table 3)"),
)


def scoop_plan(dt: float, y: np.ndarray, ydot: np.ndarray, f: np.ndarray) -> Plan:
    """A scoop plan from its three columns."""
    return Plan.from_columns(dt, CHANNELS, y, ydot, f)


#: the paper's 3 x 3 grid of demonstration environments (IV-B)
PAPER_GRID = {"y_obj": (0.10, 0.19, 0.28), "mu": (1.0, 2.0, 3.0)}
