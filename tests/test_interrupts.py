"""Ctrl-C held while native code runs (judgeopt.interrupts): the command line's rule for imports
(`held`: Python's own handler only) and the direct planner's for Ipopt (`sigint_recorded`: any
handler set from Python, but never an ignored SIGINT, and only in the main thread)."""

from __future__ import annotations

import os
import signal
import threading
import time

import pytest

from judgeopt.interrupts import held, sigint_recorded


@pytest.fixture
def handler():
    """Install a SIGINT handler for the test (a shell starting the tests in the background ignores SIGINT)."""
    before = signal.getsignal(signal.SIGINT)
    yield lambda h: signal.signal(signal.SIGINT, h)
    signal.signal(signal.SIGINT, before)


def _ctrl_c() -> None:
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(0.05)  # the handler runs between bytecodes: here it only records the signal


def test_a_ctrl_c_while_held_is_raised_when_the_block_ends(handler):
    handler(signal.default_int_handler)  # Python's own, as in a terminal
    finished = []
    with pytest.raises(KeyboardInterrupt):
        with held():
            _ctrl_c()
            finished.append(True)
    assert finished == [True]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_held_leaves_another_handler_alone(handler):
    calls = []
    host = lambda signum, frame: calls.append(signum)  # noqa: E731
    handler(host)
    with held():
        _ctrl_c()
    assert calls == [signal.SIGINT] and signal.getsignal(signal.SIGINT) is host


def test_a_solve_records_a_ctrl_c_under_any_handler_and_restores_it(handler):
    calls = []
    host = lambda signum, frame: calls.append(signum)  # noqa: E731
    for before in (signal.default_int_handler, host):
        handler(before)
        with sigint_recorded() as seen:
            _ctrl_c()
        assert seen == [signal.SIGINT] and calls == []
        assert signal.getsignal(signal.SIGINT) is before


def test_nothing_is_recorded_where_sigint_is_ignored_or_off_the_main_thread(handler):
    handler(signal.SIG_IGN)
    with sigint_recorded() as seen:
        _ctrl_c()
    assert seen == [] and signal.getsignal(signal.SIGINT) == signal.SIG_IGN

    handler(signal.default_int_handler)
    found = []

    def solve() -> None:
        with sigint_recorded() as seen, held():
            found.append((seen, signal.getsignal(signal.SIGINT)))

    worker = threading.Thread(target=solve)
    worker.start(), worker.join()
    assert found == [([], signal.default_int_handler)]
