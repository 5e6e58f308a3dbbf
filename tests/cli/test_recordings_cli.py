"""`judgeopt import-demos` and `export-demos` from the command line: flags, refusals, round trip."""

from __future__ import annotations

import argparse

from pathlib import Path

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.cli.main import build_parser
from judgeopt.data.dataset import load
from judgeopt.files import REPO

EXAMPLE_CSV = REPO / "data" / "example_demos.csv"


def _command(name: str) -> argparse.ArgumentParser:
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[name]


@pytest.mark.parametrize("name", ["import-demos", "export-demos"])
def test_every_flag_says_its_default(name):
    for action in _command(name)._actions:
        if not action.option_strings or action.nargs == 0 or action.required:  # positionals, switches, --out
            continue
        shown = action.default is not None or "default" in (action.help or "").lower()
        assert shown, f"{name} {action.option_strings[0]}: help gives no default"
    text = " ".join(_command("import-demos").format_help().split())
    for unit in ("crop: drop what comes before S seconds", "force magnitude in N", "seconds kept before contact"):
        assert unit in text


def test_export_then_import_from_the_command_line(tmp_path, capsys):
    data, csv_out, back = tmp_path / "d.h5", tmp_path / "d.csv", tmp_path / "back.h5"
    assert main(["import-demos", str(EXAMPLE_CSV), "--out", str(data)]) == 0
    assert main(["export-demos", str(data), "--out", str(csv_out)]) == 0
    assert "import it back with: judgeopt import-demos" in capsys.readouterr().out
    before = csv_out.read_text()
    assert main(["export-demos", str(data), "--out", str(csv_out)]) == 6  # exists: refused, file untouched
    assert "pass --overwrite" in capsys.readouterr().err and csv_out.read_text() == before
    assert main(["export-demos", str(data), "--out", str(csv_out), "--overwrite"]) == 0
    assert main(["import-demos", str(csv_out), "--out", str(back)]) == 0
    a, b = load(data), load(back)
    assert a.labels.tolist() == b.labels.tolist()
    np.testing.assert_allclose(a.responses, b.responses, rtol=0, atol=1e-12)
    assert main(["export-demos", str(tmp_path / "none.h5"), "--out", str(tmp_path / "n.csv")]) == 5
    assert "none.h5: no such file" in capsys.readouterr().err


@pytest.mark.parametrize("args, message", [
    (["--filter-key", "train"], "--filter-key selects demo groups of HDF5 files"),
    (["--keys", "y=observation.state:1"], "--keys maps LeRobot columns"),
    (["--start", "1", "--end", "0.5"], "--end 0.5 s must be after --start 1 s"),
    (["--success-threshold", "0.5"], "--success-threshold labels dense rewards; no LeRobot dataset folder (with "
                                     "meta/info.json) or .h5/.hdf5 file is given"),
])
def test_flags_that_cannot_apply_are_one_line_usage_errors(tmp_path, capsys, args, message):
    assert main(["import-demos", str(EXAMPLE_CSV), "--out", str(tmp_path / "d.h5"), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0]
    assert not (tmp_path / "d.h5").exists()


def _long_csv(path: Path, stop: float) -> Path:
    """3 s at 100 Hz: the tool moves at 1 cm/s until `stop` s, pressing 2 N from 1 s."""
    t = np.round(np.arange(0, 3.0 + 1e-9, 0.01), 6)
    rows = ["t,y,f,label,y_obj,mu"] + [f"{float(ti)!r},{0.01 * min(float(ti), stop)!r},{2.0 if ti > 1 else 0.0},"
                                       "success,0.2,1.5" for ti in t]
    path.write_text("\n".join(rows) + "\n")
    return path


def test_a_long_recording_names_the_flags_and_crop_to_horizon_takes_it(tmp_path, capsys):
    path = _long_csv(tmp_path / "long.csv", stop=2.0)
    assert main(["import-demos", str(path), "--out", str(tmp_path / "d.h5")]) == 5
    err = capsys.readouterr().err
    assert "lasts 3 s, longer than the horizon N·dt = 1.5 s" in err and "--align onset (or contact)" in err
    assert main(["import-demos", str(path), "--out", str(tmp_path / "d.h5"), "--align", "contact",
                 "--crop-to-horizon"]) == 0
    np.testing.assert_allclose(load(tmp_path / "d.h5").responses[0, 0, 0], 0.0091, atol=1e-9)  # 1.01 s - 0.1 s
    # a window that ends before the motion does lost what decided the label: refused, with the fixes
    moving = _long_csv(tmp_path / "moving.csv", stop=3.0)
    assert main(["import-demos", str(moving), "--out", str(tmp_path / "e.h5"), "--align", "contact",
                 "--fit", "crop"]) == 5
    err = capsys.readouterr().err
    assert "the motion ends 3 s after the first time stamp, after the 1.5 s kept from 0.91 s" in err
    assert "--horizon N with N·dt >= 2.19 s" in err and "--fit resample" in err


def test_an_environment_value_the_files_lack_names_env_names_first(tmp_path, capsys):
    """--env gives one value by hand, the files carry no environment column: the fix for the value
    left is to drop it (--env-names with the rest), not to map a column that is not there."""
    path = tmp_path / "a.csv"
    path.write_text("t,y,f,label\n" + "".join(f"{k / 20},{k / 200},5,success\n" for k in range(21)))
    out = tmp_path / "d.h5"
    assert main(["import-demos", str(path), "--env", "y_obj=0.246", "--out", str(out)]) == 5
    err = capsys.readouterr().err
    assert f"{path}: missing column(s) ['mu']; the header has ['t', 'y', 'f', 'label']; leave it out with " \
           "--env-names y_obj, give it with --env mu=VALUE or map a column with --columns mu=COLUMN" in err
    assert main(["import-demos", str(path), "--env", "y_obj=0.246", "--env-names", "y_obj", "--out", str(out)]) == 0
    assert load(out).env.tolist() == [[0.246]]


def test_every_readers_flags_are_the_commands(tmp_path):
    """The command's per-format flags come from the readers' registry, each under its format."""
    from judgeopt.data.readers.registry import flags

    parser = _command("import-demos")
    groups = {a.option_strings[0]: g.title for g in parser._action_groups for a in g._group_actions
              if a.option_strings}
    for spelling, (flag, readers) in flags().items():
        assert spelling in groups and all(r.title in groups[spelling] for r in readers), spelling
    for spelling in ("--columns", "--streams", "--hdf5-keys", "--filter-key", "--keys", "--topics",
                     "--success-threshold"):  # users' commands keep their spelling
        assert spelling in groups
