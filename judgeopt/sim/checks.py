"""The two checks an arm must pass before its simulated outcomes mean anything (`judgeopt robots --check`,
tests/robots): the plant PyBullet integrates is the model the controller computes with, and the compiled
1 kHz control step is the Python step it was generated from."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from judgeopt.sim.quiet import pb


def mass_matrix_error(client: int, body: int, urdf_path: str, n: int = 6, seed: int = 3) -> float:
    """The largest difference between PyBullet's mass matrix of `body` and Pinocchio's CRBA on its URDF,
    relative to the largest entry, over `n` random postures within the joint limits (and +-pi)."""
    model = pin.buildModelFromUrdf(str(urdf_path))
    data = model.createData()
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(n):
        q = rng.uniform(np.maximum(model.lowerPositionLimit, -math.pi), np.minimum(model.upperPositionLimit, math.pi))
        plant = np.array(pb.calculateMassMatrix(body, q.tolist(), physicsClientId=client))
        m = pin.crba(model, data, q)
        m = np.triu(m) + np.triu(m, 1).T
        worst = max(worst, float(np.abs(plant - m).max() / np.abs(m).max()))
    return worst


def plant_model_error(robot: str, n: int = 6, seed: int = 3) -> float:
    """mass_matrix_error of the arm `robot` as every scene loads it (hand removed, fingers fixed, base placed,
    inertias from the file), in a client of its own."""
    from judgeopt.sim.arm import connect, load_arm
    from judgeopt.sim.robot import SpatulaGeometry

    client = connect(1e-3, 50)
    try:
        body = load_arm(client, SpatulaGeometry(), visual_shapes=False, robot=robot)
        return mass_matrix_error(client, body.robot, body.urdf_path, n, seed)
    finally:
        pb.disconnect(physicsClientId=client)


def compiled_step_error(robot: str, n: int = 30, seed: int = 5, payload: float = 1.27) -> float:
    """The largest difference between the compiled and the Python control step's torques (relative to the
    largest torque, at least 1 N m), on `n` random states near the home posture, each stepped three times
    (filters carried over, no force reading on the first step), free and pressing commands."""
    from judgeopt.robots import get_robot
    from judgeopt.sim.compiled import CompiledController
    from judgeopt.sim.controller import ControllerConfig, HybridController, TaskCommand
    from judgeopt.sim.robot import SpatulaGeometry, robot_urdf

    urdf = robot_urdf(SpatulaGeometry(), robot=robot)
    cfg = ControllerConfig(selection=(1.0, 1.0, 0.2, 1.0, 1.0, 1.0))
    fast, ref = CompiledController(urdf, payload, config=cfg), HybridController(urdf, payload, config=cfg)
    home = np.array(get_robot(robot).home)
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(n):
        q0 = home + rng.normal(scale=0.2, size=home.size)
        fast.reset(q0)
        ref.reset(q0)
        for k in range(3):
            q = q0 + rng.normal(scale=0.01, size=home.size)
            cmd = TaskCommand(position=np.array([0.3, 0.05, 0.05]) + rng.normal(scale=0.03, size=3),
                              velocity=rng.normal(scale=0.2, size=6), force_z=rng.uniform(0.0, 20.0))
            force = None if k == 0 else rng.normal(scale=5.0, size=3)
            a, b = fast.step(q, force, cmd), ref.step(q, force, cmd)
            worst = max(worst, float(np.abs(a - b).max() / max(1.0, np.abs(b).max())))
    return worst
