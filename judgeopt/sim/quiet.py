"""PyBullet prints its build banner and URDF warnings from C (the banner on stdout in some
builds, on stderr in others); on stdout they would corrupt `--json` output. The banner is
discarded; the warnings go to stderr, or nowhere under `--quiet` (QUIET_ENV, which worker
processes inherit)."""

from __future__ import annotations

import contextlib
import os
import sys
from typing import Iterator

from judgeopt.sim import QUIET_ENV


@contextlib.contextmanager
def _c_output(fds: tuple[int, ...], discard: bool) -> Iterator[None]:
    """C code's output on file descriptors `fds` goes to stderr, or nowhere, while the block runs."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(fd) for fd in fds]
    target = os.open(os.devnull, os.O_WRONLY) if discard else os.dup(2)
    try:
        for fd in fds:
            os.dup2(target, fd)
        yield
    finally:
        for fd, copy in zip(fds, saved):
            os.dup2(copy, fd)
            os.close(copy)
        os.close(target)


def c_stdout_to_stderr() -> contextlib.AbstractContextManager[None]:
    """C code's stdout on stderr while the block runs; its stdout and stderr discarded when QUIET_ENV is set."""
    quiet = bool(os.environ.get(QUIET_ENV))
    return _c_output((1, 2) if quiet else (1,), discard=quiet)


# the build banner tells a user nothing, and beside an error it would make a bad input's one line two
with _c_output((1, 2), discard=True):
    import pybullet as pb  # noqa: E402

__all__ = ["pb", "c_stdout_to_stderr"]
