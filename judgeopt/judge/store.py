"""A saved judge: `<name>.pt` (state_dict) next to `<name>.json` (everything else).

Why two files: the weights stay a plain torch state_dict (loaded with weights_only=True, no
pickled code), the metadata stays human-readable: architecture, trajectory format, the
normalisation, the dataset it was trained on (sha256), metrics, version, command and seed.
The JSON also records the sha256 of the .pt, so a weights file swapped or damaged after
saving is caught on load.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

from judgeopt import __version__
from judgeopt.formats.header import header
from judgeopt.formats.model_files import model_paths, read_meta, read_weights, write_model
from judgeopt.judge.compiled import TrajectoryFormat
from judgeopt.judge.errors import JudgeError, TrajectoryError

if TYPE_CHECKING:  # the network (torch) is imported where a judge is loaded or saved, not to read its metadata
    from judgeopt.judge.model import Judge, JudgeConfig

FORMAT = "judgeopt-judge"
VERSION = 1


class JudgeFileError(JudgeError):
    """A model file that is missing, unreadable, corrupt or inconsistent with its metadata."""


class IncompatibleJudgeError(TrajectoryError):
    """A judge trained on a different trajectory format (horizon, dt, channels, env)."""


def save_judge(model: Judge, path: str | Path, meta: dict[str, Any] | None = None) -> tuple[Path, Path]:
    """Write `<path>.pt` then `<path>.json` (each atomically: temp file + os.replace).

    `meta` adds free keys (metrics, training config, dataset hashes, command, seed); the
    architecture, format, normalisation and weights hash are filled in here.
    """
    record = {**header(FORMAT, VERSION), "package_version": __version__,
              "config": model.config.to_dict(), "normalization": model.normalization(), **(meta or {})}
    return write_model(model, path, record)


def load_meta(path: str | Path) -> dict[str, Any]:
    """The judge's JSON metadata, validated."""
    return read_meta(path, FORMAT, VERSION, error=JudgeFileError, hint="train one with `judgeopt train-judge`")


def load_judge(path: str | Path, check_hash: bool = True) -> tuple[Judge, dict[str, Any]]:
    """(model in eval mode, metadata); every problem is a JudgeFileError naming the file."""
    from judgeopt.judge.model import Judge, JudgeConfig

    pt, js = model_paths(path)
    meta = load_meta(path)
    try:
        config = JudgeConfig.from_dict(meta["config"])
    except (TypeError, ValueError) as exc:
        raise JudgeFileError(f"{js}: invalid architecture config ({exc})") from exc
    state = read_weights(path, meta, JudgeFileError, check_hash=check_hash)
    model = Judge(config)
    try:
        model.load_state_dict(state)
    except (RuntimeError, TypeError, AttributeError) as exc:
        raise JudgeFileError(f"{pt}: weights do not fit the architecture in {js.name} ({exc})") from exc
    return model.eval(), meta


def check_compatible(meta: dict[str, Any] | JudgeConfig | TrajectoryFormat, horizon: int | None = None,
                     dt: float | None = None,
                     channels: Sequence[str] | None = None, env_names: Sequence[str] | None = None) -> None:
    """Raise IncompatibleJudgeError saying exactly what differs between the judge's trajectory
    format and the given one (None: not checked). env_names are those AVAILABLE: the judge
    must find every variable it reads among them (order does not matter, it selects by name)."""
    cfg = meta
    if isinstance(meta, dict):
        try:  # the trajectory format alone, without torch
            cfg = TrajectoryFormat.of(meta["config"])
        except TrajectoryError:  # an older file that leaves fields to their defaults: the full config reads it
            from judgeopt.judge.model import JudgeConfig

            cfg = JudgeConfig.from_dict(meta["config"])
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
