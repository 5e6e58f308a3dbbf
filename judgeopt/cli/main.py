"""The `judgeopt` command line: one subcommand per pipeline stage."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from judgeopt import __version__
from judgeopt.cli.common import CLIError, check_range, command_line, floats, set_argv


# -- collect ---------------------------------------------------------------------------
def cmd_collect(args: argparse.Namespace) -> int:
    from judgeopt.data.collect import PAPER_GRID, PAPER_RANGES, CollectionSpec, collect
    from judgeopt.data.commands import RandomCommandConfig
    from judgeopt.sim.scene import ENV_RANGES

    grid = None
    if args.per_env:
        grid = {"y_obj": args.y_obj or PAPER_GRID["y_obj"], "mu": args.mu or PAPER_GRID["mu"]}
        for name, vs in grid.items():
            check_range(name, vs, ENV_RANGES[name])
    elif args.y_obj or args.mu:
        raise CLIError("--y-obj and --mu lists make a grid: give --per-env N with them (or use --y-obj-range/--mu-range)")
    ranges = {"y_obj": tuple(args.y_obj_range or PAPER_RANGES["y_obj"]), "mu": tuple(args.mu_range or PAPER_RANGES["mu"])}
    for name, (lo, hi) in ranges.items():
        if lo > hi:
            raise CLIError(f"--{name.replace('_', '-')}-range: lower bound {lo} is above upper bound {hi}")
        check_range(name, (lo, hi), ENV_RANGES[name])
    if args.n <= 0 and not args.per_env:
        raise CLIError("--n must be a positive number of demonstrations")
    if not 0.0 <= args.constant_force_share <= 1.0:
        raise CLIError(f"--constant-force-share {args.constant_force_share} is not a share: give a value in [0, 1]")
    commands = RandomCommandConfig(constant_force_share=args.constant_force_share)
    spec = CollectionSpec(seed=args.seed, n=args.n, grid=grid, per_env=args.per_env, ranges=ranges, commands=commands)
    ds = collect(spec, args.out, n_jobs=args.jobs, scheduler=args.scheduler, chunk_size=args.chunk,
                 progress=not args.quiet, command=command_line())
    s = ds.summary()
    print(f"wrote {args.out}: {s['n']} demonstrations, success ratio {s['success_ratio']:.3f}, "
          f"{s['errors']} errors")
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
    from judgeopt.sim.render import render_rollout
    from judgeopt.sim.rollout import Simulator
    from judgeopt.trajectory import Plan

    ds = load(args.data)
    out = Path(args.out)
    picks: list[int] = []
    for label, count in ((1, args.successes), (0, args.failures)):
        picks += [int(i) for i in np.flatnonzero(ds.labels == label)[:count]]
    if args.index:
        picks = list(args.index)
    if not picks:
        raise CLIError(f"{args.data} has no demonstrations of the requested kind")
    sim = Simulator()
    for i in picks:
        if not 0 <= i < ds.n:
            raise CLIError(f"--index {i} is out of range: {args.data} holds {ds.n} demonstrations")
        y_obj, mu = (float(v) for v in ds.env[i])
        plan = Plan.from_array(ds.dt, ds.commands[i])
        name = out / f"demo_{int(ds.index[i]):05d}_{'success' if ds.labels[i] else 'failure'}.gif"
        r = render_rollout(sim, plan, y_obj, mu, name, caption=f"demo {int(ds.index[i])}")
        agree = "" if r.success == bool(ds.labels[i]) else "  (label in file differs: simulator settings changed?)"
        print(f"{name}: {'success' if r.success else 'failure'}{agree}")
    return 0


# -- plot-data -------------------------------------------------------------------------
def cmd_plot_data(args: argparse.Namespace) -> int:
    from judgeopt.data.dataset import load
    from judgeopt.data.plots import plot_velocity_force

    ds = load(args.data)
    plot_velocity_force(ds, args.out, title=Path(args.data).name)
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
    env_names = tuple(n for n in args.env_names.split(",") if n)
    try:
        keys = parse_hdf5_keys(args.hdf5_keys, env_names)
    except ImportError_ as exc:
        raise CLIError(str(exc)) from None
    ds, errors = import_demos(paths, ImportSpec(env_names, dt=args.dt, horizon=args.horizon, hdf5_keys=keys))
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

    c = sub.add_parser("collect", help="run random scooping commands in simulation and save labelled demonstrations",
                       description="Random spline scoops (paper IV-B) run on the simulated UR5, labelled by outcome. "
                       "A grid (--per-env N at each --y-obj x --mu point, default the paper's 3 x 3) or --n random "
                       "environments. Interrupted runs resume from OUT.partial/.")
    c.add_argument("--out", required=True, help="HDF5 file to write")
    c.add_argument("--seed", type=int, default=0)
    c.add_argument("--n", type=int, default=1000, help="number of demonstrations in random environments")
    c.add_argument("--per-env", type=int, default=0, help="demonstrations per grid environment (makes a grid)")
    c.add_argument("--y-obj", type=floats, help="grid values of y_obj (m), comma-separated")
    c.add_argument("--mu", type=floats, help="grid values of mu, comma-separated")
    c.add_argument("--y-obj-range", type=float, nargs=2, metavar=("LO", "HI"), help="random y_obj range (m)")
    c.add_argument("--mu-range", type=float, nargs=2, metavar=("LO", "HI"), help="random mu range")
    c.add_argument("--constant-force-share", type=float, default=0.0, metavar="SHARE",
                   help="share of commands that press at one near-constant force level (default 0: the paper's "
                   "independent random force knots)")
    c.add_argument("--jobs", type=int, default=-1, help="local worker processes (-1: all cores)")
    c.add_argument("--scheduler", help="address of a Dask distributed scheduler (tcp://host:8786) to run on")
    c.add_argument("--chunk", type=int, default=25, help="demonstrations per work unit (and per resume step)")
    c.add_argument("--quiet", action="store_true", help="no progress bar")
    c.set_defaults(func=cmd_collect)

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
    m.add_argument("--env-names", default="y_obj,mu", help="environment columns, comma-separated (default y_obj,mu)")
    m.add_argument("--hdf5-keys", metavar="NAME=PATH[:COL],...",
                   help="where an HDF5 file keeps t, y, ydot, f, success, dt or an environment value, e.g. "
                   "'y=obs/robot0_eef_pos:1,f=obs/ft:2,mu=friction' (:COL picks a column of a (T, k) array)")
    m.add_argument("--dt", type=float, default=0.05, help="planner sample period in s")
    m.add_argument("--horizon", type=int, default=30, help="planner steps N")
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
    return p


def main(argv: list[str] | None = None) -> int:
    from judgeopt.data.dataset import DatasetError
    from judgeopt.judge.model import JudgeError
    from judgeopt.planners.problem import ProblemError
    from judgeopt.sim.scene import EnvironmentRangeError
    from judgeopt.sim.robot import RobotDescriptionError
    from judgeopt.trajectory import PlanError

    set_argv(argv)
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (CLIError, DatasetError, JudgeError, PlanError, ProblemError, EnvironmentRangeError, RobotDescriptionError) as exc:
        print(f"judgeopt {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"judgeopt {args.command}: interrupted (a collection resumes when rerun)", file=sys.stderr)
        return 130

