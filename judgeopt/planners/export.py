"""Plans out of judgeopt: 1 kHz CSV for a real controller, a self-contained JSON record with
provenance (so a run on a real arm can be traced back to the models, code and command that
planned it, and replayed), and the Figs. 15-18-style plot (a matplotlib Figure).

Plan JSON (format "judgeopt-plan", version 2; `write_json`, read back by `read_plan_json`, which
also reads version 1, whose columns were always q, qdot, f):

    format, format_version
    method, status, message, solve_time_s, iterations
    environment                 {name: value}
    predicted_success           the judge's score of the plan
    success_probability         the probability judgeopt stands behind: calibrated on replayed
                                outcomes of this planner setting where a calibration covers it,
                                else the judge's; probability_source says which ("calibrated",
                                "judge"); verdict "likely" (>= 0.5) or "unlikely"
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
    provenance                  judge {path, weights_sha256}, generator {path, weights_sha256,
                                role} or null, judgeopt_version, git_commit, git_dirty (null
                                outside a git checkout), command, created (UTC, ISO 8601),
                                python, platform
    frame                       the task frame (judgeopt.planners.frame: frame_id, origin,
                                orientation, axes), defaults filled in; absent in files written
                                before it, which `record_frame` reads as the task's default frame

Non-finite numbers are written as null (strict JSON).

Out to a robot (`export_record`, `judgeopt export`): CSV with the importer's columns
(judgeopt.data.importer: t, each channel by name, then the environment the plan was made for;
SI units s, m, m/s, N), so a recording of the executed plan in the same columns plus `label`
re-imports unchanged; or MCAP with ROS 2 messages along the task frame (judgeopt.planners.ros).
"""

from __future__ import annotations

import io
import json
import math
import platform
import subprocess
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from judgeopt.files import REPO, atomic_write
from judgeopt.planners.problem import Problem
from judgeopt.planners.result import PlanResult
from judgeopt.planners.frame import TaskFrame
from judgeopt.trajectory import Plan, PlanError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

PLAN_FORMAT = "judgeopt-plan"
PLAN_VERSION = 2  # 2: the plan's columns named by the task's channels (1: always q, qdot, f)
#: the fields `read_plan_json` requires (a file without them is not a usable record)
REQUIRED_FIELDS = ("format_version", "method", "environment", "plan", "problem", "provenance")
V1_COLUMNS = ("q", "qdot", "f")  # a version-1 file's columns: the scoop's y, ydot, f


class PlanFileError(PlanError):
    """A plan JSON file that is missing, corrupt, of another format or lacking fields."""


#: what `export_record` writes, by file suffix
FORMATS = {".csv": "csv", ".mcap": "mcap"}


def write_csv(plan: Plan, path: str | Path, step: float = 1e-3, env: dict[str, float] | None = None) -> Path:
    """Commands at `step` (1 ms): Hermite-interpolated position/velocity, linear force; the
    same interpolation the simulated controller applies. Columns are the importer's (t, the
    channels by name, SI units; then `env`'s values, constant), so a recording of the executed
    plan with a `label` column added re-imports unchanged. Written atomically."""
    t, x = plan.resample(step)
    env = env or {}
    header = ",".join(["t", *(c.name for c in plan.channels), *env])
    table = np.column_stack([t, x, np.tile([float(v) for v in env.values()], (len(t), 1))])
    buf = io.StringIO()
    np.savetxt(buf, table, delimiter=",", fmt="%.9g", header=header, comments="")
    atomic_write(path, buf.getvalue())
    return Path(path)


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
    from judgeopt.judge.store import model_paths

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


