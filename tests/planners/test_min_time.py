"""min-time's search (judgeopt.planners.min_time) against answers known by construction, without
Ipopt: a stand-in for the direct solve whose candidate resting from sample k reaches the target
exactly when k >= K (K chosen by the test), over a real problem whose linear constraints allow
resting from sample 22 on (a_max 1, 0.28 m rest to rest: a_max T² / 4 >= 0.28 m first at T = 1.1 s).
The earliest time is then max(22, K) samples, found by bisection, and everything the result
reports (time, candidates tried, iterations, message) is checked against that figure."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from judgeopt.planners import min_time
from judgeopt.planners.min_time import earliest, earliest_linear, reached
from judgeopt.planners.result import TARGET_TOL as REACHED_TOL
from judgeopt.planners.problem import Problem
from judgeopt.planners.result import PlanResult
from judgeopt.tasks import get_task
from judgeopt.trajectory import Plan

ENV = {"y_obj": 0.25, "mu": 2.0}
PROBLEM = Problem(objective="min_time", a_max=1.0)  # p_target 0.98, 30 steps of 0.05 s
LINEAR = 22  # the first sample the linear constraints allow resting from (test_constraints.py, by hand)


def plan_for(k: int) -> Plan:
    """A stand-in plan that remembers which candidate made it (its force column)."""
    z = np.zeros(PROBLEM.steps + 1)
    return Plan.from_columns(PROBLEM.dt, get_task("scoop").channels, z, z, np.full(PROBLEM.steps + 1, float(k)))


class Fake:
    """The direct solve's interface to min-time: `problem`, `resting_from(k).solve(env, guess,
    env_set)`. A candidate reaches the target (p = 0.99) iff k >= K, else p = 0.5; a solve that
    reaches it reports 3 iterations, one that does not reports none (None); every call is recorded
    (k, the guess's candidate, env_set) and must be given the environment min-time was given."""

    def __init__(self, K: int, problem: Problem = PROBLEM, status: str = "solved"):
        self.K, self.problem, self.status, self.calls, self._k = K, problem, status, [], None

    def resting_from(self, k: int) -> "Fake":
        new = Fake(self.K, self.problem, self.status)
        new.calls, new._k = self.calls, k
        return new

    def solve(self, env, guess=None, env_set=None) -> PlanResult:
        k = self._k
        assert env == ENV, env
        self.calls.append((k, None if guess is None else int(guess.values[0, 2]), env_set))
        p = 0.99 if k >= self.K else 0.5
        return PlanResult("direct", env, plan_for(k), p, self.status, 0.0, iterations=3 if k >= self.K else None,
                          message=f"Ipopt: k={k}")


def result(p, status="solved", plan=True) -> PlanResult:
    return PlanResult("direct", ENV, plan_for(1) if plan else None, p, status, 0.0)


# -- reached ----------------------------------------------------------------------------------------
def test_reached_needs_a_solved_plan_at_the_target_within_its_tolerance():
    """p_target 0.98, tolerance 1e-3: 0.979 exactly (p_target - tolerance) counts, 0.9789 does not;
    no plan, another status or no prediction never counts."""
    assert REACHED_TOL == 1e-3
    assert reached(result(0.98), 0.98) and reached(result(1.0), 0.98)
    assert reached(result(0.98 - REACHED_TOL), 0.98)
    assert reached(result(0.9791), 0.98)
    assert not reached(result(0.9789), 0.98)
    assert not reached(result(0.99, plan=False), 0.98)
    assert not reached(result(0.99, status="not_converged"), 0.98)
    assert not reached(result(0.99, status="infeasible"), 0.98)
    assert not reached(result(None), 0.98)


# -- earliest_linear: a linear program per candidate ------------------------------------------------
@pytest.mark.parametrize("y_obj, k", [(0.25, LINEAR), (0.12, 16), (0.115, 16), (0.1, 15)])
def test_earliest_linear_is_the_hand_figure(y_obj, k):
    """Rest to rest under a_max 1 over D = y_obj + 0.03 m. An even k: bang-bang switching on a
    sample covers (k dt)² / 4 exactly; an odd k: 7 steps up, one at the top, 7 down covers (for
    k = 15) 0.06125 + 0.0175 + 0.06125 = 0.14 m by the trapezoid rule. D = 0.28: k = 22 (1.1 s:
    0.3025 m; 21 samples: 0.2756 m at best); D = 0.15 and 0.145: k = 16 (0.16 m), 15 (0.14 m) is
    short; D = 0.13: k = 15. k = 16 is what a bisection of [1, 30] reaches only by mid + 1."""
    env = {"y_obj": y_obj, "mu": 2.0}
    assert earliest_linear(Fake(0), env) == k


def test_earliest_linear_at_the_start_is_sample_1():
    """Already at the end (y_obj = q0 = -0.03 m, at rest): resting from sample 1, the earliest there is."""
    assert earliest_linear(Fake(0), {"y_obj": -0.03, "mu": 2.0}) == 1


def test_earliest_linear_at_the_last_sample():
    """a_max such that the reach a_max T² / 4 over the whole 1.5 s just covers 0.28 m (a_max 0.5:
    0.28125 m) and 1.45 s does not (0.2628 m): sample 30."""
    pr = PROBLEM.with_overrides(a_max=0.5)
    assert earliest_linear(Fake(0, pr), ENV) == 30


def test_earliest_linear_none_when_not_even_the_horizon_allows_it():
    """a_max 0.4: 0.225 m in 1.5 s, short of 0.28 m: None, and min-time's result is that of the
    full-horizon candidate (the solve reports the conflict)."""
    pr = PROBLEM.with_overrides(a_max=0.4)
    fake = Fake(0, pr)
    assert earliest_linear(fake, ENV) is None
    r = earliest(fake, ENV, plan_for(99), env_set=[ENV])
    assert fake.calls == [(30, 99, [ENV])] and r.message == "Ipopt: k=30"  # the guess and the set passed on
    assert "min_time_s" not in r.info


# -- earliest: the bisection over direct solves ------------------------------------------------------
@pytest.mark.parametrize("K", [0, 21, 22, 23, 25, 29, 30])
def test_earliest_is_the_later_of_the_linear_and_the_judges_earliest(K):
    """The time is max(22, K) samples: never below what the linear constraints allow, never below
    what the judge asks for; the plan returned is that candidate's."""
    fake = Fake(K)
    r = earliest(fake, ENV)
    k = max(LINEAR, K)
    assert r.info["min_time_s"] == pytest.approx(k * 0.05, abs=1e-12)
    assert r.info["horizon_s"] == pytest.approx(1.5)
    assert int(r.plan.values[0, 2]) == k
    tried = [c[0] for c in fake.calls]
    assert tried[0] == 30 and len(set(tried)) == len(tried)  # the horizon first, none twice
    assert all(LINEAR <= t <= 30 for t in tried)
    assert r.info["min_time_tried"] == {f"{t * 0.05:g}": t >= K for t in sorted(tried)}
    assert r.iterations == 3 * sum(t >= K for t in tried)  # None counts as 0
    assert r.message == (f"Ipopt: k={k}; min-time: at rest at the terminal state from t = {k * 0.05:g} s of "
                         f"the 1.5 s horizon ({len(tried)} solves)")
    assert r.solve_time_s >= 0.0


def test_the_bisection_takes_logarithmically_many_solves_each_warm_started_from_the_best_so_far():
    """K = 25, candidates 22-30: the horizon, then 26, 24, 25 (bisection of [22, 30]); each after the
    first starts from the latest candidate that reached the target (30, then 26, then 26, then 25)."""
    fake = Fake(25)
    guess = plan_for(99)
    r = earliest(fake, ENV, guess, env_set=[ENV])
    assert [c[0] for c in fake.calls] == [30, 26, 24, 25]
    assert [c[1] for c in fake.calls] == [99, 30, 26, 26]
    assert all(c[2] == [ENV] for c in fake.calls)  # the environment set passed on to each solve
    assert r.info["min_time_s"] == pytest.approx(1.25)


def test_a_target_not_reached_at_the_horizon_is_said_and_no_time_given():
    """K beyond the horizon: only the full horizon is tried; its result comes back with no time
    and a message saying the target was not reached."""
    fake = Fake(31)
    r = earliest(fake, ENV)
    assert [c[0] for c in fake.calls] == [30]
    assert r.info["min_time_s"] is None and r.info["min_time_tried"] == {"1.5": False}
    assert r.message == "Ipopt: k=30; min-time: p_target = 0.98 not reached even at the horizon's end"
    assert r.iterations == 0


def test_an_unsolved_horizon_candidate_is_not_a_time():
    """Every candidate 'not_converged' (p 0.99 notwithstanding): no time."""
    fake = Fake(0, status="not_converged")
    r = earliest(fake, ENV)
    assert r.info["min_time_s"] is None and [c[0] for c in fake.calls] == [30]


def test_the_search_time_covers_every_solve(monkeypatch):
    """solve_time_s is the whole search's: the clock read before the first solve and after the last."""
    ticks = iter([100.0, 107.5])
    monkeypatch.setattr(min_time, "time", SimpleNamespace(perf_counter=lambda: next(ticks)))  # min_time's clock only
    r = earliest(Fake(25), ENV)
    assert r.solve_time_s == pytest.approx(7.5)
