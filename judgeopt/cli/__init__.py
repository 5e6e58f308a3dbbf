"""The `judgeopt` command line: one package, one subcommand module per pipeline stage."""

import signal as _signal

#: a Ctrl-C while the modules load is held until they have loaded: raised inside an extension's import
#: (numpy's), it surfaces as that module's ImportError and a traceback instead of a KeyboardInterrupt
_held: list[int] = []
try:
    _before = _signal.getsignal(_signal.SIGINT)
    if _before is _signal.default_int_handler:
        _signal.signal(_signal.SIGINT, lambda signum, frame: _held.append(signum))
except ValueError:  # not the main thread: signals are not ours to hold
    _before = None

try:
    try:
        from judgeopt.cli.main import main
    finally:
        if _before is _signal.default_int_handler:
            _signal.signal(_signal.SIGINT, _before)
    if _held:
        raise KeyboardInterrupt
except KeyboardInterrupt:  # Ctrl-C while its modules load (the first second): one line and 130, as later on
    from judgeopt.cli.common import command_of as _command_of, print_error as _print_error
    from judgeopt.errors import ExitCode as _ExitCode, interrupted as _interrupted

    _command = _command_of()
    _print_error(f"judgeopt{' ' + _command if _command else ''}", _interrupted(_command), _ExitCode.INTERRUPTED)
    raise SystemExit(_ExitCode.INTERRUPTED) from None

__all__ = ["main"]
