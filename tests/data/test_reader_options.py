"""Every reader's every option, against a small file whose content is known by construction: the
value each option should give is worked out by hand (a unit, a sign, a column, an offset after the
scale, a period, a labels file matched by a recording's stem), so a reader that applies an option
in the wrong order, to the wrong field or not at all fails here."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from judgeopt.data.importer import ImportSpec, import_demos
from judgeopt.data.labels import LabelFile
from judgeopt.data.readers.csv import CsvOptions
from judgeopt.data.readers.hdf5 import Hdf5Options, parse_hdf5_keys
from judgeopt.data.readers.lerobot import LeRobotOptions
from judgeopt.data.readers.mcap import McapOptions, parse_topics

ENV = ("y_obj", "mu")
TK = np.arange(31) * 0.05  # the planner's grid: N = 30, dt = 0.05 s


def _inside(duration: float) -> np.ndarray:
    return TK <= duration + 1e-9


# -- CSV ---------------------------------------------------------------------------------------------
def _lab_table(path: Path) -> Path:
    """Two demonstrations in one table, as a lab logs them: time in ms, position in mm, a force
    sensor reading negative while pressing, its own column names, one environment value."""
    rows = ["stamp_ms,pos_mm,fz,outcome,run,obj"]
    for run, (label, obj) in {"A": ("success", 0.21), "B": ("failure", 0.26)}.items():
        for k in range(101):  # 1 s at 100 Hz
            t = k / 100
            rows.append(f"{10 * k},{100 + 50 * t!r},{-(3 + 2 * t)!r},{label},{run},{obj}")
    path.write_text("\n".join(rows) + "\n")
    return path


def test_csv_columns_units_sign_and_the_offset_after_the_scale(tmp_path):
    path = _lab_table(tmp_path / "lab.csv")
    columns = {"t": "stamp_ms", "y": "pos_mm", "f": "fz", "label": "outcome", "demo_id": "run", "y_obj": "obj"}
    spec = ImportSpec(ENV, scale={"t": 1e-3, "y": 1e-3, "f": -1.0}, offset={"y": -0.05}, env_values={"mu": 0.7})
    ds, errors = import_demos([path], spec, {"csv": CsvOptions(columns)})
    assert errors == [] and ds.meta["demo_ids"] == ["lab.csv:A", "lab.csv:B"]
    assert ds.labels.tolist() == [1, 0] and ds.env.tolist() == [[0.21, 0.7], [0.26, 0.7]]
    inside = _inside(1.0)
    for x in ds.responses:
        # y = 1e-3 * (100 + 50 t) - 0.05; an offset added before the scale would give 0.09995 + 0.05 t
        np.testing.assert_allclose(x[inside, 0], 0.05 + 0.05 * TK[inside], atol=1e-9)
        np.testing.assert_allclose(x[inside, 1], 0.05, atol=1e-6)  # derived from y, in m/s
        np.testing.assert_allclose(x[inside, 2], 3 + 2 * TK[inside], atol=1e-9)  # sign turned
        np.testing.assert_allclose(x[~inside, 0], 0.1, atol=1e-9)
    # unmapped, the file's own names are looked for, and the message says which to map, and to which
    # of the header's columns where one is named alike (the mapping above)
    ds, errors = import_demos([path], spec)
    assert ds is None and "missing column(s) ['t', 'y', 'f', 'label', 'y_obj']" in errors[0]
    assert errors[0].endswith("map them with --columns t=stamp_ms,y=pos_mm,f=fz,label=outcome, and for the "
                              "environment: leave it out with --env-names mu, give it with --env y_obj=VALUE or map a "
                              "column with --columns y_obj=COLUMN")


def test_csv_labels_file_by_demo_id_file_name_and_stem(tmp_path):
    path = _lab_table(tmp_path / "lab.csv")
    columns = {"t": "stamp_ms", "y": "pos_mm", "f": "fz", "demo_id": "run"}
    spec = dict(scale={"t": 1e-3, "y": 1e-3, "f": -1.0}, env_values={"y_obj": 0.2, "mu": 0.7})
    options = {"csv": CsvOptions(columns)}
    ds, errors = import_demos([path], ImportSpec(ENV, labels=LabelFile("l", {"A": 0, "B": 1}), **spec), options)
    assert errors == [] and ds.labels.tolist() == [0, 1]  # the outcome column is not read
    ds, errors = import_demos([path], ImportSpec(ENV, labels=LabelFile("l", {"lab.csv:A": 1, "lab": 0}), **spec),
                              options)
    assert errors == [] and ds.labels.tolist() == [1, 0]  # the demo id first, then the file's stem


def _streams(folder: Path, name: str) -> None:
    """One recording as two files: motion capture at 100 Hz, force at 400 Hz on its own clock."""
    t = np.arange(101) / 100
    (folder / f"{name}_mocap.csv").write_text("t,y\n" + "".join(f"{float(ti)!r},{float(0.1 * ti)!r}\n" for ti in t))
    tf = 0.0025 * np.arange(401)
    (folder / f"{name}_ft.csv").write_text("t,f\n" + "".join(f"{float(ti)!r},{float(4 + ti)!r}\n" for ti in tf))


@pytest.mark.parametrize("row", ["run_3.csv", "run_3"])
def test_csv_streams_merge_into_one_recording_labelled_by_its_stem(tmp_path, row):
    _streams(tmp_path, "run_3")
    files = sorted(tmp_path.glob("*.csv"))
    spec = ImportSpec(ENV, labels=LabelFile("labels.csv", {row: 0}), env_values={"y_obj": 0.2, "mu": 0.5})
    ds, errors = import_demos(files, spec, {"csv": CsvOptions(streams=("mocap", "ft"))})
    assert errors == [] and ds.n == 1 and ds.meta["files_imported"] == 1
    assert ds.labels.tolist() == [0] and ds.meta["demo_ids"] == ["run_3:run_3"]
    inside = _inside(1.0)
    np.testing.assert_allclose(ds.responses[0, inside, 0], 0.1 * TK[inside], atol=1e-9)
    np.testing.assert_allclose(ds.responses[0, inside, 2], 4 + TK[inside], atol=1e-9)
    # without --streams each file is a recording of its own, and each lacks a channel
    ds, errors = import_demos(files, spec)
    assert ds is None and [e.split(": ", 1)[1][:23] for e in errors[:2]] == ["missing column(s) ['y']",  # _ft
                                                                              "missing column(s) ['f']"]  # _mocap


# -- HDF5 --------------------------------------------------------------------------------------------
def _robot_h5(path: Path) -> Path:
    """Three demo groups at 50 Hz (period in a `period` attribute of `data`, no time stamps): the
    position in cm in column 1 of obs/eef (T, 3), the force negative in column 2 of obs/ft (T, 6),
    a dense reward, friction in env_args' env_kwargs, the object in an attribute."""
    with h5py.File(path, "w") as h:
        data = h.create_group("data")
        data.attrs["period"] = 0.02
        data.attrs["env_args"] = json.dumps({"env_name": "Scoop", "env_kwargs": {"friction": 0.9}})
        t = np.arange(51) * 0.02
        for k, peak in enumerate((0.8, 0.3, 0.6)):
            g = data.create_group(f"demo_{k}")
            g["obs/eef"] = np.stack([np.full_like(t, 7.0), 20 + 10 * t + k, np.full_like(t, -3.0)], axis=1)
            g["obs/ft"] = np.stack([np.full_like(t, 50.0)] * 2 + [-(6 + 2 * t)] + [np.zeros_like(t)] * 3, axis=1)
            g["rew"] = np.r_[np.linspace(0, peak, 40), np.full(11, peak / 2)]  # the largest is not the last
            g.attrs["object"] = 0.2 + 0.01 * k
        h["mask/train"] = np.array([b"demo_0", b"demo_2"])
    return path


