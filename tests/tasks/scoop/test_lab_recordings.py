"""Lab recordings made in the scene: the promised file layout, labels for every file, determinism."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from judgeopt.files import OverwriteError
from judgeopt.tasks.scoop.lab_recordings import LabConfig, main, make_recordings


def read(path: Path) -> tuple[list[str], np.ndarray, np.ndarray, np.ndarray]:
    """Header, time, position (nan where blank), force (nan where blank)."""
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    cols = [np.array([float(r[j]) if r[j] else np.nan for r in rows[1:]]) for j in range(3)]
    assert all(len(r) == 3 for r in rows)  # time, position, force: no velocity column
    return rows[0], *cols


def table(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    out = tmp_path_factory.mktemp("lab")
    make_recordings(out, 4, seed=0, n_jobs=1, progress=False)
    return out


def test_files_have_the_promised_layout(lab):
    demos = table(lab / "demos.csv")
    assert [d["file"] for d in demos] == [f"demo_{k:04d}.csv" for k in (1, 2, 3, 4)]
    last = -np.inf
    for d in demos:
        head, t, y, f = read(lab / "recordings" / d["file"])
        assert head == ["time", "tool_y_m", "fz_N"]
        assert np.all(np.isnan(y) != np.isnan(f))  # each row one stream, the other cell blank
        assert np.all(np.diff(t) >= 0) and t[0] > last and t[0] > 1.6e9  # UNIX seconds, increasing across files
        last = t[-1]
        tm, tf = t[~np.isnan(y)], t[~np.isnan(f)]
        assert np.median(np.diff(tm)) == pytest.approx(1 / 120, abs=2e-6)
        assert np.median(np.diff(tf)) == pytest.approx(1e-3, abs=2e-6)
        onset, end = float(d["onset"]), float(d["onset"]) + float(d["stroke_s"])
        assert onset - t[0] >= 0.29 and t[-1] - end >= 0.29  # at rest 0.3-1.5 s before and after
        for rest in (tm < onset - 0.01, tm > end + 0.01):  # the tool still, 1 mm noise
            assert y[~np.isnan(y)][rest].std() < 0.002
        assert abs(np.mean(y[~np.isnan(y)][tm < onset]) - float(d["y_start"])) < 0.002
        assert abs(np.mean(y[~np.isnan(y)][tm > end + 0.01]) - float(d["y_end"])) < 0.003
        fv = f[~np.isnan(f)]
        for rest in (tf < onset, tf > end):  # no pressing: the sensor's bias
            assert np.mean(fv[rest]) == pytest.approx(0.3, abs=0.02)
        assert fv.min() < -1.0 and fv.max() < 1.0  # pressing reads negative


def test_labels_name_every_file(lab):
    files = {d["file"] for d in table(lab / "demos.csv")}
    for name in ("labels.csv", "labels_true.csv"):
        rows = table(lab / name)
        assert list(rows[0]) == ["file", "success"] and {r["file"] for r in rows} == files
        assert {r["success"] for r in rows} <= {"0", "1"}
    truth = {r["file"]: r["success"] for r in table(lab / "labels_true.csv")}
    assert truth == {d["file"]: d["success"] for d in table(lab / "demos.csv")}


def test_recordings_are_seeded_and_do_not_depend_on_how_many(lab, tmp_path):
    make_recordings(tmp_path, 2, seed=0, n_jobs=1, progress=False)
    for name in ("demo_0001.csv", "demo_0002.csv"):
        assert (tmp_path / "recordings" / name).read_bytes() == (lab / "recordings" / name).read_bytes()
    with pytest.raises(OverwriteError):
        make_recordings(tmp_path, 2, seed=0, n_jobs=1, progress=False)


def test_a_lab_no_file_here_has(tmp_path):
    """mm, 250 Hz motion capture, pressing read positive, other column names, half the labels wrong."""
    assert main(["--out", str(tmp_path), "--n", "2", "--jobs", "1", "--quiet", "--set", "position_unit=mm",
                 "--set", "mocap_rate=250", "--set", "force_sign=1", "--set", "columns=t,y_mm,f",
                 "--set", "label_noise=0.5"]) == 0
    head, t, y, f = read(tmp_path / "recordings" / "demo_0001.csv")
    assert head == ["t", "y_mm", "f"]
    assert np.median(np.diff(t[~np.isnan(y)])) == pytest.approx(1 / 250, abs=2e-6)
    assert np.nanmin(y) == pytest.approx(-100, abs=20) and np.nanmax(f) > 1.0
    noisy, true = table(tmp_path / "labels.csv"), table(tmp_path / "labels_true.csv")
    assert sum(a["success"] != b["success"] for a, b in zip(noisy, true)) == 1


def test_bad_settings_are_one_line(tmp_path, capsys):
    assert main(["--out", str(tmp_path), "--n", "1", "--set", "position_unit=furlong"]) == 2
    assert "position_unit = 'furlong'" in capsys.readouterr().err
    with pytest.raises(ValueError, match="label_noise"):
        LabConfig(label_noise=2.0)
