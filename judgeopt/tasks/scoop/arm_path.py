"""The scoop's arm along the scooping line, for the planners' joint-limit constraints: the TCP at
(x_home, y, contact height), level (rotation identity), as the rollout places and holds it while
the plan runs (rollout.Simulator.home_joints, Execution), pressing down (-z) on the plate.

Pinocchio and the robot's URDF load only here, when a planner asks (ScoopTask.arm_model).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from judgeopt.robots import get_robot
from judgeopt.sim.controller import solve_ik, wrap_angles
from judgeopt.sim.robot import robot_urdf
from judgeopt.tasks.base import ArmModel
from judgeopt.tasks.scoop.scene import SceneConfig

#: the TCP frame the controller tracks (sim.controller.HybridController's default)
TCP_FRAME = "tcp"


def tool_model(scene: SceneConfig) -> tuple[pin.Model, int]:
    """The arm + spatula's Pinocchio model (the URDF the simulator loads) and its TCP frame."""
    model = pin.buildModelFromUrdf(str(robot_urdf(scene.spatula, wrist_inertia=scene.wrist_inertia,
                                                  robot=scene.robot)))
    return model, model.getFrameId(TCP_FRAME)


def level_pose(scene: SceneConfig, y: float, lift: float = 0.0) -> pin.SE3:
    """The TCP level at (x_home, y), the blade on the plate (or `lift` above it): where the rollout holds it."""
    return pin.SE3(np.eye(3), np.array([scene.x_home, y, scene.spatula.tcp_height_on_plate() + lift]))


def scoop_arm(scene: SceneConfig | None = None) -> ArmModel:
    """The arm + spatula of `scene` (default: the shipped UR5) as an ArmModel: the same URDF the
    simulator and its controller load, the same IK and home posture the rollout starts from."""
    cfg = scene or SceneConfig()
    spec = get_robot(cfg.robot)
    model, tcp = tool_model(cfg)
    home = np.array(spec.home)

    def pose(position: np.ndarray) -> pin.SE3:
        return level_pose(cfg, float(np.ravel(position)[0]))

    def ik(position: np.ndarray, start: np.ndarray | None = None) -> np.ndarray:
        # as ArmDriver.joints_for: angles wrapped to [-pi, pi)
        q = solve_ik(model, tcp, pose(position), home if start is None else start)
        return wrap_angles(q)

    joints = tuple(model.names[i] for i in range(1, model.njoints))
    if joints != spec.joints:
        raise RuntimeError(f"the robot's URDF has joints {joints}, not the arm's {spec.joints}")
    return ArmModel(model=model, tool_frame=tcp, joints=joints, pose=pose, ik=ik,
                    axes=np.array([[0.0, 1.0, 0.0]]), force_axis=np.array([0.0, 0.0, -1.0]))
