"""Refinement with a robot instead of the simulator: a round's plans out for execution, the
labelled executions back in (`judgeopt refine --plans-only`, then `--outcomes DIR`).

OUT/round_k/plans/ holds, per plan id (`r<k>_<environment index>_<method>`):

    <id>.json       the plan record (judgeopt.formats.plan: limits, environment, frame, provenance)
    <id>.csv        its commands at 1 kHz in the importer's columns (t, channels, environment)
    manifest.json   format "judgeopt-refine-plans": round, judge, generator, outcomes (what to record)
                    and plans: [{id, method, env_index, environment, limits, json, csv,
                    predicted_success}]

Execute each plan with the environment its manifest entry names, record it in the importer's CSV
format (judgeopt.data.importer: t, the task's positions and forces in SI units, optional
velocities, label success/failure; the environment columns optional, else the manifest's) and
save it as DIR/<id>.csv. The round then trains on the recordings exactly as it would on replays:
the plan is the command, the recording (resampled to the plan's period) the response.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import numpy as np

from judgeopt.files import atomic_write
from judgeopt.planners.problem import Problem, ProblemError

MANIFEST = "manifest.json"
MANIFEST_FORMAT = "judgeopt-refine-plans"


def plan_id(k: int, env_index: int, method: str) -> str:
    return f"r{k}_{env_index:05d}_{method}"


def write_plans(folder: Path, rows: list[dict[str, Any]], k: int, problem: Problem, models: dict[str, Any]) -> Path:
    """Each row's plan as JSON and CSV, then the manifest (last: its presence means the round's
    plans are complete)."""
    from judgeopt.formats.exporters import export_record
    from judgeopt.formats.plan import write_record

    entries = []
    for r in rows:
        rec, pid = r["record"], plan_id(k, r["env_index"], r["method"])
        write_record(rec, folder / f"{pid}.json")
        export_record(rec, folder / f"{pid}.csv", "csv")
        entries.append({"id": pid, "method": r["method"], "env_index": r["env_index"], "environment": rec["environment"],
                        "limits": r["limits"], **({"constraints": r["constraints"]} if r.get("constraints") else {}), "json": f"{pid}.json", "csv": f"{pid}.csv",
                        "predicted_success": rec["predicted_success"]})
    manifest = {"format": MANIFEST_FORMAT, "round": k, "task": problem.task, **models,
                "outcomes": "DIR/<id>.csv per plan: the importer's CSV columns (t, "
                            + ", ".join(problem.channels) + ") and label (success/failure); environment columns "
                            "optional (default: this manifest's)",
                "plans": entries}
    atomic_write(folder / MANIFEST, json.dumps(manifest, indent=1) + "\n")
    return folder / MANIFEST


def _header(path: Path) -> list[str]:
    try:
        with open(path, newline="") as fh:
            return [h.strip() for h in next(csv.reader(fh), [])]
    except (OSError, UnicodeDecodeError):
        return []  # the importer says what is wrong with it


def read_outcomes(manifest_path: Path, outcomes: str | Path, problem: Problem) -> tuple[list[dict[str, Any]], list[str]]:
    """The executed plans as rows for the round's dataset (command, response, success, env,
    predicted, violation), and one line per plan left out (no recording, or a bad one: file,
    row, field). Raises ProblemError when no recording is usable."""
    from judgeopt.data.importer import ImportSpec, import_demos
    from judgeopt.formats.plan import PlanFileError, plan_from_record, read_plan_record

    outcomes = Path(outcomes)
    if not outcomes.is_dir():
        raise ProblemError(f"{outcomes}: no such folder of recorded executions (--outcomes DIR holds one <id>.csv "
                           f"per plan of {manifest_path})")
    try:
        manifest = json.loads(manifest_path.read_text())
        entries = [(e["id"], e["json"], e["env_index"], e["method"], e["limits"], e["environment"])
                   for e in manifest["plans"]]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ProblemError(f"{manifest_path}: not a readable plan manifest ({type(exc).__name__}: {exc}); "
                           "write the round's plans again with --plans-only") from None
    rows, errors = [], []
    for pid, plan_json, env_index, method, limits, planned_env in entries:
        path = outcomes / f"{pid}.csv"
        if not path.exists():
            errors.append(f"{path}: no recording of plan {pid} (listed in {manifest_path})")
            continue
        try:
            rec = read_plan_record(manifest_path.parent / plan_json)
            command = plan_from_record(rec, manifest_path.parent / plan_json).values
        except PlanFileError as exc:
            errors.append(str(exc))
            continue
        recorded_env = all(n in _header(path) for n in problem.env_names)
        spec = ImportSpec(problem.env_names if recorded_env else (), dt=problem.dt, horizon=problem.steps,
                          task=problem.task)
        ds, errs = import_demos([path], spec)
        if ds is None or ds.n != 1:
            errors += errs or [f"{path}: {ds.n} demonstrations (demo_id values); one recording per plan"]
            continue
        env = ds.env[0].tolist() if recorded_env else [float(planned_env[n]) for n in problem.env_names]
        rows.append({"env_index": env_index, "method": method, "env": env, "limits": limits, "command": np.asarray(command).tolist(),
                     "response": ds.responses[0].tolist(), "success": bool(ds.labels[0]),
                     "predicted": rec["predicted_success"], "violation": rec["max_constraint_violation"]})
    if not rows:
        raise ProblemError(f"{outcomes}: no usable recording of the {len(entries)} plans in {manifest_path}"
                           + (f" (first: {errors[0]})" if errors else ""))
    return rows, errors


def pending(out: str | Path) -> Path | None:
    """The manifest of a round whose plans were written and wait for their executions, or None."""
    for manifest in sorted(Path(out).glob(f"round_*/plans/{MANIFEST}"), key=lambda p: int(p.parent.parent.name[6:])):
        if not (manifest.parent.parent / "summary.json").exists():
            return manifest
    return None
