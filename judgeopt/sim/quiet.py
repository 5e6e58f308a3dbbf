"""PyBullet prints its build banner and URDF warnings on the C-level stdout, which would
corrupt `--json` output; this redirects file descriptor 1 around those calls."""

from __future__ import annotations

import contextlib
import os
import sys
from typing import Iterator


@contextlib.contextmanager
def c_stdout_to_stderr() -> Iterator[None]:
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


with c_stdout_to_stderr():
    import pybullet as pb  # noqa: E402

__all__ = ["pb", "c_stdout_to_stderr"]
