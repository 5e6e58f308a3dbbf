"""The scooping scene in PyBullet: plate, pancake-like object and the arm (default the UR5) with its spatula.

Frames (SI units throughout): the world frame is the UR5's base frame (another arm's base stands where
its RobotSpec.base_xyz places it), z up; the plate's top
surface is the plane z = 0 and y is the scooping direction. The tool centre point (TCP) is the
blade centre; the motion's home point is (x, y, z) = (0.3, 0, 0) in the paper's task
coordinates, i.e. TCP at x = 0.3 m, y = 0, blade front edge on the plate. The planner's
position q is the TCP's y coordinate, the object position y_obj its centre's y coordinate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from judgeopt.robots import DEFAULT_ROBOT
from judgeopt.sim.quiet import pb
from judgeopt.sim.arm import connect, load_arm
from judgeopt.sim.robot import SpatulaGeometry
from judgeopt.tasks.base import EnvironmentRangeError
from judgeopt.tasks.scoop.spec import ENV_VARS

#: physical range of the environment variables the scene accepts
ENV_RANGES = {v.name: v.physical for v in ENV_VARS}


#: SceneConfig.plant_inertia: which inertias PyBullet integrates
PLANT_INERTIA = ("urdf", "collision_shapes")


@dataclass(frozen=True)
class ObjectGeometry:
    """A pancake: a thin disc whose bottom rim is bevelled, so a blade edge can get under it."""

    diameter: float = 0.07
    thickness: float = 0.013
    bevel_in: float = 0.008  # how far the bottom face is set in from the rim
    bevel_height: float = 0.004
    mass: float = 0.03
    sides: int = 24

    def hull_vertices(self) -> list[list[float]]:
        r, h = self.diameter / 2, self.thickness
        rings = ((r, h / 2), (r, -h / 2 + self.bevel_height), (r - self.bevel_in, -h / 2))
        pts = []
        for radius, z in rings:
            for k in range(self.sides):
                a = 2 * math.pi * k / self.sides
                pts.append([radius * math.cos(a), radius * math.sin(a), z])
        return pts


@dataclass(frozen=True)
class SceneConfig:
    """Everything physical about the scene except the environment (y_obj, mu)."""

    timestep: float = 1e-3
    x_home: float = 0.3
    spatula: SpatulaGeometry = field(default_factory=SpatulaGeometry)
    pancake: ObjectGeometry = field(default_factory=ObjectGeometry)
    # The plate is a soft mat (the paper's real robot scooped off a carpet on a mat): pressing
    # harder sinks the blade's edge below the object's rim, which is what lets a blade get
    # under a high-friction object at low speed. Chosen from a grid of speeds, forces and mu
    # run before any data was made (README, "The scene").
    plate_friction: float = 2.0  # object-plate coefficient (the object's own coefficient is 1)
    blade_plate_friction: float = 0.2  # spatula-plate coefficient, independent of mu
    plate_stiffness: float = 1.2e3  # N/m per contact point
    plate_damping: float = 1.0e2  # N s/m
    solver_iterations: int = 50
    # The plant's link inertias. "urdf": PyBullet integrates the URDF's inertias, the ones
    # Pinocchio (and so M and Lambda in the controller) reads, so plant and model agree (to
    # 1e-12, tests/test_scene.py). "collision_shapes": PyBullet's default, inertias derived
    # from the collision meshes: a model error of up to ~19 % of M's largest entry, the scene
    # of every dataset made before 2026-11-22 (with wrist_inertia = "example_robot_data").
    plant_inertia: str = "urdf"
    wrist_inertia: str = "universal_robots"  # judgeopt.sim.robot.WRIST_INERTIA_SOURCES
    robot: str = DEFAULT_ROBOT  # the arm holding the spatula (judgeopt.robots; `judgeopt robots` lists them)


def check_environment(y_obj: float, mu: float) -> None:
    for name, value in (("y_obj", y_obj), ("mu", mu)):
        lo, hi = ENV_RANGES[name]
        if not (math.isfinite(value) and lo <= value <= hi):
            raise EnvironmentRangeError(f"{name} = {value!r} is outside the scene's physical range [{lo}, {hi}]")


class Scene:
    """One PyBullet DIRECT client holding the scene; reset() places the object for a new rollout."""

    def __init__(self, config: SceneConfig | None = None, visual_shapes: bool = True):
        """`visual_shapes`: load the arm's meshes for a camera (render); physics never reads them."""
        self.config = cfg = config or SceneConfig()
        self.visual_shapes = visual_shapes
        self.client = c = connect(cfg.timestep, cfg.solver_iterations)
        if cfg.plant_inertia not in PLANT_INERTIA:
            raise ValueError(f"plant_inertia = {cfg.plant_inertia!r}; choose one of {PLANT_INERTIA}")
        self.arm = load_arm(c, cfg.spatula, cfg.wrist_inertia, inertia_from_file=cfg.plant_inertia == "urdf",
                            visual_shapes=visual_shapes, robot=cfg.robot)
        self.robot, self.urdf_path = self.arm.robot, self.arm.urdf_path
        self.arm_joints, self.ft_joint = self.arm.arm_joints, self.arm.ft_joint
        links = self.arm.links
        self.blade_top, self.blade_bottom, self.handle = links["blade_top"], links["blade_bottom"], links["spatula"]
        self.tcp_link = links["tcp"]

        plate_half = [0.2, 0.45, 0.05]  # thick, so a deep press into the soft mat never tunnels through
        col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=plate_half, physicsClientId=c)
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=plate_half, rgbaColor=[0.45, 0.5, 0.42, 1], physicsClientId=c)
        self.plate = pb.createMultiBody(0, col, vis, [cfg.x_home, 0.15, -plate_half[2]], physicsClientId=c)
        pb.changeDynamics(self.plate, -1, lateralFriction=cfg.plate_friction, contactStiffness=cfg.plate_stiffness,
                          contactDamping=cfg.plate_damping, physicsClientId=c)

        g = cfg.pancake
        col = pb.createCollisionShape(pb.GEOM_MESH, vertices=g.hull_vertices(), physicsClientId=c)
        vis = pb.createVisualShape(pb.GEOM_MESH, vertices=g.hull_vertices(), indices=_hull_indices(g),
                                   rgbaColor=[0.85, 0.6, 0.25, 1], physicsClientId=c)
        self.obj = pb.createMultiBody(g.mass, col, vis, [cfg.x_home, 0.2, 0.5], physicsClientId=c)
        pb.changeDynamics(self.obj, -1, lateralFriction=1.0, physicsClientId=c)
        for link, layer in ((self.blade_top, 1), (self.handle, 1), (self.blade_bottom, 2)):
            pb.setCollisionFilterGroupMask(self.robot, link, layer, layer, physicsClientId=c)
        pb.setCollisionFilterGroupMask(self.obj, -1, 1, 1 | 4, physicsClientId=c)
        pb.setCollisionFilterGroupMask(self.plate, -1, 2 | 4, 2 | 4, physicsClientId=c)
        pb.changeDynamics(self.robot, self.blade_bottom, lateralFriction=cfg.blade_plate_friction / cfg.plate_friction,
                          physicsClientId=c)
        self.mu = float("nan")
        # every rollout starts from this snapshot (no contacts, no solver warm-start
        # history), so a rollout's result does not depend on the ones before it
        self.state_id = pb.saveState(physicsClientId=c)

    def restore(self) -> None:
        pb.restoreState(self.state_id, physicsClientId=self.client)

    def set_mu(self, mu: float) -> None:
        """Spatula-object friction: Bullet multiplies the two bodies' coefficients, the object's is 1."""
        pb.changeDynamics(self.robot, self.blade_top, lateralFriction=mu, physicsClientId=self.client)
        pb.changeDynamics(self.robot, self.handle, lateralFriction=mu, physicsClientId=self.client)
        self.mu = mu

    def place_object(self, y_obj: float) -> None:
        g = self.config.pancake
        pb.resetBasePositionAndOrientation(self.obj, [self.config.x_home, y_obj, g.thickness / 2], [0, 0, 0, 1],
                                           physicsClientId=self.client)
        pb.resetBaseVelocity(self.obj, [0, 0, 0], [0, 0, 0], physicsClientId=self.client)

    def object_pose(self) -> tuple[np.ndarray, np.ndarray]:
        p, q = pb.getBasePositionAndOrientation(self.obj, physicsClientId=self.client)
        return np.array(p), np.array(q)

    def object_lowest_point(self) -> float:
        """Height of the object's lowest point above the plate's surface (z = 0) now."""
        p, q = pb.getBasePositionAndOrientation(self.obj, physicsClientId=self.client)
        R = np.array(pb.getMatrixFromQuaternion(q)).reshape(3, 3)
        return float(np.min(np.asarray(self.config.pancake.hull_vertices()) @ R[2]) + p[2])

    def contacts(self, link: int) -> int:
        return len(pb.getContactPoints(self.robot, self.obj, link, -1, physicsClientId=self.client))

    def touches_plate(self) -> bool:
        return bool(pb.getContactPoints(self.obj, self.plate, physicsClientId=self.client))

    def close(self) -> None:
        if pb.isConnected(self.client):
            pb.disconnect(self.client)


def _hull_indices(g: ObjectGeometry) -> list[int]:
    """Triangles of the bevelled disc's surface, for rendering only."""
    n = g.sides
    idx: list[int] = []
    for k in range(n):
        a, b = k, (k + 1) % n
        for ring in (0, 1):  # side bands: rim, bevel
            p0, p1, q0, q1 = ring * n + a, ring * n + b, (ring + 1) * n + a, (ring + 1) * n + b
            idx += [p0, q0, p1, p1, q0, q1]
    for k in range(1, n - 1):  # top and bottom caps as fans
        idx += [0, k + 1, k]
        idx += [2 * n, 2 * n + k, 2 * n + k + 1]
    return idx
