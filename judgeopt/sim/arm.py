"""The simulated arm (judgeopt.robots) with its spatula, shared by every task's scene: loading it into a PyBullet
client, and the plant side of the control loop (read the joints and the wrist sensor, apply the
hybrid controller's torques, step the physics).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from judgeopt.sim.quiet import c_stdout_to_stderr, pb
from judgeopt.sim.compiled import make_controller
from judgeopt.sim.controller import ControllerConfig, TaskCommand, solve_ik, wrap_angles
from judgeopt.robots import DEFAULT_ROBOT, get_robot
from judgeopt.robots.spec import RobotSpec
from judgeopt.sim.robot import SpatulaGeometry, robot_urdf

# PyBullet calls of the 1 kHz loop, bound once (ArmDriver.step)
_get_joint_states, _set_joint_motors, _step_simulation = pb.getJointStates, pb.setJointMotorControlArray, pb.stepSimulation
_TORQUE_CONTROL = pb.TORQUE_CONTROL

def connect(timestep: float, solver_iterations: int) -> int:
    """A PyBullet DIRECT client with gravity and a deterministic, fixed-step solver."""
    c = pb.connect(pb.DIRECT)
    pb.setGravity(0, 0, -9.81, physicsClientId=c)
    pb.setPhysicsEngineParameter(fixedTimeStep=timestep, numSolverIterations=solver_iterations,
                                 deterministicOverlappingPairs=1, physicsClientId=c)
    return c


@dataclass
class ArmBody:
    """The arm in a client: its config, body id, URDF, joint and link indices by name."""

    spec: RobotSpec
    client: int
    robot: int
    urdf_path: Path
    arm_joints: list[int]
    ft_joint: int
    links: dict[str, int]


def load_arm(client: int, spatula: SpatulaGeometry, wrist_inertia: str = "universal_robots",
             inertia_from_file: bool = True, visual_shapes: bool = True, robot: str = DEFAULT_ROBOT) -> ArmBody:
    """Load the arm; nothing of it collides until a task gives its spatula links collision layers.
    `inertia_from_file`: PyBullet integrates the URDF's inertias (the ones the controller's
    model reads; docs/physics.md), not ones derived from the collision shapes."""
    spec = get_robot(robot)
    urdf_path = robot_urdf(spatula, wrist_inertia=wrist_inertia, robot=robot)
    flags = pb.URDF_USE_INERTIA_FROM_FILE if inertia_from_file else 0
    if not visual_shapes:  # only a camera sees them; reading the arm's meshes is most of a scene's build (0.45 s)
        flags |= pb.URDF_IGNORE_VISUAL_SHAPES
    with c_stdout_to_stderr():  # URDF warnings about the massless root link
        body_id = pb.loadURDF(str(urdf_path), useFixedBase=True, flags=flags, physicsClientId=client)
    n = pb.getNumJoints(body_id, physicsClientId=client)
    names = {pb.getJointInfo(body_id, j, physicsClientId=client)[1].decode(): j for j in range(n)}
    links = {pb.getJointInfo(body_id, j, physicsClientId=client)[12].decode(): j for j in names.values()}
    body = ArmBody(spec, client, body_id, urdf_path, [names[j] for j in spec.joints], names["ft_sensor_joint"], links)
    for j in range(-1, n):
        pb.setCollisionFilterGroupMask(body_id, j, 0, 0, physicsClientId=client)
    for j in body.arm_joints:  # torque control: switch off the default velocity motors
        pb.setJointMotorControl2(body_id, j, pb.VELOCITY_CONTROL, force=0, physicsClientId=client)
        if spec.cap_joint_speed:  # no faster than its drive (RobotSpec.cap_joint_speed)
            limit = pb.getJointInfo(body_id, j, physicsClientId=client)[11]
            pb.changeDynamics(body_id, j, maxJointVelocity=limit, physicsClientId=client)
    pb.enableJointForceTorqueSensor(body_id, body.ft_joint, True, physicsClientId=client)
    return body


class ArmDriver:
    """The hybrid controller closed around the simulated arm, one 1 ms step at a time."""

    def __init__(self, body: ArmBody, spatula: SpatulaGeometry, config: ControllerConfig | None = None):
        self.body = body
        self.controller = make_controller(body.urdf_path, payload_weight=(spatula.handle_mass + spatula.blade_mass)
                                           * 9.81, config=config)
        # PyBullet reports the sensor joint's reaction in its child link's inertial frame,
        # which it rotates to the principal axes of the URDF's inertia (the handle is tilted):
        # rotate readings back to the link frame the controller expects
        orn = pb.getDynamicsInfo(body.robot, body.ft_joint, physicsClientId=body.client)[4]
        self.sensor_rotation = np.array(pb.getMatrixFromQuaternion(orn)).reshape(3, 3)
        # the compiled controller's 1 kHz path takes the joint states as PyBullet gives them
        self._step_states = getattr(self.controller, "step_joint_states", None)
        if self._step_states is not None:
            self.controller.sensor_rotation = self.sensor_rotation
        self._sensor_valid = False
        self._read_joints = [*body.arm_joints, body.ft_joint]  # read() takes the sensor's joint last
        #: the force sensor's errors: None (exact), or a callable from the true force in the sensor
        #: frame to the reading (bias and noise; the tasks' perturbations set it)
        self.sensor_model = None

    def joints_for(self, target: pin.SE3, start: np.ndarray | None = None) -> np.ndarray:
        """Joint angles placing the TCP at `target` (wrapped to [-pi, pi)), from `start` (None: the
        arm's home posture, which picks the IK's branch)."""
        q = solve_ik(self.controller.model, self.controller.tcp, target,
                     np.array(self.body.spec.home) if start is None else start)
        return wrap_angles(q)

    def reset(self, q0: np.ndarray) -> None:
        b = self.body
        for j, qi in zip(b.arm_joints, q0):
            pb.resetJointState(b.robot, j, qi, 0.0, physicsClientId=b.client)
        self.controller.reset(q0)
        self._sensor_valid = False  # PyBullet reports the last step's joint reaction until the next step

    def read(self) -> tuple[np.ndarray, np.ndarray | None]:
        """Joint angles and the force reading (sensor frame; None on the first step after a reset).
        One request for the arm's and the sensor's joints: PyBullet copies the body's whole state
        for each request."""
        b = self.body
        states = _get_joint_states(b.robot, self._read_joints, physicsClientId=b.client)
        q = np.array([s[0] for s in states[:-1]])
        if not self._sensor_valid:
            self._sensor_valid = True
            return q, None
        force = self.sensor_rotation @ np.array(states[-1][2][:3])
        return q, force if self.sensor_model is None else self.sensor_model(force)

    def step(self, cmd: TaskCommand) -> None:
        """Read the sensors, compute the torques, step the physics. With the compiled controller and
        an exact sensor, the joint states go to it as PyBullet gives them (one call, no arrays)."""
        b = self.body
        if self._step_states is not None and self.sensor_model is None:
            states = _get_joint_states(b.robot, self._read_joints, physicsClientId=b.client)
            tau = self._step_states(states, self._sensor_valid, cmd)
            self._sensor_valid = True
        else:
            q, ft = self.read()
            # a list converts to PyBullet's doubles in half the time an array of 6 takes (same values)
            tau = self.controller.step(q, ft, cmd).tolist()
        _set_joint_motors(b.robot, b.arm_joints, _TORQUE_CONTROL, forces=tau, physicsClientId=b.client)
        _step_simulation(physicsClientId=b.client)
