"""A verdict on every plan, what would make an unlikely plan likely, and re-planning under other limits."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from judgeopt.files import REPO, resolve
from judgeopt.cli import main
from judgeopt.planners import result as result_module
from judgeopt.planners import suggest as suggest_module
from judgeopt.planners.problem import load_problem
from judgeopt.planners.result import LIKELY, PlanResult, assess
from judgeopt.planners.suggest import relaxations, suggest
from judgeopt.tasks import get_task

RELAXATIONS = relaxations(get_task("scoop"))

ROOT = REPO  # the source checkout


def _result(predicted, **info) -> PlanResult:
    from conftest import min_jerk_plan

    return PlanResult("direct", {"y_obj": 0.2, "mu": 2.0}, min_jerk_plan(-0.03, 0.2, 1.2, 12.0), predicted, "solved",
                      0.1, info=dict(info))


def test_the_probability_stood_behind_is_the_calibrated_one_where_it_exists():
    judged = assess(_result(0.99))
    assert (judged.success_probability, judged.probability_source, judged.verdict) == (0.99, "judge", "likely")
    calibrated = assess(_result(0.99, calibrated_success=0.2, calibration_covers=True))
    assert (calibrated.success_probability, calibrated.probability_source, calibrated.verdict) == (
        0.2, "calibrated", "unlikely")
    outside = assess(_result(0.1, calibrated_success=0.7, calibration_covers=False))  # no extrapolated map
    assert (outside.success_probability, outside.probability_source, outside.verdict) == (0.1, "judge", "unlikely")
    assert assess(_result(LIKELY)).verdict == "likely" and assess(_result(LIKELY - 1e-9)).verdict == "unlikely"
    no_plan = assess(PlanResult("direct", {}, None, None, "infeasible", 0.0))
    assert no_plan.verdict is None and no_plan.to_json()["verdict"] is None


# -- the suggestion search, on a planner whose answer is a known function of the limits ---------------
@dataclasses.dataclass
class FakePlanners:
    """Stands in for Planners: success probability rises with f_max (0.5 at 20 N), not with q̇_max."""

    problem: object
    methods: tuple = ("direct",)
    direct: object = True
    cem: object = None
    amortized: object = None
    calls: list = dataclasses.field(default_factory=list)

    def with_limits(self, **limits):
        return dataclasses.replace(self, problem=self.problem.with_overrides(**limits))

    def solve(self, env, simulator=None, guess=None):
        self.calls.append(self.problem.f_max)
        p = 1.0 / (1.0 + np.exp(-(self.problem.f_max - 20.0)))
        return [assess(_result(float(p)))]


def test_suggest_finds_the_smallest_relaxation_that_makes_a_plan_likely():
    problem = load_problem(resolve("problems/paper_sim.toml")).with_overrides(f_max=12.0)
    planners = FakePlanners(problem)
    found = suggest(planners, {"y_obj": 0.2, "mu": 2.0}, planners.solve({}))
    assert [s.limit for s in found] == ["f_max"]  # q̇_max and f_min change nothing here
    f_max = next(r for r in RELAXATIONS if r.name == "f_max")
    assert 20.0 <= found[0].value <= 20.0 + f_max.resolution  # the first value with p >= 0.5
    assert found[0].result.success_probability >= LIKELY and found[0].p_at_bound > 0.99
    assert "likely with f_max >= " in found[0].text() and found[0].to_json()["limit"] == "f_max"


def test_suggest_says_nothing_when_no_relaxation_helps(monkeypatch):
    problem = load_problem(resolve("problems/paper_sim.toml")).with_overrides(f_max=12.0)
    monkeypatch.setattr(suggest_module, "LIKELY", 1.01)  # nothing is ever likely
    planners = FakePlanners(problem)
    assert suggest(planners, {"y_obj": 0.2, "mu": 2.0}, []) == []
    assert len(planners.calls) == len(RELAXATIONS)  # one screen at each bound, no bisection


# -- the command line ----------------------------------------------------------------------------------
def test_solve_reports_a_verdict_and_its_source(capsys):
    rc = main(["solve", "--qdot-max", "0.4", "--method", "direct", "--json", "--no-simulate"])
    out = json.loads(capsys.readouterr().out)
    (r,) = out["results"]
    assert r["verdict"] in ("likely", "unlikely") and r["probability_source"] in ("calibrated", "judge")
    assert 0.0 <= r["success_probability"] <= 1.0
    assert (rc, out["verdict"]) == ((0, "likely") if r["verdict"] == "likely" else (4, "unlikely"))


@pytest.mark.parametrize("suggest_flag", ["--no-suggest", "--suggest"])
def test_solve_exits_4_and_says_so_in_one_line_when_no_plan_is_likely(monkeypatch, capsys, suggest_flag):
    monkeypatch.setattr(result_module, "LIKELY", 1.01)
    monkeypatch.setattr(suggest_module, "LIKELY", 1.01)
    rc = main(["solve", "--qdot-max", "0.4", "--method", "direct", "--no-simulate", suggest_flag])
    text = capsys.readouterr().out
    assert rc == 4
    verdict_lines = [line for line in text.splitlines() if line.startswith("judgeopt solve: no plan is likely")]
    assert len(verdict_lines) == 1 and "best p = " in verdict_lines[0]
    assert ("no single limit relaxed" in text) == (suggest_flag == "--suggest")


def test_infeasible_stays_exit_3(capsys):
    assert main(["solve", "--qdot-max", "0.1", "--json"]) == 3
    assert json.loads(capsys.readouterr().out)["verdict"] == "infeasible"


# -- re-planning under other limits ----------------------------------------------------------------------
@pytest.mark.slow
def test_with_limits_plans_what_a_fresh_load_for_those_limits_plans():
    from judgeopt.planners.solve import Planners

    problem = load_problem(resolve("problems/paper_sim.toml"))
    env = {"y_obj": 0.2, "mu": 2.0}
    base = Planners.load(problem, ("amortized", "direct"))
    relaxed = base.with_limits(qdot_max=0.5, f_max=20.0).solve(env)
    fresh = Planners.load(problem.with_overrides(qdot_max=0.5, f_max=20.0), ("amortized", "direct")).solve(env)
    assert [r.method for r in relaxed] == [r.method for r in fresh]
    for a, b in zip(relaxed, fresh):
        np.testing.assert_allclose(a.plan.as_array(), b.plan.as_array(), atol=1e-9)
        assert a.info["setting"] == b.info["setting"]
    assert max(relaxed[-1].plan.ydot) <= 0.5 + 1e-6 and max(relaxed[-1].plan.f) <= 20.0 + 1e-6


def test_a_calibration_for_other_models_is_refused_in_one_line(capsys, tmp_path):
    from judgeopt.planners.calibration import save_calibration

    empty = save_calibration(tmp_path / "other.json", {})
    assert main(["solve", "--qdot-max", "0.4", "--method", "direct", "--no-simulate", "--calibration",
                 str(empty)]) == 2
    err = capsys.readouterr().err
    assert "has no calibration for these planners" in err and len(err.strip().splitlines()) == 1
