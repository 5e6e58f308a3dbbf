"""[constraints] on the command line and in problem files (issue 36): each bad input is exactly one
line on stderr naming the fix, exit 2 (a bad option or value) or 5 (a bad file), no traceback; an
infeasible set exits 3 before any solver runs, says "infeasible" and names both constraints of the
pair; a problem file's [constraints] is read and held by the plan it gives."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.errors import ExitCode

SOLVE = ["solve", "--no-simulate", "--method", "direct", "--no-suggest"]


def run(argv: list[str], capsys) -> tuple[int, list[str]]:
    """The CLI in this process: its exit code and its stderr lines."""
    try:
        rc = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse's usage errors
        rc = exc.code
    return rc, capsys.readouterr().err.strip().splitlines()


def one_line(rc: int, err: list[str], code: int, *says: str) -> None:
    assert rc == code and len(err) == 1 and "Traceback" not in err[0], (rc, err)
    for s in says:
        assert s in err[0], (s, err[0])


BAD = [  # (options, what the one line says: the fix)
    (["--bound", "f:12:0"], ["bound f:12:0: LO = 12 is above HI = 0; swap them"]),
    (["--bound", "f:0:12@0:9"], ["window [0, 9] s lies outside the horizon [0, 1.5] s", "give T0:T1 within it"]),
    (["--bound", "f:0:12@-0.5:0.4"], ["lies outside the horizon", "give T0:T1 within it"]),
    (["--bound", "f:0:12@0.4:0.2"], ["give T0 <= T1"]),
    (["--bound", "zz:0:1"], ["no channel 'zz'", "the task's channels are y, ydot, f"]),
    (["--bound", "f:0"], ["must read NAME:LO:HI@T0:T1", "e.g. f:0:12@0:0.4"]),
    (["--bound", "f:0:12@0.01:0.04"], ["no sample (every 0.05 s) lies in the window; widen it"]),
    (["--joint-limit-scale", "0"], ["joint_limit_scale = 0.0 must be a positive number"]),
    (["--joint-limit-scale", "-0.5"], ["joint_limit_scale = -0.5 must be a positive number"]),
    (["--objective", "min-time", "--q-end", "free"], ["objective = min_time", "needs a terminal position",
                                                      "set q_end"]),
    (["--a-max", "0"], ["a_max = 0.0 must be a positive number"]),
    (["--jerk-max", "-1"], ["jerk_max = -1.0 must be a positive number"]),
    (["--fdot-max", "nan"], ["fdot_max", "must be a positive number"]),
    (["--fdot-max", "20,30"], ["fdot_max = [20.0, 30.0] has 2 values; give one, or one for each of 1"]),
    (["--a-max", "fast"], ["--a-max", "expected a finite number or comma-separated numbers"]),
]


@pytest.mark.parametrize("options, says", BAD, ids=[" ".join(o) for o, _ in BAD])
def test_a_bad_constraint_on_the_command_line_is_one_line_naming_the_fix(options, says, capsys):
    one_line(*run(SOLVE + options, capsys), ExitCode.USAGE, *says)


INFEASIBLE = [  # (options, the two constraints named)
    (["--bound", "f:0:5"], ["limits.f_min/f_max", "bound f:0:5"]),  # against f_min 7.5 N
    (["--bound", "y:0.3:0.4@1.5:1.5"], ["terminal.q_end", "bound y:0.3:0.4@1.5:1.5"]),  # against y_obj = 0.19 m
    (["--bound", "ydot:1.2:2@0.5:0.6"], ["limits.qdot_min/qdot_max", "bound ydot:1.2:2@0.5:0.6"]),
    (["--bound", "f:8:10@0:0.5", "--bound", "f:20:22@1:1.5", "--fdot-max", "15"],
     ["constraints.fdot_max = 15", "bound f:8:10@0:0.5", "bound f:20:22@1:1.5"]),  # 10 N in 0.5 s: 20 N/s
    (["--bound", "y:0:0.1@0:0.2"], ["bound y:0:0.1@0:0.2", "the start state"]),  # y_0 = q0 = -0.03
]


@pytest.mark.parametrize("options, named", INFEASIBLE, ids=[" ".join(o) for o, _ in INFEASIBLE])
def test_an_infeasible_set_exits_3_naming_the_pair(options, named, capsys):
    rc, err = run(SOLVE + options, capsys)
    one_line(rc, err, ExitCode.INFEASIBLE, "infeasible", *named)


def test_an_infeasible_set_in_json_names_the_pair(capsys):
    """--json: one object on stdout with the error, exit 3 (the same check)."""
    try:
        rc = main(SOLVE + ["--bound", "f:0:5", "--json"])
    except SystemExit as exc:
        rc = exc.code
    out = capsys.readouterr().out
    assert rc == ExitCode.INFEASIBLE
    assert "infeasible" in out and "bound f:0:5" in out and "limits.f_min/f_max" in out


# -- problem files -------------------------------------------------------------------------------
def write(tmp_path: Path, body: str, name: str = "p.toml") -> Path:
    path = tmp_path / name
    path.write_text('base = "problems/paper_sim.toml"\n' + body)
    return path


@pytest.mark.parametrize("body, says", [
    ('[constraints]\nbounds = "f:0:1"\n', "bounds = 'f:0:1' must be a list of NAME:LO:HI@T0:T1 strings"),
    ("[constraints]\nsnap_max = 3\n", "unknown key 'snap_max' in [constraints]"),
    ('[constraints]\nbounds = ["f:1:0"]\n', "swap them"),
    ('[constraints]\nbounds = ["f:0:1@0:2"]\n', "lies outside the horizon"),
    ("[constraints]\njoint_limit_scale = 0\n", "joint_limit_scale = 0 must be a positive number"),
    ("[constraints]\na_max = -2\n", "a_max = -2 must be a positive number"),
    ('[constraints]\na_max = "fast"\n', "a_max = 'fast' must be a positive number"),
    ("[constraints]\na_max = 2\n[solver]\nobjective = \"min_time\"\n[terminal]\nq_end = \"free\"\n",
     "needs a terminal position"),
    ("[limits]\na_max = 2\n", "a_max belongs in [constraints], not [limits]"),
    ('constraints = "a_max"\n', "[constraints] must be a table"),
])
def test_a_malformed_constraints_section_is_one_line_naming_the_file(tmp_path, body, says, capsys):
    path = write(tmp_path, body)
    one_line(*run(SOLVE + ["--problem", path], capsys), ExitCode.BAD_INPUT, str(path), says)


def test_an_infeasible_set_from_a_problem_file_exits_3(tmp_path, capsys):
    """The file's bound is read: it is the one named."""
    path = write(tmp_path, '[constraints]\nbounds = ["f:0:5@0.5:1"]\n')
    one_line(*run(SOLVE + ["--problem", path], capsys), ExitCode.INFEASIBLE, "infeasible", "limits.f_min/f_max",
             "bound f:0:5@0.5:1")


