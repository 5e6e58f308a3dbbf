"""The plan JSON file: a self-contained record of one planner's result with provenance, so a run
on a real arm can be traced back to the models, code and command that planned it, and replayed.

Plan JSON (format "judgeopt-plan", version 2; `write_json`, read back by `read_plan_json`, which
also reads version 1, whose columns were always q, qdot, f):

    format, format_version
    method, status, message, solve_time_s, iterations
    environment                 {name: value}
    predicted_success           the judge's score of the plan
    success_probability         the probability judgeopt stands behind: calibrated on replayed
                                outcomes of this planner setting where a calibration covers it,
                                else the judge's; probability_source says which ("calibrated",
                                "judge"); verdict "likely" (>= 0.5), "unlikely", "outside the
                                judge's data" or "breaks a hard limit"
    simulated_success           true/false if replayed in the simulator, else null; `simulation`
                                holds what the replay measured
    max_constraint_violation, worst_constraint, residuals   every constraint's worst violation
    plan                        dt, horizon, channels, units, t and one list per channel (the
                                scoop's y, ydot, f) at the planner's period (these are the plan;
                                everything else is derived or context)
    plan_1khz                   step, interpolation, t and the channels at 1 ms, as `write_csv`
                                and the simulated controller compute them (9 significant digits)
    problem                     the whole problem (`Problem.to_dict()`: limits, terminal
                                constraints, weights, environment ranges, judge)
    provenance                  judge {path, weights_sha256, and for the direct solve backend: the
                                CasADi function it planned through}, generator {path, weights_sha256,
                                role} or null, judgeopt_version, git_commit, git_dirty (null
                                outside a git checkout), command, created (UTC, ISO 8601),
                                python, platform
    frame                       the task frame (judgeopt.formats.frame: frame_id, origin,
                                orientation, axes), defaults filled in; absent in files written
                                before it, which `record_frame` reads as the task's default frame

Non-finite numbers are written as null (strict JSON).

Out to a robot from a record: judgeopt.formats.exporters.
"""

from __future__ import annotations

import json
import math
import platform
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

from judgeopt.files import REPO, atomic_write
from judgeopt.formats.header import check_header, header
from judgeopt.formats.frame import TaskFrame
from judgeopt.trajectory import Plan, PlanError

PLAN_FORMAT = "judgeopt-plan"
PLAN_VERSION = 2  # 2: the plan's columns named by the task's channels (1: always q, qdot, f)
#: the fields `read_plan_json` requires (a file without them is not a usable record)
REQUIRED_FIELDS = ("format_version", "method", "environment", "plan", "problem", "provenance")
V1_COLUMNS = ("q", "qdot", "f")  # a version-1 file's columns: the scoop's y, ydot, f