def test_hdf5_keys_columns_period_threshold_filter_and_conversions(tmp_path):
    path = _robot_h5(tmp_path / "robot.hdf5")
    keys = parse_hdf5_keys("y=obs/eef:1,f=obs/ft:-4,success=rew,dt=period,mu=friction,y_obj=object", ENV)
    spec = ImportSpec(ENV, scale={"y": 0.01, "f": -1.0}, offset={"y": -0.2})
    ds, errors = import_demos([path], spec, {"hdf5": Hdf5Options(keys, filter_key="train", success_threshold=0.5)})
    assert errors == [] and ds.meta["demo_ids"] == ["robot.hdf5:demo_0", "robot.hdf5:demo_2"]
    assert ds.labels.tolist() == [1, 1]  # largest rewards 0.8 and 0.6, last ones 0.4 and 0.3
    np.testing.assert_allclose(ds.env, [[0.2, 0.9], [0.22, 0.9]])
    inside = _inside(1.0)
    for x, k in zip(ds.responses, (0, 2)):
        # y = 0.01 * (20 + 10 t + k) - 0.2 on the 50 Hz clock the period gives
        np.testing.assert_allclose(x[inside, 0], 0.1 * TK[inside] + 0.01 * k, atol=1e-9)
        np.testing.assert_allclose(x[inside, 2], 6 + 2 * TK[inside], atol=1e-9)
    ds, _ = import_demos([path], spec, {"hdf5": Hdf5Options(keys, success_threshold=0.7)})
    assert ds.labels.tolist() == [1, 0, 0]  # no filter: every demo group, threshold 0.7
    _, errors = import_demos([path], spec, {"hdf5": Hdf5Options({**keys, "dt": "rate"})})
    assert errors[0].endswith("field 't': no attribute or env_args key 'rate' for the sample period "
                              "(--hdf5-keys dt=...)")


