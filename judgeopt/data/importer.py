"""Recorded demonstrations (CSV or robomimic-style HDF5) into the dataset format, checked sample by sample.

Both readers turn a file into `RawDemo`s (per-sample arrays, environment values, a label and
a way to say where each value came from); one checker (`_check`) validates them and one
resampler (`_resample`) brings them to the planner's period, so the two formats are held to
the same rules and their messages name the file and the exact place (CSV: row and column;
HDF5: demo group and field). The file suffix picks the reader: `.h5`/`.hdf5` HDF5, else CSV.

Channels are the task's (`ImportSpec.task`, default the scoop: y, ydot, f): every position and
force channel is required, the velocities are optional (derived from their positions). Below,
the scoop's names.

CSV format (header row required, SI units, one file per demonstration or one table with a
`demo_id` column):

    demo_id  optional; without it the file is one demonstration
    t        time stamps in s, strictly increasing, any rate
    y        position along the scooping direction in m (each position channel of the task)
    ydot     optional velocity in m/s (derived from y when missing)
    f        pressing force in N (each force channel)
    label    success or failure (also 1/0, true/false), the same on every row of a demonstration
    <env>    environment values (e.g. y_obj, mu), constant within a demonstration

HDF5 format (robomimic's layout: a `data` group holding one group per demonstration,
`data/demo_0`, `data/demo_1`, ..., taken in the order of their trailing number). In each
demo group, every name below is looked up first as a dataset at that path in the group,
then under `obs/` (robomimic keeps low-dimensional signals in `obs/<key>`):

    t        optional time stamps in s, (T,) strictly increasing; without it the samples are
             taken as evenly spaced by the `dt` attribute (s; on the demo group, else on
             `data`), else by `control_freq` (Hz; demo or `data` attribute, or a key of
             `env_args["env_kwargs"]`); no time information at all is an error
    y        position in m, (T,)
    ydot     optional velocity in m/s, (T,) (derived from y when missing)
    f        pressing force in N, (T,)
    success  the label, the first of: attribute `success` of the demo group (true/false, 1/0 or
             "success"/"failure"); dataset `success` (its last value); dataset `rewards` (last
             value 1 or 0); dataset `dones` (last value 1 or 0; some robomimic sets set `dones`
             at the end of every demo, so prefer a `success` attribute there); none is an error
    <env>    environment values, the first of: attribute of the demo group; dataset (scalar or
             constant per-step array); key of `env_args["env_kwargs"]`, then of `env_args`
             (`env_args` is the JSON string attribute robomimic puts on `data`); attribute of `data`

Other key names are mapped with `ImportSpec.hdf5_keys` (`parse_hdf5_keys`, the command's
`--hdf5-keys`): `NAME=PATH` or `NAME=PATH:COLUMN` for one column of a (T, k) array, e.g.
`y=obs/robot0_eef_pos:1,f=obs/ft:2,success=is_success,mu=friction,dt=period`. A mapped name
is looked up only where it points (dataset at PATH, or an attribute/`env_args` key named
PATH). A (T, k) array with k > 1 needs a column. A bad demo group is reported and the others
in the file are imported; a bad CSV file is skipped whole.

Each demonstration is resampled to the planner's period (cubic interpolation of each position,
linear of each force) from its first time stamp over N·dt; a shorter one is held at its last position (at
rest) and force. Recorded values are stored as both commands and responses: a recording is
what the tool did.
"""

from __future__ import annotations

import csv
import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import numpy as np
from scipy.interpolate import CubicSpline

from judgeopt.data.dataset import Dataset
from judgeopt.tasks import DEFAULT_TASK, get_task
from judgeopt.trajectory import CHANNELS, DEFAULT_DT, DEFAULT_HORIZON, Channel

LABELS = {"success": 1, "1": 1, "true": 1, "failure": 0, "0": 0, "false": 0}
#: plausible magnitudes by channel kind: a value beyond is a unit mistake (mm, mm/s, N·10) more likely than a motion
LIMITS = {"position": 5.0, "velocity": 10.0, "force": 1000.0}
HDF5_SUFFIXES = (".h5", ".hdf5")


class ImportError_(ValueError):
    """A demonstration file that cannot be imported; the message names the file and the place in it."""


