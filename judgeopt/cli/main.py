"""The `judgeopt` command line: one subcommand per pipeline stage."""

from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import logging
import sys
import warnings
from pathlib import Path
from typing import Any, Iterator

from judgeopt import __version__
from judgeopt.cli.commands import COMMANDS, HELP
from judgeopt.cli.common import (EXIT_MEANINGS, JSON, OVERWRITE, QUIET, CLIError, ExitCode, ListingHelpFormatter, Parser,
                                 check_range, command_line, command_of, env_range, env_set, env_values, jobs_option,
                                 missing_extra, out_option, positive, print_error, restore_argv, seed_option, set_argv, threads_option,
                                 using_plugins, value_range, wants_json)
from judgeopt.interrupts import held
from judgeopt.errors import JudgeoptError
from judgeopt.files import OutputWriteError, check_writable, refuse_overwrite
from judgeopt.robots import DEFAULT_ROBOT
from judgeopt.tasks import DEFAULT_TASK


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
        raise CLIError(task.not_a_variable(', '.join(unknown)))
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
    settings = task.robot_settings(args.robot, settings)
    randomize = task.check_randomization(dict(args.randomize or []))  # names, order, physical range: one line
    partial = Path(args.out).with_name(Path(args.out).name + ".partial")
    if not partial.exists():  # an unfinished collection resumes; a finished file is kept
        refuse_overwrite([args.out], args.overwrite)
    focus = None
    if args.focus:
        from judgeopt.judge.focus import JudgeFocus

        focus = JudgeFocus.of(args.focus, band=args.focus_band, tries=args.focus_tries, env_names=task.env_names,
                              horizon=task.horizon, dt=task.dt)
    spec = CollectionSpec(task=task.name, seed=args.seed, n=args.n, grid=grid, per_env=args.per_env, ranges=ranges,
                          settings=settings, randomize=randomize or None, focus=focus)
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
        if t["perturbations"]:  # what evaluate robustness replays under and collect --randomize draws
            print("  perturbations: " + ", ".join(f"{p['name']} in [{p['physical'][0]:g}, {p['physical'][1]:g}]"
                                                  f"{' ' + p['unit'] if p['unit'] not in ('', 'x') else ''}"
                                                  f"{' (factor)' if p['unit'] == 'x' else ''}"
                                                  for p in t["perturbations"]))
    return 0


# -- render ----------------------------------------------------------------------------
def cmd_render(args: argparse.Namespace) -> int:
    import numpy as np

    from judgeopt.data.dataset import load
    from judgeopt.tasks import get_task

    check_writable([args.out])  # before any demonstration is replayed
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
    sim = task.simulator(task.robot_settings(args.robot or ds.robot), render=True)
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


#: the commands that never import torch (listings, plots of data files; the service, whose workers import it): the
#: others but FAST_START import it first, holding Ctrl-C
NO_TORCH = frozenset({"tasks", "robots", "plot-data", "serve"})
#: the commands that import torch only where they need it: solve loads its judge's built library and the
#: generator's numpy weights without it once a run has left them (planners.loaded.fast_models)
FAST_START = frozenset({"solve"})
EXIT_CODES_HELP = "exit codes:\n" + "\n".join(f"  {c.value:<4} {text}" for c, text in EXIT_MEANINGS.items())


