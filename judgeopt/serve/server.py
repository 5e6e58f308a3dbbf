"""`judgeopt serve`: the app under uvicorn, on a socket bound first (a port in use is one line,
and port 0 a free port, printed), stopped by SIGTERM or Ctrl-C the graceful way.

On SIGTERM uvicorn stops accepting, lets the requests in flight finish (up to --shutdown-timeout),
then the workers stop, and the process exits 0. uvicorn re-raises the signal it stopped on once it
is done (so that a process run with its defaults dies by it); it re-raises it to the handler that
was installed before it ran: this module's, which only notes it, so the exit is 0 as documented.
"""

from __future__ import annotations

import signal
import socket
import sys
from typing import TextIO

from judgeopt.errors import UsageError
from judgeopt.serve.config import ServeConfig, read_token


def bind(host: str, port: int) -> socket.socket:
    """A socket listening on host:port (port 0: a free one), or one line saying why not."""
    try:
        family, kind, proto, _, address = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0]
        sock = socket.socket(family, kind, proto)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind(address)
        sock.listen(2048)  # connections wait in the backlog from now on, not refused until uvicorn starts
    except OSError as exc:
        raise UsageError(f"--host {host} --port {port}: cannot listen there ({exc.strerror or exc}); give another "
                         "--port (0: a free one) or --host") from None
    return sock


def serve(config: ServeConfig, out: TextIO = sys.stdout) -> int:
    """Run the service until SIGTERM or Ctrl-C; 0 once it has stopped cleanly."""
    config.check()
    token = read_token(config.token_file) if config.token_file else None
    from judgeopt.serve.request import problem_files

    problems = problem_files(config.problems)
    unknown = [p for p in config.preload if p not in problems]
    if unknown:
        raise UsageError(f"--preload {', '.join(unknown)}: no such problem; choose from {', '.join(problems)}")
    sock = bind(config.host, config.port)
    import uvicorn

    from judgeopt.serve.app import create_app

    app = create_app(config, problems, token)
    server = uvicorn.Server(uvicorn.Config(app, access_log=False, log_level="warning", server_header=False,
                                           timeout_graceful_shutdown=int(config.shutdown_s), lifespan="on"))
    host, port = sock.getsockname()[:2]
    shown = f"[{host}]" if ":" in host else host
    print(f"judgeopt serve: listening on http://{shown}:{port} ({config.workers} workers loading their models; "
          "GET /v1/ready answers 200 once one has)", file=out, flush=True)
    stopped_by: list[int] = []
    before = {s: signal.signal(s, lambda sig, frame: stopped_by.append(sig)) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        server.run(sockets=[sock])
    finally:
        for s, handler in before.items():
            signal.signal(s, handler)
        sock.close()
    how = f" on {signal.Signals(stopped_by[0]).name}" if stopped_by else ""
    print(f"judgeopt serve: stopped{how}", file=out, flush=True)
    return 0 if server.started else 1
