"""One recorded demonstration, whatever file it came from: checked, cropped and resampled.

Every reader (`judgeopt.data.readers`: CSV, robomimic-style HDF5, LeRobot, ROS 2 bags) turns its
input into `RawDemo`s and hands them to `check`, so every format is held to the same rules, windows
and messages (see the importer's module docstring).
"""

from __future__ import annotations

import re
from pathlib import Path
from dataclasses import dataclass, field, replace
from typing import Any, Callable, Iterator, Mapping, Sequence

import numpy as np

from judgeopt.data.signals import Smoothed, motion_span, motion_step, smooth
from judgeopt.errors import BadInput
from judgeopt.tasks import DEFAULT_TASK, get_task
from judgeopt.trajectory import CHANNELS, DEFAULT_DT, DEFAULT_HORIZON, Channel

LABELS = {"success": 1, "1": 1, "true": 1, "failure": 0, "0": 0, "false": 0}
#: plausible magnitudes by channel kind: a value beyond is a unit mistake (mm, mm/s, N·10) more likely than a motion
LIMITS = {"position": 5.0, "velocity": 10.0, "force": 1000.0}
ALIGN = ("start", "contact", "onset")
FIT = ("refuse", "crop", "resample")


class ImportError_(BadInput, ValueError):
    """A demonstration file that cannot be imported; the message names the file and the place in it."""


@dataclass(frozen=True)
class ImportSpec:
    """What every reader shares: the task and environment names, the planner's grid, which part of
    a recording is kept, conversions, and labels and environment values given by hand. A format's
    own options (a key map, a filter) are its reader's (`judgeopt.data.readers`)."""

    env_names: tuple[str, ...]
    dt: float = DEFAULT_DT
    horizon: int = DEFAULT_HORIZON
    #: whose channels the recordings hold (positions and forces required, velocities optional)
    task: str = DEFAULT_TASK
    #: crop window in s from the recording's first time stamp (None: to its end)
    start: float = 0.0
    end: float | None = None
    #: "start": keep from `start`; "contact": from `lead` s before the force first exceeds `contact_force` N;
    #: "onset": from `lead` s before the position first leaves rest (each recording its own)
    align: str = "start"
    contact_force: float = 1.0
    lead: float = 0.1
    #: a window longer than N·dt: "refuse" it; "crop" its first N·dt s (refused when the motion ends later:
    #: the label would belong to a part cut off); "resample" onset-to-end (plus `lead` each side) onto N·dt
    fit: str = "refuse"
    #: name -> factor applied as read (`--scale f=-1,y=mm`), then name -> offset added (`--offset y=-1.2`)
    scale: Mapping[str, float] = field(default_factory=dict)
    offset: Mapping[str, float] = field(default_factory=dict)
    #: a labels file (`judgeopt.data.labels.LabelFile`): labels for recordings that carry none
    labels: Any = None
    #: environment values for recordings that do not carry them (`--env NAME=0.246`)
    env_values: Mapping[str, float] = field(default_factory=dict)
    #: subtract each force channel's mean over the rest before the motion (a force sensor's bias)
    tare: bool = False

    def __post_init__(self) -> None:
        if self.align not in ALIGN:
            raise ImportError_(f"--align {self.align!r}: choose one of {', '.join(ALIGN)}")
        if self.fit not in FIT:
            raise ImportError_(f"--fit {self.fit!r}: choose one of {', '.join(FIT)}")
        if not self.start >= 0:
            raise ImportError_(f"--start {self.start:g} s: must be 0 or later")
        if self.end is not None and not self.end > self.start:
            raise ImportError_(f"--end {self.end:g} s must be after --start {self.start:g} s")
        if not (self.contact_force > 0 and self.lead >= 0):
            raise ImportError_(f"--contact-force {self.contact_force:g} N must be positive and --lead "
                               f"{self.lead:g} s not negative")
        unknown = sorted(set(self.env_values) - set(self.env_names))
        if unknown:
            raise ImportError_(f"--env {unknown[0]}: not one of the environment names {list(self.env_names)}; "
                               "choose them with --env-names A,B")

    @property
    def channels(self) -> tuple[Channel, ...]:
        return get_task(self.task).channels

    def names(self, *kinds: str) -> tuple[str, ...]:
        return tuple(c.name for c in self.channels if c.kind in kinds)

    @property
    def limits(self) -> dict[str, float]:
        return {c.name: LIMITS[c.kind] for c in self.channels}


