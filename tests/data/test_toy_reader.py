"""A format of one's own is a reader in one file plus one registration line: a toy format, its
reader and its one option written here, imported through `judgeopt import-demos` (folder listing,
its own flag, the shared checks) into a dataset read back against the values written."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.data.dataset import load
from judgeopt.data.readers.base import Flag, Reader, Source
from judgeopt.data.readers.registry import READERS, reader_for
from judgeopt.data.recording import LABELS, ImportError_, ImportSpec, RawDemo

# -- the toy format: a first line "label=success y_obj=0.2 mu=1.5", then "t y f" per line -----------


@dataclass(frozen=True)
class ToyOptions:
    #: samples dropped from the start of each file (a toy logger's warm-up)
    skip: int = 0


def read_toy(source: Source, spec: ImportSpec, options: ToyOptions) -> tuple[list[RawDemo], list[str]]:
    first, *lines = source.path.read_text().splitlines()
    meta = dict(item.split("=", 1) for item in first.split())
    if meta.get("label") not in LABELS:
        raise ImportError_(f"{source.path}, line 1: no label=success|failure")
    rows = np.array([[float(v) for v in line.split()] for line in lines[options.skip:]])
    env = {n: np.array([float(meta[n])]) for n in spec.env_names if n not in spec.env_values}
    return [RawDemo(str(source.path), "toy recording", source.path.stem,
                    {"t": rows[:, 0], "y": rows[:, 1], "f": rows[:, 2]}, env, LABELS[meta["label"]],
                    lambda c, i: f"{source.path}, sample {i + options.skip}, field {c!r}")], []


TOY = Reader("toy", "toy", ".toy file", read_toy, ToyOptions, suffixes=(".toy",), flags=(
    Flag("--toy-skip", "skip", type=int, metavar="N", does="drops the first samples of toy files",
         help="samples dropped from the start of each toy file (default: 0)"),))


@pytest.fixture(autouse=True)
def toy_registered(monkeypatch):
    monkeypatch.setitem(READERS, TOY.name, TOY)  # the one registration line


# -- the test --------------------------------------------------------------------------------------
def _toy(path: Path, label: str, y0: float, env: tuple[float, float]) -> Path:
    """1 s at 20 Hz: y = y0 + 0.1 t, f = 4 + 2 t; a warm-up of 3 samples at y = 9 (beyond 5 m: refused if kept)."""
    t = np.arange(21) * 0.05
    warm = [f"{-0.15 + 0.05 * k:.2f} 9.0 0.0" for k in range(3)]
    rows = [f"{ti:.2f} {float(y0 + 0.1 * ti)!r} {float(4 + 2 * ti)!r}" for ti in t]
    path.write_text(f"label={label} y_obj={env[0]} mu={env[1]}\n" + "\n".join(warm + rows) + "\n")
    return path


def test_a_toy_format_imports_through_the_command_with_its_own_flag(tmp_path, capsys):
    folder = tmp_path / "toys"
    folder.mkdir()
    _toy(folder / "a.toy", "success", 0.1, (0.2, 1.5))
    _toy(folder / "b.toy", "failure", 0.3, (0.25, 0.5))
    (folder / "notes.txt").write_text("not a recording")
    assert reader_for(folder / "a.toy") is TOY and reader_for(folder) is None  # a folder of recordings
    out = tmp_path / "d.h5"
    assert main(["import-demos", str(folder), "--toy-skip", "3", "--out", str(out)]) == 0
    assert "2 demonstrations from 2 of 2 file(s) (0 skipped)" in capsys.readouterr().out
    ds = load(out)
    assert ds.labels.tolist() == [1, 0] and ds.env.tolist() == [[0.2, 1.5], [0.25, 0.5]]
    tk = np.arange(31) * 0.05
    inside = tk <= 1.0 + 1e-9
    for x, y0 in zip(ds.responses, (0.1, 0.3)):
        np.testing.assert_allclose(x[inside, 0], y0 + 0.1 * tk[inside], atol=1e-9)
        np.testing.assert_allclose(x[inside, 1], 0.1, atol=1e-6)  # velocity derived, as for every format
        np.testing.assert_allclose(x[inside, 2], 4 + 2 * tk[inside], atol=1e-9)
        np.testing.assert_allclose(x[~inside, 0], y0 + 0.1, atol=1e-9)  # held at rest after the end
    # without the flag the warm-up is kept, and the shared checks name the toy's own place
    assert main(["import-demos", str(folder / "a.toy"), "--out", str(tmp_path / "e.h5")]) == 5
    err = capsys.readouterr().err
    assert f"{folder / 'a.toy'}, sample 0, field 'y': 9 is beyond 5" in err and "--scale y=mm" in err


def test_the_toy_flag_without_a_toy_file_is_a_usage_error(tmp_path, capsys):
    csv = tmp_path / "a.csv"
    csv.write_text("t,y,f,label,y_obj,mu\n0,0,5,success,0.2,0.5\n0.1,0.01,5,success,0.2,0.5\n")
    assert main(["import-demos", str(csv), "--toy-skip", "1", "--out", str(tmp_path / "d.h5")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--toy-skip drops the first samples of toy files; no .toy file is given" in err[0]
