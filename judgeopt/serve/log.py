"""The service's log: one line per event on stderr, "judgeopt serve: ...", in the server and in
each worker process alike. Its lines hold what the service decided (a route's template, a status,
a worker's pid), never what a request sent, so a request cannot forge or flood a log line.
"""

from __future__ import annotations

import logging
import sys

NAME = "judgeopt.serve"
#: what a client is told of a bug (its traceback goes to the log only)
INTERNAL_ERROR = "internal error; the server's log has the traceback: please report it"


def service_log() -> logging.Logger:
    """The service's logger, writing to stderr (set up once per process; not passed to the command
    line's "judgeopt" handler, which would print each line twice)."""
    log = logging.getLogger(NAME)
    if not log.handlers:
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter("judgeopt serve: %(message)s"))
        log.addHandler(handler)
        log.setLevel(logging.INFO)
        log.propagate = False
    return log


def one_line(text: str) -> str:
    """`text` (a traceback) as one log line: line breaks and other control characters escaped."""
    return text.encode("unicode_escape").decode("ascii")
