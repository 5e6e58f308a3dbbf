"""`judgeopt export`: a saved plan (JSON) out to a robot's tools, as CSV or ROS 2 MCAP; and the
same for `solve --export`."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from judgeopt.cli.commands import HELP
from judgeopt.cli.common import OVERWRITE, CLIError, number, out_option
from judgeopt.files import refuse_overwrite
from judgeopt.trajectory import PlanError


def export_format(out: str | Path, fmt: str | None = None) -> str:
    """The format asked for, else the one `out`'s suffix names (judgeopt.formats.exporters)."""
    from judgeopt.formats.exporters import exporter_for

    try:
        return exporter_for(out, fmt).name
    except PlanError as exc:
        raise CLIError(str(exc)) from None


def export_record_to(rec: dict[str, Any], out: str | Path, fmt: str | None = None, step: float = 1e-3,
                     source: str | Path = "plan", start_ns: int = 0) -> Path:
    """One plan record to `out` (format from `fmt` or the suffix)."""
    from judgeopt.formats.exporters import export_record

    return export_record(rec, out, export_format(out, fmt), step=step, source=source, start_ns=start_ns)


def cmd_export(args: argparse.Namespace) -> int:
    from judgeopt.formats.plan import read_plan_record

    fmt = export_format(args.out, args.format)
    refuse_overwrite([args.out], args.overwrite)
    rec = read_plan_record(args.plan)
    path = export_record_to(rec, args.out, fmt, args.step, args.plan, int(round(args.start_time * 1e9)))
    from judgeopt.formats.exporters import EXPORTERS

    print(f"wrote {path} ({fmt}, every {args.step * 1e3:g} ms; {EXPORTERS[fmt].holds})")
    return 0


def add_export_commands(sub: argparse._SubParsersAction) -> None:
    e = sub.add_parser("export", help=HELP["export"],
                       description="CSV: the importer's columns (t [s], each channel by name in m, m/s, N, then the "
                       "environment the plan was made for), resampled to --step, so a recording of the executed "
                       "plan in the same columns plus a label column (success/failure) re-imports with "
                       "`judgeopt import-demos`. MCAP: ROS 2 messages per sample along the problem's task frame "
                       "([frame] in the problem file; default: the task's axes in base_link): PoseStamped on "
                       "/judgeopt/pose, TwistStamped on /judgeopt/twist, WrenchStamped on /judgeopt/wrench, and the "
                       "plan's provenance as JSON on /judgeopt/plan_info (needs pip install 'judgeopt[ros]'); play "
                       "it with `ros2 bag play -s mcap FILE`.",
                       parents=[out_option("FILE", "file to write (.csv or .mcap)", required=True), OVERWRITE])
    e.add_argument("plan", help="plan JSON file (judgeopt solve --save-json)")
    from judgeopt.formats.exporters import EXPORTERS

    e.add_argument("--format", choices=tuple(EXPORTERS), help=f"{' or '.join(EXPORTERS)} (default: from the --out "
                   "suffix)")
    e.add_argument("--step", type=number, default=1e-3, metavar="S",
                   help="sample period of the written commands in s (default 0.001: the controller's 1 kHz)")
    e.add_argument("--start-time", type=number, default=0.0, metavar="S",
                   help="MCAP: time stamp of the first sample in s since the epoch (default 0: the plan's own time)")
    e.set_defaults(func=cmd_export)