def add_collect_command(sub: argparse._SubParsersAction) -> None:
    """Add `collect`."""
    from judgeopt.cli.examples import example_perturbation

    c = sub.add_parser("collect", help=HELP["collect"],
                       description="Random demonstrations of a task (the scoop's: random spline scoops, paper IV-B) "
                       "run on the simulated UR5, labelled by outcome. A grid (--per-env N at each point of --grid "
                       "values, default the task's grid: the scoop's is the paper's 3 x 3) or --n random environments. "
                       "Interrupted runs resume from OUT.partial/.",
                       parents=[out_option("FILE", "HDF5 file to write (an unfinished one resumes)", required=True),
                                OVERWRITE, seed_option(), jobs_option(), threads_option(), QUIET])
    c.add_argument("--n", type=int, default=1000, help="number of demonstrations in random environments")
    c.add_argument("--per-env", type=int, default=0, help="demonstrations per grid environment (makes a grid)")
    c.add_argument("--task", default=DEFAULT_TASK, help="the task to collect (`judgeopt tasks` lists them)")
    c.add_argument("--grid", type=env_values, action="append", metavar="NAME=V1,V2,...",
                   help="grid values of one environment variable (with --per-env; default: the task's grid)")
    c.add_argument("--range", type=env_range, action="append", metavar="NAME=LO,HI",
                   help="range of one environment variable for --n random environments (default: the task's)")
    c.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="one of the task's settings, e.g. commands.constant_force_share=0.4 (the scoop: share of "
                   "commands pressing at one near-constant force)")
    c.add_argument("--randomize", type=env_range, action="append", metavar="NAME=LO,HI",
                   help=f"draw one of the scene's unobserved parameters (the task's perturbations, e.g. "
                   f"{example_perturbation()}; `judgeopt tasks --json` lists them) uniformly "
                   "per demonstration; the draws are recorded in the file (default: the nominal scene)")
    c.add_argument("--focus", metavar="JUDGE",
                   help="active collection: keep a demonstration only where this judge, reading its command, is unsure "
                   "(probability inside --focus-band); candidates are redrawn up to --focus-tries times. The file is "
                   "then no sample of the task: train on it beside random demonstrations, never test on it")
    c.add_argument("--focus-band", type=value_range, metavar="LO,HI",
                   help="the judge's probabilities counted as unsure (with --focus; default: JudgeFocus.band, 0.02,0.98)")
    c.add_argument("--focus-tries", type=positive,
                   help="candidates per demonstration before the last is kept anyway (with --focus; default: "
                   "JudgeFocus.tries, 50)")
    c.add_argument("--robot", default=DEFAULT_ROBOT, metavar="NAME",
                   help="the arm that runs the demonstrations (`judgeopt robots` lists them; default: %(default)s)")
    c.add_argument("--chunk", type=positive, default=25, help="demonstrations per work unit (and per resume step)")
    c.set_defaults(func=cmd_collect)


def add_tasks_command(sub: argparse._SubParsersAction) -> None:
    """Add `tasks`."""
    k = sub.add_parser("tasks", help=HELP["tasks"],
                       description="Each task's channels (name, unit, kind), environment variables and horizon. "
                       "With --json: a list of objects (name, channels, env_names, environment, horizon, dt).",
                       parents=[JSON])
    k.set_defaults(func=cmd_tasks)


def add_render_command(sub: argparse._SubParsersAction) -> None:
    """Add `render`."""
    r = sub.add_parser("render", help=HELP["render"],
                       description="Replays demonstrations of a dataset with the headless renderer.",
                       parents=[out_option("DIR", "folder for the GIFs", default="renders")])
    r.add_argument("--data", required=True, metavar="FILE", help="dataset (HDF5)")
    r.add_argument("--successes", type=int, default=2, help="how many successful demonstrations (the first ones)")
    r.add_argument("--failures", type=int, default=2, help="how many failed demonstrations (the first ones)")
    r.add_argument("--index", type=int, nargs="+", help="render these demonstrations (row numbers) instead")
    r.add_argument("--robot", metavar="NAME", help="replay on this arm (`judgeopt robots`; default: the one the "
                   "dataset was collected on)")
    r.set_defaults(func=cmd_render)


def add_plot_data_command(sub: argparse._SubParsersAction) -> None:
    """Add `plot-data`."""
    d = sub.add_parser("plot-data", help=HELP["plot-data"],
                       parents=[out_option("IMAGE", "image to write (PNG, PDF or SVG by suffix)",
                                           default="velocity_force.png"), OVERWRITE])
    d.add_argument("--data", required=True, metavar="FILE", help="dataset (HDF5)")
    d.set_defaults(func=cmd_plot_data)


