"""A plan as a ROS 2 recording (MCAP) a ROS 2 user can play (`ros2 bag play -s mcap FILE`) or
inspect (Foxglove, `ros2 bag info`), written with the pure-Python `rosbags` library (the `ros`
extra: pip install 'judgeopt[ros]'), so no ROS installation is needed to write one.

Per sample of the plan resampled to the controller's step (1 ms, as the CSV), in the task frame's
parent frame (judgeopt.formats.frame; header.frame_id), stamped with the plan's time from
`start_ns`:

    /judgeopt/pose       geometry_msgs/msg/PoseStamped    commanded tool position, the frame's orientation
    /judgeopt/twist      geometry_msgs/msg/TwistStamped   commanded tool velocity (linear; angular 0)
    /judgeopt/wrench     geometry_msgs/msg/WrenchStamped  commanded force (torque 0)
    /judgeopt/plan_info  std_msgs/msg/String              once, at the start: JSON with the plan's
                                                          method, environment, verdict, frame, channels
                                                          and provenance

One .mcap file (rosbag2's metadata is inside it), written to a temporary folder and renamed.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from judgeopt.files import cannot_write, make_temp_dir
from judgeopt.formats.frame import TaskFrame
from judgeopt.trajectory import Plan, PlanError

TOPICS = {"pose": "/judgeopt/pose", "twist": "/judgeopt/twist", "wrench": "/judgeopt/wrench",
          "info": "/judgeopt/plan_info"}
TYPES = {"pose": "geometry_msgs/msg/PoseStamped", "twist": "geometry_msgs/msg/TwistStamped",
         "wrench": "geometry_msgs/msg/WrenchStamped", "info": "std_msgs/msg/String"}
EXTRA = "pip install 'judgeopt[ros]' (the rosbags package)"


class RosExportError(PlanError):
    """An MCAP file the library could not write (a value it refused, a full disk)."""


def typestore():
    """The ROS 2 message types (rosbags' Humble store: these messages are the same in every distro)."""
    try:
        from rosbags.typesys import Stores, get_typestore
    except ImportError:  # the command line maps a missing extra to its exit code and this line
        raise ModuleNotFoundError(f"writing MCAP needs the ros extra: {EXTRA}", name="rosbags") from None
    return get_typestore(Stores.ROS2_HUMBLE)


def plan_samples(plan: Plan, frame: TaskFrame, step: float) -> dict[str, np.ndarray]:
    """t (s) and, in the frame's parent frame, the tool's position, velocity and force (T, 3)."""
    t, values = plan.resample(step)
    return {"t": t, **{kind: frame.place(values, plan.channels, kind) for kind in ("position", "velocity", "force")}}


def write_mcap(plan: Plan, frame: TaskFrame, path: str | Path, info: dict[str, Any] | None = None,
               step: float = 1e-3, start_ns: int = 0) -> Path:
    """Write the plan's messages (module docstring) to one MCAP file at `path`, atomically."""
    ts = typestore()
    from rosbags.rosbag2 import StoragePlugin, Writer

    T = ts.types
    s = plan_samples(plan, frame, step)
    stamps = start_ns + np.round(s["t"] * 1e9).astype(np.int64)
    info_text = json.dumps({**(info or {}), "frame": frame.to_dict(), "step": step, "start_ns": int(start_ns),
                            "channels": [c.name for c in plan.channels], "topics": TOPICS})
    q = T["geometry_msgs/msg/Quaternion"](x=frame.orientation[0], y=frame.orientation[1], z=frame.orientation[2],
                                          w=frame.orientation[3])
    zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)

    def header(ns: int):
        return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=int(ns // 10**9),
                                                                               nanosec=int(ns % 10**9)),
                                        frame_id=frame.frame_id)

    def vector(v: np.ndarray):
        return T["geometry_msgs/msg/Vector3"](x=float(v[0]), y=float(v[1]), z=float(v[2]))

    path = Path(path)
    tmp = make_temp_dir(path)  # an unwritable folder: one line naming `path` (OutputWriteError)
    bag = tmp / "bag"
    try:
        with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as w:
            conn = {k: w.add_connection(TOPICS[k], TYPES[k], typestore=ts) for k in TOPICS}
            msg = T[TYPES["info"]](data=info_text)
            w.write(conn["info"], int(stamps[0]), ts.serialize_cdr(msg, TYPES["info"]))
            for k, ns in enumerate(map(int, stamps)):
                p = s["position"][k]
                pose = T["geometry_msgs/msg/Pose"](
                    position=T["geometry_msgs/msg/Point"](x=float(p[0]), y=float(p[1]), z=float(p[2])), orientation=q)
                msgs = {"pose": T[TYPES["pose"]](header=header(ns), pose=pose),
                        "twist": T[TYPES["twist"]](header=header(ns), twist=T["geometry_msgs/msg/Twist"](
                            linear=vector(s["velocity"][k]), angular=zero)),
                        "wrench": T[TYPES["wrench"]](header=header(ns), wrench=T["geometry_msgs/msg/Wrench"](
                            force=vector(s["force"][k]), torque=zero))}
                for key, m in msgs.items():
                    w.write(conn[key], ns, ts.serialize_cdr(m, TYPES[key]))
        (bag / "bag.mcap").replace(path)
    except Exception as exc:  # rosbags' own errors (a bad value, a full disk) as one line
        if isinstance(exc, OSError):
            raise cannot_write(path, exc) from None
        raise RosExportError(f"{path}: rosbags could not write the plan ({type(exc).__name__}: {exc})") from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return path



def summarize_mcap(path: str | Path) -> dict[str, Any]:
    """What an MCAP file holds, read back with rosbags: each topic's type and message count, the
    time span, and the plan information judgeopt wrote on /judgeopt/plan_info (when it did)."""
    try:
        from rosbags.highlevel import AnyReader
    except ImportError:
        raise ModuleNotFoundError(f"reading MCAP needs the ros extra: {EXTRA}", name="rosbags") from None
    path = Path(path)
    try:
        with AnyReader([path]) as reader:
            topics = {c.topic: {"type": c.msgtype, "messages": c.msgcount} for c in reader.connections}
            info = None
            for conn, _, raw in reader.messages([c for c in reader.connections if c.topic == TOPICS["info"]]):
                info = json.loads(reader.deserialize(raw, conn.msgtype).data)
                break
            span = (reader.end_time - reader.start_time) / 1e9 if topics else 0.0
    except Exception as exc:  # rosbags' own errors (not MCAP, damaged) as one line
        raise RosExportError(f"{path}: not a readable MCAP file ({type(exc).__name__}: {exc})") from None
    return {"topics": topics, "duration_s": round(span, 6),
            "plan": None if info is None else {k: info.get(k) for k in ("method", "environment", "verdict", "frame",
                                                                        "channels", "step")}}
