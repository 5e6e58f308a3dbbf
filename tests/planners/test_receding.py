"""The receding planner: re-solves from the measured state without touching what was measured,
holds every limit on the rest, and executes to a simulated outcome with every re-plan logged."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.files import resolve
from judgeopt.planners.problem import ProblemError, load_problem
from judgeopt.planners.receding import RecedingConfig, RecedingPlanner
from judgeopt.planners.loaded import Planners
from judgeopt.tasks import get_task
from judgeopt.trajectory import Plan

ENV = {"y_obj": 0.19, "mu": 2.0}


@pytest.mark.parametrize("period, message", [(0.07, "multiple of the planner's dt"), (1.5, "shorter than the horizon")])
def test_a_period_the_planner_cannot_keep_is_refused(period, message):
    with pytest.raises(ProblemError, match=message):
        RecedingConfig(period, "always").steps(0.05, 30)
    assert RecedingConfig(0.15, "judge").steps(0.05, 30) == 3
    with pytest.raises(ProblemError, match="choose one of judge, always"):
        RecedingConfig(0.1, "sometimes").steps(0.05, 30)


@pytest.fixture(scope="module")
def setup():
    problem = load_problem(resolve("problems/paper_sim_slow.toml"))
    planners = Planners.load(problem, ("amortized", "direct"))
    sim = get_task("scoop").simulator()
    yield problem, planners, sim
    sim.close()


@pytest.mark.slow
def test_a_re_plan_keeps_the_measured_part_and_holds_the_limits_on_the_rest(setup):
    problem, planners, sim = setup
    first = planners.solve(ENV)[1]
    run = sim.start(first.plan, ENV["y_obj"], ENV["mu"])
    run.advance(first.plan, 9)
    measured = run.measured()  # samples 0..9
    k = len(measured)
    guess = first.plan.values.copy()
    guess[:k] = measured
    r = planners["direct"].with_prefix(measured).solve(ENV, guess=Plan(problem.dt, guess, first.plan.channels))
    assert r.status == "solved"
    x = r.plan.values
    np.testing.assert_allclose(x[1:k], measured[1:], atol=1e-9)  # sample 0's position is the problem's start
    np.testing.assert_allclose(x[:k, 2], measured[:, 2], atol=1e-9)
    rest = x[k:]  # (sample k-1 is measured: the arm may press past f_max for a moment)
    assert rest[:, 1].max() <= problem.qdot_max + 1e-6 and rest[:, 2].min() >= problem.f_min - 1e-6
    assert rest[:, 2].max() <= problem.f_max + 1e-6
    # the plan goes on from the measured state: the trapezoidal step from sample k-1 to k holds
    assert abs(x[k, 0] - x[k - 1, 0] - 0.5 * problem.dt * (x[k - 1, 1] + x[k, 1])) < 1e-6
    assert abs(x[-1, 0] - ENV["y_obj"]) < 1e-6 and abs(x[-1, 1]) < 1e-6


@pytest.mark.slow
def test_a_closed_loop_execution_logs_every_re_plan(setup):
    problem, planners, sim = setup
    first = planners.solve(ENV)[1]
    loop = RecedingPlanner(planners["direct"], RecedingConfig(0.1, "always")).execute(sim, first, ENV,
                                                                                  {**ENV, "y_obj": 0.22})
    assert [r.k for r in loop.replans] == list(range(2, 23, 2))  # every 0.1 s until 0.4 s before the end
    assert all(r.seconds > 0 and r.status != "plan kept" for r in loop.replans)
    # the problem's trigger, the judge: in the world as told it stays convinced, so the plan goes on unchanged
    judged = RecedingPlanner(planners["direct"]).execute(sim, first, ENV, ENV)
    assert [r.status for r in judged.replans] == ["plan kept"] * 11
    assert all(r.predicted >= problem.p_target for r in judged.replans)
    np.testing.assert_array_equal(judged.executed.values, first.plan.values)
    np.testing.assert_array_equal(loop.executed.values[:2], first.plan.values[:2])  # carried out before any re-plan
    assert loop.response.shape == (31, 3) and isinstance(loop.outcome.success, bool)


@pytest.mark.slow
def test_solve_receding_in_a_world_unlike_the_one_told(tmp_path, capsys):
    import json

    assert main(["solve", "--problem", "problems/paper_sim_slow.toml", "--method", "receding", "--simulate-env",
                 "y_obj=0.22", "--replan-trigger", "always", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [r["method"] for r in out["results"]] == ["direct", "receding"]  # receding is built on the direct solve
    rec = out["results"][1]
    assert rec["status"] == "executed" and rec["simulated_success"] is not None
    assert main(["solve", "--method", "receding", "--no-simulate"]) == 2
    assert "plans while the plan is executed in simulation; drop --no-simulate" in capsys.readouterr().err
    assert main(["solve", "--method", "receding", "--simulate-env", "y_obj=9"]) == 2
    assert "outside the scoop scene's physical range" in capsys.readouterr().err
