"""What every subcommand shares: the one-line error, argument types, the command line as typed."""

from __future__ import annotations

import argparse
import shlex
import sys


class CLIError(Exception):
    """A user-facing error: printed as one line, exit code 2."""


_ARGV: list[str] | None = None  # the arguments `main` was called with (in-process calls: tests, notebooks)


def set_argv(argv: list[str] | None) -> None:
    global _ARGV
    _ARGV = list(argv) if argv is not None else sys.argv[1:]


def command_line() -> str:
    """The command as the user typed it, recorded in every file a command writes."""
    argv = _ARGV if _ARGV is not None else sys.argv[1:]
    return "judgeopt " + " ".join(shlex.quote(a) for a in argv)


def floats(text: str) -> tuple[float, ...]:
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated numbers, got {text!r}") from None


def value_range(text: str) -> tuple[float, float]:
    """LO,HI (two numbers)."""
    try:
        lo, hi = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not LO,HI (two numbers)") from None
    return lo, hi


def env_values(text: str) -> tuple[str, tuple[float, ...]]:
    """NAME=V1,V2,..."""
    name, sep, values = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=V1,V2,..., got {text!r}")
    return name.strip(), floats(values)


def env_range(text: str) -> tuple[str, tuple[float, float]]:
    """NAME=LO,HI"""
    name, sep, values = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=LO,HI, got {text!r}")
    return name.strip(), value_range(values)


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
