"""The Figs. 15-18-style plot of plans: each channel against time with its limits, the
commanded plan beside the simulated response where it was replayed (a matplotlib Figure)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Sequence

import numpy as np

from judgeopt.planners.problem import Problem
from judgeopt.planners.result import PlanResult

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def measured(result: PlanResult) -> np.ndarray | None:
    """The replay's response on the plan's channels, or None (not replayed, or refused)."""
    r = result.response
    return r if r is not None and result.plan is not None and r.shape == result.plan.values.shape else None


def plot_plans(problem: Problem, results: Sequence[PlanResult], title: str = "") -> Figure:
    """q, q̇ and f against time, the allowed region unshaded and the forbidden one grey
    (the paper's Figs. 15 and 16), one line per method; where a plan was replayed, what the
    controller measured beside what it was commanded (Figs. 17 and 18)."""
    from matplotlib.figure import Figure

    bounds = {"position": ("q_min", "q_max"), "velocity": ("qdot_min", "qdot_max"), "force": ("f_min", "f_max")}
    rows = []
    for c in problem.channel_spec:  # one panel per channel, its limits shaded
        same_kind = [d.name for d in problem.channel_spec if d.kind == c.kind]
        i = [d.name for d in problem.channel_spec if d.kind == "position"].index(c.of) if c.kind == "velocity" \
            else same_kind.index(c.name)
        lo, hi = (float(problem.vec(b)[i]) for b in bounds[c.kind])
        rows.append((c, f"{c.kind} {c.name} [{c.unit}]", lo, hi, i))
    fig = Figure(figsize=(6.4, 2.4 * len(rows) + 0.8), layout="constrained")
    axes = fig.subplots(len(rows), 1, sharex=True, squeeze=False)[:, 0]
    T = problem.horizon_time
    for j, (ax, (channel, label, lo, hi, axis)) in enumerate(zip(axes, rows)):  # j: the channel's column
        values = [getattr(r.plan, channel.name) for r in results if r.plan is not None]
        values += [m[:, j] for m in map(measured, results) if m is not None]
        span = max(hi - lo, 1e-9)
        top = max([hi + 0.15 * span] + [float(v.max()) for v in values])
        bottom = min([lo - 0.15 * span] + [float(v.min()) for v in values])
        ax.axhspan(hi, top, color="0.85", lw=0)
        ax.axhspan(bottom, lo, color="0.85", lw=0)
        ax.set_ylim(bottom, top)
        for r in results:
            if r.plan is None:
                continue
            v = getattr(r.plan, channel.name)
            p = (f", p = {r.success_probability:.2f} ({r.probability_source}), {r.verdict}"
                 if r.success_probability is not None else "")
            m = measured(r)
            line, = ax.plot(r.plan.t, v, marker=".", ms=3, label=f"{r.method}{p}" + (": command" if m is not None else ""))
            if m is not None:
                ax.plot(r.plan.t, m[:, j], color=line.get_color(), lw=2.2, alpha=0.45,
                        label=f"{r.method}: simulated response ({'success' if r.simulated_success else 'failure'})")
        end = problem.terminal_positions(results[0].env)[axis] if results and channel.kind == "position" else np.nan
        if not np.isnan(end):
            ax.axhline(end, color="k", ls=":", lw=1, label="q_end")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=2, fontsize=7)
    axes[-1].set_xlabel("time [s]")
    axes[-1].set_xlim(0, T)
    env = ", ".join(f"{k} = {v:.3g}" for k, v in results[0].env.items()) if results else ""
    fig.suptitle(title or f"{problem.name}: q̇_max = {problem.qdot_max} m/s ({env})", fontsize=10)
    return fig
