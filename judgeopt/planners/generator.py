"""The amortised planner (the paper's NN_trajectory, Fig. 3): one MLP step, rolled out.

At each sample k the network reads the state and the environment and outputs the force f_k
and the acceleration a_{k+1}; the shared point-mass model (dynamics.py) integrates the state,
which is fed back: a plan of N steps is N + 1 network calls and no optimisation.

Inputs differ from the paper's (q_k, e) in one respect, on purpose: we also feed q̇_k and the
time k/N. With q_k alone the network cannot tell "still accelerating" from "must brake now"
at the same position, so it cannot meet the terminal velocity reliably; the velocity and
time make the step a proper state-feedback law. All inputs are scaled by the problem's
limits and environment ranges (stored with the model), so one file holds everything needed.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import nn

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


class Generator(nn.Module):
    """state + environment -> (f_k, a_{k+1}); `rollout` makes whole plans in a batch."""

    def __init__(self, problem: Problem, config: GeneratorConfig | None = None):
        super().__init__()
        self.problem, self.config = problem, config or GeneratorConfig()
        n_in = 3 + len(problem.env_names)
        layers: list[nn.Module] = []
        for _ in range(self.config.layers):
            layers += [nn.Linear(n_in, self.config.hidden), nn.Tanh()]
            n_in = self.config.hidden
        layers.append(nn.Linear(n_in, 2))
        self.net = nn.Sequential(*layers)
        pr = problem
        lo = [v[0] if isinstance(v, tuple) else v for v in pr.environment.values()]
        hi = [v[1] if isinstance(v, tuple) else v for v in pr.environment.values()]
        mid, half = np.add(lo, hi) / 2, np.maximum(np.subtract(hi, lo) / 2, 1e-6)
        self.register_buffer("e_mid", torch.tensor(mid, dtype=torch.float32))
        self.register_buffer("e_half", torch.tensor(half, dtype=torch.float32))
        # output scales: forces around the middle of their range; accelerations that can
        # cross the velocity range in a few steps
        self.f_mid, self.f_half = 0.5 * (pr.f_min + pr.f_max), 0.5 * (pr.f_max - pr.f_min)
        self.a_scale = (pr.qdot_max - pr.qdot_min) / (4 * pr.dt)
        self.q_mid, self.q_half = 0.5 * (pr.q_min + pr.q_max), 0.5 * (pr.q_max - pr.q_min)
        self.v_half = 0.5 * (pr.qdot_max - pr.qdot_min)

    def step(self, q: torch.Tensor, v: torch.Tensor, tau: float, en: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = torch.cat([((q - self.q_mid) / self.q_half)[:, None], (v / self.v_half)[:, None],
                       torch.full_like(q, 2 * tau - 1)[:, None], en], dim=1)
        out = self.net(x)
        return self.f_mid + self.f_half * out[:, 0], self.a_scale * out[:, 1]

    def rollout(self, env: torch.Tensor) -> torch.Tensor:
        """(B, E) environments in problem order -> (B, N + 1, 3) plans [q, q̇, f]."""
        pr = self.problem
        n, dt = pr.steps, pr.dt
        b = env.shape[0]
        en = (env.to(self.e_mid.dtype) - self.e_mid) / self.e_half
        q = torch.full((b,), pr.q0, dtype=en.dtype)
        v = torch.full((b,), pr.qdot0, dtype=en.dtype)
        qs, vs, fs = [q], [v], []
        for k in range(n + 1):
            f, a = self.step(q, v, k / n, en)
            fs.append(f)
            if k == n:
                break
            v_next = v + a * dt
            q = q + 0.5 * dt * (v + v_next)
            v = v_next
            qs.append(q)
            vs.append(v)
        return torch.stack([torch.stack(qs, 1), torch.stack(vs, 1), torch.stack(fs, 1)], dim=2)


class AmortizedPlanner:
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

    def plan(self, env: dict[str, float]) -> Plan:
        """The generator's rollout in numpy float64 (equal to Generator.rollout to float32 rounding)."""
        g, pr = self.generator, self.generator.problem
        n, dt = pr.steps, pr.dt
        en = (np.array([env[k] for k in pr.env_names]) - self._e_mid) / self._e_half
        x = np.empty(3 + en.size)
        x[3:] = en
        q, v = pr.q0, pr.qdot0
        out = np.empty((n + 1, 3))
        for k in range(n + 1):
            x[0], x[1], x[2] = (q - g.q_mid) / g.q_half, v / g.v_half, 2 * k / n - 1
            h = x
            for w, b in self._weights[:-1]:
                h = np.tanh(w @ h + b)
            w, b = self._weights[-1]
            o = w @ h + b
            out[k] = q, v, g.f_mid + g.f_half * o[0]
            v_next = v + g.a_scale * o[1] * dt
            q, v = q + 0.5 * dt * (v + v_next), v_next
        return Plan.from_array(self.problem.dt, out)

    def solve(self, env: dict[str, float]) -> PlanResult:
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
