"""Every file `judgeopt solve` and `judgeopt export` write is refused without --overwrite when it
exists: the per-method files solve really writes (NAME_METHOD.EXT, documented in its --help), not
only the bare path given to --out. Each is created alone beforehand; the command must stop with
one line naming it, leave it byte for byte, and write nothing else."""

from __future__ import annotations

import pytest

from judgeopt.cli import main
from judgeopt.cli.common import ExitCode

#: what a command that made a plan returns, likely or not (exit 4: none likely)
PLANNED = (ExitCode.OK, ExitCode.UNLIKELY)

KEEP = b"keep me \x00\xff\n"

#: what `solve --out plan.csv --save-json plan.json --export robot.csv --plot plan.png` writes with
#: the default --method both (two planners: one file per method and option, and one figure)
BOTH = ["plan_amortized.csv", "plan_direct.csv", "plan_amortized.json", "plan_direct.json",
        "robot_amortized.csv", "robot_direct.csv", "plan.png"]
#: --method receding: the direct plan, and the plan as executed with its re-plans
RECEDING = ["plan_direct.csv", "plan_receding.csv"]


def solve_argv(d, *extra):
    return ["solve", "--qdot-max", "0.4", "--y-obj", "0.2", "--no-simulate", "--quiet", "--out", str(d / "plan.csv"),
            "--save-json", str(d / "plan.json"), "--export", str(d / "robot.csv"), "--plot", str(d / "plan.png"),
            *extra]


def _refused(argv, d, name, capsys):
    capsys.readouterr()
    (d / name).write_bytes(KEEP)
    assert main(argv) == ExitCode.EXISTS
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and name in err and "--overwrite" in err, err
    assert (d / name).read_bytes() == KEEP
    assert sorted(p.name for p in d.iterdir()) == [name]  # nothing else written


def test_solve_writes_exactly_the_per_method_files(tmp_path, capsys):
    """The lists the refusals below are checked against are what solve writes (not what it checks)."""
    assert main(solve_argv(tmp_path / "both")) == 0
    assert sorted(p.name for p in (tmp_path / "both").iterdir()) == sorted(BOTH)
    assert main(["solve", "--method", "receding", "--quiet", "--out", str(tmp_path / "receding" / "plan.csv")]) == 0
    assert sorted(p.name for p in (tmp_path / "receding").iterdir()) == sorted(RECEDING)


@pytest.mark.parametrize("name", BOTH)
def test_solve_refuses_each_existing_output(tmp_path, capsys, name):
    _refused(solve_argv(tmp_path), tmp_path, name, capsys)


@pytest.mark.parametrize("name", RECEDING)
def test_solve_receding_refuses_each_existing_output(tmp_path, capsys, name):
    argv = ["solve", "--method", "receding", "--quiet", "--out", str(tmp_path / "plan.csv")]
    _refused(argv, tmp_path, name, capsys)


def test_solve_with_one_method_refuses_the_bare_path(tmp_path, capsys):
    argv = ["solve", "--method", "direct", "--no-simulate", "--quiet", "--out", str(tmp_path / "plan.csv")]
    _refused(argv, tmp_path, "plan.csv", capsys)


@pytest.mark.parametrize("suffix", ["csv", "mcap"])
def test_export_refuses_an_existing_output(tmp_path, capsys, suffix):
    if suffix == "mcap":
        pytest.importorskip("rosbags")
    src = tmp_path / "src"
    src.mkdir()
    assert main(["solve", "--method", "amortized", "--no-simulate", "--quiet", "--save-json",
                 str(src / "plan.json")]) in PLANNED
    out = tmp_path / "out"
    out.mkdir()
    _refused(["export", str(src / "plan.json"), "--out", str(out / f"robot.{suffix}")], out, f"robot.{suffix}",
             capsys)
    assert main(["export", str(src / "plan.json"), "--out", str(out / f"robot.{suffix}"), "--overwrite"]) == 0
    assert (out / f"robot.{suffix}").read_bytes() != KEEP
