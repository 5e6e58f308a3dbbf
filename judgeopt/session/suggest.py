"""What would make an unlikely plan likely: the smallest relaxation of one limit, found by re-planning.

For each limit a user could relax (f_max up, q̇_max up, f_min down; of [constraints], a rate limit
up, the joint-limit scale up to the arm's own limits, a window bound dropped), the planners re-plan the
same environment under the relaxed limit; the smallest relaxation under which a plan is
"likely" is reported. Relaxing a limit only enlarges the set of allowed plans, so the best
achievable probability grows with the relaxation: the search tries the widest relaxation the
demonstrations support first (none likely there: nothing to suggest for that limit), then
bisects down to the limit's resolution. Screening uses the fastest planner that covers the
relaxed limits (the amortised generator when it was trained for them, else the direct solve);
the value found is then re-planned with every method and that result is what is reported.
Nothing here is guessed: each figure is a planner's result under the suggested limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from judgeopt.planners.constraints import RATE_LIMITS
from judgeopt.planners.problem import Problem, ProblemError
from judgeopt.verdict.rules import LIKELY, recommended, verdict_of
from judgeopt.planners.result import PlanResult
from judgeopt.planners.base import spec_of
from judgeopt.tasks import Task, get_task

if TYPE_CHECKING:  # annotations only: a report read back from JSON (a service's answer) prints its suggestions
    from judgeopt.planners.loaded import Planners  # without importing torch


@dataclass(frozen=True)
class Relaxation:
    """One limit, the direction that relaxes it, the search's resolution, and how far the
    judge's demonstrations reach (beyond that the judge has seen nothing to stand on)."""

    name: str
    direction: int  # +1: raise the limit, -1: lower it
    resolution: float
    bound: float
    unit: str


def relaxations(task: Task) -> tuple[Relaxation, ...]:
    """The limits a user of `task` could relax, bounded by what its demonstrations commanded."""
    (f_lo, f_hi), (_, v_hi) = task.demonstrated_bound("force"), task.demonstrated_bound("velocity")
    f_unit, v_unit = task.channels_of("force")[0].unit, task.channels_of("velocity")[0].unit
    return (Relaxation("f_max", +1, 1.0, f_hi, f_unit), Relaxation("qdot_max", +1, 0.05, v_hi, v_unit),
            Relaxation("f_min", -1, 1.0, f_lo, f_unit))


#: a rate limit is relaxed up to this many times its value, to this fraction of it
RATE_REACH, RATE_RESOLUTION = 4.0, 0.05


def constraint_relaxations(problem: Problem) -> tuple[Relaxation, ...]:
    """The problem's [constraints] a user could relax: each rate limit set (one value for every
    axis) up to RATE_REACH times, the joint-limit scale up to 1 (the arm's own limits: beyond them
    is not the arm's to do). Window bounds are dropped instead (`suggest`)."""
    task = get_task(problem.task)
    pos, force = task.channels_of("position")[0].unit, task.channels_of("force")[0].unit
    units = {"a_max": f"{pos}/s^2", "jerk_max": f"{pos}/s^3", "fdot_max": f"{force}/s"}
    out = [Relaxation(name, +1, RATE_RESOLUTION * v, RATE_REACH * v, units[name])
           for name in RATE_LIMITS if isinstance(v := getattr(problem, name), (int, float)) and math.isfinite(v)]
    scale = problem.joint_limit_scale
    if scale is not None and scale < 1.0:
        out.append(Relaxation("joint_limit_scale", +1, 0.02, 1.0, "x the arm's limits"))
    return tuple(out)


