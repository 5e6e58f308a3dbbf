"""What each shipped model is, read from its own metadata: kind, architecture, data, what made it,
its held-out figure, which judge a generator was trained against (and which generators go with a
judge), and which models a task's problems plan with by default (the same choice `judgeopt
solve` makes: planners.loaded.choose_models).

Why from the metadata and not from a hand-written list: a list drifts from the files; the files
are what planning loads. Models kept only to reproduce a table or an experiment live in
`models/experiments/` (EXPERIMENTS), which the wheel leaves out.
"""

from __future__ import annotations

import json
import re
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from judgeopt.files import resolve, shipped_models

#: the folder, inside a task's models folder, of the models kept only to reproduce a table or an
#: experiment (not in the wheel: pyproject's exclude-package-data)
EXPERIMENTS = "experiments"


@dataclass
class ModelEntry:
    """One model (a .json/.pt pair, an ensemble folder, or a JSON model) of a task."""

    name: str  # the path `--judge` / `--generator` take, e.g. models/judge_refined
    kind: str  # judge, generator, ensemble, calibration, trust region
    what: str  # architecture and data, in a few words
    made_by: str | None = None  # the command (or the refinement) that wrote it
    held_out: str | None = None  # its held-out figure, as its metadata records it, and the command that gives it
    trained_against: str | None = None  # a generator's judge, by name where shipped
    generators: list[str] = field(default_factory=list)  # a judge's: the generators trained against it
    defaults: list[str] = field(default_factory=list)  # e.g. "judge of problems/paper_sim.toml"
    experiment: bool = False  # kept only to reproduce a table or an experiment (models/experiments/, not in the wheel)
    formerly: str | None = None  # its name before a rename
    renamed_since: str | None = None  # models its `made_by` command names that have been renamed since it ran
    note: str | None = None  # what its metadata says about it (`about`)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def task_folder(task: str) -> Path:
    """A task's model folder: where its default judge lives (models/ for the scoop, models/scrape/ ...)."""
    from judgeopt.tasks import get_task

    return resolve(Path(get_task(task).default_judge).parent)


def index(task: str) -> list[ModelEntry]:
    """Every model in the task's folder (not in another task's subfolder), defaults marked."""
    from judgeopt.tasks import task_names

    root = task_folder(task)
    others = [task_folder(t) for t in task_names() if t != task]
    entries: dict[Path, ModelEntry] = {}
    metas: dict[Path, dict[str, Any]] = {}
    for js in sorted(root.rglob("*.json")):
        if any(root in o.parents and o in js.parents for o in others) or js.name.endswith(".history.json"):
            continue
        if (js.parent / "ensemble.json").exists() and js.parent != root:
            if js.name == "ensemble.json":
                entries[js.parent] = _ensemble(js)
            continue
        meta = _meta(js)
        entry = _entry(js, meta)
        if entry is not None:
            entries[js.with_suffix("")], metas[js.with_suffix("")] = entry, meta
    judges = {m.get("weights_sha256"): entries[p] for p, m in metas.items() if entries[p].kind == "judge"}
    renamed = {m["formerly"]: entries[p].name for p, m in metas.items() if m.get("formerly")}
    for path, e in entries.items():
        e.renamed_since = _renamed_in(e.made_by, renamed)
        if e.kind == "generator":
            e.trained_against = _trained_against(metas[path], judges)
            judge = next((j for j in judges.values() if j.name == e.trained_against), None)
            if judge is not None:
                judge.generators.append(e.name)
    _mark_defaults(task, entries)
    return list(entries.values())


def shipped_judge(sha: str | None) -> str | None:
    """The name of the shipped judge with these weights (any task, experiments included); None if none."""
    for js in sorted(shipped_models().rglob("*.json")):
        meta = _meta(js)
        if sha and meta.get("format") == "judgeopt-judge" and meta.get("weights_sha256") == sha:
            return _name(js)
    return None


def _meta(path: Path) -> dict[str, Any]:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


