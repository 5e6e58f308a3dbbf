"""Ctrl-C that ends in one line and exit 130 whenever it comes (judgeopt.cli.main prints the line).

Two ways it did not, both in native code that runs Python: a KeyboardInterrupt raised inside a
C++ extension's import (torch's pybind11 code) terminates the process with SIGABRT, so such
imports hold Ctrl-C until they end (`held`); and CPython marks a KeyboardInterrupt that left code
an extension ran through PyRun_* as unhandled and, under `python -m`, kills itself with SIGINT at
exit even after the interrupt was handled (`forget_nested_interrupt`). Light to import: the
package's own import holds Ctrl-C with it.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from typing import Iterator


@contextlib.contextmanager
def held() -> Iterator[None]:
    """A Ctrl-C while the block runs is raised (as KeyboardInterrupt) when it ends. Only where
    Python's own handler is installed, in the main thread: another handler is not ours to replace."""
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        yield
        return
    caught: list[int] = []
    signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if caught:
        raise KeyboardInterrupt


def forget_nested_interrupt() -> None:
    """Clear CPython's mark of an unhandled KeyboardInterrupt (set where one left a PyRun_* call
    of an extension, e.g. during torch's import), which would turn exit 130 into death by SIGINT;
    any PyRun_* call resets it before it runs."""
    import ctypes

    ctypes.pythonapi.PyRun_SimpleString(b"")
