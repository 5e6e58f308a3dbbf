"""What a lab keeps beside its recordings: a labels file (`--labels labels.csv`), constant
environment values (`--env NAME=0.246`) and unit/sign conversions (`--scale f=-1`, `y=mm`).

Why a module of its own: every reader (CSV, HDF5, LeRobot, ROS 2 bags) takes them the same way.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence

from judgeopt.data.recording import LABELS, ImportError_

#: header names a labels file may use for the recording and for its outcome
FILE_COLUMNS = ("file", "recording", "name", "demo", "demo_id", "path", "filename")
LABEL_COLUMNS = ("success", "label", "outcome", "result")

#: unit -> (factor to SI, what it measures)
UNITS = {
    "s": (1.0, "t"), "ms": (1e-3, "t"), "us": (1e-6, "t"), "ns": (1e-9, "t"),
    "m": (1.0, "position"), "cm": (1e-2, "position"), "mm": (1e-3, "position"),
    "m/s": (1.0, "velocity"), "cm/s": (1e-2, "velocity"), "mm/s": (1e-3, "velocity"),
    "N": (1.0, "force"), "kN": (1e3, "force"), "mN": (1e-3, "force"),
}


@dataclass(frozen=True)
class LabelFile:
    """A labels file: recording name -> 1 (success) or 0 (failure)."""

    path: str
    labels: Mapping[str, int] = field(default_factory=dict)

    def lookup(self, keys: Sequence[str]) -> tuple[str, int] | None:
        """The entry for the first of `keys` (file name, stem, demo id) it names, by full name or base name."""
        for k in keys:
            if k in self.labels:
                return k, self.labels[k]
        base = {Path(k).name: k for k in self.labels} | {Path(k).stem: k for k in self.labels}
        for k in keys:
            if k in base:
                return base[k], self.labels[base[k]]
        return None


def read_labels(path: str | Path) -> LabelFile:
    """A CSV with a header naming the recording (file, recording, name, ...) and its outcome
    (success, label, ...: success/failure, 1/0, true/false)."""
    try:
        with open(path, newline="") as fh:
            rows = [r for r in csv.reader(fh) if any(c.strip() for c in r)]
    except (OSError, UnicodeDecodeError) as exc:
        raise ImportError_(f"--labels {path}: cannot read ({exc})") from None
    if not rows:
        raise ImportError_(f"--labels {path}: empty file; expected a header 'file,success' and a row per recording")
    header = [h.strip().lower() for h in rows[0]]
    name_col = next((header.index(c) for c in FILE_COLUMNS if c in header), None)
    label_col = next((header.index(c) for c in LABEL_COLUMNS if c in header), None)
    if name_col is None or label_col is None:
        raise ImportError_(f"--labels {path}: the header {rows[0]} needs a recording column (one of "
                           f"{', '.join(FILE_COLUMNS)}) and an outcome column (one of {', '.join(LABEL_COLUMNS)})")
    out: dict[str, int] = {}
    for r, row in enumerate(rows[1:], start=2):
        if len(row) <= max(name_col, label_col):
            raise ImportError_(f"--labels {path}, row {r}: {len(row)} fields, the header has {len(header)}")
        name, value = row[name_col].strip(), row[label_col].strip().lower()
        if value not in LABELS:
            raise ImportError_(f"--labels {path}, row {r}: {row[label_col]!r} is not success/failure (or 1/0)")
        if name in out and out[name] != LABELS[value]:
            raise ImportError_(f"--labels {path}, row {r}: {name!r} is labelled twice, differently")
        out[name] = LABELS[value]
    return LabelFile(str(path), out)


def parse_assignments(items: Sequence[str] | str | None, flag: str, allowed: Sequence[str],
                      units: bool = False, kinds: Mapping[str, str] | None = None) -> dict[str, float]:
    """`NAME=VALUE` items (comma-separated or repeated) as floats; with `units`, VALUE may be a
    unit (`mm`, `kN`, ...) or a signed one (`-N`), checked against what the name measures (`kinds`)."""
    if isinstance(items, str):
        items = [items]
    out: dict[str, float] = {}
    for item in (p.strip() for text in (items or ()) for p in text.split(",")):
        if not item:
            continue
        name, eq, value = (s.strip() for s in item.partition("="))
        if not eq or not name or not value:
            raise ImportError_(f"{flag}: {item!r} is not NAME=VALUE")
        if name not in allowed:
            raise ImportError_(f"{flag}: unknown name {name!r}; use one of {list(allowed)}")
        if name in out:
            raise ImportError_(f"{flag}: {name!r} is given twice")
        sign, unit = (-1.0, value[1:]) if units and value.startswith("-") else (1.0, value)
        if units and unit in UNITS:
            factor, kind = UNITS[unit]
            want = (kinds or {}).get(name, kind)
            if kind != want:
                raise ImportError_(f"{flag}: {name}={value}: {unit!r} measures {kind}, {name!r} is a {want}")
            out[name] = sign * factor
            continue
        try:
            out[name] = float(value)
        except ValueError:
            known = f" or a unit ({', '.join(UNITS)})" if units else ""
            raise ImportError_(f"{flag}: {name}={value!r}: not a number{known}") from None
        if not math.isfinite(out[name]):
            raise ImportError_(f"{flag}: {name}={value}: not a finite number; give a value such as {name}=1.5")
        if units and out[name] == 0:
            raise ImportError_(f"{flag}: {name}=0 would erase the channel; a scale is a non-zero factor")
    return out
