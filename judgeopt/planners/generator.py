"""The amortised planner (the paper's NN_trajectory, Fig. 3): one MLP step, rolled out.

At each sample k the network reads the state and the environment and outputs the force f_k
and the acceleration a_{k+1}; the shared point-mass model (dynamics.py) integrates the state,
which is fed back: a plan of N steps is N + 1 network calls and no optimisation.

Inputs differ from the paper's (q_k, e) in one respect, on purpose: we also feed q̇_k and the
time k/N. With q_k alone the network cannot tell "still accelerating" from "must brake now"
at the same position, so it cannot meet the terminal velocity reliably; the velocity and
time make the step a proper state-feedback law. All inputs are scaled by the problem's
limits and environment ranges (stored with the model), so one file holds everything needed.

A *conditioned* generator (issue 6, `LimitRanges`) also reads the limits q̇_max, f_min and f_max
as inputs, scaled to [-1, 1] over the ranges it was trained on, so one network plans for any
limits inside those ranges. Its output and velocity scales follow each plan's own limits
(force around the middle of [f_min, f_max], accelerations from q̇_max), exactly as a per-limit
generator's follow its problem's; the other limits (positions, q̇_min, start, terminal
state, horizon) stay fixed to the problem it was trained on.
"""

from __future__ import annotations

from typing import Any

import time
from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import nn

from judgeopt.planners.dynamics import channel_order, plan_from_parts, step
from judgeopt.planners.limits import CONDITION_NAMES, LimitRanges, limits_of
from judgeopt.planners.base import BuildContext, Planner
from judgeopt.planners.problem import Problem
from judgeopt.planners.result import PlanResult, constraint_residuals
from judgeopt.trajectory import Plan


@dataclass(frozen=True)
class GeneratorConfig:
    """Table 3: two fully connected layers of 150 units."""

    hidden: int = 150
    layers: int = 2

    def to_dict(self) -> dict:
        return asdict(self)


def per_axis(values: np.ndarray):
    """One axis: a float (the arithmetic of the one-axis generators trained before tasks);
    several: a float32 tensor that broadcasts over the axes."""
    values = np.asarray(values, dtype=float)
    return float(values[0]) if values.size == 1 else torch.tensor(values, dtype=torch.float32)


