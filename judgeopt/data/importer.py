"""Recorded demonstrations (CSV, robomimic-style HDF5, LeRobot v3, ROS 2 MCAP bags) into the dataset format,
checked sample by sample.

Every reader turns its input into `RawDemo`s (per-sample arrays, environment values, a label and
a way to say where each value came from); one checker (`judgeopt.data.recording.check`) validates
them, crops them to their window and resamples them to the planner's period, so every format is
held to the same rules and its messages name the file and the exact place (CSV: row and column;
HDF5: demo group and field; LeRobot: data file, episode, row and field). A folder with
`meta/info.json` is read as a LeRobot dataset (`judgeopt.data.lerobot`), a ROS 2 bag (a folder
with metadata.yaml, or a `.mcap` file) by `judgeopt.data.ros2`, a `.h5`/`.hdf5` file as HDF5,
anything else as CSV.

Channels are the task's (`ImportSpec.task`, default the scoop: y, ydot, f): every position and
force channel is required, the velocities are optional (derived from their positions). Below,
the scoop's names.

CSV format (header row required, SI units, one file per demonstration or one table with a
`demo_id` column):

    demo_id  optional; without it the file is one demonstration
    t        time stamps in s, strictly increasing, any rate and origin (UNIX time is fine)
    y        position along the scooping direction in m (each position channel of the task)
    ydot     optional velocity in m/s (derived from y when missing)
    f        pressing force in N, pressing positive (each force channel)
    label    success or failure (also 1/0, true/false), the same on every row of a demonstration
    <env>    environment values (e.g. y_obj, mu), constant within a demonstration

A lab's own files need no conversion: `--columns t=time,y=tool_y_m,f=fz_N` maps its header;
`--scale f=-1,y=mm` (a factor or a signed unit) and `--offset y=X` convert as read; `--labels
FILE` (a CSV of recording and outcome) and `--env y_obj=0.246` stand in for the label and
environment columns. A channel whose cells are empty on some rows was recorded at its own rate
(motion capture at 120 Hz, force at 1 kHz on other rows); each keeps its own time stamps, and
only each stream's must increase. `--streams mocap,ft` merges NAME_mocap.csv and NAME_ft.csv.
A force that is only negative while pressing is refused, naming `--scale f=-1`; a position
beyond 5 m names `--scale y=mm`.

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
             value 1 or 0); dataset `dones` (last value 1 or 0; refused when all are 1, see
             below); none is an error
    <env>    environment values, the first of: attribute of the demo group; dataset (scalar or
             constant per-step array); key of `env_args["env_kwargs"]`, then of `env_args`
             (`env_args` is the JSON string attribute robomimic puts on `data`); attribute of `data`

Other key names are mapped with `ImportSpec.hdf5_keys` (`parse_hdf5_keys`, the command's
`--hdf5-keys`): `NAME=PATH` or `NAME=PATH:COLUMN` for one column of a (T, k) array, e.g.
`y=obs/robot0_eef_pos:1,f=obs/ft:2,success=is_success,mu=friction,dt=period`. A mapped name
is looked up only where it points (dataset at PATH, or an attribute/`env_args` key named
PATH). A (T, k) array with k > 1 needs a column. A bad demo group is reported and the others
in the file are imported; a bad CSV file is skipped whole.

ROS 2 bags (rosbag2 with MCAP storage, read with `rosbags`, extra `judgeopt[ros]`): the command's
`--topics` (`ImportSpec.ros_topics`) names a geometry_msgs/msg/PoseStamped topic and axis for
each position and a WrenchStamped topic and axis for each force, e.g.
`y=/tool/pose:y,f=/ft/wrench:z`; optionally `episode=TOPIC` (each message starts a
demonstration; else one bag, one demonstration), `label=TOPIC` (std_msgs Bool/String) and an
environment value per topic. Time is the header stamp; each stream keeps its own rate. Labels
and environment values a bag lacks come from `--labels`/`--env`. Details in `judgeopt.data.ros2`.

Velocity, where not recorded, comes from a Savitzky-Golay fit of the position whose window is
the shortest that leaves at most 0.01 m/s of the measured position noise (at most 0.25 s;
`judgeopt.data.signals`); the same fit gives the motion's onset and end. The noise, window and
durations are reported (`report`).

Which part of a recording is kept (`ImportSpec` start/end/align/..., the command's flags):
`--start`/`--end` S crop it (seconds after its first time stamp); `--align contact` starts it
`--lead` s (default 0.1) before the first sample where a force channel's magnitude exceeds
`--contact-force` N (default 1), `--align onset` `--lead` s before the position leaves rest,
each recording its own, clipped at `--start`. `--tare` subtracts each force's mean over the rest
before the motion. What is kept must fit in N·dt: a longer window is refused with its duration
and these flags (`--fit refuse`); `--fit crop` keeps its first N·dt seconds but refuses a
recording whose motion ends after them (its label belongs to the part cut off); `--fit
resample` stretches each motion, onset to end plus `--lead` each side, onto N·dt (velocities
scaled with it). Only the kept samples must be finite and plausible.

Labels from dense rewards: with `--success-threshold X` the label is 1 when the demonstration's
largest reward (HDF5: dataset `rewards` or the mapped `success`; LeRobot: `next.reward`) is at
least X; the largest, not the last, because a recording often goes on after the goal was
reached. A file (or LeRobot dataset) whose labels all come from `dones` (`next.done`) and are
all 1 is refused: robomimic's done_mode 2 sets it at the end of every demo, success or not.
`--filter-key NAME` imports only the HDF5 demo groups robomimic's `mask/NAME` lists.

The kept window is resampled to the planner's period (cubic interpolation of each position,
linear of each force) from its start over N·dt; a shorter one is held at its last position (at
rest) and force, except under `--fit resample`. Recorded values are stored as both commands and responses: a recording is
what the tool did. `judgeopt.data.export` writes a dataset back as CSV in the format above.
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from judgeopt.data.dataset import Dataset
from judgeopt.formats.table_csv import TableError, read_table
from judgeopt.data.labels import FILE_COLUMNS, LABEL_COLUMNS
from judgeopt.data.lerobot import LEROBOT_LABEL_HINT, is_lerobot, lerobot_demos
from judgeopt.data.ros2 import bag_demos, is_bag
from judgeopt.data.recording import (LABELS, LIMITS, Checked, ImportError_, ImportSpec, RawDemo, check, parse_keys,
                                     refuse_done_labels, series_label, split_key)
from judgeopt.trajectory import CHANNELS

__all__ = ["LABELS", "LIMITS", "HDF5_SUFFIXES", "ImportError_", "ImportSpec", "RawDemo", "import_demos",
           "import_csv", "parse_hdf5_keys"]

HDF5_SUFFIXES = (".h5", ".hdf5")
#: the good demonstrations of one file: (demo id, the checked demonstration)
Good = list[tuple[str, Checked]]
#: what to pass instead when an HDF5 file's labels all come from `dones`
HDF5_LABEL_HINT = ("give each demo group a 'success' attribute, map a success flag with --hdf5-keys success=NAME, "
                   "or label from dense rewards with --success-threshold X")


# -- CSV --------------------------------------------------------------------------------------------
def _read(path: Path) -> tuple[list[str], list[list[str]]]:
    try:
        return read_table(path)
    except TableError as exc:
        raise ImportError_(str(exc)) from None


def _csv_demos(path: Path, spec: ImportSpec, table: tuple[list[str], list[tuple[str, list[str]]]] | None = None
               ) -> list[RawDemo]:
    """Parse a CSV file (or `table`: streams merged from several, `_merged`) into raw
    demonstrations (numbers and labels parsed, nothing else checked). A channel with empty cells
    was recorded at its own rate: its rows with a value are its samples."""
    if table is None:
        header, lines = _read(path)
        table = header, [(f"{path}, row {r}", row) for r, row in enumerate(lines, start=2)]  # as a spreadsheet shows
    header, rows = table
    missing = [c for c in spec.required if spec.column(c) not in header]
    if missing and any(c.strip().lower() in FILE_COLUMNS for c in header) and any(
            c.strip().lower() in LABEL_COLUMNS for c in header):
        raise ImportError_(f"{path}: a labels file, not a recording; pass it with --labels {path}")
    if missing:
        named = [f"{c}={spec.column(c)}" if c in spec.columns else c for c in missing]
        raise ImportError_(f"{path}: missing column(s) {named}; the header has {header}; map them with "
                           f"--columns {','.join(f'{c}=COLUMN' for c in missing)}")
    col = {name: header.index(spec.column(name)) for name in
           ("demo_id", "label", "t", *spec.names("position", "force", "velocity"), *spec.env_names)
           if spec.column(name) in header}
    numeric = ["t", *spec.names("position", "force"), *(c for c in spec.names("velocity") if c in col),
               *(c for c in spec.env_names if c in col and c not in spec.env_values)]
    groups: dict[str, list[tuple[str, list[str]]]] = {}
    for r, row in rows:
        if len(row) != len(header):
            raise ImportError_(f"{r}: {len(row)} fields, the header has {len(header)}")
        key = row[col["demo_id"]].strip() if "demo_id" in col else path.stem
        groups.setdefault(key, []).append((r, row))
    return [_csv_demo(path, spec, key, items, col, numeric) for key, items in groups.items()]


def _csv_demo(path: Path, spec: ImportSpec, key: str, items: list[tuple[str, list[str]]], col: dict[str, int],
              numeric: list[str]) -> RawDemo:
    values: dict[str, np.ndarray] = {}
    rows_of: dict[str, np.ndarray] = {}  # per field: the item indices holding its values
    for c in numeric:
        v, at = [], []
        for k, (r, row) in enumerate(items):
            cell = row[col[c]].strip()
            if not cell and c != "t":
                continue
            try:
                v.append(float(cell))
            except ValueError:
                raise ImportError_(f"{r}, column {spec.column(c)!r}: {row[col[c]]!r} is not a number"
                                   ) from None
            at.append(k)
        if not v:
            raise ImportError_(f"{path}: demonstration {key!r}: column {spec.column(c)!r} is empty")
        values[c], rows_of[c] = np.array(v), np.array(at)
    label = None
    if spec.labels is None:
        labels = set()
        for r, row in items:
            lab = row[col["label"]].strip().lower()
            if not lab:
                continue
            if lab not in LABELS:
                raise ImportError_(f"{r}, column {spec.column('label')!r}: {row[col['label']]!r} is not "
                                   "success/failure")
            labels.add(LABELS[lab])
        if len(labels) != 1:
            raise ImportError_(f"{path}: demonstration {key!r} has " + ("both labels; a demonstration has one outcome"
                               if labels else "no label; fill the label column or give --labels FILE"))
        label = labels.pop()
    t = values["t"]
    times = {c: t[rows_of[c]] for c in values if c != "t" and len(rows_of[c]) != len(items)}

    def where(c: str, i: int) -> str:
        rows = rows_of.get(c, rows_of["t"])
        return f"{items[int(rows[i])][0]}, column {spec.column(c)!r}"

    def shown(c: str, i: int) -> str:
        rows = rows_of.get(c, rows_of["t"])
        return repr(items[int(rows[i])][1][col[c]])

    channels = ("t", *spec.names("position", "force", "velocity"))
    return RawDemo(str(path), f"demonstration {key!r}", f"{path.name}:{key}",
                   {c: values[c] for c in channels if c in values},
                   {c: values[c] for c in spec.env_names if c in values}, label, where, shown, times=times)


def _stream(p: Path, streams: Sequence[str]) -> str | None:
    """Which of `streams` a CSV file NAME_<stream>.csv holds, or None."""
    return next((s for s in streams if p.suffix.lower() == ".csv" and p.stem.endswith(f"_{s}")), None)


def _merged(paths: Sequence[Path], spec: ImportSpec) -> tuple[list[tuple[Path, tuple | None]], list[str]]:
    """With --streams A,B: the files NAME_A.csv, NAME_B.csv, ... of one recording as one table
    (their columns side by side, each file's rows blank in the others' columns), under the path
    NAME; every other path as it is. A recording missing one of its streams is reported."""
    out: list[tuple[Path, tuple | None]] = []
    groups: dict[Path, dict[str, Path]] = {}
    for p in paths:
        stream = _stream(p, spec.streams)
        if stream is None:
            out.append((p, None))
        else:
            groups.setdefault(p.with_name(p.stem[:-len(stream) - 1]), {})[stream] = p
    errors = []
    for name, files in groups.items():
        missing = [s for s in spec.streams if s not in files]
        if missing:
            errors.append(f"{name}: no {', '.join(f'{name.name}_{s}.csv' for s in missing)} beside "
                          f"{', '.join(f.name for f in files.values())} (--streams {','.join(spec.streams)})")
            continue
        try:
            tables = [(f, *_read(f)) for f in files.values()]
        except ImportError_ as exc:
            errors.append(str(exc))
            continue
        short = next(((f, r, len(row), len(head)) for f, head, lines in tables
                      for r, row in enumerate(lines, start=2) if len(row) != len(head)), None)
        if short:
            errors.append(f"{short[0]}, row {short[1]}: {short[2]} fields, the header has {short[3]}")
            continue
        header = list(dict.fromkeys(h for _, head, _ in tables for h in head))
        rows = [(f"{f}, row {r}", [row[head.index(h)] if h in head else "" for h in header])
                for f, head, lines in tables for r, row in enumerate(lines, start=2)]
        out.append((name, (header, rows)))
    return out, errors


# -- HDF5 (robomimic-style) -------------------------------------------------------------------------
def parse_hdf5_keys(text: str | None, env_names: Sequence[str] = (), channels: Sequence[str] = CHANNELS) -> dict[str, str]:
    """`y=obs/eef_pos:1,f=obs/ft:2` -> {"y": "obs/eef_pos:1", "f": "obs/ft:2"}, checked. Names
    that may be mapped: t, the task's channels, success, dt and the environment names."""
    return parse_keys(text, env_names, channels, flag="--hdf5-keys")


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

        paths = [split_key(self.keys[name])[0]] if name in self.keys else [name, f"obs/{name}"]
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
        col = split_key(self.keys[name])[1] if name in self.keys else None
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


