"""`judgeopt import-demos` and `export-demos`: recordings (CSV, robomimic-style HDF5, LeRobot v3,
ROS 2 MCAP bags) into the dataset format, and a dataset back out as CSV."""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path
from typing import Any

from judgeopt.cli.commands import HELP
from judgeopt.cli.common import OVERWRITE, CLIError, ExitCode, command_line, number, out_option
from judgeopt.data.recording import ALIGN, FIT, ImportSpec
from judgeopt.files import refuse_overwrite
from judgeopt.tasks import DEFAULT_TASK
from judgeopt.trajectory import DEFAULT_DT, DEFAULT_HORIZON

#: skipped recordings listed one by one; the rest counted by their fix
SHOWN = 10


def recordings(files: list[str], out: str, labels: str | None = None) -> list[Path]:
    """The paths to import: files as given; a folder a reader reads whole (a LeRobot dataset, a ROS 2
    bag) as one path; any other folder as the recordings in it, by suffix or content (not the
    output being written, nor the labels file)."""
    from judgeopt.data.readers.registry import inputs, listed, reader_for

    paths: list[Path] = []
    for p in map(Path, files):
        if p.is_dir() and reader_for(p) is None:
            paths += listed(p, skip=[x for x in (out, labels) if x])
        else:
            paths.append(p)
    if not paths:
        raise CLIError(f"no recordings in {files}: no {inputs()}", ExitCode.BAD_INPUT)
    return paths


def import_spec(args: argparse.Namespace) -> Any:
    """The ImportSpec the shared flags describe (what every reader takes)."""
    from judgeopt.data.labels import parse_assignments, read_labels
    from judgeopt.data.recording import ImportError_
    from judgeopt.tasks import get_task

    task = get_task(args.task)
    env_names = tuple(n for n in args.env_names.split(",") if n) if args.env_names else task.env_names
    kinds = {"t": "t", **{c.name: c.kind for c in task.channels}}
    try:
        return ImportSpec(
            env_names, dt=args.dt, horizon=args.horizon, task=task.name,
            scale=parse_assignments(args.scale, "--scale", list(kinds), units=True, kinds=kinds),
            offset=parse_assignments(args.offset, "--offset", [c.name for c in task.channels_of("position")]),
            labels=read_labels(args.labels) if args.labels else None,
            env_values=parse_assignments(args.env, "--env", env_names),
            start=args.start, end=args.end, align=args.align, contact_force=args.contact_force, lead=args.lead,
            fit="crop" if args.crop_to_horizon else args.fit, tare=args.tare)
    except ImportError_ as exc:
        raise CLIError(str(exc)) from None


def reader_options(args: argparse.Namespace, paths: list[Path], spec: Any) -> dict[str, Any]:
    """Each reader's options from its own flags (judgeopt.data.readers.registry), for the readers
    of `paths`; a flag given where no input it applies to is, is refused naming the flags that do."""
    from judgeopt.data.readers.registry import READERS, flags, inputs, reader_for
    from judgeopt.data.recording import ImportError_

    present = {r.name for r in map(reader_for, paths) if r is not None}
    every = flags()
    for spelling, (flag, readers) in every.items():
        if getattr(args, flag.dest, None) is None or present & {r.name for r in readers}:
            continue
        instead = [s for s, (f, rs) in every.items() if flag.kind and f.kind == flag.kind
                   and present & {r.name for r in rs}]
        raise CLIError(f"{spelling} {flag.does}; no {inputs(readers)} is given"
                       + (f" (for the inputs given: {', '.join(instead)})" if instead else ""))
    try:
        return {name: r.configure(vars(args), spec) for name, r in READERS.items() if name in present}
    except ImportError_ as exc:
        raise CLIError(str(exc)) from None


