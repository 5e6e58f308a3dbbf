"""The environments (and, for refined judges, the limits) a judge learnt from, and the values
outside them.

Why: a judge is a network fitted to its data. Asked about a world its demonstrations never
showed (an object further than any of them, a friction none had), it still answers, often
with a confident p = 1.000, and nothing in that number says it is a guess. A judge file
records what its data covered, so whoever prints the number can add "qdot_max = 1.5 m/s is
outside the judge's data (0.22-1.20)":

    train_data.env_ranges       per environment variable, [min, max] over the training data's
                                environments (train-judge, refine and the ensemble write it)
    refine_config.limit_ranges  refined judges only: the q̇_max, f_min, f_max ranges the
                                refinement rounds planned under (the judge saw their outcomes);
    train_data.limit_ranges     where written, their union over every round the judge continued
                                (a refinement resumed with other ranges), read instead

Judge files written before these were recorded give no ranges and so no phrase.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np

#: share of a range's width a value may lie beyond it and still count as inside (with
#: TOLERANCE_ABS on top): rounding in a problem file or a limit typed as 0.28 for a range that
#: ends at 0.27998 is not a world the judge has not seen
TOLERANCE = 0.01
#: absolute part of the tolerance: a range of width 0 (one recorded value) still admits the
#: value itself after a float round trip
TOLERANCE_ABS = 1e-9

# the units of the limits refinement samples, by the kind of channel they bound
_LIMIT_KINDS = {"qdot_max": "velocity", "f_min": "force", "f_max": "force"}


def env_ranges_of(dataset: Any) -> dict[str, list[float]]:
    """Per environment variable of `dataset` (a judgeopt.data.dataset.Dataset), [min, max] over
    its demonstrations' environments, as plain floats (what a judge file records). An empty
    dataset has no ranges: {}."""
    env = np.asarray(dataset.env, dtype=float)
    if env.size == 0:
        return {}
    return {name: [float(env[:, i].min()), float(env[:, i].max())] for i, name in enumerate(dataset.env_names)}


def _pairs(d: Any) -> dict[str, tuple[float, float]]:
    """The [lo, hi] pairs of a recorded mapping; anything else in it (a task name) is skipped."""
    out: dict[str, tuple[float, float]] = {}
    if not isinstance(d, Mapping):
        return out
    for k, v in d.items():
        if (isinstance(v, Sequence) and not isinstance(v, str) and len(v) == 2
                and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)):
            out[str(k)] = (float(v[0]), float(v[1]))
    return out


def env_ranges_in(meta: Mapping[str, Any]) -> dict[str, tuple[float, float]]:
    """The environment variables' ranges a judge file records (train_data.env_ranges), or {}."""
    td = meta.get("train_data")
    return _pairs(td.get("env_ranges")) if isinstance(td, Mapping) else {}


def limit_ranges_in(meta: Mapping[str, Any]) -> dict[str, tuple[float, float]]:
    """The limits' ranges a refined judge's file records, or {}: train_data.limit_ranges where
    written (the union over every round it continued: rounds resumed with other ranges), else
    refine_config.limit_ranges (the ranges of the `refine` run that made it)."""
    td, rc = meta.get("train_data"), meta.get("refine_config")
    if isinstance(td, Mapping) and td.get("limit_ranges"):
        return _pairs(td["limit_ranges"])
    return _pairs(rc.get("limit_ranges")) if isinstance(rc, Mapping) else {}


def union(*ranges: Mapping[str, Sequence[float]]) -> dict[str, list[float]]:
    """Per name, the smallest [lo, hi] holding every given range of it."""
    out: dict[str, list[float]] = {}
    for r in ranges:
        for k, (lo, hi) in r.items():
            out[k] = [min(out[k][0], float(lo)), max(out[k][1], float(hi))] if k in out else [float(lo), float(hi)]
    return out


def data_ranges(meta: Mapping[str, Any]) -> dict[str, tuple[float, float]]:
    """What a judge's metadata says it learnt from: its environment variables' ranges
    (train_data.env_ranges) and, for a refined judge, the limits' (train_data.limit_ranges, else
    refine_config.limit_ranges), name -> (lo, hi). Empty where the file records none (files from
    before)."""
    return {**env_ranges_in(meta), **limit_ranges_in(meta)}


def tolerance(lo: float, hi: float) -> float:
    """How far beyond [lo, hi] a value still counts as inside."""
    return TOLERANCE_ABS + TOLERANCE * (hi - lo)