def _label(d: _H5Demo, threshold: float | None) -> tuple[int, str]:
    """The success flag, from the sources the module docstring lists, in that order (a mapped
    `success` is looked up only where it points: attribute, then dataset), and the done flag's
    name when it came from `dones` (see `refuse_done_labels`). With a threshold: the rewards."""
    key = d.keys.get("success", "success")
    mapped = "success" in d.keys
    found: tuple[Any, str] | None = None
    if key in d.g.attrs and (mapped or threshold is None):
        found = d.g.attrs[key], f"attribute {key!r}"
    names = ["success"] if mapped else ["rewards"] if threshold is not None else ["success", "rewards", "dones"]
    source = ""
    for name in names:
        if found is not None:
            break
        ds = d.dataset(name)
        if ds is not None:
            found, source = (d.read("success", *ds), f"dataset {ds[1]!r}"), name
    if found is None:
        tried = (f"attribute or dataset {key!r}" if mapped
                 else "dataset 'rewards' (also under obs/) for --success-threshold" if threshold is not None
                 else "attribute 'success', dataset 'success', 'rewards' or 'dones' (also under obs/)")
        raise d.fail("success", f"no success flag: found no {tried}; map one with --hdf5-keys success=NAME")
    value, where = found
    if isinstance(value, (bytes, np.bytes_)):
        value = value.decode(errors="replace")
    if isinstance(value, str):
        if value.strip().lower() in LABELS:
            return LABELS[value.strip().lower()], ""
        raise d.fail("success", f"{where} is {value!r}, not success/failure")
    label = series_label(_number(d, "success", value, where), f"{d.ctx}, field 'success': {where}", threshold)
    return label, "dones" if source == "dones" and not mapped else ""


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
    for name in (n for n in spec.env_names if n not in spec.env_values):
        found = d.value(name)
        if found is None:
            raise d.fail(name, f"no environment value {d.keys.get(name, name)!r}: not an attribute of the demo "
                         "group, a dataset, a key of env_args or an attribute of 'data'; map one with "
                         f"--hdf5-keys {name}=NAME")
        env[name], desc[name] = _number(d, name, *found), found[1]
    label, done = (None, "") if spec.labels is not None else _label(d, spec.success_threshold)

    def where(c: str, i: int) -> str:
        at = f", sample {i}" if len(series.get(c, env.get(c, ()))) > 1 else ""
        return f"{d.ctx}, field {c!r} ({desc[c]}){at}"

    group = d.g.name.lstrip("/")
    return RawDemo(str(d.path), f"demo group {group!r}", f"{d.path.name}:{group.split('/')[-1]}",
                   series, env, label, where, label_from_done=done)


