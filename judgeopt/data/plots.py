"""Plots of demonstration sets (Figures: the caller shows them or saves them with
`judgeopt.files.save_figure`; the matplotlib backend is left to the user)."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from judgeopt.data.dataset import Dataset
from judgeopt.tasks import TaskError, get_task


def panels(ds: Dataset) -> list[tuple[str, np.ndarray]]:
    """The demonstrations split by the variable the dataset's task names (`Task.demo_panels`), one
    (label, mask) per interval between its edges; none where the task names none, the data lacks
    it, or the task is not installed here."""
    try:
        split = get_task(ds.task).demo_panels
    except TaskError:
        return []
    if split is None or split[0] not in ds.env_names:
        return []
    name, inner = split
    x = ds.env[:, list(ds.env_names).index(name)]
    edges = [-float("inf"), *inner, float("inf")]
    labels = ([f"{name} < {inner[0]:g}"] + [f"{lo:g} <= {name} < {hi:g}" for lo, hi in zip(inner, inner[1:])]
              + [f"{name} >= {inner[-1]:g}"])
    return [(label, (x >= lo) & (x < hi)) for label, lo, hi in zip(labels, edges, edges[1:])]


def plot_velocity_force(ds: Dataset, title: str = "") -> Figure:
    """Max commanded velocity against max commanded force, coloured by outcome (paper Fig. 13),
    beside one panel per interval of the variable the task splits its demonstrations by
    (`panels`: the scoop's friction), so that variable's effect shows."""
    vmax = ds.commands[:, :, 1].max(axis=1)
    fmax = ds.commands[:, :, 2].max(axis=1)
    groups: list[tuple[str, np.ndarray | slice]] = [("all", slice(None)), *panels(ds)]
    fig = Figure(figsize=(4.2 * len(groups), 4))
    axes = fig.subplots(1, len(groups), sharex=True, sharey=True, squeeze=False)[0]
    for ax, (name, m) in zip(axes, groups):
        lab = ds.labels[m]
        ax.scatter(vmax[m][lab == 0], fmax[m][lab == 0], s=4, c="tab:red", alpha=0.35, label="failure")
        ax.scatter(vmax[m][lab == 1], fmax[m][lab == 1], s=4, c="tab:blue", alpha=0.6, label="success")
        ax.set_title(f"{name}: {lab.mean():.0%} success of {len(lab)}")
        ax.set_xlabel("max velocity (m/s)")
    axes[0].set_ylabel("max force (N)")
    axes[0].legend(loc="lower right", markerscale=3)
    fig.suptitle(title)
    fig.tight_layout()
    return fig