@dataclass(frozen=True)
class ImportSpec:
    env_names: tuple[str, ...]
    dt: float = DEFAULT_DT
    horizon: int = DEFAULT_HORIZON
    #: HDF5 name -> "PATH" or "PATH:COLUMN" (see the module docstring); unmapped names use their defaults
    hdf5_keys: Mapping[str, str] = field(default_factory=dict)
    #: whose channels the recordings hold (positions and forces required, velocities optional)
    task: str = DEFAULT_TASK

    @property
    def channels(self) -> tuple[Channel, ...]:
        return get_task(self.task).channels

    def names(self, *kinds: str) -> tuple[str, ...]:
        return tuple(c.name for c in self.channels if c.kind in kinds)

    @property
    def required(self) -> tuple[str, ...]:
        """CSV columns every file must have."""
        return ("t", *self.names("position", "force"), "label")

    @property
    def limits(self) -> dict[str, float]:
        return {c.name: LIMITS[c.kind] for c in self.channels}


@dataclass
class RawDemo:
    """One demonstration as read, before any check: what both readers hand to `_check`."""

    origin: str  # the file, first in every message
    name: str  # "demonstration 'demo0'" (CSV) or "demo group 'data/demo_0'" (HDF5)
    demo_id: str  # kept in the dataset's meta
    series: dict[str, np.ndarray]  # t, y, f and optional ydot, one value per sample
    env: dict[str, np.ndarray]  # per environment name: per-sample values, or one value
    label: int
    where: Callable[[str, int], str]  # "<file>, row 5, column 'y'": where sample i of a field is
    shown: Callable[[str, int], str] = lambda c, i: ""  # sample i of a field as the file spells it


# -- the shared checks ------------------------------------------------------------------------------
def _check(raw: RawDemo, spec: ImportSpec) -> tuple[np.ndarray, int, np.ndarray]:
    """Validate one demonstration (finite, plausible units, increasing time, constant environment)
    and resample it: the (N + 1, channels) array, its label and environment values."""
    s = raw.series
    lengths = {c: len(a) for c, a in s.items()}
    if len(set(lengths.values())) > 1:
        raise ImportError_(f"{raw.origin}: {raw.name} has fields of different lengths {lengths}")
    fields = [("t", s["t"]), *((c, s[c]) for c in spec.names("position", "force")),
              *((c, raw.env[c]) for c in spec.env_names), *((c, s[c]) for c in spec.names("velocity") if c in s)]
    limits = spec.limits
    for c, a in fields:
        lim = limits.get(c, np.inf)
        bad = np.flatnonzero(~np.isfinite(a) | (np.abs(np.nan_to_num(a)) > lim))
        if bad.size:
            i = int(bad[0])
            if not np.isfinite(a[i]):
                raise ImportError_(f"{raw.where(c, i)}: {raw.shown(c, i) or repr(float(a[i]))} is not finite")
            raise ImportError_(f"{raw.where(c, i)}: {a[i]:g} is beyond {lim:g}; expected SI units (m, m/s, N)")
    t = s["t"]
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        what = "duplicate" if t[k] == t[k - 1] else "earlier"
        raise ImportError_(f"{raw.where('t', k)}: {what} time stamp {t[k]:g} (time stamps must increase)")
    if len(t) < 2:
        raise ImportError_(f"{raw.origin}: {raw.name} has {len(t)} sample(s); need at least 2")
    env = []
    for c in spec.env_names:
        v = raw.env[c]
        if np.ptp(v) > 1e-9 * max(1.0, abs(v[0])):
            raise ImportError_(f"{raw.origin}: environment value {c!r} changes within {raw.name}")
        env.append(float(v[0]))
    return _resample(raw, spec), raw.label, np.array(env)


