"""What is possible under a limit set, asked of the simulator itself, and the no-judge baseline.

Both search the CEM baseline's space of plans (`SplineCommands`): velocity knots mapped onto
[q̇_min, q̇_max], forces a monotone spline inside [f_min, f_max], a half-sine correction so the
plan ends at q_end. So every plan they try satisfies the limits by construction. Where the
problem has [constraints] (acceleration, jerk, force-rate limits, window bounds), each such plan
is then projected onto them (`Projection`: the nearest plan, in velocity and force, that holds
every linear constraint, one small QP per axis and force channel), and a plan still off them by
more than PROJECTION_TOL is dropped: so every plan they try holds those too.

- No-judge baseline: random plans from that space, replayed. Its success rate is what the
  limits alone give; a judge's worth is its distance from this rate.
- Feasibility search: a cross-entropy search whose score is the rollout's own outcome (success
  first, then how far the object rose and how close to the blade centre it ended). It stops at
  the first success. A search can miss a feasible plan, so its negative answer is "no
  successful plan found in N tries", never "impossible".
"""

from __future__ import annotations

import dataclasses
import zlib
from dataclasses import asdict, dataclass

import numpy as np

from judgeopt.planners.cem import SplineCommands
from judgeopt.planners.dynamics import channel_order, positions
from judgeopt.planners.feasible import check as check_constraints
from judgeopt.planners.problem import InfeasibleProblemError, Problem
from judgeopt.trajectory import Plan

TERMINAL_TOL = 1e-3  # m: a random plan that misses q_end by more does not satisfy the constraints
#: a projected plan off any constraint by more (in the constraint's units) is dropped
PROJECTION_TOL = 1e-6


@dataclass(frozen=True)
class SearchConfig:
    knots: int = 6
    population: int = 12
    iterations: int = 8  # at most population x iterations rollouts per environment
    elite: int = 3
    init_std: float = 0.3
    min_std: float = 0.05


def env_rng(problem: Problem, env: dict[str, float], seed: int, stream: int) -> np.random.Generator:
    """Seeded by the environment's values, so a result does not depend on which ran before."""
    key = zlib.crc32(np.asarray([env[n] for n in problem.env_names], dtype=np.float64).tobytes())
    return np.random.default_rng([seed, stream, key])


