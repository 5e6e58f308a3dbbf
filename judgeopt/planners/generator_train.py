"""Training the generator through the frozen judge: L = L1 + L2, eqs. (2)-(4).

L1 = P softplus(-logit) = -P log y_judge (eq. 3). L2 (eq. 4) = Q times the squared limit
violations summed over the steps, plus R times the squared terminal errors. The same two
smoothing terms as the direct solve are added, so both planners minimise the same objective
and differ only in how the constraints are held (soft here, hard there). Each epoch samples
fresh environments from the problem's ranges (100 by default, Table 3) and takes one Adam step.

A conditioned generator (`conditioned=LimitRanges(...)`) also draws q̇_max, f_min and f_max per
trajectory, uniformly from the ranges, after the environments from the same seeded stream; the
penalties of eq. (4) then use each trajectory's own limits (and the generator scales its
outputs by them), so the loss is exactly a per-limit generator's loss for every sample.
"""

from __future__ import annotations

import copy
import time
from dataclasses import asdict, dataclass

import numpy as np
import torch
import torch.nn.functional as F

from judgeopt.judge.model import Judge
from judgeopt.planners.generator import Generator, GeneratorConfig, per_axis
from judgeopt.planners.limits import LimitRanges
from judgeopt.planners.dynamics import channel_order
from judgeopt.planners.problem import FREE, Problem


@dataclass(frozen=True)
class GeneratorTrainConfig:
    epochs: int = 5000
    batch: int = 100  # environments per epoch (Table 3: 100 actions per epoch)
    lr: float = 1e-3
    lr_final: float = 0.05  # cosine decay to this fraction: the last epochs refine, not jump
    grad_clip: float = 10.0
    seed: int = 0
    threads: int = 0
    progress: bool = True
    # margin: environment shifts ((name, delta), ...) under which the judge must also call each plan a
    # success, e.g. (("NAME", 0.03),): the world's NAME 0.03 more than told. Each adds margin_weight * P
    # times -log p of the plan in the shifted environment (clipped to the problem's range).
    margin: tuple[tuple[str, float], ...] = ()
    margin_weight: float = 1.0


def generator_loss(gen: Generator, judge: Judge, env: torch.Tensor,
                   limits: torch.Tensor | None = None, margin: tuple[tuple[str, float], ...] = (),
                   margin_weight: float = 1.0) -> tuple[torch.Tensor, dict[str, float]]:
    """Mean over the batch of eqs. (2)-(4) plus smoothing; parts returned for the history.
    `limits`: (B, 3) per-trajectory [q̇_max, f_min, f_max] for a conditioned generator
    (default: its problem's); the limit penalties use each trajectory's own. `margin`: see
    GeneratorTrainConfig; the plan (and its end at the told environment) is unchanged, only the
    environment the judge is told differs, so the plan must also succeed where the world differs."""
    pr = gen.problem
    lim = gen.condition(limits, env.shape[0])
    x = gen.rollout(env, lim)
    order = channel_order(pr)  # column of each channel in [positions, velocities, forces]
    na = pr.n_axes
    parts = torch.empty_like(x)
    parts[..., order] = x  # back to [positions, velocities, forces]
    q, v, f = parts[..., :na], parts[..., na:2 * na], parts[..., 2 * na:]

    if lim is None:
        qdot_max, f_min, f_max = (per_axis(pr.vec(k)) for k in ("qdot_max", "f_min", "f_max"))
    else:  # (B, 1, 1): broadcast along the steps and axes
        qdot_max, f_min, f_max = lim[:, 0:1, None], lim[:, 1:2, None], lim[:, 2:3, None]
    qdot_min, q_min, q_max = (per_axis(pr.vec(k)) for k in ("qdot_min", "q_min", "q_max"))
    cols = [pr.env_names.index(k) for k in judge.config.env_names]
    logit = judge(x, env[:, cols])
    l1 = pr.P * F.softplus(-logit)
    l_margin = torch.zeros_like(l1)
    for name, delta in margin:
        k = pr.env_names.index(name)
        lo, hi = pr.env_range(name)
        shifted = env.clone()
        shifted[:, k] = torch.clamp(env[:, k] + delta, lo, hi)
        l_margin = l_margin + margin_weight * pr.P * F.softplus(-judge(x, shifted[:, cols]))
    limits = ((F.relu(v[:, 1:] - qdot_max) ** 2 + F.relu(qdot_min - v[:, 1:]) ** 2
               + F.relu(q[:, 1:] - q_max) ** 2 + F.relu(q_min - q[:, 1:]) ** 2).sum((1, 2))
              + (F.relu(f - f_max) ** 2 + F.relu(f_min - f) ** 2).sum((1, 2)))
    terminal = ((v[:, -1] - torch.tensor(pr.vec("qdot_end"), dtype=x.dtype)) ** 2).sum(1)
    ends = pr.q_end if isinstance(pr.q_end, (list, tuple)) else [pr.q_end] * na
    for i, end in enumerate(ends):  # a fixed end: a number or an environment variable
        if end == FREE:
            continue
        if isinstance(end, str):  # the environment's value, end_margin past it within q_max (Problem.terminal_positions)
            told = env[:, pr.env_names.index(end)]
            room = torch.clamp(float(pr.vec("q_max")[i]) - told, min=0.0)
            target = told + torch.minimum(room, torch.full_like(told, float(pr.vec("end_margin")[i])))
        else:
            target = torch.full_like(q[:, -1, i], float(end))
        terminal = terminal + (q[:, -1, i] - target) ** 2
    acc = torch.diff(v, dim=1) / pr.dt
    smooth = (pr.acc_weight * pr.dt * (acc ** 2).sum((1, 2))
              + pr.force_rate_weight * (torch.diff(f, dim=1) ** 2).sum((1, 2)) / pr.dt)
    loss = (l1 + l_margin + pr.Q * limits + pr.R * terminal + smooth).mean()
    parts = {"loss": loss.item(), "L1": l1.mean().item(), "margin": l_margin.mean().item(),
             "limits": limits.mean().item(), "terminal": terminal.mean().item(),
             "p_mean": torch.sigmoid(logit).mean().item()}
    return loss, parts


