"""Every bad input is one line on stderr naming the fix, with its exit code and no traceback:
a folder where a file belongs, a missing, empty or wrong kind of file, a number that is not
finite (nan, +inf and -inf, on every command with limit options and in problem files)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from judgeopt.cli import main
from judgeopt.errors import ExitCode
from judgeopt.files import resolve

#: what a command that made a plan returns, likely or not (exit 4: none likely)
PLANNED = (ExitCode.OK, ExitCode.UNLIKELY)

DATA = str(resolve("data/test.h5"))


@pytest.fixture
def files(tmp_path: Path) -> Path:
    """A folder, empty files and files of the wrong kind, named as the cases name them."""
    (tmp_path / "dir").mkdir()
    for name in ("empty.toml", "empty.json", "empty.h5", "empty.csv"):
        (tmp_path / name).write_text("")
    (tmp_path / "judge.json").write_text('{"format": "judgeopt-judge", "format_version": 1}')
    return tmp_path


def run(argv: list[str], files: Path, capsys) -> tuple[int, list[str]]:
    """The CLI in this process: its exit code and its stderr lines."""
    argv = [a.replace("{tmp}", str(files)) for a in argv]
    try:
        rc = main(argv)
    except SystemExit as exc:  # argparse's usage errors
        rc = exc.code
    return rc, capsys.readouterr().err.strip().splitlines()


def check(rc: int, err: list[str], code: int, says: str) -> None:
    assert rc == code and len(err) == 1 and "Traceback" not in err[0] and says in err[0], (rc, err)


LIMITS = [  # +-inf and nan limits: on the command line of every command with limit options
    (["solve", "--qdot-max", "inf"], "expected a finite number"),
    (["solve", "--qdot-max", "-inf"], "expected a finite number"),  # a value, not an unknown option
    (["solve", "--f-max", "-inf"], "expected a finite number"),
    (["solve", "--f-min", "-inf"], "expected a finite number"),
    (["solve", "--q0", "-inf"], "expected a finite number"),
    (["solve", "--q-max", "nan"], "expected a finite number"),
    (["train-generator", "--out", "{tmp}/g", "--f-max", "-inf"], "expected a finite number"),
    (["train-generator", "--out", "{tmp}/g", "--conditioned", "--qdot-max-range", "0.4,inf"], "two finite numbers"),
    (["train-generator", "--out", "{tmp}/g", "--conditioned", "--f-max-range", "-inf,20"], "two finite numbers"),
    (["refine", "--train", DATA, "--out", "{tmp}/r", "--qdot-max", "inf"], "expected a finite number"),
    (["evaluate", "edge", "--qdot-max", "-inf"], "finite numbers"),
    (["evaluate", "robustness", "--qdot-max", "0.4,inf"], "finite numbers"),
    (["evaluate", "sweep", "--vary", "mu=-inf,2"], "two finite numbers"),
    (["collect", "--out", "{tmp}/x.h5", "--range", "mu=1,inf"], "two finite numbers"),
    (["collect", "--out", "{tmp}/x.h5", "--per-env", "1", "--grid", "mu=1,inf"], "finite numbers"),
]


@pytest.mark.parametrize("argv, says", LIMITS)
def test_a_limit_that_is_not_finite_is_refused_on_the_command_line(argv, says, files, capsys):
    check(*run(argv, files, capsys), ExitCode.USAGE, says)


@pytest.mark.parametrize("line", ["qdot_max = inf", "f_max = -inf", "f_min = -inf", "q_min = -inf", "qdot_max = nan"])
def test_a_limit_that_is_not_finite_is_refused_in_a_problem_file(line, files, capsys):
    problem = files / "p.toml"
    problem.write_text(f'base = "problems/paper_sim.toml"\n[limits]\n{line}\n')
    rc, err = run(["solve", "--problem", str(problem), "--no-simulate", "--method", "amortized"], files, capsys)
    check(rc, err, ExitCode.BAD_INPUT, "must be a finite number")


NUMBERS = [  # the other number options: nan and inf refused before any work, naming the option
    (["import-demos", "{tmp}/empty.csv", "--out", "{tmp}/x.h5", "--dt", "nan"], "argument --dt"),
    (["import-demos", "{tmp}/empty.csv", "--out", "{tmp}/x.h5", "--start", "inf"], "argument --start"),
    (["train-judge", "--train", DATA, "--out", "{tmp}/j", "--lr", "nan"], "argument --lr"),
    (["export", "{tmp}/plan.json", "--out", "{tmp}/x.csv", "--step", "inf"], "argument --step"),
    (["collect", "--out", "{tmp}/x.h5", "--set", "commands.constant_force_share=inf"], "finite number"),
]


@pytest.mark.parametrize("argv, says", NUMBERS)
def test_a_number_that_is_not_finite_is_refused(argv, says, files, capsys):
    check(*run(argv, files, capsys), ExitCode.USAGE, says)


FILES = [  # (argv, exit code, what the line says: the fix)
    # a folder where a file belongs
    (["plot-data", "--data", DATA, "--out", "{tmp}/dir"], ExitCode.USAGE, "give an image file"),
    (["plot-data", "--data", DATA, "--out", "{tmp}/fig.pngx"], ExitCode.USAGE, "the suffix picks the format"),
    (["plot-data", "--data", "{tmp}/dir", "--out", "{tmp}/fig.png"], ExitCode.BAD_INPUT, "give a dataset file"),
    (["collect", "--out", "{tmp}/dir"], ExitCode.USAGE, "give a file to write"),
    (["export-demos", DATA, "--out", "{tmp}/dir"], ExitCode.USAGE, "give a file to write"),
    (["test-judge", "--data", "{tmp}/dir"], ExitCode.BAD_INPUT, "give a dataset file"),
    (["export", "{tmp}/dir", "--out", "{tmp}/x.csv"], ExitCode.BAD_INPUT, "give a plan file"),
    (["solve", "--no-simulate", "--method", "amortized", "--save-json", "{tmp}/dir"], ExitCode.USAGE,
     "give a file to write"),
    (["solve", "--no-simulate", "--method", "amortized", "--export", "{tmp}/dir"], ExitCode.USAGE,
     "give a file to write"),
    (["solve", "--no-simulate", "--method", "amortized", "--calibration", "{tmp}/dir"], ExitCode.BAD_INPUT,
     "judgeopt calibrate --out FILE"),
    (["solve", "--no-simulate", "--method", "direct", "--ensemble", "{tmp}/dir", "--pessimism", "1"],
     ExitCode.BAD_INPUT, "judgeopt train-ensemble"),
    (["solve", "--no-simulate", "--method", "direct", "--trust-model", "{tmp}/dir", "--trust-region", "0.1"],
     ExitCode.BAD_INPUT, "judgeopt fit-trust-region"),
    (["calibrate", "{tmp}/dir", "--out", "{tmp}/dir"], ExitCode.USAGE, "give a file to write"),
    (["refine", "--train", DATA, "--out", "{tmp}/r", "--generator", "{tmp}/dir"], ExitCode.BAD_INPUT,
     "judgeopt train-generator"),
    # a missing file
    (["solve", "--no-simulate", "--method", "amortized", "--calibration", "{tmp}/missing.json"], ExitCode.BAD_INPUT,
     "judgeopt calibrate"),
    (["solve", "--no-simulate", "--method", "direct", "--ensemble", "{tmp}/missing", "--pessimism", "1"],
     ExitCode.BAD_INPUT, "judgeopt train-ensemble"),
    (["import-demos", "{tmp}/missing.csv", "--out", "{tmp}/x.h5"], ExitCode.BAD_INPUT, "missing.csv"),
    (["export", "{tmp}/missing.json", "--out", "{tmp}/x.csv"], ExitCode.BAD_INPUT, "judgeopt solve --save-json"),
    # an empty file
    (["solve", "--no-simulate", "--problem", "{tmp}/empty.toml"], ExitCode.BAD_INPUT, 'base = "problems/'),
    (["test-judge", "--data", "{tmp}/empty.h5"], ExitCode.BAD_INPUT, "not a readable HDF5 file"),
    (["export", "{tmp}/empty.json", "--out", "{tmp}/x.csv"], ExitCode.BAD_INPUT, "not valid JSON"),
    # a file of another kind
    (["solve", "--no-simulate", "--problem", "{tmp}/judge.json"], ExitCode.BAD_INPUT, "give one like problems/"),
    (["solve", "--no-simulate", "--method", "amortized", "--calibration", "{tmp}/judge.json"], ExitCode.BAD_INPUT,
     "expected 'judgeopt-calibration'"),
    (["export", "{tmp}/judge.json", "--out", "{tmp}/x.csv"], ExitCode.BAD_INPUT, "expected 'judgeopt-plan'"),
    (["import-demos", "{tmp}/judge.json", "--out", "{tmp}/x.h5"], ExitCode.BAD_INPUT, "nothing imported"),
]


@pytest.mark.parametrize("argv, code, says", FILES)
def test_a_bad_file_is_one_line_naming_the_fix(argv, code, says, files, capsys):
    check(*run(argv, files, capsys), code, says)


def test_a_model_in_a_problem_file_is_found_beside_the_file_from_any_folder(tmp_path, monkeypatch, capsys):
    from judgeopt.planners.problem import load_problem

    shipped = load_problem("paper_sim")
    assert not Path(shipped.judge).is_absolute()  # the shipped files keep their names: `resolve` finds them
    judge = resolve(shipped.judge, (".json",))
    (tmp_path / "models").mkdir()
    for suffix in (".json", ".pt"):
        shutil.copy(judge.with_name(judge.name + suffix), tmp_path / "models" / f"mine{suffix}")
    problem = tmp_path / "p.toml"
    problem.write_text('base = "problems/paper_sim.toml"\n[models]\njudge = "models/mine"\n')
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert load_problem("../p.toml").judge == str(tmp_path / "models" / "mine")
    # planned (the amortised plan is not called likely at 2 %: exit 4; not this test's subject)
    assert main(["solve", "--problem", "../p.toml", "--no-simulate", "--method", "amortized", "--json"]) in PLANNED
    assert json.loads(capsys.readouterr().out)["judge"] == str(tmp_path / "models" / "mine")


def test_every_model_field_of_a_problem_file_is_found_beside_it(tmp_path):
    from judgeopt.planners.problem import SECTIONS, load_problem

    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "x.json").write_text("{}")
    for field in SECTIONS["models"]:
        problem = tmp_path / f"{field}.toml"
        problem.write_text(f'base = "problems/paper_sim.toml"\n[models]\n{field} = "models/x"\n')
        assert getattr(load_problem(problem), field) == str(tmp_path / "models" / "x"), field
        problem.write_text(f'base = "problems/paper_sim.toml"\n[models]\n{field} = "models/elsewhere"\n')
        assert getattr(load_problem(problem), field) == "models/elsewhere", field  # not beside it: as written


def cli(*argv: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "judgeopt.cli", *argv], capture_output=True, text=True, cwd=cwd)


def test_quiet_prints_no_simulator_banner(tmp_path):
    r = cli("solve", "--quiet", "--method", "amortized", cwd=tmp_path)  # replays in PyBullet
    assert r.returncode in (0, 4) and "Traceback" not in r.stderr
    assert "pybullet build time" not in r.stdout + r.stderr


def test_an_error_after_the_simulator_loads_is_still_one_line(tmp_path):
    r = cli("collect", "--out", "x.h5", "--n", "1", "--focus", "missing", cwd=tmp_path)
    err = r.stderr.strip().splitlines()
    assert r.returncode == ExitCode.BAD_INPUT and len(err) == 1 and "judgeopt train-judge" in err[0], err
