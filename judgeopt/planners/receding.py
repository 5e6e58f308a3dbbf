"""Re-planning in the loop: the direct solve re-run during execution from what the arm measured.

Every `period` seconds the executed motion so far (the arm's own position, velocity and force
readings at the planner's samples) is fixed, the judge reads it followed by the planned rest,
and the rest is solved again by the direct solve under every limit and the terminal state,
starting from the measured state (`DirectPlanner.with_prefix`: only bounds change, one solve per
re-plan). The horizon shrinks rather than recedes: a scoop has a fixed duration and a terminal
state, so each re-plan covers the time left, warm-started from the previous plan on the same
clock. A re-plan that does not finish as "solved" is dropped and the previous plan kept.

The environment the judge reads stays what the user said: the scoop's measured channels carry too
little of it to re-estimate on the way (docs/physics.md, scripts/estimability.py).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from judgeopt.planners.base import BuildContext, ClosedLoopPlanner
from judgeopt.planners.direct import DirectPlanner
from judgeopt.planners.problem import ProblemError
from judgeopt.planners.result import PlanResult
from judgeopt.verdict.rules import assess
from judgeopt.trajectory import Plan


TRIGGERS = ("judge", "always")


@dataclass(frozen=True)
class RecedingConfig:
    """When to re-plan: the period and trigger come from the problem ([solver] replan_period,
    replan_trigger; `of`), the rest is defined here."""

    #: s between re-plans; a multiple of the planner's dt, shorter than the horizon
    period: float
    #: "judge": re-solve only when the judge, reading the measured part followed by the plan's rest,
    #: falls below the problem's p_target (else the plan goes on); "always": at every period
    trigger: str
    #: s before the end with no more re-plans: the terminal state is all that is left to decide, and re-solves
    #: 0.2-0.3 s before the end mostly ended unsolved after 21-54 iterations (q̇_max 1.0, 12 environments)
    last: float = 0.4

    @classmethod
    def of(cls, problem: Any) -> "RecedingConfig":
        return cls(problem.replan_period, problem.replan_trigger)

    def steps(self, dt: float, horizon: int) -> int:
        """The period in planner samples, checked (and the trigger)."""
        if self.trigger not in TRIGGERS:
            raise ProblemError(f"re-planning trigger {self.trigger!r}: choose one of {', '.join(TRIGGERS)}")
        m = self.period / dt
        if not (abs(m - round(m)) < 1e-9 and 1 <= round(m) < horizon):
            raise ProblemError(f"re-planning period {self.period:g} s: must be a multiple of the planner's dt = {dt:g} s "
                               f"and shorter than the horizon {horizon * dt:g} s (e.g. {2 * dt:g})")
        return int(round(m))


#: a check at which the judge, reading what was measured and the plan's rest, was convinced: nothing re-solved
PLAN_KEPT = "plan kept"


@dataclass
class Replan:
    """One re-plan: when, from how many measured samples, what it believed and what it cost."""

    t: float
    k: int
    status: str
    predicted: float | None
    seconds: float
    iterations: int
    kept: bool  # False: the previous plan went on
    remainder: list | None = None  # the re-planned samples k..N (task's channel order), to plot


@dataclass
class ClosedLoopResult:
    """The first plan, every re-plan, the plan as it finally stood and the measured response."""

    first: PlanResult
    replans: list[Replan]
    executed: Plan  # the command as it was carried out (each part from the plan in force then)
    response: np.ndarray  # (N + 1, channels) measured
    outcome: Any  # the task's Outcome
    env_told: dict[str, float]

    def summary(self) -> dict[str, Any]:
        s = [r.seconds for r in self.replans]
        return {"replans": len(self.replans), "kept": sum(r.kept for r in self.replans),
                "replan_p95_ms": float(np.percentile(s, 95) * 1e3) if s else None,
                "replan_max_ms": float(max(s) * 1e3) if s else None, "success": bool(self.outcome.success),
                "env_told": self.env_told}


class RecedingPlanner(ClosedLoopPlanner):
    """The direct solve, re-run from the measured state every `period` during execution."""

    method = "receding"

    def __init__(self, direct: DirectPlanner, config: RecedingConfig | None = None):
        self.direct, self.config = direct, config or RecedingConfig.of(direct.problem)
        pr = direct.problem
        self.every = self.config.steps(pr.dt, pr.steps)

    @classmethod
    def build(cls, context: BuildContext) -> "RecedingPlanner":
        """On the direct solve loaded with it (its registry entry `uses` it), configured by its problem."""
        return cls(context.uses["direct"])

    def with_limits(self, problem: Any) -> "RecedingPlanner":
        return RecedingPlanner(self.direct.with_limits(problem), self.config)

    def run(self, simulator: Any, results: list[PlanResult], env: dict[str, float],
            world: dict[str, float]) -> PlanResult:
        """The direct plan among `results` executed in `world` with re-planning, as a result row
        (its p: the last kept re-plan's; its outcome: the closed loop's)."""
        first = next((r for r in results if r.method == self.direct.method), None)
        if first is None:
            raise ProblemError(f"the receding planner executes the {self.direct.method} plan: run it with the "
                               f"{self.direct.method} planner")
        loop = self.execute(simulator, first, env, world)
        kept = [r for r in loop.replans if r.kept]
        solves = [r for r in loop.replans if r.status != PLAN_KEPT]
        p = kept[-1].predicted if kept else first.predicted_success
        out = dataclasses.replace(
            first, method=self.method, plan=loop.executed, predicted_success=p, status="executed",
            solve_time_s=sum(r.seconds for r in loop.replans), iterations=sum(r.iterations for r in loop.replans),
            simulated_success=bool(loop.outcome.success), response=loop.response,
            info={"warm_start": first.info.get("warm_start"), "closed_loop": loop.summary(),
                  "replan_log": [dataclasses.asdict(r) for r in loop.replans],
                  **{f"sim_{k}": v for k, v in loop.outcome.details.items() if isinstance(v, (bool, int, float))}},
            message=f"{len(loop.replans)} checks every {self.config.period:g} s (trigger {self.config.trigger}), "
                    f"{len(solves)} re-solved, {len(kept)} re-plans kept")
        return assess(out)

    def details(self, result: PlanResult) -> list[str]:
        """Its log: one line per re-plan."""
        lines = [f"{self.method}: {result.message}; each re-plan's time, predicted success and Ipopt status:"]
        for x in result.info["replan_log"]:
            p = "-" if x["predicted"] is None else f"{x['predicted']:.3f}"
            dropped = "" if x["kept"] or x["status"] == PLAN_KEPT else " (dropped)"
            lines.append(f"  t = {x['t']:.2f} s (from {x['k']} measured samples): p {p}, {1000 * x['seconds']:.0f} ms, "
                         f"{x['iterations']} it, {x['status']}{dropped}")
        return lines

    def execute(self, simulator: Any, first: PlanResult, env: Mapping[str, float],
                world: Mapping[str, float]) -> ClosedLoopResult:
        """Execute `first` (a plan for `env`, what the user said) in `world` (the simulated
        world, which may differ), re-planning every period from the measured response."""
        pr = self.direct.problem
        n, dt = pr.steps, pr.dt
        if first.plan is None:
            raise ProblemError(f"no first plan to execute ({first.status}: {first.message})")
        plan = first.plan
        run = simulator.execute(plan, world)
        told = dict(pr.env_dict(dict(env)))
        replans: list[Replan] = []
        last_k = n - int(round(self.config.last / dt))
        k = self.every
        while k <= last_k:
            run.advance(plan, k - 1)  # samples 0..k-1 measured; the step starting at k is the new plan's
            measured = run.measured()
            t0 = time.perf_counter()
            guess = plan.values.copy()
            guess[:k] = measured
            if self.config.trigger == "judge":
                p_now = self.direct.probability(guess, told)
                if p_now >= pr.p_target:  # what was measured and the rest of the plan still convince the judge
                    replans.append(Replan(k * dt, k, PLAN_KEPT, p_now, time.perf_counter() - t0, 0, False))
                    k += self.every
                    continue
            r = self.direct.with_prefix(measured).solve(told, guess=Plan(dt, guess, plan.channels))
            seconds = time.perf_counter() - t0
            kept = r.status == "solved" and r.plan is not None
            replans.append(Replan(k * dt, k, r.status, r.predicted_success, seconds, r.iterations, kept,
                                  None if r.plan is None else r.plan.values[k:].tolist()))
            if kept:  # the commands already carried out stay; the rest is the new plan's
                plan = Plan(dt, np.vstack([plan.values[:k], r.plan.values[k:]]), plan.channels)
            k += self.every
        outcome = run.outcome()
        return ClosedLoopResult(first, replans, plan, np.asarray(outcome.response), outcome, told)
