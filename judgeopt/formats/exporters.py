"""Plans out to a robot's tools, by format: a registry the command line reads (`judgeopt export
--format`, the suffix of `--out` and of `solve --export`). Each exporter writes a plan record
(judgeopt.formats.plan) at the controller's step; adding one is an entry here.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from judgeopt.formats.plan import plan_from_record, record_frame
from judgeopt.trajectory import Plan, PlanError


@dataclass(frozen=True)
class Exporter:
    name: str
    suffix: str
    #: what the written file holds, one line (printed after writing)
    holds: str
    #: (plan, record, out, step, source, start_ns) -> the path written
    write: Callable[[Plan, dict[str, Any], Path, float, str | Path, int], Path]


def _csv(plan: Plan, rec: dict[str, Any], out: Path, step: float, source: str | Path, start_ns: int) -> Path:
    from judgeopt.formats.table_csv import write_plan_csv

    return write_plan_csv(plan, out, step, env=rec["environment"])


def _mcap(plan: Plan, rec: dict[str, Any], out: Path, step: float, source: str | Path, start_ns: int) -> Path:
    from judgeopt.formats.mcap import write_mcap

    info = {k: rec.get(k) for k in ("method", "environment", "predicted_success", "success_probability",
                                    "probability_source", "verdict", "simulated_success", "provenance")}
    info["problem"] = {k: rec["problem"].get(k) for k in ("name", "task", "source")}
    return write_mcap(plan, record_frame(rec, source), out, info, step, start_ns)


EXPORTERS: dict[str, Exporter] = {e.name: e for e in (
    Exporter("csv", ".csv", "the importer's columns: t, each channel, the environment; add a label column to a "
             "recording of its execution", _csv),
    Exporter("mcap", ".mcap", "ROS 2: /judgeopt/pose, /judgeopt/twist, /judgeopt/wrench, /judgeopt/plan_info", _mcap),
)}


def exporter_for(out: str | Path, name: str | None = None) -> Exporter:
    """The exporter named, else the one `out`'s suffix names."""
    if name is not None:
        if name not in EXPORTERS:
            raise PlanError(f"export format {name!r} is not one of {', '.join(EXPORTERS)}")
        return EXPORTERS[name]
    found = [e for e in EXPORTERS.values() if e.suffix == Path(out).suffix.lower()]
    if not found:
        raise PlanError(f"{out}: cannot tell the format from the suffix {Path(out).suffix!r}: name the file "
                        f"{' or '.join(e.suffix for e in EXPORTERS.values())}, or give --format")
    return found[0]


def export_record(rec: dict[str, Any], out: str | Path, fmt: str | None = None, step: float = 1e-3,
                  source: str | Path = "plan", start_ns: int = 0) -> Path:
    """A plan record out to a robot as `fmt` (else from `out`'s suffix) at `step` (the controller's
    1 ms); `source` is where the record came from, for messages."""
    exporter = exporter_for(out, fmt)
    plan = plan_from_record(rec, source)
    if not (isinstance(step, (int, float)) and 0 < step <= plan.dt):
        raise PlanError(f"export step {step!r} s must be positive and at most the plan's period {plan.dt:g} s")
    return exporter.write(plan, rec, Path(out), step, source, start_ns)
