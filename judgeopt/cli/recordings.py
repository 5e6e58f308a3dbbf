"""`judgeopt import-demos` and `export-demos`: recordings (CSV, robomimic-style HDF5, LeRobot v3,
ROS 2 MCAP bags) into the dataset format, and a dataset back out as CSV."""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path
from typing import Any

from judgeopt.cli.common import OVERWRITE, CLIError, ExitCode, command_line, out_option
from judgeopt.data.recording import ALIGN, FIT, ImportSpec
from judgeopt.files import refuse_overwrite
from judgeopt.tasks import DEFAULT_TASK
from judgeopt.trajectory import DEFAULT_DT, DEFAULT_HORIZON

#: skipped recordings listed one by one; the rest counted by their fix
SHOWN = 10


def recordings(files: list[str], out: str, labels: str | None = None) -> list[Path]:
    """The paths to import: files as given; a LeRobot dataset folder (meta/info.json) or a ROS 2
    bag folder (metadata.yaml) as one path; any other folder as its .csv/.h5/.hdf5/.mcap files and
    bag folders (not the output being written)."""
    from judgeopt.data.importer import HDF5_SUFFIXES
    from judgeopt.data.lerobot import is_lerobot
    from judgeopt.data.ros2 import is_bag

    paths: list[Path] = []
    for p in map(Path, files):
        if p.is_dir() and not is_lerobot(p) and not is_bag(p):
            skip = {Path(x).resolve() for x in (out, labels) if x}
            paths += sorted(f for f in p.iterdir() if (f.suffix.lower() in (".csv", *HDF5_SUFFIXES) or is_bag(f))
                            and f.resolve() not in skip)
        else:
            paths.append(p)
    if not paths:
        raise CLIError(f"no .csv, .h5, .hdf5 or .mcap files, LeRobot dataset folders or ROS 2 bags in {files}",
                       ExitCode.BAD_INPUT)
    return paths


def import_spec(args: argparse.Namespace, paths: list[Path]) -> Any:
    """The ImportSpec the flags describe, each flag checked against the inputs it applies to."""
    from judgeopt.data.importer import HDF5_SUFFIXES, ImportError_, ImportSpec, parse_hdf5_keys
    from judgeopt.data.lerobot import is_lerobot
    from judgeopt.data.labels import parse_assignments, read_labels
    from judgeopt.data.recording import parse_keys
    from judgeopt.data.ros2 import is_bag, parse_topics
    from judgeopt.tasks import get_task

    task = get_task(args.task)
    hdf5 = any(p.suffix.lower() in HDF5_SUFFIXES for p in paths)
    if args.filter_key and not hdf5:
        raise CLIError("--filter-key selects demo groups of HDF5 files (mask/NAME); no .h5/.hdf5 file is given")
    lerobot = any(is_lerobot(p) for p in paths)
    if args.success_threshold is not None and not (hdf5 or lerobot):
        raise CLIError("--success-threshold labels HDF5 rewards or LeRobot next.reward; a CSV file has its own "
                       "label column")
    if args.keys and not lerobot:
        raise CLIError("--keys maps LeRobot columns; no LeRobot dataset folder (with meta/info.json) is given "
                       "(HDF5 files: --hdf5-keys)")
    if args.topics and not any(is_bag(p) for p in paths):
        raise CLIError("--topics names the topics of ROS 2 bags; no bag (a folder with metadata.yaml, or a .mcap "
                       "file) is given")
    csv = any(p.suffix.lower() == ".csv" for p in paths)
    if args.columns and not csv:
        raise CLIError("--columns maps CSV header columns; no .csv file is given (HDF5: --hdf5-keys, LeRobot: --keys)")
    if args.hdf5_keys and not hdf5:
        raise CLIError("--hdf5-keys maps HDF5 datasets; no .h5/.hdf5 file is given (CSV: --columns)")
    env_names = tuple(n for n in args.env_names.split(",") if n) if args.env_names else task.env_names
    kinds = {"t": "t", **{c.name: c.kind for c in task.channels}}
    try:
        return ImportSpec(
            env_names, dt=args.dt, horizon=args.horizon, task=task.name,
            hdf5_keys=parse_hdf5_keys(args.hdf5_keys, env_names, task.channel_names),
            lerobot_keys=parse_keys(args.keys, env_names, task.channel_names, flag="--keys", scalars=("success",),
                                    columns_everywhere=True),
            ros_topics=parse_topics(args.topics, env_names,
                                    [c.name for c in task.channels if c.kind in ("position", "force")]),
            columns=parse_keys(args.columns, env_names, task.channel_names, flag="--columns",
                               scalars=("label", "demo_id")),
            scale=parse_assignments(args.scale, "--scale", list(kinds), units=True, kinds=kinds),
            offset=parse_assignments(args.offset, "--offset", [c.name for c in task.channels_of("position")]),
            labels=read_labels(args.labels) if args.labels else None,
            env_values=parse_assignments(args.env, "--env", env_names),
            start=args.start, end=args.end, align=args.align, contact_force=args.contact_force, lead=args.lead,
            fit="crop" if args.crop_to_horizon else args.fit, tare=args.tare,
            streams=tuple(x.strip() for x in (args.streams or "").split(",") if x.strip()), filter_key=args.filter_key,
            success_threshold=args.success_threshold)
    except ImportError_ as exc:
        raise CLIError(str(exc)) from None


