"""Universal Robots UR5 (CB3), the default arm: the paper's scoop was planned for a UR5-class arm."""

from judgeopt.robots.spec import Correction, RobotSpec

_UR = "Universal_Robots_ROS2_Description, config/ur5/physical_parameters.yaml"
#: example-robot-data computes each wrist's cylinder inertia with a radius of 0.6 m instead of 0.06 m (izz =
#: m r^2 / 2 = 0.219 kg m^2 for a 1.2 kg wrist, about 100x too large; wrist 3 likewise). Universal Robots'
#: own figures: the same masses, cylinders of radius 0.06 m (wrists 1, 2) and 0.0375 m (wrist 3).
WRIST_INERTIA = {
    "wrist_1_link": Correction((0.0020138896, 0.0020138896, 0.0021942), _UR),
    "wrist_2_link": Correction((0.0018310396, 0.0018310396, 0.0021942), _UR),
    "wrist_3_link": Correction((8.0624758e-05, 8.0624758e-05, 1.3211719e-04), _UR),
}

ARM = RobotSpec(
    name="ur5",
    title="Universal Robots UR5",
    description="ur_description/urdf/ur5_robot.urdf",
    flange="tool0",
    joints=("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
            "wrist_3_joint"),
    home=(-0.816, -1.778, 2.418, -2.211, -1.571, -2.387),  # elbow up, tool down
    inertias=WRIST_INERTIA,
    # the shipped data, judges and plans were made without the cap: its light wrist 3 spins at up to 10 rad/s
    # for about 0.1 s early in random demonstrations (docs/physics.md, "Joint speeds"); capped, 2 of 50 such
    # demonstrations change their label
    cap_joint_speed=False,
    notes="the file's velocity (3.15/3.2 rad/s) and effort (150/28 N m) limits are Universal Robots' own",
)