@dataclass
class RawDemo:
    """One demonstration as read, before any check: what every reader hands to `check`."""

    origin: str  # the file, first in every message
    name: str  # "demonstration 'demo0'" (CSV), "demo group 'data/demo_0'" (HDF5), "episode 3" (LeRobot)
    demo_id: str  # kept in the dataset's meta
    series: dict[str, np.ndarray]  # t, y, f and optional ydot, one value per sample
    env: dict[str, np.ndarray]  # per environment name: per-sample values, or one value
    label: int | None  # None: from the labels file (`ImportSpec.labels`)
    where: Callable[[str, int], str]  # "<file>, row 5, column 'y'": where sample i of a field is
    shown: Callable[[str, int], str] = lambda c, i: ""  # sample i of a field as the file spells it
    #: the label is the last value of a done flag (not a success flag): see `refuse_done_labels`
    label_from_done: str = ""
    #: a channel recorded at its own rate: its time stamps (s), one per value; else series["t"]
    times: dict[str, np.ndarray] = field(default_factory=dict)

    def time(self, c: str) -> np.ndarray:
        return self.times.get(c, self.series["t"])

    def label_keys(self) -> tuple[str, ...]:
        """Names a labels file may give this demonstration by: its id, its file's name and stem."""
        key = self.demo_id.rpartition(":")[2]
        return (self.demo_id, Path(self.origin).name, Path(self.origin).stem, key)


# -- key maps (--hdf5-keys, --keys) -----------------------------------------------------------------
_KEY = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*([^:,]+?)\s*(?::\s*(-?\d{1,9})\s*)?$")


def mapped_items(text: str | None, pattern: re.Pattern[str], flag: str, form: str,
                 allowed: Sequence[str]) -> Iterator[tuple[str, str, str | None, str]]:
    """Each item of a comma-separated NAME=VALUE[:PART] map (`--hdf5-keys`, `--keys`, `--topics`)
    as (name, value, part, the item's text): matched by `pattern` (three groups), its name one of
    `allowed` and mapped once; a one-line error naming `flag` and the `form` expected otherwise."""
    seen: set[str] = set()
    for item in filter(None, (p.strip() for p in (text or "").split(","))):
        m = pattern.match(item)
        if not m:
            raise ImportError_(f"{flag}: {item!r} is not {form}")
        name, value, part = m.groups()
        if name not in allowed:
            raise ImportError_(f"{flag}: unknown name {name!r}; map one of {list(allowed)}")
        if name in seen:
            raise ImportError_(f"{flag}: {name!r} is mapped twice")
        seen.add(name)
        yield name, value, part, item


def parse_keys(text: str | None, env_names: Sequence[str] = (), channels: Sequence[str] = CHANNELS,
               flag: str = "--hdf5-keys", scalars: Sequence[str] = ("success", "dt"),
               columns_everywhere: bool = False) -> dict[str, str]:
    """`y=obs/eef_pos:1,f=obs/ft:2` -> {"y": "obs/eef_pos:1", "f": "obs/ft:2"}, checked. Names
    that may be mapped: t, the task's channels, `scalars` and the environment names; a column
    selector only on per-step ones (on every name where every value is a column: LeRobot)."""
    out: dict[str, str] = {}
    per_step = ("t", *channels)
    allowed = (*per_step, *scalars, *env_names)
    for name, path, column, item in mapped_items(text, _KEY, flag, "NAME=PATH or NAME=PATH:COLUMN", allowed):
        path = re.sub(r"^[\s/]+|[\s/]+$", "", path)  # "/obs/ft/" and "obs/ft" are one path
        if not path:
            raise ImportError_(f"{flag}: {item!r} names no PATH")
        if column is not None and name not in per_step and not columns_everywhere:
            raise ImportError_(f"{flag}: a column selector is only for per-step arrays ({', '.join(per_step)}), "
                               f"not {name!r}")
        out[name] = path + (f":{int(column)}" if column is not None else "")
    return out


