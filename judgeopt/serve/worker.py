"""One planning process of the service: it loads its models once, then answers plan requests read
from its pipe until told to stop or until the pipe closes (the server is gone).

Why processes and one torch thread each: the planners are single-threaded arithmetic on small
networks (judgeopt.threads), so the cores are used by running one request per core; a process
also confines a crash in a native library (Ipopt, libtorch, PyBullet) to the one request it held.

Messages (tuples of plain values, between this package's own processes only; nothing a client
sends is unpickled): the server sends ("plan", id, request) or None (stop); the worker answers
("ready", info) once, ("failed", message) if its models cannot load, ("stage", id, text) as a
request moves on (what a deadline cut short) and ("done", id, status, json bytes, timings).
"""

from __future__ import annotations

import json
import math
import os
import signal
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from judgeopt.errors import JudgeoptError
from judgeopt.serve.log import INTERNAL_ERROR, one_line, service_log


#: HTTP status by judgeopt's exit code: a request the planners refuse is the client's to fix (422);
#: a missing extra or library is the server's (500)
STATUS_OF_EXIT = {2: 422, 3: 422, 5: 422, 7: 500}


@dataclass(frozen=True)
class WorkerOptions:
    """What every worker is started with (from ServeConfig)."""

    problems: dict[str, Path]
    models_dir: str
    preload: tuple[str, ...]
    cache: int


def finite_json(body: dict[str, Any]) -> bytes:
    """`body` as strict JSON (what a C++ or browser parser reads): a number that is not finite,
    which JSON cannot hold, is null."""
    try:
        return json.dumps(body, allow_nan=False).encode()
    except ValueError:
        def clean(x: Any) -> Any:
            if isinstance(x, float) and not math.isfinite(x):
                return None
            if isinstance(x, dict):
                return {k: clean(v) for k, v in x.items()}
            return [clean(v) for v in x] if isinstance(x, (list, tuple)) else x
        return json.dumps(clean(body), allow_nan=False).encode()


class Planning:
    """A worker's loaded planners, one per problem (with its limits and environment) and set of
    planners asked for, the least recently used dropped beyond `cache`; and its simulators."""

    def __init__(self, options: WorkerOptions):
        from judgeopt.recent import Recent
        from judgeopt.serve.request import PreparedRequests

        self.options = options
        self.loaded = Recent(options.cache)
        self.simulators: dict[tuple[str, str], Any] = {}
        self.prepared = PreparedRequests(options.problems, options.cache)

    def planners(self, prepared: Any, stage: Callable[[str], None]) -> Any:
        """The planners for a prepared request, loaded as `judgeopt solve` loads them (so the
        answer is the one solve gives: its notes, its generator) the first time, then reused, in
        the request's environment too; a copy whose notes are the request's own."""
        from judgeopt.session import solve as session
        from judgeopt.planners.base import with_uses
        from judgeopt.planners.loaded import Planners

        problem, asked = prepared.problem, prepared.methods

        def load() -> Any:
            if len(asked) == 1:
                methods, fallback = session.methods_for(problem, asked[0], None, self.options.models_dir,
                                                        prepared.simulate)
            else:
                methods, fallback = with_uses(asked), None
            stage(f"loading the planners ({', '.join(methods)}) for problem {problem.name}")
            planners = Planners.load(problem, methods, models_dir=self.options.models_dir)
            if fallback:
                planners.notes.append(fallback)
            return planners

        # kept by what was asked, so a request asked again skips choosing its models (reading each
        # generator's metadata: about 1 ms)
        return self.loaded.get_or_make((prepared.planners_key, asked, prepared.simulate), load).in_environment(problem)

    def simulator(self, task: str, robot: str) -> Any:
        """The task's simulator with arm `robot`, made once per worker (as solve makes it)."""
        if (task, robot) not in self.simulators:
            from judgeopt.api import simulator

            self.simulators[task, robot] = simulator(task, robot)
        return self.simulators[task, robot]

    def plan(self, request: dict[str, Any], stage: Callable[[str], None]) -> tuple[int, bytes, dict[str, float]]:
        """(HTTP status, the answer as JSON, each planner's solve time) for one request."""
        from judgeopt.session import solve as session
        from judgeopt.serve.request import InfeasibleRequest

        try:
            prepared = self.prepared.get(request)
        except InfeasibleRequest as exc:
            return 422, finite_json({"error": str(exc), **exc.answer}), {}
        planners = self.planners(prepared, stage)
        sim = self.simulator(prepared.problem.task, prepared.problem.robot) if prepared.simulate else None
        stage(f"planning with {', '.join(planners.methods)}" + (" and replaying the plans in simulation" if sim else ""))
        report = session.solve(planners, simulator=sim, ranges=prepared.ranges)
        return 200, finite_json(report.to_json()), {r.method: r.solve_time_s for r in report.results}

    def answer(self, request: dict[str, Any], stage: Callable[[str], None]) -> tuple[int, bytes, dict[str, float]]:
        """`plan`, with an error the user can act on as its one line (a 4xx), any other as a 500
        whose traceback goes to the server's log, never to the client."""
        try:
            return self.plan(request, stage)
        except JudgeoptError as exc:
            return STATUS_OF_EXIT.get(int(exc.exit_code), 500), finite_json({"error": str(exc)}), {}
        except ModuleNotFoundError as exc:  # an optional extra the server lacks (the simulator's, for simulate)
            return 500, finite_json({"error": f"the server cannot do this: {exc.name} is not installed there"}), {}
        except Exception:  # a bug: the client learns that much, the log the rest
            service_log().error("internal error in worker %d: %s", os.getpid(), one_line(traceback.format_exc()))
            return 500, finite_json({"error": INTERNAL_ERROR}), {}

    def preload(self) -> dict[str, Any]:
        """Load the problems named to preload (default planners, no simulation) and plan once for
        each (what a first solve pays, paid before the worker says it is ready); what was loaded."""
        from judgeopt.serve.schema import PlanRequest

        loaded = {}
        for name in self.options.preload:
            status, body, _ = self.plan(PlanRequest(problem=name).model_dump(), lambda text: None)
            answer = json.loads(body)
            if status != 200:
                raise RuntimeError(f"--preload {name}: {answer.get('error') or answer.get('message')}")
            loaded[name] = {k: answer[k] for k in ("judge", "judge_sha256", "generator")}
        return loaded


def run(conn: Any, options: WorkerOptions) -> None:
    """A worker process's life: one torch thread, the models loaded (without torch where a fast
    start can: planners.loaded.fast_models), then requests until told to stop. SIGINT and SIGTERM
    are the server's to handle (a Ctrl-C in the terminal or systemd's stop reaches the whole process
    group): the worker finishes what it holds and stops when asked."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    for name in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        os.environ[name] = "1"  # before torch and numpy start their pools
    from judgeopt.judge.compiled import enable_fast_start
    from judgeopt.threads import set_threads

    set_threads(1, lazy=True)  # torch is imported where a request needs it (judge.compiled: a fast start)
    enable_fast_start()
    planning = Planning(options)
    try:
        loaded = planning.preload()
    except Exception as exc:  # the same for every worker: the server says it and stops replacing them
        conn.send(("failed", f"worker {os.getpid()} could not load its models: {exc}"))
        return
    conn.send(("ready", {"pid": os.getpid(), "loaded": loaded}))
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):  # the server is gone
            return
        if message is None:
            return
        _, job, request = message
        try:
            status, body, timings = planning.answer(request, lambda text, job=job: conn.send(("stage", job, text)))
            conn.send(("done", job, status, body, timings))
        except OSError:  # the server is gone while this was planned
            return
