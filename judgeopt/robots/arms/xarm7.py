"""UFACTORY xArm7: 7 joints, light wrist; controlled with the dynamically consistent inverse (sim/controller.py)."""

from judgeopt.robots.spec import RobotSpec

ARM = RobotSpec(
    name="xarm7",
    title="UFACTORY xArm7",
    description="xarm_description/urdf/xarm7.urdf",
    flange="link_eef",
    joints=tuple(f"joint{i}" for i in range(1, 8)),
    home=(-0.165, 0.67, -0.071, 1.307, 0.074, 0.64, -0.28),  # scripts/place_arm.py xarm7
    base_xyz=(-0.25, 0.0, 0.05),
    notes="velocity limit 3.14 rad/s agrees with UFACTORY's 180 deg/s maximum joint speed (xArm user manual, "
          "8. Technical Specifications, xArm-Developer/ufactory_doc_usermanual); the effort limits 50/50/30/30/30/20/20 "
          "N m are UFACTORY's own description's (xArm-Developer/xarm_ros2, xarm7.urdf.xacro: the same); no UFACTORY "
          "torque figure found (user manual's technical and robot specifications, xarm_ros2's config/xarm7/joint_limits.yaml "
          "with its effort limits off, xArm SDK issues): unchecked; the file's 11.3 kg against 13.7 kg quoted "
          "by a distributor; the file's joint damping (10/5/2 N m s) is dropped with every arm's (sim/robot.py)",
)
