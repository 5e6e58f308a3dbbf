"""What the main command says is true of the run: the problem's description states no limit that an
option changed, and without the `sim` extra the error names the way to plan without it."""

from __future__ import annotations

import json
import re
import subprocess
import sys

from judgeopt.cli import main
from judgeopt.cli.common import ExitCode
from judgeopt.files import REPO
from judgeopt.planners.problem import load_problem

#: what a command that made a plan returns, likely or not (exit 4: none likely)
PLANNED = (ExitCode.OK, ExitCode.UNLIKELY)

PROBLEMS = sorted((REPO / "judgeopt" / "tasks").glob("*/problems/*.toml"))
LIMITS = ("q0", "qdot0", "q_min", "q_max", "qdot_min", "qdot_max", "f_min", "f_max", "end_margin")


def test_json_problem_description_states_no_limit_the_option_changed(capsys):
    assert main(["solve", "--qdot-max", "0.4", "--no-simulate", "--json", "--method", "amortized"]) in PLANNED
    problem = json.loads(capsys.readouterr().out)["problem"]
    assert problem["qdot_max"] == 0.4  # the limit in force
    assert problem["name"] == "paper_sim" and problem["description"]
    assert "1.0 m/s" not in problem["description"] and not re.search(r"\d\s*m/s", problem["description"])


def test_no_shipped_problem_description_names_a_limit_value():
    """A limit stated in the description goes stale as soon as an option or override changes the field."""
    assert PROBLEMS
    for path in PROBLEMS:
        p = load_problem(path)
        text = p.description
        assert not re.search(r"(qdot|q̇|f)_?(max|min)?\s*(=|within)\s*[±\d]", text), (path.name, text)
        assert not re.search(r"\d\s*(m/s|N\b|m\b)", text), (path.name, text)


def test_solve_without_the_sim_extra_names_no_simulate(tmp_path):
    code = ("import sys; sys.modules['pybullet'] = None\n"
            "from judgeopt.cli import main; sys.exit(main(['solve', '--qdot-max', '0.4', '--method', 'amortized']))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == ExitCode.MISSING
    assert "pip install 'judgeopt[sim]'" in r.stderr and "--no-simulate" in r.stderr and "Traceback" not in r.stderr


def test_the_hint_is_only_where_the_command_has_the_option():
    from judgeopt.cli.common import missing_extra, set_argv

    exc = ModuleNotFoundError("No module named 'pybullet'", name="pybullet")
    try:
        set_argv(["collect", "--out", "x.h5"])
        assert "--no-simulate" not in missing_extra(exc)
        set_argv(["solve"])
        assert "--no-simulate" in missing_extra(exc)
    finally:
        set_argv(None)
