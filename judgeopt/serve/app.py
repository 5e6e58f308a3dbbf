"""The service's ASGI app (FastAPI): its routes, the bearer token, the body limit, one-line errors,
one log line per request, the metrics.

Every answer that is not a plan is {"error": "one line"}: what is wrong and how to fix it, the same
text the command line gives for the same value where there is one. A request is checked here (the
schema, then the problem as the command line checks it) before it takes a worker, so a bad request
costs no planning. Nothing a request sends is logged: a log line holds the method, the route's
template, the status and the time.
"""

from __future__ import annotations

import contextlib
import hmac
import time
import traceback
from pathlib import Path
from typing import Any, AsyncIterator

from fastapi import FastAPI, Request, Security
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response
from fastapi.security import HTTPBearer
from starlette.exceptions import HTTPException

from judgeopt import __version__
from judgeopt.errors import JudgeoptError
from judgeopt.serve.config import ServeConfig
from judgeopt.serve.metrics import Metrics
from judgeopt.serve.pool import Pool
from judgeopt.serve.request import InfeasibleRequest, PreparedRequests
from judgeopt.serve.schema import ErrorAnswer, Health, PlanAnswer, PlanRequest, Ready, describe_errors
from judgeopt.serve.worker import WorkerOptions
from judgeopt.serve.log import INTERNAL_ERROR, one_line, service_log

log = service_log()

#: the routes that answer without the token: a load balancer's liveness probe
OPEN_ROUTES = ("/v1/health",)
#: what the service answers (named in a 404), and what a log line or a metric may name
PATHS = ("/v1/plan", "/v1/health", "/v1/ready", "/v1/models", "/metrics", "/openapi.json", "/docs")
ROUTES = f"POST /v1/plan, GET {', '.join(PATHS[1:])}"
METHODS = ("GET", "POST", "HEAD", "PUT", "PATCH", "DELETE", "OPTIONS")
ERRORS = {code: {"model": ErrorAnswer} for code in (400, 401, 413, 415, 422, 500, 503, 504)}


def error(status: int, message: str, headers: dict[str, str] | None = None,
          fields: dict[str, Any] | None = None) -> JSONResponse:
    """{"error": message} (and `fields`: an infeasible request's answer) with `status`."""
    return JSONResponse({"error": message, **(fields or {})}, status_code=status, headers=headers)


class Guard:
    """Before the app: the token (constant-time compare), the body's size (declared, and counted as
    it is read) and type. After it: one log line and the request's count and latency, by route
    template (never the raw path)."""

    def __init__(self, app: Any, token: str | None, max_body_bytes: int, metrics: Metrics):
        self.app, self.token, self.max_body_bytes, self.metrics = app, token, max_body_bytes, metrics

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        t0, status = time.perf_counter(), [0]

        async def sending(message: dict) -> None:
            if message["type"] == "http.response.start":
                status[0] = message["status"]
            await send(message)

        received = [0]

        async def receiving() -> dict:  # a body sent without its length (chunked) is counted as it comes
            message = await receive()
            received[0] += len(message.get("body", b""))
            if received[0] > self.max_body_bytes:
                raise HTTPException(413)  # the app's handler answers it
            return message

        refused = self.refusal(scope)
        try:
            await (refused or self.app)(scope, receiving if refused is None else receive, sending)
        except Exception:  # a bug: one line in the log (never the request's data as lines), a 500 to the client
            log.error("internal error: %s", one_line(traceback.format_exc()))
            if not status[0]:
                await error(500, INTERNAL_ERROR)(scope, receive, sending)
        path = getattr(scope.get("route"), "path", None) or scope["path"]
        route = path if path in PATHS else "unmatched"
        seconds = time.perf_counter() - t0
        self.metrics.answered(route, status[0], seconds)
        method = scope["method"] if scope["method"] in METHODS else "other"
        log.info("%s %s %d %.1f ms", method, route, status[0], 1e3 * seconds)

    def refusal(self, scope: dict) -> Response | None:
        headers = {k.decode("latin-1").lower(): v for k, v in scope["headers"]}
        if self.token is not None and scope["path"] not in OPEN_ROUTES:
            given = headers.get("authorization", b"")
            if not hmac.compare_digest(given, b"Bearer " + self.token.encode()):
                return error(401, "a bearer token is needed: send the header 'Authorization: Bearer TOKEN' with the "
                                  "token in the server's --token-file", {"WWW-Authenticate": "Bearer"})
        length = headers.get("content-length", b"0")
        if not length.isdigit():
            return error(400, "Content-Length is not a number")
        if int(length) > self.max_body_bytes:
            return error(413, f"the body is {int(length)} bytes; this server takes at most {self.max_body_bytes} (a plan "
                              "request is under 2 kB: send the problem by name, not its data)")
        if scope["path"] == "/v1/plan" and scope["method"] == "POST" \
                and not headers.get("content-type", b"").startswith(b"application/json"):
            return error(415, "send the body as JSON, with the header 'Content-Type: application/json'")
        return None


