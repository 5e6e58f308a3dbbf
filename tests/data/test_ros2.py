"""ROS 2 bags in: small MCAP bags written here with rosbags' own writer and serializer, values known by construction."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rosbags")

from rosbags.rosbag2 import StoragePlugin, Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from judgeopt.cli import main  # noqa: E402
from judgeopt.data.dataset import load  # noqa: E402
from judgeopt.data.importer import ImportSpec, import_demos  # noqa: E402
from judgeopt.data.labels import LabelFile  # noqa: E402
from judgeopt.data.recording import ImportError_  # noqa: E402
from judgeopt.data.readers.mcap import McapOptions, is_bag, parse_topics  # noqa: E402

TS = get_typestore(Stores.LATEST)
T = TS.types
EPOCH = 1_700_000_000_000_000_000  # header stamps in ns since the epoch, as a robot's clock gives them
POSE_HZ, WRENCH_HZ = 120, 1000
DURATION = 1.2  # inside the horizon N·dt = 1.5 s
TOPICS = "y=/tool/pose:y,f=/ft/wrench:z,label=/outcome"
ENV = {"y_obj": 0.2, "mu": 0.5}


def _stamp(ns: int):
    return T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)


def _header(ns: int):
    return T["std_msgs/msg/Header"](stamp=_stamp(ns), frame_id="base")


def _pose(ns: int, y: float):
    pose = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=0.3, y=y, z=0.7),
                                       orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))
    return T["geometry_msgs/msg/PoseStamped"](header=_header(ns), pose=pose)


def _wrench(ns: int, fz: float):
    v = T["geometry_msgs/msg/Vector3"]
    return T["geometry_msgs/msg/WrenchStamped"](header=_header(ns), wrench=T["geometry_msgs/msg/Wrench"](
        force=v(x=1.0, y=2.0, z=fz), torque=v(x=0.0, y=0.0, z=0.0)))


def _episode(start: float, y0: float = 0.0, force=lambda t: 5.0 + 0 * t, label: bool | None = True,
             stamps: bool = True) -> list[tuple[float, str, object]]:
    """One demonstration from `start` s: y = y0 + 0.1 t at 120 Hz, f = force(t) at 1 kHz (and 2 N
    on x, 0.7 m on z: the other axes), then its label. (log time, topic, message); the log time
    lags the header stamp by 2 to 2.4 ms, as a recorder receives messages after they are stamped
    (in order: one topic is one FIFO stream)."""
    rng = np.random.default_rng(int(start * 10))
    out = []
    for topic, hz, make in (("/tool/pose", POSE_HZ, lambda ns, t: _pose(ns, y0 + 0.1 * t)),
                            ("/ft/wrench", WRENCH_HZ, lambda ns, t: _wrench(ns, force(t)))):
        for k in range(int(round(DURATION * hz)) + 1):
            t = k / hz
            ns = EPOCH + int(round((start + t) * 1e9))
            lag = int(rng.uniform(2e6, 2.4e6)) if stamps else 0
            out.append((ns + lag, topic, make(ns if stamps else 0, t)))
    if label is not None:
        out.append((EPOCH + int((start + DURATION + 0.01) * 1e9), "/outcome", T["std_msgs/msg/Bool"](data=label)))
    return out


def write_bag(path: Path, messages: list[tuple[int, str, object]]) -> Path:
    """A rosbag2 folder (metadata.yaml + .mcap) holding `messages` in log-time order."""
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {}
        for log, topic, msg in sorted(messages, key=lambda m: m[0]):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msg.__msgtype__, typestore=TS)
            w.write(conns[topic], log, TS.serialize_cdr(msg, msg.__msgtype__))
    return path


def _import(paths: list[Path], topics: str = TOPICS, **kw):
    kw.setdefault("env_values", ENV)
    options = McapOptions(parse_topics(topics, ("y_obj", "mu"), ("y", "f")))
    return import_demos(paths, ImportSpec(("y_obj", "mu"), **kw), {"mcap": options})


def _check_ramp(x: np.ndarray, y0: float = 0.0, force=lambda t: 5.0 + 0 * t) -> None:
    tk = np.arange(31) * 0.05
    inside = tk <= DURATION + 1e-9
    np.testing.assert_allclose(x[inside, 0], y0 + 0.1 * tk[inside], atol=1e-6)  # y at sample k: 0.1·k·dt
    np.testing.assert_allclose(x[inside, 1], 0.1, atol=1e-4)  # ydot derived from y
    np.testing.assert_allclose(x[inside, 2], force(tk[inside]), atol=1e-6)
    np.testing.assert_allclose(x[~inside, 0], y0 + 0.1 * DURATION, atol=1e-6)  # held at rest after the end


def test_a_bag_folder_and_a_bare_mcap_file_give_the_recorded_values(tmp_path):
    bag = write_bag(tmp_path / "run1", _episode(0.0))
    mcap = next(bag.glob("*.mcap"))
    bare = shutil.copy(mcap, tmp_path / "run2.mcap")
    assert is_bag(bag) and is_bag(Path(bare)) and not is_bag(tmp_path)
    ds, errors = _import([bag, bare])
    assert errors == [] and ds.meta["demo_ids"] == ["run1", "run2"] and ds.labels.tolist() == [1, 1]
    np.testing.assert_allclose(ds.env, [[0.2, 0.5], [0.2, 0.5]])
    for x in ds.responses:
        _check_ramp(x)


def test_zero_header_stamps_fall_back_to_the_log_time(tmp_path):
    force = lambda t: 5.0 + 2.0 * t  # noqa: E731  a ramp: checks the force's own time base too
    bag = write_bag(tmp_path / "nostamp", _episode(0.0, force=force, stamps=False))
    ds, errors = _import([bag])
    assert errors == []
    _check_ramp(ds.responses[0], force=force)


def test_an_episode_topic_cuts_a_bag_into_demonstrations(tmp_path):
    messages = []
    for k, label in enumerate((True, False, True)):
        start = 2.0 * k
        messages.append((EPOCH + int((start - 0.05) * 1e9), "/episode", T["std_msgs/msg/Int32"](data=k)))
        messages += _episode(start, y0=0.01 * k, label=label)
    bag = write_bag(tmp_path / "session", messages)
    ds, errors = _import([bag], TOPICS + ",episode=/episode")
    assert errors == [] and ds.meta["demo_ids"] == ["session:0", "session:1", "session:2"]
    assert ds.labels.tolist() == [1, 0, 1]
    for k, x in enumerate(ds.responses):
        _check_ramp(x, y0=0.01 * k)
    # a labels file wins over the label topic, looked up by <bag>:<episode>
    labels = LabelFile("labels.csv", {"session:0": 0, "session:1": 1, "session:2": 0})
    ds, errors = _import([bag], "y=/tool/pose:y,f=/ft/wrench:z,episode=/episode", labels=labels)
    assert errors == [] and ds.labels.tolist() == [0, 1, 0]


def test_environment_values_from_topics_and_the_missing_label(tmp_path):
    messages = _episode(0.0, label=None) + [
        (EPOCH + k * 10**8, f"/env/{n}", T["std_msgs/msg/Float64"](data=v)) for k in range(3) for n, v in ENV.items()]
    bag = write_bag(tmp_path / "env", messages)
    ds, errors = _import([bag], TOPICS + ",y_obj=/env/y_obj,mu=/env/mu", env_values={})
    assert ds is None and errors == [  # this bag has no label topic
        f"{bag}: no topic '/outcome' (for 'label'); the bag has /env/mu (std_msgs/msg/Float64), "
                      "/env/y_obj (std_msgs/msg/Float64), /ft/wrench (geometry_msgs/msg/WrenchStamped), /tool/pose "
                      "(geometry_msgs/msg/PoseStamped); name another with --topics label=TOPIC"]
    ds, errors = _import([bag], "y=/tool/pose:y,f=/ft/wrench:z,y_obj=/env/y_obj,mu=/env/mu", env_values={})
    assert ds is None and errors == [f"{bag}: the bag has no label (a bag does not carry one); give a labels file "
                                     "with --labels FILE (a row 'env',success or failure) or name a topic with "
                                     "--topics label=TOPIC (std_msgs/msg/Bool or std_msgs/msg/String)"]
    ds, errors = _import([bag], "y=/tool/pose:y,f=/ft/wrench:z,y_obj=/env/y_obj,mu=/env/mu",
                         env_values={}, labels=LabelFile("l.csv", {"env": 1}))
    assert errors == [] and ds.env.tolist() == [[0.2, 0.5]] and ds.labels.tolist() == [1]
    _, errors = _import([bag], "y=/tool/pose:y,f=/ft/wrench:z", env_values={"mu": 0.5},
                        labels=LabelFile("l.csv", {"env": 1}))
    assert errors == [f"{bag}: no value for environment name 'y_obj' (a bag does not carry it); leave it out with "
                      "--env-names mu, give it with --env y_obj=VALUE or name a topic with --topics y_obj=TOPIC "
                      "(std_msgs/msg/Float64 or std_msgs/msg/Float32)"]


def test_bad_bags_are_named_and_the_rest_imported(tmp_path):
    good = write_bag(tmp_path / "good", _episode(0.0))
    no_wrench = write_bag(tmp_path / "no_wrench", [m for m in _episode(0.0) if m[1] != "/ft/wrench"])
    wrong = write_bag(tmp_path / "wrong", [m for m in _episode(0.0) if m[1] != "/ft/wrench"]
                      + [(EPOCH + k * 10**6, "/ft/wrench", T["std_msgs/msg/Float64"](data=5.0)) for k in range(10)])
    junk = tmp_path / "junk.mcap"
    junk.write_text("not an mcap file")
    ds, errors = _import([good, no_wrench, wrong, junk])
    assert ds.meta["demo_ids"] == ["good"] and ds.meta["files_imported"] == 1
    assert errors == [
        f"{no_wrench}: no topic '/ft/wrench' (for 'f'); the bag has /outcome (std_msgs/msg/Bool), /tool/pose "
        "(geometry_msgs/msg/PoseStamped); name another with --topics f=TOPIC:AXIS",
        f"{wrong}: topic '/ft/wrench' (for 'f') holds std_msgs/msg/Float64, not geometry_msgs/msg/WrenchStamped; "
        "name another with --topics f=TOPIC:AXIS",
        f"{junk}: not a readable ROS 2 bag (File magic is invalid.); give a rosbag2 folder (metadata.yaml + .mcap) or "
        "a .mcap file; repair a cut-off one with `mcap recover`"]
    _, errors = _import([good], "f=/ft/wrench:z,label=/outcome")
    assert errors[0].startswith(f"{good}: no topic named for 'y'; the bag has /ft/wrench (")
    assert errors[0].endswith("name one with --topics y=TOPIC:AXIS")


def test_topics_flag_syntax():
    assert parse_topics("y=tool/pose:y, f=/ft/wrench:z,episode=/ep,label=/ok,mu=/env/mu", ("mu",)) == {
        "y": "/tool/pose:y", "f": "/ft/wrench:z", "episode": "/ep", "label": "/ok", "mu": "/env/mu"}
    for text, message in (("y=/tool/pose", "'y=/tool/pose': no axis; AXIS is one of x, y, z"),
                          ("y=/tool/pose:w", "axis 'w' is not one of x, y, z"),
                          ("episode=/ep:x", "'episode' takes a topic alone, no axis"),
                          ("speed=/s:x", "unknown name 'speed'"),
                          ("y=/a:x,y=/b:y", "'y' is mapped twice"),
                          ("y", "'y' is not NAME=TOPIC:AXIS or NAME=TOPIC")):
        with pytest.raises(ImportError_, match="^--topics: .*" + __import__("re").escape(message)):
            parse_topics(text)


def test_without_rosbags_one_line_says_what_to_install(tmp_path, monkeypatch):
    bag = write_bag(tmp_path / "b", _episode(0.0))
    monkeypatch.setitem(sys.modules, "rosbags.rosbag2", None)
    ds, errors = _import([bag])
    assert ds is None and errors == ["reading a ROS 2 bag needs rosbags: pip install 'judgeopt[ros]' "
                                     "(or pip install rosbags)"]


def test_the_command_reads_a_folder_of_bags(tmp_path, capsys):
    recordings = tmp_path / "recordings"
    recordings.mkdir()
    write_bag(recordings / "run1", _episode(0.0))
    shutil.copy(next((recordings / "run1").glob("*.mcap")), recordings / "run2.mcap")
    (recordings / "notes.txt").write_text("not a recording")
    rc = main(["import-demos", str(recordings), "--topics", TOPICS, "--env", "y_obj=0.2,mu=0.5",
               "--out", str(tmp_path / "o.h5")])
    captured = capsys.readouterr()
    assert rc == 0 and "2 demonstrations from 2 of 2" in captured.out, captured
    ds = load(tmp_path / "o.h5")
    assert ds.n == 2 and "run2" in str(ds.meta["demo_ids"])
    _check_ramp(ds.responses[1])
    csv = tmp_path / "a.csv"
    csv.write_text("t,y,f,label,y_obj,mu\n0,0,5,success,0.2,0.5\n0.1,0.01,5,success,0.2,0.5\n")
    assert main(["import-demos", str(csv), "--topics", TOPICS, "--out", str(tmp_path / "p.h5")]) == 2
    assert "--topics names the topics of ROS 2 bags; no ROS 2 bag (a folder with metadata.yaml, or a .mcap file) is " \
           "given (for the inputs given: --columns)" in capsys.readouterr().err
