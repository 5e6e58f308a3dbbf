"""Universal Robots UR10 (CB3): long reach, strong base joints."""

from judgeopt.robots.arms.ur5 import ARM as UR5
from judgeopt.robots.spec import Correction, RobotSpec

_UR = "Universal_Robots_ROS2_Description, config/ur10/physical_parameters.yaml"
#: Universal Robots' masses where the file's are more than 5 % off: shoulder 7.778 kg (UR: 7.1), forearm
#: 3.87 kg (4.27), wrist 3 0.202 kg (0.365). The upper arm (12.93 against 12.7) and wrists 1, 2 (1.96
#: against 2.0) are within 2 % and stay the file's.
MASSES = {"shoulder_link": 7.1, "forearm_link": 4.27, "wrist_3_link": 0.365}


def cylinder(mass: float, radius: float, length: float) -> tuple[float, float, float]:
    """The (ixx, iyy, izz) of a solid cylinder along z: the formula the file's tensors come from."""
    across = mass * (3 * radius**2 + length**2) / 12
    return across, across, mass * radius**2 / 2


#: the file's tensors are cylinders of radius 0.075 m and its own masses (lengths 0.178, 0.5723 and 0.12 m, read
#: back from its ixx and izz): with UR's masses they are those cylinders' again, else density and size disagree.
#: UR's own tensors (extracted from URSim, in its ROS 2 description's link frames) are not taken: see notes.
_CYLINDER = {"shoulder_link": (0.075, 0.178), "forearm_link": (0.075, 0.5723), "wrist_3_link": (0.075, 0.12)}

ARM = RobotSpec(
    name="ur10",
    title="Universal Robots UR10",
    description="ur_description/urdf/ur10_robot.urdf",
    flange="tool0",
    joints=UR5.joints,
    home=(-0.388, -1.183, 1.989, -2.377, -1.571, -1.959),  # scripts/place_arm.py ur10
    base_xyz=(-0.45, 0.0, 0.0),
    masses={link: Correction(m, _UR) for link, m in MASSES.items()},
    inertias={link: Correction(cylinder(MASSES[link], r, h), f"the file's cylinder with UR's mass, {_UR}")
              for link, (r, h) in _CYLINDER.items()},
    notes="limits match Universal Robots' within 4 %; masses checked against UR's (Universal_Robots_ROS2_Description, "
          "config/ur10/physical_parameters.yaml): shoulder, forearm and wrist 3 corrected from 7.778/3.87/0.202 kg to "
          "7.1/4.27/0.365 kg, their cylinder tensors with them; the other three within 2 %. The file's centres of mass "
          "(mid-link) and cylinder tensors are not UR's (its URSim tensors and centres of mass are in the ROS 2 "
          "description's link frames): not taken",
)
