"""A saved judge: `<name>.pt` (state_dict) next to `<name>.json` (everything else).

Why two files: the weights stay a plain torch state_dict (loaded with weights_only=True, no
pickled code), the metadata stays human-readable: architecture, trajectory format, the
normalisation, the dataset it was trained on (sha256), metrics, version, command and seed.
The JSON also records the sha256 of the .pt, so a weights file swapped or damaged after
saving is caught on load.
"""

from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path
from typing import Any, Sequence

import torch

from judgeopt import __version__
from judgeopt.files import atomic_write
from judgeopt.judge.model import Judge, JudgeConfig, JudgeError, TrajectoryError

FORMAT = "judgeopt-judge"
VERSION = 1


class JudgeFileError(JudgeError):
    """A model file that is missing, unreadable, corrupt or inconsistent with its metadata."""


class IncompatibleJudgeError(TrajectoryError):
    """A judge trained on a different trajectory format (horizon, dt, channels, env)."""


def model_paths(path: str | Path) -> tuple[Path, Path]:
    """`models/x`, `models/x.pt` or `models/x.json` -> (models/x.pt, models/x.json)."""
    p = Path(path)
    if p.suffix in (".pt", ".json"):
        p = p.with_suffix("")
    return p.with_name(p.name + ".pt"), p.with_name(p.name + ".json")


def save_judge(model: Judge, path: str | Path, meta: dict[str, Any] | None = None) -> tuple[Path, Path]:
    """Write `<path>.pt` then `<path>.json` (each atomically: temp file + os.replace).

    `meta` adds free keys (metrics, training config, dataset hashes, command, seed); the
    architecture, format, normalisation and weights hash are filled in here.
    """
    record = {"format": FORMAT, "format_version": VERSION, "package_version": __version__,
              "config": model.config.to_dict(), "normalization": model.normalization(), **(meta or {})}
    return write_model(model, path, record)


def write_model(model: torch.nn.Module, path: str | Path, record: dict[str, Any]) -> tuple[Path, Path]:
    """The weights to `<path>.pt`, then `record` plus the weights' name and sha256 to
    `<path>.json`, each atomically (shared by every saved model: judges and generators)."""
    pt, js = model_paths(path)
    buf = io.BytesIO()
    torch.save({k: v.detach().cpu() for k, v in model.state_dict().items()}, buf)
    data = buf.getvalue()
    atomic_write(pt, data)
    record = {**record, "weights_file": pt.name, "weights_sha256": hashlib.sha256(data).hexdigest()}
    atomic_write(js, (json.dumps(record, indent=2, sort_keys=False) + "\n").encode())
    return pt, js


def read_meta(path: str | Path, fmt: str = FORMAT, version: int = VERSION,
              required: Sequence[str] = ("config", "weights_sha256"), error: type[Exception] = None,
              hint: str = "train one with `judgeopt train-judge`", kind: str = "model") -> dict[str, Any]:
    """A model's JSON metadata, validated for format, version and the keys loading needs
    (shared by every saved model; `error` is the model kind's file error)."""
    error = error or JudgeFileError
    _, js = model_paths(path)
    if not js.exists():
        raise error(f"{js}: no such {kind} metadata file ({hint})")
    try:
        meta = json.loads(js.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise error(f"{js}: corrupt {kind} metadata, not valid JSON ({exc})") from exc
    if not isinstance(meta, dict) or meta.get("format") != fmt:
        got = meta.get("format") if isinstance(meta, dict) else type(meta).__name__
        raise error(f"{js}: not a judgeopt {fmt.removeprefix('judgeopt-')} metadata file (format is {got!r})")
    if int(meta.get("format_version", -1)) > version:
        raise error(f"{js}: format version {meta['format_version']} is newer than this judgeopt reads ({version})")
    missing = [k for k in required if k not in meta]
    if missing:
        raise error(f"{js}: metadata lacks {missing}")
    return meta


def read_weights(path: str | Path, meta: dict[str, Any], error: type[Exception] = None,
                 check_hash: bool = True) -> dict[str, Any]:
    """The state_dict next to the metadata, checked against its recorded sha256."""
    error = error or JudgeFileError
    pt, js = model_paths(path)
    if not pt.exists():
        raise error(f"{pt}: no such weights file (its metadata {js.name} exists)")
    data = pt.read_bytes()
    if check_hash and hashlib.sha256(data).hexdigest() != meta["weights_sha256"]:
        raise error(f"{pt}: weights file does not match the sha256 recorded in {js.name} "
                    "(damaged, or replaced after saving)")
    try:
        return torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises several types for corrupt files
        raise error(f"{pt}: corrupt weights file, torch cannot read it ({type(exc).__name__}: {exc})") from exc


def load_meta(path: str | Path) -> dict[str, Any]:
    """The judge's JSON metadata, validated."""
    return read_meta(path)


def load_judge(path: str | Path, check_hash: bool = True) -> tuple[Judge, dict[str, Any]]:
    """(model in eval mode, metadata); every problem is a JudgeFileError naming the file."""
    pt, js = model_paths(path)
    meta = load_meta(path)
    try:
        config = JudgeConfig.from_dict(meta["config"])
    except (TypeError, ValueError) as exc:
        raise JudgeFileError(f"{js}: invalid architecture config ({exc})") from exc
    state = read_weights(path, meta, check_hash=check_hash)
    model = Judge(config)
    try:
        model.load_state_dict(state)
    except (RuntimeError, TypeError, AttributeError) as exc:
        raise JudgeFileError(f"{pt}: weights do not fit the architecture in {js.name} ({exc})") from exc
    return model.eval(), meta


def check_compatible(meta: dict[str, Any] | JudgeConfig, horizon: int | None = None, dt: float | None = None,
                     channels: Sequence[str] | None = None, env_names: Sequence[str] | None = None) -> None:
    """Raise IncompatibleJudgeError saying exactly what differs between the judge's trajectory
    format and the given one (None: not checked). env_names are those AVAILABLE: the judge
    must find every variable it reads among them (order does not matter, it selects by name)."""
    cfg = meta if isinstance(meta, JudgeConfig) else JudgeConfig.from_dict(meta["config"])
    problems = []
    if horizon is not None and int(horizon) != cfg.horizon:
        problems.append(f"horizon N = {horizon} but the judge was trained on N = {cfg.horizon} "
                        f"({cfg.horizon + 1} samples)")
    if dt is not None and abs(float(dt) - cfg.dt) > 1e-9 * max(1.0, cfg.dt):
        problems.append(f"dt = {dt} s but the judge was trained on dt = {cfg.dt} s")
    if channels is not None and tuple(channels) != cfg.channels:
        problems.append(f"channels {list(channels)} but the judge reads {list(cfg.channels)}")
    if env_names is not None:
        missing = [n for n in cfg.env_names if n not in tuple(env_names)]
        if missing:
            problems.append(f"environment variables {missing} are missing (available {list(env_names)}, "
                            f"the judge reads {list(cfg.env_names)})")
    if problems:
        raise IncompatibleJudgeError("judge incompatible with the data: " + "; ".join(problems))