def _resample(raw: RawDemo, spec: ImportSpec) -> np.ndarray:
    v = raw.series
    t = v["t"] - v["t"][0]
    T = spec.horizon * spec.dt
    if t[-1] > T + 1e-9:
        raise ImportError_(f"{raw.origin}: {raw.name} lasts {t[-1]:g} s, longer than the horizon "
                           f"N·dt = {T:g} s; trim it or import with a longer --horizon")
    tk = np.arange(spec.horizon + 1) * spec.dt
    inside = tk <= t[-1]
    columns: dict[str, np.ndarray] = {}
    for c in spec.channels:
        if c.kind == "position":  # cubic through the positions; held (at rest) after the end
            spline = CubicSpline(t, v[c.name]) if len(t) > 2 else None
            q, qdot = np.full(tk.shape, v[c.name][-1]), np.zeros(tk.shape)
            q[inside] = spline(tk[inside]) if spline is not None else np.interp(tk[inside], t, v[c.name])
            velocity = next(d.name for d in spec.channels if d.of == c.name)
            if velocity in v:
                qdot[inside] = np.interp(tk[inside], t, v[velocity])
            else:
                qdot[inside] = spline(tk[inside], 1) if spline is not None else (v[c.name][1] - v[c.name][0]) / t[1]
            columns[c.name], columns[velocity] = q, qdot
        elif c.kind == "force":
            columns[c.name] = np.interp(tk, t, v[c.name])  # holds the last force after the end
    return np.stack([columns[c.name] for c in spec.channels], axis=1)


# -- CSV --------------------------------------------------------------------------------------------
def _read(path: Path) -> tuple[list[str], list[list[str]]]:
    try:
        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
    except (OSError, UnicodeDecodeError) as exc:
        raise ImportError_(f"{path}: cannot read ({exc})") from None
    if not rows:
        raise ImportError_(f"{path}: empty file")
    return [h.strip() for h in rows[0]], rows[1:]


def _csv_demos(path: Path, spec: ImportSpec) -> list[RawDemo]:
    """Parse a CSV file into raw demonstrations (numbers and labels parsed, nothing else checked)."""
    header, rows = _read(path)
    missing = [c for c in spec.required + spec.env_names if c not in header]
    if missing:
        raise ImportError_(f"{path}: missing column(s) {missing}; the header has {header}")
    col = {h: i for i, h in enumerate(header)}
    numeric = ["t", *spec.names("position", "force"), *spec.env_names] + [
        c for c in spec.names("velocity") if c in col]
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
                    v.append(float(row[col[c]]))
                except ValueError:
                    raise ImportError_(f"{path}, row {r}, column {c!r}: {row[col[c]]!r} is not a number") from None
            values[c] = np.array(v)
        labels = set()
        for r, row in items:
            lab = row[col["label"]].strip().lower()
            if lab not in LABELS:
                raise ImportError_(f"{path}, row {r}, column 'label': {row[col['label']]!r} is not success/failure")
            labels.add(LABELS[lab])
        if len(labels) > 1:
            raise ImportError_(f"{path}: demonstration {key!r} has both labels; a demonstration has one outcome")

        def where(c: str, i: int, items=items) -> str:
            return f"{path}, row {items[i][0]}, column {c!r}"

        def shown(c: str, i: int, items=items) -> str:
            return repr(items[i][1][col[c]])

        out.append(RawDemo(str(path), f"demonstration {key!r}", f"{path.name}:{key}",
                           {c: values[c] for c in ("t", *spec.names("position", "force", "velocity")) if c in values},
                           {c: values[c] for c in spec.env_names}, labels.pop(), where, shown))
    return out


# -- HDF5 (robomimic-style) -------------------------------------------------------------------------
_KEY = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*([^:,]+?)\s*(?::\s*(-?\d+)\s*)?$")


def parse_hdf5_keys(text: str | None, env_names: Sequence[str] = (), channels: Sequence[str] = CHANNELS) -> dict[str, str]:
    """`y=obs/eef_pos:1,f=obs/ft:2` -> {"y": "obs/eef_pos:1", "f": "obs/ft:2"}, checked. Names
    that may be mapped: t, the task's channels, success, dt and the environment names."""
    out: dict[str, str] = {}
    per_step = ("t", *channels)
    allowed = (*per_step, "success", "dt", *env_names)
    for item in filter(None, (p.strip() for p in (text or "").split(","))):
        m = _KEY.match(item)
        if not m:
            raise ImportError_(f"--hdf5-keys: {item!r} is not NAME=PATH or NAME=PATH:COLUMN")
        name, path, column = m.groups()
        if name not in allowed:
            raise ImportError_(f"--hdf5-keys: unknown name {name!r}; map one of {list(allowed)}")
        if name in out:
            raise ImportError_(f"--hdf5-keys: {name!r} is mapped twice")
        if column is not None and name not in per_step:
            raise ImportError_(f"--hdf5-keys: a column selector is only for per-step arrays ({', '.join(per_step)}), "
                               f"not {name!r}")
        out[name] = path.strip("/") + (f":{int(column)}" if column is not None else "")
    return out


