"""What every subcommand shares: exit codes, the one-line error, the help format, the options
every command spells the same way (parent parsers), argument types, the command line as typed."""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import re
import shlex
import sys
from pathlib import Path
from typing import Iterator

from judgeopt.errors import EXIT_MEANINGS, ExitCode, JudgeoptError  # noqa: F401 (re-exported)
from judgeopt.field_text import finite  # noqa: F401 (re-exported: every option's number)


class CLIError(JudgeoptError):
    """A user-facing error: printed as one line (exit code 2 unless given)."""

    def __init__(self, message: str, code: ExitCode = ExitCode.USAGE):
        super().__init__(message)
        self.code = self.exit_code = code


#: optional modules and the extra that installs them (pyproject.toml [project.optional-dependencies])
EXTRAS = {"pybullet": "sim", "pybullet_data": "sim", "pinocchio": "sim", "example_robot_data": "sim", "PIL": "sim",
          "dask": "dask", "distributed": "dask", "pyarrow": "lerobot", "rosbags": "ros", "l4casadi": "l4casadi"}


#: (extra, command) -> the option with which that command does without the extra (the error names it)
WITHOUT_EXTRA = {("sim", "solve"): "--no-simulate, to plan without replaying the plans in simulation"}


def missing_extra(exc: ModuleNotFoundError) -> str | None:
    """The one-line fix for a missing optional dependency, or None if it is not one of ours; where the
    command can run without it (solve without the `sim` extra: --no-simulate), that option too."""
    root = (exc.name or "").split(".")[0]
    extra = EXTRAS.get(root)
    if extra is None:
        return None
    argv = current_argv()
    without = WITHOUT_EXTRA.get((extra, argv[0] if argv else ""))
    return (f"this needs {root}, which is not installed: pip install 'judgeopt[{extra}]'"
            + (f", or run it with {without}" if without else ""))


def wants_json(argv: list[str] | None = None) -> bool:
    """Was --json given? (errors are then one JSON object on stdout, usage errors included)."""
    return "--json" in (argv if argv is not None else current_argv())


def print_error(command: str, message: str, code: int) -> None:
    """The one error line: on stderr, or under --json one object on stdout."""
    if wants_json():
        print(json.dumps({"error": message, "exit_code": int(code), "command": command}))
    else:
        print(f"{command}: error: {message}", file=sys.stderr)


class HelpFormatter(argparse.HelpFormatter):
    """Every option's help ends with its default, unless it says it already or has none."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if (not action.option_strings or "default" in text.lower() or action.default is None
                or action.default is False or action.default == [] or action.default is argparse.SUPPRESS):
            return text
        return f"{text} (default: %(default)s)"


class ListingHelpFormatter(argparse.RawDescriptionHelpFormatter, HelpFormatter):
    """The same, with the description and epilog kept as written (a list of exit codes)."""


_NUMBER = r"(?:(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?|inf(?:inity)?|nan)"
#: what an option takes as a value, not as another option: a negative number or a list of numbers
#: starting with one (-5, -1e-3, -inf, -0.05,-0.02); argparse's own takes only -5 and -0.5
NEGATIVE_NUMBER = re.compile(rf"^-{_NUMBER}(?:,\s*[-+]?{_NUMBER})*$", re.IGNORECASE)


class Parser(argparse.ArgumentParser):
    """judgeopt's parser: its help format for every subcommand, usage errors as JSON under --json."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER  # `--f-max -inf` reaches the option's own check

    def error(self, message: str):
        """One line (the usage is one --help away), or under --json one object."""
        if not wants_json():
            message += f" (`{self.prog} --help` lists the options)"
        print_error(self.prog, message, ExitCode.USAGE)
        sys.exit(ExitCode.USAGE)


def _parent() -> argparse.ArgumentParser:
    return argparse.ArgumentParser(add_help=False)


def _folder(text: str) -> str:
    """A folder to write into: anything but an existing file."""
    if Path(text).exists() and not Path(text).is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a file; give a folder (it is created if missing)")
    return text


#: the image formats judgeopt's figures are written in (matplotlib's, by the file's suffix)
FIGURE_SUFFIXES = (".png", ".pdf", ".svg", ".jpg", ".jpeg")


def figure_path(text: str) -> str:
    """An image file to write, checked before any work is done: a known suffix, not a folder."""
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder; give an image file, e.g. {path / 'plan.png'}")
    if path.suffix.lower() not in FIGURE_SUFFIXES:
        raise argparse.ArgumentTypeError(f"{text}: the suffix picks the format; use one of "
                                         f"{', '.join(FIGURE_SUFFIXES)}")
    return text


