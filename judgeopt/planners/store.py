"""A saved generator: `<name>.pt` (state_dict) next to `<name>.json` (problem, judge, metrics).

The JSON holds the whole problem it was trained for and the judge's weights hash, so a
solve can tell whether a shipped generator fits the limits asked for (`matches`) and
which judge it was trained against.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from judgeopt import __version__
from judgeopt.judge.store import model_paths, read_meta, read_weights, write_model
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
    return read_meta(path, FORMAT, VERSION, ("config", "problem", "weights_sha256"), GeneratorFileError,
                     "train one with `judgeopt train-generator`", kind="generator")


def load_generator(path: str | Path) -> tuple[Generator, dict[str, Any]]:
    pt, js = model_paths(path)
    meta = load_generator_meta(path)
    state = read_weights(path, meta, GeneratorFileError)
    problem = Problem.from_dict({**meta["problem"], "source": str(js)})
    try:
        gen = Generator(problem, GeneratorConfig(**meta["config"]))
        gen.load_state_dict(state)
    except (RuntimeError, TypeError) as exc:
        raise GeneratorFileError(f"{pt}: weights do not fit the architecture in {js.name} ({exc})") from None
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
