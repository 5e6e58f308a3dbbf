"""The scrape's simulator with a world that may differ from the nominal one (spec.PERTURBATIONS):
the puck's place and friction misestimated (the plan was told one environment, the world has
another), the puck's mass, the controller's stiff gains, the force sensor's bias and noise, all
changed in the running scene."""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

from judgeopt.sim.quiet import pb
from judgeopt.tasks.base import Outcome
from judgeopt.tasks.scrape.scene import ScrapeSimulator
from judgeopt.tasks.world import sensor_errors, world_sensor

#: the gains `kp_factor` scales: x, y and the rotation (z is force-controlled)
SCALED_AXES = np.array([True, True, False, True, True, True])


class ScrapeWorldSimulator(ScrapeSimulator):
    """`perturb(values, seed)` sets the world of the rollouts that follow; `simulate(plan, env)`
    replays a plan made for `env` in that world (`{}`: the nominal world, the default)."""

    def __init__(self, config=None):
        super().__init__(config)
        info = pb.getDynamicsInfo(self.puck, -1, physicsClientId=self.client)
        self._mass, self._inertia = float(info[0]), np.array(info[2], dtype=float)
        self._kp = np.array(self.driver.controller.kp, dtype=float)
        self.world: dict[str, float] = {}
        self.seed = 0

    def perturb(self, values: Mapping[str, float], seed: int | Sequence[int] = 0) -> None:
        values = self.task.check_perturbation(values)
        self.world = {k: v for k, v in values.items() if v != self.task.perturbation(k).nominal}
        self.seed = seed
        m = self.world.get("mass_factor", 1.0)
        pb.changeDynamics(self.puck, -1, mass=self._mass * m, localInertiaDiagonal=(self._inertia * m).tolist(),
                          physicsClientId=self.client)
        k = self.world.get("kp_factor", 1.0)
        self.driver.controller.kp = np.where(SCALED_AXES, self._kp * k, self._kp) if k != 1.0 else self._kp.copy()

    def simulate(self, plan: Any, env: Mapping[str, float], record: int = 0) -> Outcome:
        """Replay `plan`, made for `env` (the told environment), in the perturbed world."""
        true = self.task.true_env(env, self.world)
        with sensor_errors(self.driver, self.world, self.rotation, self.seed):
            return super().simulate(plan, true, record)

    def execute(self, plan: Any, env: Mapping[str, float], record: int = 0) -> Any:
        """Start executing `plan`, made for `env` (the told environment), in the perturbed world,
        to be stepped; the sensor's bias and noise stay on until the next `simulate`."""
        self.driver.sensor_model = world_sensor(self.world, self.rotation, self.seed)
        return self.start(plan, self.task.true_env(env, self.world), record)

