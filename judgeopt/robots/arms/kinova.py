"""Kinova JACO2 6-DOF, spherical wrist (j2s6s200): slow joints, light; its fingers are replaced by the
sensor and spatula."""

import math

from judgeopt.robots.spec import Correction, RobotSpec

#: Kinova's actuator sheet (KA-75+ on joints 1-3, KA-58 on 4-6; peak torques), as quoted by
#: google-deepmind/dm_control, dm_control/entities/manipulators/kinova/jaco_arm.py
_SOURCE = ("Kinova, KINOVA Actuator series KA75+ KA-58 Specifications (AS-ACT-KA58-KA75-SP-INT-EN 201804-1.2), "
           "peak torque, as quoted in dm_control's jaco_arm.py")
_JOINTS = tuple(f"j2s6s200_joint_{i}" for i in range(1, 7))

ARM = RobotSpec(
    name="kinova",
    title="Kinova JACO2 6-DOF spherical wrist (j2s6s200)",
    description="kinova_description/robots/kinova.urdf",
    flange="j2s6s200_link_6",
    joints=_JOINTS,
    home=(1.785, 1.033, 1.787, 0.0, 0.754, 0.214),  # scripts/place_arm.py kinova
    base_xyz=(-0.25, 0.0, 0.0),
    mount_rpy=(math.pi, 0.0, 0.0),  # the hand's -z leaves the wrist
    remove=("j2s6s200_link_finger_1", "j2s6s200_link_finger_2"),
    # the file's 40/80/40/20/20/20 N m are above the actuators' peak torques
    effort_limits={j: Correction(30.5 if i < 3 else 6.8, _SOURCE) for i, j in enumerate(_JOINTS)},
    notes="velocity limits 36/48 deg/s confirmed by Kinova (kinova-ros issue 236) and dm_control's jaco_arm.py",
)