def _hdf5_file(path: Path, spec: ImportSpec) -> tuple[Good, list[str]]:
    """Every good demo group of one file, and one message per bad one (or one for the file)."""
    import h5py

    try:
        h = h5py.File(path, "r")
    except (OSError, ValueError) as exc:
        return [], [f"{path}: not a readable HDF5 file ({exc})"]
    errors: list[str] = []
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
        if spec.filter_key is not None:
            try:
                names, errors = _filtered(h, path, spec.filter_key, names)
            except ImportError_ as exc:
                return [], [str(exc)]
        raws = []
        for name in names:
            d = _H5Demo(path, data, data[name], env_args, spec.hdf5_keys)
            try:
                raws.append(_hdf5_raw(d, spec))
            except ImportError_ as exc:
                errors.append(str(exc))
            except (OSError, KeyError, RuntimeError) as exc:  # a damaged file: h5py's own read errors
                errors.append(f"{d.ctx}: cannot read ({exc})")
    good, bad = _checked(raws, spec, str(path), HDF5_LABEL_HINT)
    return good, errors + bad


def _filtered(h: Any, path: Path, key: str, names: list[str]) -> tuple[list[str], list[str]]:
    """The demo groups robomimic's filter key `mask/<key>` lists (b"demo_0", ...), in file
    order, and one message per listed name that is not in `data`."""
    import h5py

    masks = h.get("mask")
    keys = sorted(masks.keys()) if isinstance(masks, h5py.Group) else []
    if key not in keys:
        raise ImportError_(f"{path}: no filter key {key!r} (mask/{key}); the file has "
                           + (f"{keys}" if keys else "no 'mask' group"))
    try:
        listed = [v.decode() if isinstance(v, (bytes, np.bytes_)) else str(v) for v in np.ravel(masks[key][()])]
    except (OSError, TypeError, UnicodeDecodeError) as exc:
        raise ImportError_(f"{path}, mask/{key}: not a list of demo group names ({exc})") from None
    listed = [n.removeprefix("data/") for n in listed]
    unknown = [n for n in listed if n not in names]
    errors = [f"{path}, mask/{key}: lists demo group {n!r}, which is not in 'data'" for n in unknown]
    return [n for n in names if n in set(listed)], errors


