"""A planner added in a few lines is a --method choice, a row of `evaluate planners` and a
calibration setting, with nothing else changed."""

from __future__ import annotations

import json
import time

import pytest

from judgeopt.cli import main
from judgeopt.planners.base import REGISTRY, Planner, PlannerSpec, register, unregister, with_uses
from judgeopt.planners.cold_start import default_guess
from judgeopt.planners.problem import ProblemError
from judgeopt.planners.result import PlanResult, constraint_residuals


class Straight(Planner):
    """The min-jerk move to the terminal state, pressing at the middle force: no judge involved."""

    method = "straight"

    def __init__(self, problem, judge):
        self.problem, self.judge = problem, judge

    def solve(self, env, guess=None):
        t0 = time.perf_counter()
        plan = default_guess(self.problem, env)
        p = float(self.judge.predict_proba(plan.as_array()[None], [[env[k] for k in self.judge.config.env_names]])[0])
        return PlanResult(self.method, env, plan, p, "solved", time.perf_counter() - t0,
                          constraint_residuals(self.problem, plan, env))

    def with_limits(self, problem):
        return Straight(problem, self.judge)


@pytest.fixture
def straight():
    register(PlannerSpec("straight", "the min-jerk move", build=Straight))
    yield
    unregister("straight")


def test_the_built_ins_are_registered_and_names_are_checked():
    assert list(REGISTRY)[:4] == ["amortized", "direct", "cem", "receding"]
    assert REGISTRY["receding"].closed_loop and REGISTRY["receding"].uses == ("direct",)
    assert with_uses(["receding", "cem"]) == ("direct", "receding", "cem")
    for bad in ("direct", "both", "receding", "two words"):
        with pytest.raises(ProblemError, match="taken or not a plain name"):
            register(PlannerSpec(bad, "x"))


@pytest.mark.slow
def test_a_registered_planner_runs_through_solve_and_evaluate(straight, tmp_path, capsys):
    assert main(["solve", "--method", "straight", "--no-simulate", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    (r,) = out["results"]
    assert r["method"] == "straight" and r["status"] == "solved" and r["verdict"] in ("likely", "unlikely")
    assert main(["evaluate", "planners", "--methods", "straight", "--n", "2", "--jobs", "1", "--quiet",
                 "--out", str(tmp_path)]) == 0
    report = (tmp_path / "planners.md").read_text()
    assert "| straight |" in report
    with pytest.raises(SystemExit) as exc:  # an unregistered name is a usage error
        main(["solve", "--method", "nowhere"])
    assert exc.value.code == 2
