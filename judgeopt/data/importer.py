"""Recorded demonstrations (CSV) into the dataset format, checked row by row.

CSV format (header row required, SI units, one file per demonstration or one table with a
`demo_id` column):

    demo_id  optional; without it the file is one demonstration
    t        time stamps in s, strictly increasing, any rate
    y        position along the scooping direction in m
    ydot     optional velocity in m/s (derived from y when missing)
    f        pressing force in N
    label    success or failure (also 1/0, true/false), the same on every row of a demonstration
    <env>    environment values (e.g. y_obj, mu), constant within a demonstration

Each demonstration is resampled to the planner's period (cubic interpolation of y, linear
of f) from its first time stamp over N·dt; a shorter one is held at its last position (at
rest) and force. Recorded values are stored as both commands and responses: a recording is
what the tool did.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.interpolate import CubicSpline

from judgeopt.data.dataset import Dataset
from judgeopt.trajectory import DEFAULT_DT, DEFAULT_HORIZON

LABELS = {"success": 1, "1": 1, "true": 1, "failure": 0, "0": 0, "false": 0}
REQUIRED = ("t", "y", "f", "label")
#: plausible magnitudes: a value beyond these is a unit mistake (mm, mm/s, N·10) more likely than a motion
LIMITS = {"y": 5.0, "ydot": 10.0, "f": 1000.0}


class ImportError_(ValueError):
    """A demonstration file that cannot be imported; the message names file, row and column."""


@dataclass(frozen=True)
class ImportSpec:
    env_names: tuple[str, ...]
    dt: float = DEFAULT_DT
    horizon: int = DEFAULT_HORIZON


def _read(path: Path) -> tuple[list[str], list[list[str]]]:
    try:
        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError) as exc:
        raise ImportError_(f"{path}: cannot read ({exc})") from None
    if not rows:
        raise ImportError_(f"{path}: empty file")
    return [h.strip() for h in rows[0]], rows[1:]


def _demos(path: Path, spec: ImportSpec) -> list[tuple[str, np.ndarray, int, np.ndarray]]:
    header, rows = _read(path)
    missing = [c for c in REQUIRED + spec.env_names if c not in header]
    if missing:
        raise ImportError_(f"{path}: missing column(s) {missing}; the header has {header}")
    col = {h: i for i, h in enumerate(header)}
    numeric = ["t", "y", "f", *spec.env_names] + (["ydot"] if "ydot" in col else [])
    groups: dict[str, list[tuple[int, list[str]]]] = {}
    for r, row in enumerate(rows, start=2):  # row numbers as a spreadsheet shows them
        if len(row) != len(header):
            raise ImportError_(f"{path}, row {r}: {len(row)} fields, the header has {len(header)}")
        key = row[col["demo_id"]].strip() if "demo_id" in col else path.stem
        groups.setdefault(key, []).append((r, row))
    out = []
    for key, items in groups.items():
        values = {}
        for c in numeric:
            v = []
            for r, row in items:
                try:
                    x = float(row[col[c]])
                except ValueError:
                    raise ImportError_(f"{path}, row {r}, column {c!r}: {row[col[c]]!r} is not a number") from None
                if not math.isfinite(x):
                    raise ImportError_(f"{path}, row {r}, column {c!r}: {row[col[c]]!r} is not finite")
                if c in LIMITS and abs(x) > LIMITS[c]:
                    raise ImportError_(f"{path}, row {r}, column {c!r}: {x:g} is beyond {LIMITS[c]:g}; "
                                       "expected SI units (m, m/s, N)")
                v.append(x)
            values[c] = np.array(v)
        t = values["t"]
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            r = items[bad[0] + 1][0]
            what = "duplicate" if t[bad[0] + 1] == t[bad[0]] else "earlier"
            raise ImportError_(f"{path}, row {r}, column 't': {what} time stamp {t[bad[0] + 1]:g} "
                               f"(time stamps must increase)")
        if len(t) < 2:
            raise ImportError_(f"{path}: demonstration {key!r} has {len(t)} row; need at least 2")
        labels = set()
        for r, row in items:
            lab = row[col["label"]].strip().lower()
            if lab not in LABELS:
                raise ImportError_(f"{path}, row {r}, column 'label': {row[col['label']]!r} is not success/failure")
            labels.add(LABELS[lab])
        if len(labels) > 1:
            raise ImportError_(f"{path}: demonstration {key!r} has both labels; a demonstration has one outcome")
        env = []
        for c in spec.env_names:
            if np.ptp(values[c]) > 1e-9 * max(1.0, abs(values[c][0])):
                raise ImportError_(f"{path}: environment column {c!r} changes within demonstration {key!r}")
            env.append(values[c][0])
        out.append((key, _resample(path, key, values, spec), labels.pop(), np.array(env)))
    return out


def _resample(path: Path, key: str, v: dict[str, np.ndarray], spec: ImportSpec) -> np.ndarray:
    t = v["t"] - v["t"][0]
    T = spec.horizon * spec.dt
    if t[-1] > T + 1e-9:
        raise ImportError_(f"{path}: demonstration {key!r} lasts {t[-1]:g} s, longer than the horizon "
                           f"N·dt = {T:g} s; trim it or import with a longer --horizon")
    tk = np.arange(spec.horizon + 1) * spec.dt
    inside = tk <= t[-1]
    spline = CubicSpline(t, v["y"]) if len(t) > 2 else None
    y = np.full(tk.shape, v["y"][-1])
    ydot = np.zeros(tk.shape)
    if spline is not None:
        y[inside] = spline(tk[inside])
    else:
        y[inside] = np.interp(tk[inside], t, v["y"])
    if "ydot" in v:
        ydot[inside] = np.interp(tk[inside], t, v["ydot"])
    else:
        ydot[inside] = spline(tk[inside], 1) if spline is not None else (v["y"][1] - v["y"][0]) / t[1]
    f = np.interp(tk, t, v["f"])  # holds the last force after the end
    return np.stack([y, ydot, f], axis=1)


def import_csv(paths: Sequence[str | Path], spec: ImportSpec) -> tuple[Dataset | None, list[str]]:
    """Every good demonstration from `paths`, and one message per bad file (never raises for a bad file)."""
    xs, labels, envs, errors, ids = [], [], [], [], []
    for p in map(Path, paths):
        try:
            demos = _demos(p, spec)
        except ImportError_ as exc:
            errors.append(str(exc))
            continue
        for key, x, lab, env in demos:
            xs.append(x)
            labels.append(lab)
            envs.append(env)
            ids.append(f"{p.name}:{key}")
    if not xs:
        return None, errors
    x = np.stack(xs)
    ds = Dataset(commands=x, responses=x.copy(), labels=np.array(labels, dtype=np.int8), env=np.stack(envs),
                 dt=spec.dt, env_names=tuple(spec.env_names),
                 meta={"source": "import-demos", "demo_ids": ids, "errors": errors})
    return ds, errors
