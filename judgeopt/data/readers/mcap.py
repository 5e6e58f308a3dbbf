"""ROS 2 bags (rosbag2 with MCAP storage, what `ros2 bag record -s mcap` writes) read as recordings.

One job: a bag -> `RawDemo`s, so the checks, windows and resampling are the other formats'.
Read with `rosbags` (the optional extra `judgeopt[ros]`), not with a ROS installation. A bag is
a rosbag2 folder (metadata.yaml and its .mcap files; rosbags reads a sqlite3 .db3 folder the
same way) or a bare `.mcap` file (rosbags reads its own summary; no metadata.yaml needed).

Which topic holds what (`McapOptions.topics`, the command's `--topics`):

    NAME=TOPIC:AXIS  each position and force channel of the task, AXIS one of x, y, z: a
                     position is pose.position.AXIS of a geometry_msgs/msg/PoseStamped topic,
                     a force wrench.force.AXIS of a geometry_msgs/msg/WrenchStamped topic
                     (velocities are derived from their positions)
    episode=TOPIC    optional: each message (std_msgs/msg/Int32 or String; its content is not
                     read) starts an episode at its log time, so one bag holds several
                     demonstrations; what comes before the first one is dropped. Without it the
                     bag is one demonstration
    label=TOPIC      optional: std_msgs/msg/Bool (true: success) or String (success/failure,
                     1/0, true/false); the last message of each episode is its label
    <env>=TOPIC      optional: std_msgs/msg/Float64 or Float32 for an environment value (it must
                     not change within a demonstration)

e.g. `y=/tool/pose:y,f=/ft/wrench:z,episode=/episode,label=/outcome`. A bag carries no label
or environment value of its own: a labels file (`--labels`, `ImportSpec.labels`) wins over the
label topic and is looked up by demo id, `<bag name>` or, for a bag cut into episodes,
`<bag name>:<episode index>` (the name is the folder's, or the file's without .mcap); `--env
NAME=VALUE` (`ImportSpec.env_values`) wins over an environment topic.

Time is each message's header stamp. Only when every header stamp of a channel's topic is zero
(a publisher that never sets it) is the bag's log time (when the recorder received the message)
used instead, and then for every channel, so all share one clock. Episodes are cut by log time.
Streams keep their own rates (pose 120 Hz, wrench 1 kHz): the first position channel's topic
gives `series["t"]`, every other channel its own times (`RawDemo.times`, same origin), and
`check` resamples each from its own stamps.

Messages name the bag, the topic, the message (0-based, in that topic's order in the bag) and
the field; a bad episode is reported and the others imported; a bad bag is skipped whole.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from judgeopt.data.readers.base import Flag, Reader, Source
from judgeopt.data.recording import LABELS, ImportError_, ImportSpec, RawDemo, env_fix, mapped_items

POSE = "geometry_msgs/msg/PoseStamped"
WRENCH = "geometry_msgs/msg/WrenchStamped"
#: per channel kind: the message type it is read from and the field holding the axes
FIELDS = {"position": (POSE, "pose.position"), "force": (WRENCH, "wrench.force")}
AXES = ("x", "y", "z")
EPISODE_TYPES = ("std_msgs/msg/Int32", "std_msgs/msg/String")
LABEL_TYPES = ("std_msgs/msg/Bool", "std_msgs/msg/String")
ENV_TYPES = ("std_msgs/msg/Float64", "std_msgs/msg/Float32")
FLAG = "--topics"
#: a recording cut off by a crash lacks the MCAP summary rosbags needs
REPAIR_HINT = "give a rosbag2 folder (metadata.yaml + .mcap) or a .mcap file; repair a cut-off one with `mcap recover`"

_TOPIC = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*([^:,\s]+)\s*(?::\s*([^:,\s]*)\s*)?$")


# -- which inputs are bags, and the --topics flag ---------------------------------------------------
@dataclass(frozen=True)
class McapOptions:
    #: name -> "TOPIC:AXIS" (channels) or "TOPIC" (episode, label, environment) (`--topics`)
    topics: Mapping[str, str] = field(default_factory=dict)


def is_bag(path: Path) -> bool:
    """A rosbag2 folder (metadata.yaml) or an .mcap file."""
    path = Path(path)
    if path.is_dir():
        return (path / "metadata.yaml").is_file()
    return path.suffix.lower() == ".mcap"


def parse_topics(text: str | None, env_names: Sequence[str] = (),
                 channels: Sequence[str] = ("y", "f")) -> dict[str, str]:
    """`y=/tool/pose:y,f=/ft/wrench:z,episode=/episode` -> {"y": "/tool/pose:y", ...}, checked.
    `channels` (the task's positions and forces) take TOPIC:AXIS; episode, label and the
    environment names take a topic alone. Topics are made absolute, as a bag names them."""
    out: dict[str, str] = {}
    allowed = (*channels, "episode", "label", *env_names)
    for name, topic, axis, item in mapped_items(text, _TOPIC, FLAG, "NAME=TOPIC:AXIS or NAME=TOPIC", allowed):
        if name in channels and axis not in AXES:
            got = f"axis {axis!r} is not" if axis else "no axis; AXIS is"
            raise ImportError_(f"{FLAG}: {item!r}: {got} one of {', '.join(AXES)} ({name}=TOPIC:AXIS)")
        if name not in channels and axis is not None:
            raise ImportError_(f"{FLAG}: {item!r}: {name!r} takes a topic alone, no axis ({name}=TOPIC)")
        out[name] = "/" + topic.strip("/") + (f":{axis}" if axis else "")
    return out


# -- reading a bag ----------------------------------------------------------------------------------
def _rosbags() -> tuple[Any, tuple[type[Exception], ...], Any]:
    """rosbags' Reader, the errors it raises on a bad file, and a typestore of the standard ROS 2
    messages (PoseStamped, WrenchStamped and std_msgs are the same in every distribution, so the
    bag's own definitions are not needed), imported only when a bag is read."""
    try:
        from rosbags.rosbag2 import Reader, ReaderError
        from rosbags.serde import SerdeError
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise ImportError_("reading a ROS 2 bag needs rosbags: pip install 'judgeopt[ros]' (or pip install rosbags)") \
            from None
    return Reader, (ReaderError, SerdeError, OSError, struct.error, IndexError, KeyError), get_typestore(Stores.LATEST)


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _listing(types: Mapping[str, str | None]) -> str:
    return ", ".join(f"{t} ({types[t]})" for t in sorted(types)) or "no topics"


@dataclass
class _Topic:
    """Every message of one topic: log and header times (ns) and the decoded messages."""

    name: str
    log: np.ndarray
    stamp: np.ndarray
    msgs: list[Any]


def _wanted(path: Path, spec: ImportSpec, topics: Mapping[str, str], types: Mapping[str, str | None]) -> set[str]:
    """The topics to read, checked against the bag: there, and of a message type allowed for their use."""
    need: dict[str, tuple[str, tuple[str, ...]]] = {}  # name -> (topic, allowed types)
    for c in spec.channels:
        if c.kind in FIELDS:
            if c.name not in topics:
                raise ImportError_(f"{path}: no topic named for {c.name!r}; the bag has {_listing(types)}; name one "
                                   f"with {FLAG} {_syntax(spec, c.name)}")
            need[c.name] = (topics[c.name].split(":")[0], (FIELDS[c.kind][0],))
    extra = {"episode": EPISODE_TYPES, "label": LABEL_TYPES, **{n: ENV_TYPES for n in spec.env_names}}
    need.update({n: (topics[n], allowed) for n, allowed in extra.items() if n in topics})
    for name, (topic, allowed) in need.items():
        if topic not in types:
            raise ImportError_(f"{path}: no topic {topic!r} (for {name!r}); the bag has {_listing(types)}; name "
                               f"another with {FLAG} {_syntax(spec, name)}")
        if types[topic] not in allowed:
            raise ImportError_(f"{path}: topic {topic!r} (for {name!r}) holds {types[topic]}, not "
                               f"{' or '.join(allowed)}; name another with {FLAG} {_syntax(spec, name)}")
    return {topic for topic, _ in need.values()}


def _syntax(spec: ImportSpec, name: str) -> str:
    return f"{name}=TOPIC:AXIS" if name in spec.names("position", "force") else f"{name}=TOPIC"


def _stamp(msg: Any) -> int:
    header = getattr(msg, "header", None)
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec) if header is not None else 0


def read_bag(path: Path, spec: ImportSpec, topics: Mapping[str, str]) -> dict[str, _Topic]:
    """The messages of every topic `topics` (`McapOptions.topics`) names, decoded; raises
    ImportError_ for an unreadable bag or a missing or mistyped topic."""
    Reader, errors, typestore = _rosbags()
    got: dict[str, tuple[list[int], list[Any]]] = {}
    try:
        with Reader(path) as reader:
            types = {t: info.msgtype for t, info in reader.topics.items()}
            wanted = _wanted(path, spec, topics, types)
            connections = [c for c in reader.connections if c.topic in wanted]
            for con, log, raw in reader.messages(connections):
                logs, msgs = got.setdefault(con.topic, ([], []))
                logs.append(log)
                msgs.append(typestore.deserialize_cdr(raw, con.msgtype))
    except ImportError_:
        raise
    except (*errors, ValueError) as exc:
        raise ImportError_(f"{path}: not a readable ROS 2 bag ({_one_line(exc)}); {REPAIR_HINT}") from None
    out = {}
    for topic in wanted:
        logs, msgs = got.get(topic, ([], []))
        order = np.argsort(np.array(logs, dtype=np.int64), kind="stable")
        msgs = [msgs[i] for i in order]
        out[topic] = _Topic(topic, np.array(logs, dtype=np.int64)[order],
                            np.array([_stamp(m) for m in msgs], dtype=np.int64), msgs)
    return out


# -- bag -> demonstrations --------------------------------------------------------------------------
def bag_name(path: Path) -> str:
    """What a labels file and the demo ids call a bag: its folder's name, or its file's without .mcap."""
    return path.name if path.is_dir() else path.stem


def _spans(path: Path, names: Mapping[str, str], topics: dict[str, _Topic]) -> list[tuple[int, int]]:
    """Log-time spans [from, to) of the episodes: one per message on the episode topic, or the whole bag."""
    end = int(np.iinfo(np.int64).max)
    if "episode" not in names:
        return [(int(np.iinfo(np.int64).min), end)]
    marks = topics[names["episode"]].log.tolist()
    if not marks:
        raise ImportError_(f"{path}: episode topic {names['episode']!r} has no messages; leave out "
                           f"episode= from {FLAG} to import the bag as one demonstration")
    return list(zip(marks, [*marks[1:], end]))


def _label(value: Any, where: str) -> int:
    """A Bool or String label message's value as 1 or 0."""
    if isinstance(value, (bool, np.bool_)):
        return int(value)
    text = str(value).strip().lower()
    if text not in LABELS:
        raise ImportError_(f"{where}: {value!r} is not success/failure (also 1/0, true/false)")
    return LABELS[text]


@dataclass
class _Bag:
    """One bag being cut into demonstrations: its topics and the clock they are read on."""

    path: Path
    spec: ImportSpec
    #: name -> "TOPIC[:AXIS]" (`McapOptions.topics`)
    names: Mapping[str, str]
    topics: dict[str, _Topic]
    use_log: bool

    def topic(self, name: str) -> _Topic:
        return self.topics[self.names[name].split(":")[0]]

    def times(self, tp: _Topic, rows: np.ndarray) -> np.ndarray:
        return (tp.log if self.use_log else tp.stamp)[rows]

    def field(self, name: str) -> str:
        kind = next(c.kind for c in self.spec.channels if c.name == name)
        return f"{FIELDS[kind][1]}.{self.names[name].split(':')[1]}"

    def values(self, name: str, rows: np.ndarray) -> np.ndarray:
        outer, inner, axis = self.field(name).split(".")
        msgs = self.topic(name).msgs
        return np.array([getattr(getattr(getattr(msgs[i], outer), inner), axis) for i in rows], dtype=np.float64)


def _episode(bag: _Bag, k: int | None, span: tuple[int, int]) -> RawDemo:
    """One episode (or the whole bag, k None) as a RawDemo: the first position's topic sets
    series["t"]; every other channel keeps its own times (`RawDemo.times`), same origin."""
    path, spec = bag.path, bag.spec
    what = "the bag" if k is None else f"episode {k}"
    rows = {tp.name: np.flatnonzero((tp.log >= span[0]) & (tp.log < span[1])) for tp in bag.topics.values()}
    channels = spec.names("position", "force")
    for name in channels:
        if not len(rows[bag.topic(name).name]):
            raise ImportError_(f"{path}: {what} has no messages on {bag.topic(name).name!r} (for {name!r})")
    base = bag.topic(channels[0])
    t0 = int(bag.times(base, rows[base.name])[0])  # int ns: epoch stamps keep their precision
    series = {"t": (bag.times(base, rows[base.name]) - t0) / 1e9}
    times = {}
    for name in channels:
        tp = bag.topic(name)
        series[name] = bag.values(name, rows[tp.name])
        if tp is not base:
            times[name] = (bag.times(tp, rows[tp.name]) - t0) / 1e9
    env = {n: _env(bag, n, rows, what) for n in spec.env_names if n not in spec.env_values}
    clock = "log time" if bag.use_log else "header stamp"

    def where(c: str, i: int) -> str:
        if c in spec.env_names:
            tp = bag.topic(c)
            return f"{path}, topic {tp.name!r}, message {rows[tp.name][i]}, field {c!r} (data)"
        tp = base if c == "t" else bag.topic(c)
        return f"{path}, topic {tp.name!r}, message {rows[tp.name][i]}, field {c!r} " \
               f"({clock if c == 't' else bag.field(c)})"

    demo_id = bag_name(path) if k is None else f"{bag_name(path)}:{k}"
    return RawDemo(str(path), what, demo_id, series, env, _demo_label(bag, rows, what, demo_id), where, times=times)


def _env(bag: _Bag, name: str, rows: dict[str, np.ndarray], what: str) -> np.ndarray:
    """An environment value from its topic: every message in the episode (`check` wants them equal)."""
    if name not in bag.names:
        raise ImportError_(f"{bag.path}: no value for environment name {name!r} (a bag does not carry it); "
                           + env_fix(bag.spec, [name], f"name a topic with {FLAG} {name}=TOPIC "
                                                       f"({' or '.join(ENV_TYPES)})"))
    tp = bag.topic(name)
    if not len(rows[tp.name]):
        raise ImportError_(f"{bag.path}: {what} has no messages on {tp.name!r} (for {name!r})")
    return np.array([float(tp.msgs[i].data) for i in rows[tp.name]])


def _demo_label(bag: _Bag, rows: dict[str, np.ndarray], what: str, demo_id: str) -> int | None:
    """The last message on the label topic in the episode; None when a labels file gives the
    labels (`check` looks them up by the demo id `<bag>` or `<bag>:<episode>`, or the bag's name)."""
    if bag.spec.labels is not None:
        return None
    if "label" not in bag.names:
        raise ImportError_(f"{bag.path}: {what} has no label (a bag does not carry one); give a labels file with "
                           f"--labels FILE (a row {demo_id!r},success or failure) or name a topic with {FLAG} "
                           f"label=TOPIC ({' or '.join(LABEL_TYPES)})")
    tp = bag.topic("label")
    if not len(rows[tp.name]):
        raise ImportError_(f"{bag.path}: {what} has no message on the label topic {tp.name!r}")
    i = int(rows[tp.name][-1])
    return _label(tp.msgs[i].data, f"{bag.path}, topic {tp.name!r}, message {i}, field 'label'")


def read(source: Source, spec: ImportSpec, options: McapOptions) -> tuple[list[RawDemo], list[str]]:
    """Every demonstration of one bag as a RawDemo (values not yet checked), and one message per
    episode that could not be cut out. Raises ImportError_ when the bag as a whole cannot be
    read (no rosbags, unreadable, topics missing or of the wrong type)."""
    path, names = source.path, options.topics
    topics = read_bag(path, spec, names)
    stamps = [topics[names[n].split(":")[0]].stamp for n in spec.names("position", "force")]
    bag = _Bag(path, spec, names, topics, use_log=not all(s.any() for s in stamps))
    episodes = "episode" in names
    raws, errors = [], []
    for k, span in enumerate(_spans(path, names, topics)):
        try:
            raws.append(_episode(bag, k if episodes else None, span))
        except ImportError_ as exc:
            errors.append(str(exc))
    return raws, errors


READER = Reader(
    "mcap", "ROS 2 bags (MCAP)", "ROS 2 bag (a folder with metadata.yaml, or a .mcap file)", read, McapOptions,
    suffixes=(".mcap",), folder=is_bag, flags=(
        Flag("--topics", "topics", metavar="NAME=TOPIC[:AXIS],...", kind="map", does="names the topics of ROS 2 bags",
             parse=lambda text, spec: parse_topics(text, spec.env_names, spec.names("position", "force")),
             help="which topics of a ROS 2 bag hold a channel (NAME=TOPIC:AXIS, AXIS x, y or z: a position of a "
             "geometry_msgs/msg/PoseStamped, a force of a WrenchStamped), the start of each episode (episode=TOPIC, "
             "std_msgs Int32 or String; default: one bag, one demonstration), the label (label=TOPIC, std_msgs Bool "
             "or String) or an environment value (NAME=TOPIC, std_msgs Float64), e.g. "
             "'y=/tool/pose:y,f=/ft/wrench:z,episode=/episode'"),
    ))