class Generator(nn.Module):
    """state (positions, velocities per axis) + time + environment (+ limits, when conditioned)
    -> (forces f_k, accelerations a_{k+1} per axis); `rollout` makes whole plans in a batch."""

    def __init__(self, problem: Problem, config: GeneratorConfig | None = None,
                 conditioned: LimitRanges | None = None):
        super().__init__()
        self.problem, self.config = problem, config or GeneratorConfig()
        self.conditioned = conditioned
        na, nf = problem.n_axes, problem.n_forces
        self.n_axes, self.n_forces = na, nf
        n_in = 2 * na + 1 + len(problem.env_names) + (len(CONDITION_NAMES) if conditioned is not None else 0)
        layers: list[nn.Module] = []
        for _ in range(self.config.layers):
            layers += [nn.Linear(n_in, self.config.hidden), nn.Tanh()]
            n_in = self.config.hidden
        layers.append(nn.Linear(n_in, nf + na))
        self.net = nn.Sequential(*layers)
        pr = problem
        lo = [v[0] if isinstance(v, tuple) else v for v in pr.environment.values()]
        hi = [v[1] if isinstance(v, tuple) else v for v in pr.environment.values()]
        mid, half = np.add(lo, hi) / 2, np.maximum(np.subtract(hi, lo) / 2, 1e-6)
        self.register_buffer("e_mid", torch.tensor(mid, dtype=torch.float32))
        self.register_buffer("e_half", torch.tensor(half, dtype=torch.float32))
        if conditioned is not None:  # buffers only here: per-limit files keep their state_dict keys
            r = conditioned.array()
            self.register_buffer("c_mid", torch.tensor(r.mean(1), dtype=torch.float32))
            self.register_buffer("c_half", torch.tensor(np.maximum(0.5 * (r[:, 1] - r[:, 0]), 1e-6),
                                                        dtype=torch.float32))
        # output scales: forces around the middle of their range; accelerations that can
        # cross the velocity range in a few steps
        v = {k: pr.vec(k) for k in ("f_min", "f_max", "qdot_min", "qdot_max", "q_min", "q_max")}
        self.f_mid, self.f_half = 0.5 * (v["f_min"] + v["f_max"]), 0.5 * (v["f_max"] - v["f_min"])
        self.a_scale = (v["qdot_max"] - v["qdot_min"]) / (4 * pr.dt)
        self.q_mid, self.q_half = 0.5 * (v["q_min"] + v["q_max"]), 0.5 * (v["q_max"] - v["q_min"])
        self.v_half = 0.5 * (v["qdot_max"] - v["qdot_min"])

    def scales(self, limits: torch.Tensor | None) -> tuple:
        """(f_mid, f_half, a_scale, v_half): the problem's, or per-plan (B, 1) tensors from (B, 3)
        limits [q̇_max, f_min, f_max] (the same for every axis) for a conditioned generator."""
        if limits is None:
            return tuple(per_axis(x) for x in (self.f_mid, self.f_half, self.a_scale, self.v_half))
        qmax, fmin, fmax = limits[:, 0:1], limits[:, 1:2], limits[:, 2:3]
        qdot_min = per_axis(self.problem.vec("qdot_min"))
        return (0.5 * (fmin + fmax), 0.5 * (fmax - fmin), (qmax - qdot_min) / (4 * self.problem.dt),
                0.5 * (qmax - qdot_min))

    def condition(self, limits: torch.Tensor | None, b: int) -> torch.Tensor | None:
        """(B, 3) limits for a conditioned generator (default: its problem's), else None."""
        if self.conditioned is None:
            if limits is not None:
                raise ValueError("this generator was trained for fixed limits; it takes no per-plan limits")
            return None
        if limits is None:
            return torch.tensor(limits_of(self.problem), dtype=self.e_mid.dtype).expand(b, -1)
        return limits.to(self.e_mid.dtype)

    def step(self, q: torch.Tensor, v: torch.Tensor, tau: float, en: torch.Tensor,
             scales: tuple | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """(B, axes) positions and velocities -> (B, forces) forces and (B, axes) accelerations.
        `en`: the scaled environment, followed by the scaled limits for a conditioned generator."""
        f_mid, f_half, a_scale, v_half = scales or self.scales(None)
        x = torch.cat([(q - per_axis(self.q_mid)) / per_axis(self.q_half), v / v_half,
                       torch.full_like(q[:, :1], 2 * tau - 1), en], dim=1)
        out = self.net(x)
        nf = self.n_forces
        return f_mid + f_half * out[:, :nf], a_scale * out[:, nf:]

    def rollout(self, env: torch.Tensor, limits: torch.Tensor | None = None) -> torch.Tensor:
        """(B, E) environments in problem order -> (B, N + 1, channels) plans in the task's channel
        order. A conditioned generator also takes (B, 3) limits [q̇_max, f_min, f_max] (default:
        its problem's)."""
        pr = self.problem
        n, dt = pr.steps, pr.dt
        b = env.shape[0]
        en = (env.to(self.e_mid.dtype) - self.e_mid) / self.e_half
        limits = self.condition(limits, b)
        if limits is not None:
            en = torch.cat([en, (limits - self.c_mid) / self.c_half], dim=1)
        scales = self.scales(limits)
        q = torch.tensor(pr.vec("q0"), dtype=en.dtype).expand(b, -1)
        v = torch.tensor(pr.vec("qdot0"), dtype=en.dtype).expand(b, -1)
        qs, vs, fs = [q], [v], []
        for k in range(n + 1):
            f, a = self.step(q, v, k / n, en, scales)
            fs.append(f)
            if k == n:
                break
            q, v = step(q, v, a, dt)
            qs.append(q)
            vs.append(v)
        return torch.cat([torch.stack(qs, 1), torch.stack(vs, 1), torch.stack(fs, 1)], dim=2)[:, :, channel_order(pr)]


class AmortizedPlanner(Planner):
    """Plans with a trained generator in milliseconds; constraints are soft (penalties in
    training), so the residuals are measured and reported, never assumed to be zero."""

    method = "amortized"

    def __init__(self, generator: Generator, problem: Problem, judge=None):
        self.generator = generator.eval()
        self.problem = problem
        self.judge = judge
        # numpy copies of the weights: one plan is 31 tiny matrix-vector products, where
        # torch's per-call overhead (~0.1 ms) would dominate
        linears = [m for m in generator.net if isinstance(m, nn.Linear)]
        self._weights = [(m.weight.detach().double().numpy(), m.bias.detach().double().numpy()) for m in linears]
        self._e_mid = generator.e_mid.double().numpy()
        self._e_half = generator.e_half.double().numpy()
        g = generator
        if g.conditioned is not None:  # this problem's limits are the generator's extra inputs
            lim = limits_of(problem)
            self._c = (lim - g.c_mid.double().numpy()) / g.c_half.double().numpy()
            qmax, fmin, fmax = lim
            gp = g.problem
            qdot_min = gp.vec("qdot_min")
            self._scales = (np.full(g.n_forces, 0.5 * (fmin + fmax)), np.full(g.n_forces, 0.5 * (fmax - fmin)),
                            (qmax - qdot_min) / (4 * gp.dt), 0.5 * (qmax - qdot_min))
        else:
            self._c = np.empty(0)
            self._scales = (g.f_mid, g.f_half, g.a_scale, g.v_half)

    @classmethod
    def build(cls, context: BuildContext) -> "AmortizedPlanner":
        """With the generator found for the context's limits (the registry leaves this planner out
        where none covers them)."""
        return cls(context.generator, context.problem, context.judge)

    def plan(self, env: dict[str, float]) -> Plan:
        """The generator's rollout in numpy float64 (equal to Generator.rollout to float32 rounding)."""
        g, pr = self.generator, self.generator.problem
        n, dt = pr.steps, pr.dt
        f_mid, f_half, a_scale, v_half = self._scales
        na, nf = g.n_axes, g.n_forces
        en = (np.array([env[k] for k in pr.env_names]) - self._e_mid) / self._e_half
        x = np.empty(2 * na + 1 + en.size + self._c.size)
        x[2 * na + 1:2 * na + 1 + en.size] = en
        x[2 * na + 1 + en.size:] = self._c
        q, v = pr.vec("q0"), pr.vec("qdot0")
        qs, vs, fs = np.empty((n + 1, na)), np.empty((n + 1, na)), np.empty((n + 1, nf))
        for k in range(n + 1):
            x[:na], x[na:2 * na], x[2 * na] = (q - g.q_mid) / g.q_half, v / v_half, 2 * k / n - 1
            h = x
            for w, b in self._weights[:-1]:
                h = np.tanh(w @ h + b)
            w, b = self._weights[-1]
            o = w @ h + b
            qs[k], vs[k], fs[k] = q, v, f_mid + f_half * o[:nf]
            q, v = step(q, v, a_scale * o[nf:], dt)
        return plan_from_parts(self.problem, qs, vs, fs)

    def solve(self, env: dict[str, float], guess: Any = None) -> PlanResult:
        env = self.problem.env_dict(env)
        t0 = time.perf_counter()
        plan = self.plan(env)
        elapsed = time.perf_counter() - t0
        prob = None
        if self.judge is not None:
            from judgeopt.planners.direct import judge_env

            prob = float(self.judge.predict_proba(plan.as_array()[None], judge_env(self.judge, env)[None])[0])
        return PlanResult(self.method, env, plan, prob, "generated", elapsed,
                          constraint_residuals(self.problem, plan, env), iterations=None,
                          message="one forward rollout (constraints soft)")