# -- every format -----------------------------------------------------------------------------------
def _checked(raws: Sequence[RawDemo], spec: ImportSpec, origin: str, hint: str) -> tuple[Good, list[str]]:
    """The shared checks on every demonstration of one file or dataset; the good ones, and one
    message per bad one (or one for all when their labels are only done flags)."""
    good, ok, errors = [], [], []
    for raw in raws:
        try:
            good.append((raw.demo_id, check(raw, spec)))
        except ImportError_ as exc:
            errors.append(str(exc))
            continue
        ok.append(raw)
    refused = refuse_done_labels(origin, ok, hint)
    return ([], errors + [refused]) if refused else (good, errors)


def _file(path: Path, spec: ImportSpec, table: tuple | None = None) -> tuple[Good, list[str]]:
    if is_bag(path):
        try:
            raws, errors = bag_demos(path, spec)
        except ImportError_ as exc:
            return [], [str(exc)]
        good, bad = _checked(raws, spec, str(path), "")
        return good, errors + bad
    if is_lerobot(path):
        try:
            raws, errors = lerobot_demos(path, spec)
        except ImportError_ as exc:
            return [], [str(exc)]
        good, bad = _checked(raws, spec, str(path), LEROBOT_LABEL_HINT)
        return good, errors + bad
    if path.suffix.lower() in HDF5_SUFFIXES:
        return _hdf5_file(path, spec)
    try:  # a CSV file is imported whole or not at all
        return [(raw.demo_id, check(raw, spec)) for raw in _csv_demos(path, spec, table)], []
    except ImportError_ as exc:
        return [], [str(exc)]


