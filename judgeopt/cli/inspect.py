"""`judgeopt inspect`: what any file judgeopt writes holds, validated by loading it.

The kind is told by the file's own `format` field (models, calibrations, trust regions, plans),
its suffix (HDF5 datasets) or its layout (an ensemble folder, an evaluation folder with
partial/*.json), never by its name, so a renamed file is still recognised.
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path
from typing import Any, Callable

from judgeopt.cli.commands import HELP
from judgeopt.cli.common import JSON, CLIError, ExitCode

KINDS = "datasets (.h5), judges and generators (STEM, STEM.json or STEM.pt), ensembles (folder), calibrations, " \
        "trust regions and plans (.json), exported plans for ROS 2 (.mcap), evaluation folders (with partial/)"


def _format_of(path: Path) -> str | None:
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise CLIError(f"{path}: not readable JSON ({exc})", ExitCode.BAD_INPUT) from None
    return data.get("format") if isinstance(data, dict) else None


def kind_of(path: str | Path) -> tuple[str, Path]:
    """(kind, the path to load) for a file or folder judgeopt wrote; one-line error otherwise."""
    from judgeopt.files import resolve

    p = resolve(path, ("", ".json"))
    if p.is_dir():
        if (p / "ensemble.json").exists():
            return "ensemble", p
        if (p / "partial").is_dir():
            return "evaluation", p
        raise CLIError(f"{p}: a folder, but neither an ensemble (ensemble.json) nor an evaluation (partial/); "
                       f"inspect reads {KINDS}", ExitCode.BAD_INPUT)
    if p.suffix.lower() in (".h5", ".hdf5"):
        return "dataset", p
    if p.suffix.lower() == ".mcap" and p.is_file():
        return "ros bag", p
    js = p.with_suffix(".json") if p.suffix == ".pt" else p if p.suffix == ".json" else p.with_name(p.name + ".json")
    if not js.exists():
        what = "a file inspect does not read" if p.is_file() else "no such file"
        raise CLIError(f"{path}: {what}; inspect reads {KINDS}", ExitCode.BAD_INPUT)
    fmt = _format_of(js)
    kinds = {"judgeopt-judge": "judge", "judgeopt-generator": "generator", "judgeopt-judge-ensemble": "ensemble",
             "judgeopt-calibration": "calibration", "judgeopt-trust-region": "trust region"}
    from judgeopt.formats.plan import PLAN_FORMAT

    kinds[PLAN_FORMAT] = "plan"
    if fmt not in kinds:
        raise CLIError(f"{js}: JSON with format {fmt!r}, not a file judgeopt writes; inspect reads {KINDS}",
                       ExitCode.BAD_INPUT)
    where = js.parent if kinds[fmt] == "ensemble" else js.with_suffix("") if kinds[fmt] in ("judge", "generator") else js
    return kinds[fmt], where


def _dataset(p: Path) -> dict[str, Any]:
    from judgeopt.data.dataset import load

    return load(p).summary()


def _judge(p: Path) -> dict[str, Any]:
    from judgeopt.cli.judge import inspect_model

    return inspect_model(p)


def _generator(p: Path) -> dict[str, Any]:
    from judgeopt.planners.limits import CONDITION_NAMES
    from judgeopt.planners.store import conditioned_ranges, load_generator

    gen, meta = load_generator(p)
    ranges = conditioned_ranges(meta)
    recorded = ("judge", "loss_judge", "metrics", "fine_tuned_from", "command", "source", "seed", "created",
                "package_version", "about", "weights_sha256")
    return {"path": str(p), "parameters": sum(x.numel() for x in gen.parameters()),
            "task": gen.problem.task,  # files from before generators recorded it hold the default task's
            "problem": {k: meta["problem"].get(k) for k in ("name", "qdot_max", "f_min", "f_max", "q_end", "steps", "dt")},
            "conditioned_on": None if ranges is None else {k: list(getattr(ranges, k)) for k in CONDITION_NAMES},
            "judge_sha256": meta.get("judge", {}).get("weights_sha256"), **{k: meta.get(k) for k in recorded}}


def format_generator(info: dict[str, Any]) -> str:
    """A generator's summary in lines a reader scans: what it plans for, against which judge, its
    held-out check, what made it (the model it continued only where that is another one)."""
    from judgeopt.model_index import shipped_judge

    pr, m = info["problem"], info.get("metrics") or {}
    judge = info.get("judge") or {}
    sha = judge.get("weights_sha256")
    against = shipped_judge(sha) or f"{judge.get('path')}, a judge not shipped (sha256 {str(sha)[:12]}...)"
    lj = info.get("loss_judge")
    if lj:
        against = f"the pessimistic score of {lj['ensemble']} (mean - {lj['pessimism']:g} std); judge record {against}"
    ranges = info.get("conditioned_on")
    end = "its end left free" if pr["q_end"] == "free" else f"ends at {pr['q_end']}"
    plans = (f"{pr['name']}: q̇_max {pr['qdot_max']} m/s, f {pr['f_min']}-{pr['f_max']} N, {end}, "
             f"{pr['steps']} steps of {pr['dt']} s")
    made_with = [f"judgeopt {info['package_version']}" if info.get("package_version") else None, info.get("created")]
    lines = [f"{info['path']}  ({', '.join(['generator'] + [x for x in made_with if x])})",
             f"  network        : {info['parameters']} parameters",
             f"  task           : {info['task']}",
             f"  plans for      : {plans}",
             "  conditioned on : " + (", ".join(f"{k} {lo:g}-{hi:g}" for k, (lo, hi) in ranges.items()) if ranges
                                      else "nothing: these limits only"),
             f"  against        : {against}"]
    if m.get("predicted_success_mean") is not None:
        drawn = "environments and limits" if m.get("limits_sampled_from_ranges") else "environments"
        lines.append(f"  held out       : the judge's mean p {m['predicted_success_mean']:.3f} on {m.get('n_envs')} "
                     f"fresh {drawn}, worst violation {m.get('max_constraint_violation_max', float('nan')):.1e}")
    made = info.get("command") or info.get("source")
    if made:
        seed = f"  (seed {info['seed']})" if info.get("seed") is not None else ""
        lines.append(f"  made by        : {made}{seed}")
    parent = info.get("fine_tuned_from")
    if parent and Path(str(parent)).name != Path(info["path"]).name:  # its own earlier version is no news
        lines.append(f"  continued from : {parent}")
    if info.get("about"):
        lines.append(f"  note           : {info['about']}")
    lines.append(f"  weights sha256 : {info['weights_sha256']}")
    return "\n".join(lines)


def _ensemble(p: Path) -> dict[str, Any]:
    from judgeopt.judge.ensemble import load_ensemble

    judges, meta = load_ensemble(p)
    return {"path": str(p), "members": len(judges), "config": meta.get("config"),
            "test_accuracy": [m.get("metrics", {}).get("test_accuracy") for m in meta.get("members", [])],
            "train_data": meta.get("train_data")}


def _calibration(p: Path) -> dict[str, Any]:
    """Its calibrators, and the held-out evidence behind "likely" per planner (at the default risk)."""
    from judgeopt.verdict.calibration import describe, load_calibration_document
    from judgeopt.verdict.plan_model import plan_model_of
    from judgeopt.verdict.risk import RISK

    calibrators, found, section = load_calibration_document(p)
    model = plan_model_of(section, str(p))
    evidence = [{"planner": k, "kind of p": e.kind or "both (stored before they were kept apart)", "plans": e.plans, "confidence": e.confidence, "sources": e.sources,
                 "ranges": {n: [round(lo, 4), round(hi, 4)] for n, (lo, hi) in e.ranges.items() if hi > lo},
                 f"at risk {RISK:g}": e.describe(RISK), "raised above 0.5 by the calibration": e.raised,
                 "thresholds": e.grid} for k, e in found.items()]
    out = {"path": str(p), "settings": [describe(c) for c in calibrators.values()], "evidence": evidence}
    if model is not None:
        out["plan model"] = {"planners": model.planners, "plans": model.n, "succeeded": model.successes,
                             "trees": len(model.sizes), "sources": model.sources, "robot": model.robot,
                             "ranges": {n: [round(lo, 4), round(hi, 4)] for n, lo, hi in zip(model.names, model.low,
                                                                                           model.high) if hi > lo}}
    return out


def _trust_region(p: Path) -> dict[str, Any]:
    from judgeopt.planners.trust_region import load_trust_region

    tr = load_trust_region(p)
    meta = json.loads(p.read_text())
    return {"path": str(p), "components": int(tr.components.shape[0]), "features": int(tr.components.shape[1]),
            "distance_quantiles": tr.quantiles, "data": meta.get("data")}


def _plan(p: Path) -> dict[str, Any]:
    from judgeopt.formats.plan import read_plan_json, read_plan_record

    rec = read_plan_record(p)
    plan = read_plan_json(p)
    keep = ("method", "status", "environment", "predicted_success", "success_probability", "probability_source",
            "verdict", "simulated_success", "max_constraint_violation", "worst_constraint")
    return {"path": str(p), **{k: rec.get(k) for k in keep}, "task": rec.get("problem", {}).get("task"),
            "channels": [c.name for c in plan.channels], "samples": plan.horizon + 1, "dt": plan.dt,
            "provenance": {k: rec.get("provenance", {}).get(k) for k in ("command", "git_commit", "created")}}


def _ros_bag(p: Path) -> dict[str, Any]:
    from judgeopt.formats.mcap import summarize_mcap

    return {"path": str(p), **summarize_mcap(p)}


def _evaluation(p: Path) -> dict[str, Any]:
    from judgeopt.evaluate.stored import StoredRowsError, chunk_files, read_chunk

    rows: list[dict] = []
    bad = []
    for f in chunk_files(p):
        try:
            rows += read_chunk(f)
        except StoredRowsError as exc:
            bad.append(str(exc))
    per: dict[str, Counter] = {}
    for r in rows:
        key = r.get("setting_description") or r.get("method", "?")
        c = per.setdefault(key, Counter())
        c["plans"] += 1
        c["simulated"] += r.get("simulated_success") is not None
        c["successes"] += bool(r.get("simulated_success"))
    return {"path": str(p), "plans": len(rows), "unreadable_chunks": bad,
            "tables": sorted(f.name for f in p.glob("*.md")),
            "settings": [{"setting": k, **c, "success_pct": 100 * c["successes"] / c["simulated"] if c["simulated"]
                          else None} for k, c in per.items()]}


READERS: dict[str, Callable[[Path], dict[str, Any]]] = {
    "dataset": _dataset, "judge": _judge, "generator": _generator, "ensemble": _ensemble, "calibration": _calibration,
    "trust region": _trust_region, "plan": _plan, "ros bag": _ros_bag, "evaluation": _evaluation}


def inspect(path: str | Path) -> dict[str, Any]:
    """{"kind": ..., ...} for any file judgeopt writes."""
    kind, p = kind_of(path)
    return {"kind": kind, **READERS[kind](p)}


def _lines(d: dict[str, Any], indent: str = "  ") -> list[str]:
    out = []
    for k, v in d.items():
        if k in ("kind", "path"):
            continue
        if isinstance(v, list) and v and isinstance(v[0], dict):
            out.append(f"{indent}{k}:")
            out += [indent + "  - " + ", ".join(f"{a}={b}" for a, b in item.items()) for item in v]
        else:
            out.append(f"{indent}{k:<15}: {v}")
    return out


def cmd_inspect(args: argparse.Namespace) -> int:
    from judgeopt.cli.judge import format_model_info

    info = inspect(args.path)
    if args.json:
        print(json.dumps(info, default=str))
    elif info["kind"] == "judge":
        print(format_model_info(info))
    elif info["kind"] == "dataset":
        print(format_dataset(args.path, info))
    elif info["kind"] == "generator":
        print(format_generator(info))
    else:
        print("\n".join([f"{info['path']}  ({info['kind']})", *_lines(info)]))
    return 0


def format_dataset(path: str, s: dict[str, Any]) -> str:
    # what a dataset's maker recorded (import-demos records no seed or version): the parts present
    made = [f"{label}{s[k]}" for k, label in (("source", "source: "), ("seed", "seed "), ("package_version", "judgeopt "))
            if s.get(k) is not None]
    lines = [f"{path}",
             f"  demonstrations : {s['n']}" + (f"  ({', '.join(made)})" if made else ""),
             f"  success ratio  : {s['success_ratio']:.3f}",
             f"  horizon, dt    : {s['horizon']} samples after the start, {s['dt']} s"]
    lines += [f"  {name:<15}: {rng[0]:.4g} .. {rng[1]:.4g}" for name, rng in s["env_range"].items()]
    if s["per_env"]:
        lines.append("  per environment:")
        for row in s["per_env"]:
            env = "  ".join(f"{k}={row[k]:.3g}" for k in s["env_names"])
            lines.append(f"    {env}  n={row['n']:<5} success {row['success_ratio']:.3f}")
    lines += [f"  randomized     : {name} {rng[0]:.4g} .. {rng[1]:.4g}" for name, rng in s.get("randomized", {}).items()
              if rng is not None]
    lines.append(f"  errors         : {s['errors']}")
    if s.get("command"):
        lines.append(f"  made by        : {s['command']}")
    return "\n".join(lines)


def add_inspect_command(sub: argparse._SubParsersAction) -> None:
    i = sub.add_parser("inspect", help=HELP["inspect"],
                       description=f"Reads {KINDS}; each is validated by loading it.", parents=[JSON])
    i.add_argument("path", help="the file or folder")
    i.set_defaults(func=cmd_inspect)
