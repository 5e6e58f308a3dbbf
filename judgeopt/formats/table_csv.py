"""The importer's CSV: one header row naming the columns (t, each channel by name, a label, the
environment; SI units), one row per sample. `read_table` is what `judgeopt import-demos` reads;
`write_table` is its one writer, used for plans sent to a robot (`write_plan_csv`, so a recording
of the executed plan with a `label` column re-imports unchanged) and for datasets exported as
demonstrations (judgeopt.data.export).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from judgeopt.errors import BadInput
from judgeopt.files import atomic_write
from judgeopt.trajectory import Plan


class TableError(BadInput, ValueError):
    """A CSV file that cannot be read as a table."""


def read_table(path: str | Path) -> tuple[list[str], list[list[str]]]:
    """(the header's column names, stripped; the rows as text)."""
    try:
        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError) as exc:
        raise TableError(f"{path}: cannot read ({exc})") from None
    if not rows:
        raise TableError(f"{path}: empty file")
    return [h.strip() for h in rows[0]], rows[1:]


def table_text(header: Sequence[str], rows: Iterable[Sequence[object]]) -> str:
    """CSV text: floats as `repr` (exact round trip) unless already text."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for row in rows:
        w.writerow([repr(float(v)) if isinstance(v, (float, np.floating)) else v for v in row])
    return buf.getvalue()


def write_table(path: str | Path, header: Sequence[str], rows: Iterable[Sequence[object]]) -> Path:
    """Write atomically (a reader sees the old file or the whole new one)."""
    atomic_write(path, table_text(header, rows))
    return Path(path)


def write_records(path: str | Path, records: Sequence[dict], fieldnames: Sequence[str] | None = None) -> Path:
    """Rows of dicts (a training history, a summary) as CSV, atomically; the columns are
    `fieldnames`, else every key in the order it first appears."""
    buf = io.StringIO(newline="")
    w = csv.DictWriter(buf, fieldnames=list(fieldnames or dict.fromkeys(k for r in records for k in r)))
    w.writeheader()
    w.writerows(records)
    atomic_write(path, buf.getvalue())
    return Path(path)


def write_plan_csv(plan: Plan, path: str | Path, step: float = 1e-3, env: dict[str, float] | None = None) -> Path:
    """Commands at `step` (1 ms): Hermite-interpolated position/velocity, linear force; the same
    interpolation the simulated controller applies. Columns: t, the channels by name, then `env`'s
    values, constant; 9 significant digits."""
    t, x = plan.resample(step)
    env = env or {}
    table = np.column_stack([t, x, np.tile([float(v) for v in env.values()], (len(t), 1))])
    return write_table(path, ["t", *(c.name for c in plan.channels), *env], ([f"{v:.9g}" for v in row] for row in table))