def test_hdf5_missing_environment_value_names_the_three_fixes(tmp_path):
    path = _robot_h5(tmp_path / "robot.hdf5")
    keys = parse_hdf5_keys("y=obs/eef:1,f=obs/ft:2,success=rew,dt=period", ENV)
    ds, errors = import_demos([path], ImportSpec(ENV, scale={"y": 0.01, "f": -1.0}, env_values={"y_obj": 0.2}),
                              {"hdf5": Hdf5Options(keys, success_threshold=0.5)})
    assert ds is None and errors[0].endswith("field 'mu': no environment value 'mu': not an attribute of the demo "
                                             "group, a dataset, a key of env_args or an attribute of 'data'; leave it "
                                             "out with --env-names y_obj, give it with --env mu=VALUE or map one "
                                             "with --hdf5-keys mu=NAME")


def test_an_hdf5_file_of_another_suffix_is_told_by_its_first_bytes(tmp_path):
    path = _robot_h5(tmp_path / "robot.hdf5")
    other = path.rename(tmp_path / "robot.dat")
    keys = parse_hdf5_keys("y=obs/eef:1,f=obs/ft:2,success=rew,dt=period,mu=friction,y_obj=object", ENV)
    ds, errors = import_demos([other], ImportSpec(ENV, scale={"y": 0.01, "f": -1.0}),
                              {"hdf5": Hdf5Options(keys, success_threshold=0.5)})
    assert errors == [] and ds.meta["demo_ids"] == ["robot.dat:demo_0", "robot.dat:demo_1", "robot.dat:demo_2"]


