"""Ctrl-C held while native code runs Python, and acted on when the native code has returned.

Why: a KeyboardInterrupt raised where native code called back into Python is lost or fatal. Inside
a C++ extension's import (torch's pybind11 code) it terminates the process with SIGABRT; CasADi runs
Python's handler inside its own calls and drops the KeyboardInterrupt (in a judge callback Ipopt goes
on to converge; in a symbolic build the build goes on). So such code runs with SIGINT recorded instead
of raised. Shared by the command line (imports), the direct planner and the simulator's compiled step
(CasADi), hence here and public. Light to import (signal and threading only):
judgeopt.cli's own import holds Ctrl-C with it.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from typing import Any, Callable, Iterator


@contextlib.contextmanager
def held() -> Iterator[None]:
    """A Ctrl-C while the block runs is raised (as KeyboardInterrupt) when it ends, for imports of
    native code. Only where Python's own handler is installed: raising KeyboardInterrupt is what that
    handler would have done, while another handler (a host program's) is not ours to stand in for."""
    with _recording(lambda handler: handler is signal.default_int_handler) as caught:
        yield
    if caught:
        raise KeyboardInterrupt


@contextlib.contextmanager
def sigint_recorded() -> Iterator[list[int]]:
    """The SIGINTs that arrive while the block runs, recorded in the list it yields instead of handled;
    the caller raises KeyboardInterrupt once the block has ended. For code that runs CasADi (an Ipopt
    solve, a symbolic build), which calls Python's handler itself and drops what it raises (13 of 20
    Ctrl-Cs during a loop of plain SX/MX operations). So it acts wherever SIGINT is handled from Python
    and not ignored, whatever the handler: a host's handler run inside CasADi would have its exception
    dropped too, and a solve would go on for up to max_cpu_time after the user asked it to stop."""
    with _recording(lambda handler: handler is not None) as caught:  # None: installed from C, not Python
        yield caught


@contextlib.contextmanager
def _recording(replaceable: Callable[[Any], bool]) -> Iterator[list[int]]:
    """SIGINTs recorded in the yielded list while the block runs, the handler before restored after.
    Only in the main thread (Python runs signal handlers nowhere else) and only where `replaceable`
    accepts the handler installed (never SIG_IGN: ignored on purpose); elsewhere the list stays empty."""
    if threading.current_thread() is not threading.main_thread():
        yield []
        return
    previous = signal.getsignal(signal.SIGINT)
    if previous == signal.SIG_IGN or not replaceable(previous):
        yield []
        return
    caught: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield caught
    finally:
        signal.signal(signal.SIGINT, previous)