def env_fix(spec: ImportSpec, missing: Sequence[str], mapping: str) -> str:
    """The fixes for environment values a recording lacks, likeliest first: leave them out
    (`--env-names` with the rest, when some are left), give them by hand (`--env`), or say where
    the recording keeps them (`mapping`, the reader's own flag). No "; " in it: the command groups
    skipped recordings by what follows the last one."""
    them = "it" if len(missing) == 1 else "them"
    kept = [n for n in spec.env_names if n not in missing]
    fixes = [f"leave {them} out with --env-names {','.join(kept)}"] if kept else []
    fixes.append(f"give {them} with --env {','.join(f'{n}=VALUE' for n in missing)}")
    return f"{', '.join(fixes)} or {mapping}"


def split_key(ref: str) -> tuple[str, int | None]:
    """"obs/ft:2" -> ("obs/ft", 2)."""
    path, _, col = ref.rpartition(":") if re.search(r":-?\d+$", ref) else (ref, "", "")
    return path, (int(col) if col else None)


# -- labels -----------------------------------------------------------------------------------------
def series_label(values: np.ndarray, where: str, threshold: float | None) -> int:
    """A success/reward series as a label: with a threshold, 1 when its largest value reaches it
    (a recording often goes on after the goal was reached); else its last value, 1 or 0."""
    if threshold is not None:
        if not np.isfinite(values).any():
            raise ImportError_(f"{where}: no finite reward to compare with --success-threshold {threshold:g}")
        return int(np.nanmax(values) >= threshold)
    last = values[-1]
    if last in (0.0, 1.0):
        return int(last)
    raise ImportError_(f"{where}: last value {last:g} is neither 1 (success) nor 0 (failure); for dense rewards "
                       "pass --success-threshold X")


def refuse_done_labels(origin: str, raws: Sequence[RawDemo], hint: str) -> str | None:
    """Why the labels of `raws` mean nothing when each is the last value of a done flag and all
    are 1 (robomimic's done_mode 2 and LeRobot's next.done mark the end of every demonstration,
    success or not); None when they can be used."""
    if not raws or not all(r.label_from_done for r in raws) or not all(r.label == 1 for r in raws):
        return None
    field_ = raws[0].label_from_done
    return (f"{origin}: every label comes from {field_!r} and all {len(raws)} are 1: {field_!r} marks the end of "
            f"every demonstration (robomimic's done_mode 2, LeRobot's next.done), success or not; {hint}")


# -- the shared checks ------------------------------------------------------------------------------
@dataclass
class Checked:
    """One demonstration ready for the dataset, and what the import measured on it (reported)."""

    x: np.ndarray  # (N + 1, channels) at the planner's period
    label: int
    env: np.ndarray
    #: position noise (m), smoothing window (s), velocity noise (m/s), motion onset/end and kept window (s), bias (N)
    info: dict[str, float] = field(default_factory=dict)
    label_key: str | None = None  # the labels-file entry used


def check(raw: RawDemo, spec: ImportSpec) -> Checked:
    """Validate one demonstration (finite, plausible units and sign, increasing time, constant
    environment), convert it (--scale/--offset, --tare), find its window (--start/--end,
    --align, --fit) and resample it to the planner's period."""
    raw = _converted(raw, spec)
    _check_times(raw)
    label, label_key = _label(raw, spec)
    env = _environment(raw, spec)
    t0 = float(np.min(raw.series["t"]))
    lo, hi = _crop(raw, spec, t0)
    fits = {c: _fit_position(raw, spec, c, t0, lo, hi) for c in spec.names("position")}
    info: dict[str, float] = {}
    first = fits[spec.names("position")[0]]
    info.update(noise=first.noise, window=first.window, velocity_noise=first.velocity_noise)
    motion = motion_span(first)
    if motion is not None:
        info.update(onset=motion[0], end=motion[1])
    forces = {c: (raw.time(c) - t0, raw.series[c]) for c in spec.names("force")}
    if spec.tare:
        forces = _tared(raw, spec, forces, motion, lo, info)
    if spec.align == "contact":
        lo = contact_onset(raw, spec, forces, lo, hi)
    elif spec.align == "onset":
        if motion is None:
            raise ImportError_(f"{raw.origin}: {raw.name}: no motion onset for --align onset: the position never "
                               f"leaves its rest by more than {motion_step(first) * 1e3:.3g} mm")
        lo = max(lo, motion[0] - spec.lead)
    lo, hi, scale = _fitted(raw, spec, lo, hi, motion)
    info.update(kept=hi - lo, time_scale=scale)
    for c, (t, f) in forces.items():
        i0, i1 = span(t, lo, hi)
        _finite(raw, c, f[i0:i1 + 1], LIMITS["force"], offset=i0)
        _check_sign(raw, spec, c, f[i0:i1 + 1])
    for c in spec.names("velocity"):
        if c in raw.series:
            i0, i1 = span(raw.time(c) - t0, lo, hi)
            _finite(raw, c, raw.series[c][i0:i1 + 1], LIMITS["velocity"], offset=i0, small="mm/s")
    x = resample(raw, spec, t0, lo, hi, scale, fits, forces)
    return Checked(x, label, env, info, label_key)


