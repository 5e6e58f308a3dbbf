"""The planning service under load, on the loopback only: latency and throughput at 1, 2 and 8
concurrent clients, failed requests, and the server's resident memory as requests go by.

Starts `judgeopt serve --port 0` (its default workers: one per core), warms it up, then runs
bounded request loops: each client a thread with its own keep-alive judgeopt.Client, asking for
the direct planner's plan without simulation (the issue's figure; --method to change it) until
its level's count is reached. Memory is the server's and its workers' resident set (VmRSS in
/proc) when the running total of requests passes each --memory-at mark.

    python benchmarks/bench_serve.py [--levels 1 2 8] [--requests 300 300 400] [--soak 1000]
                                     [--memory-at 500 2000] [--simulate 20] [--receding 10]
                                     [--per-planner 100 --planners amortized direct cmaes] [--moving 100]

--per-planner N: each of --planners alone, N requests at 1 client and N at the last level, each
row's throughput against that planner's own one client.
--moving N: N requests, one client, each with the object somewhere new (as a robot re-planning after
it moved): a new environment value each time, so what a request pays for one shows.

Prints one row per level side by side (with the CPU time the server and its workers spent per
request: what bounds the throughput where the cores are shared), then the memory and the issue's
targets, met or missed.
"""

from __future__ import annotations

import argparse
import os
import select
import statistics
import subprocess
import sys
import threading
import time
from typing import Callable
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from judgeopt.planners.receding import PLAN_KEPT  # noqa: E402
from judgeopt.serve.client import Client, ServiceError  # noqa: E402