def _name(path: Path) -> str:
    """The name `--judge` and `--generator` take: models/ and the path below it, without suffix."""
    for root in (resolve("models"), shipped_models()):
        if root.resolve() in path.resolve().parents:
            return str(Path("models") / path.resolve().with_suffix("").relative_to(root.resolve()))
    return str(path.with_suffix(""))


def _trained_against(meta: dict[str, Any], judges: dict[str | None, ModelEntry]) -> str | None:
    """A generator's judge by name, or what it was where that judge is not shipped."""
    sha = (meta.get("judge") or {}).get("weights_sha256")
    named = judges[sha].name if sha in judges else None
    lj = meta.get("loss_judge")
    if lj:
        record = named or f"{(meta.get('judge') or {}).get('path')}, a judge not shipped (sha256 {str(sha)[:12]}...)"
        return f"the pessimistic score of {lj['ensemble']} (mean - {lj['pessimism']:g} std); its judge record: {record}"
    return named or (f"a judge not shipped ({(meta.get('judge') or {}).get('path')}, sha256 {sha[:12]}...)"
                     if sha else None)


def _renamed_in(command: str | None, renamed: dict[str, str]) -> str | None:
    """Which of the models a recorded command names have been renamed since it ran (old -> new)."""
    then = [f"{old} is now {new}" for old, new in renamed.items()
            if command and re.search(re.escape(old) + r"(?![\w/])", command)]
    return ", ".join(then) or None


def _entry(js: Path, meta: dict[str, Any]) -> ModelEntry | None:
    fmt = str(meta.get("format", ""))
    name = _name(js)
    made = meta.get("command") or meta.get("source")
    common = {"experiment": EXPERIMENTS in Path(name).parts[1:-1], "formerly": meta.get("formerly"),
              "note": meta.get("about")}
    if "calibration" in fmt or js.stem.startswith("calibration"):
        return ModelEntry(name, "calibration", f"success predictions fitted to replayed outcomes, for "
                          f"{len(meta.get('settings') or {})} planner settings (judgeopt calibrate)", made, **common)
    if "trust" in fmt or js.stem.startswith("trust_region"):
        data = meta.get("data") or {}
        return ModelEntry(name, "trust region", f"principal components ({meta.get('components_kept', '?')} kept) of "
                          f"the {data.get('successful_demonstrations', '?'):,} successful demonstrations in "
                          f"{data.get('path')} (judgeopt fit-trust-region)", made, **common)
    if not js.with_suffix(".pt").exists():
        return None
    if "problem" in meta:
        return _generator(name, meta, made, common)
    return _judge(name, meta, made, common)


def _generator(name: str, meta: dict[str, Any], made: str | None, common: dict[str, Any]) -> ModelEntry:
    from judgeopt.planners.limits import CONDITION_NAMES
    from judgeopt.planners.store import conditioned_ranges

    metrics = meta.get("metrics") or {}
    problem = meta.get("problem") or {}
    limits = (f"q̇_max {problem.get('qdot_max')} m/s, f {problem.get('f_min')}-{problem.get('f_max')} N "
              f"({problem.get('name')})")
    ranges = conditioned_ranges(meta)
    spans = [f"{k} {getattr(ranges, k)[0]:g}-{getattr(ranges, k)[1]:g}" for k in CONDITION_NAMES] if ranges else []
    kind = f"conditioned on the limits {', '.join(spans)}" if ranges else f"for one set of limits: {limits}"
    held = metrics.get("predicted_success_mean")
    drawn = "environments and limits" if metrics.get("limits_sampled_from_ranges") else "environments"
    return ModelEntry(name, "generator", f"amortised planner (paper eqs. 2-4), {kind}", made,
                      None if held is None else f"the judge's mean p {held:.3f} on {metrics.get('n_envs', '?')} "
                      f"fresh {drawn} (train-generator's check, recorded in its metadata)", **common)


