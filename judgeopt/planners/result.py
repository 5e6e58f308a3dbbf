"""What a planner returns, and the constraint residuals measured on the plan itself.

Residuals are computed from the final plan against the problem's original limits, for both
planners, the same way: a planner's own bookkeeping (Ipopt's scaled, relaxed bounds; the
generator's penalty) is never what is reported.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from judgeopt.planners.constraints import residuals as path_residuals
from judgeopt.planners.dynamics import dynamics_residual
from judgeopt.planners.feasible import check
from judgeopt.planners.problem import InfeasibleProblemError, Problem
from judgeopt.planners.summary import SummaryTable
from judgeopt.trajectory import Plan
from judgeopt.verdict.risk import HOLD_TOL
from judgeopt.verdict.rules import LIKELY, breaks, verdict_of

#: how close to p_target (in probability) a plan's judge must come to count as reaching it
TARGET_TOL = 1e-3


def meets_target(result: "PlanResult", p_target: float) -> bool:
    """Whether a result's judge reached p_target (to TARGET_TOL)."""
    return result.predicted_success is not None and result.predicted_success >= p_target - TARGET_TOL


def constraint_residuals(problem: Problem, plan: Plan, env: dict[str, float]) -> dict[str, float]:
    """Worst violation of each constraint over all axes (>= 0; 0 when satisfied), in the
    constraint's units: the boxes, the terminal state, the model, and [constraints]'s."""
    def over(values: np.ndarray, bound: np.ndarray) -> float:
        return float(max(0.0, np.max(values - bound)))

    def under(values: np.ndarray, bound: np.ndarray) -> float:
        return float(max(0.0, np.max(bound - values)))

    q, v, f = (plan.values[:, plan.columns(kind)] for kind in ("position", "velocity", "force"))
    ends = problem.terminal_positions(env)
    fixed = ~np.isnan(ends)
    return {
        "q_min": under(q, problem.vec("q_min")), "q_max": over(q, problem.vec("q_max")),
        "qdot_min": under(v, problem.vec("qdot_min")), "qdot_max": over(v, problem.vec("qdot_max")),
        "f_min": under(f, problem.vec("f_min")), "f_max": over(f, problem.vec("f_max")),
        "q_end": float(np.max(np.abs(q[-1, fixed] - ends[fixed]), initial=0.0)),
        "qdot_end": float(np.max(np.abs(v[-1] - problem.vec("qdot_end")))),
        "start": max(float(np.max(np.abs(q[0] - problem.vec("q0")))), float(np.max(np.abs(v[0] - problem.vec("qdot0"))))),
        "dynamics": max(dynamics_residual(q[:, i], v[:, i], plan.dt) for i in range(q.shape[1])),
        **path_residuals(problem.constraints, plan),
        **joint_residuals(problem, plan),
    }


def joint_residuals(problem: Problem, plan: Plan) -> dict[str, float]:
    """The arm's joint velocity (rad/s) and torque (N m) beyond their limits times
    joint_limit_scale, at each sample's exact configuration; none unless the scale is set."""
    if problem.joint_limit_scale is None:
        return {}
    from judgeopt.planners.joint_limits import joint_map

    return joint_map(problem).residuals(plan, problem.joint_limit_scale)


