"""The sampling baseline searched by CMA-ES (`cmaes`): it finds a known optimum, is deterministic
per seed and environment, and its plans hold the limits by construction."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from judgeopt.files import resolve
from judgeopt.planners.cmaes_search import CMAESConfig, CMAESPlanner
from judgeopt.planners.problem import load_problem

ENV = {"y_obj": 0.2, "mu": 2.0}


class PeakJudge:
    """A stub judge whose logit is minus the squared distance to one plan: the plan that the knots
    `target` decode to, so the best knots are known by construction."""

    def __init__(self, problem, target: np.ndarray, knots: int):
        self.config = SimpleNamespace(env_names=problem.env_names)
        self.planner = CMAESPlanner(problem, self, CMAESConfig(knots=knots))
        self.peak, _ = self.planner.commands.decode(target[None], problem.terminal_positions(ENV))

    def predict_logit(self, x: np.ndarray, e: np.ndarray) -> np.ndarray:
        return -((x - self.peak) ** 2).sum(axis=(1, 2)) * 100.0

    def predict_proba(self, x: np.ndarray, e: np.ndarray) -> np.ndarray:
        return np.exp(-np.logaddexp(0.0, -self.predict_logit(x, e)))  # the sigmoid, without overflow


@pytest.fixture(scope="module")
def problem():
    return load_problem(resolve("problems/paper_sim.toml"))


@pytest.fixture(scope="module")
def peak(problem):
    # inside [0, 1] and slow enough that no velocity is clipped: the decoded plan is the only optimum
    target = np.array([0.2, 0.35, 0.4, 0.3, 0.25, 0.15, 0.3, 0.7, 0.6, 0.4, 0.5, 0.2])
    return target, PeakJudge(problem, target, knots=6)


def test_cma_finds_the_known_best_knots(problem, peak):
    target, judge = peak
    r = CMAESPlanner(problem, judge, CMAESConfig(population=32, iterations=200)).solve(ENV)
    assert r.status == "sampled" and r.iterations <= 200
    assert np.abs(r.plan.as_array() - judge.peak[0]).max() < 1e-3
    assert r.max_constraint_violation < 1e-9, r.residuals


def test_same_seed_same_plan_other_seed_another(problem, peak):
    _, judge = peak
    cfg = CMAESConfig(population=16, iterations=5)
    a = CMAESPlanner(problem, judge, cfg).solve(ENV)
    planner = CMAESPlanner(problem, judge, cfg)
    planner.solve({"y_obj": 0.12, "mu": 1.2})  # another plan in between changes nothing
    b = planner.solve(ENV)
    c = CMAESPlanner(problem, judge, CMAESConfig(population=16, iterations=5, seed=1)).solve(ENV)
    assert np.array_equal(a.plan.as_array(), b.plan.as_array())
    assert not np.array_equal(a.plan.as_array(), c.plan.as_array())


def test_a_returned_plan_holds_the_limits(problem):
    from judgeopt.judge.store import load_judge

    judge, _ = load_judge(resolve(problem.judge, (".json",)))
    slow = CMAESPlanner(problem, judge, CMAESConfig(population=32, iterations=3)).with_limits(
        problem.with_overrides(qdot_max=0.4, f_min=9.0, f_max=20.0))
    r = slow.solve({"y_obj": 0.25, "mu": 1.5})
    assert r.method == "cmaes" and 0.0 <= r.predicted_success <= 1.0 and r.solve_time_s > 0
    assert r.max_constraint_violation < 1e-9, r.residuals
    assert r.plan.ydot.max() <= 0.4 + 1e-12 and r.plan.ydot.min() >= -0.05 - 1e-12
    assert 9.0 <= r.plan.f.min() and r.plan.f.max() <= 20.0
    assert abs(r.plan.y[-1] - 0.25) < 1e-9 and r.plan.ydot[-1] == 0.0
