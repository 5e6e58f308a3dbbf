"""The planners on a task with two position axes (the scrape): shapes, limits and the shared
point-mass model hold per axis, for the direct solve, the generator and the CEM."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from judgeopt.judge.casadi_fn import build_casadi_judge
from judgeopt.judge.model import Judge, JudgeConfig
from judgeopt.planners.cem import CEMConfig, CEMPlanner
from judgeopt.planners.cold_start import default_guess
from judgeopt.planners.direct import DirectPlanner
from judgeopt.planners.generator import AmortizedPlanner, Generator
from judgeopt.planners.problem import ProblemError, load_problem
from judgeopt.planners.result import constraint_residuals

PROBLEM = "problems/scrape.toml"


def scrape_problem(**overrides):
    from judgeopt.files import resolve

    return load_problem(resolve(PROBLEM)).with_overrides(steps=8, **overrides)


def tiny_judge(problem) -> Judge:
    """An untrained judge that prefers ending far along y: enough to give the solver a gradient."""
    torch.manual_seed(0)
    m = Judge(JudgeConfig(horizon=problem.steps, env_names=problem.env_names, channels=problem.channels,
                          units={c.name: c.unit for c in problem.channel_spec}, lstm_units=8, fc_units=8))
    rng = np.random.default_rng(0)
    m.fit_normalization(rng.normal(0.1, 0.1, (20, problem.steps + 1, len(problem.channels))),
                        rng.uniform(0.2, 0.5, (20, len(problem.env_names))))
    return m.eval()


def test_problem_values_per_axis_are_checked():
    p = scrape_problem()
    assert p.n_axes == 2 and p.n_forces == 1 and p.channels == ("x", "y", "xdot", "ydot", "f")
    assert np.isnan(p.terminal_positions(p.nominal_env())).all()  # both ends free
    with pytest.raises(ProblemError, match="has 3 values; task 'scrape' has 2 position axes"):
        scrape_problem(q_max=[0.4, 0.2, 0.1])
    with pytest.raises(ProblemError, match="q_end = 'z_obj'.* must be a number, \"free\" or an environment variable"):
        scrape_problem(q_end=["free", "z_obj"])
    p = scrape_problem(q_end=[0.30, "y_obj"])  # an end fixed by a number and one by the environment
    assert p.terminal_positions({"x_obj": 0.3, "y_obj": 0.12, "mu": 0.4}).tolist() == [0.30, 0.12]


def test_direct_solve_holds_every_axis_limit_and_end():
    p = scrape_problem(q_end=[0.32, "y_obj"], qdot_max=[0.3, 0.6])
    judge = tiny_judge(p)
    planner = DirectPlanner(p, judge, build_casadi_judge(judge, "native"))
    env = {"x_obj": 0.3, "y_obj": 0.12, "mu": 0.4}
    r = planner.solve(env)
    assert r.status == "solved", r.message
    assert r.plan.values.shape == (9, 5) and [c.name for c in r.plan.channels] == list(p.channels)
    assert max(r.residuals.values()) < 1e-6, r.residuals
    assert r.plan.x[-1] == pytest.approx(0.32, abs=1e-6) and r.plan.y[-1] == pytest.approx(0.12, abs=1e-6)
    assert r.plan.xdot.max() <= 0.3 + 1e-6
    guess = default_guess(p, env)
    assert constraint_residuals(p, guess, env)["dynamics"] < 1e-12


def test_generator_rollout_and_numpy_plan_agree_for_two_axes():
    p = scrape_problem()
    judge = tiny_judge(p)
    gen = Generator(p).eval()
    env = {"x_obj": 0.25, "y_obj": 0.14, "mu": 0.6}
    with torch.no_grad():
        x = gen.rollout(torch.tensor([[env[k] for k in p.env_names]]))[0].numpy()
    plan = AmortizedPlanner(gen, p, judge).plan(env)
    assert x.shape == (9, 5)
    np.testing.assert_allclose(plan.values, x, atol=1e-5)
    r = AmortizedPlanner(gen, p, judge).solve(env)
    assert r.residuals["dynamics"] < 1e-9 and r.residuals["start"] < 1e-12


def test_cem_plans_stay_within_the_limits_on_both_axes():
    p = scrape_problem(q_end=[0.28, "free"])
    judge = tiny_judge(p)
    r = CEMPlanner(p, judge, CEMConfig(population=32, iterations=2)).solve({"x_obj": 0.3, "y_obj": 0.12, "mu": 0.4})
    assert r.plan.values.shape == (9, 5)
    res = r.residuals
    assert res["qdot_max"] == 0 and res["qdot_min"] == 0 and res["f_max"] == 0 and res["dynamics"] < 1e-12
    assert res["q_end"] < 1e-6  # the x end holds by construction; y is free
