"""Overload, deadlines and a killed worker, each made to happen on the session's service (one
worker, a queue of one): the request it concerns gets its 503 or 504 with a message, the others
are answered, and the service goes on."""

from __future__ import annotations

import os
import signal
import time

from serving import QUICK, SLOW, busy, pids


def test_a_full_queue_is_503_with_retry_after(service):
    held = service.in_background(SLOW)
    service.wait("the worker holds the slow request", busy, 30)
    waiting = service.in_background(QUICK)
    service.wait("the quick request waits in the queue", lambda h: h["queued"] == 1, 30)
    refused = service.plan(QUICK)
    assert refused.status == 503 and refused.headers["retry-after"] == "1"
    assert "every worker is busy" in refused.body["error"]
    for request in (held, waiting):  # those accepted are answered
        request["thread"].join(60)
        assert request["answer"].status == 200, request["answer"].text
    metrics = service.call("GET", "/metrics").text
    assert 'judgeopt_requests_total{route="/v1/plan",status="503"}' in metrics


def test_a_deadline_in_the_queue_is_504_saying_so(service):
    held = service.in_background(SLOW)
    service.wait("the worker holds the slow request", busy, 30)
    t0 = time.monotonic()
    late = service.plan({**QUICK, "timeout_s": 0.5})
    assert late.status == 504 and 0.5 <= time.monotonic() - t0 < 3
    assert "waited in the queue" in late.body["error"] and "nothing was planned" in late.body["error"]
    held["thread"].join(60)
    assert held["answer"].status == 200


def test_a_deadline_while_planning_is_504_saying_what_was_cut_short(service):
    t0 = time.monotonic()
    late = service.plan({**SLOW, "timeout_s": 1.0})
    assert late.status == 504 and 1.0 <= time.monotonic() - t0 < 3
    assert "while planning with amortized, direct" in late.body["error"], late.body
    service.wait("the worker finishes the request cut short", lambda h: not busy(h), 60)
    assert service.plan(QUICK).status == 200


def _restarts(service) -> float:
    """The workers replaced so far, as /metrics counts them (the session's service: other tests' too)."""
    line = next(x for x in service.call("GET", "/metrics").text.splitlines() if x.startswith("judgeopt_worker_restarts "))
    return float(line.split()[1])


def test_a_killed_worker_costs_only_its_request_and_is_replaced(service):
    before = _restarts(service)
    held = service.in_background(SLOW)
    service.wait("the worker holds the slow request", busy, 30)
    (victim,) = pids(service.health())
    os.kill(victim, signal.SIGKILL)
    held["thread"].join(30)
    answer = held["answer"]
    assert answer.status == 503 and "killed by SIGKILL" in answer.body["error"], answer.text
    replaced = service.wait("a new worker", lambda h: pids(h) and victim not in pids(h), 5)
    assert replaced < 5
    service.wait_ready()
    assert service.plan(QUICK).status == 200
    assert _restarts(service) == before + 1