def _judge(name: str, meta: dict[str, Any], made: str | None, common: dict[str, Any]) -> ModelEntry:
    config = meta.get("config") or {}
    data = meta.get("train_data") or {}
    parts = [p for p in str(data.get("path") or "").split(" + ") if p]
    shipped = [p for p in parts if not p.startswith("out/")]  # out/ is a working folder, not shipped
    what = f"{(config.get('arch') or 'lstm').upper()} judge"
    if meta.get("invert_labels"):
        what += " trained on INVERTED labels"
    if data.get("planner_outcomes"):
        what += (f", refined on {data['planner_outcomes']} of its planners' plans replayed in simulation "
                 "(judgeopt refine)")
    if parts:
        count = f"{data['n']:,} demonstrations: " if data.get("n") else ""
        rest = len(parts) - len(shipped)
        what += (f", trained on {count}{' + '.join(shipped) if shipped else ''}"
                 + (f"{' + ' if shipped else ''}{rest} file{'s' if rest > 1 else ''} not shipped" if rest else ""))
    what += f"; reads {', '.join(config.get('env_names') or [])}"
    return ModelEntry(name, "judge", what, made, _held_out(name, meta), **common)


def _held_out(name: str, meta: dict[str, Any]) -> str | None:
    """A judge's recorded test accuracy and the command that prints it again (where its test set is shipped)."""
    acc = (meta.get("metrics") or {}).get("test_accuracy")
    test = meta.get("test_data") or {}
    path = test.get("shipped_as") or test.get("path")
    if acc is None:
        return None
    figure = (f"test accuracy {acc:.3f} against the inverted labels it was trained on, {1 - acc:.3f} against the "
              "true ones" if meta.get("invert_labels") else f"test accuracy {acc:.3f}")
    if path and not str(path).startswith("out/"):
        return f"{figure} on {test.get('n', 0):,} demonstrations (judgeopt test-judge --judge {name} --data {path})"
    return f"{figure} (as its metadata records it{f'; on {path}, not shipped' if path else ''})"


def _ensemble(js: Path) -> ModelEntry:
    meta = _meta(js)
    members = meta.get("members") or []
    accs = [m.get("metrics", {}).get("test_accuracy") for m in members]
    accs = [a for a in accs if a is not None]
    cfg = meta.get("config") or {}
    return ModelEntry(_name(js.parent), "ensemble",
                      f"{len(members)} LSTM judges, each on its own bootstrap sample of {meta.get('train_data')} "
                      f"({cfg.get('epochs', '?')} epochs; judgeopt train-ensemble), for pessimistic planning "
                      "(mean - k std)",
                      meta.get("command"),
                      f"test accuracy {min(accs):.3f}-{max(accs):.3f} per member (as the manifest records it)"
                      if accs else None)


def _mark_defaults(task: str, entries: dict[Path, ModelEntry]) -> None:
    """What each of the task's shipped problems plans with, as `solve` chooses it."""
    from judgeopt.planners.problem import load_problem
    from judgeopt.planners.base import default_planners
    from judgeopt.planners.loaded import choose_models

    by_path = {p.resolve(): e for p, e in entries.items()}
    problems = sorted((Path(__file__).parent / "tasks" / task / "problems").glob("*.toml"))
    for path in problems:
        problem = load_problem(path)
        label = f"problems/{path.name}"
        chosen = choose_models(problem, default_planners())
        for role, p in (("judge", chosen.judge), ("generator", chosen.generator)):
            if p is not None and Path(p).with_suffix("").resolve() in by_path:
                by_path[Path(p).with_suffix("").resolve()].defaults.append(f"{role} of {label}")
        for role, ref in (("calibration", problem.calibration), ("ensemble", problem.ensemble),
                          ("trust model", problem.trust_model if problem.trust_region is not None else None)):
            if ref:
                p = resolve(ref).with_suffix("") if resolve(ref).suffix == ".json" else resolve(ref)
                if p.resolve() in by_path:
                    by_path[p.resolve()].defaults.append(f"{role} of {label}")
