"""A saved generator: `<name>.pt` (state_dict) next to `<name>.json` (problem, judge, metrics).

The JSON holds the whole problem it was trained for and the judge's weights hash, so a
solve can tell whether a shipped generator fits the limits asked for (`matches`) and
which judge it was trained against. A problem file names the generator that goes with its
judge ([models] generator_model); `find_generator` uses it where it fits, and searches the
models folder by metadata only where it names none or no longer fits (other limits, another judge).

A conditioned generator (issue 6) also records `"conditioned": {"names": [...], "ranges":
{name: [lo, hi]}}`, the limits it reads as inputs and the ranges it was trained over; its
`problem` is the base problem (the other limits, the environment). Those files carry
format_version 2, so an older judgeopt refuses them by name instead of misreading them;
per-limit files are written as before (version 1, no `conditioned` key) and old ones load
unchanged.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from judgeopt import __version__
from judgeopt.errors import BadInput
from judgeopt.files import resolve
from judgeopt.formats.header import header
from judgeopt.formats.model_files import model_paths, read_arrays, read_meta, read_weights, write_model
from judgeopt.planners.amortized import GeneratorArrays, GeneratorConfig
from judgeopt.planners.limits import CONDITION_NAMES, LimitRanges
from judgeopt.planners.problem import Problem, ProblemError

if TYPE_CHECKING:  # the network (torch) is imported where a generator is loaded for training or saved
    from judgeopt.planners.generator import Generator

FORMAT = "judgeopt-generator"
VERSION = 2  # the newest this reads; 1: per-limit generators, 2: conditioned ones


class GeneratorFileError(BadInput, ProblemError):
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
    from judgeopt.planners.generator import Generator

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


def load_generator_arrays(path: str | Path) -> tuple[GeneratorArrays, dict[str, Any]] | None:
    """The generator at `path` as numpy arrays without torch (formats.model_files.read_arrays: the
    cache's copy of its weights); None where there is no valid copy (load_generator makes one)."""
    _, js = model_paths(path)
    meta = load_generator_meta(path)
    state = read_arrays(path, meta)
    if state is None:
        return None
    try:
        problem = Problem.from_dict({**meta["problem"], "source": str(js)})
        return GeneratorArrays.from_state(problem, GeneratorConfig(**meta["config"]), conditioned_ranges(meta),
                                          state), meta
    except (TypeError, ValueError):  # weights that do not fit: load_generator says so in one line
        return None


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


def misfit(meta: dict[str, Any], problem: Problem, judge_sha: str | None = None) -> str | None:
    """Why a generator cannot plan for this problem (and judge), in a few words; None: it can."""
    if matches(meta, problem, judge_sha):
        return None
    if matches(meta, problem):
        return "it was trained against another judge"
    trained = Problem.from_dict(meta["problem"])
    if trained.task != problem.task:
        return f"it was trained for task {trained.task!r}"
    if trained.env_names != problem.env_names:
        return f"it reads the environment {list(trained.env_names)}, the problem {list(problem.env_names)}"
    lj = meta.get("loss_judge")
    if lj and not (problem.ensemble and Path(lj["ensemble"]).name == Path(problem.ensemble).name
                   and lj["pessimism"] == problem.pessimism):
        return f"it was trained against {lj['ensemble']} - {lj['pessimism']:g} std, which the problem does not name"
    ranges = conditioned_ranges(meta)
    spans = "" if ranges is None else ", ".join(f"{k} {getattr(ranges, k)[0]:g}-{getattr(ranges, k)[1]:g}"
                                                for k in CONDITION_NAMES)
    return "it was trained for other limits" + (f" (conditioned on {spans})" if spans else "")


def named_generator(problem: Problem, judge_sha: str | None = None) -> Path | None:
    """The generator the problem file names ([models] generator_model), if it fits these limits and
    this judge; None where it names none, or the limits or the judge were changed so that it no
    longer fits (`misfit` says why). A named file that is missing or damaged is an error."""
    if not problem.generator_model:
        return None
    path = resolve(problem.generator_model, (".json",))
    try:
        meta = load_generator_meta(path)
    except GeneratorFileError as exc:
        raise GeneratorFileError(f"{problem.source or problem.name}: generator_model = {problem.generator_model!r}: "
                                 f"{exc}; name a generator that exists, or set it to \"\"") from None
    return path if misfit(meta, problem, judge_sha) is None else None


def find_generator(folder: str | Path, problem: Problem, judge_sha: str | None = None) -> Path | None:
    """The generator for this problem's task and limits (and judge) among those in `folder` and its
    subfolders (a task's own, e.g. models/scrape/): the one the problem file names where it lies there
    and fits (`named_generator`); else, as a checked fallback (no generator named, limits or judge
    changed, e.g. `Planners.with_limits`, or another folder searched: `solve --models DIR`), one
    whose metadata fits, by preference: one trained against the problem's ensemble's pessimistic
    score (when it names an ensemble), one trained for exactly these limits, one conditioned on
    ranges that contain them; then by name."""
    named = named_generator(problem, judge_sha)
    if named is not None and Path(folder).resolve() in named.resolve().parents:
        return named
    found = []
    for js in sorted(Path(folder).rglob("*.json")):
        try:
            meta = load_generator_meta(js)
        except GeneratorFileError:
            continue
        if matches(meta, problem, judge_sha):
            found.append((not meta.get("loss_judge"), conditioned_ranges(meta) is not None, js.name, js.with_suffix("")))
    return min(found)[-1] if found else None
