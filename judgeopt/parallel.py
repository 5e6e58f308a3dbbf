"""The one way judgeopt runs work in parallel: joblib, on local processes or a Dask cluster.

Long jobs (collection, evaluation, refinement) are cut into chunks; each finished chunk is
written to its own file as soon as it arrives, so an interrupted job resumes from the chunks
on disk and gives what an uninterrupted one gives. Worker processes keep what is costly to
build (simulators, loaded planners) in `worker_cache` between chunks.
"""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

_CACHE: dict[str, Any] = {}


def worker_cache(key: str, build: Callable[[], Any]) -> Any:
    """`build()` once per process and key (a simulator, a set of loaded planners)."""
    if key not in _CACHE:
        _CACHE[key] = build()
    return _CACHE[key]


@contextlib.contextmanager
def backend(scheduler: str | None, n_jobs: int) -> Iterator[int]:
    """Local processes, or the workers of a Dask distributed cluster at `scheduler`; yields
    the number of workers."""
    from joblib import parallel_config  # here, not at the top: the command line imports this module at start-up

    if scheduler is None:
        with parallel_config(backend="loky", n_jobs=n_jobs):
            yield n_jobs
        return
    from dask.distributed import Client

    with Client(scheduler) as client, parallel_config(backend="dask", n_jobs=-1):
        yield max(1, sum(client.nthreads().values()))


@contextlib.contextmanager
def stop_workers_on_sigterm() -> Iterator[None]:
    """SIGTERM (a scheduler's or `kill`'s) is handled like Ctrl-C: it raises KeyboardInterrupt in
    the main process, so joblib stops and reaps its worker processes instead of orphaning them."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt(f"signal {signum}")

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _keyed(key: Any, fn: Callable, args: tuple) -> tuple[Any, Any]:
    return key, fn(*args)


def run_chunks(work: Sequence[tuple[Any, Callable, tuple]], save: Callable[[Any, Any], None], *,
               n_jobs: int = -1, scheduler: str | None = None, progress: bool = True, desc: str = "",
               unit: str = "chunk", sizes: dict[Any, int] | None = None, done: int = 0) -> dict[Any, Any]:
    """Run `fn(*args)` for each (key, fn, args) in parallel, in any order; `save(key, result)`
    as each arrives (write it to the chunk's file there). Returns {key: result}.

    `sizes`: units per chunk for the progress bar (default 1 each); `done`: units already done.
    """
    out: dict[Any, Any] = {}
    if not work:
        return out
    from joblib import Parallel, delayed
    from tqdm import tqdm

    size = (lambda k: sizes[k]) if sizes else (lambda k: 1)
    total = done + sum(size(k) for k, _, _ in work)
    with stop_workers_on_sigterm(), backend(scheduler, n_jobs), \
            tqdm(total=total, initial=done, desc=desc, unit=unit, disable=not progress) as bar:
        for key, result in Parallel(return_as="generator_unordered")(delayed(_keyed)(*w) for w in work):
            save(key, result)
            out[key] = result
            bar.update(size(key))
    return out



def _saved_chunk(path: Path) -> Any:
    """A chunk an earlier run wrote, or None where there is none or it cannot be read (it is then redone)."""
    if not path.exists():
        return None
    try:
        return json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        print(f"note: {path} is unreadable (a damaged chunk): redoing it")
        return None


def run_json_chunks(work: Sequence[tuple[Path, Callable, tuple]], *, n_jobs: int = -1, scheduler: str | None = None,
                    progress: bool = True, desc: str = "") -> list[Any]:
    """Each chunk's result: read back from its JSON file where one exists, else `fn(*args)` run in
    parallel (run_chunks) and written there atomically as it arrives, so a rerun resumes. In the
    order of `work`."""
    from judgeopt.files import atomic_write

    done = {path: saved for path, saved in ((p, _saved_chunk(p)) for p, _, _ in work) if saved is not None}
    todo = [w for w in work if w[0] not in done]
    done.update(run_chunks(todo, lambda p, r: atomic_write(p, json.dumps(r).encode()), n_jobs=n_jobs,
                           scheduler=scheduler, progress=progress, desc=f"{desc} ({len(done)} chunks already done)"))
    return [done[path] for path, _, _ in work]
