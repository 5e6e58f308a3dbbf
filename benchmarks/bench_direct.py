"""The direct solve, per plan: Ipopt iterations, judge calls and time, warm-started from the
generator and cold (the min-jerk guess), with the generator's own time beside it, in one run.

Each variant is one way of posing and running the solve (the levers of issue 20); the first
is the shipped default. A variant is `key=value,...` over:
  objective   target (least effort and change to the warm start, p >= p_target) | log_p (eq. 3)
  hessian     exact (every term but the judge's) | limited-memory
  backend     the judge's CasADi function (judgeopt.judge.casadi_fn.BACKENDS)
  last_call   on (default) | off: an l4casadi library's calls all evaluated (judge.compiled.LastCall)
  a_max, jerk_max, fdot_max, joint_limit_scale, bound=NAME:LO:HI@T0:T1 (repeatable): [constraints]
  any Ipopt option by name (mu_init=1e-3, ...)

    .venv/bin/python benchmarks/bench_direct.py --n 100                  # the targets (both tasks)
    .venv/bin/python benchmarks/bench_direct.py --n 10 --levers          # every lever, side by side
    .venv/bin/python benchmarks/bench_direct.py --n 20 --simulate        # and replay each plan
    .venv/bin/python benchmarks/bench_direct.py --n 20 --busy --threads 1 2 --fresh 6

--busy: every solve is timed twice in turn, idle and with every core spun by another process
(a robot computer's load), and the two are printed side by side with their ratio.
--threads N ...: torch threads, each count a run of its own in this process.
--fresh K: also K `judgeopt solve --json --method direct --no-simulate` runs, each a fresh
process (idle and, with --busy, busy), warm-started and cold: the first solve in a process
against the warm loop's median above; --before DIR: the same on an earlier commit's worktree.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import torch

from busy import Load

from judgeopt.files import resolve
from judgeopt.judge.casadi_fn import build_casadi_judge
from judgeopt.planners.direct import DirectOptions, DirectPlanner
from judgeopt.planners.problem import load_problem
from judgeopt.planners.loaded import Planners

PROBLEMS = ["problems/paper_sim.toml", "problems/paper_sim_slow.toml", "problems/scrape.toml"]
#: the earlier solve (eq. 3 with L-BFGS, l4casadi) and each lever moved from it, one at a time
LEVERS = ["", "objective=log_p,hessian=limited-memory,backend=l4casadi",
          "objective=log_p,hessian=exact,backend=l4casadi", "objective=target,hessian=limited-memory,backend=l4casadi",
          "last_call=off", "backend=l4casadi", "backend=torch", "backend=torch32", "backend=native", "mu_init=1e-3",
          "mu_strategy=adaptive"]


def number(text: str) -> float | int | str:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def parse_variant(text: str) -> tuple[dict, str, dict, bool]:
    """(problem overrides, backend, DirectOptions fields, last_call) from `key=value,...`."""
    over, backend, ipopt = {}, "", {}
    opts: dict = {}
    last_call = True
    for item in filter(None, text.split(",")):
        k, _, v = item.partition("=")
        if k == "objective":
            over[k] = v
        elif k in ("a_max", "jerk_max", "fdot_max", "joint_limit_scale"):
            over[k] = float(v)
        elif k == "bound":
            over.setdefault("bounds", []).append(v)
        elif k == "backend":
            backend = v
        elif k == "last_call":
            if v not in ("on", "off"):
                raise SystemExit(f"last_call={v}: give on or off")
            last_call = v == "on"
        elif k == "hessian":
            opts[k] = v
        else:
            ipopt[k] = number(v)
    if ipopt:
        opts["ipopt"] = ipopt
    return over, backend, opts, last_call


def timed(load: Load, fn):
    """fn() idle and, with a load, busy: (idle result, busy result or None)."""
    idle = fn()
    if not load.procs:
        return idle, None
    with load.busy():
        return idle, fn()


def run(problem_path: str, variants: list[str], n: int, seed: int, simulate: bool, load: Load) -> list[dict]:
    problem = load_problem(resolve(problem_path))
    planners = Planners.load(problem, methods=("amortized", "direct"))
    envs = [problem.env_dict(e) for e in problem.sample_env(np.random.default_rng(seed), n)]
    sim = None
    if simulate:
        from judgeopt.tasks import get_task

        sim = get_task(problem.task).simulator()
    guesses, gen_times, gen_ok = [], [], []
    for env in envs:
        r = planners["amortized"].solve(env)
        guesses.append(r.plan)
        gen_times.append(r.solve_time_s)
        gen_ok.append(bool(sim.simulate(r.plan, env).success) if sim else None)
    rows = [{"problem": problem.name, "variant": "generator", "start": "-", "time": gen_times, "success": gen_ok}]
    shipped = planners["direct"].cjudge
    judges: dict[tuple[str, bool], object] = {(shipped.backend, True): shipped}
    for text in variants:
        over, backend, opts, last_call = parse_variant(text)
        key = (backend or shipped.backend, last_call)
        if key not in judges:
            judges[key] = build_casadi_judge(planners.judge, backend=key[0], last_call=last_call)
        direct = DirectPlanner(problem.with_overrides(**over), planners.judge, judges[key], DirectOptions(**opts))
        direct.warm_up(cold=True)  # what a first call pays (kernels, imports): the loop is the steady state
        for start in ("warm", "cold"):
            pairs = [timed(load, lambda: direct.solve(env, guess=g if start == "warm" else None))
                     for env, g in zip(envs, guesses)]
            out = [a for a, _ in pairs]
            row = {"problem": problem.name, "variant": text or "default", "backend": key[0], "start": start,
                   "time": [r.solve_time_s for r in out], "iterations": [r.iterations for r in out],
                   "judge_calls": [r.info["judge_calls"] for r in out],
                   "violation": [max(r.residuals.values()) for r in out],
                   "p": [r.predicted_success for r in out], "status": [r.status for r in out],
                   "success": [bool(sim.simulate(r.plan, env).success) if sim else None
                               for r, env in zip(out, envs)]}
            if load.procs:
                row["busy_time"] = [b.solve_time_s for _, b in pairs]
            rows.append(row)
    return rows


def fresh_runs(problem_path: str, k: int, seed: int, load: Load, code: str | None = None) -> list[dict]:
    """The first direct solve of K fresh `judgeopt solve` processes, warm-started and cold,
    idle and busy: solve_time_s from --json, and the process's wall time. `code`: run the
    judgeopt in that folder instead (a worktree of an earlier commit: before and after in one run)."""
    problem = load_problem(resolve(problem_path))
    envs = [problem.env_dict(e) for e in problem.sample_env(np.random.default_rng(seed), k)]
    exe = [sys.executable, "-m", "judgeopt.cli", "solve", "--json", "--method", "direct", "--no-simulate",
           "--problem", problem_path]
    rows = []
    for start in ("warm", "cold"):
        pairs = []
        for env in envs:
            cmd = exe + [f"--{name.replace('_', '-')}={value!r}" for name, value in env.items()]
            cmd += ["--warm-start", "none"] if start == "cold" else []
            pairs.append(timed(load, lambda: _cli_time(cmd, code)))
        row = {"problem": problem.name, "variant": "fresh process" + (f" ({code})" if code else ""), "start": start,
               "time": [a[0] for a, _ in pairs], "wall": [a[1] for a, _ in pairs], "success": [None]}
        if load.procs:
            row["busy_time"] = [b[0] for _, b in pairs]
            row["busy_wall"] = [b[1] for _, b in pairs]
        rows.append(row)
    return rows


def _cli_time(cmd: list[str], code: str | None = None) -> tuple[float, float]:
    env = {**os.environ, "PYTHONPATH": code} if code else None
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=code)
    wall = time.perf_counter() - t0
    try:
        out = json.loads(res.stdout)
        return next(r["solve_time_s"] for r in out["results"] if r["method"] == "direct"), wall
    except (ValueError, KeyError, StopIteration):
        raise SystemExit(f"{' '.join(cmd)} failed: {res.stderr.strip()[-500:] or res.stdout[-500:]}") from None


def report(rows: list[dict]) -> None:
    busy = any("busy_time" in r for r in rows)
    print(f"{'problem':<14} {'variant':<44} {'start':<5} {'median':>8} {'p95':>8} "
          + (f"{'busy med.':>9} {'busy/idle':>9} " if busy else "")
          + f"{'iter':>5} {'calls':>5} {'worst viol.':>11} {'mean p':>6} {'solved':>7} {'sim':>7}")
    for r in rows:
        t = np.array(r["time"]) * 1e3
        it = f"{np.median(r['iterations']):5.0f}" if "iterations" in r else f"{'':5}"
        calls = f"{np.median(r['judge_calls']):5.0f}" if "judge_calls" in r else f"{'':5}"
        viol = f"{max(r['violation']):11.1e}" if "violation" in r else f"{'':11}"
        p = f"{np.mean(r['p']):6.3f}" if "p" in r else f"{'':6}"
        solved = f"{sum(s == 'solved' for s in r['status'])}/{len(r['status'])}" if "status" in r else ""
        sim = f"{sum(r['success'])}/{len(r['success'])}" if r["success"][0] is not None else ""
        name = r["variant"] + (f" ({r['backend']})" if "backend" in r else "") + (f" [{r['threads']}t]" if "threads" in r else "")
        extra = ""
        if busy:
            b = np.array(r.get("busy_time", [np.nan])) * 1e3
            extra = f"{np.median(b):7.1f}ms {np.median(b) / np.median(t):9.2f} " if "busy_time" in r else " " * 20
        print(f"{r['problem']:<14} {name:<44} {r['start']:<5} {np.median(t):6.1f}ms {np.percentile(t, 95):6.1f}ms "
              f"{extra}{it} {calls} {viol} {p} {solved:>7} {sim:>7}")
        if "wall" in r:
            w = np.array(r["wall"])
            bw = f", busy {np.median(r['busy_wall']):.2f} s" if "busy_wall" in r else ""
            print(f"{'':14} {'  (process wall time, median)':<44} {'':<5} {np.median(w):6.2f} s{bw}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100, help="environments per problem")
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--problems", nargs="+", default=PROBLEMS)
    ap.add_argument("--variants", nargs="+", default=[""], help="key=value,... per variant ('' = the default)")
    ap.add_argument("--levers", action="store_true", help="every lever of LEVERS, side by side")
    ap.add_argument("--simulate", action="store_true", help="replay every plan (success k/n)")
    ap.add_argument("--threads", type=int, nargs="+", default=[1], help="torch threads, one run per count")
    ap.add_argument("--busy", action="store_true", help="time every solve idle and with every core busy, in turn")
    ap.add_argument("--fresh", type=int, default=0, metavar="K", help="also K fresh `judgeopt solve` processes")
    ap.add_argument("--before", metavar="DIR", help="with --fresh: the same fresh runs on the judgeopt in DIR too "
                    "(e.g. `git worktree add /tmp/before REV`)")
    ap.add_argument("--json", help="also write every row here")
    args = ap.parse_args()
    load = Load(args.busy)
    t0 = time.perf_counter()
    rows = []
    try:
        for threads in args.threads:
            torch.set_num_threads(threads)
            for path in args.problems:
                for r in run(path, LEVERS if args.levers else args.variants, args.n, args.seed, args.simulate, load):
                    rows.append({**r, "threads": threads})
        for path in args.problems if args.fresh else ():
            rows += fresh_runs(path, args.fresh, args.seed, load)
            if args.before:
                rows += fresh_runs(path, args.fresh, args.seed, load, str(Path(args.before).resolve()))
    finally:
        load.close()
    print(f"\n{args.n} environments per problem (seed {args.seed}), one process, torch threads {args.threads}"
          f"{', each solve idle and with ' + str(os.cpu_count()) + ' cores spun' if args.busy else ''}; "
          f"{time.perf_counter() - t0:.0f} s in all")
    report(rows)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=str) + "\n")


if __name__ == "__main__":
    main()
