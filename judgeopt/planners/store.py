"""A saved generator: `<name>.pt` (state_dict) next to `<name>.json` (problem, judge, metrics).

The JSON holds the whole problem it was trained for and the judge's weights hash, so a
solve can tell whether a shipped generator fits the limits asked for (`matches`) and
which judge it was trained against.
"""

from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path
from typing import Any

import torch

from judgeopt import __version__
from judgeopt.judge.store import model_paths, write_model
from judgeopt.planners.generator import Generator, GeneratorConfig
from judgeopt.planners.problem import Problem, ProblemError

FORMAT = "judgeopt-generator"
VERSION = 1


class GeneratorFileError(ProblemError):
    """A generator file that is missing, corrupt or inconsistent with its metadata."""


def save_generator(gen: Generator, path: str | Path, meta: dict[str, Any] | None = None) -> tuple[Path, Path]:
    return write_model(gen, path, {"format": FORMAT, "format_version": VERSION, "package_version": __version__,
                                    "config": gen.config.to_dict(), "problem": gen.problem.to_dict(), **(meta or {})})


def load_generator_meta(path: str | Path) -> dict[str, Any]:
    _, js = model_paths(path)
    if not js.exists():
        raise GeneratorFileError(f"{js}: no such generator metadata file (train one with `judgeopt train-generator`)")
    try:
        meta = json.loads(js.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise GeneratorFileError(f"{js}: corrupt generator metadata, not valid JSON ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise GeneratorFileError(f"{js}: not a judgeopt generator file")
    if int(meta.get("format_version", -1)) > VERSION:
        raise GeneratorFileError(f"{js}: format version {meta['format_version']} is newer than this judgeopt reads")
    for k in ("config", "problem", "weights_sha256"):
        if k not in meta:
            raise GeneratorFileError(f"{js}: metadata lacks {k!r}")
    return meta


def load_generator(path: str | Path) -> tuple[Generator, dict[str, Any]]:
    pt, js = model_paths(path)
    meta = load_generator_meta(path)
    if not pt.exists():
        raise GeneratorFileError(f"{pt}: no such weights file (its metadata {js.name} exists)")
    data = pt.read_bytes()
    if hashlib.sha256(data).hexdigest() != meta["weights_sha256"]:
        raise GeneratorFileError(f"{pt}: weights do not match the sha256 recorded in {js.name} (damaged or replaced)")
    try:
        problem = Problem.from_dict({**meta["problem"], "source": str(js)})
        gen = Generator(problem, GeneratorConfig(**meta["config"]))
        state = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
        gen.load_state_dict(state)
    except ProblemError:
        raise
    except Exception as exc:  # torch raises several types for corrupt or mismatched weights
        raise GeneratorFileError(f"{pt}: cannot load ({type(exc).__name__}: {exc})") from None
    return gen.eval(), meta


def matches(meta: dict[str, Any], problem: Problem, judge_sha: str | None = None) -> bool:
    """Was this generator trained for exactly these limits (and this judge, if given)?"""
    trained = Problem.from_dict(meta["problem"])
    if trained.limits_key() != problem.limits_key() or trained.env_names != problem.env_names:
        return False
    return judge_sha is None or meta.get("judge", {}).get("weights_sha256") == judge_sha


def find_generator(folder: str | Path, problem: Problem, judge_sha: str | None = None) -> Path | None:
    """The first generator in `folder` (sorted by name) trained for this problem's limits."""
    for js in sorted(Path(folder).glob("*.json")):
        try:
            meta = load_generator_meta(js)
        except GeneratorFileError:
            continue
        if matches(meta, problem, judge_sha):
            return js.with_suffix("")
    return None