# -- LeRobot -----------------------------------------------------------------------------------------
def _lerobot(root: Path, fps: int = 25) -> Path:
    """Two episodes in one data file, no timestamp column (time from frame_index / fps): y in
    element 1 of a 3-vector, the force in element 2 of the same, a per-frame friction column, a
    dense reward and a success flag that is never set; the object's position is a number in
    meta/info.json."""
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    (root / "meta").mkdir(parents=True)
    (root / "meta" / "info.json").write_text(json.dumps({"codebase_version": "v3.0", "fps": fps, "y_obj": 0.23}))
    cols: dict[str, list] = {k: [] for k in ("observation.state", "frame_index", "episode_index", "next.reward",
                                             "next.success", "env.mu")}
    for e, peak in enumerate((0.9, 0.2)):
        n = fps + 1  # 1 s
        for i in range(n):
            t = i / fps
            cols["observation.state"].append([9.0, 0.1 * t + 0.01 * e, 5.0 + t])
            cols["frame_index"].append(i)
            cols["episode_index"].append(e)
            cols["next.reward"].append(peak if i == n // 2 else peak / 2 if i == n - 1 else 0.0)
            cols["next.success"].append(False)
            cols["env.mu"].append(0.4 + 0.1 * e)
    path = root / "data" / "chunk-000" / "file-000.parquet"
    path.parent.mkdir(parents=True)
    pq.write_table(pa.table({k: pa.array(v) for k, v in cols.items()}), path)
    return root


def test_lerobot_keys_indices_time_from_frames_threshold_and_info_values(tmp_path):
    root = _lerobot(tmp_path / "scoops")
    keys = {"y": "observation.state:-2", "f": "observation.state:2", "mu": "env.mu"}
    spec = ImportSpec(ENV, offset={"y": 0.05})
    ds, errors = import_demos([root], spec, {"lerobot": LeRobotOptions(keys, success_threshold=0.5)})
    assert errors == [] and ds.meta["demo_ids"] == ["scoops:episode_0", "scoops:episode_1"]
    assert ds.labels.tolist() == [1, 0]  # the largest next.reward, mid-episode (not next.success)
    np.testing.assert_allclose(ds.env, [[0.23, 0.4], [0.23, 0.5]])  # y_obj from info.json
    inside = _inside(1.0)
    for e, x in enumerate(ds.responses):
        np.testing.assert_allclose(x[inside, 0], 0.05 + 0.1 * TK[inside] + 0.01 * e, atol=1e-6)  # 25 frames a second
        np.testing.assert_allclose(x[inside, 2], 5 + TK[inside], atol=1e-6)
    ds, _ = import_demos([root], spec, {"lerobot": LeRobotOptions(keys)})
    assert ds.labels.tolist() == [0, 0]  # no threshold: next.success
    keys["success"] = "next.reward"
    _, errors = import_demos([root], spec, {"lerobot": LeRobotOptions(keys)})  # a dense reward is no label
    assert errors[0].endswith("episode 0, field 'success' (next.reward): last value 0.45 is neither 1 (success) nor "
                              "0 (failure); for dense rewards pass --success-threshold X")


# -- ROS 2 bags ---------------------------------------------------------------------------------------
def _bag(path: Path) -> Path:
    """One demonstration: pose at 100 Hz (x = 0.05 + 0.1 t, y = 9: the other axis), wrench at 400 Hz
    (force y = 7 - t, z = 99), friction on a topic; header stamps from an epoch."""
    pytest.importorskip("rosbags")
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.LATEST)
    T = ts.types
    epoch = 1_700_000_000_000_000_000

    def header(ns: int):
        return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                                        frame_id="base")

    def pose(ns: int, t: float):
        p = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=0.05 + 0.1 * t, y=9.0, z=0.0),
                                        orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0))
        return T["geometry_msgs/msg/PoseStamped"](header=header(ns), pose=p)

    def wrench(ns: int, t: float):
        v = T["geometry_msgs/msg/Vector3"]
        return T["geometry_msgs/msg/WrenchStamped"](header=header(ns), wrench=T["geometry_msgs/msg/Wrench"](
            force=v(x=0.0, y=7.0 - t, z=99.0), torque=v(x=0.0, y=0.0, z=0.0)))

    messages = []
    for topic, hz, make in (("/tool", 100, pose), ("/ft", 400, wrench)):
        for k in range(hz + 1):
            ns = epoch + k * 10**9 // hz
            messages.append((ns + 1000, topic, make(ns, k / hz)))
    messages.append((epoch + 5 * 10**8, "/env/mu", T["std_msgs/msg/Float64"](data=0.8)))
    from test_ros2 import write_bag

    return write_bag(path, messages)


def test_bag_topics_axes_environment_topic_and_labels_by_bag_name(tmp_path):
    bag = _bag(tmp_path / "take_7")
    topics = parse_topics("y=/tool:x,f=/ft:y,mu=/env/mu", ENV, ("y", "f"))
    spec = ImportSpec(ENV, labels=LabelFile("labels.csv", {"take_7": 1}), env_values={"y_obj": 0.2},
                      offset={"y": -0.05})
    ds, errors = import_demos([bag], spec, {"mcap": McapOptions(topics)})
    assert errors == [] and ds.meta["demo_ids"] == ["take_7"] and ds.labels.tolist() == [1]
    assert ds.env.tolist() == [[0.2, 0.8]]
    inside = _inside(1.0)
    x = ds.responses[0]
    np.testing.assert_allclose(x[inside, 0], 0.1 * TK[inside], atol=1e-9)  # pose.position.x, less the offset
    np.testing.assert_allclose(x[inside, 2], 7 - TK[inside], atol=1e-9)  # wrench.force.y on its own clock
    other = parse_topics("y=/tool:y,f=/ft:y,mu=/env/mu", ENV, ("y", "f"))
    _, errors = import_demos([bag], spec, {"mcap": McapOptions(other)})
    assert "field 'y' (pose.position.y): 8.95 is beyond 5" in errors[0]  # the other axis, with the offset
