"""A dataset out as one CSV table in the importer's format (judgeopt.formats.table_csv), so it can be read by any tool and
imported back unchanged (`judgeopt export-demos`, then `judgeopt import-demos`).

Columns: demo_id, t (s, k·dt from 0), every channel (the scoop's y [m], ydot [m/s], f [N]),
label (success/failure), the environment values. The responses are written (what was measured
and what the judge reads); an imported dataset holds the recording as both commands and
responses, so it makes the round trip whole, while a simulated one loses its commands.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from judgeopt.data.dataset import Dataset
from judgeopt.formats.table_csv import table_text, write_table


def demo_ids(ds: Dataset) -> list[str]:
    """The demonstrations' names: those the importer kept (file:demo), else `demo<index>`."""
    ids = ds.meta.get("demo_ids")
    if isinstance(ids, str):  # as a loaded file keeps it
        try:
            ids = json.loads(ids)
        except json.JSONDecodeError:
            ids = None
    if isinstance(ids, list) and len(ids) == ds.n and len(set(map(str, ids))) == ds.n:
        return [str(i) for i in ids]
    return [f"demo{int(i)}" for i in ds.index]


def _rows(ds: Dataset):
    t = np.arange(ds.horizon + 1) * ds.dt
    for name, x, label, env in zip(demo_ids(ds), ds.responses, ds.labels, ds.env):
        outcome = "success" if label else "failure"
        env_cells = [float(v) for v in env]
        for k in range(len(t)):
            yield [name, float(t[k]), *(float(v) for v in x[k]), outcome, *env_cells]


def demos_csv(ds: Dataset) -> str:
    """The dataset as CSV text (numbers written exactly: repr of each float)."""
    return table_text(["demo_id", "t", *ds.channels, "label", *ds.env_names], _rows(ds))


def export_csv(ds: Dataset, path: str | Path) -> Path:
    """Write the CSV atomically (a reader sees the old file or the whole new one)."""
    return write_table(path, ["demo_id", "t", *ds.channels, "label", *ds.env_names], _rows(ds))