def cpu_s(pid: int) -> float:
    """The CPU time (user + system) a process has used so far."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def rss_mb(pid: int) -> float:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return float("nan")


class Run:
    """The server, the running total of requests, and the memory read at each mark."""

    def __init__(self, url: str, server: subprocess.Popen, marks: list[int]):
        self.url, self.server, self.marks = url, server, sorted(marks)
        self.total, self.lock, self.memory = 0, threading.Lock(), {}

    def workers(self) -> list[int]:
        return [w["pid"] for w in Client(self.url).health()["workers"]]

    def cpu_now(self) -> tuple[float, float]:
        """CPU seconds used so far by the server and by its workers."""
        return cpu_s(self.server.pid), sum(cpu_s(p) for p in self.workers())

    def memory_now(self) -> dict[str, float]:
        workers = self.workers()
        return {"server": rss_mb(self.server.pid), "workers": sum(rss_mb(p) for p in workers), "n_workers": len(workers)}

    def count(self) -> None:
        with self.lock:
            self.total += 1
            if self.total in self.marks:
                self.memory[self.total] = self.memory_now()

    def level(self, clients: int, requests: int, body: dict | Callable[[int], dict]) -> dict:
        """`requests` plans asked by `clients` threads at once (`body`, or body(i) for the i-th request):
        latencies (s), failures, wall time."""
        latencies, failures, planner, replans, left = [], [], [], [], [requests]
        lock = threading.Lock()

        def client() -> None:
            c = Client(self.url, timeout_s=120)
            while True:
                with lock:
                    if left[0] == 0:
                        break
                    left[0] -= 1
                    ask = body(requests - left[0] - 1) if callable(body) else body
                t0 = time.perf_counter()
                try:
                    answer = c.plan(**ask)
                    dt = time.perf_counter() - t0
                    with lock:
                        latencies.append(dt)
                        planner.extend(r["solve_time_s"] for r in answer["results"])
                        replans.extend((x["seconds"], x["status"] != PLAN_KEPT) for r in answer["results"]
                                       for x in r.get("replan_log", ()))  # each check, and whether it re-solved
                except ServiceError as exc:
                    with lock:
                        failures.append(str(exc))
                self.count()
            c.close()

        threads = [threading.Thread(target=client) for _ in range(clients)]
        cpu0 = self.cpu_now()
        t0 = time.perf_counter()
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        wall = time.perf_counter() - t0
        cpu = [b - a for a, b in zip(cpu0, self.cpu_now())]
        return {"clients": clients, "n": requests, "latencies": latencies, "failures": failures, "wall": wall,
                "planner": planner, "replans": replans, "cpu_ms": [1e3 * c / max(requests, 1) for c in cpu]}


def percentile(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(q / 100 * (len(xs) - 1))))] if xs else float("nan")


def start_server(workers: int | None, queue: int) -> tuple[subprocess.Popen, str]:
    args = [sys.executable, "-m", "judgeopt", "serve", "--port", "0", "--queue", str(queue)]
    if workers:
        args += ["--workers", str(workers)]
    server = subprocess.Popen(args, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    if not select.select([server.stdout], [], [], 60)[0]:
        raise SystemExit("the server did not start")
    url = server.stdout.readline().split("listening on ")[1].split()[0]
    client, t0 = Client(url), time.monotonic()
    while True:
        try:
            client.ready()
            return server, url
        except ServiceError:
            if time.monotonic() - t0 > 180 or server.poll() is not None:
                raise SystemExit("the server did not get ready")
            time.sleep(0.2)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[1, 2, 8], help="concurrent clients per level")
    ap.add_argument("--requests", type=int, nargs="+", default=[300, 300, 400], help="requests per level")
    ap.add_argument("--soak", type=int, default=1000, help="more requests at the last level, for the memory marks")
    ap.add_argument("--memory-at", type=int, nargs="+", default=[500, 2000])
    ap.add_argument("--warmup", type=int, default=20)
    ap.add_argument("--workers", type=int, help="default: the server's (one per core)")
    ap.add_argument("--method", default="direct")
    ap.add_argument("--simulate", type=int, default=0, metavar="N", help="also N requests with simulate, one client")
    ap.add_argument("--per-planner", type=int, default=0, metavar="N",
                    help="also N requests of each of --planners, at 1 client and at the last level, side by side")
    ap.add_argument("--planners", nargs="+", default=["amortized", "direct", "cmaes"])
    ap.add_argument("--receding", type=int, default=0, metavar="N",
                    help="also N requests of the receding planner (it re-plans while its plan runs in simulation), one "
                         "client: each re-plan's solve time inside the service against the re-planning period")
    ap.add_argument("--moving", type=int, default=0, metavar="N",
                    help="also N requests with the object somewhere new each time (y_obj and mu), one client")
    args = ap.parse_args()
    if len(args.requests) != len(args.levels):
        raise SystemExit("give one --requests count per level")
    body = {"limits": {"qdot_max": 0.4}, "methods": [args.method]}
    load = os.getloadavg()
    server, url = start_server(args.workers, queue=max(args.levels) * 2)
    try:
        run = Run(url, server, args.memory_at)
        warm = run.level(1, args.warmup, body)  # the first request for these limits loads their planners
        run.total = 0  # the marks count measured requests only
        rows = [run.level(c, n, body) for c, n in zip(args.levels, args.requests)]
        if args.soak:
            soak = run.level(args.levels[-1], args.soak, body)
        per = []
        for m in args.planners if args.per_planner else ():
            run.level(1, 3, {**body, "methods": [m]})  # its first request loads it
            per += [(m, run.level(c, args.per_planner, {**body, "methods": [m]})) for c in dict.fromkeys((1, args.levels[-1]))]
        moving = run.level(1, args.moving, lambda i: {**body, "environment": {"y_obj": 0.12 + 0.0011 * (i % 137),
                                                                          "mu": 1.2 + 0.013 * (i % 131)}}
                           ) if args.moving else None
        sim = run.level(1, args.simulate, {**body, "simulate": True}) if args.simulate else None
        receding = (run.level(1, args.receding, {**body, "methods": ["receding"], "simulate": True})
                    if args.receding else None)
        workers = run.memory_now()["n_workers"]
    finally:
        server.terminate()
        code = server.wait(60)
    print(f"judgeopt serve on {url}, {workers} workers, {os.cpu_count()} cores (load average at start "
          f"{load[0]:.2f}), method {args.method} without simulation; warm-up {len(warm['latencies'])} requests; "
          f"server exit code on SIGTERM {code}")
    print(f"{'clients':>7} {'requests':>8} {'failed':>6} {'p50 ms':>8} {'p95 ms':>8} {'p99 ms':>8} {'req/s':>7} "
          f"{'x 1 client':>10} {'planner p50 ms':>14} {'CPU ms/req: server':>18} {'workers':>7}")
    # (group, label, level): "x 1 client" is against the group's first row (the method's own, per planner)
    labelled = ([("levels", "", r) for r in rows] + ([("levels", "soak", soak)] if args.soak else [])
                + ([("levels", "sim", sim)] if sim else []) + ([("levels", "moving", moving)] if moving else [])
                + [(f"alone {m}", m, r) for m, r in per])
    bases: dict[str, float] = {}
    for group, label, r in labelled:
        lat, rate = r["latencies"], len(r["latencies"]) / r["wall"]
        base = bases.setdefault(group, rate)
        print(f"{r['clients']:>7} {r['n']:>8} {len(r['failures']):>6} {1e3 * percentile(lat, 50):>8.1f} "
              f"{1e3 * percentile(lat, 95):>8.1f} {1e3 * percentile(lat, 99):>8.1f} {rate:>7.1f} {rate / base:>10.2f} "
              f"{1e3 * statistics.median(r['planner']) if r['planner'] else float('nan'):>14.1f} "
              f"{r['cpu_ms'][0]:>18.1f} {r['cpu_ms'][1]:>7.1f} {label}")
    if receding:
        from judgeopt.files import resolve
        from judgeopt.planners.problem import load_problem

        period = load_problem(resolve("problems/paper_sim.toml")).replan_period
        s = [t for t, _ in receding["replans"]]
        print(f"receding planner through the service ({len(receding['latencies'])} requests, "
              f"{len(receding['failures'])} failed, each a whole scoop simulated: p50 "
              f"{1e3 * percentile(receding['latencies'], 50):.0f} ms): {len(s)} checks "
              f"({sum(solved for _, solved in receding['replans'])} re-solved), each p50 {1e3 * percentile(s, 50):.1f} ms, "
              f"p95 {1e3 * percentile(s, 95):.1f} ms, max {1e3 * max(s, default=float('nan')):.1f} ms against its period "
              f"of {1e3 * period:.0f} ms (p95 / period {percentile(s, 95) / period:.2f})")
    for mark, m in sorted(run.memory.items()):
        print(f"after {mark} requests: server {m['server']:.0f} MB + workers {m['workers']:.0f} MB = "
              f"{m['server'] + m['workers']:.0f} MB resident")
    one = rows[0]
    many = next((r for r in rows if r["clients"] == 8), None)
    failed = sum(len(r["failures"]) for r in rows + ([soak] if args.soak else []))
    measured = sum(len(r["latencies"]) + len(r["failures"]) for r in rows + ([soak] if args.soak else []))
    checks = [("1 client p50 <= 40 ms", 1e3 * percentile(one["latencies"], 50), 40),
              ("1 client p95 <= 100 ms", 1e3 * percentile(one["latencies"], 95), 100)]
    if many is not None:
        checks += [("8 clients throughput >= 1.6 x 1 client's", (len(many["latencies"]) / many["wall"]) /
                    (len(one["latencies"]) / one["wall"]), -1.6),
                   ("8 clients p95 <= 5 x 1 client's", percentile(many["latencies"], 95) / percentile(one["latencies"], 95),
                    5)]
    checks.append((f"0 failed of {measured}", failed, 0))
    if len(run.memory) >= 2:
        (a, ma), (b, mb) = sorted(run.memory.items())[:2]
        growth = 100 * ((mb["server"] + mb["workers"]) / (ma["server"] + ma["workers"]) - 1)
        checks.append((f"resident memory grows <= 5 % from request {a} to {b}", growth, 5))
    for what, value, limit in checks:
        met = value >= -limit if limit < 0 else value <= limit
        print(f"  {'met   ' if met else 'MISSED'} {what}: {value:.2f}")
    for r in rows:
        for f in r["failures"][:3]:
            print(f"  failure ({r['clients']} clients): {f}")


if __name__ == "__main__":
    main()
