"""What the tasks' perturbed worlds share: the force sensor's errors (bias and noise), given to
the arm driver's sensor hook (`judgeopt.sim.arm.ArmDriver.sensor_model`)."""

from __future__ import annotations

from contextlib import contextmanager
from typing import Any, Iterator, Mapping, Sequence

import numpy as np


class SensorErrors:
    """reading = force + bias + noise: `bias` a vector in the sensor frame, `noise` the standard
    deviation (N) of independent Gaussian noise on each axis of each reading, drawn from a
    generator seeded by `seed` (a rollout's noise is the same whenever it is run)."""

    def __init__(self, bias: np.ndarray, noise: float, seed: int | Sequence[int] = 0):
        self.bias = np.asarray(bias, dtype=float)
        self.noise = float(noise)
        self.rng = np.random.default_rng(seed)

    def __call__(self, force: np.ndarray) -> np.ndarray:
        out = force + self.bias
        if self.noise > 0.0:
            out = out + self.rng.normal(0.0, self.noise, 3)
        return out


def pressing_bias(bias: float, rotation: np.ndarray) -> np.ndarray:
    """The sensor-frame bias that makes the measured pressing force (world z, the controller's
    f_est) read `bias` N high with the tool at `rotation` (TCP to world): the controller takes
    the contact force as -(R f_sensor), so f_sensor is biased by -bias R^T e_z."""
    return -float(bias) * np.asarray(rotation, dtype=float)[2]


def sensor_model(bias: float, noise: float, rotation: np.ndarray, seed: int | Sequence[int]) -> SensorErrors | None:
    """The sensor errors of a perturbed world, or None where the sensor is exact."""
    if bias == 0.0 and noise == 0.0:
        return None
    return SensorErrors(pressing_bias(bias, rotation), noise, seed)


def world_sensor(world: Mapping[str, float], rotation: np.ndarray, seed: int | Sequence[int]) -> SensorErrors | None:
    """The sensor errors of a perturbed world (its `sensor_bias` and `sensor_noise`, 0 if not
    given) with the tool at `rotation` (TCP to world), or None where the sensor is exact."""
    return sensor_model(world.get("sensor_bias", 0.0), world.get("sensor_noise", 0.0), rotation, seed)


@contextmanager
def sensor_errors(driver: Any, world: Mapping[str, float], rotation: np.ndarray,
                  seed: int | Sequence[int]) -> Iterator[None]:
    """The arm driver reads its force sensor with the world's errors while the block runs (a
    rollout), and exactly again after it, even if the rollout raises."""
    driver.sensor_model = world_sensor(world, rotation, seed)
    try:
        yield
    finally:
        driver.sensor_model = None
