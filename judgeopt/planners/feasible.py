"""Whether a problem's constraints can hold together, before any solve: the boxes and terminal
state (`Problem.check_feasible`), then [constraints] by a linear program per position axis and
per force channel (every constraint but the judge's is linear in the plan). Where they cannot, a
deletion filter names an irreducible set, each of which the others can hold without: usually a
pair, which is what the user must choose between.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from judgeopt.planners.constraints import per_channel
from judgeopt.planners.problem import InfeasibleProblemError, Problem, ProblemError


def check(problem: Problem, env: dict[str, float], rest_from: int | None = None) -> None:
    """Raise InfeasibleProblemError naming the constraints in conflict (no solver needed;
    `rest_from`: also at rest at the terminal state from that sample on)."""
    problem.check_feasible(env)
    if problem.constraints.is_set() or rest_from is not None:
        names = conflict(problem, env, rest_from)
        if names is not None:
            which = " and ".join(names) if len(names) > 1 else f"{names[0]} and the start state"
            raise InfeasibleProblemError(f"{which} cannot {'all' if len(names) > 2 else 'both'} hold "
                                         "(on the motion model from the start state); relax one", names)
    if problem.joint_limit_scale is not None:
        _check_joints(problem, env)


def _check_joints(problem: Problem, env: dict[str, float]) -> None:
    """The arm's joint torques and speeds (joint_limit_scale) on the positions every plan passes through: an
    arm too weak or too slow for the limits is infeasible, with the joint and the limit's value at which it
    holds (joint_limits.JointMap.check_path); an arm that cannot reach [q_min, q_max] likewise. A task the
    joint limits cannot be held for is left to the planner that holds them to report."""
    from judgeopt.planners.joint_limits import joint_map

    try:
        joints = joint_map(problem)
    except InfeasibleProblemError:
        raise
    except ProblemError:
        return
    joints.check_path(problem, env, getattr(problem, "robot", None))


@dataclass
class _Group:
    """Rows of one named constraint: A x <= b, bounds lo <= x <= hi."""

    name: str
    A: list[np.ndarray] = field(default_factory=list)
    b: list[float] = field(default_factory=list)
    lo: dict[int, float] = field(default_factory=dict)
    hi: dict[int, float] = field(default_factory=dict)

    def bound(self, j: int, lo: float, hi: float) -> None:
        self.lo[j], self.hi[j] = max(self.lo.get(j, -np.inf), lo), min(self.hi.get(j, np.inf), hi)

    def row(self, coeffs: dict[int, float], n: int, hi: float, lo: float = -np.inf) -> None:
        r = np.zeros(n)
        for j, x in coeffs.items():
            r[j] = x
        if hi < np.inf:
            self.A.append(r)
            self.b.append(hi)
        if lo > -np.inf:
            self.A.append(-r)
            self.b.append(-lo)


def _feasible(n: int, eq: tuple[np.ndarray, np.ndarray], groups: list[_Group]) -> bool:
    from scipy.optimize import linprog

    lo, hi = np.full(n, -np.inf), np.full(n, np.inf)
    A, b = [], []
    for g in groups:
        for j, x in g.lo.items():
            lo[j] = max(lo[j], x)
        for j, x in g.hi.items():
            hi[j] = min(hi[j], x)
        A += g.A
        b += g.b
    if np.any(lo > hi + 1e-12):
        return False
    res = linprog(np.zeros(n), A_ub=np.array(A) if A else None, b_ub=np.array(b) if b else None, A_eq=eq[0],
                  b_eq=eq[1], bounds=list(zip(lo, hi)), method="highs")
    return res.status == 0


def _axis_program(problem: Problem, env: dict[str, float], axis: int, rest_from: int | None
                  ) -> tuple[int, tuple[np.ndarray, np.ndarray], list[_Group]]:
    """Variables q_0..q_N, v_0..v_N of one axis; the start and the model as equalities; every
    other constraint on the axis a named group."""
    n, dt = problem.steps, problem.dt
    nv = 2 * (n + 1)
    Q, V = (lambda k: k), (lambda k: n + 1 + k)
    rows, rhs = [], []
    for j, x in ((Q(0), problem.vec("q0")[axis]), (V(0), problem.vec("qdot0")[axis])):
        r = np.zeros(nv)
        r[j] = 1.0
        rows.append(r)
        rhs.append(float(x))
    for k in range(1, n + 1):  # q_k - q_{k-1} - dt/2 (v_{k-1} + v_k) = 0
        r = np.zeros(nv)
        r[Q(k)], r[Q(k - 1)], r[V(k - 1)], r[V(k)] = 1.0, -1.0, -0.5 * dt, -0.5 * dt
        rows.append(r)
        rhs.append(0.0)
    spec = problem.channel_spec
    pos = [c for c in spec if c.kind == "position"][axis]
    vel = next(c for c in spec if c.of == pos.name)
    c = problem.constraints
    groups = []
    box_q, box_v = _Group("limits.q_min/q_max"), _Group("limits.qdot_min/qdot_max")
    for k in range(1, n + 1):
        box_q.bound(Q(k), problem.vec("q_min")[axis], problem.vec("q_max")[axis])
        box_v.bound(V(k), problem.vec("qdot_min")[axis], problem.vec("qdot_max")[axis])
    groups += [box_q, box_v]
    end = problem.terminal_positions(env)[axis]
    if not np.isnan(end):
        g = _Group("terminal.q_end")
        g.bound(Q(n), end, end)
        groups.append(g)
    g = _Group("terminal.qdot_end")
    g.bound(V(n), problem.vec("qdot_end")[axis], problem.vec("qdot_end")[axis])
    groups.append(g)
    a_max = per_channel(c.a_max, problem.n_axes, "a_max")[axis]
    if np.isfinite(a_max):
        g = _Group(f"constraints.a_max = {a_max:g}")
        for k in range(1, n + 1):
            g.row({V(k): 1 / dt, V(k - 1): -1 / dt}, nv, a_max, -a_max)
        groups.append(g)
    j_max = per_channel(c.jerk_max, problem.n_axes, "jerk_max")[axis]
    if np.isfinite(j_max):
        g = _Group(f"constraints.jerk_max = {j_max:g}")
        for k in range(1, n):
            g.row({V(k + 1): 1 / dt ** 2, V(k): -2 / dt ** 2, V(k - 1): 1 / dt ** 2}, nv, j_max, -j_max)
        groups.append(g)
    for b in c.parsed_bounds():
        if b.name in (pos.name, vel.name):
            g = _Group(f"bound {b.text}")
            for k in b.samples(n, dt):
                g.bound(Q(k) if b.name == pos.name else V(k), b.lo, b.hi)
            groups.append(g)
    if rest_from is not None:
        g = _Group(f"rest from t = {rest_from * dt:g} s")
        qd_end = problem.vec("qdot_end")[axis]
        for k in range(rest_from, n + 1):
            g.bound(V(k), qd_end, qd_end)
            if not np.isnan(end):
                g.bound(Q(k), end, end)
        groups.append(g)
    return nv, (np.array(rows), np.array(rhs)), groups


def _force_program(problem: Problem, channel: int) -> tuple[int, tuple[np.ndarray, np.ndarray], list[_Group]]:
    n, dt = problem.steps, problem.dt
    nv = n + 1
    name = [c for c in problem.channel_spec if c.kind == "force"][channel].name
    box = _Group("limits.f_min/f_max")
    for k in range(nv):
        box.bound(k, problem.vec("f_min")[channel], problem.vec("f_max")[channel])
    groups = [box]
    limit = per_channel(problem.constraints.fdot_max, problem.n_forces, "fdot_max")[channel]
    if np.isfinite(limit):
        g = _Group(f"constraints.fdot_max = {limit:g}")
        for k in range(n):
            g.row({k + 1: 1 / dt, k: -1 / dt}, nv, limit, -limit)
        groups.append(g)
    for b in problem.constraints.parsed_bounds():
        if b.name == name:
            g = _Group(f"bound {b.text}")
            for k in b.samples(n, dt):
                g.bound(k, b.lo, b.hi)
            groups.append(g)
    return nv, (np.zeros((0, nv)), np.zeros(0)), groups


def conflict(problem: Problem, env: dict[str, float], rest_from: int | None = None) -> list[str] | None:
    """The constraints that no plan can hold together (with the start state and the model): an
    irreducible set, each of which the others can hold without (a deletion filter over linear
    programs), usually a pair; None when the linear constraints are feasible (the judge's is not
    linear, and is the solve's to meet). `rest_from`: the plan must be at its terminal state from
    sample k on (min-time's candidate)."""
    programs = [_axis_program(problem, env, i, rest_from) for i in range(problem.n_axes)]
    programs += [_force_program(problem, i) for i in range(problem.n_forces)]
    for n, eq, groups in programs:
        if _feasible(n, eq, groups):
            continue
        keep = list(groups)
        for g in groups:
            rest = [h for h in keep if h is not g]
            if not _feasible(n, eq, rest):
                keep = rest
        return [g.name for g in keep]
    return None
