"""The `judgeopt` command line: one package, one subcommand module per pipeline stage."""

from judgeopt.interrupts import held as _held

try:
    with _held():  # a Ctrl-C inside an extension's import (numpy's) would be an ImportError and a traceback
        from judgeopt.cli.main import main
except KeyboardInterrupt:  # Ctrl-C while its modules load (the first second): one line and 130, as later on
    from judgeopt.cli.common import command_of as _command_of, print_error as _print_error
    from judgeopt.errors import ExitCode as _ExitCode, interrupted as _interrupted

    _command = _command_of()
    _print_error(f"judgeopt{' ' + _command if _command else ''}", _interrupted(_command), _ExitCode.INTERRUPTED)
    raise SystemExit(_ExitCode.INTERRUPTED) from None

__all__ = ["main"]
