"""Recorded demonstrations in: CSV validation (file, row, column), resampling, batch import."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.data.dataset import load
from judgeopt.data.importer import ImportSpec, import_csv

ROOT = Path(__file__).resolve().parents[1]
SPEC = ImportSpec(("y_obj", "mu"))


def _write(path: Path, t, y, f, label="success", extra_cols="", env=(0.2, 1.5), ydot=None) -> Path:
    head = "t,y," + ("ydot," if ydot is not None else "") + "f,label,y_obj,mu" + extra_cols
    lines = [head]
    for k in range(len(t)):
        v = f"{float(ydot[k])!r}," if ydot is not None else ""
        lines.append(f"{float(t[k])!r},{float(y[k])!r},{v}{float(f[k])!r},{label},{env[0]},{env[1]}")
    path.write_text("\n".join(lines) + "\n")
    return path


def test_a_1khz_recording_resamples_to_the_planners_period(tmp_path):
    t = np.arange(0, 1.5 + 1e-9, 0.001)
    y = 0.1 * np.sin(t)
    ds, errors = import_csv([_write(tmp_path / "a.csv", t, y, 10 + t)], SPEC)
    assert errors == [] and ds.n == 1 and ds.labels[0] == 1 and ds.env.tolist() == [[0.2, 1.5]]
    tk = np.arange(31) * 0.05
    x = ds.responses[0]
    assert np.abs(x[:, 0] - 0.1 * np.sin(tk)).max() < 1e-9
    assert np.abs(x[:, 1] - 0.1 * np.cos(tk)).max() < 1e-4  # velocity derived from the position
    assert np.abs(x[:, 2] - (10 + tk)).max() < 1e-9


def test_a_short_recording_is_held_at_rest(tmp_path):
    t = np.linspace(0, 1.0, 11)
    ds, _ = import_csv([_write(tmp_path / "a.csv", t, t * 0.1, np.full(11, 5.0), ydot=np.full(11, 0.1))], SPEC)
    x = ds.responses[0]
    assert x[-1, 0] == pytest.approx(0.1) and x[-1, 1] == 0.0 and x[-1, 2] == 5.0


@pytest.mark.parametrize("mutate, message", [
    (lambda s: s.replace("t,y,", "time,y,"), "missing column.*'t'"),
    (lambda s: s.replace("\n0.1,", "\n0.04,", 1), "row 4, column 't': earlier time stamp"),
    (lambda s: s.replace("\n0.1,", "\n0.05,", 1), "row 4, column 't': duplicate time stamp"),
    (lambda s: s.replace(",success,", ",nan_here,", 1), "row 2, column 'label'"),
    (lambda s: s.replace("0.2,1.5\n", "0.2,nan\n", 1), "row 2, column 'mu': 'nan' is not finite"),
    (lambda s: s.replace("\n0.05,0.005,", "\n0.05,5.5,", 1), "row 3, column 'y': 5.5 is beyond 5.*SI units"),
])
def test_bad_files_name_the_row_and_column(tmp_path, mutate, message):
    t = np.round(np.arange(0, 1.0, 0.05), 3)
    good = _write(tmp_path / "good.csv", t, np.round(t * 0.1, 6), np.full(len(t), 5.0))
    bad = tmp_path / "bad.csv"
    bad.write_text(mutate(good.read_text()))
    ds, errors = import_csv([good, bad], SPEC)
    assert ds.n == 1 and len(errors) == 1
    assert errors[0].startswith(str(bad)) and __import__("re").search(message, errors[0]), errors[0]


def test_the_shipped_example_imports_and_the_command_keeps_good_files(tmp_path, capsys):
    (tmp_path / "bad.csv").write_text("t,y,f\n0,0,1\n")
    rc = main(["import-demos", str(ROOT / "data" / "example_demos.csv"), str(tmp_path / "bad.csv"),
               "--out", str(tmp_path / "d.h5")])
    captured = capsys.readouterr()
    assert rc == 0 and "missing column" in captured.err and "3 demonstrations from 1 of 2" in captured.out
    ds = load(tmp_path / "d.h5")
    assert ds.n == 3 and sorted(ds.labels.tolist()) == [0, 0, 1]
    assert main(["import-demos", str(tmp_path / "bad.csv"), "--out", str(tmp_path / "e.h5")]) == 2
    assert not (tmp_path / "e.h5").exists()