class _Only:
    """The subparsers action as an adder sees it when only `name`'s parser is wanted: the other
    commands the adder adds go to a parser that is thrown away (they are listed by their line)."""

    def __init__(self, sub: argparse._SubParsersAction, name: str) -> None:
        self.sub, self.name = sub, name

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser:
        return self.sub.add_parser(name, **kwargs) if name == self.name else Parser(prog=f"judgeopt {name}")


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The command line's parser. `command` None: every subcommand's parser in full (what the tests
    and the docs walk); a name: that command's in full and the others listed by their help line
    (cli.commands), so that running one command, or `judgeopt --help` (""), imports no other
    command's module (those import numpy, the tasks, the problems)."""
    p = Parser(prog="judgeopt", description=__doc__, epilog=EXIT_CODES_HELP, formatter_class=ListingHelpFormatter)
    p.add_argument("--version", action="version", version=f"judgeopt {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    added: set[str] = set()
    for name, c in COMMANDS.items():
        if command is not None and name != command:
            sub.add_parser(name, help=c.help)  # listed; never parses (the command typed is another)
        elif c.adder not in added:
            added.add(c.adder)
            module, function = c.adder.split(":")
            getattr(importlib.import_module(module), function)(sub if command is None else _Only(sub, name))
    return p


def exit_code(exc: BaseException) -> ExitCode | None:
    """The exit code of an error the user can act on; None for a bug (its traceback is shown).
    judgeopt's errors carry theirs (judgeopt.errors); of other libraries', only a missing extra."""
    if isinstance(exc, JudgeoptError):
        return ExitCode(exc.exit_code)
    if isinstance(exc, ModuleNotFoundError) and missing_extra(exc):
        return ExitCode.MISSING
    return None


def _log_to_stderr(quiet: bool) -> None:
    """judgeopt's progress messages ("building the judge library ...") on stderr, unless --quiet."""
    log = logging.getLogger("judgeopt")
    if not any(getattr(h, "judgeopt_cli", False) for h in log.handlers):
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter("judgeopt: %(message)s"))
        handler.judgeopt_cli = True
        log.addHandler(handler)
    log.setLevel(logging.WARNING if quiet else logging.INFO)


def _quiet_simulator(quiet: bool) -> contextlib.AbstractContextManager:
    """Under --quiet, PyBullet's warnings from C (judgeopt.sim.quiet) are discarded, in worker processes
    too (they inherit the environment variable); set for the command only, so in-process calls do not leak."""
    from judgeopt.sim import QUIET_ENV

    return env_set(QUIET_ENV, "1" if quiet else None)


@contextlib.contextmanager
def _fast_start(on: bool) -> Iterator[None]:
    """For the command only (main() may be called in a process that goes on): the fast start
    (judge.compiled), and torch's import, where it cannot serve, holding Ctrl-C as main's own does."""
    if not on:
        yield
        return
    from judgeopt import threads
    from judgeopt.judge.compiled import fast_start

    guard, threads.import_guard = threads.import_guard, held
    try:
        with fast_start():
            yield
    finally:
        threads.import_guard = guard


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """A problem file's field in its old place is one line of note, a limit in an implausible unit one
    line of warning; other warnings as Python shows them."""
    if category.__name__ == "ProblemDeprecation":
        print(f"note: {message}", file=sys.stderr)
    elif category.__name__ == "ProblemUnits":
        print(f"warning: {message}", file=sys.stderr)
    else:
        _python_show_warning(message, category, filename, lineno, file, line)


_python_show_warning = warnings.showwarning


def _written_since(start: int) -> list[str]:
    """The files this command wrote whole (judgeopt.files.WRITTEN from `start`), not the cache's."""
    from judgeopt import files

    cache = files.cache_dir().resolve()
    out = [p for p in files.WRITTEN[start:] if cache not in p.resolve().parents]
    return [str(p) for p in dict.fromkeys(out)]


