"""Direct solve of one instance with Ipopt: maximise the judge under HARD constraints.

Decision variables (lifted, one block per sample): positions q_1..q_N, velocities q̇_1..q̇_N,
accelerations a_1..a_N and forces f_0..f_N, all scaled to O(1). Why lifted rather than
accelerations only: position, velocity and force limits become simple bounds, which Ipopt
keeps exactly (its final point is projected into the original bounds), and the integration
(dynamics.py) becomes 2N linear equalities that hold to rounding after the first Newton step.
The terminal state is two more equalities; the optional y_judge >= p_min is one inequality
on the logit. The objective is eq. (3), P softplus(-logit) = -P log y_judge, plus two small
smoothing terms. The judge has no usable second derivatives (l4casadi exposes first ones),
so Ipopt runs with a limited-memory (L-BFGS) Hessian.

One solver is built per problem; the environment and q_end are parameters, so solving many
environments re-uses it.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass

import casadi as cs
import numpy as np

from judgeopt.judge.casadi_fn import CasadiJudge
from judgeopt.judge.ensemble import pessimistic
from judgeopt.judge.model import Judge
from judgeopt.planners.dynamics import accelerations, channel_order, plan_from_parts, positions
from judgeopt.planners.problem import LIMIT_NAMES, InfeasibleProblemError, Problem, ProblemError
from judgeopt.planners.trust_region import TrustRegion
from judgeopt.planners.result import PlanResult, constraint_residuals, infeasible_result
from judgeopt.trajectory import Plan

# variable scales (m, m/s, m/s^2, N): the scaled unknowns are O(1), which L-BFGS needs
SCALE_Q, SCALE_V, SCALE_A, SCALE_F = 0.1, 0.5, 5.0, 10.0

STATUS = {"Solve_Succeeded": "solved", "Solved_To_Acceptable_Level": "solved",
          "Infeasible_Problem_Detected": "infeasible", "Maximum_Iterations_Exceeded": "not_converged",
          "Maximum_CpuTime_Exceeded": "not_converged", "Restoration_Failed": "not_converged",
          "Search_Direction_Becomes_Too_Small": "not_converged", "Error_In_Step_Computation": "not_converged"}


def judge_env(judge: Judge, env: dict[str, float]) -> np.ndarray:
    """The judge's environment vector (it may read only some of the problem's variables)."""
    return np.array([env[k] for k in judge.config.env_names], dtype=float)


def default_guess(problem: Problem, env: dict[str, float]) -> Plan:
    """The documented warm start when no generator is available: per axis a minimum-jerk move
    from q0 to q_end (a free end: the middle of the position limits) over the horizon (velocity
    clipped to the limits), pressing at the middle of the force range."""
    n, dt = problem.steps, problem.dt
    s = np.linspace(0.0, 1.0, n + 1)
    T = n * dt
    ends = problem.terminal_positions(env)
    q0, qd0, qd_end = problem.vec("q0"), problem.vec("qdot0"), problem.vec("qdot_end")
    lo, hi = problem.vec("qdot_min"), problem.vec("qdot_max")
    qs, vs = [], []
    for i in range(problem.n_axes):
        end = ends[i] if not np.isnan(ends[i]) else 0.5 * (problem.vec("q_min")[i] + problem.vec("q_max")[i])
        d = end - q0[i]
        v = np.clip(d / T * (30 * s**2 - 60 * s**3 + 30 * s**4), lo[i], hi[i])
        v[0], v[-1] = qd0[i], qd_end[i]
        qs.append(positions(q0[i], v, dt))
        vs.append(v)
    f = [np.full(n + 1, m) for m in 0.5 * (problem.vec("f_min") + problem.vec("f_max"))]
    return plan_from_parts(problem, np.stack(qs, 1), np.stack(vs, 1), np.stack(f, 1))


@dataclass
class DirectOptions:
    print_level: int = 0
    max_cpu_time: float = 60.0


class DirectPlanner:
    """Ipopt over the judge's CasADi function for one problem (any environment in it)."""

    method = "direct"

    def __init__(self, problem: Problem, judge: Judge, cjudge: CasadiJudge, options: DirectOptions | None = None,
                 members: list[CasadiJudge] | None = None, trust: TrustRegion | None = None):
        """`members`: an ensemble's CasADi judges (the objective becomes mean - pessimism * std
        of their logits); `trust`: the demonstrations' model for the trust-region constraint
        (used when the problem sets trust_region)."""
        for cj in [cjudge] + list(members or []):
            if cj.horizon != problem.steps:
                raise InfeasibleProblemError(f"the judge was built for N = {cj.horizon} steps, the problem has "
                                             f"{problem.steps}", ["horizon.steps"])
        if problem.trust_region is not None and trust is None:
            raise ProblemError("trust_region is set but no trust-region model was given (see [models] trust_model)")
        self.problem, self.judge, self.cjudge = problem, judge, cjudge
        self.members, self.trust = list(members or []), trust
        self.options = options or DirectOptions()
        self._build()

    def _build(self) -> None:
        pr, n, dt = self.problem, self.problem.steps, self.problem.dt
        na, nf = pr.n_axes, pr.n_forces
        # one column per axis (force channel); vectorised column by column, so one axis is one vector
        zq, zv, za, zf = (cs.MX.sym(name, rows, cols) for name, rows, cols in (
            ("q", n, na), ("v", n, na), ("a", n, na), ("f", n + 1, nf)))
        q, v, a, f = SCALE_Q * zq, SCALE_V * zv, SCALE_A * za, SCALE_F * zf
        env = cs.MX.sym("env", self.cjudge.n_env)
        self._fixed = ~np.isnan(pr.terminal_positions({k: 0.0 for k in pr.env_names}))  # axes with an end
        q_end = cs.MX.sym("q_end", int(self._fixed.sum()))
        qs = cs.vertcat(cs.DM(pr.vec("q0")).T if na > 1 else pr.vec("q0")[0], q)
        vs = cs.vertcat(cs.DM(pr.vec("qdot0")).T if na > 1 else pr.vec("qdot0")[0], v)
        # integration as constraints, scaled by the step's typical size
        g_vel = cs.vec((vs[1:, :] - vs[:-1, :] - a * dt) / (SCALE_V))
        g_pos = cs.vec((qs[1:, :] - qs[:-1, :] - 0.5 * dt * (vs[:-1, :] + vs[1:, :])) / (SCALE_Q * 0.1))
        ends = [(qs[-1, i] - q_end[j]) / SCALE_Q for j, i in enumerate(np.flatnonzero(self._fixed))]
        qd_end = pr.vec("qdot_end")
        g_term = cs.vertcat(*ends, *[(vs[-1, i] - qd_end[i]) / SCALE_V for i in range(na)])
        parts = [qs[:, i] for i in range(na)] + [vs[:, i] for i in range(na)] + [f[:, i] for i in range(nf)]
        traj = cs.reshape(cs.horzcat(*[parts[k] for k in channel_order(pr)]).T, -1, 1)  # row-major, channel order
        logit = self.cjudge.fn(traj, env)[0] if not self.members else self._pessimistic(traj, env)
        neg_log_p = cs.fmax(-logit, 0) + cs.log1p(cs.exp(-cs.fabs(logit)))  # softplus(-logit), stable
        rate = cs.diff(f) if nf == 1 else f[1:, :] - f[:-1, :]
        obj = pr.P * neg_log_p + pr.acc_weight * dt * cs.sumsqr(a) + pr.force_rate_weight * cs.sumsqr(rate) / dt
        g = [g_vel, g_pos, g_term]
        if pr.p_min is not None:
            g.append(logit)
        if pr.trust_region is not None:
            g.append(self.trust.casadi_distance2(traj) / pr.trust_region ** 2)  # <= 1
        x = cs.vertcat(cs.vec(zq), cs.vec(zv), cs.vec(za), cs.vec(zf))
        nlp = {"x": x, "p": cs.vertcat(env, q_end), "f": obj, "g": cs.vertcat(*g)}
        opts = {"ipopt.hessian_approximation": "limited-memory", "ipopt.max_iter": pr.max_iter,
                "ipopt.tol": pr.tol, "ipopt.constr_viol_tol": 1e-9, "ipopt.acceptable_iter": 0,
                "ipopt.print_level": self.options.print_level, "ipopt.max_cpu_time": self.options.max_cpu_time,
                "ipopt.sb": "yes", "print_time": False}
        self.solver = cs.nlpsol("judgeopt_direct", "ipopt", nlp, opts)
        self._n_eq = 2 * n * na + int(self._fixed.sum()) + na
        self._bounds()

    def _bounds(self) -> None:
        """Variable bounds from the problem's limits, and the constraint bounds."""
        pr, n = self.problem, self.problem.steps

        def column(values: np.ndarray, rows: int, scale: float) -> np.ndarray:  # one block per axis
            return np.concatenate([np.full(rows, x / scale) for x in values])

        free = np.full(pr.n_axes, np.inf)
        lb = np.concatenate([column(pr.vec("q_min"), n, SCALE_Q), column(pr.vec("qdot_min"), n, SCALE_V),
                             column(-free, n, 1.0), column(pr.vec("f_min"), n + 1, SCALE_F)])
        ub = np.concatenate([column(pr.vec("q_max"), n, SCALE_Q), column(pr.vec("qdot_max"), n, SCALE_V),
                             column(free, n, 1.0), column(pr.vec("f_max"), n + 1, SCALE_F)])
        self._lbx, self._ubx = lb, ub
        self._lbg = np.zeros(self._n_eq)
        self._ubg = np.zeros(self._n_eq)
        if pr.p_min is not None:
            lp = float(np.log(pr.p_min / (1 - pr.p_min)))
            self._lbg, self._ubg = np.append(self._lbg, lp), np.append(self._ubg, np.inf)
        if pr.trust_region is not None:
            self._lbg, self._ubg = np.append(self._lbg, -np.inf), np.append(self._ubg, 1.0)

    def with_limits(self, problem: Problem) -> "DirectPlanner":
        """The same compiled solver for a problem that differs only in its position, velocity
        and force limits (they are variable bounds): no rebuild, so re-planning under relaxed
        or sampled limits costs one solve."""
        same = {k: v for k, v in problem.to_dict().items() if k not in LIMIT_NAMES}
        if same != {k: v for k, v in self.problem.to_dict().items() if k not in LIMIT_NAMES}:
            raise ProblemError("with_limits: the problems differ in more than their limits; build a new DirectPlanner")
        new = copy.copy(self)
        new.problem = problem
        new._bounds()
        return new

    def _pessimistic(self, traj: cs.MX, env: cs.MX) -> cs.MX:
        """mean - pessimism * std of the members' logits (pessimism = inf: their minimum)."""
        return pessimistic([m.fn(traj, env)[0] for m in self.members], self.problem.pessimism, cs.sqrt, cs.fmin, 1e-9)

    def _pack(self, plan: Plan) -> np.ndarray:
        q, v, f = (plan.values[:, plan.columns(kind)] for kind in ("position", "velocity", "force"))
        a = accelerations(v, plan.dt)
        return np.concatenate([q[1:].T.ravel() / SCALE_Q, v[1:].T.ravel() / SCALE_V, a.T.ravel() / SCALE_A,
                               f.T.ravel() / SCALE_F])

    def _unpack(self, x: np.ndarray) -> Plan:
        pr, n = self.problem, self.problem.steps
        na, nf = pr.n_axes, pr.n_forces
        q = np.vstack([pr.vec("q0"), x[:n * na].reshape(na, n).T * SCALE_Q])
        v = np.vstack([pr.vec("qdot0"), x[n * na:2 * n * na].reshape(na, n).T * SCALE_V])
        f = x[3 * n * na:].reshape(nf, n + 1).T * SCALE_F
        return plan_from_parts(pr, q, v, f)

    def solve(self, env: dict[str, float], guess: Plan | None = None) -> PlanResult:
        """Solve for one environment; infeasible limits are reported without calling Ipopt."""
        pr = self.problem
        env = pr.env_dict(env)
        t0 = time.perf_counter()
        if (infeasible := infeasible_result(self.method, pr, env)) is not None:
            return infeasible
        warm = "generator" if guess is not None else "min-jerk guess"
        guess = guess if guess is not None else default_guess(pr, env)
        x0 = np.clip(self._pack(guess), self._lbx, self._ubx)
        p = np.concatenate([judge_env(self.judge, env), pr.terminal_positions(env)[self._fixed]])
        sol = self.solver(x0=x0, p=p, lbx=self._lbx, ubx=self._ubx, lbg=self._lbg, ubg=self._ubg)
        elapsed = time.perf_counter() - t0
        stats = self.solver.stats()
        ipopt_status = stats.get("return_status", "unknown")
        plan = self._unpack(np.asarray(sol["x"]).ravel())
        residuals = constraint_residuals(pr, plan, env)
        traj, je = plan.as_array().ravel(), judge_env(self.judge, env)
        info = {"ipopt_status": ipopt_status, "warm_start": warm}
        if self.members:  # the ensemble's own prediction: the mean of its members' probabilities
            z = np.array([float(m.fn(traj, je)[0]) for m in self.members])
            prob = float(np.mean(1.0 / (1.0 + np.exp(-z))))
            bound = float(1.0 / (1.0 + np.exp(-pessimistic(z, pr.pessimism))))
            info.update(member_success=(1.0 / (1.0 + np.exp(-z))).tolist(), pessimistic_success=bound)
        else:
            bound = prob = float(1.0 / (1.0 + np.exp(-float(self.cjudge.fn(traj, je)[0]))))
        status = STATUS.get(ipopt_status, "failed")
        message = f"Ipopt: {ipopt_status}"
        if pr.p_min is not None:
            residuals["p_min"] = max(0.0, pr.p_min - bound)
        if pr.trust_region is not None:
            d = float(self.trust.distance(traj)[0])
            residuals["trust_region"] = max(0.0, d - pr.trust_region)
            info["trust_distance"] = d
        if status == "infeasible":
            worst = sorted((k for k, v in residuals.items() if v > 1e-6), key=residuals.get, reverse=True)
            message += f"; constraints left violated: {', '.join(worst) or 'none measurable'}"
        return PlanResult(self.method, env, plan, prob, status, elapsed, residuals,
                          iterations=int(stats.get("iter_count", -1)), message=message, info=info)
