"""SO-100 (TheRobotStudio and Hugging Face's LeRobot arm): 5 joints and a gripper, each driven by a Feetech
STS3215 hobby servo; the gripper's moving jaw is replaced by the sensor and spatula. Too weak for the scoop's
pressing force: kept to show what judgeopt says of an arm that cannot do the task (docs/guides/arm.md)."""

import math

from judgeopt.robots.spec import Correction, RobotSpec

_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll")
#: TheRobotStudio/SO-ARM100, README.md, footnote 1: the kit's STS3215 (7.4 V) stalls at 16.5 kg cm at 6 V
#: ("likely slightly less" on the kit's 5 V supply): 16.5 x 0.0980665 = 1.618 N m. Feetech's page names the
#: servo 19 kg cm at 7.4 V (1.86 N m); the 12 V version stalls at 30 kg cm (2.94 N m). A stall torque is the most
#: a servo gives at all, at zero speed, not what it holds for long.
STALL = Correction(1.618, "TheRobotStudio/SO-ARM100 README.md, footnote 1: STS3215 7.4 V, 16.5 kg cm stall torque at 6 V")
#: Feetech's STS3215 data sheet: 0.22 s/60 deg (45 rpm) at no load, as quoted in TheRobotStudio/SO-ARM100
#: issue 134 (the 12 V C018, measured there at 46 rpm); 45 rpm = 4.71 rad/s. The 7.4 V servo's own figure was
#: not found and is taken to be the same.
NO_LOAD = Correction(4.712, "Feetech STS3215 data sheet, 0.22 s/60 deg (45 rpm) no-load, as quoted in "
                            "TheRobotStudio/SO-ARM100 issue 134")

ARM = RobotSpec(
    name="so100",
    title="TheRobotStudio SO-100 (SO-ARM100), Feetech STS3215 servos",
    description="so_arm_description/urdf/so100.urdf",
    flange="gripper",
    joints=_JOINTS,
    home=(0.0, 1.975, -0.496, -0.25, 1.571),  # found by scripts/place_arm.py (docs/guides/arm.md, "The SO-100")
    base_xyz=(0.3, -0.3, 0.15),
    base_yaw=math.pi,
    mount_rpy=(math.pi / 2, 0.0, 0.0),  # the wrist roll's axis, out of the gripper (its link's -y)
    remove=("jaw",),
    # the file's 35 N m and 1 rad/s are not a hobby servo's
    velocity_limits={j: NO_LOAD for j in _JOINTS},
    effort_limits={j: STALL for j in _JOINTS},
)