def _split(ref: str) -> tuple[str, int | None]:
    path, _, col = ref.partition(":")
    return path, (int(col) if col else None)


def _demo_order(name: str) -> tuple[int, str]:
    m = re.search(r"(\d+)$", name)
    return (int(m.group(1)) if m else -1, name)


class _H5Demo:
    """Look-ups in one demo group, each answer saying where it was found (for messages)."""

    def __init__(self, path: Path, data: Any, group: Any, env_args: dict[str, Any], keys: Mapping[str, str]):
        self.path, self.data, self.g, self.env_args, self.keys = path, data, group, env_args, keys
        self.ctx = f"{path}, demo group {group.name.lstrip('/')!r}"

    def fail(self, name: str, what: str) -> ImportError_:
        return ImportError_(f"{self.ctx}, field {name!r}: {what}")

    def dataset(self, name: str) -> tuple[Any, str] | None:
        """The dataset for `name`: the mapped path, else `name` in the group, else `obs/name`."""
        import h5py

        paths = [_split(self.keys[name])[0]] if name in self.keys else [name, f"obs/{name}"]
        for p in paths:
            obj = self.g.get(p)
            if isinstance(obj, h5py.Dataset):
                return obj, p
        return None

    def read(self, name: str, ds: Any, p: str) -> np.ndarray:
        """A dataset as float64, with numeric type checked and read errors named."""
        if ds.dtype.kind not in "biuf":
            raise self.fail(name, f"dataset {p!r} holds {ds.dtype} values, not numbers")
        try:
            return np.asarray(ds[()], dtype=np.float64)
        except (OSError, ValueError, TypeError) as exc:
            raise self.fail(name, f"cannot read dataset {p!r} ({exc})") from None

    def series(self, name: str, required: bool) -> tuple[np.ndarray, str] | None:
        """A per-step array (T,), or one column of a (T, k) one."""
        found = self.dataset(name)
        if found is None:
            if required or name in self.keys:
                where = repr(self.keys[name]) if name in self.keys else f"{name!r} or 'obs/{name}'"
                raise self.fail(name, f"no dataset {where} in the demo group (it has {self.listing()}); map "
                                f"another with --hdf5-keys {name}=PATH[:COLUMN]")
            return None
        ds, p = found
        col = _split(self.keys[name])[1] if name in self.keys else None
        a = self.read(name, ds, p)
        if a.ndim == 2 and col is None and a.shape[1] == 1:
            a = a[:, 0]
        elif a.ndim == 2 and col is not None:
            if not -a.shape[1] <= col < a.shape[1]:
                raise self.fail(name, f"column {col} is out of range for dataset {p!r} of shape {a.shape}")
            a, p = a[:, col], f"{p}:{col}"
        elif a.ndim == 2:
            raise self.fail(name, f"dataset {p!r} has shape {a.shape}: choose a column with "
                            f"--hdf5-keys {name}={p}:COLUMN")
        elif a.ndim != 1 or col is not None:
            raise self.fail(name, f"dataset {p!r} has shape {a.shape}; expected (T,)"
                            + (" or (T, k) with a column" if col is None else " and (T, k) for a column selector"))
        return a, p

    def listing(self) -> str:
        import h5py

        names: list[str] = []
        self.g.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        return str(sorted(names)) if names else "no datasets"

    def value(self, name: str, datasets: bool = True) -> tuple[Any, str] | None:
        """A per-demo value: demo attribute, dataset, env_args["env_kwargs"], env_args, `data` attribute."""
        key = self.keys.get(name, name)
        if key in self.g.attrs:
            return self.g.attrs[key], f"attribute {key!r}"
        if datasets:
            found = self.dataset(name)
            if found is not None:
                return self.read(name, *found), f"dataset {found[1]!r}"
        kwargs = self.env_args.get("env_kwargs")
        if isinstance(kwargs, dict) and key in kwargs:
            return kwargs[key], f"env_args['env_kwargs'][{key!r}]"
        if key in self.env_args:
            return self.env_args[key], f"env_args[{key!r}]"
        if key in self.data.attrs:
            return self.data.attrs[key], f"attribute {key!r} of 'data'"
        return None


