"""`judgeopt solve`'s problem options: the simulated world's values by name."""

from __future__ import annotations

import argparse

import pytest

from judgeopt.cli import main
from judgeopt.cli.main import build_parser
from judgeopt.cli.planners import problem_from_args


def solve_parser() -> argparse.ArgumentParser:
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices["solve"]


@pytest.mark.parametrize("argv", [["--mu", "2"], ["--env", "mu=2"]])
def test_a_variable_the_judge_does_not_read_sets_the_simulated_world(argv):
    problem = problem_from_args(solve_parser().parse_args(["--problem", "problems/paper_real.toml", *argv]))
    assert problem.environment == {"y_obj": 0.246} and problem.world == {"mu": 2.0}


def test_a_variable_of_no_task_is_refused(capsys):
    assert main(["solve", "--problem", "problems/paper_real.toml", "--env", "x_obj=0.1", "--no-simulate"]) == 2
    assert "not an environment variable of task 'scoop'" in capsys.readouterr().err


@pytest.mark.parametrize("args, says", [
    (["--problem", "{tmp}"], "is a folder; give a problem file"),
    (["--plot", "{tmp}", "--overwrite"], "is a folder; give an image file"),
    (["--plot", "{tmp}/plan.jpgx"], "the suffix picks the format"),
    (["--qdot-max", "nan"], "expected a finite number"),
    (["--f-max", "inf"], "expected a finite number"),
    (["--f-min", "-5"], "must not be negative"),
    (["--f-min", "30"], "changed from"),  # the file is fine: the message blames the change, not the file
])
def test_bad_solve_input_is_one_line_before_any_planning(args, says, tmp_path, capsys):
    from judgeopt.cli.main import main

    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    try:
        rc = main(["solve", "--no-simulate", "--method", "amortized", *args])
    except SystemExit as exc:  # argparse's usage errors
        rc = exc.code
    err = capsys.readouterr().err.strip().splitlines()
    assert rc not in (0, 1) and len(err) == 1 and says in err[0], err


@pytest.mark.parametrize("args", [["evaluate", "edge", "--qdot-max", "0.4,nan"], ["evaluate", "edge", "--edge-span", "10,inf"],
                                  ["evaluate", "sweep", "--vary", "mu=1,nan"]])
def test_no_number_option_takes_nan_or_inf(args, capsys):
    from judgeopt.cli.main import main

    with pytest.raises(SystemExit) as exc:
        main(args)
    err = capsys.readouterr().err.strip().splitlines()
    assert exc.value.code == 2 and len(err) == 1 and ("nan" in err[0] or "inf" in err[0]), err
