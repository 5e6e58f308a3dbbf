"""The scrape's channels, environment and commandable ranges: what its scene, its commands and
the task share, in a module that imports none of them."""

from __future__ import annotations

from judgeopt.tasks.base import EnvVar, Perturbation
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

#: how the world may differ from the one the scrape's plans are made for (evaluate robustness,
#: collect --randomize); the scene applies them (judgeopt.tasks.scrape.world)
PERTURBATIONS = (
    Perturbation("mu_factor", "x", (0.1, 10.0), (0.8, 1.25), "friction misestimated: the true puck-plate mu is the "
                 "told one times this (clipped to the scene's range, 0.05-1)", nominal=1.0, env="mu"),
    Perturbation("x_obj_offset", "m", (-0.05, 0.05), (-0.02, 0.02), "the puck lies this much further along x than "
                 "the plan was told", env="x_obj"),
    Perturbation("y_obj_offset", "m", (-0.05, 0.05), (-0.02, 0.02), "the puck lies this much further along y (towards "
                 "the tray) than the plan was told (clipped to 0.06-0.18 m)", env="y_obj"),
    Perturbation("mass_factor", "x", (0.2, 5.0), (0.5, 2.0), "the puck's mass (1 kg) times this", nominal=1.0),
    Perturbation("kp_factor", "x", (0.1, 5.0), (0.5,), "the controller's stiff x, y and rotation gains times this "
                 "(z, force-controlled, unchanged)", nominal=1.0),
    Perturbation("sensor_bias", "N", (-10.0, 10.0), (-1.0, 1.0), "the force sensor reads the pressing force this "
                 "much high"),
    Perturbation("sensor_noise", "N", (0.0, 10.0), (0.5, 2.0), "standard deviation of Gaussian noise on each 1 kHz "
                 "force reading, per axis (seeded per rollout)"),
)
#: `plot-data`'s panels: demonstrations split at these frictions, about the terciles of the sampled range
DEMO_PANELS = ("mu", (0.35, 0.55))
#: a lab's trial-to-trial spread (`evaluate trials`): each perturbation's half-width around its nominal (the
#: scoop's widths, what the scrape's trials drew before each task declared its own)
TRIAL_SPREAD = {"y_obj_offset": 0.005, "mu_factor": 0.1, "mass_factor": 0.1, "sensor_noise": 0.5}
