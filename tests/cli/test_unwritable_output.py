"""An output that cannot be written is one line naming it and the option to change, exit 5, never a
traceback, and nothing is lost: solve shows its plans first (and writes every other output), every
other command refuses before any work. Tests run as root, where chmod stops nothing: the unwritable
folder is one under a regular file (`afile/...`), and permission, a read-only and a full disk are
monkeypatched where the system answers."""

from __future__ import annotations

import errno
import os
from pathlib import Path

import pytest

from judgeopt.cli import main
from judgeopt.errors import ExitCode
from judgeopt.files import OutputWriteError, atomic_write, check_writable, refuse_overwrite

#: solve's per-run settings: the amortised generator only, no replay (about 1 s once loaded)
SOLVE = ["solve", "--qdot-max", "0.4", "--no-simulate", "--quiet", "--method", "amortized"]


def _blocked(tmp_path: Path) -> Path:
    """A folder nothing can be written in, even as root: its parent is a regular file."""
    (tmp_path / "afile").write_text("a file, not a folder\n")
    return tmp_path / "afile"


def _one_line_naming(err: str, path: Path, flag: str, blocked: Path | None = None) -> str:
    assert "Traceback" not in err, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    line = lines[0]
    assert f"cannot write {path}: {blocked or path.parent} is a file, not a folder; " in line, line
    assert line.endswith(f"choose a writable folder with {flag}"), line
    return line


# -- solve: the plans are shown, then the write fails -------------------------------------------------
@pytest.mark.parametrize("flag, name", [("--out", "plan.csv"), ("--save-json", "plan.json"),
                                        ("--export", "robot.csv"), ("--plot", "plan.png")])
def test_solve_shows_its_plans_then_names_the_output_it_cannot_write(tmp_path, capsys, flag, name):
    target = _blocked(tmp_path) / name
    code = main([*SOLVE, flag, str(target)])
    out, err = capsys.readouterr()
    assert code == ExitCode.BAD_INPUT == 5
    _one_line_naming(err, target, flag)
    assert "method" in out and "amortized" in out and "success p" in out  # the table was printed
    assert "total" in out and f"wrote {target}" not in out


def test_solve_writes_every_other_output_and_names_the_first_it_cannot(tmp_path, capsys):
    """Two planners, per-method names; --save-json's folder is fine and written whole."""
    blocked, fine = _blocked(tmp_path), tmp_path / "fine"
    code = main(["solve", "--qdot-max", "0.4", "--no-simulate", "--quiet", "--out", str(blocked / "plan.csv"),
                 "--save-json", str(fine / "plan.json")])
    out, err = capsys.readouterr()
    assert code == 5
    _one_line_naming(err, blocked / "plan_amortized.csv", "--out")
    assert sorted(p.name for p in fine.iterdir()) == ["plan_amortized.json", "plan_direct.json"]
    assert f"wrote {fine / 'plan_direct.json'}" in out
    assert (blocked).read_text() == "a file, not a folder\n"  # nothing lost


def test_solve_json_says_what_was_written_and_the_error_in_one_object(tmp_path, capsys):
    import json

    target = _blocked(tmp_path) / "plan.csv"
    assert main([*SOLVE, "--json", "--out", str(target)]) == 5
    out, err = capsys.readouterr()
    doc = json.loads(out)  # one object: the results and the error
    assert doc["exit_code"] == 5 and doc["files"] == [] and doc["results"]
    assert doc["error"].startswith(f"cannot write {target}") and doc["error"].endswith("with --out")
    assert err == ""


# -- every other command: refused before any work ------------------------------------------------------
#: command line (OUT: the blocked folder, X: an input that need not exist, CSV: a file), and the path
#: the line names (a STEM's first file, a folder's own file where the command names it)
OTHERS = [
    (["collect", "--n", "2", "--out", "{OUT}/c.h5"], "{OUT}/c.h5"),
    (["render", "--data", "{X}", "--out", "{OUT}/gifs"], "{OUT}/gifs"),
    (["plot-data", "--data", "{X}", "--out", "{OUT}/fig.png"], "{OUT}/fig.png"),
    (["import-demos", "{CSV}", "--out", "{OUT}/d.h5"], "{OUT}/d.h5"),
    (["export-demos", "{X}", "--out", "{OUT}/d.csv"], "{OUT}/d.csv"),
    (["train-judge", "--train", "{X}", "--out", "{OUT}/judge"], "{OUT}/judge.pt"),
    (["train-ensemble", "--train", "{X}", "--out", "{OUT}/ens"], "{OUT}/ens/ensemble.json"),
    (["train-generator", "--out", "{OUT}/gen"], "{OUT}/gen.pt"),
    (["fit-trust-region", "--data", "{X}", "--out", "{OUT}/tr"], "{OUT}/tr.json"),
    (["evaluate", "planners", "--n", "1", "--out", "{OUT}/ev"], "{OUT}/ev"),
    (["calibrate", "{X}", "--out", "{OUT}/cal.json"], "{OUT}/cal.json"),
    (["export", "{X}", "--out", "{OUT}/robot.csv"], "{OUT}/robot.csv"),
    (["refine", "--out", "{OUT}/refine"], "{OUT}/refine"),
]