class PlanFileError(PlanError):
    """A plan JSON file that is missing, corrupt, of another format or lacking fields."""


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(["git", "-C", str(REPO), *args], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout if out.returncode == 0 else None


def plan_provenance(judge_path: str | Path | None, judge_sha256: str | None,
                    generator_path: str | Path | None = None, command: str | None = None) -> dict[str, Any]:
    """Where a plan came from: models (with hashes), code version and commit, command, time.
    Computed once per run; never fails for lack of git or of a generator."""
    from judgeopt import __version__
    from judgeopt.files import sha256_file
    from judgeopt.formats.model_files import model_paths

    generator = None
    if generator_path is not None:
        pt = model_paths(generator_path)[0]
        try:
            sha = sha256_file(pt)
        except OSError:
            sha = None
        generator = {"path": str(generator_path), "weights_sha256": sha}
    commit = _git("rev-parse", "HEAD")
    status = _git("status", "--porcelain", "--untracked-files=no") if commit else None
    return {
        "judge": {"path": None if judge_path is None else str(judge_path), "weights_sha256": judge_sha256},
        "generator": generator,
        "judgeopt_version": __version__,
        "git_commit": commit.strip() if commit else None,
        "git_dirty": None if status is None else bool(status.strip()),
        "command": command if command is not None else " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]),
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "python": platform.python_version(),
        "platform": platform.platform(),
    }


def _clean(x: Any) -> Any:
    """JSON-ready: numpy scalars and arrays as Python values, non-finite floats as null."""
    if isinstance(x, dict):
        return {str(k): _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [_clean(v) for v in (x.tolist() if isinstance(x, np.ndarray) else x)]
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if x is None or isinstance(x, (bool, int, float, str)):
        return x
    return str(x)


def plan_record(result: Any, problem: Any, provenance: dict[str, Any], step: float = 1e-3) -> dict[str, Any]:
    """The JSON record of one planner's result (a judgeopt.planners.result.PlanResult) for its
    problem (judgeopt.planners.problem.Problem); the module docstring lists its fields."""
    plan = result.plan
    if plan is None:
        raise PlanError(f"{result.method}: no plan to export (status {result.status}: {result.message})")
    names = [c.name for c in plan.channels]
    units = {"t": "s", **{c.name: c.unit for c in plan.channels}}
    t, fine = plan.resample(step)
    prov = dict(provenance)
    # the generator's part in the plan: its own ("generated": one rollout of it), or the start of a solve
    role = ("planner" if result.status == "generated"
            else "warm start" if result.info.get("warm_start") == "generator" else None)
    prov["generator"] = {**prov["generator"], "role": role} if role and prov.get("generator") else None
    if result.info.get("judge_backend") and prov.get("judge"):
        prov["judge"] = {**prov["judge"], "backend": result.info["judge_backend"]}
    sim = {k.removeprefix("sim_"): v for k, v in result.info.items() if k.startswith("sim_")}
    other = {k: v for k, v in result.info.items() if not k.startswith("sim_")}
    record = {
        **header(PLAN_FORMAT, PLAN_VERSION),
        "method": result.method, "status": result.status, "message": result.message,
        "solve_time_s": result.solve_time_s, "iterations": result.iterations, "solver_info": other,
        "environment": result.env,
        "predicted_success": result.predicted_success,
        "success_probability": result.success_probability, "probability_source": result.probability_source or None,
        "verdict": result.verdict,
        "simulated_success": result.simulated_success, "simulation": sim or None,
        "max_constraint_violation": result.max_constraint_violation, "worst_constraint": result.worst_constraint,
        "residuals": result.residuals,
        "plan": {"dt": plan.dt, "horizon": plan.horizon, "channels": names, "units": units, "t": plan.t,
                 **{n: plan.values[:, j] for j, n in enumerate(names)}},
        "plan_1khz": {"step": step, "units": units,
                      "interpolation": "cubic Hermite in each position through the samples' positions and velocities "
                                       "(each velocity its derivative), linear in the forces: Plan.resample, what the "
                                       "simulated controller applies",
                      "t": [float(f"{v:.9g}") for v in t],
                      **{n: [float(f"{v:.9g}") for v in fine[:, j]] for j, n in enumerate(names)}},
        "problem": problem.to_dict(),
        "provenance": prov,
        "frame": problem.task_frame().to_dict(),
    }
    return _clean(record)


def write_json(result: Any, problem: Any, path: str | Path, provenance: dict[str, Any],
               step: float = 1e-3) -> Path:
    """One self-contained JSON file for a plan (fields: module docstring), written atomically
    (temporary file, then rename), so a controller polling the path never reads half a plan."""
    return write_record(plan_record(result, problem, provenance, step), path)


def write_record(record: dict[str, Any], path: str | Path) -> Path:
    """A `plan_record` as its JSON file, atomically."""
    path = Path(path)
    # one top-level field per line: `head` shows method, outcome and residuals; arrays stay on one line
    text = "{\n" + ",\n".join(f" {json.dumps(k)}: {json.dumps(v, allow_nan=False)}" for k, v in record.items())
    atomic_write(path, (text + "\n}\n").encode())
    return path


def read_plan_record(path: str | Path) -> dict[str, Any]:
    """A plan JSON file's record, validated: format, version, required fields, plan arrays."""
    path = Path(path)
    if path.is_dir():
        raise PlanFileError(f"{path} is a folder; give a plan file (.json, written by `judgeopt solve --save-json`)")
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise PlanFileError(f"{path}: no such plan file (write one with `judgeopt solve --save-json`)") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PlanFileError(f"{path}: cannot read ({exc})") from None
    try:
        rec = json.loads(text)
    except json.JSONDecodeError as exc:
        raise PlanFileError(f"{path}: corrupt plan file, not valid JSON ({exc.msg} at line {exc.lineno}, "
                            f"column {exc.colno}; truncated or edited?)") from None
    version = check_header(rec, str(path), PLAN_FORMAT, PLAN_VERSION, PlanFileError, "plan file")
    missing = [k for k in REQUIRED_FIELDS if k not in rec]
    if missing:
        raise PlanFileError(f"{path}: missing field(s) {missing}")
    plan = rec["plan"]
    if not isinstance(plan, dict):
        raise PlanFileError(f"{path}: field 'plan' is {type(plan).__name__}, not an object")
    columns = V1_COLUMNS if version < 2 else plan.get("channels")
    if not isinstance(columns, (list, tuple)) or not all(isinstance(c, str) for c in columns):
        raise PlanFileError(f"{path}: field 'plan.channels' must list the plan's channel names")
    missing = [k for k in ("dt", "t", *columns) if k not in plan]
    if missing:
        raise PlanFileError(f"{path}: missing field(s) {['plan.' + k for k in missing]}")
    for k in ("t", *columns):
        v = plan[k]
        if not isinstance(v, list) or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
            raise PlanFileError(f"{path}: field 'plan.{k}' must be a list of numbers (null: a non-finite value)")
    for k in ("environment", "problem", "provenance"):
        if not isinstance(rec[k], dict):
            raise PlanFileError(f"{path}: field {k!r} is {type(rec[k]).__name__}, not an object")
    return rec


def read_plan_json(path: str | Path) -> Plan:
    """The plan of a `write_json` file (at the planner's period), checked, ready to replay
    (`Simulator.run(plan, **env)`) or to resample for a controller (`Plan.resample`)."""
    return plan_from_record(read_plan_record(path), path)


def plan_from_record(rec: dict[str, Any], path: str | Path) -> Plan:
    """The plan of a record `read_plan_record` checked (`path`: named in every message)."""
    p = rec["plan"]
    dt = p["dt"]
    if not isinstance(dt, (int, float)) or isinstance(dt, bool):
        raise PlanFileError(f"{path}: field 'plan.dt' is {dt!r}, not a number")
    from judgeopt.tasks import DEFAULT_TASK, TaskError, get_task

    try:
        task = get_task(rec["problem"].get("task", DEFAULT_TASK))
        columns = V1_COLUMNS if rec["format_version"] < 2 else p["channels"]
        task.check_channels(task.channel_names if rec["format_version"] < 2 else columns, f"{path}")
        plan = Plan.from_columns(float(dt), task.channels, *(np.array(p[k], dtype=float) for k in columns))
    except (PlanError, TaskError) as exc:
        raise PlanFileError(f"{path}: {exc}") from None
    t = np.asarray(p["t"], dtype=float)
    if t.shape != plan.t.shape or np.abs(t - plan.t).max() > 1e-9:
        raise PlanFileError(f"{path}: field 'plan.t' ({len(t)} samples) is not k * dt for the "
                            f"{plan.horizon + 1} samples of the plan at dt = {plan.dt:g} s")
    return plan


def record_frame(rec: dict[str, Any], path: str | Path) -> TaskFrame:
    """The record's task frame, checked; the task's default frame for a file written before
    plans recorded one."""
    from judgeopt.formats.frame import FrameError, task_frame
    from judgeopt.tasks import DEFAULT_TASK, TaskError, get_task

    try:  # a record's frame was checked when planned: a failure here is an edited file
        return task_frame(rec.get("frame"), get_task(rec["problem"].get("task", DEFAULT_TASK)))
    except (FrameError, TaskError) as exc:
        raise PlanFileError(f"{path}: field 'frame': {exc}") from None