@dataclass
class Suggestion:
    limit: str
    value: float
    current: float
    unit: str
    result: PlanResult  # the best method's plan under the relaxed limit
    p_at_bound: float  # screened at the widest relaxation the demonstrations support
    bound: float
    #: what binds on the plan under the current limit (the joint-limit scale: the joint and quantity)
    binds: str = ""

    @property
    def relative_change(self) -> float:
        if math.isnan(self.value):  # a window bound dropped: as large a change as there is
            return math.inf
        return abs(self.value - self.current) / max(abs(self.current), 1e-9)

    def text(self) -> str:
        r = self.result
        p = f"p = {r.success_probability:.2f} ({r.method}, {r.probability_source})"
        if math.isnan(self.value):
            return f"likely without {self.limit}: {p}"
        op = ">=" if self.value > self.current else "<="
        binds = f"; {self.binds}" if self.binds else ""
        return (f"likely with {self.limit} {op} {self.value:g} {self.unit} (now {self.current:g}{binds}): {p}; "
                f"p = {self.p_at_bound:.2f} at {self.limit} = {self.bound:g} {self.unit}")

    def to_json(self) -> dict:
        r = self.result
        return {"limit": self.limit, "value": None if math.isnan(self.value) else self.value,
                "current": self.current, "unit": self.unit, "binds": self.binds or None,
                "success_probability": r.success_probability, "probability_source": r.probability_source,
                "method": r.method, "predicted_success": r.predicted_success, "bound": self.bound,
                "success_probability_at_bound": self.p_at_bound}

    @classmethod
    def from_json(cls, d: dict[str, Any]) -> "Suggestion":
        """A suggestion as `to_json` wrote it (a planning service's answer), enough to print it
        (`text`) and write it again; its result keeps the headline values only, no plan."""
        result = PlanResult(d["method"], {}, None, d["predicted_success"], "", 0.0,
                            success_probability=d["success_probability"], probability_source=d["probability_source"])
        return cls(d["limit"], math.nan if d["value"] is None else d["value"], d["current"], d["unit"], result,
                   d["success_probability_at_bound"], d["bound"], d["binds"] or "")


def _screen(planners: Planners, name: str, value, env: dict[str, float], guess) -> tuple[float, bool]:
    """The success probability of the fastest planner that covers the relaxed limit (the first
    that plans before execution: the registry lists the built-ins fastest first), and whether its
    plan is called likely there (at the risk asked for)."""
    relaxed = planners.with_limits(**{name: value})
    fastest = next(m for m in relaxed.methods if not spec_of(m).closed_loop)
    r = recommended(relaxed.only(fastest).solve(env, guess=guess))
    # a screen: the fast planner's p, at the threshold the evidence sets for it (p >= 0.5 where it sets
    # none: the amortised plan, never called likely at 2 %, still tells where a plan may be), where its soft
    # plan breaks a limit too (the suggestion itself is planned again by every planner and must be called likely)
    if r is None:
        return -1.0, False
    likely_at = r.info.get("likely_at", LIKELY)
    return r.success_probability, verdict_of(r.success_probability, likely_at=LIKELY if likely_at is None else likely_at) == "likely"


def printable(value: float, direction: int, limit: float, digits: int = 3) -> float:
    """`value` to `digits` significant digits, rounded the way the limit relaxes (up where it is
    raised, down where lowered) and never past `limit` (the demonstrations' reach): the value a
    suggestion prints is the one it planned at, and no tighter than the one the search found."""
    if value == 0 or not math.isfinite(value):
        return value
    step = 10.0 ** (math.floor(math.log10(abs(value))) - digits + 1)
    units = round(value / step, 6)  # 45.3000000001 steps is 45.3, not 46
    rounded = float(f"{(math.ceil(units) if direction > 0 else math.floor(units)) * step:.{digits}g}")
    return min(rounded, limit) if direction > 0 else max(rounded, limit)


