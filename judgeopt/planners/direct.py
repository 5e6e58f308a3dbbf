"""Direct solve of one instance with Ipopt, under HARD constraints.

Decision variables (lifted, one block per sample): positions q_1..q_N, velocities q̇_1..q̇_N,
accelerations a_1..a_N and forces f_0..f_N, all scaled to O(1). Why lifted rather than
accelerations only: position, velocity and force limits become simple bounds, which Ipopt
keeps exactly (its final point is projected into the original bounds), and the integration
(dynamics.py) becomes 2N linear equalities that hold to rounding after the first Newton step.
The terminal state is two more equalities; the optional y_judge >= p_min is one inequality.

Objectives (Problem.objective):
  "target" (default)  least effort and least change to the warm start, subject to the judge's
      logit >= logit(p_target). A saturated judge (p = 1.000 everywhere near a good plan) gives
      -log p no curvature and no optimum worth the iterations; this has a well-defined one next
      to its start, so a warm start converges in a few iterations. The judge enters only as a
      constraint, so its curvature can be left out of the Hessian (every other term's is exact
      and constant), and its float32 noise is harmless. A slack lets an unreachable target give
      the judge's best instead; a start far below the target is raised TARGET_STEP at a time.
  "log_p"  the paper's eq. (3), P softplus(-logit) = -P log y_judge, with the judge's Hessian
      replaced by its Gauss-Newton term (or L-BFGS for everything: DirectOptions.hessian).
Both add two small smoothing terms. The derivatives Ipopt gets are built here (grad_f, jac_g,
hess_lag): the judge's gradient by one reverse sweep, not CasADi's Jacobian of it.

One solver is built per problem; the environment and q_end are parameters, so solving many
environments re-uses it. benchmarks/bench_direct.py measures each of these choices.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import casadi as cs
import numpy as np

from judgeopt.interrupts import sigint_recorded
from judgeopt.judge.compiled import CasadiJudge, CompiledJudge, sigmoid
from judgeopt.planners.cold_start import cold_start, default_guess
from judgeopt.planners.dynamics import accelerations, channel_order, plan_from_parts, step_residuals
from judgeopt.planners.base import BuildContext, Planner
from judgeopt.planners.constraints import RATE_LIMITS, is_constraint_key, per_channel
from judgeopt.planners.problem import LIMIT_NAMES, InfeasibleProblemError, Problem, ProblemError
from judgeopt.planners.trust_region import TrustRegion, load_trust_region
from judgeopt.verdict.risk import HOLD_TOL
from judgeopt.planners.result import PlanResult, constraint_residuals, infeasible_result, meets_target
from judgeopt.trajectory import Plan

if TYPE_CHECKING:
    from judgeopt.judge.model import Judge

# variable scales (m, m/s, m/s^2, N): the scaled unknowns are O(1), which L-BFGS needs
SCALE_Q, SCALE_V, SCALE_A, SCALE_F = 0.1, 0.5, 5.0, 10.0
#: typical jerk (m/s^3) and force rate (N/s): their rows are divided by these
SCALE_J, SCALE_FDOT = 100.0, 100.0
#: [constraints] fields the compiled solver holds as bounds (a_max, the windows) or as rows whose
#: bounds alone change (jerk_max, fdot_max: the rows are always there, free when unset)
BOUND_FIELDS = (*LIMIT_NAMES, *RATE_LIMITS, "bounds")

STATUS = {"Solve_Succeeded": "solved", "Solved_To_Acceptable_Level": "solved",
          "Infeasible_Problem_Detected": "infeasible", "Maximum_Iterations_Exceeded": "not_converged",
          "Maximum_CpuTime_Exceeded": "not_converged", "Restoration_Failed": "not_converged",
          "Search_Direction_Becomes_Too_Small": "not_converged", "Error_In_Step_Computation": "not_converged"}


def _logit(p: float) -> float:
    return float(np.log(p / (1 - p)))


def softplus(z: cs.MX) -> cs.MX:
    """log(1 + exp(z)) without overflow: -log sigmoid(-z)."""
    return cs.fmax(z, 0) + cs.log1p(cs.exp(-cs.fabs(z)))


def judge_env(judge: "Judge | CompiledJudge", env: dict[str, float]) -> np.ndarray:
    """The judge's environment vector (it may read only some of the problem's variables)."""
    return np.array([env[k] for k in judge.config.env_names], dtype=float)


#: objective "target": weight of the squared change to the warm start (scaled variables, per
#: variable), and of the slack s (logit units) that lets an unreachable target give the judge's
#: best instead: SLACK_WEIGHT (s + s^2). The linear part keeps a reachable target exact; the
#: square gives Ipopt curvature (Gauss-Newton on the logit) where the target is out of reach
PROXIMITY_WEIGHT = 1e-2
SLACK_WEIGHT = 10.0
#: objective "target" from a start far below it: each solve raises the logit by at most this much
#: from where the last one ended (the judge's linearisation holds over a few logit units; one
#: leap from a failing start to p = 0.98 takes Ipopt many short steps), in at most MAX_ROUNDS
TARGET_STEP = 4.0
MAX_ROUNDS = 6
ROUND_ITER_MIN = 20
HESSIANS = ("exact", "limited-memory")
#: how one plan for a set of environments is judged: in the worst of them, or on average
CASES = ("worst", "expected")


@dataclass
class DirectOptions:
    """How Ipopt is run (what is solved is the Problem's). hessian "exact": every term's exact
    second derivatives except the judge's (none in a constraint; Gauss-Newton in -log p);
    "limited-memory": L-BFGS for everything (the earlier default, for comparison)."""

    print_level: int = 0
    max_cpu_time: float = 60.0
    hessian: str = "exact"
    #: further Ipopt options by name (e.g. {"mu_init": 1e-4}), over judgeopt's own
    ipopt: dict = field(default_factory=dict)
    #: warm-start from a guess that breaks [constraints] and repair it (False: start cold instead, `_broken`)
    repair_guess: bool = False


class DirectPlanner(Planner):
    """Ipopt over the judge's CasADi function for one problem (any environment in it)."""

    method = "direct"
    plans_env_sets = True

    def __init__(self, problem: Problem, judge: "Judge | CompiledJudge", cjudge: CasadiJudge, options: DirectOptions | None = None,
                 members: list[CasadiJudge] | None = None, trust: TrustRegion | None = None,
                 samples: int = 1, case: str = "worst"):
        """`members`: an ensemble's CasADi judges (the objective becomes mean - pessimism * std
        of their logits); `trust`: the demonstrations' model for the trust-region constraint
        (used when the problem sets trust_region); `samples` > 1: one plan for that many
        environments at once (solve's `env_set`), its `case` "worst" (the target met in every
        one) or "expected" (by the mean success probability over them); objective "target" only."""
        for cj in [cjudge] + list(members or []):
            if cj.horizon != problem.steps:
                raise InfeasibleProblemError(f"the judge was built for N = {cj.horizon} steps, the problem has "
                                             f"{problem.steps}", ["horizon.steps"])
        if problem.trust_region is not None and trust is None:
            raise ProblemError("trust_region is set but no trust-region model was given (see [models] trust_model)")
        self.problem, self.judge, self.cjudge = problem, judge, cjudge
        self.members, self.trust = list(members or []), trust
        self.options = options or DirectOptions()
        if self.options.hessian not in HESSIANS:
            raise ProblemError(f"hessian {self.options.hessian!r}: choose one of {', '.join(HESSIANS)}")
        if case not in CASES:
            raise ProblemError(f"case {case!r}: choose one of {', '.join(CASES)}")
        if samples > 1 and problem.objective != "target":
            raise ProblemError("planning for a set of environments needs objective = target (its judge constraint "
                               "holds per environment)")
        self.samples, self.case = samples, case
        with sigint_recorded() as seen:  # CasADi would drop a Ctrl-C's KeyboardInterrupt (judgeopt.interrupts)
            self._build()
        if seen:
            raise KeyboardInterrupt

    @classmethod
    def build(cls, context: BuildContext) -> "DirectPlanner":
        """Its judge through l4casadi32 where l4casadi is installed, else the torch32 callback
        (judge.backends.choose_backend; the library is built once per judge, a few seconds, and
        loaded from the cache after; a fast start's CompiledJudge brings it loaded), with the problem's
        ensemble and trust region; what the user should know about them is added to the context's notes."""
        from judgeopt.files import resolve
        from judgeopt.judge.backends import DEFAULT_BACKEND
        from judgeopt.judge.store import check_compatible

        problem, judge, notes = context.problem, context.judge, context.notes
        metrics = context.judge_meta.get("metrics")
        ceiling = metrics.get("p_max_train") if isinstance(metrics, dict) else None
        if problem.objective == "target" and ceiling is not None and ceiling < problem.p_target:
            notes.append(f"the judge never gives a training demonstration more than p = {ceiling:.3f} (some labels "
                         f"wrong?), so the direct solve's p_target = {problem.p_target:g} is out of reach and it "
                         f"spends its iterations on the slack; set --p-target below {ceiling:.3f}")
        if context.generator is None:
            notes.append("no generator trained for these limits: the direct solve starts from the min-jerk guess")
        backend = context.casadi_backend or DEFAULT_BACKEND
        # the judge as a constraint (objective "target") tolerates float32's noise; -log p does not
        tolerant = problem.objective == "target"
        if isinstance(judge, CompiledJudge):  # the fast start: the library the torch path built, loaded without it
            cj = judge.cjudge
        else:
            from judgeopt.judge.casadi_fn import build_casadi_judge, remember_library

            cj = build_casadi_judge(judge, backend=backend, noise_tolerant=tolerant)
            remember_library(judge, context.judge_meta, cj)
        members, trust = None, None
        if problem.ensemble:
            from judgeopt.judge.ensemble import load_ensemble

            judges, _ = load_ensemble(resolve(problem.ensemble))
            for m in judges:
                check_compatible(m.config, horizon=problem.steps, dt=problem.dt, channels=problem.channels,
                                 env_names=problem.env_names)
            from judgeopt.judge.casadi_fn import build_casadi_judge

            members = [build_casadi_judge(m, backend=backend, noise_tolerant=tolerant) for m in judges]
            notes.append(f"direct: maximises mean - {problem.pessimism:g} std of the logits of "
                         f"{len(members)} judges ({problem.ensemble})")
        if problem.trust_region is not None:
            trust = load_trust_region(resolve(problem.trust_model, (".json",)), 3 * (problem.steps + 1))
            notes.append(f"direct: trust region, distance to the demonstrations <= {problem.trust_region:g} "
                         f"(demonstrations' median {trust.quantiles['q50']:.1f}, 95 % "
                         f"{trust.quantiles['q95']:.1f})")
        return cls(problem, judge, cj, members=members, trust=trust)

    def for_env_set(self, samples: int, case: str) -> "DirectPlanner":
        """The same solve for `samples` environments at once (`solve`'s env_set), in their `case`."""
        return DirectPlanner(self.problem, self.judge, self.cjudge, self.options, self.members, self.trust, samples,
                             case)

    def _build(self) -> None:
        pr, n, dt = self.problem, self.problem.steps, self.problem.dt
        na, nf = pr.n_axes, pr.n_forces
        # one column per axis (force channel); vectorised column by column, so one axis is one vector
        zq, zv, za, zf = (cs.MX.sym(name, rows, cols) for name, rows, cols in (
            ("q", n, na), ("v", n, na), ("a", n, na), ("f", n + 1, nf)))
        q, v, a, f = SCALE_Q * zq, SCALE_V * zv, SCALE_A * za, SCALE_F * zf
        env = cs.MX.sym("env", self.cjudge.n_env, self.samples)
        self._fixed = ~np.isnan(pr.terminal_positions({k: 0.0 for k in pr.env_names}))  # axes with an end
        q_end = cs.MX.sym("q_end", int(self._fixed.sum()))
        qs = cs.vertcat(cs.DM(pr.vec("q0")).T if na > 1 else pr.vec("q0")[0], q)
        vs = cs.vertcat(cs.DM(pr.vec("qdot0")).T if na > 1 else pr.vec("qdot0")[0], v)
        # integration as constraints, scaled by the step's typical size
        d_vel, d_pos = step_residuals(qs[:-1, :], vs[:-1, :], qs[1:, :], vs[1:, :], a, dt)
        g_vel, g_pos = cs.vec(d_vel / SCALE_V), cs.vec(d_pos / (SCALE_Q * 0.1))
        ends = [(qs[-1, i] - q_end[j]) / SCALE_Q for j, i in enumerate(np.flatnonzero(self._fixed))]
        qd_end = pr.vec("qdot_end")
        g_term = cs.vertcat(*ends, *[(vs[-1, i] - qd_end[i]) / SCALE_V for i in range(na)])
        parts = [qs[:, i] for i in range(na)] + [vs[:, i] for i in range(na)] + [f[:, i] for i in range(nf)]
        traj = cs.reshape(cs.horzcat(*[parts[k] for k in channel_order(pr)]).T, -1, 1)  # row-major, channel order
        rate = cs.diff(f) if nf == 1 else f[1:, :] - f[:-1, :]
        effort = pr.acc_weight * dt * cs.sumsqr(a) + pr.force_rate_weight * cs.sumsqr(rate) / dt
        x = cs.vertcat(cs.vec(zq), cs.vec(zv), cs.vec(za), cs.vec(zf))
        params = [cs.vec(env), q_end]
        self._target = pr.objective in ("target", "min_time")
        if self._target:  # slack s >= 0 in logit units: logit + s >= target, s costs SLACK_WEIGHT (s + s^2)
            slack, x_ref = cs.MX.sym("slack"), cs.MX.sym("x_ref", x.size1())
            params.append(x_ref)
            effort += PROXIMITY_WEIGHT * cs.sumsqr(x - x_ref) + SLACK_WEIGHT * (slack + slack ** 2)
            x = cs.vertcat(x, slack)
        # [constraints]' rows: the jerk per axis, the force rate per channel (free where unset), the arm's joints
        jerk = (a[1:, :] - a[:-1, :]) / dt / SCALE_J
        path = [cs.vec(jerk), cs.vec(rate / dt / SCALE_FDOT)]
        self._joints = None
        if pr.joint_limit_scale is not None:
            from judgeopt.planners.joint_limits import joint_map

            self._joints = joint_map(pr)
            path.append(self._joints.rows(qs, vs, f, a))
        g_path = cs.vertcat(*path)
        logits = [self.cjudge.fn(traj, env[:, k])[0] if not self.members else self._pessimistic(traj, env[:, k])
                  for k in range(self.samples)]
        # the judge's rows: one logit, one per environment of a set ("worst"), or the logit of the
        # mean success probability over the set ("expected"; the 1/K of the means cancels)
        if self.samples == 1 or self.case == "worst":
            logit = cs.vertcat(*logits)
        else:
            ls = cs.vertcat(*logits)
            logit = cs.log(cs.sum1(0.5 + 0.5 * cs.tanh(0.5 * ls))) - cs.log(cs.sum1(0.5 - 0.5 * cs.tanh(0.5 * ls)))
        self._n_judge = logit.size1()

        def objective_and_constraints(z: cs.MX) -> tuple[cs.MX, cs.MX]:
            """The NLP with the judge's rows given as z (the real ones, or stand-ins for the Hessian)."""
            obj = effort if self._target else effort + pr.P * softplus(-z)
            g = [g_vel, g_pos, g_term, z + slack if self._target else z, g_path]
            if pr.trust_region is not None:
                g.append(self.trust.casadi_distance2(traj) / pr.trust_region ** 2)  # <= 1
            return obj, cs.vertcat(*g)

        obj, g = objective_and_constraints(logit)
        p = cs.vertcat(*params)
        self._logit_fn = cs.Function("logit", [x, p], [cs.mmin(logit)])
        nlp = {"x": x, "p": p, "f": obj, "g": g}
        opts = {"ipopt.max_iter": self._round_iter(), "ipopt.tol": pr.tol, "ipopt.constr_viol_tol": 1e-9,
                "ipopt.acceptable_iter": 0, "ipopt.print_level": self.options.print_level,
                "ipopt.max_cpu_time": self.options.max_cpu_time, "ipopt.sb": "yes", "print_time": False}
        z = cs.MX.sym("z", self._n_judge)  # the judge's rows as stand-ins: derivatives by the chain rule
        obj_z, g_z = objective_and_constraints(z)
        # one reverse sweep of the judge per row (CasADi's own Jacobian of the judge is many times dearer)
        jac_logit = cs.vertcat(*[cs.gradient(logit[i], x).T for i in range(self._n_judge)])
        at_logit = lambda e: cs.substitute(e, z, logit)  # noqa: E731
        grad = cs.gradient(obj_z, x) + cs.mtimes(jac_logit.T, cs.jacobian(obj_z, z).T)
        jac = cs.jacobian(g_z, x) + cs.mtimes(cs.jacobian(g_z, z), jac_logit)
        opts["grad_f"] = cs.Function("grad_f", [x, p], [obj, at_logit(grad)], ["x", "p"], ["f", "grad_f_x"])
        opts["jac_g"] = cs.Function("jac_g", [x, p], [g, at_logit(jac)], ["x", "p"], ["g", "jac_g_x"])
        if self.options.hessian == "limited-memory":
            opts["ipopt.hessian_approximation"] = "limited-memory"
        else:
            opts["hess_lag"] = self._hess_lag(x, p, logit, objective_and_constraints)
            # a warm start is near the optimum: keep it close to the bounds it touches, with a small
            # barrier (benchmarks/bench_direct.py --levers: 6-7 iterations instead of 11)
            opts.update({"ipopt.mu_init": 1e-5, "ipopt.bound_push": 1e-6, "ipopt.bound_frac": 1e-6})
        opts.update({f"ipopt.{k}": v for k, v in self.options.ipopt.items()})
        self.solver = cs.nlpsol("judgeopt_direct", "ipopt", nlp, opts)
        self._n_eq = 2 * n * na + int(self._fixed.sum()) + na
        self._n_path = g_path.size1()
        self._rest_from: int | None = None
        self._earliest_search = self.problem.objective == "min_time"  # solve() searches the time (min_time.py)
        self._warmed = (False, False)  # (the judge, the cold start's sampling): paid once a process
        self._n_plan = x.size1() - int(self._target)
        self._bounds()

    def _round_iter(self) -> int:
        """Ipopt's iterations per solve: the problem's max_iter, shared by the rounds of "target"."""
        return max(ROUND_ITER_MIN, self.problem.max_iter // MAX_ROUNDS) if self._target else self.problem.max_iter

    def _hess_lag(self, x: cs.MX, p: cs.MX, logit: cs.MX, nlp_of) -> cs.Function:
        """Ipopt's Hessian of the Lagrangian: exact for every term but the judge, whose curvature
        (which l4casadi cannot give, and which is indefinite) is left out; under -P log p its
        Gauss-Newton term P p (1 - p) ∇logit ∇logitᵀ takes its place. Under objective "target"
        the result is constant: one factorisation pattern, no judge call."""
        z = cs.MX.sym("z", self._n_judge)
        obj, g = nlp_of(z)
        lam_f, lam_g = cs.MX.sym("lam_f"), cs.MX.sym("lam_g", g.size1())
        hess = cs.substitute(cs.hessian(lam_f * obj + cs.dot(lam_g, g), x)[0], z, cs.DM.zeros(self._n_judge))
        if not self._target:
            grad = cs.gradient(logit, x)
            s = 0.5 + 0.5 * cs.tanh(0.5 * logit)
            hess += lam_f * self.problem.P * s * (1 - s) * cs.mtimes(grad, grad.T)
        return cs.Function("hess_lag", [x, p, lam_f, lam_g], [cs.triu(hess)],
                           ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])

    def _bounds(self) -> None:
        """Variable bounds from the problem's limits, and the constraint bounds."""
        pr, n = self.problem, self.problem.steps

        def column(values: np.ndarray, rows: int, scale: float) -> np.ndarray:  # one block per axis
            return np.concatenate([np.full(rows, x / scale) for x in values])

        a_max = per_channel(pr.a_max, pr.n_axes, "a_max")
        lb = np.concatenate([column(pr.vec("q_min"), n, SCALE_Q), column(pr.vec("qdot_min"), n, SCALE_V),
                             column(-a_max, n, SCALE_A), column(pr.vec("f_min"), n + 1, SCALE_F)])
        ub = np.concatenate([column(pr.vec("q_max"), n, SCALE_Q), column(pr.vec("qdot_max"), n, SCALE_V),
                             column(a_max, n, SCALE_A), column(pr.vec("f_max"), n + 1, SCALE_F)])
        self._windows(lb, ub)
        # the judge's row: its logit (plus the slack) at least the target, or p_min's logit, or free;
        # the slack never relaxes p_min, which is hard
        self._hard = hard = _logit(pr.p_min) if pr.p_min is not None else -np.inf
        floor = max(_logit(pr.p_target), hard) if self._target else hard
        if self._target:
            lb, ub = np.append(lb, 0.0), np.append(ub, floor - hard)
        self._lbx, self._ubx = lb, ub
        rows = np.full(self._n_judge, 1.0)
        path = np.concatenate([column(per_channel(pr.jerk_max, pr.n_axes, "jerk_max"), n - 1, SCALE_J),
                               column(per_channel(pr.fdot_max, pr.n_forces, "fdot_max"), n, SCALE_FDOT)])
        if self._joints is not None:
            path = np.append(path, np.full(self._n_path - len(path), pr.joint_limit_scale))
        self._lbg = np.concatenate([np.zeros(self._n_eq), floor * rows, -path])
        self._ubg = np.concatenate([np.zeros(self._n_eq), np.inf * rows, path])
        self._judge_rows = slice(self._n_eq, self._n_eq + self._n_judge)
        if pr.trust_region is not None:
            self._lbg, self._ubg = np.append(self._lbg, -np.inf), np.append(self._ubg, 1.0)

    def _index(self, block: int, channel: int, sample: int) -> int:
        """Where sample `sample` of one axis's q (block 0), q̇ (1), a (2) or one force channel's f
        (3) lies among the plan variables (q, q̇, a from sample 1, f from sample 0)."""
        n, na = self.problem.steps, self.problem.n_axes
        return block * n * na + channel * n + sample - 1 if block < 3 else 3 * n * na + channel * (n + 1) + sample

    def _windows(self, lb: np.ndarray, ub: np.ndarray) -> None:
        """[constraints]' window bounds onto the variable bounds (sample 0 of q and q̇ is the
        start, not a variable: a window that excludes it is feasible.check's to report)."""
        pr = self.problem
        spec = pr.channel_spec
        pos = [c.name for c in spec if c.kind == "position"]
        where = {c.name: ((0, pos.index(c.name), SCALE_Q) if c.kind == "position" else
                          (1, pos.index(c.of), SCALE_V) if c.kind == "velocity" else
                          (3, [d.name for d in spec if d.kind == "force"].index(c.name), SCALE_F)) for c in spec}
        for b in pr.constraints.parsed_bounds():
            block, channel, scale = where[b.name]
            for k in b.samples(pr.steps, pr.dt):
                if block < 3 and k == 0:
                    continue
                j = self._index(block, channel, k)
                lb[j], ub[j] = max(lb[j], b.lo / scale), min(ub[j], b.hi / scale)

    def resting_from(self, k: int) -> "DirectPlanner":
        """The same compiled solver for one plan at rest at the terminal state from sample k on
        (min-time's candidates; the terminal position is the environment's, set at solve time)."""
        if not 1 <= k <= self.problem.steps:
            raise ProblemError(f"resting_from: sample {k}; give 1 to {self.problem.steps}")
        new = copy.copy(self)
        new._rest_from, new._earliest_search = k, False
        return new

    def _rested(self, env: dict[str, float]) -> "DirectPlanner":
        """This solver with the rest from `_rest_from` on, in `env`: q̇ (and q, where it has an
        end) fixed there; the position steps between fixed samples hold already, so their rows
        are freed (fixed variables in an equality would leave Ipopt a singular system)."""
        pr, n, na = self.problem, self.problem.steps, self.problem.n_axes
        lbx, ubx, lbg, ubg = self._lbx.copy(), self._ubx.copy(), self._lbg.copy(), self._ubg.copy()
        ends, qd_end = pr.terminal_positions(env), pr.vec("qdot_end")
        for i in range(na):
            for k in range(self._rest_from, n + 1):
                jv = self._index(1, i, k)
                lbx[jv] = ubx[jv] = qd_end[i] / SCALE_V
                if not np.isnan(ends[i]):
                    jq = self._index(0, i, k)
                    lbx[jq] = ubx[jq] = ends[i] / SCALE_Q
                    if k > self._rest_from:
                        row = n * na + i * n + k - 1
                        lbg[row], ubg[row] = -np.inf, np.inf
        new = copy.copy(self)
        new._lbx, new._ubx, new._lbg, new._ubg, new._rest_from = lbx, ubx, lbg, ubg, None
        return new

    def with_limits(self, problem: Problem) -> "DirectPlanner":
        """The same compiled solver for a problem that differs only in its position, velocity
        and force limits and [constraints] (variable bounds and row bounds), and its environment: no rebuild, so
        re-planning under relaxed or sampled limits costs one solve (joint limits switched on or
        off: a rebuild, their rows come or go)."""
        def rest(p: Problem) -> dict:  # what the compiled solver is built for (each solve is given its environment)
            return {k: v for k, v in p.to_dict().items()
                    if k not in BOUND_FIELDS and k not in ("joint_limit_scale", "environment")}

        if rest(problem) != rest(self.problem):
            raise ProblemError("with_limits: the problems differ in more than their limits; build a new DirectPlanner")
        if (problem.joint_limit_scale is None) != (self.problem.joint_limit_scale is None):  # joint rows come or go
            return DirectPlanner(problem, self.judge, self.cjudge, self.options, self.members, self.trust,
                                 self.samples, self.case)
        new = copy.copy(self)
        new.problem = problem
        new._bounds()
        return new

    def probability(self, values: np.ndarray, env: dict[str, float]) -> float:
        """The judge's success probability of a (N + 1, channels) trajectory in `env`."""
        z = float(self.cjudge.fn(np.asarray(values, float).ravel(), judge_env(self.judge, env))[0])
        return sigmoid(z)

    def with_prefix(self, measured: np.ndarray) -> "DirectPlanner":
        """The same compiled solver for the rest of a motion already under way: samples 0..k-1
        of the plan are what the arm measured (`measured`, (k, channels) in the task's channel
        order, k >= 1) and stay as they are, the judge reads them followed by the plan, and the
        plan from sample k-1 on holds every limit and the integration, so it starts from the
        measured state. Only bounds change: no rebuild (a re-plan costs one solve)."""
        pr, n = self.problem, self.problem.steps
        na, nf = pr.n_axes, pr.n_forces
        k = len(measured)
        if not 1 <= k <= n:
            raise ProblemError(f"with_prefix: {k} measured samples; give 1 to {n} (the plan has {n + 1})")
        spec = pr.channel_spec
        pos = [j for j, c in enumerate(spec) if c.kind == "position"]
        cols = {"position": pos, "force": [j for j, c in enumerate(spec) if c.kind == "force"],
                "velocity": [next(j for j, c in enumerate(spec) if c.of == spec[p].name) for p in pos]}
        new = copy.copy(self)
        lbx, ubx, lbg, ubg = self._lbx.copy(), self._ubx.copy(), self._lbg.copy(), self._ubg.copy()
        for i in range(na):
            for s in range(1, k):  # q and v start at sample 1 (sample 0 is the problem's start)
                for block, kind, scale in ((0, "position", SCALE_Q), (1, "velocity", SCALE_V)):
                    j = block * n * na + i * n + (s - 1)
                    lbx[j] = ubx[j] = measured[s, cols[kind][i]] / scale
            for block in (0, 1):  # the integration between measured samples is what happened: not a constraint
                rows = block * n * na + i * n + np.arange(k - 1)
                lbg[rows], ubg[rows] = -np.inf, np.inf
        for i in range(nf):
            j = 3 * n * na + i * (n + 1) + np.arange(k)
            lbx[j] = ubx[j] = measured[:, cols["force"][i]] / SCALE_F
        new._lbx, new._ubx, new._lbg, new._ubg = lbx, ubx, lbg, ubg
        return new

    def _broken(self, guess: Plan | None, env: dict[str, float]) -> str:
        """Which of [constraints] a warm start breaks, and by how much ("": none, or no guess).
        Repaired, such a plan lands on the constraints' edge near the generator's motion, where
        the judge has seen nothing and is over-confident (held-out constraint sets: 62 of 80 plans
        succeeded from it, 76 of 80 from the cold start; docs/constraints.md), so the solve starts
        cold instead unless DirectOptions.repair_guess."""
        if guess is None or self.options.repair_guess or not self.problem.constraints.is_set():
            return ""
        over = {k: v for k, v in constraint_residuals(self.problem, guess, env).items()
                if is_constraint_key(k) and v > HOLD_TOL}
        return ", ".join(f"{k} by {v:.3g}" for k, v in sorted(over.items(), key=lambda kv: -kv[1]))

    def details(self, result: PlanResult) -> list[str]:
        """Under min_time, the time found against the horizon; then Planner.details (the binding joint)."""
        lines = []
        if result.info.get("min_time_s") is not None:
            tried = ", ".join(f"{t} s {'yes' if ok else 'no'}" for t, ok in result.info["min_time_tried"].items())
            lines.append(f"{self.method}, min-time: at rest at the terminal state from t = "
                         f"{result.info['min_time_s']:g} s of the {result.info['horizon_s']:g} s horizon "
                         f"(candidates, p >= {self.problem.p_target:g} reached: {tried})")
        return lines + super().details(result)

    def _pessimistic(self, traj: cs.MX, env: cs.MX) -> cs.MX:
        """mean - pessimism * std of the members' logits (pessimism = inf: their minimum)."""
        from judgeopt.judge.ensemble import pessimistic

        return pessimistic([m.fn(traj, env)[0] for m in self.members], self.problem.pessimism, cs.sqrt, cs.fmin, 1e-9)

    def _reached(self, x: np.ndarray, fixed: list[np.ndarray]) -> float:
        """The judge's logit (its worst row) at plan variables x."""
        return float(self._logit_fn(np.append(x, 0.0), np.concatenate(fixed + [x])))

    def _round(self, x: np.ndarray, fixed: list[np.ndarray], working: float | None, runs: list[dict],
               reached: float = 0.0) -> np.ndarray:
        """One Ipopt solve from x, its stats appended to `runs` (under "target": near x, the
        judge's rows at least `working`, -inf: any, the nearest plan that holds the limits;
        `reached`: the judge's logit at x, where the slack starts)."""
        lbg, ubx, x0 = self._lbg, self._ubx, x
        p = np.concatenate(fixed)
        if working is not None:
            lbg, ubx = lbg.copy(), ubx.copy()
            lbg[self._judge_rows] = working
            ubx[-1] = max(0.0, working - self._hard) if np.isfinite(working) else 0.0
            p = np.concatenate(fixed + [x])
            x0 = np.append(x, min(ubx[-1], max(0.0, working - reached)))
        with sigint_recorded() as seen:  # raised inside a judge callback, CasADi would let Ipopt go on
            sol = self.solver(x0=np.clip(x0, self._lbx, ubx), p=p, lbx=self._lbx, ubx=ubx, lbg=lbg, ubg=self._ubg)
        runs.append(self.solver.stats())
        # a Ctrl-C held while Ipopt ran, or one CasADi turned into Ipopt's stop: the solve was interrupted
        if seen or runs[-1].get("return_status") == "User_Requested_Stop":
            raise KeyboardInterrupt
        return np.asarray(sol["x"]).ravel()[:self._n_plan]

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

    def warm_up(self, cold: bool = False) -> float:
        """Pay now what the first solve in a process would pay on its own, and return the
        seconds: the judge's value and gradient once (torch builds its kernels for the shapes,
        l4casadi loads its traced models), and with `cold` the cold start's sampling (the task's
        command sampler imports its spline library). Solves after it take their steady time; a
        second call costs nothing."""
        if self._warmed[0] and (self._warmed[1] or not cold):
            return 0.0  # a service's next request, a session's next solve: paid already
        t0 = time.perf_counter()
        pr = self.problem
        env = pr.nominal_env()
        guess = default_guess(pr, env)
        self.cjudge.value_and_gradient(guess.as_array().ravel(), judge_env(self.judge, env))
        if cold:
            cold_start(pr, env, self.judge, guess)
        self._warmed = (True, self._warmed[1] or cold)
        return time.perf_counter() - t0

    def solve(self, env: dict[str, float], guess: Plan | None = None,
              env_set: list[dict[str, float]] | None = None) -> PlanResult:
        """Solve for one environment; infeasible limits are reported without calling Ipopt.
        `env_set` (as many as `samples`): judge the plan in each of these instead (the terminal
        position still comes from `env`, what the user said)."""
        pr = self.problem
        env = pr.env_dict(env)
        if self._earliest_search:
            from judgeopt.planners.min_time import earliest

            return earliest(self, env, guess, env_set)
        if self._rest_from is not None:
            return self._rested(env).solve(env, guess, env_set)
        env_set = [pr.env_dict(e) for e in env_set] if env_set is not None else [env]
        if len(env_set) != self.samples:
            raise ProblemError(f"this direct solve plans for {self.samples} environment(s) at once, got {len(env_set)}")
        t0 = time.perf_counter()
        if (infeasible := infeasible_result(self.method, pr, env)) is not None:
            return infeasible
        warm, broken = "generator", self._broken(guess, env)
        if guess is None or broken:
            guess, warm = cold_start(pr, env, self.judge, default_guess(pr, env), self._lbg[self._judge_rows][0])
            warm += f" (the generator's plan breaks {broken})" if broken else ""
        result = self._solve_from(env, env_set, guess, warm, t0)
        if pr.constraints.is_set() and warm.startswith("best of") and self._target and not self._met(result):
            # the start the judge liked best fell short of the target: the min-jerk guess gets its own solve
            # (held-out constraint sets: near objects under an early force cap, where the task command the
            # judge preferred led to p 0.35-0.96 and failures, and the min-jerk guess to p 0.98 and successes;
            # where no scoop was possible, retries short of the target reached p 0.52-0.89 and all failed)
            retry = self._solve_from(env, env_set, default_guess(pr, env),
                                     f"min-jerk guess (from the {warm.split(' (')[0]}: p {result.predicted_success:.2f})",
                                     t0)
            if self._met(retry):  # kept where it reaches the target: short of it from both starts, the first stands
                retry.iterations = (retry.iterations or 0) + (result.iterations or 0)
                result = retry
        return result

    def nearest(self, env: dict[str, float], plan: Plan) -> PlanResult:
        """The plan nearest `plan` (in the solver's scaled variables, plus this problem's smoothing terms)
        that holds every limit, the judge's row free but for p_min: one Ipopt solve, about 7 iterations
        from a plan that breaks its limits by millimetres (planners/held.py). Objective "target" only: under
        "log_p" there is no distance to a plan in the objective."""
        pr = self.problem
        if not self._target:
            raise ProblemError(f"the nearest plan needs objective = target (its distance to a plan), not {pr.objective!r}")
        env = pr.env_dict(env)
        t0 = time.perf_counter()
        if (infeasible := infeasible_result(self.method, pr, env)) is not None:
            return infeasible
        fixed = [judge_env(self.judge, env), pr.terminal_positions(env)[self._fixed]]
        x, runs = self._pack(plan), []
        x = self._round(x, fixed, self._hard, runs, self._reached(x, fixed))
        held = self._unpack(x)
        ipopt_status = runs[-1].get("return_status", "unknown")
        prob = self.probability(held.as_array(), env)
        return PlanResult(self.method, env, held, prob, STATUS.get(ipopt_status, "failed"), time.perf_counter() - t0,
                          self._residuals(held, env, prob), iterations=int(runs[-1].get("iter_count", 0)),
                          message=f"Ipopt: {ipopt_status}", info={"ipopt_status": ipopt_status})

    def _residuals(self, plan: Plan, env: dict[str, float], p: float) -> dict[str, float]:
        """How far `plan` breaks each limit and constraint, p_min among them: kept hard in the solve, so a
        p short of it is reported as a residual like any other."""
        residuals = constraint_residuals(self.problem, plan, env)
        if self.problem.p_min is not None:
            residuals["p_min"] = max(0.0, self.problem.p_min - p)
        return residuals

    def _met(self, result: PlanResult) -> bool:
        """Whether a solve reached p_target (to its tolerance)."""
        return meets_target(result, self.problem.p_target)

    def _solve_from(self, env: dict[str, float], env_set: list[dict[str, float]], guess: Plan, warm: str,
                    t0: float) -> PlanResult:
        """One solve (its rounds under "target") from `guess`; `warm` says what that start is."""
        pr = self.problem
        fixed = [np.concatenate([judge_env(self.judge, e) for e in env_set]), pr.terminal_positions(env)[self._fixed]]
        x = self._pack(guess)
        target = self._lbg[self._judge_rows][0]
        runs: list[dict] = []  # Ipopt's stats of each solve
        if not self._target:
            x = self._round(x, fixed, None, runs)
        else:  # a reachable step of the target at a time, near the last plan (TARGET_STEP)
            reached = self._reached(x, fixed)
            while True:
                working = min(target, reached + TARGET_STEP)
                x = self._round(x, fixed, working, runs, reached)
                before, reached = reached, self._reached(x, fixed)
                # out of reach: the judge's best is here. A round that ran out of iterations after
                # most of its step (a judge with many ReLU kinks) gets another round instead
                short = reached < working - 1e-3 and reached - before < 0.5 * (working - before)
                if short or working >= target or len(runs) >= MAX_ROUNDS \
                        or sum(r["iter_count"] for r in runs) >= pr.max_iter:
                    break
            if STATUS.get(runs[-1].get("return_status"), "failed") != "solved" and pr.p_min is None:
                # stopped mid-way: the nearest plan that holds every limit, whatever the judge says
                x = self._round(x, fixed, -np.inf, runs, reached)
                reached = self._reached(x, fixed)
        stats = runs[-1]
        calls = ("nlp_g", "nlp_jac_g") + (() if self._target else ("nlp_f", "nlp_grad_f"))
        iterations = sum(int(r.get("iter_count", 0)) for r in runs)
        judge_calls = sum(int(r.get(f"n_call_{k}", 0)) for r in runs for k in calls)
        rounds = len(runs)
        elapsed = time.perf_counter() - t0
        ipopt_status = stats.get("return_status", "unknown")
        status = STATUS.get(ipopt_status, "failed")
        message = f"Ipopt: {ipopt_status}"
        if self._target:
            if status == "infeasible" and pr.p_min is None:  # the slack keeps every row satisfiable
                status = "not_converged"
            if reached < target - 1e-3:
                p_reached = sigmoid(reached)
                message += (f"; p_target = {pr.p_target:g} not reached in {rounds} round(s) of at most "
                            f"{self._round_iter()} iterations: best p = {p_reached:.3g}")
        plan = self._unpack(x)
        traj, je = plan.as_array().ravel(), judge_env(self.judge, env)
        info = {"ipopt_status": ipopt_status, "warm_start": warm, "judge_calls": judge_calls, "rounds": rounds,
                "judge_backend": self.cjudge.backend}
        if self.members:  # the ensemble's own prediction: the mean of its members' probabilities
            from judgeopt.judge.ensemble import pessimistic

            z = np.array([float(m.fn(traj, je)[0]) for m in self.members])
            prob = float(np.mean(sigmoid(z)))
            bound = sigmoid(pessimistic(z, pr.pessimism))
            info.update(member_success=sigmoid(z).tolist(), pessimistic_success=bound)
        else:
            bound = prob = sigmoid(float(self.cjudge.fn(traj, je)[0]))
        if self.samples > 1:  # the plan's success probability over the set, as it was planned
            each = [sigmoid(float(self.cjudge.fn(traj, judge_env(self.judge, e))[0]))
                    for e in env_set]
            bound = prob = min(each) if self.case == "worst" else float(np.mean(each))
            info.update(env_case=self.case, env_set=env_set, env_set_success=each)
        residuals = self._residuals(plan, env, bound)
        if pr.trust_region is not None:
            d = float(self.trust.distance(traj)[0])
            residuals["trust_region"] = max(0.0, d - pr.trust_region)
            info["trust_distance"] = d
        if status == "infeasible":
            worst = sorted((k for k, v in residuals.items() if v > 1e-6), key=residuals.get, reverse=True)
            message += f"; constraints left violated: {', '.join(worst) or 'none measurable'}"
        return PlanResult(self.method, env, plan, prob, status, elapsed, residuals,
                          iterations=iterations, message=message, info=info)