def import_demos(paths: Sequence[str | Path], spec: ImportSpec) -> tuple[Dataset | None, list[str]]:
    """Every good demonstration from `paths` (CSV or HDF5 by suffix), and one message per bad
    CSV file or HDF5 demo group, and per labels-file row naming no recording (never raises for
    bad input). `meta["files_imported"]` counts the files that gave at least one demonstration;
    `meta["import"]` holds what was measured on each (noise, smoothing, onset, bias; `report`)."""
    good: Good = []
    inputs, errors = _merged(list(map(Path, paths)), spec)
    used = 0
    for p, table in inputs:
        ok, errs = _file(p, spec, table)
        errors += errs
        used += bool(ok)
        good += ok
    if spec.labels is not None:  # a row for a recording not given: a typo, or a file missing from the folder
        given = {c.label_key for _, c in good} | {n for p in map(Path, paths) for n in (
            p.name, p.stem, *(p.stem[:-len(s) - 1] for s in [_stream(p, spec.streams)] if s))}
        absent = [k for k in spec.labels.labels if k not in given and Path(k).name not in given
                  and Path(k).stem not in given]
        if absent:
            errors.append(f"--labels {spec.labels.path}: names {len(absent)} recording(s) not given ("
                          f"{', '.join(absent[:3])}{', ...' if len(absent) > 3 else ''}); a typo or a missing file? "
                          "(fine when importing a subset)")
    if not good:
        return None, errors
    x = np.stack([c.x for _, c in good])
    info = {k: [c.info.get(k, np.nan) for _, c in good] for k in sorted({k for _, c in good for k in c.info})}
    ds = Dataset(commands=x, responses=x.copy(), labels=np.array([c.label for _, c in good], dtype=np.int8),
                 env=np.stack([c.env for _, c in good]), dt=spec.dt, env_names=tuple(spec.env_names),
                 task=spec.task, channels=tuple(c.name for c in spec.channels),
                 units={c.name: c.unit for c in spec.channels},
                 meta={"source": "import-demos", "demo_ids": [i for i, _ in good], "errors": errors,
                       "files_imported": used, "import": info})
    return ds, errors


