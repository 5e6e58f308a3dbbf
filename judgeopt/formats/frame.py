"""The task frame: where a plan's one-dimensional channels lie in the robot's world.

A plan knows positions along the task's own axes (the scoop's y along the scooping line) and
pressing forces; a robot needs poses and wrenches in one of its frames. A problem file says how
in an optional `[frame]` section (units m; a quaternion as x, y, z, w):

    [frame]
    frame_id = "base_link"          # the parent frame of every exported pose and wrench
    origin = [0.45, -0.10, 0.02]    # the task frame's origin (where every position is 0), in frame_id
    orientation = [0, 0, 0, 1]      # the task frame's orientation in frame_id (the tool keeps it)
    axes = { y = "y", f = "-z" }    # the task-frame axis of each position and force channel

Left out, each value takes its default: frame_id "base_link", origin 0, orientation identity,
and the axes from the task: a position channel named x, y or z lies along that axis, a task's
only force presses along -z (down); another task's channels need their axes given. A velocity
lies along the axis of the position it is the rate of.

The tool position at a sample is origin + R (sum of position * axis), its commanded velocity
R (sum of velocity * axis) and its commanded force R (force * axis), R the orientation's rotation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from judgeopt.errors import BadInput
from judgeopt.tasks import Task

#: the signed axis names a channel may lie along
AXES = {"x": (1, 0, 0), "y": (0, 1, 0), "z": (0, 0, 1), "-x": (-1, 0, 0), "-y": (0, -1, 0), "-z": (0, 0, -1)}
KEYS = ("frame_id", "origin", "orientation", "axes")
DEFAULT_FRAME_ID = "base_link"
#: a quaternion this far from unit norm is a typing mistake, not rounding
QUATERNION_TOLERANCE = 1e-3


class FrameError(BadInput, ValueError):
    """A task frame that is malformed or does not fit the task; the message names the field."""


@dataclass(frozen=True)
class TaskFrame:
    """Where the task's axes lie in `frame_id` (see the module docstring)."""

    frame_id: str = DEFAULT_FRAME_ID
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    #: position or force channel -> signed axis name ("y", "-z")
    axes: Mapping[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"frame_id": self.frame_id, "origin": list(self.origin), "orientation": list(self.orientation),
                "axes": dict(self.axes)}

    def rotation(self) -> np.ndarray:
        """The 3 x 3 rotation of the orientation quaternion."""
        x, y, z, w = self.orientation
        return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])

    def direction(self, channel: str) -> np.ndarray:
        """The unit vector, in frame_id, of a channel's axis."""
        return self.rotation() @ np.array(AXES[self.axes[channel]], dtype=float)

    def place(self, values: np.ndarray, channels: tuple, kind: str) -> np.ndarray:
        """(T, 3) in frame_id: the tool position (kind "position", offset by the origin), velocity
        or force of each sample of `values` (T, channels)."""
        out = np.zeros((len(values), 3))
        for j, c in enumerate(channels):
            if c.kind == kind:
                out += np.outer(values[:, j], self.direction(c.of if kind == "velocity" else c.name))
        return out + np.array(self.origin) if kind == "position" else out


def default_axes(task: Task) -> dict[str, str]:
    """The task's own axes: positions named x, y or z along that axis; a single force along -z."""
    axes = {c.name: c.name for c in task.channels_of("position") if c.name in AXES}
    forces = task.channels_of("force")
    if len(forces) == 1:
        axes[forces[0].name] = "-z"
    return axes


def _numbers(name: str, value: Any, count: int) -> tuple[float, ...]:
    ok = (isinstance(value, (list, tuple)) and len(value) == count
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value))
    if not ok:
        raise FrameError(f"[frame] {name} = {value!r} must be a list of {count} finite numbers")
    return tuple(float(v) for v in value)


def task_frame(spec: Mapping[str, Any] | None, task: Task) -> TaskFrame:
    """A checked TaskFrame from a problem file's `[frame]` table (None: every default)."""
    if spec is not None and not isinstance(spec, Mapping):
        raise FrameError(f"[frame] must be a table, got {spec!r}")
    spec = dict(spec or {})
    unknown = [k for k in spec if k not in KEYS]
    if unknown:
        raise FrameError(f"[frame] unknown key {unknown[0]!r}; allowed: {', '.join(KEYS)}")
    frame_id = spec.get("frame_id", DEFAULT_FRAME_ID)
    if not isinstance(frame_id, str) or not frame_id.strip() or any(ch.isspace() for ch in frame_id):
        raise FrameError(f"[frame] frame_id = {frame_id!r} must be a frame name without spaces (e.g. \"base_link\")")
    origin = _numbers("origin", spec.get("origin", [0.0, 0.0, 0.0]), 3)
    q = np.array(_numbers("orientation", spec.get("orientation", [0.0, 0.0, 0.0, 1.0]), 4))
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        raise FrameError(f"[frame] orientation = {list(spec['orientation'])} is not a unit quaternion [qx, qy, qz, qw] "
                         f"(norm {norm:.4g})")
    given = spec.get("axes", {})
    if not isinstance(given, dict):
        raise FrameError(f"[frame] axes = {given!r} must be a table, e.g. {{ y = \"y\", f = \"-z\" }}")
    placed = [c.name for c in task.channels if c.kind in ("position", "force")]
    for name, axis in given.items():
        if name not in placed:
            raise FrameError(f"[frame] axes.{name}: not a position or force channel of task {task.name!r} "
                             f"(those are {', '.join(placed)}; a velocity follows its position)")
        if axis not in AXES:
            raise FrameError(f"[frame] axes.{name} = {axis!r} must be one of {', '.join(AXES)}")
    axes = {**default_axes(task), **given}
    missing = [n for n in placed if n not in axes]
    if missing:
        raise FrameError(f"[frame] axes.{missing[0]}: task {task.name!r} has no default axis for channel "
                         f"{missing[0]!r}; give one (x, y, z, -x, -y or -z)")
    positions = [c.name for c in task.channels_of("position")]
    for kind_names in (positions, [c.name for c in task.channels_of("force")]):
        seen: dict[str, str] = {}
        for n in kind_names:
            bare = axes[n].lstrip("-")
            if bare in seen:
                raise FrameError(f"[frame] axes.{n} = {axes[n]!r} lies along the axis of {seen[bare]!r} "
                                 f"({axes[seen[bare]]!r}); each channel needs its own axis")
            seen[bare] = n
    return TaskFrame(frame_id, origin, tuple(float(v) for v in q / norm),  # type: ignore[arg-type]
                     {n: axes[n] for n in placed})
