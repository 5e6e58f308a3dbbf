"""What a planner of one's own needs to answer as the built-ins answer: plans of the problem's
channels, the judge's probability for them, and a `PlanResult` whose residuals are measured the way
every planner's are (so its rows in `judgeopt solve` and the evaluations compare with theirs).

    class PressHarder(Planner):
        method = "press"

        def solve(self, env, guess=None):
            started = time.perf_counter()
            move = min_jerk_plan(self.problem, env)
            ...
            return plan_result(self, env, plan, started)

The whole planner is in docs/guides/planner.md, run by the tests.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from judgeopt.planners.cold_start import default_guess
from judgeopt.planners.dynamics import plan_from_parts, positions
from judgeopt.planners.problem import Problem, ProblemError
from judgeopt.planners.result import PlanResult, constraint_residuals
from judgeopt.trajectory import Plan, PlanError

if TYPE_CHECKING:
    from judgeopt.judge.model import Judge
    from judgeopt.planners.base import Planner


def min_jerk_plan(problem: Problem, env: Mapping[str, float]) -> Plan:
    """The min-jerk move from the start to the problem's terminal state, pressing at the middle of
    the force limits: the direct solve's own cold start, a plan that holds the limits to begin from."""
    return default_guess(problem, problem.env_dict(dict(env)))


def plan_from_velocities(problem: Problem, qdot: Any, forces: Any) -> Plan:
    """A plan of the problem's channels from velocities at the N + 1 samples ((N + 1,) for one axis,
    or (N + 1, axes)) and forces (one value, one per force channel, (N + 1,) or (N + 1, forces)):
    positions are integrated from q0 by the model every planner shares, so its dynamics hold."""
    n, axes, nf = problem.steps + 1, problem.n_axes, problem.n_forces
    v = np.asarray(qdot, dtype=float)
    v = v[:, None] if v.ndim == 1 else v
    if v.shape != (n, axes):
        raise PlanError(f"velocities of shape {np.shape(qdot)}: give ({n},) or ({n}, {axes}), one row per sample "
                        f"of the {problem.steps}-step horizon, one column per axis")
    f = np.asarray(forces, dtype=float)
    f = f[:, None] if f.ndim == 1 and len(f) == n and nf != n else f
    try:
        f = np.broadcast_to(f, (n, nf))
    except ValueError:
        raise PlanError(f"forces of shape {np.shape(forces)}: give one value, {nf} (one per force channel), ({n},) "
                        f"or ({n}, {nf})") from None
    q = positions(problem.vec("q0")[:, None], v.T, problem.dt).T
    return plan_from_parts(problem, q, v, np.array(f))


def judge_plans(judge: Judge, plans: Sequence[Plan], env: Mapping[str, float]) -> np.ndarray:
    """The judge's probability that each plan succeeds in `env`, in one batched call."""
    missing = [k for k in judge.config.env_names if k not in env]
    if missing:
        raise ProblemError(f"the judge reads {', '.join(missing)}, which the environment {dict(env)} lacks")
    if not plans:
        return np.zeros(0)
    e = np.array([[float(env[k]) for k in judge.config.env_names]] * len(plans))
    return np.asarray(judge.predict_proba(np.stack([p.as_array() for p in plans]), e), dtype=float)


def plan_result(planner: Planner, env: Mapping[str, float], plan: Plan | None, started: float, *,
                status: str | None = None, iterations: int | None = None, message: str = "",
                info: Mapping[str, Any] | None = None) -> PlanResult:
    """`planner`'s answer for `env`, what its `solve` returns: `plan` judged by the planner's judge,
    its residuals measured against the problem's limits (`constraint_residuals`), and the seconds
    since `started` (a `time.perf_counter()` reading taken when `solve` began). `status`: "solved"
    by default, "failed" without a plan (say why in `message`)."""
    problem = planner.problem
    env = problem.env_dict(dict(env))
    extra = dict(info or {})
    if plan is None:
        return PlanResult(planner.method, env, None, None, status or "failed", time.perf_counter() - started,
                          iterations=iterations, message=message, info=extra)
    if tuple(plan.channels) != tuple(problem.channel_spec) or (plan.horizon, plan.dt) != (problem.steps, problem.dt):
        raise PlanError(f"planner {planner.method!r}: its plan ({', '.join(c.name for c in plan.channels)}; "
                        f"{plan.horizon} steps of {plan.dt:g} s) is not of the problem's channels "
                        f"({', '.join(c.name for c in problem.channel_spec)}) and horizon ({problem.steps} steps of "
                        f"{problem.dt:g} s); build it with plan_from_velocities")
    p = float(judge_plans(planner.judge, [plan], env)[0])
    residuals = constraint_residuals(problem, plan, env)
    return PlanResult(planner.method, env, plan, p, status or "solved", time.perf_counter() - started, residuals,
                      iterations, message, info=extra)
