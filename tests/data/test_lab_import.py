"""Recordings as a lab makes them, imported with one command: mapped columns, motion capture and
force at different rates on different rows, absolute UNIX time, a flipped and biased force, no
velocity, idle periods, a labels file and a constant environment. Every check is against the
motion the test wrote (known by construction)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.data.dataset import load
from judgeopt.data.importer import ImportSpec, import_demos, report
from judgeopt.data.labels import LabelFile, parse_assignments, read_labels
from judgeopt.data.readers.csv import CsvOptions
from judgeopt.data.recording import ImportError_

EPOCH = 1.7e9  # absolute UNIX seconds
Q0, Q1 = -0.1, 0.246
COLUMNS = {"t": "time", "y": "tool_y_m", "f": "fz_N"}


def _motion(t: np.ndarray, start: float, duration: float) -> tuple[np.ndarray, np.ndarray]:
    """Min-jerk from Q0 to Q1 starting at `start`: position and velocity."""
    s = np.clip((t - start) / duration, 0.0, 1.0)
    y = Q0 + (Q1 - Q0) * (10 * s**3 - 15 * s**4 + 6 * s**5)
    v = (Q1 - Q0) / duration * (30 * s**2 - 60 * s**3 + 30 * s**4)
    return y, v


def _force(t: np.ndarray, start: float, duration: float) -> np.ndarray:
    """Presses 8 N while moving (ramped in over 0.1 s), nothing at rest."""
    on = np.clip((t - start) / 0.1, 0, 1) * (t <= start + duration)
    return 8.0 * on


def _lab_file(path: Path, idle: float, duration: float, rng: np.random.Generator, sign: float = -1.0,
              bias: float = 0.3, noise: float = 0.001, mocap_hz: float = 120.0, unit: float = 1.0,
              t0: float = EPOCH) -> Path:
    """One demonstration: motion capture and force/torque rows interleaved by time, blank cells
    for the other stream."""
    end = idle + duration + idle
    tm = np.arange(0, end, 1 / mocap_hz)
    tf = np.arange(0, end, 1e-3)
    y = _motion(tm, idle, duration)[0] + rng.normal(0, noise, tm.size)
    f = sign * _force(tf, idle, duration) + bias + rng.normal(0, 0.02, tf.size)
    rows = [(t, f"{float(y_ * unit)!r}", "") for t, y_ in zip(tm, y)] + [(t, "", f"{float(f_)!r}") for t, f_ in zip(tf, f)]
    rows.sort(key=lambda r: r[0])
    path.write_text("time,tool_y_m,fz_N\n" + "".join(f"{float(t0 + t)!r},{a},{b}\n" for t, a, b in rows))
    return path


def _folder(tmp_path: Path, durations=(0.9, 1.3), idles=(0.5, 1.2), **kw) -> tuple[list[Path], Path]:
    rng = np.random.default_rng(0)
    files = [_lab_file(tmp_path / f"demo_{k:04d}.csv", idle, d, rng, t0=EPOCH + 100 * k, **kw)
             for k, (d, idle) in enumerate(zip(durations, idles))]
    labels = tmp_path / "labels.csv"
    labels.write_text("file,success\n" + "".join(f"{p.name},{k % 2}\n" for k, p in enumerate(files)))
    return files, labels


def _spec(labels: Path | LabelFile, **kw) -> ImportSpec:
    """What a user passes for the files `_lab_file` writes (with `CSV`, the reader's options)."""
    labels = read_labels(labels) if isinstance(labels, Path) else labels
    base = dict(scale={"f": -1.0}, labels=labels, env_values={"y_obj": Q1}, align="onset", tare=True, fit="crop")
    return ImportSpec(("y_obj",), **{**base, **kw})


CSV = {"csv": CsvOptions(COLUMNS)}


def _start_on_window_clock(x: np.ndarray, tk: np.ndarray, duration: float) -> float:
    """Where the written motion starts on the imported window's clock: the shift that matches it best."""
    shifts = np.arange(0.0, 0.5, 0.001)
    err = [np.abs(x[:, 0] - _motion(tk, s, duration)[0]).max() for s in shifts]
    return float(shifts[int(np.argmin(err))])


def test_a_lab_folder_imports_with_one_spec_and_matches_the_motion_written(tmp_path):
    files, labels = _folder(tmp_path)
    ds, errors = import_demos(files, _spec(labels), CSV)
    assert errors == [] and ds.n == 2
    assert ds.labels.tolist() == [0, 1] and ds.env.ravel().tolist() == [Q1, Q1]
    tk = np.arange(31) * 0.05
    for x, duration in zip(ds.responses, (0.9, 1.3)):
        s0 = _start_on_window_clock(x, tk, duration)
        assert 0.0 < s0 <= 0.15  # onset found per file (idle 0.5 and 1.2 s), 0.1 s of lead kept before it
        y_true, v_true = _motion(tk, s0, duration)
        assert np.abs(x[:, 0] - y_true).max() < 0.002  # 1 mm noise, smoothed
        assert np.sqrt(np.mean((x[:, 1] - v_true) ** 2)) < 0.02  # velocity derived, not noise (0.16 m/s raw)
        assert np.abs(x[:, 1][tk < s0 - 0.06]).max(initial=0) < 0.03  # at rest: 0.009 m/s of noise left, 3 sigma
        pressing = (tk > s0 + 0.15) & (tk < s0 + duration - 0.05)
        assert np.abs(x[pressing, 2] - 8.0).max() < 0.1  # sign turned and the 0.3 N bias tared
        assert np.abs(x[tk < s0 - 0.02, 2]).max(initial=0) < 0.1  # nothing pressed before the motion
    lines = report(ds)
    assert any("position noise" in s and "Savitzky-Golay" in s for s in lines)
    np.testing.assert_allclose(ds.meta["import"]["noise"], 0.001, rtol=0.1)  # the 1 mm written, measured
    assert any("tared 'f'" in s for s in lines)
    np.testing.assert_allclose(ds.meta["import"]["bias_f"], -0.3, atol=0.01)  # in the task's sign: the sensor read +0.3 N
    info = ds.meta["import"]
    for k, (duration, idle) in enumerate(((0.9, 0.5), (1.3, 1.2))):  # inside the motion written, most of it
        assert idle - 0.05 <= info["onset"][k] <= idle + 0.05  # the smoothing window spreads the start a little
        assert idle + duration - 0.1 <= info["end"][k] <= idle + duration + 0.05


def test_a_flipped_force_is_refused_with_the_fix_and_a_right_one_is_not(tmp_path):
    files, labels = _folder(tmp_path)
    ds, errors = import_demos(files, _spec(labels, scale={}), CSV)
    assert ds is None and len(errors) == 2
    assert errors[0].startswith(f"{files[0]}: demonstration 'demo_0000': force 'f' runs from -8")
    assert errors[0].endswith("negative while pressing, and pressing is positive in the scoop task; pass --scale f=-1")
    right = _lab_file(tmp_path / "right.csv", 0.5, 1.0, np.random.default_rng(1), sign=1.0, bias=0.0)
    ds, errors = import_demos([right], _spec(LabelFile("l", {"right": 1}), scale={}), CSV)
    assert errors == [] and ds.n == 1


def test_millimetres_are_refused_with_the_unit_to_pass_and_imported_with_it(tmp_path):
    path = _lab_file(tmp_path / "mm.csv", 0.5, 1.0, np.random.default_rng(2), unit=1000.0)
    labels = LabelFile("l", {"mm.csv": 1})
    _, errors = import_demos([path], _spec(labels), CSV)
    assert "column 'tool_y_m'" in errors[0] and "expected SI units (m, m/s, N); in mm? pass --scale y=mm" in errors[0]
    ds, errors = import_demos([path], _spec(labels, scale=parse_assignments("f=-N,y=mm", "--scale", ["t", "y", "f"],
                                                                          units=True, kinds={"y": "position",
                                                                                             "f": "force"})), CSV)
    assert errors == [] and abs(ds.responses[0, -1, 0] - Q1) < 0.002


def test_the_labels_file_must_name_every_recording_and_only_those(tmp_path):
    files, labels = _folder(tmp_path, durations=(0.9, 1.0, 1.1), idles=(0.5, 0.5, 0.5))
    labels.write_text("file,success\ndemo_0000.csv,1\ndemo_0001,failure\ndemo_0009.csv,1\n")
    ds, errors = import_demos(files, _spec(labels), CSV)
    assert ds.labels.tolist() == [1, 0]  # by file name or by stem
    assert errors == [
        f"{files[2]}: demonstration 'demo_0002' is not in the labels file {labels}; add a row 'demo_0002.csv,success' "
        "(or failure), or leave the recording out",
        f"--labels {labels}: names 1 recording(s) not given (demo_0009.csv); a typo or a missing file? (fine when "
        "importing a subset)"]


@pytest.mark.parametrize("text, message", [
    ("name\nx\n", "needs a recording column"), ("file,success\na.csv,maybe\n", "row 2: 'maybe' is not success"),
    ("file,success\na.csv,1\na.csv,0\n", "row 3: 'a.csv' is labelled twice, differently"),
])
def test_bad_labels_files_say_where(tmp_path, text, message):
    (tmp_path / "l.csv").write_text(text)
    with pytest.raises(ImportError_, match=message):
        read_labels(tmp_path / "l.csv")


@pytest.mark.parametrize("text, message", [
    ("f=kg", "not a number or a unit"), ("y=N", "'N' measures force, 'y' is a position"), ("q=2", "unknown name 'q'"),
    ("f=0", "would erase the channel"), ("f", "not NAME=VALUE"),
])
def test_bad_scales_are_refused(text, message):
    with pytest.raises(ImportError_, match=message):
        parse_assignments(text, "--scale", ["t", "y", "f"], units=True, kinds={"t": "t", "y": "position", "f": "force"})


def test_a_rate_too_low_for_the_planner_is_refused_with_the_dt_that_would_do(tmp_path):
    path = _lab_file(tmp_path / "slow.csv", 0.5, 1.0, np.random.default_rng(3), mocap_hz=8.0)
    _, errors = import_demos([path], _spec(LabelFile("l", {"slow": 1})), CSV)
    assert "column 'tool_y_m': 'y' is sampled every 0.125 s (8 Hz), less than half the planner's rate" in errors[0]
    assert "--dt 0.0625" in errors[0]


def test_resample_stretches_each_motion_onto_the_horizon(tmp_path):
    files, labels = _folder(tmp_path, durations=(0.9, 2.2), idles=(0.5, 0.8))
    _, errors = import_demos(files, _spec(labels), CSV)  # --fit crop: the 2.2 s motion does not fit 1.5 s
    assert len(errors) == 1 and "the motion ends" in errors[0] and "--fit resample" in errors[0]
    ds, errors = import_demos(files, _spec(labels, fit="resample"), CSV)
    assert errors == []
    scale = np.array(ds.meta["import"]["time_scale"])
    kept = np.array(ds.meta["import"]["kept"])
    np.testing.assert_allclose(scale, kept / 1.5)
    assert scale[0] < 1 < scale[1]  # the short motion played slower, the long one faster
    for x, s in zip(ds.responses, scale):  # the whole motion, from rest to rest, in the window
        assert abs(x[0, 0] - Q0) < 0.003 and abs(x[-1, 0] - Q1) < 0.003
        assert np.abs(x[:, 1]).max() == pytest.approx(1.875 * (Q1 - Q0) / (2.2 if s > 1 else 0.9) * s, rel=0.1)


def test_one_command_from_a_lab_folder_to_a_dataset(tmp_path, capsys):
    files, labels = _folder(tmp_path)
    out = tmp_path / "demos.h5"
    assert main(["import-demos", str(tmp_path), "--labels", str(labels), "--columns", "t=time,y=tool_y_m,f=fz_N",
                 "--scale", "f=-1", "--env-names", "y_obj", "--env", "y_obj=0.246", "--align", "onset", "--tare",
                 "--fit", "crop", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "2 demonstrations from 2 of 2 file(s)" in text  # labels.csv is not read as a demonstration
    assert "Savitzky-Golay" in text and "tared 'f'" in text
    ds = load(out)
    assert ds.env_names == ("y_obj",) and ds.labels.tolist() == [0, 1]


def test_labels_and_environment_values_apply_to_hdf5_demo_groups_too(tmp_path):
    from judgeopt.files import REPO

    labels = LabelFile("l", {"demo_0": 0, "demo_1": 1, "demo_2": 0})
    spec = ImportSpec(("y_obj", "mu"), labels=labels, env_values={"y_obj": 0.3})
    ds, errors = import_demos([REPO / "data" / "example_demos_robomimic.hdf5"], spec)
    assert errors == [] and ds.labels.tolist() == [0, 1, 0]
    assert (ds.env[:, 0] == 0.3).all() and len(set(ds.env[:, 1])) > 1  # mu still read from each demo group


def test_streams_in_separate_files_merge_on_time(tmp_path):
    one = tmp_path / "one"
    one.mkdir()
    _lab_file(one / "demo_0007.csv", 0.5, 1.0, np.random.default_rng(4))
    ref, errors = import_demos([one / "demo_0007.csv"], _spec(LabelFile("l", {"demo_0007": 1})), CSV)
    assert errors == []
    header, *rows = (one / "demo_0007.csv").read_text().splitlines()
    mocap = [r.rsplit(",", 1)[0] for r in rows if r.split(",")[1]]
    ft = [r.split(",")[0] + "," + r.split(",")[2] for r in rows if r.split(",")[2]]
    (tmp_path / "demo_0007_mocap.csv").write_text("time,tool_y_m\n" + "\n".join(mocap) + "\n")
    (tmp_path / "demo_0007_ft.csv").write_text("time,fz_N\n" + "\n".join(ft) + "\n")
    (tmp_path / "demo_0008_mocap.csv").write_text("time,tool_y_m\n1,0\n2,0\n")
    files = sorted(tmp_path.glob("*.csv"))
    ds, errors = import_demos(files, _spec(LabelFile("l", {"demo_0007": 1, "demo_0008": 0})),
                              {"csv": CsvOptions(COLUMNS, streams=("mocap", "ft"))})
    np.testing.assert_array_equal(ds.responses, ref.responses)  # the same as one file with both streams
    assert errors == [f"{tmp_path / 'demo_0008'}: no demo_0008_ft.csv beside demo_0008_mocap.csv (--streams mocap,ft)"]
