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
from judgeopt.planners.dynamics import accelerations
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
    """The documented warm start when no generator is available: a minimum-jerk move from q0
    to q_end over the horizon (velocity clipped to the limits), pressing at the middle of the
    force range."""
    n, dt = problem.steps, problem.dt
    s = np.linspace(0.0, 1.0, n + 1)
    d = problem.terminal_position(env) - problem.q0
    T = n * dt
    v = np.clip(d / T * (30 * s**2 - 60 * s**3 + 30 * s**4), problem.qdot_min, problem.qdot_max)
    v[0], v[-1] = problem.qdot0, problem.qdot_end
    q = problem.q0 + np.concatenate([[0.0], np.cumsum(0.5 * dt * (v[:-1] + v[1:]))])
    f = np.full(n + 1, 0.5 * (problem.f_min + problem.f_max))
    return Plan.from_columns(dt, problem.channel_spec, q, v, f)


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
        zq, zv, za, zf = (cs.MX.sym(name, size) for name, size in (("q", n), ("v", n), ("a", n), ("f", n + 1)))
        self._sizes = (n, n, n, n + 1)
        q, v, a, f = SCALE_Q * zq, SCALE_V * zv, SCALE_A * za, SCALE_F * zf
        env = cs.MX.sym("env", self.cjudge.n_env)
        q_end = cs.MX.sym("q_end")
        qs = cs.vertcat(pr.q0, q)
        vs = cs.vertcat(pr.qdot0, v)
        # integration as constraints, scaled by the step's typical size
        g_vel = (vs[1:] - vs[:-1] - a * dt) / (SCALE_V)
        g_pos = (qs[1:] - qs[:-1] - 0.5 * dt * (vs[:-1] + vs[1:])) / (SCALE_Q * 0.1)
        g_term = cs.vertcat((qs[-1] - q_end) / SCALE_Q, (vs[-1] - pr.qdot_end) / SCALE_V)
        traj = cs.reshape(cs.horzcat(qs, vs, f).T, -1, 1)  # row-major [y, ydot, f] per sample
        logit = self.cjudge.fn(traj, env)[0] if not self.members else self._pessimistic(traj, env)
        neg_log_p = cs.fmax(-logit, 0) + cs.log1p(cs.exp(-cs.fabs(logit)))  # softplus(-logit), stable
        obj = pr.P * neg_log_p + pr.acc_weight * dt * cs.sumsqr(a) + pr.force_rate_weight * cs.sumsqr(cs.diff(f)) / dt
        g = [g_vel, g_pos, g_term]
        if pr.p_min is not None:
            g.append(logit)
        if pr.trust_region is not None:
            g.append(self.trust.casadi_distance2(traj) / pr.trust_region ** 2)  # <= 1
        x = cs.vertcat(zq, zv, za, zf)
        nlp = {"x": x, "p": cs.vertcat(env, q_end), "f": obj, "g": cs.vertcat(*g)}
        opts = {"ipopt.hessian_approximation": "limited-memory", "ipopt.max_iter": pr.max_iter,
                "ipopt.tol": pr.tol, "ipopt.constr_viol_tol": 1e-9, "ipopt.acceptable_iter": 0,
                "ipopt.print_level": self.options.print_level, "ipopt.max_cpu_time": self.options.max_cpu_time,
                "ipopt.sb": "yes", "print_time": False}
        self.solver = cs.nlpsol("judgeopt_direct", "ipopt", nlp, opts)
        self._n_eq = 2 * n + 2
        self._bounds()

    def _bounds(self) -> None:
        """Variable bounds from the problem's limits, and the constraint bounds."""
        pr, n = self.problem, self.problem.steps
        lb = np.concatenate([np.full(n, pr.q_min / SCALE_Q), np.full(n, pr.qdot_min / SCALE_V), np.full(n, -np.inf),
                             np.full(n + 1, pr.f_min / SCALE_F)])
        ub = np.concatenate([np.full(n, pr.q_max / SCALE_Q), np.full(n, pr.qdot_max / SCALE_V), np.full(n, np.inf),
                             np.full(n + 1, pr.f_max / SCALE_F)])
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
        z = [m.fn(traj, env)[0] for m in self.members]
        if np.isinf(self.problem.pessimism):
            out = z[0]
            for zi in z[1:]:
                out = cs.fmin(out, zi)
            return out
        mean = sum(z) / len(z)
        var = sum((zi - mean) ** 2 for zi in z) / len(z)
        return mean - self.problem.pessimism * cs.sqrt(var + 1e-9)

    def _pack(self, plan: Plan) -> np.ndarray:
        a = accelerations(plan.ydot, plan.dt)
        return np.concatenate([plan.y[1:] / SCALE_Q, plan.ydot[1:] / SCALE_V, a / SCALE_A, plan.f / SCALE_F])

    def _unpack(self, x: np.ndarray) -> Plan:
        n = self.problem.steps
        q = np.concatenate([[self.problem.q0], x[:n] * SCALE_Q])
        v = np.concatenate([[self.problem.qdot0], x[n:2 * n] * SCALE_V])
        f = x[3 * n:] * SCALE_F
        return Plan.from_columns(self.problem.dt, self.problem.channel_spec, q, v, f)

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
        p = np.concatenate([judge_env(self.judge, env), [pr.terminal_position(env)]])
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
