"""The direct solve's cold start: the task's own commands, fitted to the problem's limits."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.files import REPO, resolve
from judgeopt.planners.cold_start import cold_start, default_guess, fit_to_limits
from judgeopt.planners.problem import load_problem
from judgeopt.planners.result import constraint_residuals
from judgeopt.tasks import get_task


@pytest.mark.parametrize("name", ["problems/paper_sim_slow.toml", "problems/scrape.toml"])
def test_a_fitted_command_holds_the_limits_the_start_and_the_shared_model(name):
    problem = load_problem(resolve(name)).with_overrides(qdot_max=0.3)
    env = problem.nominal_env()
    raw = get_task(problem.task).random_command(np.random.default_rng(1), env)
    plan = fit_to_limits(problem, raw)
    r = constraint_residuals(problem, plan, env)
    assert max(r[k] for k in ("qdot_min", "qdot_max", "f_min", "f_max", "start", "qdot_end")) == 0.0, r
    assert r["dynamics"] < 1e-15


def test_cold_start_keeps_a_min_jerk_move_the_judge_accepts_and_else_takes_the_judges_best():
    from judgeopt.judge.store import load_judge

    problem = load_problem(resolve("problems/scrape.toml"))
    judge = load_judge(REPO / "models" / "scrape" / "judge_refined")[0]
    env = problem.nominal_env()
    mj = default_guess(problem, env)
    e = np.array([[env[k] for k in judge.config.env_names]])
    lj = float(judge.predict_logit(mj.as_array()[None], e)[0])
    kept, how = cold_start(problem, env, judge, mj, target_logit=lj - 1.0)
    assert kept is mj and how == "min-jerk guess"
    best, how = cold_start(problem, env, judge, mj, target_logit=lj + 1.0)
    assert float(judge.predict_logit(best.as_array()[None], e)[0]) >= lj
    again, _ = cold_start(problem, env, judge, mj, target_logit=lj + 1.0)
    assert np.array_equal(again.as_array(), best.as_array())  # seeded: the same start every time