def create_app(config: ServeConfig, problems: dict[str, Path], token: str | None = None) -> FastAPI:
    """The app for `config`, planning `problems` (request.problem_files), its workers started and
    stopped with it; every route but /v1/health needs `token` where one is given."""
    pool = Pool(config.workers, config.queue, WorkerOptions(problems, config.models_dir, config.preload, config.cache),
                config.kill_after_s, config.retry_after_s)
    prepared = PreparedRequests(problems, config.cache)
    metrics = Metrics(lambda: pool.depth, lambda: pool.busy, lambda: pool.ready, lambda: pool.restarts)

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        pool.start()
        yield
        await pool.close()

    app = FastAPI(title="judgeopt planning service", version=__version__, lifespan=lifespan,
                  description="Plans contact-rich motions against a learned success judge: POST a request, get the "
                              "object `judgeopt solve --json` prints. docs/guides/service.md tells how to run and call it.")
    app.add_middleware(Guard, token=token, max_body_bytes=config.max_body_bytes, metrics=metrics)
    bearer = [Security(HTTPBearer(auto_error=False))] if token is not None else []  # documents it: Guard checks it

    @app.exception_handler(RequestValidationError)
    async def invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        errors = exc.errors()
        return error(400 if any(e["type"] == "json_invalid" for e in errors) else 422, describe_errors(errors))

    @app.exception_handler(HTTPException)
    async def http_error(request: Request, exc: HTTPException) -> JSONResponse:
        message = {404: f"no such route; this service answers {ROUTES}",
                   405: f"this route does not take that method; this service answers {ROUTES}",
                   413: f"the body is over the {config.max_body_bytes} bytes this server takes"}.get(exc.status_code,
                                                                                                      str(exc.detail))
        return error(exc.status_code, message, getattr(exc, "headers", None))

    @app.post("/v1/plan", response_model=None, dependencies=bearer, responses={200: {"model": PlanAnswer}, **ERRORS},
              summary="plan a motion", description="The answer is the object `judgeopt solve --json` prints for the "
              "same problem, limits, environment, constraints, planners and objective. 422: a bad value or infeasible "
              "limits (then with the infeasible object's fields); 503: the queue is full (Retry-After) or the worker "
              "died; 504: past the deadline, saying what was cut short.")
    async def plan(request: PlanRequest) -> Response:
        timeout = request.timeout_s or config.timeout_s
        if timeout > config.max_timeout_s:
            return error(422, f"timeout_s {timeout:g}: this server allows at most {config.max_timeout_s:g} s "
                              "(its --max-timeout)")
        sent = request.model_dump()
        try:
            prepared.get(sent)  # the command line's checks, before a worker is taken
        except InfeasibleRequest as exc:
            return error(422, str(exc), fields=exc.answer)
        except JudgeoptError as exc:
            return error(422, str(exc))
        answer = await pool.run(sent, timeout)
        for planner, seconds in answer.timings.items():
            metrics.planner.labels(planner).observe(seconds)
        return Response(answer.body, status_code=answer.status, headers=answer.headers, media_type="application/json")

    @app.get("/v1/health", response_model=Health, summary="the server answers")
    async def health() -> Health:
        return Health(status="alive", version=__version__, queued=pool.depth,
                      workers=[{"pid": w.pid, "ready": w.ready, "busy": w.job is not None} for w in pool.workers])

    @app.get("/v1/ready", response_model=Ready, dependencies=bearer, responses={503: {"model": ErrorAnswer}},
             summary="a worker has its models loaded")
    async def ready() -> Any:
        if pool.failure:
            return error(503, pool.failure)
        if not pool.ready:
            return error(503, f"no worker has loaded its models yet (0 of {config.workers}); ask again in a few seconds")
        return Ready(ready=True, workers_ready=pool.ready, workers=config.workers)

    @app.get("/v1/models", dependencies=bearer, summary="the problems, planners and models this server plans with")
    async def models() -> dict[str, Any]:
        from judgeopt.planners.base import GROUPS, REGISTRY
        from judgeopt.robots import robot_names
        from judgeopt.serve.request import base_problem

        return {"problems": [{"name": name, "task": base_problem(p).task, "description": base_problem(p).description}
                             for name, p in problems.items()],
                "methods": {"groups": list(GROUPS), "planners": {n: s.description for n, s in REGISTRY.items()}},
                "robots": list(robot_names()),
                "loaded": pool.loaded}

    @app.get("/metrics", dependencies=bearer, response_class=Response, summary="Prometheus' text format")
    async def prometheus() -> Response:
        from prometheus_client import CONTENT_TYPE_LATEST

        return Response(metrics.text(), media_type=CONTENT_TYPE_LATEST)

    return app
