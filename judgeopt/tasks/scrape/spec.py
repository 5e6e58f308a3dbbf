"""The scrape's channels, environment and commandable ranges: what its scene, its commands and
the task share, in a module that imports none of them."""

from __future__ import annotations

from judgeopt.tasks.base import EnvVar
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