def train_generator(problem: Problem, judge: Judge, config: GeneratorConfig | None = None,
                    tc: GeneratorTrainConfig | None = None,
                    conditioned: LimitRanges | None = None,
                    init: Generator | None = None) -> tuple[Generator, list[dict[str, float]]]:
    """A generator for `problem` trained against the frozen `judge`; seeded, deterministic.
    With `conditioned`, one generator for every q̇_max, f_min, f_max in those ranges (the
    problem's other limits and its environment ranges as given)."""
    tc = tc or GeneratorTrainConfig()
    if conditioned is not None:
        conditioned.check(problem)
    if tc.threads:
        torch.set_num_threads(tc.threads)
    torch.manual_seed(tc.seed)
    rng = np.random.default_rng(tc.seed)
    judge = judge.eval()
    for p in judge.parameters():
        p.requires_grad_(False)
    # `init`: fine-tune a copy of that generator (e.g. against a refined judge) instead of starting afresh
    gen = copy.deepcopy(init).train() if init is not None else Generator(problem, config, conditioned)
    if init is not None and conditioned is not None and init.conditioned != conditioned:
        # fine-tune over other limit ranges: same network, the new ranges' input scaling
        wider = Generator(init.problem, init.config, conditioned)
        wider.net.load_state_dict(init.net.state_dict())
        gen = wider.train()
    if init is not None:  # the loss weights and the end asked for now (--P, --Q, --R, end_margin), not init's
        gen.problem = gen.problem.with_overrides(P=problem.P, Q=problem.Q, R=problem.R, end_margin=problem.end_margin)
    opt = torch.optim.Adam(gen.parameters(), lr=tc.lr)
    sched = torch.optim.lr_scheduler.LambdaLR(
        opt, lambda k: tc.lr_final + (1 - tc.lr_final) * 0.5 * (1 + np.cos(np.pi * min(k, tc.epochs) / tc.epochs)))
    history: list[dict[str, float]] = []
    bar = None
    if tc.progress:
        from tqdm import tqdm
        bar = tqdm(total=tc.epochs, desc="train generator", unit="epoch")
    t0 = time.perf_counter()
    for epoch in range(1, tc.epochs + 1):
        env = torch.tensor(problem.sample_env(rng, tc.batch), dtype=torch.float32)
        lim = None if conditioned is None else torch.tensor(conditioned.sample(rng, tc.batch), dtype=torch.float32)
        opt.zero_grad(set_to_none=True)
        loss, parts = generator_loss(gen, judge, env, lim, tc.margin, tc.margin_weight)
        loss.backward()
        torch.nn.utils.clip_grad_norm_(gen.parameters(), tc.grad_clip)
        opt.step()
        sched.step()
        if epoch % 10 == 0 or epoch == tc.epochs:
            history.append({"epoch": epoch, **parts, "seconds": time.perf_counter() - t0})
            if bar is not None:
                bar.set_postfix(loss=f"{parts['loss']:.3f}", p=f"{parts['p_mean']:.3f}",
                                limits=f"{parts['limits']:.1e}", term=f"{parts['terminal']:.1e}")
        if bar is not None:
            bar.update(1)
    if bar is not None:
        bar.close()
    return gen.eval(), history


def train_config_dict(tc: GeneratorTrainConfig) -> dict:
    return asdict(tc)