def cmd_import_demos(args: argparse.Namespace) -> int:
    from judgeopt.data.dataset import save
    from judgeopt.data.importer import import_demos, report

    paths = recordings(args.files, args.out, args.labels)
    refuse_overwrite([args.out], args.overwrite)
    spec = import_spec(args)
    ds, errors = import_demos(paths, spec, reader_options(args, paths, spec))
    if ds is None and len(errors) == 1:  # one bad input: its reason is the one line
        raise CLIError(f"nothing imported: {errors[0]}", ExitCode.BAD_INPUT)
    for e in errors[:SHOWN]:
        print(f"judgeopt import-demos: skipped: {e}", file=sys.stderr)
    for fix, n in Counter(e.rpartition("; ")[2] for e in errors[SHOWN:]).most_common():
        print(f"judgeopt import-demos: skipped {n} more" + (f", the fix: {fix}" if n > 1 else f": ...; {fix}"),
              file=sys.stderr)
    if ds is None:
        raise CLIError(f"nothing imported from {len(paths)} file(s): every demonstration was bad (reasons above)",
                       ExitCode.BAD_INPUT)
    ds.meta["command"] = command_line()
    save(ds, args.out)
    skipped = sum(not e.startswith("--labels") for e in errors)  # a labels file's unused rows skip nothing
    print(f"wrote {args.out}: {ds.n} demonstrations from {ds.meta['files_imported']} of {len(paths)} file(s) "
          f"({skipped} skipped), success ratio {ds.success_ratio():.2f}, resampled to dt = {ds.dt} s, "
          f"N = {ds.horizon}")
    for line in report(ds):
        print(f"  {line}")
    return 0


def cmd_export_demos(args: argparse.Namespace) -> int:
    from judgeopt.data.dataset import load
    from judgeopt.data.export import export_csv

    refuse_overwrite([args.out], args.overwrite)
    ds = load(args.data)
    export_csv(ds, args.out)
    print(f"wrote {args.out}: {ds.n} demonstrations x {ds.horizon + 1} samples (dt = {ds.dt} s); import it back "
          f"with: judgeopt import-demos {args.out} --task {ds.task} --env-names {','.join(ds.env_names)} "
          f"--dt {ds.dt} --horizon {ds.horizon} --out FILE.h5")
    return 0


def add_import_flags(m: argparse.ArgumentParser) -> None:
    """Where the recordings keep each value, and which part of them is kept."""
    m.add_argument("--task", default=DEFAULT_TASK, help="whose channels the recordings hold (the scoop's: y [m], "
                   "ydot [m/s], f [N]; `judgeopt tasks` lists them)")
    m.add_argument("--env-names", metavar="A,B", help="environment values, comma-separated (default: the task's, "
                   "`judgeopt tasks` lists them)")
    m.add_argument("--scale", metavar="NAME=FACTOR|UNIT,...", help="convert as read: a factor or the unit recorded, "
                   "signed, e.g. 'f=-1' (a sensor whose z axis points into the tool), 'y=mm', 'f=-N', 't=ms' (default: SI "
                   "units, pressing positive)")
    m.add_argument("--offset", metavar="NAME=M,...", help="added to a position after --scale, to move the recording's "
                   "origin to the task's (e.g. 'y=-1.2'; default: none)")
    m.add_argument("--labels", metavar="FILE", help="a CSV of outcomes for recordings that carry none: a header with a "
                   "recording column (file, name, demo_id, ...) and an outcome column (success, label, ...), e.g. "
                   "'file,success' then 'demo_0001.csv,1' (default: none; labels from the recordings)")
    m.add_argument("--env", action="append", metavar="NAME=VALUE", help="an environment value the recordings do not "
                   "carry, the same for all (e.g. --env NAME=0.246; repeat or comma-separate for several; default: none, "
                   "read from the recordings)")
    m.add_argument("--tare", action="store_true", help="subtract each force's mean over the rest before the motion "
                   "(a force sensor's bias); needs at least 0.05 s at rest before the motion")
    w = m.add_argument_group("which part of a recording is kept (then resampled to dt over N·dt)")
    w.add_argument("--start", type=number, default=0.0, metavar="S",
                   help="crop: drop what comes before S seconds after the first time stamp")
    w.add_argument("--end", type=number, metavar="S", help="crop: drop what comes after S seconds after the first "
                   "time stamp (default: keep to the end)")
    w.add_argument("--align", choices=ALIGN, default=ImportSpec.align,
                   help="start: keep from --start; contact: from --lead s before the force first exceeds "
                   "--contact-force; onset: from --lead s before the position first leaves rest (each recording its "
                   "own)")
    w.add_argument("--contact-force", type=number, default=ImportSpec.contact_force, metavar="N",
                   help="force magnitude in N that marks contact onset, for --align contact")
    w.add_argument("--lead", "--pre-contact", dest="lead", type=number, default=ImportSpec.lead, metavar="S",
                   help="seconds kept before contact or motion onset (clipped at --start); also after the motion's "
                   "end for --fit resample")
    w.add_argument("--fit", choices=FIT, default=ImportSpec.fit, help="a window longer than N·dt: refuse it (naming "
                   "its duration); crop: keep its first N·dt s, refused when the motion ends later (its label would "
                   "belong to what was cut); resample: every motion, onset to end, stretched onto N·dt")
    w.add_argument("--crop-to-horizon", action="store_true", help="the same as --fit crop")
    m.add_argument("--dt", type=number, default=DEFAULT_DT, metavar="S", help="planner sample period in s")
    m.add_argument("--horizon", type=int, default=DEFAULT_HORIZON, metavar="N", help="planner steps N")
    add_reader_flags(m)


