"""The arm's own limits along a plan (issue 36): joint velocities and joint torques at each sample,
held within `joint_limit_scale` times the URDF's limits by the direct solve.

On the task's ArmModel (Task.arm_model): at a sample's position the tool's pose is fixed by the
task, so the configuration q(y) comes from IK alone, and

    joint velocity = J(q)^-1 [axis * ydot; 0]       (the tool moves along the axis, does not turn)
    joint torque   = g(q) + J(q)^T [force_axis * f; 0] + m(q) yddot + c(q) ydot^2

J the tool frame's Jacobian (LOCAL_WORLD_ALIGNED), g the gravity torques (tool included), and
force_axis * f the force the tool exerts on the environment: the simulator's controller commands
exactly this at rest (its feed-forward xdd -= Lambda^-1 F_cmd gives tau = g - J^T e_z f_z; tested
against a pressing rollout). m and c are the arm's inertia as the controller commands it while the
tool accelerates along the axis (`joint_dynamics`): on the Panda and xArm7 at 1 m/s it is a quarter
to a third of the base and elbow joints' limits, where gravity puts nothing. The plan's acceleration
is constant over each step, so at a sample the torque jumps: both sides are held. The contact's
moment about the TCP is left out.

The direct solve needs these symbolically: for a one-axis task they are tabulated over a fine grid
of positions covering [q_min, q_max] and interpolated by CasADi B-splines (`JointMap.rows`); the
residual check recomputes them exactly, with IK at each sample (`JointMap.residuals`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from judgeopt.planners.problem import InfeasibleProblemError, ProblemError
from judgeopt.recent import Recent
from judgeopt.tasks import get_task
from judgeopt.tasks.base import ArmModel
from judgeopt.trajectory import Plan

#: grid spacing of the tabulated kinematics (m): the B-spline's error is then far below 1e-6 relative
GRID_STEP = 0.0025
#: the grid reaches this far beyond [q_min, q_max] (m), where the arm reaches there
GRID_MARGIN = 0.02
#: positions sampled along a segment (m, at most) where a force or speed that holds every joint is computed
FINE_STEP = 0.0005

_CACHE: dict[tuple, "JointMap"] = {}
#: plans whose exact check a JointMap keeps
CHECKED_KEPT = 4


def joint_kinematics(arm: ArmModel, position: float, start: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """At the IK configuration of `position`: (q, joint velocity per unit axis velocity, gravity
    torques, torques per unit pressing force), exactly (Pinocchio)."""
    import pinocchio as pin

    model, data = arm.model, arm.data
    q = arm.ik(np.array([position]), start)
    J = pin.computeFrameJacobian(model, data, q, arm.tool_frame, pin.LOCAL_WORLD_ALIGNED)
    twist = np.concatenate([arm.axes[0], np.zeros(3)])
    wrench = np.concatenate([arm.force_axis, np.zeros(3)])
    # an arm with more joints than the tool's 6 coordinates: the least-norm joint velocities (the controller's
    # J+ xdd, its null space held still)
    rate = np.linalg.solve(J, twist) if J.shape[0] == J.shape[1] else np.linalg.pinv(J) @ twist
    gravity = pin.computeGeneralizedGravity(model, data, q).copy()
    return q, rate, gravity, J.T @ wrench


def joint_dynamics(arm: ArmModel, q: np.ndarray, rate: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """At configuration q, the tool moving along the axis with joint velocities `rate` per unit axis
    velocity: (torques per unit axis acceleration, torques per unit axis velocity squared), as the
    controller commands them: M qdd + C(q, qd) qd with qdd = J# (xdd - Jdot qd) and J# = M^-1 J^T Lambda
    (J^-1 on a six-joint arm; a seventh joint's null space gets no torque; Lambda a pseudo-inverse on
    an arm of five), i.e.
    J^T Lambda (xdd - Jdot qd) + C(q, qd) qd, each term scaling with yddot or ydot^2."""
    import pinocchio as pin

    model, data = arm.model, arm.data
    J = pin.computeFrameJacobian(model, data, q, arm.tool_frame, pin.LOCAL_WORLD_ALIGNED)
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T  # crba fills the upper triangle
    inverse_lambda = J @ np.linalg.solve(M, J.T)  # symmetric, so J^T Lambda = (Lambda J)^T
    # pinv: an arm of five joints moves the tool in five directions only (the twist lies among them)
    lam_JT = (np.linalg.solve(inverse_lambda, J) if J.shape[1] >= J.shape[0]
              else np.linalg.pinv(inverse_lambda, rcond=1e-10) @ J).T
    pin.forwardKinematics(model, data, q, rate, np.zeros(model.nv))
    drift = pin.getFrameClassicalAcceleration(model, data, arm.tool_frame, pin.LOCAL_WORLD_ALIGNED)  # Jdot qd
    coriolis = pin.rnea(model, data, q, rate, np.zeros(model.nv)) - pin.computeGeneralizedGravity(model, data, q)
    per_acc = lam_JT @ np.concatenate([arm.axes[0], np.zeros(3)])
    return per_acc, coriolis - lam_JT @ np.concatenate([drift.linear, drift.angular])


@dataclass
class JointMap:
    """How a one-axis task's plan maps to its arm's joints: limits (URDF) and tabulated kinematics."""

    names: tuple[str, ...]
    velocity_limit: np.ndarray  # rad/s per joint
    torque_limit: np.ndarray  # N m per joint
    grid: np.ndarray  # (G,) positions
    configs: np.ndarray  # (G, joints): the IK configurations (one continuous branch)
    rate: np.ndarray  # (G, joints): joint velocity per unit axis velocity
    gravity: np.ndarray  # (G, joints): gravity torques
    force: np.ndarray  # (G, joints): torques per unit pressing force
    arm: ArmModel
    inertia: np.ndarray | None = None  # (G, joints): torques per unit axis acceleration (None: a massless arm)
    velocity_product: np.ndarray | None = None  # (G, joints): torques per unit axis velocity squared
    _table: Any = field(default=None, repr=False)
    #: the last few plans' exact checks, by content: a solve checks its warm start and its plan, and the
    #: verdict each plan's binding joint, each IK at 2N + 1 points (about 20 ms on a 30-step plan)
    _checked: Recent = field(default_factory=lambda: Recent(CHECKED_KEPT), repr=False)

    @property
    def n_joints(self) -> int:
        return len(self.names)

    def table(self) -> Any:
        """One CasADi B-spline of position -> [rate, gravity, force, inertia, velocity product] (5 x joints
        outputs)."""
        if self._table is None:
            import casadi as cs

            zero = np.zeros_like(self.gravity)
            values = np.hstack([self.rate, self.gravity, self.force, zero if self.inertia is None else self.inertia,
                                zero if self.velocity_product is None else self.velocity_product])  # outputs fastest
            self._table = cs.interpolant("joint_table", "bspline", [self.grid], values.ravel(order="C"))
        return self._table

    def rows(self, q: Any, v: Any, f: Any, a: Any) -> Any:
        """Constraint rows normalised by the limits, for q, v, f (N + 1, 1) columns and the steps'
        accelerations a (N, 1): joint velocity / limit for k = 1..N (joints fastest), joint torque / limit
        at k = 0..N-1 leaving each sample (step k + 1's acceleration) and at k = 1..N entering it (step
        k's), then both halfway between samples (q, v, f their neighbours' means, as `exact(between=True)`
        checks them); hold them in [-scale, scale]."""
        import casadi as cs

        def mid(x: Any) -> Any:
            return 0.5 * (x[:-1] + x[1:])

        accel = cs.repmat(a.T, self.n_joints, 1)
        vel, (tau, per_acc) = self._rows(q, v, f)
        leaving, entering = tau[:, :-1] + per_acc[:, :-1] * accel, tau[:, 1:] + per_acc[:, 1:] * accel
        vel_mid, (tau_mid, per_acc_mid) = self._rows(mid(q), mid(v), mid(f))
        between = tau_mid + per_acc_mid * accel
        return cs.vertcat(cs.vec(vel[:, 1:]), cs.vec(leaving), cs.vec(entering), cs.vec(vel_mid), cs.vec(between))

    def _rows(self, q: Any, v: Any, f: Any) -> tuple[Any, tuple[Any, Any]]:
        """(joint velocity / limit, (joint torque but for the inertia's, torque per unit axis acceleration)
        / limit), (joints, points) each, at the points q, v, f."""
        import casadi as cs

        n, nj = q.shape[0], self.n_joints
        T = self.table().map(n)(cs.reshape(q, 1, n))  # (5 nj, n)
        rate, grav, force, inertia, product = (T[i * nj:(i + 1) * nj, :] for i in range(5))
        row = lambda x: cs.repmat(cs.reshape(x, 1, n), nj, 1)  # noqa: E731
        per_limit = cs.repmat(cs.DM(1.0 / self.torque_limit), 1, n)
        vel = rate * row(v) * cs.repmat(cs.DM(1.0 / self.velocity_limit), 1, n)
        tau = (grav + force * row(f) + product * row(v) ** 2) * per_limit
        return vel, (tau, inertia * per_limit)

    def exact(self, plan: Plan, between: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Joint velocities (N, joints; samples 1..N) and torques (N + 1, joints), from IK at each
        sample's position (not the tables), each sample's torque the larger in magnitude of the two it
        takes, entering and leaving it (the acceleration of the step before and after). `between`: also
        halfway between samples (position, velocity and force interpolated linearly, the step's
        acceleration), where a joint's rate can peak: rows 2N - 1 and 2N + 1."""
        key = (plan.dt, between, tuple(c.kind for c in plan.channels), plan.values.shape, plan.values.tobytes())
        return self._checked.get_or_make(key, lambda: self._exact(plan, between))

    def _exact(self, plan: Plan, between: bool) -> tuple[np.ndarray, np.ndarray]:
        pos = plan.values[:, _column(plan, "position")]
        vel = plan.values[:, _column(plan, "velocity")]
        force = plan.values[:, _column(plan, "force")]
        acc = np.diff(vel) / plan.dt
        # the accelerations each point takes: a sample the steps' on either side, a midpoint its step's
        sides = [acc[max(k - 1, 0):k + 1] for k in range(len(pos))]
        if between:
            pos, vel, force = (np.insert(x, np.arange(1, len(x)), 0.5 * (x[1:] + x[:-1])) for x in (pos, vel, force))
            sides = [s for k, here in enumerate(sides) for s in ([here] if k == 0 else [acc[k - 1:k], here])]
        rates, taus = [], []
        for y, ydot, fk, accs in zip(pos, vel, force, sides):
            start = self.configs[int(np.argmin(np.abs(self.grid - y)))]  # the tabulated branch
            q, rate, grav, per_f = joint_kinematics(self.arm, float(y), start)
            per_acc, per_v2 = joint_dynamics(self.arm, q, rate)
            rates.append(rate * ydot)
            both = [grav + per_f * fk + per_v2 * ydot ** 2 + per_acc * a for a in accs]
            taus.append(np.where(np.abs(both[0]) >= np.abs(both[-1]), both[0], both[-1]))
        out = np.array(rates)[1:], np.array(taus)
        for array in out:
            array.flags.writeable = False  # kept, and shared by every caller that checks this plan
        return out

    def residuals(self, plan: Plan, scale: float) -> dict[str, float]:
        """Worst |joint velocity| - scale * limit (rad/s) and |joint torque| - scale * limit (N m), >= 0,
        at the samples and halfway between them."""
        qd, tau = self.exact(plan, between=True)
        over_v = np.abs(qd) - scale * self.velocity_limit
        over_t = np.abs(tau) - scale * self.torque_limit
        return {"joint_velocity": max(0.0, float(over_v.max())),
                "joint_torque": max(0.0, float(over_t.max()))}

    def binding(self, plan: Plan, scale: float) -> tuple[str, str, float]:
        """(joint, "velocity" or "torque", |value| / (scale * limit)) of the joint nearest to (or
        furthest over) its scaled limit: what a suggestion names; at the samples and halfway between them,
        where `residuals` checks them (a joint over its limit only between samples is named as over it)."""
        qd, tau = self.exact(plan, between=True)
        rv = (np.abs(qd) / (scale * self.velocity_limit)).max(axis=0)
        rt = (np.abs(tau) / (scale * self.torque_limit)).max(axis=0)
        if rv.max() > rt.max():
            j = int(np.argmax(rv))
            return self.names[j], "velocity", float(rv[j])
        j = int(np.argmax(rt))
        return self.names[j], "torque", float(rt[j])

    def along(self, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(positions, rate, gravity, force per unit pressing force), the last three (positions, joints): the
        tables at every FINE_STEP of [lo, hi], both ends included."""
        ys = np.linspace(lo, hi, max(2, int(np.ceil((hi - lo) / FINE_STEP)) + 1))
        T = np.array(self.table().map(len(ys))(ys.reshape(1, -1)))  # (5 nj, n): the first three read here
        nj = self.n_joints
        return ys, T[:nj].T, T[nj:2 * nj].T, T[2 * nj:3 * nj].T

    def force_window(self, lo: float, hi: float, scale: float) -> "ForceWindow":
        """The pressing forces f at which every joint's torque |g + a f| stays within scale x its limit at every
        position of [lo, hi]: at each position an interval of f (its joints' intervals intersected), of which
        the largest lower end and the smallest upper end over the positions, each with the joint and position
        that set it; and the position where no force at all holds, if there is one."""
        ys, _, grav, per_f = self.along(lo, hi)
        lim = scale * self.torque_limit
        a = np.where(np.abs(per_f) > 1e-12, per_f, np.nan)  # NaN (no warning) where the force makes no torque
        ends = np.stack([(-lim - grav) / a, (lim - grav) / a])  # (2, positions, joints)
        f_lo = np.where(np.isnan(a), np.where(np.abs(grav) <= lim, -np.inf, np.inf), ends.min(axis=0))
        f_hi = np.where(np.isnan(a), np.where(np.abs(grav) <= lim, np.inf, -np.inf), ends.max(axis=0))
        lo_y, hi_y = f_lo.max(axis=1), f_hi.min(axis=1)  # per position: the forces every joint holds
        i_lo, i_hi = int(np.argmax(lo_y)), int(np.argmin(hi_y))
        empty = np.flatnonzero(lo_y > hi_y)
        return ForceWindow(low=float(lo_y[i_lo]), low_joint=self.names[int(np.argmax(f_lo[i_lo]))],
                           low_at=float(ys[i_lo]), high=float(hi_y[i_hi]),
                           high_joint=self.names[int(np.argmin(f_hi[i_hi]))], high_at=float(ys[i_hi]),
                           nowhere=float(ys[empty[0]]) if len(empty) else None)

    def torque_at(self, joint: str, position: float, f: float) -> float:
        """Joint `joint`'s torque (N m, from the tables) at `position`, pressing with `f`."""
        _, _, grav, per_f = self.along(position, position)
        j = self.names.index(joint)
        return float(grav[0, j] + per_f[0, j] * f)

    def speed_cap(self, lo: float, hi: float, scale: float) -> tuple[float, str, float]:
        """(speed, joint, position): the fastest the tool may move along the axis at every position of [lo, hi]
        with every joint's velocity within scale x its limit, and the joint and position that set it."""
        ys, rate, _, _ = self.along(lo, hi)
        with np.errstate(divide="ignore"):
            cap = scale * self.velocity_limit / np.abs(rate)  # (positions, joints)
        i, j = np.unravel_index(int(np.argmin(cap)), cap.shape)
        return float(cap[i, j]), self.names[j], float(ys[i])

    def check_path(self, problem: Any, env: dict[str, float], robot: str | None = None) -> None:
        """Raise InfeasibleProblemError where no plan can hold the joints' torques (or speeds) on the positions
        every plan passes through, from the start q0 to the terminal position: the joint, what it needs of its
        limit, and the value of a limit at which they hold (computed from the tables, not searched). At rest:
        what the arm's inertia adds while it moves is the direct solve's to hold."""
        scale = problem.joint_limit_scale
        q0, end = float(problem.vec("q0")[0]), float(problem.terminal_positions(env)[0])
        lo, hi = (q0, q0) if np.isnan(end) else (min(q0, end), max(q0, end))
        f_min, f_max = float(problem.vec("f_min")[0]), float(problem.vec("f_max")[0])
        who = f"robot {robot!r}" if robot else "the arm"
        limits = ", ".join(f"{j} {scale * t:.3g}" for j, t in zip(self.names, self.torque_limit))
        w = self.force_window(lo, hi, scale)
        path = f"on the path from q0 = {q0:g} to {end:g} m" if hi > lo else f"at q0 = {q0:g} m"
        if w.nowhere is not None:
            name, need, limit = self._worst(w.nowhere, max(f_min, 0.0), scale)
            raise InfeasibleProblemError(
                f"{who} cannot hold its joints' torques at y = {w.nowhere:.3g} m {path} whatever the pressing force: "
                f"{name} needs {abs(need):.3g} N m of its {limit:.3g} N m at f = {max(f_min, 0.0):g} N; a stronger "
                f"arm (its limits x {scale:g}: {limits} N m), a lighter tool, or an end it reaches otherwise",
                ["limits.f_min/f_max", "joint_limit_scale"])
        if w.high < f_min:
            need, limit = self.torque_at(w.high_joint, w.high_at, f_min), scale * self._limit(w.high_joint)
            at_max = self.torque_at(w.high_joint, w.high_at, f_max)
            value = _rounded(w.high, -1)
            raise InfeasibleProblemError(
                f"{who} is too weak for f_min = {f_min:g} N: {w.high_joint} needs {abs(need):.3g} N m of its "
                f"{limit:.3g} N m at y = {w.high_at:.3g} m {path} (at f_max = {f_max:g} N: {abs(at_max):.3g} N m); "
                f"every joint holds its torque there with f_min <= {value:g} N (--f-min {value:g}), or with a "
                "stronger arm", ["limits.f_min/f_max", "joint_limit_scale"])
        if w.low > f_max:
            value = _rounded(w.low, +1)
            raise InfeasibleProblemError(
                f"{who} holds {w.low_joint}'s torque at y = {w.low_at:.3g} m {path} only pressing with at least "
                f"{w.low:.3g} N, above f_max = {f_max:g} N: --f-max {value:g}, or a stronger arm",
                ["limits.f_min/f_max", "joint_limit_scale"])
        if hi > lo:
            self._check_time(problem, lo, hi, end > q0, scale, who, path)

    def _check_time(self, problem: Any, lo: float, hi: float, forward: bool, scale: float, who: str, path: str) -> None:
        """The joints' speed limits cap the tool's speed at each position: a path that takes longer than the
        horizon at that speed (or the velocity box, where lower) admits no plan."""
        ys, rate, _, _ = self.along(lo, hi)
        box = float(problem.vec("qdot_max")[0] if forward else -problem.vec("qdot_min")[0])
        if box <= 0:
            return  # the boxes' own conflict: Problem.check_feasible reports it
        with np.errstate(divide="ignore"):
            cap = scale * self.velocity_limit / np.abs(rate)
        speed = np.minimum(cap.min(axis=1), box)
        mid = 0.5 * (1.0 / speed[1:] + 1.0 / speed[:-1])
        least = float(np.sum(mid * np.diff(ys)))  # the trapezoid rule on dt/dy
        horizon = problem.steps * problem.dt
        if least > horizon:
            i, j = np.unravel_index(int(np.argmin(cap)), cap.shape)
            raise InfeasibleProblemError(
                f"{who} is too slow {path}: {self.names[j]}'s {scale * self.velocity_limit[j]:.3g} rad/s caps the "
                f"tool at {cap[i, j]:.3g} m/s at y = {ys[i]:.3g} m, so the path takes at least {least:.3g} s of the "
                f"{horizon:g} s horizon: a nearer end, or a faster arm",
                ["limits.qdot_min/qdot_max", "joint_limit_scale"])

    def _limit(self, joint: str) -> float:
        return float(self.torque_limit[self.names.index(joint)])

    def _worst(self, position: float, f: float, scale: float) -> tuple[str, float, float]:
        """(joint, torque, scaled limit) of the joint furthest over its limit at `position`, pressing `f`."""
        _, _, grav, per_f = self.along(position, position)
        tau = grav[0] + per_f[0] * f
        j = int(np.argmax(np.abs(tau) / self.torque_limit))
        return self.names[j], float(tau[j]), float(scale * self.torque_limit[j])

    def _backward(self, plan: Plan, joint: str) -> bool:
        """Whether `joint` runs fastest while the tool moves back (towards lower y): the limit to name is then
        qdot_min, not qdot_max (from the tables: the joint's rate at each sample times the tool's velocity)."""
        pos = plan.values[:, _column(plan, "position")]
        vel = plan.values[:, _column(plan, "velocity")]
        ys, rate, _, _ = self.along(float(pos.min()), float(pos.max()))
        speed = np.abs(np.interp(pos, ys, rate[:, self.names.index(joint)]) * vel)
        return bool(vel[int(np.argmax(speed))] < 0)

    def advice(self, plan: Plan, scale: float, f_min: float | None = None) -> str:
        """For a plan whose binding joint (`binding`) is at or over its limit: the limit's value at which every
        joint holds on the positions this plan passes through (computed from the tables), as a phrase; empty
        where no joint binds. `f_min`: the problem's, named too where it is above that value."""
        joint, quantity, ratio = self.binding(plan, scale)
        if ratio < 1.0 - 1e-3:
            return ""
        pos = plan.values[:, _column(plan, "position")]
        lo, hi = float(pos.min()), float(pos.max())
        if quantity == "velocity":
            cap, name, at = self.speed_cap(lo, hi, scale)
            bound = (f"qdot_min >= {-_rounded(cap, -1):g}" if self._backward(plan, joint)
                     else f"qdot_max <= {_rounded(cap, -1):g}")
            return f"every joint's speed holds on this plan's positions with {bound} m/s ({name} at y = {at:.3g} m)"
        w = self.force_window(lo, hi, scale)
        if w.nowhere is not None or w.high < 0:
            return f"no pressing force holds {joint}'s torque on this plan's positions (at y = {w.high_at:.3g} m)"
        f_max = float(plan.values[:, _column(plan, "force")].max())
        need = self.torque_at(w.high_joint, w.high_at, f_max)
        cap = _rounded(w.high, -1)
        also = f" and f_min < {cap:g} N" if f_min is not None and f_min >= cap else ""
        limit = scale * self._limit(w.high_joint)
        return (f"{w.high_joint} caps the pressing force at {w.high:.3g} N at y = {w.high_at:.3g} m (pressing the "
                f"plan's {f_max:.3g} N there, it would need {abs(need):.3g} N m of its {limit:.3g}); "
                f"every joint's torque holds on these positions with f_max <= {cap:g} N{also}")


@dataclass(frozen=True)
class ForceWindow:
    """JointMap.force_window: pressing forces in [low, high] hold every joint's torque at every position of a
    segment; each end with the joint and position that set it; `nowhere`: a position where no force does."""

    low: float
    low_joint: str
    low_at: float
    high: float
    high_joint: str
    high_at: float
    nowhere: float | None = None


def _rounded(value: float, direction: int, digits: int = 3) -> float:
    """`value` to `digits` significant digits, rounded towards where the limit holds (down: -1, up: +1)."""
    if value == 0 or not np.isfinite(value):
        return value
    step = 10.0 ** (np.floor(np.log10(abs(value))) - digits + 1)
    units = round(value / step, 6)
    return float(f"{(np.ceil(units) if direction > 0 else np.floor(units)) * step:.{digits}g}")


def _column(plan: Plan, kind: str) -> int:
    return next(j for j, c in enumerate(plan.channels) if c.kind == kind)


def tabulate(arm: ArmModel, lo: float, hi: float, seed: float, step: float = GRID_STEP,
             margin: float = GRID_MARGIN, robot: str | None = None) -> JointMap:
    """The JointMap of `arm` over [lo, hi] (and `margin` beyond, where the arm reaches). The IK
    branch is the one the arm holds at `seed` (the plan's start, where the simulator places it from
    the home posture), followed continuously outwards: the arm moves, it does not jump branches
    (IK from the home posture alone switches the UR5 to another branch near y = 0.4 m). A position
    in [lo, hi] the arm cannot hold the tool at: InfeasibleProblemError naming it and the fix."""
    def unreachable(y: float, what: str) -> InfeasibleProblemError:
        return InfeasibleProblemError(
            f"{f'robot {robot!r}' if robot else 'the arm'} cannot hold the tool at {what} {y:.4g} m (its IK does not "
            f"converge there), within the positions [q_min, q_max] = [{lo:g}, {hi:g}] m: keep the positions on the "
            f"segment it reaches (`judgeopt robots {robot or 'NAME'} --reach`), or place the arm nearer the line (its "
            "base_xyz)", ["limits.q_min/q_max", "robot"])

    n = int(np.ceil((hi - lo + 2 * margin) / step)) + 1
    grid = np.linspace(lo - margin, hi + margin, n)
    i0 = int(np.argmin(np.abs(grid - seed)))
    try:
        q_seed = arm.ik(np.array([seed]), None)
    except ValueError:
        raise unreachable(seed, "the start q0 =") from None
    found: dict[int, tuple] = {}
    for order in (range(i0, n), range(i0 - 1, -1, -1)):
        start = q_seed
        for i in order:
            y = float(grid[i])
            try:
                found[i] = joint_kinematics(arm, y, start)
            except ValueError:
                if lo <= y <= hi:
                    raise unreachable(y, "position") from None
                break
            start = found[i][0]
    idx = sorted(found)
    model = arm.model
    dynamics = [joint_dynamics(arm, found[i][0], found[i][1]) for i in idx]
    return JointMap(names=arm.joints, velocity_limit=np.array(model.velocityLimit, dtype=float),
                    torque_limit=np.array(model.effortLimit, dtype=float), grid=grid[idx],
                    configs=np.array([found[i][0] for i in idx]), rate=np.array([found[i][1] for i in idx]),
                    gravity=np.array([found[i][2] for i in idx]), force=np.array([found[i][3] for i in idx]), arm=arm,
                    inertia=np.array([d[0] for d in dynamics]), velocity_product=np.array([d[1] for d in dynamics]))


def joint_map(problem: Any) -> JointMap:
    """The JointMap of `problem`'s task over its position limits, on the IK branch of its start
    q0 (cached per task, limits and start);
    a one-line ProblemError where the task offers no arm or has more than one position axis."""
    task = get_task(problem.task)
    if len(task.channels_of("position")) != 1:
        raise ProblemError(f"joint_limit_scale: task {task.name!r} has {len(task.channels_of('position'))} position "
                           "axes; the arm's joint limits are held for one-axis tasks only")
    lo, hi, q0 = (float(problem.vec(k)[0]) for k in ("q_min", "q_max", "q0"))
    key = (task.name, getattr(problem, "robot", None), lo, hi, q0)
    if key not in _CACHE:
        arm = task.arm_model(problem)
        if arm is None:
            raise ProblemError(f"joint_limit_scale: task {task.name!r} has no arm model (Task.arm_model), "
                               "so its joint limits cannot be held; leave joint_limit_scale out")
        _CACHE[key] = tabulate(arm, lo, hi, q0, robot=getattr(problem, "robot", None))
    return _CACHE[key]
