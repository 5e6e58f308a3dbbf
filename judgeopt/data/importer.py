"""Recorded demonstrations (CSV, robomimic-style HDF5, LeRobot v3, ROS 2 MCAP bags) into the dataset format,
checked sample by sample.

Each format is a reader (`judgeopt.data.readers`: `csv`, `hdf5`, `lerobot`, `mcap`, each module
documenting its format and options) that turns one input into `RawDemo`s (per-sample arrays,
environment values, a label and a way to say where each value came from); which reader reads a
path is decided in one place (`judgeopt.data.readers.registry.reader_for`: a folder with
`meta/info.json` is a LeRobot dataset, one with `metadata.yaml` or a `.mcap` file a ROS 2 bag, a
`.h5`/`.hdf5` file (or any file starting as HDF5 does) robomimic-style HDF5, anything else CSV).
One checker (`judgeopt.data.recording.check`) validates them, crops them to their window and
resamples them to the planner's period, so every format is held to the same rules and its
messages name the file and the exact place (CSV: row and column; HDF5: demo group and field;
LeRobot: data file, episode, row and field; bags: topic, message and field).

What every format shares is `ImportSpec`; a reader's own options (`--columns`, `--hdf5-keys`,
`--keys`, `--topics`, ...) are its options dataclass, passed by reader name
(`import_demos(paths, spec, {"hdf5": Hdf5Options(filter_key="train")})`).

Channels are the task's (`ImportSpec.task`, default the scoop: y, ydot, f): every position and
force channel is required, the velocities are optional (derived from their positions).
`--scale f=-1,y=mm` (a factor or a signed unit) multiplies a channel as read and then `--offset
y=X` is added (the offset is in the task's units); `--labels FILE` (a CSV of recording and
outcome, matched by a recording's id, file name or stem) and `--env NAME=VALUE` stand in for
labels and environment values a recording lacks. A force that is only negative while pressing is
refused, naming `--scale f=-1`; a position beyond 5 m names `--scale y=mm`.

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

A reader's labels that all come from a done flag and are all 1 (robomimic's `dones`, LeRobot's
`next.done`) are refused: done_mode 2 sets it at the end of every demonstration, success or not.

The kept window is resampled to the planner's period (cubic interpolation of each position,
linear of each force) from its start over N·dt; a shorter one is held at its last position (at
rest) and force, except under `--fit resample`. Recorded values are stored as both commands and
responses: a recording is what the tool did. `judgeopt.data.export` writes a dataset back as CSV.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from judgeopt.data.dataset import Dataset
from judgeopt.data.readers.base import Reader, Source
from judgeopt.data.readers.registry import READERS, reader_for
from judgeopt.data.recording import (LABELS, LIMITS, Checked, ImportError_, ImportSpec, RawDemo, check,
                                     refuse_done_labels)

__all__ = ["LABELS", "LIMITS", "ImportError_", "ImportSpec", "RawDemo", "import_demos", "import_csv", "report"]

#: the good demonstrations of one input: (demo id, the checked demonstration)
Good = list[tuple[str, Checked]]


def _options(given: Mapping[str, Any] | None) -> dict[str, Any]:
    """Every reader's options: those given by reader name, the defaults for the rest."""
    given = dict(given or {})
    unknown = sorted(set(given) - set(READERS))
    if unknown:
        raise ImportError_(f"options for {unknown[0]!r}: no such reader; the readers are {', '.join(READERS)}")
    for name, opts in given.items():
        if not isinstance(opts, READERS[name].options):
            raise ImportError_(f"options for {name!r}: {type(opts).__name__}, not {READERS[name].options.__name__}")
    return {name: given.get(name) or r.options() for name, r in READERS.items()}


def _sources(paths: Sequence[Path], options: Mapping[str, Any]) -> tuple[list[tuple[Reader, Source]], list[str]]:
    """Each path to its reader, and each reader's paths into the inputs it reads (CSV streams
    merged into one), in the order of their first path."""
    by_reader: dict[str, list[Path]] = {}
    readers, errors = {}, []
    for p in paths:
        r = reader_for(p)
        if r is None:
            errors.append(f"{p}: a folder no reader reads whole (a LeRobot dataset, a ROS 2 bag); give the "
                          "recordings in it (`judgeopt import-demos` lists them)")
            continue
        readers[r.name] = r
        by_reader.setdefault(r.name, []).append(p)
    out = []
    for name, group in by_reader.items():
        out += [(readers[name], s) for s in readers[name].sources(group, options[name])]
    order = {p: k for k, p in enumerate(paths)}
    out.sort(key=lambda rs: min(order.get(p, len(order)) for p in (rs[1].path, *rs[1].parts)))
    return out, errors


def _checked(raws: Sequence[RawDemo], spec: ImportSpec, origin: str, hint: str) -> tuple[Good, list[str]]:
    """The shared checks on every demonstration of one input; the good ones, and one message per
    bad one (or one for all when their labels are only done flags)."""
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


def _read(reader: Reader, source: Source, spec: ImportSpec, options: Any) -> tuple[Good, list[str]]:
    """One input read and checked; a reader's `whole` input (a CSV table) is kept whole or not at all."""
    try:
        raws, errors = reader.read(source, spec, options)
        if reader.whole:
            return [(raw.demo_id, check(raw, spec)) for raw in raws], errors
    except ImportError_ as exc:
        return [], [str(exc)]
    good, bad = _checked(raws, spec, str(source.path), reader.done_hint)
    return good, errors + bad


def import_demos(paths: Sequence[str | Path], spec: ImportSpec, options: Mapping[str, Any] | None = None
                 ) -> tuple[Dataset | None, list[str]]:
    """Every good demonstration from `paths` (each read by its reader, with `options[reader name]`
    or that reader's defaults), and one message per bad input or demonstration (a CSV file is
    skipped whole), and per labels-file row naming no recording (never raises for bad input;
    raises ImportError_ for options that name no reader). `meta["files_imported"]` counts the
    inputs that gave at least one demonstration; `meta["import"]` holds what was measured on each
    (noise, smoothing, onset, bias; `report`)."""
    paths = [Path(p) for p in paths]
    options = _options(options)
    good: Good = []
    sources, errors = _sources(paths, options)
    used = 0
    for reader, source in sources:
        ok, errs = _read(reader, source, spec, options[reader.name])
        errors += errs
        used += bool(ok)
        good += ok
    if spec.labels is not None:  # a row for a recording not given: a typo, or a file missing from the folder
        given = {c.label_key for _, c in good} | {n for p in paths for n in (p.name, p.stem)} | {
            n for _, s in sources for n in s.names()}
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
