"""The `judgeopt` command line: one subcommand per pipeline stage."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from judgeopt import __version__
from judgeopt.cli.common import CLIError, check_range, command_line, env_range, env_values, set_argv
from judgeopt.files import refuse_overwrite
from judgeopt.tasks import DEFAULT_TASK
from judgeopt.trajectory import DEFAULT_DT, DEFAULT_HORIZON


# -- collect ---------------------------------------------------------------------------
def cmd_collect(args: argparse.Namespace) -> int:
    from judgeopt.data.collect import CollectionSpec, collect
    from judgeopt.tasks import get_task
    from judgeopt.tasks.base import with_setting

    task = get_task(args.task)
    physical = task.env_ranges("physical")
    given = {**dict(args.grid or []), **dict(args.range or [])}
    unknown = [k for k in given if k not in task.env_names]
    if unknown:
        raise CLIError(f"{', '.join(unknown)}: not an environment variable of task {task.name!r} "
                       f"(it has {', '.join(task.env_names)})")
    grid = None
    if args.per_env:
        if task.demo_grid is None and not args.grid:
            raise CLIError(f"task {task.name!r} has no default grid: give --grid NAME=V1,V2,... for each of "
                           f"{', '.join(task.env_names)}")
        grid = {**(task.demo_grid or {}), **dict(args.grid or [])}
        for name, vs in grid.items():
            check_range(name, vs, physical[name])
    elif args.grid:
        raise CLIError("--grid makes a grid: give --per-env N with it (or use --range NAME=LO,HI)")
    ranges = {**task.env_ranges(), **{k: v for k, v in dict(args.range or []).items()}}
    for name, (lo, hi) in ranges.items():
        if lo > hi:
            raise CLIError(f"--range {name}: lower bound {lo} is above upper bound {hi}")
        check_range(name, (lo, hi), physical[name])
    if args.n <= 0 and not args.per_env:
        raise CLIError("--n must be a positive number of demonstrations")
    settings = task.settings()
    for item in args.set or []:
        key, sep, value = item.partition("=")
        if not sep:
            raise CLIError(f"--set {item!r}: give KEY=VALUE, e.g. commands.constant_force_share=0.4")
        settings = with_setting(settings, key, value)
    partial = Path(args.out).with_name(Path(args.out).name + ".partial")
    if not partial.exists():  # an unfinished collection resumes; a finished file is kept
        refuse_overwrite([args.out], args.overwrite)
    spec = CollectionSpec(task=task.name, seed=args.seed, n=args.n, grid=grid, per_env=args.per_env, ranges=ranges,
                          settings=settings)
    ds = collect(spec, args.out, n_jobs=args.jobs, scheduler=args.scheduler, chunk_size=args.chunk,
                 progress=not args.quiet, command=command_line())
    s = ds.summary()
    print(f"wrote {args.out}: {s['n']} demonstrations, success ratio {s['success_ratio']:.3f}, "
          f"{s['errors']} errors")
    return 0


def cmd_tasks(args: argparse.Namespace) -> int:
    from judgeopt.tasks import get_task, task_names

    tasks = [get_task(n).describe() for n in task_names()]
    if args.json:
        print(json.dumps(tasks))
        return 0
    for t in tasks:
        channels = ", ".join(f"{c['name']} [{c['unit'] or '-'}]" for c in t["channels"])
        env = ", ".join(f"{v['name']} in [{v['physical'][0]:g}, {v['physical'][1]:g}]" for v in t["environment"])
        print(f"{t['name']}: {t['description']}\n  channels: {channels}\n  environment: {env}\n"
              f"  horizon: {t['horizon']} steps of {t['dt']:g} s")
    return 0


def cmd_inspect(args: argparse.Namespace) -> int:
    from judgeopt.data.dataset import load
    from judgeopt.cli.judge import format_model_info, inspect_model, is_model_path

    if is_model_path(args.path):
        info = inspect_model(args.path)
        print(json.dumps(info) if args.json else format_model_info(info))
        return 0
    s = load(args.path).summary()
    if args.json:
        print(json.dumps(s))
        return 0
    print(f"{args.path}")
    print(f"  demonstrations : {s['n']}  (source: {s['source']}, seed {s['seed']}, judgeopt {s['package_version']})")
    print(f"  success ratio  : {s['success_ratio']:.3f}")
    print(f"  horizon, dt    : {s['horizon']} samples after the start, {s['dt']} s")
    for name, rng in s["env_range"].items():
        print(f"  {name:<15}: {rng[0]:.4g} .. {rng[1]:.4g}")
    if s["per_env"]:
        print("  per environment:")
        for row in s["per_env"]:
            env = "  ".join(f"{k}={row[k]:.3g}" for k in s["env_names"])
            print(f"    {env}  n={row['n']:<5} success {row['success_ratio']:.3f}")
    print(f"  errors         : {s['errors']}")
    print(f"  made by        : {s['command']}")
    return 0


# -- render ----------------------------------------------------------------------------
def cmd_render(args: argparse.Namespace) -> int:
    from judgeopt.data.dataset import load
    from judgeopt.tasks import get_task

    ds = load(args.data)
    task = get_task(ds.task)
    out = Path(args.out)
    picks: list[int] = []
    for label, count in ((1, args.successes), (0, args.failures)):
        picks += [int(i) for i in np.flatnonzero(ds.labels == label)[:count]]
    if args.index:
        picks = list(args.index)
    if not picks:
        raise CLIError(f"{args.data} has no demonstrations of the requested kind")
    sim = task.simulator()
    for i in picks:
        if not 0 <= i < ds.n:
            raise CLIError(f"--index {i} is out of range: {args.data} holds {ds.n} demonstrations")
        env = dict(zip(ds.env_names, map(float, ds.env[i])))
        plan = task.plan(ds.commands[i], ds.dt)
        name = out / f"demo_{int(ds.index[i]):05d}_{'success' if ds.labels[i] else 'failure'}.gif"
        r = task.render(plan, env, name, caption=f"demo {int(ds.index[i])}", simulator=sim)
        agree = "" if r.success == bool(ds.labels[i]) else "  (label in file differs: simulator settings changed?)"
        print(f"{name}: {'success' if r.success else 'failure'}{agree}")
    return 0


# -- plot-data -------------------------------------------------------------------------
def cmd_plot_data(args: argparse.Namespace) -> int:
    from judgeopt.data.dataset import load
    from judgeopt.data.plots import plot_velocity_force
    from judgeopt.files import save_figure

    refuse_overwrite([args.out], args.overwrite)
    ds = load(args.data)
    save_figure(plot_velocity_force(ds, title=Path(args.data).name), args.out, dpi=110)
    print(f"wrote {args.out}")
    return 0


def cmd_import_demos(args: argparse.Namespace) -> int:
    from judgeopt.data.dataset import save
    from judgeopt.data.importer import HDF5_SUFFIXES, ImportError_, ImportSpec, import_demos, parse_hdf5_keys

    paths = []
    for p in map(Path, args.files):
        paths += sorted(f for f in p.iterdir() if f.suffix.lower() in (".csv", *HDF5_SUFFIXES)
                        and f.resolve() != Path(args.out).resolve()) if p.is_dir() else [p]  # not our own output
    if not paths:
        raise CLIError(f"no .csv, .h5 or .hdf5 files in {args.files}")
    from judgeopt.tasks import get_task

    refuse_overwrite([args.out], args.overwrite)
    task = get_task(args.task)
    env_names = tuple(n for n in args.env_names.split(",") if n) if args.env_names else task.env_names
    try:
        keys = parse_hdf5_keys(args.hdf5_keys, env_names, task.channel_names)
    except ImportError_ as exc:
        raise CLIError(str(exc)) from None
    ds, errors = import_demos(paths, ImportSpec(env_names, dt=args.dt, horizon=args.horizon, hdf5_keys=keys,
                                                task=task.name))
    for e in errors:
        print(f"judgeopt import-demos: skipped: {e}", file=sys.stderr)
    if ds is None:
        raise CLIError(f"nothing imported from {len(paths)} file(s): every demonstration was bad (reasons above)")
    ds.meta["command"] = command_line()
    save(ds, args.out)
    print(f"wrote {args.out}: {ds.n} demonstrations from {ds.meta['files_imported']} of {len(paths)} file(s) "
          f"({len(errors)} skipped), success ratio {ds.success_ratio():.2f}, resampled to dt = {ds.dt} s, "
          f"N = {ds.horizon}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="judgeopt", description=__doc__)
    p.add_argument("--version", action="version", version=f"judgeopt {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    c = sub.add_parser("collect", help="run a task's random demonstrations in simulation and save them labelled",
                       description="Random demonstrations of a task (the scoop's: random spline scoops, paper IV-B) "
                       "run on the simulated UR5, labelled by outcome. A grid (--per-env N at each point of --grid "
                       "values, default the task's grid: the scoop's is the paper's 3 x 3) or --n random environments. "
                       "Interrupted runs resume from OUT.partial/.")
    c.add_argument("--out", required=True, help="HDF5 file to write (an unfinished one resumes)")
    c.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    c.add_argument("--seed", type=int, default=0)
    c.add_argument("--n", type=int, default=1000, help="number of demonstrations in random environments")
    c.add_argument("--per-env", type=int, default=0, help="demonstrations per grid environment (makes a grid)")
    c.add_argument("--task", default=DEFAULT_TASK, help=f"the task to collect (default {DEFAULT_TASK}; `judgeopt tasks`)")
    c.add_argument("--grid", type=env_values, action="append", metavar="NAME=V1,V2,...",
                   help="grid values of one environment variable (with --per-env; default: the task's grid)")
    c.add_argument("--range", type=env_range, action="append", metavar="NAME=LO,HI",
                   help="range of one environment variable for --n random environments (default: the task's)")
    c.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="one of the task's settings, e.g. commands.constant_force_share=0.4 (the scoop: share of "
                   "commands pressing at one near-constant force)")
    c.add_argument("--jobs", type=int, default=-1, help="local worker processes (-1: all cores)")
    c.add_argument("--scheduler", help="address of a Dask distributed scheduler (tcp://host:8786) to run on")
    c.add_argument("--chunk", type=int, default=25, help="demonstrations per work unit (and per resume step)")
    c.add_argument("--quiet", action="store_true", help="no progress bar")
    c.set_defaults(func=cmd_collect)

    k = sub.add_parser("tasks", help="list the tasks judgeopt can plan for",
                       description="Each task's channels (name, unit, kind), environment variables and horizon.")
    k.add_argument("--json", action="store_true", help="print a JSON list of objects (name, channels, env_names, ...)")
    k.set_defaults(func=cmd_tasks)

    i = sub.add_parser("inspect", help="summarise a dataset or model file",
                       description="Dataset: counts, success ratios, metadata. Model (.pt/.json or its stem): "
                       "architecture, horizon, environment variables, accuracy, provenance.")
    i.add_argument("path")
    i.add_argument("--json", action="store_true", help="print one JSON object")
    i.set_defaults(func=cmd_inspect)

    r = sub.add_parser("render", help="replay demonstrations in PyBullet and save GIFs",
                       description="Replays demonstrations of a dataset with the headless renderer.")
    r.add_argument("--data", required=True)
    r.add_argument("--out", default="renders", help="folder for the GIFs")
    r.add_argument("--successes", type=int, default=2)
    r.add_argument("--failures", type=int, default=2)
    r.add_argument("--index", type=int, nargs="+", help="render these demonstrations (row numbers) instead")
    r.set_defaults(func=cmd_render)

    d = sub.add_parser("plot-data", help="plot max velocity against max force coloured by label (paper Fig. 13)")
    d.add_argument("--data", required=True)
    d.add_argument("--out", default="velocity_force.png")
    d.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    d.set_defaults(func=cmd_plot_data)

    m = sub.add_parser("import-demos", help="import recorded demonstrations (CSV or robomimic-style HDF5) into the "
                       "dataset format",
                       description="CSV columns: t [s], y [m], optional ydot [m/s], f [N], label (success/failure), "
                       "the environment columns, optional demo_id (several demonstrations in one table). HDF5 "
                       "(.h5/.hdf5, robomimic layout): data/demo_N groups with t (or a dt/control_freq attribute), "
                       "y, optional ydot, f as datasets in the group or under obs/, a success attribute (or "
                       "success/rewards/dones dataset) and the environment values as attributes (or in env_args). "
                       "Each demonstration is validated and resampled to the planner's period; bad CSV files and "
                       "bad HDF5 demo groups are reported (file, row/demo group, column/field) and the rest imported.")
    m.add_argument("files", nargs="+", help="CSV or HDF5 files, or folders of them")
    m.add_argument("--out", required=True, help="HDF5 dataset to write")
    m.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    m.add_argument("--task", default=DEFAULT_TASK, help=f"whose channels the recordings hold (default {DEFAULT_TASK}: "
                   "y, ydot, f; `judgeopt tasks`)")
    m.add_argument("--env-names", help="environment columns, comma-separated (default: the task's, the scoop's y_obj,mu)")
    m.add_argument("--hdf5-keys", metavar="NAME=PATH[:COL],...",
                   help="where an HDF5 file keeps t, a channel (the scoop's y, ydot, f), success, dt or an environment "
                   "value, e.g. 'y=obs/robot0_eef_pos:1,f=obs/ft:2,mu=friction' (:COL picks a column of a (T, k) array)")
    m.add_argument("--dt", type=float, default=DEFAULT_DT, help="planner sample period in s")
    m.add_argument("--horizon", type=int, default=DEFAULT_HORIZON, help="planner steps N")
    m.set_defaults(func=cmd_import_demos)

    from judgeopt.cli.judge import add_judge_commands

    add_judge_commands(sub)
    from judgeopt.cli.planners import add_planner_commands

    add_planner_commands(sub)
    from judgeopt.cli.evaluate import add_evaluate_commands

    add_evaluate_commands(sub)
    from judgeopt.cli.refine import add_refine_commands

    add_refine_commands(sub)
    from judgeopt.cli.planners import add_trust_region_command

    add_trust_region_command(sub)
    from judgeopt.cli.judge import add_ensemble_command

    add_ensemble_command(sub)
    from judgeopt.cli.export import add_export_commands

    add_export_commands(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    from judgeopt.data.dataset import DatasetError
    from judgeopt.judge.model import JudgeError
    from judgeopt.planners.problem import ProblemError
    from judgeopt.files import OverwriteError
    from judgeopt.tasks.base import EnvironmentRangeError, TaskError
    from judgeopt.sim.robot import RobotDescriptionError
    from judgeopt.trajectory import PlanError

    set_argv(argv)
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (CLIError, DatasetError, JudgeError, PlanError, ProblemError, EnvironmentRangeError, RobotDescriptionError,
            TaskError, OverwriteError) as exc:
        print(f"judgeopt {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"judgeopt {args.command}: interrupted (a collection resumes when rerun)", file=sys.stderr)
        return 130

