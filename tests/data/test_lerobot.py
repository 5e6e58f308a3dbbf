"""LeRobot v3.0 datasets in: a small dataset written here in exactly lerobot-record's layout."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")

from judgeopt.cli import main  # noqa: E402
from judgeopt.data.dataset import load  # noqa: E402
from judgeopt.data.importer import ImportSpec, import_demos  # noqa: E402
from judgeopt.data.readers.lerobot import LeRobotOptions, parse_lerobot_keys  # noqa: E402
from judgeopt.data.recording import ImportError_, parse_keys  # noqa: E402

FPS = 20
FRAMES = 25  # 1.2 s, inside the horizon N·dt = 1.5 s
KEYS = "y=observation.state:1,ydot=observation.state:2,f=observation.force:2,mu=env.mu"


def _y(e: int, t: np.ndarray) -> np.ndarray:
    return 0.01 * e + 0.1 * t


def _episode_rows(e: int, start_index: int) -> dict[str, list]:
    t = np.arange(FRAMES) / FPS
    y = _y(e, t)
    return {
        "observation.state": [[0.3, yi, 0.1] for yi in y],
        "observation.force": [[0.0, 0.0, 5.0 + e] for _ in t],
        "action": [[0.0, yi] for yi in y],
        "timestamp": t.astype(np.float32).tolist(),
        "frame_index": list(range(FRAMES)),
        "episode_index": [e] * FRAMES,
        "index": list(range(start_index, start_index + FRAMES)),
        "task_index": [0] * FRAMES,
        "next.reward": [0.0] * (FRAMES - 1) + [0.9 if e % 2 == 0 else 0.2],
        "next.done": [False] * (FRAMES - 1) + [True],
        "next.success": [False] * (FRAMES - 1) + [e % 2 == 0],
        "env.mu": [0.4 + 0.1 * e] * FRAMES,
    }


def _table(episodes: list[int], fixed: bool) -> "pa.Table":
    cols: dict[str, list] = {}
    for e in episodes:
        for k, v in _episode_rows(e, e * FRAMES).items():
            cols.setdefault(k, []).extend(v)
    state_type = pa.list_(pa.float32(), 3) if fixed else pa.list_(pa.float32())  # datasets writes either
    types = {"observation.state": state_type, "observation.force": state_type, "action": pa.list_(pa.float32(), 2),
             "timestamp": pa.float32(), "frame_index": pa.int64(), "episode_index": pa.int64(), "index": pa.int64(),
             "task_index": pa.int64(), "next.reward": pa.float32(), "next.done": pa.bool_(),
             "next.success": pa.bool_(), "env.mu": pa.float32()}
    return pa.table({k: pa.array(v, type=types[k]) for k, v in cols.items()})


def write_dataset(root: Path, version: str = "v3.0", bad_episode: int | None = 2) -> Path:
    """Four episodes in two data files (chunk-000/file-000: 0, 1; chunk-001/file-000: 2, 3)."""
    info = {"codebase_version": version, "robot_type": "ur5", "total_episodes": 4, "total_frames": 4 * FRAMES,
            "fps": FPS, "chunks_size": 1000, "data_files_size_in_mb": 100, "y_obj": 0.2,
            "data_path": "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet",
            "video_path": "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4",
            "features": {"observation.state": {"dtype": "float32", "shape": [3], "names": ["x", "y", "ydot"]},
                         "observation.force": {"dtype": "float32", "shape": [3], "names": ["fx", "fy", "fz"]},
                         "action": {"dtype": "float32", "shape": [2], "names": None},
                         "timestamp": {"dtype": "float32", "shape": [1], "names": None},
                         "frame_index": {"dtype": "int64", "shape": [1], "names": None},
                         "episode_index": {"dtype": "int64", "shape": [1], "names": None},
                         "index": {"dtype": "int64", "shape": [1], "names": None},
                         "task_index": {"dtype": "int64", "shape": [1], "names": None},
                         "next.reward": {"dtype": "float32", "shape": [1], "names": None},
                         "next.done": {"dtype": "bool", "shape": [1], "names": None},
                         "next.success": {"dtype": "bool", "shape": [1], "names": None},
                         "env.mu": {"dtype": "float32", "shape": [1], "names": None}}}
    (root / "meta").mkdir(parents=True)
    (root / "meta" / "info.json").write_text(json.dumps(info, indent=2))
    for chunk, (episodes, fixed) in enumerate((([0, 1], True), ([2, 3], False))):
        table = _table(episodes, fixed)
        if bad_episode in episodes:  # a NaN in observation.state[1] at frame 5 of that episode
            state = table.column("observation.state").to_pylist()
            row = episodes.index(bad_episode) * FRAMES + 5
            state[row][1] = float("nan")
            table = table.set_column(table.schema.get_field_index("observation.state"), "observation.state",
                                     pa.array(state, type=table.schema.field("observation.state").type))
        path = root / "data" / f"chunk-{chunk:03d}" / "file-000.parquet"
        path.parent.mkdir(parents=True)
        pq.write_table(table, path)
    return root


def _import(paths: list[Path], keys: str = KEYS, success_threshold: float | None = None, **kw):
    spec = ImportSpec(("y_obj", "mu"), **kw)
    options = LeRobotOptions(parse_lerobot_keys(keys, spec), success_threshold)
    return import_demos(paths, spec, {"lerobot": options})


def test_episodes_values_labels_and_the_bad_episode(tmp_path):
    root = write_dataset(tmp_path / "scoops")
    ds, errors = _import([root])
    assert ds.meta["demo_ids"] == ["scoops:episode_0", "scoops:episode_1", "scoops:episode_3"]
    assert ds.labels.tolist() == [1, 0, 0]  # next.success's last value
    np.testing.assert_allclose(ds.env, [[0.2, 0.4], [0.2, 0.5], [0.2, 0.7]], atol=1e-6)  # y_obj from info.json
    tk = np.arange(31) * 0.05
    for i, e in enumerate((0, 1, 3)):
        x = ds.responses[i]
        inside = tk <= 1.2 + 1e-9
        np.testing.assert_allclose(x[inside, 0], _y(e, tk[inside]), atol=1e-6)
        np.testing.assert_allclose(x[~inside, 0], _y(e, np.array(1.2)), atol=1e-6)  # held at rest after the end
        np.testing.assert_allclose(x[inside, 1], 0.1, atol=1e-6)
        np.testing.assert_allclose(x[:, 2], 5.0 + e)
    bad = root / "data" / "chunk-001" / "file-000.parquet"
    assert errors == [f"{bad}, episode 2, row 5, field 'y' (observation.state:1): nan is not finite"]


def test_labels_from_rewards_and_done_flags(tmp_path):
    root = write_dataset(tmp_path / "d", bad_episode=None)
    ds, errors = _import([root], success_threshold=0.5)  # the largest next.reward >= 0.5
    assert errors == [] and ds.labels.tolist() == [1, 0, 1, 0]
    ds, errors = _import([root], KEYS + ",success=next.reward", success_threshold=0.1)
    assert ds.labels.tolist() == [1, 1, 1, 1]
    for file in root.glob("data/*/*.parquet"):  # a dataset without next.success: next.reward, 0.9 is no label
        pq.write_table(pq.read_table(file).drop_columns(["next.success"]), file)
    ds, errors = _import([root])
    assert ds is None and "episode 0, field 'success' (next.reward): last value 0.9 is neither 1" in errors[0]
    assert "--success-threshold" in errors[0]
    for file in root.glob("data/*/*.parquet"):  # next.done alone: 1 at the end of every episode
        pq.write_table(pq.read_table(file).drop_columns(["next.reward"]), file)
    ds, errors = _import([root])
    assert ds is None and errors == [
        f"{root}: every label comes from 'next.done' and all 4 are 1: 'next.done' marks the end of every "
        "demonstration (robomimic's done_mode 2, LeRobot's next.done), success or not; map a success column with "
        "--keys success=COLUMN, or label from next.reward with --success-threshold X"]


def test_bad_files_columns_and_versions_are_named(tmp_path):
    root = write_dataset(tmp_path / "d", bad_episode=None)
    first = root / "data" / "chunk-000" / "file-000.parquet"
    pq.write_table(pq.read_table(first).drop_columns(["observation.force"]), first)
    ds, errors = _import([root])
    assert ds.meta["demo_ids"] == ["d:episode_2", "d:episode_3"]  # the other file is kept
    assert errors[0].startswith(f"{first}, field 'f': no column 'observation.force' (the file has [")
    assert errors[0].endswith("map one with --keys f=COLUMN[:INDEX]")
    _, errors = _import([root], KEYS.replace("observation.state:1", "observation.state"))
    assert "field 'y' (observation.state): column 'observation.state' holds 3 values per row: choose one with " \
           "--keys y=observation.state:INDEX" in errors[-1]
    _, errors = _import([root], KEYS.replace("observation.state:1", "observation.state:3"))
    assert "index 3 is out of range" in errors[-1]
    (root / "data" / "chunk-001" / "file-000.parquet").write_text("not parquet")
    _, errors = _import([root])
    assert "file-000.parquet: not a readable parquet file" in errors[-1]
    old = write_dataset(tmp_path / "old", version="v2.1")
    ds, errors = _import([old])
    assert ds is None and errors == [f"{old / 'meta' / 'info.json'}: codebase_version 'v2.1' is not supported; "
                                     "judgeopt reads LeRobot v3.x datasets (convert older ones with lerobot's "
                                     "convert_dataset_v21_to_v30)"]


def test_without_pyarrow_one_line_says_what_to_install(tmp_path, monkeypatch):
    root = write_dataset(tmp_path / "d")
    monkeypatch.setitem(sys.modules, "pyarrow", None)
    ds, errors = _import([root])
    assert ds is None and errors == ["reading a LeRobot dataset needs pyarrow: pip install 'judgeopt[lerobot]' "
                                     "(or pip install pyarrow)"]


def test_the_command_reads_a_dataset_folder(tmp_path, capsys):
    root = write_dataset(tmp_path / "d")
    rc = main(["import-demos", str(root), "--keys", KEYS, "--out", str(tmp_path / "o.h5")])
    captured = capsys.readouterr()
    assert rc == 0 and "3 demonstrations from 1 of 1" in captured.out, captured
    assert "episode 2, row 5, field 'y'" in captured.err
    assert load(tmp_path / "o.h5").n == 3
    assert main(["import-demos", str(root), "--keys", "speed=observation.state", "--out", str(tmp_path / "p.h5")]) == 2
    assert "--keys: unknown name 'speed'" in capsys.readouterr().err


def test_keys_may_pick_an_element_of_any_column():
    keys = parse_keys("mu=observation.environment_state:2,success=next.success", ("mu",), ("y",), flag="--keys",
                      scalars=("success",), columns_everywhere=True)
    assert keys == {"mu": "observation.environment_state:2", "success": "next.success"}
    with pytest.raises(ImportError_, match="--keys: unknown name 'dt'"):
        parse_keys("dt=x", ("mu",), ("y",), flag="--keys", scalars=("success",), columns_everywhere=True)
