"""The command's own exit status, not death by SIGINT, however late a Ctrl-C comes (judgeopt.cli.main).

Two ways it was not: CPython marks a KeyboardInterrupt that left code an extension ran through
PyRun_* (torch's import) as unhandled and, under `python -m`, kills itself with SIGINT at exit even
after the interrupt was handled (`forget_nested_interrupt`); and a Ctrl-C after main returned, in
runpy or the interpreter's teardown, escaped every handler (`ignore_late_interrupts`). The process's
exit status is the command line's business, hence here; holding Ctrl-C in native code
(judgeopt.interrupts) is shared with the planners.
"""

from __future__ import annotations

import signal
import threading


def ignore_late_interrupts() -> None:
    """Ignore SIGINT from now on, in a process that exits once the command's outcome is decided. A
    Ctrl-C after that point was raised in runpy or in `sys.exit` (a traceback, and under `python -m`
    death by SIGINT) or, once the interpreter's teardown had put back the default action, killed the
    process by SIGINT outright: exit -2 after a command that had finished. Ignored, the command's
    outcome (its output, and 0 or 130) stands. The teardown keeps an ignored SIGINT ignored."""
    if threading.current_thread() is threading.main_thread():  # elsewhere signal.signal refuses
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def forget_nested_interrupt() -> None:
    """Clear CPython's mark of an unhandled KeyboardInterrupt (set where one left a PyRun_* call
    of an extension, e.g. during torch's import), which would turn exit 130 into death by SIGINT;
    any PyRun_* call resets it before it runs."""
    import ctypes

    ctypes.pythonapi.PyRun_SimpleString(b"")