def cmd_import_demos(args: argparse.Namespace) -> int:
    from judgeopt.data.dataset import save
    from judgeopt.data.importer import import_demos, report

    paths = recordings(args.files, args.out, args.labels)
    refuse_overwrite([args.out], args.overwrite)
    ds, errors = import_demos(paths, import_spec(args, paths))
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
                   "the scoop's y_obj,mu)")
    m.add_argument("--hdf5-keys", metavar="NAME=PATH[:COL],...",
                   help="where an HDF5 file keeps t, a channel (the scoop's y, ydot, f), success, dt or an environment "
                   "value, e.g. 'y=obs/robot0_eef_pos:1,f=obs/ft:2,mu=friction' (:COL picks a column of a (T, k) "
                   "array; default: the names themselves, then under obs/)")
    m.add_argument("--keys", metavar="NAME=COLUMN[:INDEX],...",
                   help="where a LeRobot dataset keeps t, a channel, success or an environment value, e.g. "
                   "'y=observation.state:1,f=observation.force:2,success=next.success' (:INDEX picks one element of a "
                   "vector column; default: t from timestamp, success from next.success/next.reward/next.done, "
                   "the rest from columns of their own name)")
    m.add_argument("--topics", metavar="NAME=TOPIC[:AXIS],...",
                   help="which topics of a ROS 2 bag hold a channel (NAME=TOPIC:AXIS, AXIS x, y or z: a position of "
                   "a geometry_msgs/msg/PoseStamped, a force of a WrenchStamped), the start of each episode "
                   "(episode=TOPIC, std_msgs Int32 or String; default: one bag, one demonstration), the label "
                   "(label=TOPIC, std_msgs "
                   "Bool or String) or an environment value (NAME=TOPIC, std_msgs Float64), e.g. "
                   "'y=/tool/pose:y,f=/ft/wrench:z,episode=/episode'")
    m.add_argument("--filter-key", metavar="NAME", help="HDF5: import only the demo groups robomimic's filter key "
                   "mask/NAME lists, e.g. train or valid (default: every demo group)")
    m.add_argument("--success-threshold", type=float, metavar="X", help="label dense rewards: success when the "
                   "largest reward of a demonstration (HDF5 'rewards', LeRobot next.reward) is >= X, in the reward's "
                   "own units (default: none; the last value of the success flag, 1 or 0)")
    m.add_argument("--columns", metavar="NAME=COLUMN,...", help="where a CSV file keeps t, a channel (the scoop's "
                   "y, ydot, f), label, demo_id or an environment value, e.g. 't=time,y=tool_y_m,f=fz_N' (default: "
                   "columns of those names). A channel whose cells are empty on some rows was recorded at its own rate")
    m.add_argument("--scale", metavar="NAME=FACTOR|UNIT,...", help="convert as read: a factor or the unit recorded, "
                   "signed, e.g. 'f=-1' (a sensor whose z axis points into the tool), 'y=mm', 'f=-N', 't=ms' (default: SI "
                   "units, pressing positive)")
    m.add_argument("--offset", metavar="NAME=M,...", help="added to a position after --scale, to move the recording's "
                   "origin to the task's (e.g. 'y=-1.2'; default: none)")
    m.add_argument("--labels", metavar="FILE", help="a CSV of outcomes for recordings that carry none: a header with a "
                   "recording column (file, name, demo_id, ...) and an outcome column (success, label, ...), e.g. "
                   "'file,success' then 'demo_0001.csv,1' (default: none; labels from the recordings)")
    m.add_argument("--env", action="append", metavar="NAME=VALUE", help="an environment value the recordings do not "
                   "carry, the same for all (e.g. --env y_obj=0.246; repeat or comma-separate for several; default: none, "
                   "read from the recordings)")
    m.add_argument("--streams", metavar="A,B", help="a recording kept as one CSV per stream, NAME_A.csv and "
                   "NAME_B.csv (e.g. --streams mocap,ft: demo_01_mocap.csv with t,y and demo_01_ft.csv with t,f), "
                   "merged on time (default: one file per recording)")
    m.add_argument("--tare", action="store_true", help="subtract each force's mean over the rest before the motion "
                   "(a force sensor's bias); needs at least 0.05 s at rest before the motion")
    w = m.add_argument_group("which part of a recording is kept (then resampled to dt over N·dt)")
    w.add_argument("--start", type=float, default=0.0, metavar="S",
                   help="crop: drop what comes before S seconds after the first time stamp")
    w.add_argument("--end", type=float, metavar="S", help="crop: drop what comes after S seconds after the first "
                   "time stamp (default: keep to the end)")
    w.add_argument("--align", choices=ALIGN, default=ImportSpec.align,
                   help="start: keep from --start; contact: from --lead s before the force first exceeds "
                   "--contact-force; onset: from --lead s before the position first leaves rest (each recording its "
                   "own)")
    w.add_argument("--contact-force", type=float, default=ImportSpec.contact_force, metavar="N",
                   help="force magnitude in N that marks contact onset, for --align contact")
    w.add_argument("--lead", "--pre-contact", dest="lead", type=float, default=ImportSpec.lead, metavar="S",
                   help="seconds kept before contact or motion onset (clipped at --start); also after the motion's "
                   "end for --fit resample")
    w.add_argument("--fit", choices=FIT, default=ImportSpec.fit, help="a window longer than N·dt: refuse it (naming "
                   "its duration); crop: keep its first N·dt s, refused when the motion ends later (its label would "
                   "belong to what was cut); resample: every motion, onset to end, stretched onto N·dt")
    w.add_argument("--crop-to-horizon", action="store_true", help="the same as --fit crop")
    m.add_argument("--dt", type=float, default=DEFAULT_DT, metavar="S", help="planner sample period in s")
    m.add_argument("--horizon", type=int, default=DEFAULT_HORIZON, metavar="N", help="planner steps N")


def add_recording_commands(sub: Any) -> None:
    """The parsers of import-demos and export-demos (called by `judgeopt.cli.main.build_parser`)."""
    m = sub.add_parser(
        "import-demos", help="import recorded demonstrations (CSV, robomimic-style HDF5, LeRobot v3 or ROS 2 MCAP "
        "bags) into the dataset format",
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
        "export-demos", help="write a dataset as one CSV table in the importer's format",
        description="Columns demo_id, t [s], the channels (the scoop's y [m], ydot [m/s], f [N]), label "
        "(success/failure) and the environment values, one row per sample; `judgeopt import-demos` reads it back "
        "to the same dataset. The responses are written (an imported dataset holds its recordings as both commands "
        "and responses).",
        parents=[out_option("FILE", "CSV file to write", required=True), OVERWRITE])
    e.add_argument("data", metavar="DATA.h5", help="dataset (HDF5) to export")
    e.set_defaults(func=cmd_export_demos)
