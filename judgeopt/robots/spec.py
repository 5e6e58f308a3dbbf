"""An arm as one config of one schema (cuRobo's idea): the description file it loads from
example-robot-data, the flange the force sensor and spatula mount on, its arm joints, where its
base stands in the task's world, the posture the IK starts from, and the corrections its file
needs, each with the maker's source.

Why one schema: everything arm-specific the simulator, the controller and the planners' joint
limits read comes from here, so an arm is added by one file (judgeopt/robots/arms/) and one
registry line, never by an edit to the physics.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from judgeopt.errors import BadInput


class RobotError(BadInput, ValueError):
    """An unknown arm, or an arm config that cannot be used."""


@dataclass(frozen=True)
class Correction:
    """A figure the description file gets wrong, replaced by the maker's, and where it comes from."""

    value: float | tuple[float, ...]
    source: str


@dataclass(frozen=True)
class RobotSpec:
    """One arm. Lengths in metres, angles in radians, limits in rad/s and N m."""

    name: str
    title: str  # maker and model, as its maker names it
    description: str  # the URDF, relative to example-robot-data's robots/ folder
    flange: str  # the link the force sensor and spatula mount on
    joints: tuple[str, ...]  # the actuated arm joints, base to flange (every other movable joint is locked)
    home: tuple[float, ...]  # a posture near the scoop's home pose, tool down: the IK's start and its branch
    #: where the arm's base stands in the task's world (the plate's top is z = 0, the TCP's home x = 0.3 m):
    #: chosen so the scooping line lies inside the arm's workspace with margin (tests/robots)
    base_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    base_yaw: float = 0.0  # rotation of the base about the world's z
    #: the mount on the flange link: its +z leaves the flange (the tool side); zeros where the link's own does
    mount_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mount_rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    #: links dropped with everything hanging on them: a hand the sensor and spatula replace
    remove: tuple[str, ...] = ()
    #: joint name -> Correction of its velocity limit [rad/s] / effort limit [N m] in the file
    velocity_limits: dict[str, Correction] = field(default_factory=dict)
    effort_limits: dict[str, Correction] = field(default_factory=dict)
    #: link name -> Correction of its inertia tensor's diagonal (ixx, iyy, izz) [kg m^2], off-diagonals zero
    inertias: dict[str, Correction] = field(default_factory=dict)
    #: link name -> Correction of its mass [kg] (its centre of mass stays the file's)
    masses: dict[str, Correction] = field(default_factory=dict)
    #: PyBullet holds each joint at or below its velocity limit, as the arm's drives do (PyBullet's own cap is
    #: 100 rad/s): a plan asking more of a slow arm falls behind in simulation as on the robot
    cap_joint_speed: bool = True
    notes: str = ""

    def __post_init__(self) -> None:
        if len(self.home) != len(self.joints):
            raise RobotError(f"robot {self.name!r}: home has {len(self.home)} angles for {len(self.joints)} joints")

    @property
    def placed(self) -> bool:
        """Whether the base stands anywhere but the world's origin (the URDF then gains a root link)."""
        return any(self.base_xyz) or bool(self.base_yaw)
