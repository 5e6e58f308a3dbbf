"""`judgeopt serve`: the planning service (judgeopt.serve), its options read from ServeConfig's
defaults (each defined there once)."""

from __future__ import annotations

import argparse
import dataclasses

from judgeopt.cli.commands import HELP
from judgeopt.cli.common import number, positive


def cmd_serve(args: argparse.Namespace) -> int:
    try:
        from judgeopt.serve.config import ServeConfig
        from judgeopt.serve.server import serve
    except ModuleNotFoundError as exc:  # the serve extra is not installed
        from judgeopt.cli.common import CLIError, ExitCode

        raise CLIError(f"judgeopt serve needs {exc.name}, which is not installed: pip install 'judgeopt[serve]'",
                       ExitCode.MISSING) from None
    given = {f.name: getattr(args, f.name) for f in dataclasses.fields(ServeConfig) if getattr(args, f.name, None) is not None}
    for name in ("problems", "preload"):
        if name in given:
            given[name] = tuple(given[name])
    return serve(ServeConfig(**given))


def add_serve_command(sub: argparse._SubParsersAction) -> None:
    from judgeopt.serve.config import ServeConfig

    d = ServeConfig()
    s = sub.add_parser("serve", help=HELP["serve"],
                       description="A planning service for a robot stack: POST /v1/plan answers with the object "
                       "`judgeopt solve --json` prints; worker processes each hold the models; a bounded queue (503 with "
                       "Retry-After when full), a deadline per request (504), a dead worker replaced; SIGTERM finishes "
                       "what is in flight and exits 0. Binds 127.0.0.1; any other address needs --token-file. "
                       "docs/guides/service.md. Needs pip install 'judgeopt[serve]'.")
    s.add_argument("--host", help=f"address to listen on (default {d.host}: this machine only)")
    s.add_argument("--port", type=int, help=f"port (default {d.port}; 0: a free one, printed at start)")
    s.add_argument("--workers", type=positive, metavar="N", help="planning processes, each with its own models "
                   "(default: the cores this process may use)")
    s.add_argument("--queue", type=int, metavar="N", help=f"requests that may wait for a worker; more get 503 with "
                   f"Retry-After (default {d.queue})")
    s.add_argument("--token-file", metavar="FILE", help="a bearer token (its first line) every request but /v1/health "
                   "must carry; needed to listen on any address but loopback")
    s.add_argument("--max-body", dest="max_body_bytes", type=positive, metavar="BYTES",
                   help=f"largest request body (default {d.max_body_bytes})")
    s.add_argument("--timeout", dest="timeout_s", type=number, metavar="S",
                   help=f"a request's deadline where it names none (default {d.timeout_s:g})")
    s.add_argument("--max-timeout", dest="max_timeout_s", type=number, metavar="S",
                   help=f"the longest deadline a request may ask for (default {d.max_timeout_s:g})")
    s.add_argument("--kill-after", dest="kill_after_s", type=number, metavar="S",
                   help=f"a worker still on a request this long past its deadline is replaced (default {d.kill_after_s:g})")
    s.add_argument("--shutdown-timeout", dest="shutdown_s", type=number, metavar="S",
                   help=f"on SIGTERM, how long requests in flight may take to finish (default {d.shutdown_s:g})")
    s.add_argument("--problem", dest="problems", action="append", metavar="FILE",
                   help="also plan this problem file, by its name (the file's stem); repeatable (default: the "
                   "shipped problems only)")
    s.add_argument("--models", dest="models_dir", metavar="DIR",
                   help=f"folder searched for generators, as solve --models (default {d.models_dir})")
    s.add_argument("--preload", action="append", metavar="NAME",
                   help=f"a problem each worker loads and plans once before it is ready; repeatable (default "
                   f"{', '.join(d.preload)})")
    s.add_argument("--cache", type=positive, metavar="N",
                   help=f"planners each worker keeps loaded, one per problem, limits and planners asked for (any "
                   f"environment), and requests the server and each worker keep checked (default {d.cache})")
    s.set_defaults(func=cmd_serve)
