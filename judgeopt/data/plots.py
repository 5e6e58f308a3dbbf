"""Plots of demonstration sets (Figures: the caller shows them or saves them with
`judgeopt.files.save_figure`; the matplotlib backend is left to the user)."""

from __future__ import annotations

from matplotlib.figure import Figure

from judgeopt.data.dataset import Dataset


def plot_velocity_force(ds: Dataset, title: str = "") -> Figure:
    """Max commanded velocity against max commanded force, coloured by outcome (paper Fig. 13),
    one panel per mu tercile so the friction's effect shows."""
    vmax = ds.commands[:, :, 1].max(axis=1)
    fmax = ds.commands[:, :, 2].max(axis=1)
    mu = ds.env[:, list(ds.env_names).index("mu")] if "mu" in ds.env_names else None
    edges = [-float("inf"), 1.5, 2.5, float("inf")] if mu is not None else [None]
    panels = len(edges) - 1 if mu is not None else 1
    fig = Figure(figsize=(4.2 * (panels + 1), 4))
    axes = fig.subplots(1, panels + 1, sharex=True, sharey=True, squeeze=False)[0]
    groups = [("all", slice(None))]
    if mu is not None:
        names = ["mu < 1.5", "1.5 <= mu < 2.5", "mu >= 2.5"]
        groups += [(names[k], (mu >= edges[k]) & (mu < edges[k + 1])) for k in range(panels)]
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
