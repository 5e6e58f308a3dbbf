"""UFACTORY xArm7: 7 joints."""

from judgeopt.robots.spec import RobotSpec

ARM = RobotSpec(
    name="xarm7",
    title="UFACTORY xArm7",
    description="xarm_description/urdf/xarm7.urdf",
    flange="link_eef",
    joints=tuple(f"joint{i}" for i in range(1, 8)),
    home=(-0.165, 0.67, -0.071, 1.307, 0.074, 0.64, -0.28),  # scripts/place_arm.py xarm7
    base_xyz=(-0.25, 0.0, 0.05),
    notes="limits as UFACTORY's own description (no datasheet torques found); the file's 11.3 kg against 13.7 kg quoted "
          "by a distributor",
)
