"""`judgeopt export`: a saved plan out as CSV or MCAP; refusals and bad files in one line."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.files import resolve
from judgeopt.formats.plan import plan_provenance, plan_record, write_record
from judgeopt.planners.problem import load_problem
from judgeopt.planners.result import PlanResult
from judgeopt.tasks import get_task


@pytest.fixture
def plan_json(tmp_path):
    problem = load_problem(resolve("problems/scrape.toml"))
    task = get_task(problem.task)
    env = problem.nominal_env()
    plan = task.plan(task.random_command(np.random.default_rng(1), env))
    result = PlanResult("direct", env, plan, 0.8, "solved", 0.1, success_probability=0.8, probability_source="judge")
    return write_record(plan_record(result, problem, plan_provenance(None, None, command="test")), tmp_path / "p.json")


def test_export_csv_then_refuses_to_replace_it(plan_json, tmp_path, capsys):
    out = tmp_path / "p.csv"
    assert main(["export", str(plan_json), "--out", str(out)]) == 0
    assert out.read_text().splitlines()[0] == "t,x,y,xdot,ydot,f,x_obj,y_obj,mu"
    before = out.read_text()
    capsys.readouterr()
    assert main(["export", str(plan_json), "--out", str(out), "--step", "0.01"]) != 0
    err = capsys.readouterr().err
    assert "exists" in err and "--overwrite" in err and out.read_text() == before
    assert main(["export", str(plan_json), "--out", str(out), "--step", "0.01", "--overwrite"]) == 0
    assert len(out.read_text().splitlines()) == 1 + 151


def test_export_mcap(plan_json, tmp_path):
    pytest.importorskip("rosbags")
    assert main(["export", str(plan_json), "--format", "mcap", "--out", str(tmp_path / "p.mcap")]) == 0
    assert (tmp_path / "p.mcap").read_bytes()[:5] == b"\x89MCAP"


@pytest.mark.parametrize("content, out, message", [
    (None, "p.txt", "cannot tell the format from the suffix '.txt'"),
    ('{"format": "judgeopt-plan", "format_version": 2', "p.csv", "corrupt plan file, not valid JSON"),
    ('{"format": "something else"}', "p.csv", "not a judgeopt plan file"),
])
def test_bad_input_is_one_line(plan_json, tmp_path, capsys, content, out, message):
    if content is not None:
        plan_json.write_text(content)
    assert main(["export", str(plan_json), "--out", str(tmp_path / out)]) != 0
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err and not (tmp_path / out).exists()
