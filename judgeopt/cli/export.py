"""`judgeopt export`: a saved plan (JSON) out to a robot's tools, as CSV or ROS 2 MCAP; and the
same for `solve --export`."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from judgeopt.cli.common import OVERWRITE, CLIError, out_option
from judgeopt.files import refuse_overwrite

FORMAT_CHOICES = ("csv", "mcap")


def export_format(out: str | Path, fmt: str | None = None) -> str:
    """The format asked for, else the one `out`'s suffix names (.csv, .mcap)."""
    from judgeopt.planners.export import FORMATS

    found = fmt or FORMATS.get(Path(out).suffix.lower())
    if found is None:
        raise CLIError(f"{out}: cannot tell the format from the suffix {Path(out).suffix!r}: name the file "
                       f"{' or '.join(FORMATS)}, or give --format")
    return found


def export_record_to(rec: dict[str, Any], out: str | Path, fmt: str | None = None, step: float = 1e-3,
                     source: str | Path = "plan", start_ns: int = 0) -> Path:
    """One plan record to `out` (format from `fmt` or the suffix)."""
    from judgeopt.planners.export import export_record

    return export_record(rec, out, export_format(out, fmt), step=step, path=source, start_ns=start_ns)


def cmd_export(args: argparse.Namespace) -> int:
    from judgeopt.planners.export import read_plan_record

    fmt = export_format(args.out, args.format)
    refuse_overwrite([args.out], args.overwrite)
    rec = read_plan_record(args.plan)
    path = export_record_to(rec, args.out, fmt, args.step, args.plan, int(round(args.start_time * 1e9)))
    what = ("importer columns: t, " + ", ".join(rec["plan"].get("channels", [])) + ", the environment; add a "
            "label column to a recording of its execution") if fmt == "csv" else \
        "ROS 2: /judgeopt/pose, /judgeopt/twist, /judgeopt/wrench, /judgeopt/plan_info"
    print(f"wrote {path} ({fmt}, every {args.step * 1e3:g} ms; {what})")
    return 0


def add_export_commands(sub: argparse._SubParsersAction) -> None:
    e = sub.add_parser("export", help="write a saved plan (solve --save-json) as CSV or ROS 2 MCAP for a robot",
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
    e.add_argument("--format", choices=FORMAT_CHOICES, help="csv or mcap (default: from the --out suffix)")
    e.add_argument("--step", type=float, default=1e-3, metavar="S",
                   help="sample period of the written commands in s (default 0.001: the controller's 1 kHz)")
    e.add_argument("--start-time", type=float, default=0.0, metavar="S",
                   help="MCAP: time stamp of the first sample in s since the epoch (default 0: the plan's own time)")
    e.set_defaults(func=cmd_export)
