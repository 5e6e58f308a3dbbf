"""One recorded demonstration, whatever file it came from: checked, cropped and resampled.

Every reader (CSV and robomimic-style HDF5 in `judgeopt.data.importer`, LeRobot in
`judgeopt.data.lerobot`) turns its file into `RawDemo`s and hands them to `check`, so every
format is held to the same rules, windows and messages (see the importer's module docstring).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from typing import Callable, Mapping, Sequence

import numpy as np
from scipy.interpolate import CubicSpline

from judgeopt.tasks import DEFAULT_TASK, get_task
from judgeopt.trajectory import CHANNELS, DEFAULT_DT, DEFAULT_HORIZON, Channel

LABELS = {"success": 1, "1": 1, "true": 1, "failure": 0, "0": 0, "false": 0}
#: plausible magnitudes by channel kind: a value beyond is a unit mistake (mm, mm/s, N·10) more likely than a motion
LIMITS = {"position": 5.0, "velocity": 10.0, "force": 1000.0}
ALIGN = ("start", "contact")


class ImportError_(ValueError):
    """A demonstration file that cannot be imported; the message names the file and the place in it."""


@dataclass(frozen=True)
class ImportSpec:
    env_names: tuple[str, ...]
    dt: float = DEFAULT_DT
    horizon: int = DEFAULT_HORIZON
    #: HDF5 name -> "PATH" or "PATH:COLUMN" (see the importer's docstring); unmapped names use their defaults
    hdf5_keys: Mapping[str, str] = field(default_factory=dict)
    #: whose channels the recordings hold (positions and forces required, velocities optional)
    task: str = DEFAULT_TASK
    #: crop window in s from the recording's first time stamp (None: to its end)
    start: float = 0.0
    end: float | None = None
    #: "start": keep from `start`; "contact": from `pre_contact` s before the force first exceeds `contact_force` N
    align: str = "start"
    contact_force: float = 1.0
    pre_contact: float = 0.1
    #: keep the first N·dt s of a longer window instead of refusing the recording
    crop_to_horizon: bool = False
    #: HDF5: import only the demo groups listed in mask/<filter_key> (robomimic's filter keys)
    filter_key: str | None = None
    #: dense rewards: label 1 when the recording's largest reward is >= this
    success_threshold: float | None = None
    #: LeRobot name -> "COLUMN" or "COLUMN:INDEX" (`--keys`)
    lerobot_keys: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.align not in ALIGN:
            raise ImportError_(f"--align {self.align!r}: choose one of {', '.join(ALIGN)}")
        if not self.start >= 0:
            raise ImportError_(f"--start {self.start:g} s: must be 0 or later")
        if self.end is not None and not self.end > self.start:
            raise ImportError_(f"--end {self.end:g} s must be after --start {self.start:g} s")
        if not (self.contact_force > 0 and self.pre_contact >= 0):
            raise ImportError_(f"--contact-force {self.contact_force:g} N must be positive and --pre-contact "
                               f"{self.pre_contact:g} s not negative")

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
    """One demonstration as read, before any check: what every reader hands to `check`."""

    origin: str  # the file, first in every message
    name: str  # "demonstration 'demo0'" (CSV), "demo group 'data/demo_0'" (HDF5), "episode 3" (LeRobot)
    demo_id: str  # kept in the dataset's meta
    series: dict[str, np.ndarray]  # t, y, f and optional ydot, one value per sample
    env: dict[str, np.ndarray]  # per environment name: per-sample values, or one value
    label: int
    where: Callable[[str, int], str]  # "<file>, row 5, column 'y'": where sample i of a field is
    shown: Callable[[str, int], str] = lambda c, i: ""  # sample i of a field as the file spells it
    #: the label is the last value of a done flag (not a success flag): see `refuse_done_labels`
    label_from_done: str = ""


# -- key maps (--hdf5-keys, --keys) -----------------------------------------------------------------
_KEY = re.compile(r"^\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*([^:,]+?)\s*(?::\s*(-?\d+)\s*)?$")


def parse_keys(text: str | None, env_names: Sequence[str] = (), channels: Sequence[str] = CHANNELS,
               flag: str = "--hdf5-keys", scalars: Sequence[str] = ("success", "dt"),
               columns_everywhere: bool = False) -> dict[str, str]:
    """`y=obs/eef_pos:1,f=obs/ft:2` -> {"y": "obs/eef_pos:1", "f": "obs/ft:2"}, checked. Names
    that may be mapped: t, the task's channels, `scalars` and the environment names; a column
    selector only on per-step ones (on every name where every value is a column: LeRobot)."""
    out: dict[str, str] = {}
    per_step = ("t", *channels)
    allowed = (*per_step, *scalars, *env_names)
    for item in filter(None, (p.strip() for p in (text or "").split(","))):
        m = _KEY.match(item)
        if not m:
            raise ImportError_(f"{flag}: {item!r} is not NAME=PATH or NAME=PATH:COLUMN")
        name, path, column = m.groups()
        if name not in allowed:
            raise ImportError_(f"{flag}: unknown name {name!r}; map one of {list(allowed)}")
        if name in out:
            raise ImportError_(f"{flag}: {name!r} is mapped twice")
        if column is not None and name not in per_step and not columns_everywhere:
            raise ImportError_(f"{flag}: a column selector is only for per-step arrays ({', '.join(per_step)}), "
                               f"not {name!r}")
        out[name] = path.strip("/") + (f":{int(column)}" if column is not None else "")
    return out


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
def check(raw: RawDemo, spec: ImportSpec) -> tuple[np.ndarray, int, np.ndarray]:
    """Validate one demonstration (finite, plausible units, increasing time, constant environment),
    crop it to its window and resample it: the (N + 1, channels) array, its label and environment values."""
    s = raw.series
    lengths = {c: len(a) for c, a in s.items()}
    if len(set(lengths.values())) > 1:
        raise ImportError_(f"{raw.origin}: {raw.name} has fields of different lengths {lengths}")
    _finite(raw, "t", s["t"], np.inf)
    t = s["t"]
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        what = "duplicate" if t[k] == t[k - 1] else "earlier"
        raise ImportError_(f"{raw.where('t', k)}: {what} time stamp {t[k]:g} (time stamps must increase)")
    if len(t) < 2:
        raise ImportError_(f"{raw.origin}: {raw.name} has {len(t)} sample(s); need at least 2")
    lo, hi = window(raw, spec)
    i0, i1 = span(t - t[0], lo, hi)
    limits = spec.limits
    for c in (*spec.names("position", "force"), *(c for c in spec.names("velocity") if c in s)):
        _finite(raw, c, s[c][i0:i1 + 1], limits[c], offset=i0)  # only what is kept must be sound
    for c in spec.env_names:
        _finite(raw, c, raw.env[c], np.inf)
    env = []
    for c in spec.env_names:
        v = raw.env[c]
        if np.ptp(v) > 1e-9 * max(1.0, abs(v[0])):
            raise ImportError_(f"{raw.origin}: environment value {c!r} changes within {raw.name}")
        env.append(float(v[0]))
    return resample(raw, spec, lo, hi), raw.label, np.array(env)


def _finite(raw: RawDemo, c: str, a: np.ndarray, lim: float, offset: int = 0) -> None:
    bad = np.flatnonzero(~np.isfinite(a) | (np.abs(np.nan_to_num(a)) > lim))
    if bad.size:
        i = int(bad[0])
        if not np.isfinite(a[i]):
            raise ImportError_(f"{raw.where(c, i + offset)}: {raw.shown(c, i + offset) or repr(float(a[i]))} "
                               "is not finite")
        raise ImportError_(f"{raw.where(c, i + offset)}: {a[i]:g} is beyond {lim:g}; expected SI units (m, m/s, N)")


def window(raw: RawDemo, spec: ImportSpec) -> tuple[float, float]:
    """The part of a recording kept, (from, to) in s after its first time stamp: --start/--end,
    then contact onset (--align contact), then at most N·dt (--crop-to-horizon, else refused)."""
    t = raw.series["t"] - raw.series["t"][0]
    duration = float(t[-1])
    lo, hi = spec.start, duration if spec.end is None else min(spec.end, duration)
    if lo >= hi:
        raise ImportError_(f"{raw.origin}: {raw.name} lasts {duration:g} s: nothing left after --start {lo:g} s")
    if spec.align == "contact":
        lo = contact_onset(raw, spec, t, lo, hi)
    T = spec.horizon * spec.dt
    if hi - lo > T + 1e-9:
        if not spec.crop_to_horizon:
            kept = "" if (lo, hi) == (0.0, duration) else f" ({hi - lo:g} s kept from {lo:g} s to {hi:g} s)"
            raise ImportError_(f"{raw.origin}: {raw.name} lasts {duration:g} s{kept}, longer than the horizon N·dt = "
                               f"{T:g} s; crop it with --start/--end S, start at contact with --align contact, or "
                               f"keep the first {T:g} s with --crop-to-horizon")
        hi = lo + T
    return lo, hi


def contact_onset(raw: RawDemo, spec: ImportSpec, t: np.ndarray, lo: float, hi: float) -> float:
    """`pre_contact` s before the first sample in [lo, hi] where a force channel's magnitude
    exceeds `contact_force` (clipped at lo): where the part worth judging starts."""
    forces = spec.names("force")
    inside = np.flatnonzero((t >= lo) & (t <= hi))
    f = np.max([np.abs(np.nan_to_num(raw.series[c][inside])) for c in forces], axis=0)
    touching = np.flatnonzero(f > spec.contact_force)
    if not touching.size:
        k = int(np.argmax(f))
        c = max(forces, key=lambda c: abs(np.nan_to_num(raw.series[c][inside[k]])))
        raise ImportError_(f"{raw.where(c, int(inside[k]))}: no contact onset for --align contact: the largest force "
                           f"between {lo:g} s and {hi:g} s is {f[k]:g} N, not above --contact-force "
                           f"{spec.contact_force:g} N")
    return max(lo, float(t[inside[touching[0]]]) - spec.pre_contact)


def span(t: np.ndarray, lo: float, hi: float) -> tuple[int, int]:
    """Sample indices (i0, i1) that cover [lo, hi]: the last sample at or before lo, the first at or after hi."""
    i0 = max(int(np.searchsorted(t, lo, side="right")) - 1, 0)
    i1 = min(int(np.searchsorted(t, hi - 1e-12, side="left")), len(t) - 1)
    return i0, max(i1, i0 + 1)


def resample(raw: RawDemo, spec: ImportSpec, lo: float, hi: float) -> np.ndarray:
    """The window [lo, hi] at the planner's period from lo: cubic through each position, linear
    for each force and given velocity; after hi, held at rest (position and force at hi)."""
    v = raw.series
    t_all = v["t"] - v["t"][0]
    i0, i1 = span(t_all, lo, hi)
    part = slice(i0, i1 + 1)
    t = t_all[part]
    tk = lo + np.arange(spec.horizon + 1) * spec.dt
    inside = tk <= hi + 1e-9
    columns: dict[str, np.ndarray] = {}
    for c in spec.channels:
        if c.kind == "position":
            y = v[c.name][part]
            spline = CubicSpline(t, y) if len(t) > 2 else None
            at = (lambda x: spline(x)) if spline is not None else (lambda x: np.interp(x, t, y))
            q, qdot = np.full(tk.shape, float(at(hi))), np.zeros(tk.shape)
            q[inside] = at(tk[inside])
            velocity = next(d.name for d in spec.channels if d.of == c.name)
            if velocity in v:
                qdot[inside] = np.interp(tk[inside], t, v[velocity][part])
            else:
                qdot[inside] = spline(tk[inside], 1) if spline is not None else (y[1] - y[0]) / (t[1] - t[0])
            columns[c.name], columns[velocity] = q, qdot
        elif c.kind == "force":
            columns[c.name] = np.interp(np.minimum(tk, hi), t, v[c.name][part])
    return np.stack([columns[c.name] for c in spec.channels], axis=1)