def _inside(value: float, lo: float, hi: float) -> bool:
    tol = tolerance(lo, hi)
    return lo - tol <= value <= hi + tol  # NaN: outside


def format_range(lo: float, hi: float) -> str:
    """0.10-0.28, 1.0-3.0, 0.05-4.0: decimals by the width, more for an end that would otherwise
    be shown further off than the tolerance; "to" where a minus sign would read as the dash; one
    value (a lab's single object position) once."""
    if hi == lo:
        return f"{lo:g}"
    width, tol = abs(hi - lo), tolerance(min(lo, hi), max(lo, hi))
    base = min(6, max(0, 1 - math.floor(math.log10(width))))

    def fmt(x: float) -> str:
        d = base
        while d < 9 and abs(round(x, d) - x) > tol:
            d += 1
        return f"{x:.{d}f}"

    return f"{fmt(lo)} to {fmt(hi)}" if lo < 0 or hi < 0 else f"{fmt(lo)}-{fmt(hi)}"


def _units(meta: Mapping[str, Any]) -> dict[str, str]:
    """Units of the environment variables and limits, from the judge's task (where it names one
    this installation knows; none otherwise: the phrase then goes without)."""
    rc = meta.get("refine_config")
    lr = rc.get("limit_ranges") if isinstance(rc, Mapping) else None
    name = meta.get("task") or (lr.get("task") if isinstance(lr, Mapping) else None)
    try:
        from judgeopt.tasks import DEFAULT_TASK, get_task

        task = get_task(str(name or DEFAULT_TASK))
        units = {v.name: v.unit for v in task.env_vars}
        for limit, kind in _LIMIT_KINDS.items():
            channels = task.channels_of(kind)
            if channels:
                units[limit] = channels[0].unit
        return units
    except Exception:  # an unknown or broken task: units are a courtesy, never a failure
        return {}


def _phrase(name: str, value: float, lo: float, hi: float, unit: str) -> str:
    rng = f"only {lo:g}" if hi == lo else format_range(lo, hi)
    return f"{name} = {value:g}{' ' + unit if unit else ''} is outside the judge's data ({rng})"


def describe(meta: Mapping[str, Any]) -> str:
    """The recorded ranges in one line (`judgeopt inspect`): "NAME 0.10-0.28 m, NAME 1.0-3.0;
    limits qdot_max 0.22-1.20 m/s, ..."; "" where the file records none."""
    units = _units(meta)

    def items(ranges: dict[str, tuple[float, float]]) -> str:
        return ", ".join(f"{k} {format_range(lo, hi)}" + (f" {units[k]}" if units.get(k) else "")
                         + (" only" if hi == lo else "") for k, (lo, hi) in ranges.items())

    envs, lims = env_ranges_in(meta), limit_ranges_in(meta)
    return "; ".join(([items(envs)] if envs else []) + ([f"limits {items(lims)}"] if lims else []))


def outside_data(meta: Mapping[str, Any], env: Mapping[str, float],
                 limits: Mapping[str, float | Sequence[float]] | None = None) -> list[str]:
    """One short phrase per value outside what the judge learnt from, e.g. "qdot_max = 1.5 m/s is
    outside the judge's data (0.22-1.20)". A value at a range's edge, or beyond it by at most
    `tolerance(lo, hi)`, is inside. Variables and limits the file records no range for are not
    mentioned; a per-axis limit (a list) is checked per element and named NAME[axis]."""
    # NaN is outside every range: a world nobody can say the judge has seen
    envs, lims = env_ranges_in(meta), limit_ranges_in(meta)
    if not envs and not lims:
        return []
    units = _units(meta)
    notes = []
    for name, value in env.items():
        if name in envs:
            lo, hi = envs[name]
            if not _inside(float(value), lo, hi):
                notes.append(_phrase(name, float(value), lo, hi, units.get(name, "")))
    for name, value in (limits or {}).items():
        if name not in lims:
            continue
        lo, hi = lims[name]
        values = np.atleast_1d(np.asarray(value, dtype=float)).ravel()
        per_axis = values.size > 1  # one axis: named as a scalar limit
        for axis, v in enumerate(values):
            if not _inside(float(v), lo, hi):
                notes.append(_phrase(f"{name}[{axis}]" if per_axis else name, float(v), lo, hi, units.get(name, "")))
    return notes
