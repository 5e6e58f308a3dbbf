"""The arms judgeopt can simulate and plan for, by name (`judgeopt robots` lists them).

Built-in arms are in `BUILTIN`, one module each under judgeopt/robots/arms/; a package of your
own adds arms through the `judgeopt.robots` entry-point group (`name = "mypkg.myarm:ARM"`) or
`register_robot`. The UR5 is the default: its plans and data are the shipped ones.
"""

from __future__ import annotations

import functools
import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from judgeopt.robots.spec import RobotSpec

#: name -> "module:attribute" of a RobotSpec
BUILTIN = {
    "ur5": "judgeopt.robots.arms.ur5:ARM",
    "ur3": "judgeopt.robots.arms.ur3:ARM",
    "ur10": "judgeopt.robots.arms.ur10:ARM",
    "panda": "judgeopt.robots.arms.panda:ARM",
    "kinova": "judgeopt.robots.arms.kinova:ARM",
    "xarm7": "judgeopt.robots.arms.xarm7:ARM",
    "so100": "judgeopt.robots.arms.so100:ARM",
}
DEFAULT_ROBOT = "ur5"

_REGISTERED: dict[str, "RobotSpec"] = {}


def register_robot(spec: "RobotSpec") -> None:
    """Make `spec` the arm called `spec.name` (in this process)."""
    _REGISTERED[spec.name] = spec


def unregister_robot(name: str) -> None:
    """Forget an arm added with `register_robot` (installed and built-in arms stay)."""
    _REGISTERED.pop(name, None)


@functools.cache
def _entry_points() -> tuple[tuple[str, str], ...]:
    from importlib.metadata import entry_points

    return tuple((ep.name, ep.value) for ep in entry_points(group="judgeopt.robots"))


def robot_names() -> list[str]:
    """Every arm's name: built in, installed, registered."""
    return sorted({*BUILTIN, *(n for n, _ in _entry_points()), *_REGISTERED})


def get_robot(name: str) -> "RobotSpec":
    """The arm called `name`; a one-line error naming the known ones otherwise."""
    if name in _REGISTERED:
        return _REGISTERED[name]
    src = BUILTIN.get(name) or dict(_entry_points()).get(name)
    if src is None:
        from judgeopt.robots.spec import RobotError

        raise RobotError(f"unknown robot {name!r}: known robots are {', '.join(robot_names())} "
                         "(`judgeopt robots` lists them with their limits)")
    module, _, attr = src.partition(":")
    return getattr(importlib.import_module(module), attr)
