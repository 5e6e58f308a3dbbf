"""The planning processes, supervised from the server's event loop: a bounded queue in front of
them, a deadline per request, and a worker that dies replaced.

Why not concurrent.futures.ProcessPoolExecutor: when one of its processes dies (SIGKILL, a segfault
in a native library) the whole pool is broken (BrokenProcessPool) and every request after it fails;
here a dead worker costs only the request it held (503), and a new one is started. Each worker has
its own pipe, so the server always knows which request a worker holds; the pipe's end of file (the
worker's end closes when it dies, however it dies) is how a death is seen.
"""

from __future__ import annotations

import asyncio
import collections
import itertools
import json
import multiprocessing
import signal
import time
from dataclasses import dataclass, field
from typing import Any

from judgeopt.serve.worker import WorkerOptions, run
from judgeopt.serve.log import service_log

log = service_log()

#: a worker that dies before it is ready is started again after this many seconds, doubled each
#: time up to RESTART_MAX_S (a crash at start would otherwise restart in a tight loop)
RESTART_FIRST_S, RESTART_MAX_S = 0.5, 30.0


@dataclass
class Answer:
    """What a request gets: its HTTP status, the JSON body, and each planner's solve time."""

    status: int
    body: bytes
    timings: dict[str, float] = field(default_factory=dict)
    headers: dict[str, str] = field(default_factory=dict)


def error(status: int, message: str, headers: dict[str, str] | None = None) -> Answer:
    return Answer(status, json.dumps({"error": message}).encode(), headers=headers or {})


@dataclass
class Job:
    id: int
    request: dict[str, Any]
    future: asyncio.Future
    stage: str = "waiting in the queue"


@dataclass
class Worker:
    process: Any  # multiprocessing's Process (spawned)
    conn: Any  # the server's end of the worker's pipe
    started: float
    ready: bool = False
    job: Job | None = None

    @property
    def pid(self) -> int:
        return self.process.pid


def how_it_ended(exitcode: int | None) -> str:
    """A process's end in words: the signal that killed it, or its exit code."""
    if exitcode is None:
        return "its pipe closed"
    if exitcode < 0:
        try:
            return f"killed by {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"exit code {exitcode}"