def test_a_command_line_bound_is_added_to_the_files(tmp_path, capsys):
    """--bound adds to the file's bounds (the file's f:0:12@0:0.4 is kept: with the added
    f:20:22@0.45:0.45 and fdot_max 60 the pair 12 -> 20 N in one 0.05 s step needs 160 N/s)."""
    path = write(tmp_path, '[constraints]\nfdot_max = 60\nbounds = ["f:0:12@0:0.4"]\n')
    rc, err = run(SOLVE + ["--problem", path, "--bound", "f:20:22@0.45:0.45"], capsys)
    one_line(rc, err, ExitCode.INFEASIBLE, "infeasible", "constraints.fdot_max = 60", "bound f:0:12@0:0.4",
             "bound f:20:22@0.45:0.45")


def test_a_problem_files_constraints_are_read_and_held(tmp_path, capsys):
    """[constraints] a_max 2, fdot_max 60, f <= 12 N over 0-0.4 s, with --qdot-max 0.4: the plan
    written holds each (checked on its samples here), and the record names them."""
    path = write(tmp_path, '[constraints]\na_max = 2.0\nfdot_max = 60\nbounds = ["f:0:12@0:0.4"]\n')
    out = tmp_path / "plan.json"
    rc, err = run(SOLVE + ["--problem", path, "--qdot-max", "0.4", "--save-json", out], capsys)
    assert rc in (ExitCode.OK, ExitCode.UNLIKELY), err
    record = json.loads(out.read_text())
    assert {k: record["problem"][k] for k in ("a_max", "fdot_max", "bounds")} == {
        "a_max": 2.0, "fdot_max": 60, "bounds": ["f:0:12@0:0.4"]}
    plan = record["plan"]
    dt = 0.05
    ydot, f = (np.asarray(plan[k], float) for k in ("ydot", "f"))
    assert np.abs(np.diff(ydot) / dt).max() <= 2.0 + 1e-6
    assert np.abs(np.diff(f) / dt).max() <= 60 + 1e-6
    assert f[:9].max() <= 12 + 1e-6  # samples 0..8: t = 0 to 0.4 s
    assert ydot.max() <= 0.4 + 1e-6
