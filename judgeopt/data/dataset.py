"""The demonstration file format: one HDF5 file per dataset.

Why HDF5: the data are fixed-shape numeric arrays (n demonstrations x N + 1 samples x 3
channels) plus metadata; HDF5 holds both in one self-describing file that h5py, MATLAB,
Julia and robomimic-style LfD tools already read, with partial reads for large sets.

Layout (format "judgeopt-demonstrations", version 1), C channels named by attr channels (the
scoop's: y (m), ydot (m/s), f (N)):

    /commands   float64 (n, N+1, C)  commanded channels at t_k = k dt
    /responses  float64 (n, N+1, C)  measured channels (what the judge reads)
    /labels     int8    (n,)         1 success, 0 failure
    /env        float64 (n, E)       environment values, columns named by attr env_names
    /index      int64   (n,)         demonstration number within its collection (seeded)
    /randomized float64 (n, K)       optional (`collect --randomize`): each demonstration's draw of the
                                     scene's unobserved parameters (the task's perturbations), columns
                                     named by attr randomized_names; attr `randomize` holds the ranges
    attrs: format, format_version, task (absent in files made before tasks: the scoop), dt,
           horizon, channels, units, env_names, seed, source, package_version, command,
           created, and JSON blobs `settings` (the task's scene, controller, rollout and
           random-command parameters; `simulator` in older files), `generator` (grid and
           ranges) and `errors` (the demonstrations that could not be run, with the reason).
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from judgeopt.errors import BadInput
from judgeopt.files import atomic_path
from judgeopt.formats.header import check_header, header
from judgeopt.tasks import DEFAULT_TASK
from judgeopt.trajectory import CHANNELS, UNITS

FORMAT = "judgeopt-demonstrations"
VERSION = 1


class DatasetError(BadInput, ValueError):
    """A dataset file that is missing, unreadable or not in the expected format."""


@dataclass
class Dataset:
    commands: np.ndarray
    responses: np.ndarray
    labels: np.ndarray
    env: np.ndarray
    dt: float
    env_names: tuple[str, ...]
    index: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)
    # the task whose channels these are (files written before tasks existed are the scoop's)
    task: str = DEFAULT_TASK
    channels: tuple[str, ...] = CHANNELS
    units: dict[str, str] = field(default_factory=lambda: dict(UNITS))
    # per demonstration, the unobserved parameters its world was drawn with (collect --randomize;
    # columns named by randomized_names), or None
    randomized: np.ndarray | None = None
    randomized_names: tuple[str, ...] = ()

    @property
    def robot(self) -> str:
        """The arm the demonstrations ran on (its settings' scene.robot; files made before arms were
        chosen, and tasks without one: the default, the UR5)."""
        from judgeopt.robots import DEFAULT_ROBOT

        scene = (self.meta.get("settings") or {}).get("scene") or {}
        return scene.get("robot", DEFAULT_ROBOT)

    def __post_init__(self) -> None:
        n = len(self.labels)
        self.index = np.arange(n) if self.index is None else np.asarray(self.index)
        self.channels = tuple(self.channels)
        self.randomized_names = tuple(self.randomized_names)
        if self.randomized is not None and self.randomized.shape != (n, len(self.randomized_names)):
            raise DatasetError(f"randomized must have shape ({n}, {len(self.randomized_names)}) for "
                               f"{self.randomized_names}, got {self.randomized.shape}")
        for name in ("commands", "responses"):
            a = getattr(self, name)
            if a.ndim != 3 or a.shape[0] != n or a.shape[2] != len(self.channels):
                raise DatasetError(f"{name} must have shape (n={n}, N+1, {len(self.channels)}) for channels "
                                   f"{', '.join(self.channels)}, got {a.shape}")
        if self.commands.shape != self.responses.shape:
            raise DatasetError(f"commands {self.commands.shape} and responses {self.responses.shape} differ in shape")
        if self.env.shape != (n, len(self.env_names)):
            raise DatasetError(f"env must have shape ({n}, {len(self.env_names)}) for {self.env_names}, got {self.env.shape}")
        if not np.isin(self.labels, (0, 1)).all():
            raise DatasetError("labels must be 0 (failure) or 1 (success)")

    @property
    def n(self) -> int:
        return len(self.labels)

    @property
    def horizon(self) -> int:
        return self.commands.shape[1] - 1

    def success_ratio(self) -> float:
        return float(self.labels.mean()) if self.n else float("nan")

    def subset(self, mask: np.ndarray) -> "Dataset":
        return dataclasses.replace(self, commands=self.commands[mask], responses=self.responses[mask],
                                   labels=self.labels[mask], env=self.env[mask], index=self.index[mask],
                                   meta=dict(self.meta),
                                   randomized=None if self.randomized is None else self.randomized[mask])

    def summary(self) -> dict[str, Any]:
        """Counts and success ratios overall and per distinct environment (for grids)."""
        per_env = []
        keys, inverse = np.unique(np.round(self.env, 6), axis=0, return_inverse=True)
        if len(keys) <= 20 and len(keys) < self.n:  # a grid, not one draw per demonstration
            for k, key in enumerate(keys):
                m = inverse.ravel() == k
                per_env.append({**dict(zip(self.env_names, key.tolist())), "n": int(m.sum()),
                                "success_ratio": float(self.labels[m].mean())})
        return {
            "task": self.task,
            "channels": list(self.channels),
            "n": self.n,
            "success_ratio": self.success_ratio(),
            "horizon": self.horizon,
            "dt": self.dt,
            "env_names": list(self.env_names),
            "env_range": {nm: [float(self.env[:, i].min()), float(self.env[:, i].max())] if self.n else None
                          for i, nm in enumerate(self.env_names)},
            "per_env": per_env,
            "command": self.meta.get("command"),
            "seed": self.meta.get("seed"),
            "source": self.meta.get("source"),
            "package_version": self.meta.get("package_version"),
            "errors": len(self.meta.get("errors", [])),
            **({"randomized": {k: [float(self.randomized[:, j].min()), float(self.randomized[:, j].max())]
                               if self.n else None for j, k in enumerate(self.randomized_names)}}
               if self.randomized is not None else {}),
        }


def save(ds: Dataset, path: str | Path) -> Path:
    """Write atomically: a temporary file in the same folder, then a rename."""
    path = Path(path)
    with atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as h:
            h.create_dataset("commands", data=ds.commands.astype(np.float64), compression="gzip", shuffle=True)
            h.create_dataset("responses", data=ds.responses.astype(np.float64), compression="gzip", shuffle=True)
            h.create_dataset("labels", data=ds.labels.astype(np.int8))
            h.create_dataset("env", data=ds.env.astype(np.float64))
            h.create_dataset("index", data=ds.index.astype(np.int64))
            if ds.randomized is not None:
                h.create_dataset("randomized", data=ds.randomized.astype(np.float64))
                h.attrs["randomized_names"] = json.dumps(list(ds.randomized_names))
            a = h.attrs
            a.update(header(FORMAT, VERSION))
            a["dt"], a["horizon"] = float(ds.dt), int(ds.horizon)
            a["task"] = ds.task
            a["channels"] = json.dumps(list(ds.channels))
            a["units"] = json.dumps(ds.units)
            a["env_names"] = json.dumps(list(ds.env_names))
            for key, value in ds.meta.items():
                a[key] = value if isinstance(value, (str, int, float)) else json.dumps(value)
    return path


_JSON_ATTRS = {"simulator", "settings", "generator", "errors", "seed", "randomize", "focus"}


#: suffixes of the recordings `judgeopt import-demos` reads (not datasets): named in load's message
RECORDING_SUFFIXES = (".csv", ".mcap")


def load(path: str | Path) -> Dataset:
    """Read and validate a dataset file; every problem is reported as a DatasetError naming it."""
    path = Path(path)
    if not path.exists():
        raise DatasetError(f"{path}: no such file (make one with `judgeopt collect` or `judgeopt import-demos`)")
    if path.is_dir():
        raise DatasetError(f"{path} is a folder; give a dataset file (.h5, from `judgeopt collect` or `judgeopt "
                           "import-demos`)")
    try:
        h = h5py.File(path, "r")
    except OSError as exc:
        if path.suffix.lower() in RECORDING_SUFFIXES:  # a recording given where a dataset belongs
            h5 = path.with_suffix(".h5")
            raise DatasetError(f"{path}: a {path.suffix.lstrip('.').upper()} recording, not a dataset; import it "
                               f"first with `judgeopt import-demos {path} --out {h5}` and give {h5} instead") from None
        raise DatasetError(f"{path}: not a readable HDF5 file ({exc})") from exc
    with h:
        a = dict(h.attrs)
        check_header(a, str(path), FORMAT, VERSION, DatasetError, "demonstration file")
        missing = [k for k in ("commands", "responses", "labels", "env") if k not in h]
        if missing:
            raise DatasetError(f"{path}: missing arrays {missing}")
        channels = json.loads(a.get("channels", "[]"))
        if not channels:
            raise DatasetError(f"{path}: names no channels (attribute 'channels')")
        meta = {}
        for k, v in a.items():
            if k in ("format", "format_version", "dt", "horizon", "channels", "units", "env_names", "task",
                     "randomized_names"):
                continue
            meta[k] = json.loads(v) if k in _JSON_ATTRS and isinstance(v, str) else (v.item() if hasattr(v, "item") else v)
        try:
            ds = Dataset(
                commands=h["commands"][()].astype(np.float64),
                responses=h["responses"][()].astype(np.float64),
                labels=h["labels"][()].astype(np.int64),
                env=h["env"][()],
                dt=float(a["dt"]),
                env_names=tuple(json.loads(a["env_names"])),
                index=h["index"][()] if "index" in h else None,
                meta=meta,
                task=str(a.get("task", DEFAULT_TASK)),
                channels=tuple(channels),
                units=json.loads(a["units"]) if "units" in a else {},
                randomized=h["randomized"][()] if "randomized" in h else None,
                randomized_names=tuple(json.loads(a.get("randomized_names", "[]"))),
            )
        except DatasetError as exc:
            raise DatasetError(f"{path}: {exc}") from exc
    if ds.horizon != int(a["horizon"]):
        raise DatasetError(f"{path}: horizon attribute {a['horizon']} disagrees with the arrays ({ds.horizon})")
    for name in ("commands", "responses"):
        arr = getattr(ds, name)
        if not np.isfinite(arr).all():
            raise DatasetError(f"{path}: {name} holds NaN or infinite values")
    return ds


def concatenate(parts: list[Dataset]) -> Dataset:
    first = parts[0]
    for p in parts[1:]:
        a, b = (p.task, p.channels, p.dt, p.horizon, p.env_names), (first.task, first.channels, first.dt, first.horizon,
                                                                 first.env_names)
        if a != b:
            raise DatasetError(f"cannot merge datasets of task/channels/dt/horizon/env {'/'.join(map(str, a))} "
                               f"and {'/'.join(map(str, b))}")
    return dataclasses.replace(
        first, commands=np.concatenate([p.commands for p in parts]), responses=np.concatenate([p.responses for p in parts]),
        labels=np.concatenate([p.labels for p in parts]), env=np.concatenate([p.env for p in parts]),
        index=np.concatenate([p.index for p in parts]), meta=dict(first.meta),
        randomized=np.concatenate([p.randomized for p in parts])
        if all(p.randomized is not None and p.randomized_names == first.randomized_names for p in parts) else None)