@pytest.mark.parametrize("argv, named", OTHERS, ids=[a[0] for a, _ in OTHERS])
def test_every_other_output_is_refused_before_any_work(tmp_path, capsys, argv, named):
    blocked = _blocked(tmp_path)
    csv = tmp_path / "rec.csv"
    csv.write_text("t,y,f,label\n0,0.1,1,success\n")
    fill = dict(OUT=blocked, X=tmp_path / "missing.h5", CSV=csv)
    argv = [a.format(**fill) for a in argv]
    assert main(argv) == 5
    out, err = capsys.readouterr()
    line = _one_line_naming(err, Path(named.format(**fill)), "--out", blocked)
    assert line.startswith(f"judgeopt {argv[0]}: error: ")
    assert out == "" and blocked.read_text() == "a file, not a folder\n"


def test_refine_install_into_an_unwritable_models_folder_is_refused_before_the_first_round(tmp_path, capsys,
                                                                                         monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("models").write_text("not a folder\n")  # `models` as the command resolves it, relative to here
    assert main(["refine", "--out", str(tmp_path / "r"), "--install", "mine"]) == 5
    err = capsys.readouterr().err.strip()
    assert err == "judgeopt refine: error: cannot write models/mine: models is a file, not a folder; choose a " \
                  "writable folder with --install NAME"
    assert not (tmp_path / "r").exists()


# -- the mechanism: judgeopt.files ---------------------------------------------------------------------
def test_a_file_in_the_way_is_named_by_the_writer_itself(tmp_path):
    blocked = _blocked(tmp_path)
    with pytest.raises(OutputWriteError) as info:
        atomic_write(blocked / "deeper" / "x.txt", "text")
    assert str(info.value) == (f"cannot write {blocked / 'deeper' / 'x.txt'}: {blocked} is a file, not a folder; "
                               "choose a writable folder")
    assert info.value.exit_code == 5 and isinstance(info.value, OSError)
    assert str(info.value.with_flag("--out")).endswith("choose a writable folder with --out")


def test_a_full_disk_while_writing_keeps_the_old_file_and_leaves_no_temporary(tmp_path, monkeypatch):
    target = tmp_path / "x.txt"
    target.write_text("old")

    def full(src, dst):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "replace", full)
    with pytest.raises(OutputWriteError, match="no space left on the device; free some space or choose another "
                                               "folder$"):
        atomic_write(target, "new")
    assert target.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["x.txt"]


def test_permission_and_a_read_only_file_system_are_refused_before_any_work(tmp_path, monkeypatch):
    """As root, access() says yes to every folder: what a user sees is answered by the system here."""
    check_writable([tmp_path / "new" / "x.txt"])  # a writable folder: nothing raised, nothing made
    assert not (tmp_path / "new").exists()
    monkeypatch.setattr(os, "access", lambda path, mode: False)
    with pytest.raises(OutputWriteError, match=f"^cannot write {tmp_path / 'x.txt'}: permission denied; "
                                               "choose a writable folder with --out$"):
        refuse_overwrite([tmp_path / "x.txt"], overwrite=False)
    with pytest.raises(OutputWriteError, match=f"permission denied in {tmp_path}; choose a writable folder with "
                                               "--plot$"):
        check_writable([tmp_path / "a" / "b" / "x.png"], "--plot")
    refuse_overwrite([tmp_path / "x.txt"], overwrite=False, writable=False)  # solve's: checked when written

    class ReadOnly:
        f_flag = os.ST_RDONLY

    monkeypatch.setattr(os, "statvfs", lambda path: ReadOnly)
    with pytest.raises(OutputWriteError, match="the file system is read-only; choose a writable folder with --out$"):
        check_writable([tmp_path / "x.txt"])


# -- the backstop: a write that fails after the check (the disk changed meanwhile) --------------------------
def test_a_write_failing_after_the_check_still_names_the_option(tmp_path, capsys, monkeypatch):
    """export-demos with its check skipped: the writer's own error, given its option by the command line."""
    import judgeopt.cli.recordings as recordings
    from judgeopt.files import REPO

    data = tmp_path / "d.h5"
    assert main(["import-demos", str(REPO / "data" / "example_demos.csv"), "--out", str(data)]) == 0
    capsys.readouterr()
    monkeypatch.setattr(recordings, "refuse_overwrite", lambda *a, **k: None)
    target = _blocked(tmp_path) / "d.csv"
    assert main(["export-demos", str(data), "--out", str(target)]) == 5
    out, err = capsys.readouterr()
    assert err.splitlines() == [f"judgeopt export-demos: error: cannot write {target}: {target.parent} is a file, "
                                "not a folder; choose a writable folder with --out"]


@pytest.mark.parametrize("path, flag", [("out/j.pt", "--out"), ("out/j.history.csv", "--out"),
                                        ("ev/partial/chunk.json", "--out"), ("plans/p_direct.json", "--save-json"),
                                        ("elsewhere/x.csv", None)])
def test_the_option_is_found_by_the_path_it_chose(path, flag):
    import argparse

    from judgeopt.cli.main import _option_for

    args = argparse.Namespace(command="x", out="out/j" if path.startswith("out") else "ev", save_json="plans/p.json",
                              data="data/train.h5", models="models", quiet=False, n=3)
    assert _option_for(args, Path(path)) == flag
