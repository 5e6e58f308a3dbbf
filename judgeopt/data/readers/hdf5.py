"""Robomimic-style HDF5 recordings: a `data` group holding one group per demonstration,
`data/demo_0`, `data/demo_1`, ..., taken in the order of their trailing number.

In each demo group, every name below is looked up first as a dataset at that path in the group,
then under `obs/` (robomimic keeps low-dimensional signals in `obs/<key>`):

    t        optional time stamps in s, (T,) strictly increasing; without it the samples are
             taken as evenly spaced by the `dt` attribute (s; on the demo group, else on
             `data`), else by `control_freq` (Hz; demo or `data` attribute, or a key of
             `env_args["env_kwargs"]`); no time information at all is an error
    y        position in m, (T,) (each position channel of the task)
    ydot     optional velocity in m/s, (T,) (derived from y when missing)
    f        pressing force in N, (T,) (each force channel)
    success  the label, the first of: attribute `success` of the demo group (true/false, 1/0 or
             "success"/"failure"); dataset `success` (its last value); dataset `rewards` (last
             value 1 or 0); dataset `dones` (last value 1 or 0; refused when all are 1:
             robomimic's done_mode 2 sets it at the end of every demo, success or not); none is
             an error. With `--success-threshold X`: 1 when the largest reward is at least X
    <env>    environment values, the first of: attribute of the demo group; dataset (scalar or
             constant per-step array); key of `env_args["env_kwargs"]`, then of `env_args`
             (`env_args` is the JSON string attribute robomimic puts on `data`); attribute of `data`

Options (`Hdf5Options`): other key names are mapped with `--hdf5-keys` (`parse_hdf5_keys`):
`NAME=PATH` or `NAME=PATH:COLUMN` for one column of a (T, k) array, e.g.
`y=obs/robot0_eef_pos:1,f=obs/ft:2,success=is_success,dt=period` (an environment value kept
under another name: NAME=friction). A mapped name is looked up only where it points (dataset at
PATH, or an attribute/`env_args` key named PATH). A (T, k) array with k > 1 needs a column.
`--filter-key NAME` imports only the demo groups robomimic's `mask/NAME` lists. A bad demo group
is reported (file, demo group, field, sample) and the others in the file are imported.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from judgeopt.data.readers.base import SUCCESS_THRESHOLD, Flag, Reader, Source
from judgeopt.data.recording import (LABELS, ImportError_, ImportSpec, RawDemo, env_fix, parse_keys, series_label,
                                     split_key)
from judgeopt.trajectory import CHANNELS

SUFFIXES = (".h5", ".hdf5")
#: what every HDF5 file starts with (a file of another suffix is recognised by it)
MAGIC = b"\x89HDF\r\n\x1a\n"
#: what to pass instead when a file's labels all come from `dones`
LABEL_HINT = ("give each demo group a 'success' attribute, map a success flag with --hdf5-keys success=NAME, "
              "or label from dense rewards with --success-threshold X")


@dataclass(frozen=True)
class Hdf5Options:
    #: name -> "PATH" or "PATH:COLUMN" (`--hdf5-keys`); unmapped names are looked up where the docstring says
    keys: Mapping[str, str] = field(default_factory=dict)
    #: import only the demo groups listed in mask/<filter_key> (robomimic's filter keys)
    filter_key: str | None = None
    #: dense rewards: label 1 when the demo's largest reward is >= this
    success_threshold: float | None = None


def parse_hdf5_keys(text: str | None, env_names: Sequence[str] = (), channels: Sequence[str] = CHANNELS
                    ) -> dict[str, str]:
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


def _raw(d: _H5Demo, spec: ImportSpec, options: Hdf5Options) -> RawDemo:
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
                         "group, a dataset, a key of env_args or an attribute of 'data'; "
                         + env_fix(spec, [name], f"map one with --hdf5-keys {name}=NAME"))
        env[name], desc[name] = _number(d, name, *found), found[1]
    label, done = (None, "") if spec.labels is not None else _label(d, options.success_threshold)

    def where(c: str, i: int) -> str:
        at = f", sample {i}" if len(series.get(c, env.get(c, ()))) > 1 else ""
        return f"{d.ctx}, field {c!r} ({desc[c]}){at}"

    group = d.g.name.lstrip("/")
    return RawDemo(str(d.path), f"demo group {group!r}", f"{d.path.name}:{group.split('/')[-1]}",
                   series, env, label, where, label_from_done=done)


def read(source: Source, spec: ImportSpec, options: Hdf5Options) -> tuple[list[RawDemo], list[str]]:
    """Every demo group of one file as a RawDemo (values not yet checked), and one message per
    demo group that could not be read; raises ImportError_ for a file that cannot be read at all."""
    import h5py

    path = source.path
    try:
        h = h5py.File(path, "r")
    except (OSError, ValueError) as exc:
        raise ImportError_(f"{path}: not a readable HDF5 file ({exc})") from None
    errors: list[str] = []
    with h:
        data = h.get("data")
        if not isinstance(data, h5py.Group):
            raise ImportError_(f"{path}: no 'data' group (a robomimic-style file holds data/demo_0, data/demo_1, "
                               f"...); top-level names: {sorted(h.keys())}")
        env_args: dict[str, Any] = {}
        if "env_args" in data.attrs:
            raw = data.attrs["env_args"]
            try:
                env_args = json.loads(raw.decode() if isinstance(raw, bytes) else str(raw))
            except (json.JSONDecodeError, UnicodeDecodeError) as exc:
                raise ImportError_(f"{path}: attribute 'env_args' of 'data' is not valid JSON ({exc})") from None
            if not isinstance(env_args, dict):
                raise ImportError_(f"{path}: attribute 'env_args' of 'data' is not a JSON object")
        names = sorted((n for n, g in data.items() if isinstance(g, h5py.Group)), key=_demo_order)
        if not names:
            raise ImportError_(f"{path}: the 'data' group holds no demo groups (data/demo_0, data/demo_1, ...)")
        if options.filter_key is not None:
            names, errors = _filtered(h, path, options.filter_key, names)
        raws = []
        for name in names:
            d = _H5Demo(path, data, data[name], env_args, options.keys)
            try:
                raws.append(_raw(d, spec, options))
            except ImportError_ as exc:
                errors.append(str(exc))
            except (OSError, KeyError, RuntimeError) as exc:  # a damaged file: h5py's own read errors
                errors.append(f"{d.ctx}: cannot read ({exc})")
    return raws, errors


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


READER = Reader(
    "hdf5", "HDF5 (robomimic)", ".h5/.hdf5 file", read, Hdf5Options, suffixes=SUFFIXES, magic=MAGIC,
    done_hint=LABEL_HINT, flags=(
        Flag("--hdf5-keys", "keys", metavar="NAME=PATH[:COL],...", kind="map", does="maps HDF5 datasets",
             parse=lambda text, spec: parse_hdf5_keys(text, spec.env_names, [c.name for c in spec.channels]),
             help="where an HDF5 file keeps t, a channel (the scoop's y, ydot, f), success, dt or an environment "
             "value, e.g. 'y=obs/robot0_eef_pos:1,f=obs/ft:2,t=timestamps' (:COL picks a column of a (T, k) array; "
             "default: the names themselves, then under obs/)"),
        Flag("--filter-key", "filter_key", metavar="NAME", does="selects demo groups of HDF5 files (mask/NAME)",
             help="HDF5: import only the demo groups robomimic's filter key mask/NAME lists, e.g. train or valid "
             "(default: every demo group)"),
        SUCCESS_THRESHOLD,
    ))