def _number(d: _H5Demo, name: str, value: Any, where: str) -> np.ndarray:
    """An attribute or JSON value as a 1-D float array (one value, or one per sample)."""
    if isinstance(value, (bytes, np.bytes_)):
        value = value.decode(errors="replace")
    try:
        a = np.atleast_1d(np.asarray(value, dtype=np.float64)).ravel()
    except (TypeError, ValueError):
        raise d.fail(name, f"{where} is {value!r}, not a number") from None
    if a.size == 0:
        raise d.fail(name, f"{where} is empty")
    return a


def _label(d: _H5Demo) -> int:
    """The success flag, from the sources the module docstring lists, in that order (a mapped
    `success` is looked up only where it points: attribute, then dataset)."""
    key = d.keys.get("success", "success")
    found: tuple[Any, str] | None = None
    if key in d.g.attrs:
        found = d.g.attrs[key], f"attribute {key!r}"
    names = ["success"] if "success" in d.keys else ["success", "rewards", "dones"]
    for name in names:
        if found is not None:
            break
        ds = d.dataset(name)
        if ds is not None:
            found = d.read("success", *ds), f"dataset {ds[1]!r}"
    if found is None:
        tried = (f"attribute or dataset {key!r}" if "success" in d.keys
                 else "attribute 'success', dataset 'success', 'rewards' or 'dones' (also under obs/)")
        raise d.fail("success", f"no success flag: found no {tried}; map one with --hdf5-keys success=NAME")
    value, where = found
    if isinstance(value, (bytes, np.bytes_)):
        value = value.decode(errors="replace")
    if isinstance(value, str):
        if value.strip().lower() in LABELS:
            return LABELS[value.strip().lower()]
        raise d.fail("success", f"{where} is {value!r}, not success/failure")
    last = _number(d, "success", value, where)[-1]
    if last in (0.0, 1.0):
        return int(last)
    raise d.fail("success", f"{where}: last value {last:g} is neither 1 (success) nor 0 (failure)")


def _hdf5_raw(d: _H5Demo, spec: ImportSpec) -> RawDemo:
    """One demo group as a RawDemo (arrays read, shapes and types checked, values not yet)."""
    series: dict[str, np.ndarray] = {}
    desc: dict[str, str] = {}
    wanted = [(c, True) for c in spec.names("position", "force")] + [(c, False) for c in spec.names("velocity")]
    for name, required in (*wanted, ("t", False)):
        found = d.series(name, required)
        if found is not None:
            series[name], desc[name] = found
    if "t" not in series:
        n = len(series[spec.names("position")[0]])
        found = d.value("dt", datasets=False)
        if found is None and "dt" in d.keys:
            raise d.fail("t", f"no attribute or env_args key {d.keys['dt']!r} for the sample period "
                         "(--hdf5-keys dt=...)")
        if found is not None:
            step = float(_number(d, "dt", *found)[0])
            desc["t"] = f"evenly spaced by dt = {step:g} s from {found[1]}"
        else:
            found = d.value("control_freq", datasets=False)
            if found is None:
                raise d.fail("t", "no time information: no dataset 't' or 'obs/t', no attribute 'dt' (on the demo "
                             "group or 'data') and no 'control_freq' (attribute or env_args); map one with "
                             "--hdf5-keys t=PATH or dt=NAME")
            hz = float(_number(d, "t", *found)[0])
            if not (np.isfinite(hz) and hz > 0):
                raise d.fail("t", f"control frequency {found[1]} = {hz:g} Hz is not a positive number")
            step = 1.0 / hz
            desc["t"] = f"evenly spaced at {hz:g} Hz from {found[1]}"
        if not (np.isfinite(step) and step > 0):
            raise d.fail("t", f"sample period {found[1]} = {step:g} s is not a positive number")
        series["t"] = np.arange(n) * step
    env: dict[str, np.ndarray] = {}
    for name in spec.env_names:
        found = d.value(name)
        if found is None:
            raise d.fail(name, f"no environment value {d.keys.get(name, name)!r}: not an attribute of the demo "
                         "group, a dataset, a key of env_args or an attribute of 'data'; map one with "
                         f"--hdf5-keys {name}=NAME")
        env[name], desc[name] = _number(d, name, *found), found[1]
    label = _label(d)

    def where(c: str, i: int) -> str:
        at = f", sample {i}" if len(series.get(c, env.get(c, ()))) > 1 else ""
        return f"{d.ctx}, field {c!r} ({desc[c]}){at}"

    group = d.g.name.lstrip("/")
    return RawDemo(str(d.path), f"demo group {group!r}", f"{d.path.name}:{group.split('/')[-1]}",
                   series, env, label, where)