def _option_for(args: argparse.Namespace, path: Path | None) -> str | None:
    """The option that chose an output `path`: the one whose value is `path`, its stem (STEM.pt,
    NAME_METHOD.csv) or a folder holding it; None where no option names it."""
    if path is None:
        return None
    best = None
    for dest, value in vars(args).items():
        if not isinstance(value, str) or not value or dest in ("command", "func"):
            continue
        given = Path(value)
        rank = (3 if path == given else
                2 if path.parent == given.parent and path.name.startswith(given.stem) else
                1 if given in path.parents else 0)
        if rank and (best is None or (rank, len(value)) > best[0]):
            best = ((rank, len(value)), f"--{dest.replace('_', '-')}")
    return best[1] if best else None


def main(argv: list[str] | None = None) -> int:
    """Run one command. Ctrl-C (or SIGTERM) at any moment, loading the modules the parser is built
    from included, is one line saying what was written or kept, and exit 130. With no `argv` the
    process is the command (the `judgeopt` script, python -m judgeopt) and ends when main returns:
    a Ctrl-C after the outcome is decided is ignored (ignore_late_interrupts says why)."""
    from judgeopt import files
    from judgeopt.cli.interrupts import forget_nested_interrupt, ignore_late_interrupts
    from judgeopt.errors import interrupted

    start = len(files.WRITTEN)
    before = set_argv(argv)
    try:
        code = _main(argv)
        if argv is None:  # inside the try: a Ctrl-C before this is the command's, one line and 130
            ignore_late_interrupts()
            if command_of(argv) in FAST_START:
                _end_now(code)
        return code
    except KeyboardInterrupt:
        if argv is None:
            ignore_late_interrupts()
        forget_nested_interrupt()
        command = command_of(argv)
        print_error(f"judgeopt {command}" if command else "judgeopt", interrupted(command, _written_since(start)),
                    ExitCode.INTERRUPTED)
        return ExitCode.INTERRUPTED
    finally:
        restore_argv(before)


def _end_now(code: int) -> None:
    """End a one-shot command's process without the interpreter's teardown: after the fast start's
    solve, unloading libtorch and its loaded library at exit took 0.2-0.3 s of a 1.1 s run
    (docs/speed.md). Python's exit handlers run and the output is flushed first, as at a normal exit;
    where another thread still runs, the normal exit waits for it, so nothing is cut short."""
    import atexit
    import os
    import threading

    if threading.active_count() > 1:
        return
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(OSError, ValueError):  # a closed pipe: nothing more can be said there
            stream.flush()
    os._exit(int(code))


def _main(argv: list[str] | None) -> int:
    warnings.showwarning = _show_warning
    args = build_parser(command_of(argv) or "").parse_args(argv)
    command = f"judgeopt {args.command}"
    _log_to_stderr(getattr(args, "quiet", False))
    here = not getattr(args, "server", None)  # solve --server: planned by a service, no torch here
    if args.command not in NO_TORCH and args.command not in FAST_START and here:
        with held():  # torch's import is native code throughout: a Ctrl-C inside it aborts the process
            import torch  # noqa: F401
    if getattr(args, "threads", None) is not None and here:
        from judgeopt.threads import set_threads

        set_threads(args.threads, lazy=args.command in FAST_START)
    try:
        with using_plugins(getattr(args, "plugin", None)), _quiet_simulator(getattr(args, "quiet", False)), \
                _fast_start(args.command in FAST_START and here):
            return int(args.func(args))
    except Exception as exc:
        code = exit_code(exc)
        if code is None:
            if wants_json():
                print_error(command, f"internal error: {type(exc).__name__}: {exc}", ExitCode.INTERNAL)
            raise
        if isinstance(exc, OutputWriteError) and exc.flag is None:  # the writer knew the path, not the option
            exc = exc.with_flag(_option_for(args, exc.path))
        message = missing_extra(exc) if isinstance(exc, ModuleNotFoundError) else str(exc)
        print_error(command, message, code)
        return code
