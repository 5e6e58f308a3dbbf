"""Plans out of judgeopt: 1 kHz CSV for a real controller, and the Figs. 15/16-style plot."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Sequence

import numpy as np

from judgeopt.planners.problem import Problem
from judgeopt.planners.result import PlanResult
from judgeopt.trajectory import Plan

CSV_HEADER = "t [s],q [m],qdot [m/s],f [N]"


def write_csv(plan: Plan, path: str | Path, step: float = 1e-3) -> Path:
    """Commands at `step` (1 ms): Hermite-interpolated position/velocity, linear force; the
    same interpolation the simulated controller applies. Written atomically."""
    t, y, ydot, f = plan.resample(step)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as fh:
            np.savetxt(fh, np.column_stack([t, y, ydot, f]), delimiter=",", fmt="%.9g", header=CSV_HEADER, comments="")
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def plot_plans(problem: Problem, results: Sequence[PlanResult], path: str | Path, title: str = "") -> Path:
    """q, q̇ and f against time, the allowed region unshaded and the forbidden one grey
    (the paper's Figs. 15 and 16), one line per method."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [("q", "position q [m]", problem.q_min, problem.q_max),
            ("qdot", "velocity q̇ [m/s]", problem.qdot_min, problem.qdot_max),
            ("f", "force f [N]", problem.f_min, problem.f_max)]
    fig, axes = plt.subplots(3, 1, figsize=(6.4, 7.2), sharex=True)
    T = problem.horizon_time
    for ax, (key, label, lo, hi) in zip(axes, rows):
        values = [getattr(r.plan, {"q": "y", "qdot": "ydot", "f": "f"}[key]) for r in results if r.plan is not None]
        span = max(hi - lo, 1e-9)
        top = max([hi + 0.15 * span] + [float(v.max()) for v in values])
        bottom = min([lo - 0.15 * span] + [float(v.min()) for v in values])
        ax.axhspan(hi, top, color="0.85", lw=0)
        ax.axhspan(bottom, lo, color="0.85", lw=0)
        ax.set_ylim(bottom, top)
        for r in results:
            if r.plan is None:
                continue
            v = getattr(r.plan, {"q": "y", "qdot": "ydot", "f": "f"}[key])
            p = f", p = {r.predicted_success:.3f}" if r.predicted_success is not None else ""
            ax.plot(r.plan.t, v, marker=".", ms=3, label=f"{r.method}{p}")
        if key == "q" and results:
            ax.axhline(problem.terminal_position(results[0].env), color="k", ls=":", lw=1, label="q_end")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="upper left")
    axes[-1].set_xlabel("time [s]")
    axes[-1].set_xlim(0, T)
    env = ", ".join(f"{k} = {v:.3g}" for k, v in results[0].env.items()) if results else ""
    fig.suptitle(title or f"{problem.name}: q̇_max = {problem.qdot_max} m/s ({env})", fontsize=10)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.stem, suffix=path.suffix or ".png")
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=120)
        os.replace(tmp, path)
    finally:
        Path(tmp).unlink(missing_ok=True)
        plt.close(fig)
    return path
