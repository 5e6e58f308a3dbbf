"""The fastest scoop the judge stands behind (`objective = "min_time"`): the earliest sample k at
which the motion reaches its terminal state and rests there, with the judge at p_target and every
constraint held.

The plans resting from sample k are a subset of those resting from k + 1 (one at rest from k is
also at rest from k + 1), so success is monotone in k and the earliest k is found by bisection:
first the smallest k the linear constraints allow (a linear program per k, feasible.check),
then direct solves between it and the horizon, each warm-started from the last plan that reached
the target. The judge still reads the whole horizon: the motion, then the rest.
"""

from __future__ import annotations

import time

from judgeopt.planners.base import Planner
from judgeopt.planners.feasible import check
from judgeopt.planners.problem import InfeasibleProblemError
from judgeopt.planners.result import PlanResult, meets_target
from judgeopt.trajectory import Plan

def reached(result: PlanResult, p_target: float) -> bool:
    """A candidate Ipopt solved (every constraint held) at the target."""
    return result.plan is not None and result.status == "solved" and meets_target(result, p_target)


def earliest_linear(direct: Planner, env: dict[str, float]) -> int | None:
    """The smallest k from which the linear constraints allow resting (None: not even at the end)."""
    pr = direct.problem
    ok = lambda k: _linear_ok(direct, env, k)  # noqa: E731
    if not ok(pr.steps):
        return None
    lo, hi = 1, pr.steps
    while lo < hi:
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if ok(mid) else (mid + 1, hi)
    return hi


def _linear_ok(direct: Planner, env: dict[str, float], k: int) -> bool:
    try:
        check(direct.problem, env, rest_from=k)
    except InfeasibleProblemError:
        return False
    return True


def earliest(direct: Planner, env: dict[str, float], guess: Plan | None = None,
             env_set: list[dict[str, float]] | None = None) -> PlanResult:
    """The plan resting earliest with the judge at p_target; info: the time found (`min_time_s`),
    the horizon, the candidates tried. Where even the full horizon does not reach the target, that
    solve's result is returned as it is (its message says so)."""
    t0 = time.perf_counter()
    pr = direct.problem
    n = pr.steps
    lo = earliest_linear(direct, env)
    if lo is None:
        return direct.resting_from(n).solve(env, guess, env_set)  # reports the conflict
    tried: dict[int, PlanResult] = {n: direct.resting_from(n).solve(env, guess, env_set)}
    best_k = n
    if reached(tried[n], pr.p_target):
        hi = n
        while lo < hi:
            mid = (lo + hi) // 2
            tried[mid] = r = direct.resting_from(mid).solve(env, tried[best_k].plan, env_set)
            if reached(r, pr.p_target):
                hi = best_k = mid
            else:
                lo = mid + 1
    best = tried[best_k]
    best.solve_time_s = time.perf_counter() - t0
    best.iterations = sum(r.iterations or 0 for r in tried.values())
    found = reached(best, pr.p_target)
    best.info.update(min_time_s=round(best_k * pr.dt, 9) if found else None, horizon_s=round(n * pr.dt, 9),
                     min_time_tried={f"{k * pr.dt:g}": bool(reached(r, pr.p_target)) for k, r in sorted(tried.items())})
    if found:
        best.message += (f"; min-time: at rest at the terminal state from t = {best_k * pr.dt:g} s of the "
                         f"{n * pr.dt:g} s horizon ({len(tried)} solves)")
    else:
        best.message += f"; min-time: p_target = {pr.p_target:g} not reached even at the horizon's end"
    return best
