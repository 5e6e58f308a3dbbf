"""Helpers of the service tests: the planning service started for real (`python -m judgeopt serve --port 0`, a free loopback
port) and called as a client would: raw HTTP, so a test can send what no well-behaved client sends."""

from __future__ import annotations

import http.client
import json
import os
import select
import signal
import subprocess
import sys
import threading
import time
import urllib.parse
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("fastapi")  # the serve extra

from judgeopt.files import REPO  # noqa: E402

TOKEN = "test-token-0123456789abcdef"
#: a request whose plan takes seconds on any machine: no plan is likely, so the suggestion search
#: re-plans under relaxed limits (about 3 s here); what the fault tests hold a worker with
SLOW = {"limits": {"f_max": 11}, "environment": {"mu": 3}}  # unlikely: the suggestion search re-plans
QUICK = {"limits": {"qdot_max": 0.4}}


@dataclass
class Answer:
    status: int
    headers: dict[str, str]
    body: Any
    text: str


@dataclass
class Service:
    url: str
    process: subprocess.Popen
    log: Path
    token: str | None = None
    threads: list = field(default_factory=list)

    @property
    def address(self) -> tuple[str, int]:
        parts = urllib.parse.urlsplit(self.url)
        return parts.hostname, parts.port

    def call(self, method: str, path: str, body: Any = None, *, raw: bytes | None = None,
             headers: dict[str, str] | None = None, token: str | None = "default", timeout: float = 60) -> Answer:
        """One request on a fresh connection: `body` as JSON, or `raw` bytes as they are."""
        token = self.token if token == "default" else token
        data = raw if raw is not None else None if body is None else json.dumps(body).encode()
        sent = {**({"Content-Type": "application/json"} if data is not None else {}),
                **({"Authorization": f"Bearer {token}"} if token else {}), **(headers or {})}
        conn = http.client.HTTPConnection(*self.address, timeout=timeout)
        try:
            conn.request(method, path, body=data, headers=sent)
            r = conn.getresponse()
            text = r.read().decode()
        finally:
            conn.close()
        try:
            parsed = json.loads(text)
        except ValueError:
            parsed = None
        return Answer(r.status, {k.lower(): v for k, v in r.getheaders()}, parsed, text)

    def plan(self, body: dict, **kw) -> Answer:
        return self.call("POST", "/v1/plan", body, **kw)

    def in_background(self, body: dict, **kw) -> dict:
        """Send a plan request from a thread; the dict gets its "answer" when it comes."""
        out: dict = {}
        t = threading.Thread(target=lambda: out.update(answer=self.plan(body, **kw)), daemon=True)
        t.start()
        out["thread"] = t
        return out

    def health(self) -> dict:
        return self.call("GET", "/v1/health").body

    def wait(self, what: str, condition, timeout: float = 120) -> float:
        """Seconds until `condition(health)` holds (a test failure naming `what` after `timeout`)."""
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout:
            if condition(self.health()):
                return time.monotonic() - t0
            time.sleep(0.05)
        raise AssertionError(f"{what}: not within {timeout} s; health: {self.health()}")

    def wait_ready(self, timeout: float = 180) -> None:
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout:
            if self.process.poll() is not None:
                raise AssertionError(f"the server exited ({self.process.returncode}): {self.log.read_text()[-2000:]}")
            try:
                if self.call("GET", "/v1/ready").status == 200:
                    return
            except OSError:
                pass
            time.sleep(0.2)
        raise AssertionError(f"not ready in {timeout} s: {self.log.read_text()[-2000:]}")

    def stop(self) -> int:
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
        try:
            return self.process.wait(30)
        except subprocess.TimeoutExpired:
            self.process.kill()
            return self.process.wait(10)


def start(tmp: Path, *options: str, token: str | None = None, env: dict[str, str] | None = None) -> Service:
    """A server on a free loopback port, its models loaded (stderr: `tmp`/server.log; `env`: more
    environment variables)."""
    args = [sys.executable, "-m", "judgeopt", "serve", "--port", "0", *options]
    if token is not None:
        (tmp / "token").write_text(token + "\n")
        args += ["--token-file", str(tmp / "token")]
    log = tmp / "server.log"
    process = subprocess.Popen(args, cwd=REPO, stdout=subprocess.PIPE, stderr=log.open("w"), text=True,
                               env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})})
    ready, _, _ = select.select([process.stdout], [], [], 60)
    line = process.stdout.readline() if ready else ""
    if "listening on" not in line:
        process.kill()
        raise AssertionError(f"the server did not start: {line!r} {log.read_text()[-2000:]}")
    service = Service(line.split("listening on ")[1].split()[0], process, log, token)
    try:
        service.wait_ready()
    except AssertionError:  # a server that never got ready is stopped, not left running after the test
        service.stop()
        raise
    return service


def pids(health: dict) -> set[int]:
    return {w["pid"] for w in health["workers"]}


def busy(health: dict) -> bool:
    return any(w["busy"] for w in health["workers"])