class Projection:
    """The nearest plan that holds every linear constraint of the problem for one environment:
    the boxes, the start, the terminal state, the motion model and [constraints]'s rate limits and
    window bounds. Per position axis, min |q̇ - q̇_c|² over the velocities (the positions follow
    by the model's trapezoid rule, so position limits, the terminal position and position bounds
    are linear rows in them); per force channel, min |f - f_c|². Each a small QP solved by DAQP
    (an exact active-set solver) through CasADi. The arm's joint limits (joint_limit_scale) are
    not linear in the plan and are not projected onto."""

    def __init__(self, problem: Problem, env: dict[str, float]):
        self.problem = problem
        self.linear = (problem if problem.joint_limit_scale is None else dataclasses.replace(
            problem, constraints=dataclasses.replace(problem.constraints, joint_limit_scale=None)))
        ends = problem.terminal_positions(env)
        self._qps = ([("position", i, self._qp(*self._axis_rows(problem, i, ends[i]))) for i in range(problem.n_axes)]
                     + [("force", i, self._qp(*self._force_rows(problem, i))) for i in range(problem.n_forces)])

    @staticmethod
    def _axis_rows(pr: Problem, i: int, end: float):
        """Variables v_0..v_N of axis i: their bounds, and rows lba <= A v <= uba."""
        from judgeopt.planners.constraints import per_channel

        n, dt, c = pr.steps, pr.dt, pr.constraints
        q0, v0, v_end = (float(pr.vec(k)[i]) for k in ("q0", "qdot0", "qdot_end"))
        lo, hi = np.full(n + 1, float(pr.vec("qdot_min")[i])), np.full(n + 1, float(pr.vec("qdot_max")[i]))
        lo[0] = hi[0] = v0
        lo[n] = hi[n] = v_end
        M = np.zeros((n + 1, n + 1))  # q_k - q0 = M[k] @ v (the trapezoid rule)
        for k in range(1, n + 1):
            M[k, :k + 1] = dt
            M[k, 0] = M[k, k] = 0.5 * dt
        rows = [(M[1:], float(pr.vec("q_min")[i]) - q0, float(pr.vec("q_max")[i]) - q0)]
        if not np.isnan(end):
            rows.append((M[n:], end - q0, end - q0))
        D = (np.eye(n + 1, k=1) - np.eye(n + 1))[:n] / dt  # a_k = (v_k - v_{k-1}) / dt
        a_max = per_channel(c.a_max, pr.n_axes, "a_max")[i]
        if np.isfinite(a_max):
            rows.append((D, -a_max, a_max))
        j_max = per_channel(c.jerk_max, pr.n_axes, "jerk_max")[i]
        if np.isfinite(j_max):
            rows.append((np.diff(D, axis=0) / dt, -j_max, j_max))  # (a_{k+1} - a_k) / dt, k = 1..N-1
        pos = [ch for ch in pr.channel_spec if ch.kind == "position"][i]
        vel = next(ch for ch in pr.channel_spec if ch.of == pos.name)
        for b in c.parsed_bounds():
            ks = [k for k in b.samples(n, dt) if k > 0]  # sample 0 is the given start
            if b.name == pos.name and ks:
                rows.append((M[ks], b.lo - q0, b.hi - q0))
            elif b.name == vel.name:
                lo[ks], hi[ks] = np.maximum(lo[ks], b.lo), np.minimum(hi[ks], b.hi)
        return lo, hi, rows, np.ones(n + 1)

    @staticmethod
    def _force_rows(pr: Problem, j: int):
        from judgeopt.planners.constraints import per_channel

        n, dt, c = pr.steps, pr.dt, pr.constraints
        lo, hi = np.full(n + 1, float(pr.vec("f_min")[j])), np.full(n + 1, float(pr.vec("f_max")[j]))
        rows = []
        limit = per_channel(c.fdot_max, pr.n_forces, "fdot_max")[j]
        if np.isfinite(limit):
            rows.append(((np.eye(n + 1, k=1) - np.eye(n + 1))[:n] / dt, -limit, limit))
        name = [ch for ch in pr.channel_spec if ch.kind == "force"][j].name
        for b in c.parsed_bounds():
            if b.name == name:
                ks = b.samples(n, dt)
                lo[ks], hi[ks] = np.maximum(lo[ks], b.lo), np.minimum(hi[ks], b.hi)
        return lo, hi, rows, np.ones(n + 1)

    @staticmethod
    def _qp(lo: np.ndarray, hi: np.ndarray, rows: list, weights: np.ndarray) -> dict:
        import casadi as ca

        nv = len(lo)
        A = np.concatenate([r[0] for r in rows]) if rows else np.zeros((0, nv))
        lba = np.concatenate([np.broadcast_to(r[1], len(r[0])) for r in rows]) if rows else np.zeros(0)
        uba = np.concatenate([np.broadcast_to(r[2], len(r[0])) for r in rows]) if rows else np.zeros(0)
        H = np.diag(weights)
        solver = ca.conic("projection", "daqp", {"h": ca.DM(H).sparsity(), "a": ca.DM(A).sparsity()},
                          {"error_on_fail": False})
        return {"solver": solver, "H": H, "A": A, "lba": lba, "uba": uba, "lbx": lo, "ubx": hi}

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """(B, N + 1, channels) plans -> their projections (all nan where a QP failed)."""
        pr = self.problem
        order = channel_order(pr)  # task column j holds entry order[j] of [positions, velocities, forces]
        parts = np.asarray(x, dtype=float)[:, :, np.argsort(order)]
        out = parts.copy()
        na = pr.n_axes
        for kind, i, qp in self._qps:
            col = na + i if kind == "position" else 2 * na + i
            for b in range(len(parts)):
                r = qp["solver"](h=qp["H"], g=-parts[b][:, col], a=qp["A"], lba=qp["lba"], uba=qp["uba"],
                                 lbx=qp["lbx"], ubx=qp["ubx"])
                if not qp["solver"].stats()["success"]:
                    out[b] = np.nan
                    continue
                out[b][:, col] = np.array(r["x"]).ravel()
                if kind == "position":  # the positions integrated from the velocities: the model holds exactly
                    out[b][:, i] = positions(float(pr.vec("q0")[i]), out[b][:, col], pr.dt)
        return out[:, :, order]


def _held(problem: Problem, x: np.ndarray, env: dict[str, float]) -> np.ndarray:
    """Which (B, N + 1, channels) plans hold every constraint to PROJECTION_TOL (q_end: TERMINAL_TOL)."""
    from judgeopt.planners.result import constraint_residuals

    ok = np.zeros(len(x), dtype=bool)
    for b, xi in enumerate(x):
        if np.all(np.isfinite(xi)):
            res = constraint_residuals(problem, Plan.from_array(problem.dt, xi, problem.channel_spec), env)
            ok[b] = res.pop("q_end") <= TERMINAL_TOL and max(res.values()) <= PROJECTION_TOL
    return ok


