"""The scoop's channels, environment and demonstration grid: what the rest of the scoop's
modules (scene, rollout, commands) and the task share, in a module that imports none of them."""

from __future__ import annotations

import numpy as np

from judgeopt.tasks.base import EnvVar, Perturbation
from judgeopt.trajectory import Channel, Plan

CHANNELS = (Channel("y", "m", "position"), Channel("ydot", "m/s", "velocity", of="y"), Channel("f", "N", "force"))
ENV_VARS = (
    EnvVar("y_obj", "m", physical=(0.05, 0.35), sampled=(0.10, 0.28),
           description="the object centre's position along the scooping line (paper Table 3)"),
    # nominal: the simulated lab's one friction, where scoops under Table 8 (f <= 10 N) succeed
    # reliably (94-99 % of random plans at mu 0.3-0.7, 0.5 in the middle; docs/physics.md)
    EnvVar("mu", "", physical=(0.01, 5.0), sampled=(1.0, 3.0),
           description="spatula-object friction coefficient (paper Table 3)", nominal=0.5),
)


def scoop_plan(dt: float, y: np.ndarray, ydot: np.ndarray, f: np.ndarray) -> Plan:
    """A scoop plan from its three columns."""
    return Plan.from_columns(dt, CHANNELS, y, ydot, f)


#: the paper's 3 x 3 grid of demonstration environments (IV-B)
PAPER_GRID = {"y_obj": (0.10, 0.19, 0.28), "mu": (1.0, 2.0, 3.0)}
#: `plot-data`'s panels: demonstrations split at these frictions (the paper's Fig. 13 shows its effect)
DEMO_PANELS = ("mu", (1.5, 2.5))
#: a lab's trial-to-trial spread (`evaluate trials`): each perturbation's half-width around its nominal
TRIAL_SPREAD = {"y_obj_offset": 0.005, "mu_factor": 0.1, "mass_factor": 0.1, "sensor_noise": 0.5}


#: the paper's real-robot gains (Table 6): Kp diag[1000, 1000, 1000, 2000, 2000, 2000] 1/s^2, Kv diag[40, 40, 40,
#: 50, 50, 50] 1/s; the simulation's are Table 1 (ControllerConfig's defaults)
REAL_ROBOT_KP = (1000.0, 1000.0, 1000.0, 2000.0, 2000.0, 2000.0)
REAL_ROBOT_KV = (40.0, 40.0, 40.0, 50.0, 50.0, 50.0)

#: how the world may differ from the one the scoop's plans are made for (evaluate robustness,
#: collect --randomize); the scene applies them (judgeopt.tasks.scoop.world)
PERTURBATIONS = (
    Perturbation("mu_factor", "x", (0.1, 10.0), (0.5, 2.0), "friction misestimated: the true spatula-object mu is the "
                 "told one times this (clipped to the scene's range, 0.01-5)", nominal=1.0, env="mu"),
    Perturbation("y_obj_offset", "m", (-0.05, 0.05), (-0.03, 0.03), "the object lies this much further along the "
                 "scooping line than the plan was told (negative: nearer)", env="y_obj"),
    Perturbation("mass_factor", "x", (0.2, 5.0), (0.5, 2.0), "the object's mass (30 g) times this", nominal=1.0),
    Perturbation("size_factor", "x", (0.7, 1.3), (0.85, 1.15), "the object's diameter, thickness and bevel times this "
                 "(mass unchanged)", nominal=1.0),
    Perturbation("stiffness_factor", "x", (0.2, 5.0), (0.6, 1.6), "the mat's contact stiffness times this",
                 nominal=1.0),
    Perturbation("damping_factor", "x", (0.2, 5.0), (0.5, 2.0), "the mat's contact damping times this", nominal=1.0),
    Perturbation("real_gains", "", (0.0, 1.0), (1.0,), "the controller's gains from the simulation's (Table 1, 0) to "
                 "the paper's real robot's (Table 6, 1), interpolated"),
    Perturbation("sensor_bias", "N", (-10.0, 10.0), (-1.0, 1.0), "the force sensor reads the pressing force this "
                 "much high"),
    Perturbation("sensor_noise", "N", (0.0, 10.0), (0.5, 2.0), "standard deviation of Gaussian noise on each 1 kHz "
                 "force reading, per axis (seeded per rollout)"),
)