def suggest(planners: Planners, env: dict[str, float], results: list[PlanResult],
            limits: tuple[Relaxation, ...] | None = None) -> list[Suggestion]:
    """One suggestion per limit whose relaxation (within the demonstrations' reach) makes a plan
    likely, smallest relative change first. Empty: no single limit's relaxation helps.
    `results`: the plans under the current limits; the best one warm-starts every direct solve
    (it satisfies any relaxed limits too)."""
    found: list[Suggestion] = []
    p = planners.problem
    limits = limits if limits is not None else relaxations(get_task(p.task)) + constraint_relaxations(p)
    start = recommended(results)
    guess = start.plan if start is not None else None
    found += _dropped_bounds(planners, env, guess)
    for rx in limits:
        current = getattr(p, rx.name)
        if (rx.bound - current) * rx.direction <= rx.resolution:
            continue  # already at what the demonstrations reach
        try:
            p_bound, likely = _screen(planners, rx.name, rx.bound, env, guess)
            lo, hi = current, rx.bound  # unlikely at lo, likely at hi
            for edge in [] if likely else kind_edges(planners, rx, current):
                if _screen(planners, rx.name, edge, env, guess)[1]:
                    hi, likely = edge, True
                    break
                lo = edge
            if not likely:
                continue
            anchor = hi  # where the screen first said likely
            while abs(hi - lo) > rx.resolution:
                mid = 0.5 * (lo + hi)
                if _screen(planners, rx.name, mid, env, guess)[1]:
                    hi = mid
                else:
                    lo = mid
            # a planner whose warm-start planner is asked for too starts from that one's new plan
            started = any(spec_of(m).warm_start in planners.methods for m in planners.methods)
            # planned at the value the suggestion prints; where every planner's plan there is not likely (the
            # screen is the fastest planner's), at the plan model's range end beyond it, then at the value the
            # screen first said likely
            ends = [v for v in kind_edges(planners, rx, hi) if (anchor - v) * rx.direction > 0]
            for value in dict.fromkeys(printable(v, rx.direction, rx.bound) for v in (hi, *ends, anchor)):
                relaxed = planners.with_limits(**{rx.name: value}).solve(env, guess=None if started else guess)
                top = recommended(relaxed)
                if top is not None and top.verdict == "likely":
                    found.append(Suggestion(rx.name, float(value), float(current), rx.unit, top, p_bound, rx.bound,
                                            _binds(p, rx.name, guess)))
                    break
        except ProblemError:  # the relaxed limits contradict another one
            continue
    return sorted(found, key=lambda s: s.relative_change)


def kind_edges(planners: Planners, rx: Relaxation, current: float) -> list[float]:
    """The ends of the plan model's range of this limit between `current` and the bound, nearest first.
    Across one a plan's p changes kind (the plan model's, then a calibrator's with its own threshold), so
    "likely" need not grow with the relaxation there: a force limit of 11 N was likely from 12 N, inside the
    model's range (11-15.5 N), but not at the demonstrations' 30 N, and the search that screened 30 N
    first found nothing."""
    model = getattr(planners, "plan_model", None)  # a stand-in planner set may carry none
    if model is None or rx.name not in model.names:
        return []
    i = model.names.index(rx.name)
    ends = (model.low[i], model.high[i])
    return sorted((v for v in ends if (v - current) * rx.direction > rx.resolution and (rx.bound - v) * rx.direction > 0),
                  key=lambda v: (v - current) * rx.direction)


def searched(problem: Problem) -> list[str]:
    """What `suggest` relaxes for this problem, one at a time (for the message where none helps)."""
    limits = relaxations(get_task(problem.task)) + constraint_relaxations(problem)
    return [rx.name for rx in limits] + [f"without bound {b}" for b in problem.bounds]


def _binds(problem: Problem, name: str, plan) -> str:
    """For the joint-limit scale: which joint's velocity or torque is nearest its scaled limit on
    the plan under the current limits (the one the relaxation is for)."""
    if name != "joint_limit_scale" or plan is None:
        return ""
    from judgeopt.planners.joint_limits import joint_map

    joint, quantity, ratio = joint_map(problem).binding(plan, problem.joint_limit_scale)
    return f"{joint}'s {quantity} binds, at {ratio:.0%} of its scaled limit"


def _dropped_bounds(planners: Planners, env: dict[str, float], guess) -> list[Suggestion]:
    """Each window bound whose removal alone makes a plan likely (a window has no one number to
    relax: the user moves it or drops it)."""
    p, found = planners.problem, []
    for i, text in enumerate(p.bounds):
        rest = [b for j, b in enumerate(p.bounds) if j != i]
        try:
            if not _screen(planners, "bounds", rest, env, guess)[1]:
                continue
            top = recommended(planners.with_limits(bounds=rest).solve(env, guess=guess))
        except ProblemError:
            continue
        if top is not None and top.verdict == "likely":
            found.append(Suggestion(f"bound {text}", math.nan, math.nan, "", top, top.success_probability, math.nan))
    return found
