"""Kinova JACO2 6-DOF, spherical wrist (j2s6s200): slow joints, light; its fingers are replaced by the
sensor and spatula."""

import math

from judgeopt.robots.spec import RobotSpec

ARM = RobotSpec(
    name="kinova",
    title="Kinova JACO2 6-DOF spherical wrist (j2s6s200)",
    description="kinova_description/robots/kinova.urdf",
    flange="j2s6s200_link_6",
    joints=tuple(f"j2s6s200_joint_{i}" for i in range(1, 7)),
    home=(1.785, 1.033, 1.787, 0.0, 0.754, 0.214),  # scripts/place_arm.py kinova
    base_xyz=(-0.25, 0.0, 0.0),
    mount_rpy=(math.pi, 0.0, 0.0),  # the hand's -z leaves the wrist
    remove=("j2s6s200_link_finger_1", "j2s6s200_link_finger_2"),
    notes="velocity limits 36/48 deg/s confirmed by Kinova (kinova-ros issue 236); the effort limits "
          "40/80/40/20/20/20 N m are kinova-ros's description values, unchecked against Kinova's actuator sheet",
)