class Pool:
    """`size` workers behind a queue of at most `queue` waiting requests; a request beyond them is
    told to come back in `retry_after_s`."""

    def __init__(self, size: int, queue: int, options: WorkerOptions, kill_after_s: float, retry_after_s: int):
        self.size, self.queue_size, self.options = size, queue, options
        self.kill_after_s, self.retry_after_s = kill_after_s, retry_after_s
        self.workers: list[Worker] = []
        self.waiting: collections.deque[Job] = collections.deque()
        self.ids = itertools.count(1)
        self.failure: str | None = None  # why the workers cannot load their models
        self.closing = False
        self.restarts = 0  # workers replaced after they died
        self.restart_delay = RESTART_FIRST_S
        self.context = multiprocessing.get_context("spawn")  # a fresh interpreter: no inherited threads or locks
        self.loaded: dict[str, Any] = {}  # what the workers loaded (the first ready one's report)

    # -- state ---------------------------------------------------------------------------
    @property
    def ready(self) -> int:
        return sum(w.ready for w in self.workers)

    @property
    def busy(self) -> int:
        return sum(w.job is not None for w in self.workers)

    @property
    def depth(self) -> int:
        return len(self.waiting)

    # -- lifetime --------------------------------------------------------------------------
    def start(self) -> None:
        for _ in range(self.size):
            self.spawn()

    def spawn(self) -> None:
        if self.closing or self.failure:
            return
        ours, theirs = self.context.Pipe()
        process = self.context.Process(target=run, args=(theirs, self.options), name="judgeopt-worker", daemon=True)
        process.start()
        theirs.close()  # only the worker holds its end now: its death closes the pipe
        worker = Worker(process, ours, time.monotonic())
        self.workers.append(worker)
        asyncio.get_running_loop().add_reader(ours.fileno(), self.on_readable, worker)

    async def close(self, timeout_s: float = 10.0) -> None:
        """Stop every worker (they hold no request by now: the server finished those first); one
        that does not stop within `timeout_s` is killed."""
        self.closing = True
        for job in self.waiting:
            if not job.future.done():
                job.future.set_result(error(503, "the server is stopping; send the request again when it is back"))
        self.waiting.clear()
        for w in list(self.workers):
            try:
                w.conn.send(None)
            except OSError:
                pass
        deadline = time.monotonic() + timeout_s
        while any(w.process.is_alive() for w in self.workers) and time.monotonic() < deadline:
            await asyncio.sleep(0.05)
        for w in list(self.workers):
            if w.process.is_alive():
                w.process.kill()
            w.process.join(1)
            self.forget(w)

    def forget(self, worker: Worker) -> None:
        if worker in self.workers:
            self.workers.remove(worker)
            asyncio.get_running_loop().remove_reader(worker.conn.fileno())
            worker.conn.close()

    # -- requests --------------------------------------------------------------------------
    async def run(self, request: dict[str, Any], timeout_s: float) -> Answer:
        """Plan `request` on the next free worker within `timeout_s` of now; a 503 at once where
        every worker is busy and the queue holds its most, or where no worker can load its models."""
        if self.failure:
            return error(503, self.failure)
        if len(self.waiting) >= self.queue_size and not self.idle():
            return error(503, f"every worker is busy and {len(self.waiting)} requests wait: send it again in "
                              f"{self.retry_after_s} s", {"Retry-After": str(self.retry_after_s)})
        loop = asyncio.get_running_loop()
        job = Job(next(self.ids), request, loop.create_future())
        self.waiting.append(job)
        self.dispatch()
        try:
            return await asyncio.wait_for(asyncio.shield(job.future), timeout_s)
        except asyncio.TimeoutError:
            return self.cut_short(job, timeout_s)

    def idle(self) -> list[Worker]:
        return [w for w in self.workers if w.ready and w.job is None]

    def dispatch(self) -> None:
        """Hand waiting requests to idle workers, oldest first."""
        for worker in self.idle():
            while self.waiting and self.waiting[0].future.done():
                self.waiting.popleft()
            if not self.waiting:
                return
            job = self.waiting.popleft()
            try:
                worker.conn.send(("plan", job.id, job.request))
            except OSError:  # it died a moment ago: the request waits for another
                self.waiting.appendleft(job)
                continue
            worker.job, job.stage = job, "waiting for the worker to start it"

    def cut_short(self, job: Job, timeout_s: float) -> Answer:
        """The 504 for a request past its deadline, saying where it was. A worker still on it
        finishes (its answer is dropped) or, past kill_after_s, is replaced."""
        job.future.cancel()  # what comes later for it is dropped
        if job in self.waiting:
            ahead = self.waiting.index(job)
            self.waiting.remove(job)
            return error(504, f"deadline of {timeout_s:g} s passed while the request waited in the queue ({ahead} "
                              f"ahead of it, {self.busy} being planned); nothing was planned: send it again with a "
                              "longer timeout_s or when the server is less busy")
        worker = next((w for w in self.workers if w.job is job), None)
        if worker is not None:
            asyncio.get_running_loop().call_later(self.kill_after_s, self.kill_if_still_on, worker, job)
        return error(504, f"deadline of {timeout_s:g} s passed while {job.stage}; that was cut short and no plan is "
                          f"returned: send it again with a longer timeout_s")

    def kill_if_still_on(self, worker: Worker, job: Job) -> None:
        if worker.job is job and worker.process.is_alive():
            log.warning("worker %d still on a request %g s past its deadline: replaced", worker.pid, self.kill_after_s)
            worker.process.kill()

    # -- what the workers say ----------------------------------------------------------------
    def on_readable(self, worker: Worker) -> None:
        try:
            while worker.conn.poll():
                self.on_message(worker, worker.conn.recv())
        except (EOFError, OSError):
            self.on_death(worker)

    def on_message(self, worker: Worker, message: tuple) -> None:
        kind = message[0]
        if kind == "ready":
            worker.ready, self.restart_delay = True, RESTART_FIRST_S
            self.loaded = self.loaded or message[1]["loaded"]
            log.info("worker %d ready in %.1f s", worker.pid, time.monotonic() - worker.started)
        elif kind == "failed":
            self.failure = message[1]
            log.error("%s", message[1])
        elif kind == "stage" and worker.job is not None and worker.job.id == message[1]:
            worker.job.stage = message[2]
        elif kind == "done":
            _, job_id, status, body, timings = message
            job, worker.job = worker.job, None
            if job is not None and job.id == job_id and not job.future.done():
                job.future.set_result(Answer(status, body, timings))
        self.dispatch()

    def on_death(self, worker: Worker) -> None:
        worker.process.join(2)  # its pipe closed as it died: reaped at once
        how = how_it_ended(worker.process.exitcode)
        self.forget(worker)
        job = worker.job
        if job is not None and not job.future.done():
            job.future.set_result(error(503, f"the worker planning this request stopped ({how}) while {job.stage}; "
                                             "nothing was returned and the server replaces the worker: send the "
                                             "request again"))
        if self.closing or self.failure:
            return
        log.warning("worker %d stopped (%s)%s; starting another", worker.pid, how,
                    " while planning a request" if job is not None else "")
        self.restarts += 1
        if worker.ready:
            self.spawn()
        else:  # it died while loading: wait before the next try
            asyncio.get_running_loop().call_later(self.restart_delay, self.spawn)
            self.restart_delay = min(2 * self.restart_delay, RESTART_MAX_S)
        self.dispatch()