def _valid(commands: SplineCommands, q_end: np.ndarray, n: int, draw, project=None,
           env: dict[str, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """n knot vectors from draw(n) whose plans end within TERMINAL_TOL of q_end (clipping to the
    velocity limits can spoil a draw's end), and their plans; fewer only if 50 n draws miss.
    `project` (a Projection for `env`): each plan projected onto the constraints first, and kept
    where it then holds them all."""
    zs, xs = [], []
    for _ in range(50):
        z = draw(n)
        x, penalty = commands.decode(z, q_end)
        if project is not None:
            x = project(x)
            ok = _held(project.linear, x, env)
        else:
            ok = penalty <= TERMINAL_TOL
        zs.append(z[ok])
        xs.append(x[ok])
        if sum(len(a) for a in zs) >= n:
            break
    return np.concatenate(zs)[:n], np.concatenate(xs)[:n]


def projection(problem: Problem, env: dict[str, float]) -> Projection | None:
    """The projection onto the problem's [constraints] for env; None where it has none (the
    spline plans hold the limits by construction)."""
    return Projection(problem, env) if problem.constraints.is_set() else None


def random_plans(problem: Problem, env: dict[str, float], n: int, seed: int, knots: int = 6) -> list[Plan]:
    """n random plans, uniform in the knots, that satisfy the limits (and [constraints]) and end at q_end."""
    commands = SplineCommands(problem, knots)
    rng = env_rng(problem, env, seed, 101)
    _, x = _valid(commands, problem.terminal_positions(env), n, lambda k: rng.uniform(0.0, 1.0, (k, commands.dim)),
                  projection(problem, env), env)
    return [Plan.from_array(problem.dt, xi, problem.channel_spec) for xi in x]


def nojudge_rows(problem: Problem, env: dict[str, float], sim, n: int, seed: int) -> list[dict]:
    """One row per random constraint-satisfying plan, replayed."""
    try:
        check_constraints(problem, env)
    except InfeasibleProblemError as exc:
        return [{"method": "nojudge", "environment": env, "status": "infeasible", "message": str(exc),
                 "simulated_success": None}]
    from judgeopt.planners.result import constraint_residuals

    rows = []
    for i, plan in enumerate(random_plans(problem, env, n, seed)):
        out = sim.simulate(plan, problem.world_env(env))
        res = constraint_residuals(problem, plan, env)
        rows.append({"method": "nojudge", "environment": env, "status": "sampled", "try": i,
                     "simulated_success": bool(out.success), "predicted_success": None,
                     "max_constraint_violation": max(res.values()), "worst_constraint": max(res, key=res.get),
                     "residuals": res, "solve_time_s": 0.0})
    return rows


def search(problem: Problem, env: dict[str, float], sim, seed: int, cfg: SearchConfig = SearchConfig()) -> dict:
    """A sim-scored cross-entropy search for one successful plan; stops at the first."""
    try:
        check_constraints(problem, env)
    except InfeasibleProblemError as exc:
        return {"method": "search", "environment": env, "status": "infeasible", "message": str(exc),
                "simulated_success": None, "tries": 0}
    commands = SplineCommands(problem, cfg.knots)
    rng = env_rng(problem, env, seed, 202)
    q_end = problem.terminal_positions(env)
    mean, std = np.full(commands.dim, 0.5), np.full(commands.dim, cfg.init_std)
    project = projection(problem, env)
    tries = 0
    for _ in range(cfg.iterations):
        z, x = _valid(commands, q_end, cfg.population,
                      lambda k: np.clip(mean + std * rng.standard_normal((k, commands.dim)), 0.0, 1.0), project, env)
        scores = np.full(len(z), -np.inf)
        for j in range(len(z)):
            out = sim.simulate(Plan.from_array(problem.dt, x[j], problem.channel_spec), problem.world_env(env))
            tries += 1
            scores[j] = out.progress
            if out.success:
                return {"method": "search", "environment": env, "status": "found", "simulated_success": True,
                        "tries": tries, "plan": x[j].tolist(), "config": asdict(cfg)}
        if len(z):
            elite = z[np.argsort(-scores)[:cfg.elite]]
            mean, std = elite.mean(0), np.maximum(elite.std(0), cfg.min_std)
    return {"method": "search", "environment": env, "status": "not_found", "simulated_success": False,
            "tries": tries, "config": asdict(cfg),
            "message": f"no successful plan found in {tries} tries"}
