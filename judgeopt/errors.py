"""judgeopt's errors: one base class carrying its exit code, so the command line maps every error
it can explain in one place (`exc.exit_code`) and a new error class needs no edit there.

The codes and their meanings are the command line's (README "Exit codes", docs/cli.md,
`judgeopt --help`). An error class picks its code by deriving from one of the kinds below,
named first where another base would give it a different code, e.g.
`class InfeasibleProblemError(Infeasible, ProblemError)`; it keeps its other bases
(ValueError, FileExistsError, ...) so that code catching those still catches it.
This module imports nothing of judgeopt: every module may raise these.
"""

from __future__ import annotations

from enum import IntEnum
from typing import ClassVar


class ExitCode(IntEnum):
    """What `judgeopt` returns (README, "Exit codes"; `judgeopt --help`)."""

    OK = 0
    INTERNAL = 1
    USAGE = 2
    INFEASIBLE = 3
    UNLIKELY = 4
    BAD_INPUT = 5
    EXISTS = 6
    MISSING = 7
    INTERRUPTED = 130


EXIT_MEANINGS = {
    ExitCode.OK: "done",
    ExitCode.INTERNAL: "a bug in judgeopt: the traceback is printed, please report it",
    ExitCode.USAGE: "a bad option, value or combination of options",
    ExitCode.INFEASIBLE: "the limits admit no plan at all (found before any solver runs)",
    ExitCode.UNLIKELY: "plans were made, but no method's plan is likely to succeed",
    ExitCode.BAD_INPUT: "a file (dataset, model, problem, plan, recording) that cannot be read or used, or an "
                        "output that cannot be written (the line names it)",
    ExitCode.EXISTS: "an output exists and --overwrite was not given",
    ExitCode.MISSING: "an optional dependency is not installed, or the judge library could not be built, or a "
                      "planning service (solve --server) could not be reached or could not plan",
    ExitCode.INTERRUPTED: "Ctrl-C or SIGTERM: workers stopped, one line says what was written; collect, evaluate, "
                          "refine and train-ensemble resume when rerun",
}

#: the commands that keep finished work as they go (chunks, rounds, members) and resume it when rerun
RESUMABLE = ("collect", "evaluate", "refine", "train-ensemble")


def interrupted(command: str | None, written: list[str] | tuple[str, ...] = ()) -> str:
    """The one line for Ctrl-C (or SIGTERM) during `judgeopt COMMAND`, saying what the user has:
    finished work kept for a rerun (a RESUMABLE command), or the files written whole before the
    interrupt (`written`; none is ever half-written), or that nothing was written."""
    if command in RESUMABLE:
        return "interrupted; what was finished is kept: rerun the same command to resume"
    if not written:
        return "interrupted: nothing was written"
    shown = ", ".join(map(str, written[:3])) + (f" and {len(written) - 3} more" if len(written) > 3 else "")
    return f"interrupted: only {shown} {'was' if len(written) == 1 else 'were'} written (whole); nothing else"


class JudgeoptError(Exception):
    """An error the user can act on: its message is one line naming the fix, and `exit_code`
    what the command line returns for it (an error not derived from this is a bug: 1, traceback)."""

    exit_code: ClassVar[ExitCode] = ExitCode.USAGE


class UsageError(JudgeoptError):
    """2: a bad option or value, typed on the command line or given to the API."""

    exit_code = ExitCode.USAGE


class Infeasible(JudgeoptError):
    """3: limits that admit no plan at all, found before any solver runs."""

    exit_code = ExitCode.INFEASIBLE


class BadInput(JudgeoptError):
    """5: a file (dataset, model, problem, plan, recording) that cannot be read or used."""

    exit_code = ExitCode.BAD_INPUT


class OutputExists(JudgeoptError):
    """6: an output that exists, without --overwrite (overwrite=True)."""

    exit_code = ExitCode.EXISTS


class Missing(JudgeoptError):
    """7: an optional dependency or a tool that is not installed, a library that could not be built, or a
    planning service that cannot be reached or cannot plan."""

    exit_code = ExitCode.MISSING
