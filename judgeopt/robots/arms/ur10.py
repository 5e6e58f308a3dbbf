"""Universal Robots UR10 (CB3): long reach, strong base joints."""

from judgeopt.robots.arms.ur5 import ARM as UR5
from judgeopt.robots.spec import RobotSpec

ARM = RobotSpec(
    name="ur10",
    title="Universal Robots UR10",
    description="ur_description/urdf/ur10_robot.urdf",
    flange="tool0",
    joints=UR5.joints,
    home=(-0.388, -1.183, 1.989, -2.377, -1.571, -1.959),  # scripts/place_arm.py ur10
    base_xyz=(-0.45, 0.0, 0.0),
    notes="limits match Universal Robots' within 4 %; the file's shoulder, forearm and wrist 3 masses differ from "
          "UR's (7.778/3.87/0.202 kg against 7.1/4.27/0.365, config/ur10/physical_parameters.yaml): not corrected yet",
)
