"""What the service measures, in Prometheus' text format (GET /metrics): requests by route and
status, their latency by route, each planner's own solve time, the queue, the workers.

A registry of its own per app (not prometheus_client's global one), so that two apps in one process
(tests, an embedding program) count apart.
"""

from __future__ import annotations

from typing import Callable

from prometheus_client import CollectorRegistry, Counter, Gauge, Histogram, generate_latest

#: latency buckets in seconds: a direct solve is tens of milliseconds, a simulated one seconds
BUCKETS = (0.005, 0.01, 0.02, 0.04, 0.06, 0.08, 0.1, 0.15, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0, 60.0)


class Metrics:
    """The service's counters, histograms and gauges; the gauges read the pool when scraped."""

    def __init__(self, queued: Callable[[], float], busy: Callable[[], float], ready: Callable[[], float],
                 restarts: Callable[[], float]):
        self.registry = CollectorRegistry()
        r = self.registry
        self.requests = Counter("judgeopt_requests", "HTTP requests answered, by route and status", ["route", "status"],
                                registry=r)
        self.latency = Histogram("judgeopt_request_seconds", "time from a request's arrival to its answer, by route",
                                 ["route"], buckets=BUCKETS, registry=r)
        self.planner = Histogram("judgeopt_planner_seconds", "each planner's own solve time in answered plans",
                                 ["planner"], buckets=BUCKETS, registry=r)
        Gauge("judgeopt_queue_depth", "plan requests waiting for a worker", registry=r).set_function(queued)
        Gauge("judgeopt_workers_busy", "workers planning a request", registry=r).set_function(busy)
        Gauge("judgeopt_workers_ready", "workers with their models loaded", registry=r).set_function(ready)
        Gauge("judgeopt_worker_restarts", "workers replaced after they died", registry=r).set_function(restarts)

    def answered(self, route: str, status: int, seconds: float, timings: dict[str, float] | None = None) -> None:
        self.requests.labels(route, str(status)).inc()
        self.latency.labels(route).observe(seconds)
        for planner, t in (timings or {}).items():
            self.planner.labels(planner).observe(t)

    def text(self) -> bytes:
        return generate_latest(self.registry)
