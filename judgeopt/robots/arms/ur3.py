"""Universal Robots UR3 (CB3): short reach; its file carries the UR10's limits, corrected here."""

from judgeopt.robots.arms.ur5 import ARM as UR5
from judgeopt.robots.spec import Correction, RobotSpec

#: Universal Robots' own figures (CB3 user manual v3.13 and UR's "max. joint torques"), as the maker's ROS 2
#: description gives them: Universal_Robots_ROS2_Description, config/ur3/joint_limits.yaml
_SOURCE = "Universal_Robots_ROS2_Description, config/ur3/joint_limits.yaml (UR3 CB3 user manual v3.13)"
_BASE, _WRIST = UR5.joints[:3], UR5.joints[3:]

ARM = RobotSpec(
    name="ur3",
    title="Universal Robots UR3",
    description="ur_description/urdf/ur3_robot.urdf",
    flange="tool0",
    joints=UR5.joints,
    home=(3.085, 2.056, 2.126, -2.611, 1.571, -1.627),  # scripts/place_arm.py ur3
    base_xyz=(0.0, 0.0, 0.15),
    # the file's 2.16/3.15/3.2 rad/s and 330/150/54 N m are the UR10's
    velocity_limits={**{j: Correction(3.1416, _SOURCE) for j in _BASE}, **{j: Correction(6.2832, _SOURCE) for j in _WRIST}},
    effort_limits={**{j: Correction(t, _SOURCE) for j, t in zip(_BASE, (56.0, 56.0, 28.0))},
                   **{j: Correction(12.0, _SOURCE) for j in _WRIST}},
)