def file_path(text: str) -> str:
    """A file to write: anything but an existing folder (refused before any work is done)."""
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder; give a file to write, e.g. {path / 'NAME'}")
    return text


#: --out's kinds: its metavar and the check of what is given
OUT_KINDS = {"FILE": ("FILE", file_path), "IMAGE": ("FILE", figure_path), "DIR": ("DIR", _folder), "STEM": ("STEM", None)}


def out_option(kind: str, what: str, required: bool = False, default: str | None = None) -> argparse.ArgumentParser:
    """--out, named for what it is: FILE (an existing folder is refused), IMAGE (a FILE whose
    suffix names an image format), DIR (a folder: an existing file is refused) or STEM (a model
    path without suffix)."""
    metavar, check = OUT_KINDS[kind]
    p = _parent()
    p.add_argument("--out", metavar=metavar, required=required, default=default, help=what, type=check)
    return p


def jobs_option(default: int = -1) -> argparse.ArgumentParser:
    """--jobs: worker processes (never threads) and --scheduler: a Dask cluster instead."""
    p = _parent()
    p.add_argument("--jobs", type=int, default=default, metavar="N", help="local worker processes (-1: all cores)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="a Dask distributed scheduler (tcp://host:8786) to run on instead of local processes "
                   "(needs judgeopt[dask])")
    return p


def threads_option() -> argparse.ArgumentParser:
    """--threads: torch threads in this process (judgeopt.threads: one holds under load)."""
    from judgeopt.threads import DEFAULT_THREADS

    p = _parent()
    p.add_argument("--threads", type=positive, default=DEFAULT_THREADS, metavar="N",
                   help="torch threads in this process (1: holds when other programs busy the cores, and is "
                   "bit-reproducible; more may speed training on an idle machine)")
    return p


def seed_option(default: int = 0) -> argparse.ArgumentParser:
    p = _parent()
    p.add_argument("--seed", type=int, default=default, help="random seed: the same seed gives the same result")
    return p


def _flag(name: str, text: str) -> argparse.ArgumentParser:
    p = _parent()
    p.add_argument(name, action="store_true", help=text)
    return p


OVERWRITE = _flag("--overwrite", "replace outputs that exist (without it, an existing output is refused, exit 6)")
JSON = _flag("--json", "print one JSON object on stdout (errors too: {\"error\": ..., \"exit_code\": ...})")
QUIET = _flag("--quiet", "no progress bars or progress messages")


_ARGV: list[str] | None = None  # the arguments `main` was called with (in-process calls: tests, notebooks)


def set_argv(argv: list[str] | None) -> list[str] | None:
    """Record the arguments of the command now running; returns those recorded before (main()
    puts them back when its command ends: a process that goes on reads no stale --plugin)."""
    global _ARGV
    before, _ARGV = _ARGV, (list(argv) if argv is not None else sys.argv[1:])
    return before


def current_argv() -> list[str]:
    """The arguments of the command now running (main's, else the process's)."""
    return _ARGV if _ARGV is not None else sys.argv[1:]


def command_of(argv: list[str] | None = None) -> str | None:
    """The subcommand typed (the first word that is no option), known before anything is parsed."""
    return next((a for a in (current_argv() if argv is None else argv) if not a.startswith("-")), None)


@contextlib.contextmanager
def env_set(name: str, value: str | None) -> Iterator[None]:
    """The environment variable `name` set to `value` (None: left as it is) while a command runs, for
    the worker processes it starts; as it was afterwards (main() may be called in a process that goes on)."""
    before = os.environ.get(name)
    if value is not None:
        os.environ[name] = value
    try:
        yield
    finally:
        if before is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = before


def restore_argv(before: list[str] | None) -> None:
    """What set_argv returned, recorded again."""
    global _ARGV
    _ARGV = before


def command_line() -> str:
    """The command as the user typed it, recorded in every file a command writes."""
    return "judgeopt " + " ".join(shlex.quote(a) for a in current_argv())


def plugins_given(argv: list[str] | None = None) -> list[str]:
    """The --plugin MODULE values anywhere on the command line, read before the parser reaches
    them (so that `--method NAME --plugin MODULE` finds NAME too)."""
    args = argv if argv is not None else current_argv()
    given = [b for a, b in zip(args, args[1:]) if a == "--plugin"]
    return given + [a.partition("=")[2] for a in args if a.startswith("--plugin=")]


def add_plugin_option(p: argparse.ArgumentParser) -> None:
    """--plugin MODULE, for every command that plans (its modules' `register(...)` lines add planners)."""
    from judgeopt.planners.base import PLUGINS_ENV

    p.add_argument("--plugin", action="append", metavar="MODULE",
                   help=f"import MODULE first (a module name, found on the Python path or in the current folder): its "
                   f"judgeopt.planners.base.register(...) lines add --method(s) choices; repeatable; ${PLUGINS_ENV} "
                   "(comma-separated modules) names plugins for every command that plans")


@contextlib.contextmanager
def using_plugins(modules: list[str] | None) -> Iterator[None]:
    """Import the --plugin modules, and name them in $JUDGEOPT_PLUGINS while the command runs, for
    the worker processes it starts (a worker imports them when it meets a planner it does not know);
    the environment is as it was afterwards (main() may be called in a process that goes on)."""
    from judgeopt.planners.base import PLUGINS_ENV, load_plugins, plugin_modules

    if modules:
        load_plugins(modules)
    with env_set(PLUGINS_ENV, ",".join(plugin_modules(modules)) if modules else None):
        yield


class PlannerChoices:
    """The choices of a --method(s) option, read when checked: the registered planners (those that
    plan before execution, with `open_loop`) and `extra` (the groups). A name not registered yet
    first imports the plugins (--plugin, $JUDGEOPT_PLUGINS), so `judgeopt --help` and a built-in's
    run never import them."""

    def __init__(self, extra: tuple[str, ...] = (), open_loop: bool = False):
        self.extra, self.open_loop = extra, open_loop

    def names(self) -> tuple[str, ...]:
        from judgeopt.planners.base import planner_names

        return (*planner_names(self.open_loop), *self.extra)

    def __contains__(self, name: object) -> bool:
        if name in self.names():
            return True
        from judgeopt.planners.base import load_plugins

        try:
            load_plugins(plugins_given())
        except JudgeoptError as exc:  # raised inside the parser: said in one line here, as its own errors are
            print_error("judgeopt", str(exc), exc.exit_code)
            sys.exit(exc.exit_code)
        return name in self.names()

    def __iter__(self):
        return iter(self.names())

    def __len__(self) -> int:
        return len(self.names())


def number(text: str) -> float:
    """An option's number: finite (nan or inf refused in one line naming the option)."""
    try:
        return finite(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}") from None


def floats(text: str) -> tuple[float, ...]:
    try:
        return tuple(finite(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated finite numbers, got {text!r}") from None


def strictly_between_0_and_1(what: str):
    """An argument type: a number strictly between 0 and 1, else one line saying `what` it is."""
    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not 0.0 < value < 1.0:  # nan too
            raise argparse.ArgumentTypeError(f"{text!r}: {what}")
        return value

    return parse


#: --risk (solve, evaluate): the failure rate a "likely" may carry
risk_rate = strictly_between_0_and_1("a failure rate between 0 and 1 (0.02 is 2 %)")


def value_range(text: str) -> tuple[float, float]:
    """LO,HI (two finite numbers)."""
    try:
        lo, hi = (finite(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not LO,HI (two finite numbers)") from None
    return lo, hi


def env_values(text: str) -> tuple[str, tuple[float, ...]]:
    """NAME=V1,V2,..."""
    name, sep, values = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=V1,V2,..., got {text!r}")
    return name.strip(), floats(values)


def name_values(text: str) -> tuple[str, tuple[float, ...] | None]:
    """NAME, or NAME=V1,V2,... (a name with its own values instead of the default ones)."""
    name, sep, values = text.partition("=")
    if not name.strip() or (sep and not values.strip()):
        raise argparse.ArgumentTypeError(f"expected NAME or NAME=V1,V2,..., got {text!r}")
    return name.strip(), floats(values) if sep else None


def env_range(text: str) -> tuple[str, tuple[float, float]]:
    """NAME=LO,HI"""
    name, sep, values = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=LO,HI, got {text!r}")
    return name.strip(), value_range(values)


def env_assignment(text: str) -> tuple[str, str]:
    """NAME=X or NAME=LO,HI (the value is checked by the problem, which knows the variable)."""
    name, sep, value = text.partition("=")
    if not sep or not name.strip() or not value.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=X or NAME=LO,HI, got {text!r}")
    return name.strip(), value.strip()


def names(text: str) -> tuple[str, ...]:
    out = tuple(n.strip() for n in text.split(",") if n.strip())
    if not out:
        raise argparse.ArgumentTypeError(f"expected comma-separated names, got {text!r}")
    return out


def positive(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {v}")
    return v


def check_range(name: str, values, allowed: tuple[float, float]) -> None:
    lo, hi = allowed
    for v in values:
        if not (lo <= v <= hi):
            raise CLIError(f"{name} = {v} is outside the scene's physical range [{lo}, {hi}]")