def _converted(raw: RawDemo, spec: ImportSpec) -> RawDemo:
    """The recording in the task's units and sign: each named series times its --scale, plus its --offset."""
    if not (spec.scale or spec.offset):
        return raw
    series = {c: a * spec.scale.get(c, 1.0) + spec.offset.get(c, 0.0) for c, a in raw.series.items()}
    times = {c: a * spec.scale.get("t", 1.0) for c, a in raw.times.items()}
    return replace(raw, series=series, times=times)


def _check_times(raw: RawDemo) -> None:
    s = raw.series
    for c, a in s.items():
        if len(a) != len(raw.time(c)):
            raise ImportError_(f"{raw.origin}: {raw.name}: field {c!r} has {len(a)} values for {len(raw.time(c))} "
                               "time stamps")
    _finite(raw, "t", s["t"], np.inf)
    # the time column of a file whose streams have their own rows need not increase: each stream's must
    used = {c if c in raw.times else "t": raw.time(c) for c in s if c != "t"}
    for c, t in used.items():
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            k = int(bad[0]) + 1
            what = "duplicate" if t[k] == t[k - 1] else "earlier"
            raise ImportError_(f"{raw.where(c, k)}: {what} time stamp {t[k]:g} "
                               "(time stamps must increase)")
        if len(t) < 2:
            raise ImportError_(f"{raw.origin}: {raw.name} has {len(t)} sample(s)"
                               + (f" of {c!r}" if c in raw.times else "") + "; need at least 2")


def _label(raw: RawDemo, spec: ImportSpec) -> tuple[int, str | None]:
    if spec.labels is None:
        if raw.label is None:
            raise ImportError_(f"{raw.origin}: {raw.name} has no label; give a labels file with --labels FILE")
        return raw.label, None
    found = spec.labels.lookup(raw.label_keys())
    if found is None:
        raise ImportError_(f"{raw.origin}: {raw.name} is not in the labels file {spec.labels.path}; add a row "
                           f"'{Path(raw.origin).name},success' (or failure), or leave the recording out")
    return found[1], found[0]


def _environment(raw: RawDemo, spec: ImportSpec) -> np.ndarray:
    env = []
    for c in spec.env_names:
        if c in spec.env_values:
            env.append(float(spec.env_values[c]))
            continue
        v = raw.env[c]
        _finite(raw, c, v, np.inf)
        if np.ptp(v) > 1e-9 * max(1.0, abs(v[0])):
            raise ImportError_(f"{raw.origin}: environment value {c!r} changes within {raw.name}")
        env.append(float(v[0]))
    return np.array(env)


def _crop(raw: RawDemo, spec: ImportSpec, t0: float) -> tuple[float, float]:
    """--start/--end as (from, to) in s after the first time stamp."""
    duration = float(np.max(raw.series["t"]) - t0)
    lo, hi = spec.start, duration if spec.end is None else min(spec.end, duration)
    if lo >= hi:
        raise ImportError_(f"{raw.origin}: {raw.name} lasts {duration:g} s: nothing left after --start {lo:g} s")
    return lo, hi


def _fit_position(raw: RawDemo, spec: ImportSpec, c: str, t0: float, lo: float, hi: float) -> Smoothed:
    """One position channel between lo and hi, checked (finite, plausible, fast enough) and fitted."""
    t = raw.time(c) - t0
    i0, i1 = span(t, lo, hi)
    y = raw.series[c][i0:i1 + 1]
    _finite(raw, c, y, LIMITS["position"], offset=i0, small="mm")
    period = float(np.median(np.diff(t[i0:i1 + 1])))
    if period > 2 * spec.dt * 1.001:  # slower, and the spline would invent the motion between samples
        raise ImportError_(f"{raw.where(c, i0)}: {c!r} is sampled every {period:g} s ({1 / period:.3g} Hz), less "
                           f"than half the planner's rate (dt = {spec.dt:g} s); import with --dt {period / 2:g} or "
                           "longer (and plan with it), or record faster")
    return smooth(t[i0:i1 + 1], y)


