"""A saved generator: `<name>.pt` (state_dict) next to `<name>.json` (problem, judge, metrics).

The JSON holds the whole problem it was trained for and the judge's weights hash, so a
solve can tell whether a shipped generator fits the limits asked for (`matches`) and
which judge it was trained against.

A conditioned generator (issue 6) also records `"conditioned": {"names": [...], "ranges":
{name: [lo, hi]}}`, the limits it reads as inputs and the ranges it was trained over; its
`problem` is the base problem (the other limits, the environment). Those files carry
format_version 2, so an older judgeopt refuses them by name instead of misreading them;
per-limit files are written as before (version 1, no `conditioned` key) and old ones load
unchanged.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from judgeopt import __version__
from judgeopt.formats.header import header
from judgeopt.formats.model_files import model_paths, read_meta, read_weights, write_model
from judgeopt.planners.generator import Generator, GeneratorConfig
from judgeopt.planners.limits import CONDITION_NAMES, LimitRanges
from judgeopt.planners.problem import Problem, ProblemError

FORMAT = "judgeopt-generator"
VERSION = 2  # the newest this reads; 1: per-limit generators, 2: conditioned ones


class GeneratorFileError(ProblemError):
    """A generator file that is missing, corrupt or inconsistent with its metadata."""


def save_generator(gen: Generator, path: str | Path, meta: dict[str, Any] | None = None) -> tuple[Path, Path]:
    record = {**header(FORMAT, 1 if gen.conditioned is None else 2), "package_version": __version__, "config": gen.config.to_dict(), "problem": gen.problem.to_dict()}
    if gen.conditioned is not None:
        record["conditioned"] = {"names": list(CONDITION_NAMES), "ranges": gen.conditioned.to_dict()}
    return write_model(gen, path, {**record, **(meta or {})})


def conditioned_ranges(meta: dict[str, Any]) -> LimitRanges | None:
    """The limit ranges of a conditioned generator's metadata; None for a per-limit one."""
    cond = meta.get("conditioned")
    if not cond:
        return None
    try:
        if tuple(cond["names"]) != CONDITION_NAMES:
            raise ValueError(f"conditioned on {cond['names']}, this judgeopt knows {list(CONDITION_NAMES)}")
        return LimitRanges.from_dict(cond["ranges"])
    except (KeyError, TypeError, ValueError) as exc:
        raise GeneratorFileError(f"invalid `conditioned` entry in generator metadata ({exc})") from None


def load_generator_meta(path: str | Path) -> dict[str, Any]:
    meta = read_meta(path, FORMAT, VERSION, ("config", "problem", "weights_sha256"), GeneratorFileError,
                     "train one with `judgeopt train-generator`", kind="generator")
    try:
        conditioned_ranges(meta)
    except GeneratorFileError as exc:
        raise GeneratorFileError(f"{model_paths(path)[1]}: {exc}") from None
    return meta


def load_generator(path: str | Path) -> tuple[Generator, dict[str, Any]]:
    pt, js = model_paths(path)
    meta = load_generator_meta(path)
    state = read_weights(path, meta, GeneratorFileError)
    problem = Problem.from_dict({**meta["problem"], "source": str(js)})
    try:
        gen = Generator(problem, GeneratorConfig(**meta["config"]), conditioned_ranges(meta))
        gen.load_state_dict(state)
    except (RuntimeError, TypeError) as exc:
        raise GeneratorFileError(f"{pt}: weights do not fit the architecture in {js.name} ({exc})") from None
    return gen.eval(), meta


def matches(meta: dict[str, Any], problem: Problem, judge_sha: str | None = None) -> bool:
    """Can this generator plan for these limits (and was it trained against this judge, if
    given)? A per-limit generator: trained for exactly these limits. A conditioned one: the
    conditioned limits inside its ranges, every other limit exactly its problem's."""
    trained = Problem.from_dict(meta["problem"])
    if trained.task != problem.task or trained.env_names != problem.env_names:
        return False
    ranges = conditioned_ranges(meta)
    mine, theirs = trained.limits_key(), problem.limits_key()
    if ranges is not None:
        mine = {k: v for k, v in mine.items() if k not in CONDITION_NAMES}
        theirs = {k: v for k, v in theirs.items() if k not in CONDITION_NAMES}
        if not ranges.contains(problem):
            return False
    if mine != theirs:
        return False
    lj = meta.get("loss_judge")  # trained against an ensemble's pessimistic score: only for that ensemble
    if lj and not (problem.ensemble and Path(lj["ensemble"]).name == Path(problem.ensemble).name
                   and lj["pessimism"] == problem.pessimism):
        return False
    return judge_sha is None or meta.get("judge", {}).get("weights_sha256") == judge_sha


def find_generator(folder: str | Path, problem: Problem, judge_sha: str | None = None) -> Path | None:
    """A generator in `folder` or its subfolders (a task's own, e.g. models/scrape/) for this
    problem's task and limits (and judge), by preference: one trained
    against the problem's ensemble's pessimistic score (when it names an ensemble), one trained
    for exactly these limits, one conditioned on ranges that contain them; then by name."""
    found = []
    for js in sorted(Path(folder).rglob("*.json")):
        try:
            meta = load_generator_meta(js)
        except GeneratorFileError:
            continue
        if matches(meta, problem, judge_sha):
            found.append((not meta.get("loss_judge"), conditioned_ranges(meta) is not None, js.name, js.with_suffix("")))
    return min(found)[-1] if found else None
