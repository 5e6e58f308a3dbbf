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

import numpy as np
import torch
from torch import nn

# the planner and the config live with the numpy rollout (no torch); imported from here before
from judgeopt.planners.amortized import AmortizedPlanner, GeneratorArrays, GeneratorConfig, OutputScales, input_size  # noqa: F401
from judgeopt.planners.dynamics import channel_order, step
from judgeopt.planners.limits import LimitRanges, limits_of
from judgeopt.planners.problem import Problem


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
        n_in = input_size(problem, conditioned)
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
        sc = OutputScales.of(problem)
        self.f_mid, self.f_half, self.a_scale = sc.f_mid, sc.f_half, sc.a_scale
        self.q_mid, self.q_half, self.v_half = sc.q_mid, sc.q_half, sc.v_half

    def arrays(self) -> GeneratorArrays:
        """The weights and buffers as numpy float64: what the amortised planner runs."""
        state = {k: v.detach().cpu().numpy() for k, v in self.state_dict().items()}
        return GeneratorArrays.from_state(self.problem, self.config, self.conditioned, state)

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