def _tared(raw: RawDemo, spec: ImportSpec, forces: dict[str, tuple[np.ndarray, np.ndarray]],
           motion: tuple[float, float] | None, lo: float, info: dict[str, float]
           ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Each force less its mean over the rest before the motion (the sensor's bias with nothing touching)."""
    if motion is None or motion[0] - spec.lead - lo < 0.05:
        at = "never moves" if motion is None else f"starts moving {motion[0] - lo:.3g} s into the kept part"
        raise ImportError_(f"{raw.origin}: {raw.name}: --tare needs at least 0.05 s at rest before the motion, and "
                           f"the tool {at}; record a rest before moving, or drop --tare")
    out = {}
    for c, (t, f) in forces.items():
        idle = (t >= lo) & (t <= motion[0] - spec.lead)
        bias = float(np.mean(f[idle])) if idle.any() and np.isfinite(f[idle]).all() else np.nan
        if not np.isfinite(bias):
            raise ImportError_(f"{raw.origin}: {raw.name}: --tare: no finite {c!r} samples in the rest before the "
                               "motion")
        info[f"bias_{c}"] = bias
        out[c] = (t, f - bias)
    return out


def _fitted(raw: RawDemo, spec: ImportSpec, lo: float, hi: float, motion: tuple[float, float] | None
            ) -> tuple[float, float, float]:
    """The kept window and its time scale (kept seconds per planner second): what --fit does with a
    window longer than N·dt, or with every motion for `resample`."""
    T = spec.horizon * spec.dt
    duration = float(np.ptp(raw.series["t"]))
    if spec.fit == "resample":
        if motion is None:
            raise ImportError_(f"{raw.origin}: {raw.name}: --fit resample needs a motion to fit, and the position "
                               "never leaves rest")
        hi = min(hi, motion[1] + spec.lead)
        return lo, hi, (hi - lo) / T
    if hi - lo <= T + 1e-9:
        return lo, hi, 1.0
    if spec.fit == "refuse":
        kept = "" if (lo, hi) == (0.0, duration) else f" ({hi - lo:g} s kept from {lo:g} s to {hi:g} s)"
        raise ImportError_(f"{raw.origin}: {raw.name} lasts {duration:g} s{kept}, longer than the horizon N·dt = "
                           f"{T:g} s; crop it with --start/--end S, start at the motion with --align onset (or "
                           f"contact), keep the first {T:g} s with --fit crop, or fit the motion to it with --fit resample")
    hi = lo + T
    if motion is not None and motion[1] > hi + 1e-9:
        raise ImportError_(f"{raw.origin}: {raw.name}: the motion ends {motion[1]:.3g} s after the first time stamp, "
                           f"after the {T:g} s kept from {lo:.3g} s: its end decided the label, so it is not kept; "
                           f"plan over a longer horizon (--horizon N with N·dt >= {motion[1] - lo + spec.lead:.3g} s) or "
                           "pass --fit resample")
    return lo, hi, 1.0


def _check_sign(raw: RawDemo, spec: ImportSpec, c: str, f: np.ndarray) -> None:
    """Pressing is positive in every task: a force that only goes negative, beyond contact, was
    recorded with the other sign (a force/torque sensor's z axis often points into the tool)."""
    lo, hi = float(np.min(f)), float(np.max(f))
    if lo < -spec.contact_force and hi < spec.contact_force and -lo > 2 * max(hi, 0.0):
        raise ImportError_(f"{raw.origin}: {raw.name}: force {c!r} runs from {lo:.3g} to {hi:.3g} N: negative while "
                           f"pressing, and pressing is positive in the {spec.task} task; pass --scale {c}=-1")


def _finite(raw: RawDemo, c: str, a: np.ndarray, lim: float, offset: int = 0, small: str = "") -> None:
    """Every value finite and within `lim`; beyond it, the unit it was probably recorded in (`small`) named."""
    bad = np.flatnonzero(~np.isfinite(a) | (np.abs(np.nan_to_num(a)) > lim))
    if bad.size:
        i = int(bad[0])
        if not np.isfinite(a[i]):
            raise ImportError_(f"{raw.where(c, i + offset)}: {raw.shown(c, i + offset) or repr(float(a[i]))} "
                               "is not finite")
        hint = f"; in {small}? pass --scale {c}={small}" if small else ""
        raise ImportError_(f"{raw.where(c, i + offset)}: {a[i]:g} is beyond {lim:g}; expected SI units (m, m/s, N)"
                           + hint)


def contact_onset(raw: RawDemo, spec: ImportSpec, forces: Mapping[str, tuple[np.ndarray, np.ndarray]],
                  lo: float, hi: float) -> float:
    """`lead` s before the first sample in [lo, hi] where a force channel's magnitude exceeds
    `contact_force` (clipped at lo): where the part worth judging starts."""
    first, peak = np.inf, (0.0, "", 0)
    for c, (t, f) in forces.items():
        inside = np.flatnonzero((t >= lo) & (t <= hi))
        a = np.abs(np.nan_to_num(f[inside]))
        touching = np.flatnonzero(a > spec.contact_force)
        if touching.size:
            first = min(first, float(t[inside[touching[0]]]))
        elif a.size and a.max() > peak[0]:
            k = int(np.argmax(a))
            peak = (float(a[k]), c, int(inside[k]))
    if not np.isfinite(first):
        value, c, i = peak
        c = c or spec.names("force")[0]
        raise ImportError_(f"{raw.where(c, i)}: no contact onset for --align contact: the largest force between "
                           f"{lo:g} s and {hi:g} s is {value:g} N, not above --contact-force {spec.contact_force:g} N")
    return max(lo, first - spec.lead)


def span(t: np.ndarray, lo: float, hi: float) -> tuple[int, int]:
    """Sample indices (i0, i1) that cover [lo, hi]: the last sample at or before lo, the first at or after hi."""
    i0 = max(int(np.searchsorted(t, lo, side="right")) - 1, 0)
    i1 = min(int(np.searchsorted(t, hi - 1e-12, side="left")), len(t) - 1)
    return i0, max(i1, i0 + 1)


def resample(raw: RawDemo, spec: ImportSpec, t0: float, lo: float, hi: float, scale: float,
             fits: Mapping[str, Smoothed], forces: Mapping[str, tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """The window [lo, hi] at the planner's period: sample k at lo + k·dt·scale (scale > 1 plays a
    slow motion faster). Positions cubic through the recording (through the smoothed fit when the
    velocity is derived), velocities the given ones (or the fit's) times `scale`, forces linear;
    after hi, held at rest."""
    from scipy.interpolate import CubicSpline  # deferred: scipy takes a second to import, and the CLI imports this

    tk = lo + np.arange(spec.horizon + 1) * spec.dt * scale
    inside = tk <= hi + 1e-9
    columns: dict[str, np.ndarray] = {}
    for c in spec.channels:
        if c.kind == "position":
            velocity = next(d.name for d in spec.channels if d.of == c.name)
            given = velocity in raw.series
            if given:
                t = raw.time(c.name) - t0
                i0, i1 = span(t, lo, hi)
                t, y = t[i0:i1 + 1], raw.series[c.name][i0:i1 + 1]
            else:
                t, y = fits[c.name].t, fits[c.name].y
            spline = CubicSpline(t, y) if len(t) > 2 else None
            at = (lambda x: spline(x)) if spline is not None else (lambda x: np.interp(x, t, y))
            q, qdot = np.full(tk.shape, float(at(min(hi, t[-1])))), np.zeros(tk.shape)
            q[inside] = at(tk[inside])
            if given:
                tv = raw.time(velocity) - t0
                qdot[inside] = np.interp(tk[inside], tv, raw.series[velocity])
            else:
                qdot[inside] = np.interp(tk[inside], fits[c.name].t, fits[c.name].v)
            columns[c.name], columns[velocity] = q, qdot * scale
        elif c.kind == "force":
            t, f = forces[c.name]
            columns[c.name] = np.interp(np.minimum(tk, hi), t, f)
    return np.stack([columns[c.name] for c in spec.channels], axis=1)
