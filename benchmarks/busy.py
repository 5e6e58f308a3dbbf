"""Every core spun by another process while a benchmark times, as on a robot's computer: one
spinning process per core, switched on and off (an Event) so idle and busy timings can alternate
in one run and see the same machine otherwise. Shared by the benchmarks' --busy options."""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import time
from typing import Iterator


class Load:
    """The spinning processes (none where `on` is False); `busy()` spins them for a block."""

    def __init__(self, on: bool) -> None:
        self.event = mp.Event()
        self.procs = [mp.Process(target=_spin, args=(self.event,), daemon=True) for _ in range(os.cpu_count() or 1)] if on else []
        for q in self.procs:
            q.start()

    @contextlib.contextmanager
    def busy(self) -> Iterator[None]:
        self.event.set()
        time.sleep(0.05)  # let the spinners take the cores
        try:
            yield
        finally:
            self.event.clear()

    def close(self) -> None:
        for q in self.procs:
            q.terminate()


def _spin(event) -> None:
    while True:
        event.wait()
        x = 0
        while event.is_set():
            for _ in range(10000):
                x += 1