def _hdf5_file(path: Path, spec: ImportSpec) -> tuple[list[tuple[str, np.ndarray, int, np.ndarray]], list[str]]:
    """Every good demo group of one file, and one message per bad one (or one for the file)."""
    import h5py

    try:
        h = h5py.File(path, "r")
    except (OSError, ValueError) as exc:
        return [], [f"{path}: not a readable HDF5 file ({exc})"]
    good, errors = [], []
    with h:
        data = h.get("data")
        if not isinstance(data, h5py.Group):
            return [], [f"{path}: no 'data' group (a robomimic-style file holds data/demo_0, data/demo_1, ...); "
                        f"top-level names: {sorted(h.keys())}"]
        env_args: dict[str, Any] = {}
        if "env_args" in data.attrs:
            raw = data.attrs["env_args"]
            try:
                env_args = json.loads(raw.decode() if isinstance(raw, bytes) else str(raw))
            except (json.JSONDecodeError, UnicodeDecodeError) as exc:
                return [], [f"{path}: attribute 'env_args' of 'data' is not valid JSON ({exc})"]
            if not isinstance(env_args, dict):
                return [], [f"{path}: attribute 'env_args' of 'data' is not a JSON object"]
        names = sorted((n for n, g in data.items() if isinstance(g, h5py.Group)), key=_demo_order)
        if not names:
            return [], [f"{path}: the 'data' group holds no demo groups (data/demo_0, data/demo_1, ...)"]
        for name in names:
            d = _H5Demo(path, data, data[name], env_args, spec.hdf5_keys)
            try:
                raw_demo = _hdf5_raw(d, spec)
                x, label, env = _check(raw_demo, spec)
            except ImportError_ as exc:
                errors.append(str(exc))
                continue
            except (OSError, KeyError, RuntimeError) as exc:  # a damaged file: h5py's own read errors
                errors.append(f"{d.ctx}: cannot read ({exc})")
                continue
            good.append((raw_demo.demo_id, x, label, env))
    return good, errors


# -- both -------------------------------------------------------------------------------------------
def _file(path: Path, spec: ImportSpec) -> tuple[list[tuple[str, np.ndarray, int, np.ndarray]], list[str]]:
    if path.suffix.lower() in HDF5_SUFFIXES:
        return _hdf5_file(path, spec)
    try:  # a CSV file is imported whole or not at all
        good = []
        for raw in _csv_demos(path, spec):
            x, label, env = _check(raw, spec)
            good.append((raw.demo_id, x, label, env))
        return good, []
    except ImportError_ as exc:
        return [], [str(exc)]


def import_demos(paths: Sequence[str | Path], spec: ImportSpec) -> tuple[Dataset | None, list[str]]:
    """Every good demonstration from `paths` (CSV or HDF5 by suffix), and one message per bad
    CSV file or HDF5 demo group (never raises for bad input). `meta["files_imported"]` counts
    the files that gave at least one demonstration."""
    xs, labels, envs, errors, ids = [], [], [], [], []
    used = 0
    for p in map(Path, paths):
        good, errs = _file(p, spec)
        errors += errs
        used += bool(good)
        for demo_id, x, lab, env in good:
            xs.append(x)
            labels.append(lab)
            envs.append(env)
            ids.append(demo_id)
    if not xs:
        return None, errors
    x = np.stack(xs)
    ds = Dataset(commands=x, responses=x.copy(), labels=np.array(labels, dtype=np.int8), env=np.stack(envs),
                 dt=spec.dt, env_names=tuple(spec.env_names), task=spec.task,
                 channels=tuple(c.name for c in spec.channels), units={c.name: c.unit for c in spec.channels},
                 meta={"source": "import-demos", "demo_ids": ids, "errors": errors, "files_imported": used})
    return ds, errors


#: the name this function had when only CSV was read; it reads HDF5 by suffix too
import_csv = import_demos
