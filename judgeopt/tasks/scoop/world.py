"""The scoop's simulator with a world that may differ from the nominal one (spec.PERTURBATIONS):
the environment misestimated (the plan was told one y_obj and mu, the world has others), and the
scene's unobserved parameters (object mass and size, the mat's stiffness and damping, the
controller's gains, the force sensor's bias and noise).

Every parameter but the object's size is changed in the running scene (PyBullet's dynamics,
the controller's gains, the driver's sensor hook), so a perturbed rollout costs what a nominal
one does; a scaled object needs a new collision shape, so it runs in a scene built for that size
(the last two sizes are kept). Tests check that each in-place change gives the rollout a scene
built with that parameter gives.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Mapping, Sequence

import numpy as np

from judgeopt.sim.quiet import pb
from judgeopt.tasks.base import Outcome
from judgeopt.tasks.scoop.rollout import Simulator
from judgeopt.tasks.scoop.spec import REAL_ROBOT_KP, REAL_ROBOT_KV
from judgeopt.tasks.world import sensor_errors, world_sensor

#: scenes with a scaled object kept per simulator (one is built per new size, ~0.3 s)
KEEP_SIZES = 2


class WorldSimulator(Simulator):
    """`perturb(values, seed)` sets the world of the rollouts that follow; `simulate(plan, env)`
    replays a plan made for `env` in that world (`{}`: the nominal world, the default)."""

    def __init__(self, scene=None, controller=None, rollout=None, visual_shapes: bool = True):
        from judgeopt.tasks import get_task

        super().__init__(scene, controller, rollout, visual_shapes)
        self.task = get_task("scoop")
        sc = self.scene
        info = pb.getDynamicsInfo(sc.obj, -1, physicsClientId=sc.client)
        self._mass, self._inertia = float(info[0]), np.array(info[2], dtype=float)
        self._kp, self._kv = np.array(self.controller.kp, dtype=float), np.array(self.controller.kv, dtype=float)
        self.world: dict[str, float] = {}
        self.seed = 0
        self._sized: dict[float, WorldSimulator] = {}

    def perturb(self, values: Mapping[str, float], seed: int | Sequence[int] = 0) -> None:
        values = self.task.check_perturbation(values)
        world = {k: v for k, v in values.items() if v != self.task.perturbation(k).nominal}
        self.world, self.seed = world, seed
        size = world.get("size_factor")
        if size is not None:
            self._scaled(size).perturb({k: v for k, v in world.items() if k != "size_factor"}, seed)
            return
        sc, c, cfg = self.scene, self.scene.client, self.scene.config
        m = world.get("mass_factor", 1.0)
        pb.changeDynamics(sc.obj, -1, mass=self._mass * m, localInertiaDiagonal=(self._inertia * m).tolist(),
                          physicsClientId=c)
        pb.changeDynamics(sc.plate, -1, contactStiffness=cfg.plate_stiffness * world.get("stiffness_factor", 1.0),
                          contactDamping=cfg.plate_damping * world.get("damping_factor", 1.0), physicsClientId=c)
        w = world.get("real_gains", 0.0)
        ctl = self.controller
        ctl.kp = self._kp.copy() if w == 0.0 else (1 - w) * self._kp + w * np.array(REAL_ROBOT_KP)
        ctl.kv = self._kv.copy() if w == 0.0 else (1 - w) * self._kv + w * np.array(REAL_ROBOT_KV)

    def _scaled(self, size: float) -> "WorldSimulator":
        if size not in self._sized:
            while len(self._sized) >= KEEP_SIZES:
                self._sized.pop(next(iter(self._sized))).close()
            g = self.scene.config.pancake
            scaled = dataclasses.replace(g, diameter=g.diameter * size, thickness=g.thickness * size,
                                         bevel_in=g.bevel_in * size, bevel_height=g.bevel_height * size)
            self._sized[size] = WorldSimulator(dataclasses.replace(self.scene.config, pancake=scaled),
                                               self.controller.config, self.rollout_config, self.scene.visual_shapes)
        return self._sized[size]

    def simulate(self, plan: Any, env: Mapping[str, float], record: int = 0) -> Outcome:
        """Replay `plan`, made for `env` (the told environment), in the perturbed world."""
        size = self.world.get("size_factor")
        if size is not None:
            return self._scaled(size).simulate(plan, env, record)
        true = self.task.true_env(env, self.world)
        # the home pose holds the TCP level (rotation identity): the pressing force is the sensor's z
        with sensor_errors(self.driver, self.world, np.eye(3), self.seed):
            return super().simulate(plan, true, record)

    def execute(self, plan: Any, env: Mapping[str, float], record: int = 0) -> Any:
        """Start executing `plan`, made for `env` (the told environment), in the perturbed world,
        to be stepped; the sensor's bias and noise stay on until the next `simulate`."""
        size = self.world.get("size_factor")
        if size is not None:
            return self._scaled(size).execute(plan, env, record)
        self.driver.sensor_model = world_sensor(self.world, np.eye(3), self.seed)
        return super().execute(plan, self.task.true_env(env, self.world), record)

    def close(self) -> None:
        for sim in self._sized.values():
            sim.close()
        self._sized.clear()
        super().close()
