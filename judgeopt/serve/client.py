"""`judgeopt.Client`: a planning service called from Python, with the standard library only (no
torch, no server packages): what a robot stack's Python node needs to ask for a plan.

    client = judgeopt.Client("http://127.0.0.1:8000")
    answer = client.plan(limits={"qdot_max": 0.4})      # the object `judgeopt solve --json` prints
    answer["verdict"], answer["recommended"]

One Client holds one keep-alive connection: use one per thread.
"""

from __future__ import annotations

import http.client
import json
import socket
import urllib.parse
from typing import Any, Mapping, Sequence

from judgeopt.errors import Missing

#: seconds a Client waits for an answer beyond the request's own deadline (the server answers 504 at
#: the deadline: this only covers the transfer)
MARGIN_S = 5.0


class ServiceError(Missing, RuntimeError):
    """A service that answered with an error (`status`, its one-line `message`, the whole `answer`;
    `retry_after` seconds where it said when to try again), or that could not be reached
    (`status` None). Exit code 7 on the command line: the service, not the request, is missing."""

    def __init__(self, message: str, status: int | None = None, answer: dict | None = None,
                 retry_after: float | None = None):
        super().__init__(message)
        self.status, self.answer, self.retry_after = status, answer or {}, retry_after


class Client:
    """A planning service (`judgeopt serve`) at `url`; `token`: its bearer token, where it has one."""

    def __init__(self, url: str = "http://127.0.0.1:8000", token: str | None = None, timeout_s: float = 60.0):
        parts = urllib.parse.urlsplit(url)
        if parts.scheme not in ("http", "https") or not parts.hostname:
            raise ServiceError(f"{url}: give the service's address as http://HOST:PORT", None)
        self.url, self.token, self.timeout_s = url.rstrip("/"), token, timeout_s
        self.parts = parts
        self.connection: http.client.HTTPConnection | None = None

    def plan(self, problem: str = "paper_sim", *, limits: Mapping[str, Any] | None = None,
             environment: Mapping[str, Any] | None = None, constraints: Mapping[str, Any] | None = None,
             methods: Sequence[str] | None = None, objective: str | None = None, simulate: bool = False,
             timeout_s: float | None = None) -> dict[str, Any]:
        """The service's plan for `problem` (a name) changed as given: the object `judgeopt solve
        --json` prints. An error answer is a ServiceError with its message; an infeasible request's
        answer (422) is in its `.answer`."""
        body: dict[str, Any] = {"problem": problem, "simulate": simulate}
        for name, value in (("limits", limits), ("environment", environment), ("constraints", constraints),
                            ("objective", objective), ("timeout_s", timeout_s)):
            if value is not None:
                body[name] = dict(value) if isinstance(value, Mapping) else value
        if methods is not None:
            body["methods"] = [methods] if isinstance(methods, str) else list(methods)
        wait = (timeout_s or self.timeout_s) + MARGIN_S
        return self.request("POST", "/v1/plan", body, wait)

    def health(self) -> dict[str, Any]:
        return self.request("GET", "/v1/health")

    def ready(self) -> dict[str, Any]:
        return self.request("GET", "/v1/ready")

    def models(self) -> dict[str, Any]:
        return self.request("GET", "/v1/models")

    def close(self) -> None:
        if self.connection is not None:
            self.connection.close()
            self.connection = None

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def request(self, method: str, path: str, body: dict[str, Any] | None = None,
                timeout_s: float | None = None) -> dict[str, Any]:
        """One call; a connection the server closed while idle is opened again once (every route
        is safe to repeat: a plan request changes nothing on the server)."""
        data = json.dumps(body, allow_nan=False).encode() if body is not None else None
        headers = {"Accept": "application/json", **({"Content-Type": "application/json"} if data else {}),
                   **({"Authorization": f"Bearer {self.token}"} if self.token else {})}
        for attempt in (1, 2):
            fresh = self.connection is None
            try:
                conn = self.connect(timeout_s or self.timeout_s)
                conn.request(method, (self.parts.path.rstrip("/") + path), body=data, headers=headers)
                response = conn.getresponse()
                raw = response.read()
                break
            except (http.client.RemoteDisconnected, BrokenPipeError, ConnectionResetError) as exc:
                self.close()
                if fresh or attempt == 2:
                    raise ServiceError(f"{self.url}: the connection broke ({exc}); is the service running?") from None
            except (OSError, http.client.HTTPException) as exc:
                self.close()
                reason = "no answer in time" if isinstance(exc, socket.timeout) else (
                    getattr(exc, "strerror", None) or str(exc) or type(exc).__name__)
                raise ServiceError(f"{self.url}: cannot reach the planning service ({reason}); start it with "
                                   "`judgeopt serve` or check the address") from None
        try:
            answer = json.loads(raw)
        except ValueError:
            raise ServiceError(f"{self.url}{path}: answered {response.status} with no JSON; is this a judgeopt "
                               "service?", response.status) from None
        if response.status >= 400:
            retry = response.getheader("Retry-After")
            raise ServiceError(f"{self.url}{path}: {response.status}: {answer.get('error', answer)}", response.status,
                               answer, float(retry) if retry and retry.replace(".", "", 1).isdigit() else None)
        return answer

    def connect(self, timeout_s: float) -> http.client.HTTPConnection:
        if self.connection is None:
            kind = http.client.HTTPSConnection if self.parts.scheme == "https" else http.client.HTTPConnection
            self.connection = kind(self.parts.hostname, self.parts.port, timeout=timeout_s)
        self.connection.timeout = timeout_s
        if self.connection.sock is not None:
            self.connection.sock.settimeout(timeout_s)
        return self.connection

