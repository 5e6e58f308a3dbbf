"""The service's settings, each default defined once (the command line reads them from here), and
who may listen where: a loopback address by default, any other only with a bearer token.

Why a token for any other address: a plan request costs a worker tens of milliseconds to seconds,
and its answer names the server's models; on a robot's network neither should be open to whoever
can reach the port.
"""

from __future__ import annotations

import ipaddress
import os
from dataclasses import dataclass, field
from pathlib import Path

from judgeopt.errors import BadInput, UsageError

#: the shortest token accepted: a guessable one is no protection
MIN_TOKEN_CHARS = 16


def default_workers() -> int:
    """One planning process per core this process may run on."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


@dataclass(frozen=True)
class ServeConfig:
    """What `judgeopt serve` runs with (its options, one each)."""

    host: str = "127.0.0.1"
    port: int = 8000  # 0: a free port, printed at start
    workers: int = field(default_factory=default_workers)  # planning processes
    queue: int = 8  # requests waiting for a worker beyond those being planned; more: 503 with Retry-After
    max_body_bytes: int = 65536  # a request body above this: 413 (a full request is under 2 kB)
    timeout_s: float = 30.0  # a request's deadline where it names none (timeout_s)
    max_timeout_s: float = 300.0  # the longest deadline a request may ask for
    kill_after_s: float = 10.0  # a worker still on a request this long after its deadline is replaced
    shutdown_s: float = 30.0  # SIGTERM: how long requests in flight may take to finish
    token_file: str | None = None  # bearer token every request but /v1/health must carry
    problems: tuple[str, ...] = ()  # problem files served besides the shipped ones, by their file's stem
    models_dir: str = "models"  # where generators are looked for (as solve --models)
    preload: tuple[str, ...] = ("paper_sim",)  # problems each worker loads before it says it is ready
    # planners kept loaded per worker (one per problem, limits and planners asked for); as many prepared
    # requests kept by the server and each worker (request.PreparedRequests)
    cache: int = 16
    retry_after_s: int = 1  # what a 503 tells a client to wait

    def check(self) -> None:
        """One line for a setting that cannot work, before anything starts."""
        for name in ("workers", "cache"):
            if getattr(self, name) < 1:
                raise UsageError(f"--{name} {getattr(self, name)}: give a whole number >= 1")
        if self.queue < 0:
            raise UsageError(f"--queue {self.queue}: give a whole number >= 0 (0: only what the workers hold)")
        if not 0 <= self.port <= 65535:
            raise UsageError(f"--port {self.port}: give a port in 0..65535 (0: a free one)")
        for name in ("timeout_s", "max_timeout_s", "kill_after_s", "shutdown_s"):
            if not getattr(self, name) > 0:
                raise UsageError(f"--{name[:-2].replace('_', '-')} {getattr(self, name)}: give a positive number of seconds")
        if self.timeout_s > self.max_timeout_s:
            raise UsageError(f"--timeout {self.timeout_s:g} is above --max-timeout {self.max_timeout_s:g}")
        if not is_loopback(self.host) and self.token_file is None:
            raise UsageError(f"--host {self.host} is reachable from other machines: give --token-file FILE (a bearer "
                             "token every request must carry), or bind 127.0.0.1")


def is_loopback(host: str) -> bool:
    """Only this machine can connect to `host` (127.0.0.0/8, ::1, localhost)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def read_token(path: str) -> str:
    """The bearer token in `path` (its first line, without surrounding blanks): one line saying what
    is wrong with a missing, empty or short one."""
    try:
        lines = Path(path).read_text().strip().splitlines()
    except OSError as exc:
        raise BadInput(f"--token-file {path}: cannot be read ({exc.strerror}); give a file holding the token on its "
                       "first line") from None
    except UnicodeDecodeError:
        raise BadInput(f"--token-file {path}: not a text file; give a file holding the token on its first line") from None
    token = lines[0].strip() if lines else ""
    if len(token) < MIN_TOKEN_CHARS:
        raise BadInput(f"--token-file {path}: the token is {len(token)} characters; give at least {MIN_TOKEN_CHARS} "
                       "(e.g. python -c 'import secrets; print(secrets.token_urlsafe(32))' > FILE)")
    return token