@dataclass
class PlanResult:
    """One planner's answer for one environment."""

    method: str
    env: dict[str, float]
    plan: Plan | None
    predicted_success: float | None
    status: str  # "solved", "not_converged", "infeasible", ...
    solve_time_s: float
    residuals: dict[str, float] = field(default_factory=dict)
    iterations: int | None = None
    message: str = ""
    simulated_success: bool | None = None
    info: dict[str, Any] = field(default_factory=dict)
    success_probability: float | None = None  # the probability the tool stands behind (see assess)
    probability_source: str = ""  # "calibrated" or "judge"
    # what the replay measured on the plan's channels and sample times (Outcome.response), to plot
    # beside the command; not written to JSON (the plan file keeps the replay's details)
    response: np.ndarray | None = None

    @property
    def verdict(self) -> str | None:
        """"likely", UNCERTAIN or "unlikely" by success_probability (verdict_of), OUTSIDE (the judge's
        own p where the request lies outside its data) or BREAKS (a hard constraint broken); None
        without a plan."""
        return verdict_of(self.success_probability, self.probability_source, self.info.get("outside_judge_data"),
                          breaks(self.max_constraint_violation), self.info.get("likely_at", LIKELY))

    @property
    def max_constraint_violation(self) -> float | None:
        return max(self.residuals.values()) if self.residuals else None

    @property
    def worst_constraint(self) -> str | None:
        return max(self.residuals, key=self.residuals.get) if self.residuals else None

    def row(self) -> dict[str, Any]:
        """The headline values, one row of a summary table (`summary`, SolveReport.summary)."""
        return {"method": self.method, "verdict": self.verdict, "success_probability": self.success_probability,
                "probability_source": self.probability_source or None, "predicted_success": self.predicted_success,
                "simulated_success": self.simulated_success, "status": self.status,
                "max_constraint_violation": self.max_constraint_violation, "worst_constraint": self.worst_constraint,
                "iterations": self.iterations, "solve_time_s": self.solve_time_s}

    def summary(self) -> SummaryTable:
        """This result as a one-row table (a list of dicts; `print` shows it aligned)."""
        return SummaryTable([self.row()])

    def __repr__(self) -> str:
        """A few lines (the default would print every sample of the plan and the response: about
        100 KB); the plan is `.plan`, everything `to_json()`."""
        if self.plan is None:
            head = f"PlanResult {self.method}: no plan ({self.status})"
            reason = self.message.splitlines()[0][:200] if self.message else ""
            return head + (f"\n  {reason}" if reason else "")
        p = ("" if self.success_probability is None else
             f", success p {self.success_probability:.3f} ({self.probability_source or 'judge'})")
        sim = {None: "not simulated", True: "simulated: success", False: "simulated: FAILURE"}[self.simulated_success]
        worst = self.max_constraint_violation
        held = ("limits held" if worst is None or worst <= HOLD_TOL else
                f"worst violation {worst:.2g} ({self.worst_constraint})")
        its = "" if self.iterations is None else f", {self.iterations} iterations"
        env = ", ".join(f"{k} = {v:g}" for k, v in self.env.items())
        return (f"PlanResult {self.method}: {self.verdict}{p}\n  {sim}; {held}; {self.status}{its}, "
                f"{seconds(self.solve_time_s)}\n  environment: {env}")

    def to_json(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "method": self.method, "status": self.status, "message": self.message, "environment": self.env,
            "predicted_success": self.predicted_success, "simulated_success": self.simulated_success,
            "max_constraint_violation": self.max_constraint_violation, "worst_constraint": self.worst_constraint,
            "residuals": self.residuals, "solve_time_s": self.solve_time_s, "iterations": self.iterations,
            "success_probability": self.success_probability, "probability_source": self.probability_source or None,
            "verdict": self.verdict,
        }
        if self.plan is not None:
            p = self.plan
            d.update(t=p.t.tolist(), **{c.name: p.values[:, j].tolist() for j, c in enumerate(p.channels)},
                     channels=[c.name for c in p.channels], units={"t": "s", **{c.name: c.unit for c in p.channels}})
        d.update({k: v for k, v in self.info.items() if k not in d})
        return d

    @classmethod
    def from_json(cls, d: dict[str, Any], dt: float, task: str) -> "PlanResult":
        """A result as `to_json` wrote it (a planning service's answer), its plan rebuilt on the
        task's channels at period `dt`: `to_json` of it gives `d` back."""
        from judgeopt.tasks import get_task

        plan = None
        if "channels" in d:
            channels = {c.name: c for c in get_task(task).channels}
            plan = Plan.from_columns(dt, tuple(channels[n] for n in d["channels"]),
                                     *(np.asarray(d[n], dtype=float) for n in d["channels"]))
        own = {"method", "status", "message", "environment", "predicted_success", "simulated_success",
               "max_constraint_violation", "worst_constraint", "residuals", "solve_time_s", "iterations",
               "success_probability", "probability_source", "verdict", "t", "channels", "units",
               *(d.get("channels") or ())}
        return cls(d["method"], d["environment"], plan, d["predicted_success"], d["status"], d["solve_time_s"],
                   d["residuals"], d["iterations"], d["message"], d["simulated_success"],
                   {k: v for k, v in d.items() if k not in own}, d["success_probability"],
                   d["probability_source"] or "")


def seconds(t: float) -> str:
    """A solve time as people read it: "12.3 ms" under a second, "1.23 s" above."""
    return f"{t * 1e3:.1f} ms" if t < 1 else f"{t:.2f} s"


def infeasible_result(method: str, problem: Problem, env: dict[str, float]) -> PlanResult | None:
    """The answer every planner gives when no trajectory can meet the limits (None if one can):
    the conflict is reported before any solver or search runs."""
    try:
        check(problem, env)
    except InfeasibleProblemError as exc:
        return PlanResult(method, env, None, None, "infeasible", 0.0, message=str(exc), info={"conflict": exc.conflict})
    return None