def report(ds: Dataset) -> list[str]:
    """What the import measured, a line each: position noise and the velocity smoothing it chose,
    motion durations, the force bias removed, and how windows were fitted to the horizon."""
    info = {k: np.asarray(v, dtype=float) for k, v in ds.meta.get("import", {}).items()}
    out = []
    if "noise" in info:
        out.append(f"position noise {np.nanmedian(info['noise']) * 1e3:.2g} mm (median); velocity derived where not "
                   f"recorded: Savitzky-Golay over {np.nanmedian(info['window']):.3g} s, leaving "
                   f"{np.nanmedian(info['velocity_noise']):.2g} m/s of noise")
    if "onset" in info and np.isfinite(info["onset"]).any():
        d = info["end"] - info["onset"]
        out.append(f"motions last {np.nanmin(d):.2f}-{np.nanmax(d):.2f} s (median {np.nanmedian(d):.2f} s)")
    for k in (k for k in info if k.startswith("bias_")):
        out.append(f"tared {k[5:]!r}: bias {np.nanmedian(info[k]):+.3g} N median ({np.nanmin(info[k]):+.3g} to "
                   f"{np.nanmax(info[k]):+.3g})")
    if "time_scale" in info and np.any(info["time_scale"] != 1.0):
        s = info["time_scale"]
        out.append(f"windows resampled onto N·dt: time scale {np.min(s):.2f}-{np.max(s):.2f} (above 1: a slow motion "
                   "played faster)")
    return out


#: the name this function had when only CSV was read; it reads HDF5 by suffix too
import_csv = import_demos
