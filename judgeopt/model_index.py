"""What each shipped model is, read from its own metadata: kind, architecture, what made it, its
held-out figure, which judge a generator was trained against, and which models a task's
problems plan with by default (the same choice `judgeopt solve` makes: planners.solve.choose_models).

Why from the metadata and not from a hand-written list: a list drifts from the files; the files
are what planning loads.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from judgeopt.files import resolve


@dataclass
class ModelEntry:
    """One model (a .json/.pt pair, an ensemble folder, or a JSON model) of a task."""

    name: str  # the path `--judge` / `--generator` take, e.g. models/judge_refined
    kind: str  # judge, generator, ensemble, calibration, trust region
    what: str  # architecture and data, in a few words
    made_by: str | None = None  # the command (or the refinement) that wrote it
    held_out: str | None = None  # its held-out figure, as its metadata records it
    trained_against: str | None = None  # a generator's judge, by name where shipped
    defaults: list[str] = field(default_factory=list)  # e.g. "judge of problems/paper_sim.toml"

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
        if js.parent.name != root.name and (js.parent / "ensemble.json").exists():
            if js.name == "ensemble.json":
                entries[js.parent] = _ensemble(js)
            continue
        meta = _meta(js)
        entry = _entry(js, meta)
        if entry is not None:
            entries[js.with_suffix("")], metas[js.with_suffix("")] = entry, meta
    judges = {metas[p].get("weights_sha256"): e.name for p, e in entries.items() if e.kind == "judge"}
    for path, e in entries.items():
        if e.kind == "generator":
            sha = (metas[path].get("judge") or {}).get("weights_sha256")
            e.trained_against = judges.get(sha, "a judge not shipped" if sha else None)
    _mark_defaults(task, entries)
    return list(entries.values())


def _meta(path: Path) -> dict[str, Any]:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


def _name(path: Path) -> str:
    """The name `--judge` and `--generator` take: models/ and the path below it, without suffix."""
    return str(Path("models") / path.with_suffix("").relative_to(resolve("models")))


def _entry(js: Path, meta: dict[str, Any]) -> ModelEntry | None:
    fmt = str(meta.get("format", ""))
    name = _name(js)
    made = meta.get("command") or meta.get("source")
    if "calibration" in fmt or js.stem.startswith("calibration"):
        return ModelEntry(name, "calibration", "success predictions fitted to replayed outcomes", made)
    if "trust" in fmt or js.stem.startswith("trust_region"):
        return ModelEntry(name, "trust region", f"principal components of the successful demonstrations "
                          f"({meta.get('components_kept', '?')} kept)", made or f"fit on {meta.get('data')}")
    if not js.with_suffix(".pt").exists():
        return None
    config = meta.get("config") or {}
    metrics = meta.get("metrics") or {}
    if "problem" in meta:  # a generator
        kind = "conditioned on limit ranges" if meta.get("conditioned") else "for one set of limits"
        held = metrics.get("predicted_success_mean")
        return ModelEntry(name, "generator", f"amortised planner (paper eqs. 2-4), {kind}", made,
                          None if held is None else f"judge's mean p {held:.3f} on {metrics.get('n_envs', '?')} "
                          "sampled environments (its training log)")
    arch = config.get("arch") or "lstm"
    data = meta.get("train_data") or {}
    what = f"{arch.upper()} judge" + (", refined on its planners' plans replayed in simulation (judgeopt refine)"
                                       if meta.get("fine_tuned_from") else "")
    if data.get("path") and not str(data["path"]).startswith("out/"):  # out/ is a working folder, not shipped
        what += f", trained on {data['path']}"
    acc, test = metrics.get("test_accuracy"), (meta.get("test_data") or {}).get("path")
    if test and not str(test).startswith("out/"):
        held = None if acc is None else f"test accuracy {acc:.3f} (judgeopt test-judge --judge {name} --data {test})"
    else:
        held = None if acc is None else f"test accuracy {acc:.3f} (as its metadata records it)"
    return ModelEntry(name, "judge", what, made, held)


def _ensemble(js: Path) -> ModelEntry:
    meta = _meta(js)
    members = meta.get("members") or []
    return ModelEntry(_name(js.parent), "ensemble",
                      f"{len(members)} judges (seeds, bootstrap samples) for pessimistic planning",
                      meta.get("command"))


def _mark_defaults(task: str, entries: dict[Path, ModelEntry]) -> None:
    """What each of the task's shipped problems plans with, as `solve` chooses it."""
    from judgeopt.planners.problem import load_problem
    from judgeopt.planners.solve import choose_models

    by_path = {p.resolve(): e for p, e in entries.items()}
    problems = sorted((Path(__file__).parent / "tasks" / task / "problems").glob("*.toml"))
    for path in problems:
        problem = load_problem(path)
        label = f"problems/{path.name}"
        chosen = choose_models(problem, ("amortized", "direct"))
        for role, p in (("judge", chosen.judge), ("generator", chosen.generator)):
            if p is not None and Path(p).with_suffix("").resolve() in by_path:
                by_path[Path(p).with_suffix("").resolve()].defaults.append(f"{role} of {label}")
        for role, ref in (("calibration", problem.calibration), ("ensemble", problem.ensemble),
                          ("trust model", problem.trust_model if problem.trust_region is not None else None)):
            if ref:
                p = resolve(ref).with_suffix("") if resolve(ref).suffix == ".json" else resolve(ref)
                if p.resolve() in by_path:
                    by_path[p.resolve()].defaults.append(f"{role} of {label}")