def add_reader_flags(m: argparse.ArgumentParser) -> None:
    """Each reader's own flags (judgeopt.data.readers.registry), grouped by the formats that take them."""
    from judgeopt.data.readers.registry import flags

    groups: dict[str, Any] = {}
    shared_last = sorted(flags().items(), key=lambda item: len(item[1][1]) > 1)
    for spelling, (flag, readers) in shared_last:
        title = " and ".join(r.title for r in readers)
        if title not in groups:
            groups[title] = m.add_argument_group(f"options of {title}")
        groups[title].add_argument(spelling, dest=flag.dest, metavar=flag.metavar, type=flag.type, help=flag.help)


def add_recording_commands(sub: Any) -> None:
    """The parsers of import-demos and export-demos (called by `judgeopt.cli.main.build_parser`)."""
    m = sub.add_parser(
        "import-demos", help=HELP["import-demos"],
        description="CSV columns: t [s], y [m], optional ydot [m/s], f [N], label (success/failure), the environment "
        "columns, optional demo_id (several demonstrations in one table). HDF5 (.h5/.hdf5, robomimic layout): "
        "data/demo_N groups with t (or a dt/control_freq attribute), y, optional ydot, f as datasets in the group or "
        "under obs/, a success attribute (or success/rewards/dones dataset) and the environment values as attributes "
        "(or in env_args). LeRobot v3 (a folder with meta/info.json and data/chunk-*/file-*.parquet): one "
        "demonstration per episode, columns chosen with --keys. ROS 2 bags (a rosbag2 folder with metadata.yaml and "
        ".mcap, or a .mcap file): PoseStamped and WrenchStamped topics chosen with --topics, each stream at its own "
        "rate, one demonstration per bag or per episode (--topics episode=TOPIC). Each demonstration is validated, "
        "cropped (--start/--end, --align contact) and resampled to the planner's period; bad CSV files, HDF5 demo "
        "groups, LeRobot episodes and bags are reported (file, row/demo group/episode/topic, column/field) and the "
        "rest imported.",
        parents=[out_option("FILE", "HDF5 dataset to write", required=True), OVERWRITE])
    m.add_argument("files", nargs="+", help="CSV, HDF5 or .mcap files, LeRobot dataset folders, ROS 2 bag folders, or "
                   "folders of these")
    add_import_flags(m)
    m.set_defaults(func=cmd_import_demos)

    e = sub.add_parser(
        "export-demos", help=HELP["export-demos"],
        description="Columns demo_id, t [s], the channels (the scoop's y [m], ydot [m/s], f [N]), label "
        "(success/failure) and the environment values, one row per sample; `judgeopt import-demos` reads it back "
        "to the same dataset. The responses are written (an imported dataset holds its recordings as both commands "
        "and responses).",
        parents=[out_option("FILE", "CSV file to write", required=True), OVERWRITE])
    e.add_argument("data", metavar="DATA.h5", help="dataset (HDF5) to export")
    e.set_defaults(func=cmd_export_demos)