def plan_record(result: PlanResult, problem: Problem, provenance: dict[str, Any], step: float = 1e-3) -> dict[str, Any]:
    """The JSON record of one planner's result (the module docstring lists its fields)."""
    plan = result.plan
    if plan is None:
        raise PlanError(f"{result.method}: no plan to export (status {result.status}: {result.message})")
    names = [c.name for c in plan.channels]
    units = {"t": "s", **{c.name: c.unit for c in plan.channels}}
    t, fine = plan.resample(step)
    prov = dict(provenance)
    role = ("planner" if result.method == "amortized"
            else "warm start" if result.info.get("warm_start") == "generator" else None)
    prov["generator"] = {**prov["generator"], "role": role} if role and prov.get("generator") else None
    sim = {k.removeprefix("sim_"): v for k, v in result.info.items() if k.startswith("sim_")}
    other = {k: v for k, v in result.info.items() if not k.startswith("sim_")}
    record = {
        "format": PLAN_FORMAT, "format_version": PLAN_VERSION,
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


def write_json(result: PlanResult, problem: Problem, path: str | Path, provenance: dict[str, Any],
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
    if not isinstance(rec, dict) or rec.get("format") != PLAN_FORMAT:
        got = rec.get("format") if isinstance(rec, dict) else type(rec).__name__
        raise PlanFileError(f"{path}: not a judgeopt plan file (format is {got!r}, expected {PLAN_FORMAT!r})")
    missing = [k for k in REQUIRED_FIELDS if k not in rec]
    if missing:
        raise PlanFileError(f"{path}: missing field(s) {missing}")
    version = rec["format_version"]
    if not isinstance(version, int) or isinstance(version, bool):
        raise PlanFileError(f"{path}: format_version {version!r} is not an integer")
    if version > PLAN_VERSION:
        raise PlanFileError(f"{path}: plan format version {version} is newer than this judgeopt reads "
                            f"({PLAN_VERSION}); update judgeopt")
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
    from judgeopt.planners.frame import FrameError, task_frame
    from judgeopt.tasks import DEFAULT_TASK, TaskError, get_task

    try:  # a record's frame was checked when planned: a failure here is an edited file
        return task_frame(rec.get("frame"), get_task(rec["problem"].get("task", DEFAULT_TASK)))
    except (FrameError, TaskError) as exc:
        raise PlanFileError(f"{path}: field 'frame': {exc}") from None


def export_record(rec: dict[str, Any], out: str | Path, fmt: str, step: float = 1e-3,
                  path: str | Path = "plan", start_ns: int = 0) -> Path:
    """A plan record out to a robot as `fmt` ("csv" or "mcap", `FORMATS`) at `step` (the
    controller's 1 ms); `path` is where the record came from, for messages."""
    if fmt not in FORMATS.values():
        raise PlanError(f"export format {fmt!r} is not one of {', '.join(FORMATS.values())}")
    plan = plan_from_record(rec, path)
    if not (isinstance(step, (int, float)) and 0 < step <= plan.dt):
        raise PlanError(f"export step {step!r} s must be positive and at most the plan's period {plan.dt:g} s")
    if fmt == "csv":
        return write_csv(plan, out, step, env=rec["environment"])
    from judgeopt.planners.ros import write_mcap

    info = {k: rec.get(k) for k in ("method", "environment", "predicted_success", "success_probability",
                                    "probability_source", "verdict", "simulated_success", "provenance")}
    info["problem"] = {k: rec["problem"].get(k) for k in ("name", "task", "source")}
    return write_mcap(plan, record_frame(rec, path), out, info, step, start_ns)


def measured(result: PlanResult) -> np.ndarray | None:
    """The replay's response on the plan's channels, or None (not replayed, or refused)."""
    r = result.response
    return r if r is not None and result.plan is not None and r.shape == result.plan.values.shape else None


def plot_plans(problem: Problem, results: Sequence[PlanResult], title: str = "") -> Figure:
    """q, q̇ and f against time, the allowed region unshaded and the forbidden one grey
    (the paper's Figs. 15 and 16), one line per method; where a plan was replayed, what the
    controller measured beside what it was commanded (Figs. 17 and 18)."""
    from matplotlib.figure import Figure

    bounds = {"position": ("q_min", "q_max"), "velocity": ("qdot_min", "qdot_max"), "force": ("f_min", "f_max")}
    rows = []
    for c in problem.channel_spec:  # one panel per channel, its limits shaded
        same_kind = [d.name for d in problem.channel_spec if d.kind == c.kind]
        i = [d.name for d in problem.channel_spec if d.kind == "position"].index(c.of) if c.kind == "velocity" \
            else same_kind.index(c.name)
        lo, hi = (float(problem.vec(b)[i]) for b in bounds[c.kind])
        rows.append((c, f"{c.kind} {c.name} [{c.unit}]", lo, hi, i))
    fig = Figure(figsize=(6.4, 2.4 * len(rows) + 0.8), layout="constrained")
    axes = fig.subplots(len(rows), 1, sharex=True, squeeze=False)[:, 0]
    T = problem.horizon_time
    for j, (ax, (channel, label, lo, hi, axis)) in enumerate(zip(axes, rows)):  # j: the channel's column
        values = [getattr(r.plan, channel.name) for r in results if r.plan is not None]
        values += [m[:, j] for m in map(measured, results) if m is not None]
        span = max(hi - lo, 1e-9)
        top = max([hi + 0.15 * span] + [float(v.max()) for v in values])
        bottom = min([lo - 0.15 * span] + [float(v.min()) for v in values])
        ax.axhspan(hi, top, color="0.85", lw=0)
        ax.axhspan(bottom, lo, color="0.85", lw=0)
        ax.set_ylim(bottom, top)
        for r in results:
            if r.plan is None:
                continue
            v = getattr(r.plan, channel.name)
            p = (f", p = {r.success_probability:.2f} ({r.probability_source}), {r.verdict}"
                 if r.success_probability is not None else "")
            m = measured(r)
            line, = ax.plot(r.plan.t, v, marker=".", ms=3, label=f"{r.method}{p}" + (": command" if m is not None else ""))
            if m is not None:
                ax.plot(r.plan.t, m[:, j], color=line.get_color(), lw=2.2, alpha=0.45,
                        label=f"{r.method}: simulated response ({'success' if r.simulated_success else 'failure'})")
        end = problem.terminal_positions(results[0].env)[axis] if results and channel.kind == "position" else np.nan
        if not np.isnan(end):
            ax.axhline(end, color="k", ls=":", lw=1, label="q_end")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=2, fontsize=7)
    axes[-1].set_xlabel("time [s]")
    axes[-1].set_xlim(0, T)
    env = ", ".join(f"{k} = {v:.3g}" for k, v in results[0].env.items()) if results else ""
    fig.suptitle(title or f"{problem.name}: q̇_max = {problem.qdot_max} m/s ({env})", fontsize=10)
    return fig
