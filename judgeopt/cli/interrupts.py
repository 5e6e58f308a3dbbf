"""Exit 130, not death by SIGINT, after a Ctrl-C the command line handled (judgeopt.cli.main).

CPython marks a KeyboardInterrupt that left code an extension ran through PyRun_* (torch's import)
as unhandled and, under `python -m`, kills itself with SIGINT at exit even after the interrupt was
handled. The process's exit status is the command line's business, hence here; holding Ctrl-C in
native code (judgeopt.interrupts) is shared with the planners.
"""

from __future__ import annotations


def forget_nested_interrupt() -> None:
    """Clear CPython's mark of an unhandled KeyboardInterrupt (set where one left a PyRun_* call
    of an extension, e.g. during torch's import), which would turn exit 130 into death by SIGINT;
    any PyRun_* call resets it before it runs."""
    import ctypes

    ctypes.pythonapi.PyRun_SimpleString(b"")
