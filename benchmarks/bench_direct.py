"""The direct solve, per plan: Ipopt iterations, judge calls and time, warm-started from the
generator and cold (the min-jerk guess), with the generator's own time beside it, in one run.

Each variant is one way of posing and running the solve (the levers of issue 20); the first
is the shipped default. A variant is `key=value,...` over:
  objective   target (least effort and change to the warm start, p >= p_target) | log_p (eq. 3)
  hessian     exact (every term but the judge's) | limited-memory
  backend     the judge's CasADi function (judgeopt.judge.casadi_fn.BACKENDS)
  any Ipopt option by name (mu_init=1e-3, ...)

    .venv/bin/python benchmarks/bench_direct.py --n 100                  # the targets (both tasks)
    .venv/bin/python benchmarks/bench_direct.py --n 10 --levers          # every lever, side by side
    .venv/bin/python benchmarks/bench_direct.py --n 20 --simulate        # and replay each plan
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch

from judgeopt.files import resolve
from judgeopt.judge.casadi_fn import build_casadi_judge
from judgeopt.planners.direct import DirectOptions, DirectPlanner
from judgeopt.planners.problem import load_problem
from judgeopt.planners.solve import Planners

PROBLEMS = ["problems/paper_sim.toml", "problems/paper_sim_slow.toml", "problems/scrape.toml"]
#: the earlier solve (eq. 3 with L-BFGS, l4casadi) and each lever moved from it, one at a time
LEVERS = ["", "objective=log_p,hessian=limited-memory,backend=l4casadi",
          "objective=log_p,hessian=exact,backend=l4casadi", "objective=target,hessian=limited-memory,backend=l4casadi",
          "backend=l4casadi", "backend=torch", "backend=torch32", "backend=native", "mu_init=1e-3",
          "mu_strategy=adaptive"]


def number(text: str) -> float | int | str:
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def parse_variant(text: str) -> tuple[dict, str, dict]:
    """(problem overrides, backend, DirectOptions fields) from `key=value,...`."""
    over, backend, ipopt = {}, "", {}
    opts: dict = {}
    for item in filter(None, text.split(",")):
        k, _, v = item.partition("=")
        if k == "objective":
            over[k] = v
        elif k == "backend":
            backend = v
        elif k == "hessian":
            opts[k] = v
        else:
            ipopt[k] = number(v)
    if ipopt:
        opts["ipopt"] = ipopt
    return over, backend, opts


def run(problem_path: str, variants: list[str], n: int, seed: int, simulate: bool) -> list[dict]:
    problem = load_problem(resolve(problem_path))
    planners = Planners.load(problem, methods=("amortized", "direct"))
    envs = [problem.env_dict(e) for e in problem.sample_env(np.random.default_rng(seed), n)]
    sim = None
    if simulate:
        from judgeopt.tasks import get_task

        sim = get_task(problem.task).simulator()
    guesses, gen_times, gen_ok = [], [], []
    for env in envs:
        r = planners.amortized.solve(env)
        guesses.append(r.plan)
        gen_times.append(r.solve_time_s)
        gen_ok.append(bool(sim.simulate(r.plan, env).success) if sim else None)
    rows = [{"problem": problem.name, "variant": "generator", "start": "-", "time": gen_times, "success": gen_ok}]
    judges: dict[str, object] = {}
    for text in variants:
        over, backend, opts = parse_variant(text)
        backend = backend or planners.direct.cjudge.backend
        if backend not in judges:
            judges[backend] = (planners.direct.cjudge if backend == planners.direct.cjudge.backend
                               else build_casadi_judge(planners.judge, backend=backend))
        direct = DirectPlanner(problem.with_overrides(**over), planners.judge, judges[backend], DirectOptions(**opts))
        direct.solve(envs[0], guess=guesses[0])  # first call: libraries load
        for start in ("warm", "cold"):
            out = [direct.solve(env, guess=g if start == "warm" else None) for env, g in zip(envs, guesses)]
            rows.append({"problem": problem.name, "variant": text or "default", "backend": backend, "start": start,
                         "time": [r.solve_time_s for r in out], "iterations": [r.iterations for r in out],
                         "judge_calls": [r.info["judge_calls"] for r in out],
                         "violation": [max(r.residuals.values()) for r in out],
                         "p": [r.predicted_success for r in out], "status": [r.status for r in out],
                         "success": [bool(sim.simulate(r.plan, env).success) if sim else None
                                     for r, env in zip(out, envs)]})
    return rows


def report(rows: list[dict]) -> None:
    print(f"{'problem':<14} {'variant':<62} {'start':<5} {'median':>8} {'p95':>8} {'iter':>5} {'calls':>5} "
          f"{'worst viol.':>11} {'mean p':>6} {'solved':>7} {'sim':>7}")
    for r in rows:
        t = np.array(r["time"]) * 1e3
        it = f"{np.median(r['iterations']):5.0f}" if "iterations" in r else f"{'':5}"
        calls = f"{np.median(r['judge_calls']):5.0f}" if "judge_calls" in r else f"{'':5}"
        viol = f"{max(r['violation']):11.1e}" if "violation" in r else f"{'':11}"
        p = f"{np.mean(r['p']):6.3f}" if "p" in r else f"{'':6}"
        solved = f"{sum(s == 'solved' for s in r['status'])}/{len(r['status'])}" if "status" in r else ""
        sim = f"{sum(r['success'])}/{len(r['success'])}" if r["success"][0] is not None else ""
        name = r["variant"] + (f" ({r['backend']})" if "backend" in r else "")
        print(f"{r['problem']:<14} {name:<62} {r['start']:<5} {np.median(t):6.1f}ms {np.percentile(t, 95):6.1f}ms "
              f"{it} {calls} {viol} {p} {solved:>7} {sim:>7}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100, help="environments per problem")
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--problems", nargs="+", default=PROBLEMS)
    ap.add_argument("--variants", nargs="+", default=[""], help="key=value,... per variant ('' = the default)")
    ap.add_argument("--levers", action="store_true", help="every lever of LEVERS, side by side")
    ap.add_argument("--simulate", action="store_true", help="replay every plan (success k/n)")
    ap.add_argument("--threads", type=int, default=1, help="torch threads (one process, like a plan call)")
    ap.add_argument("--json", help="also write every row here")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    t0 = time.perf_counter()
    rows = [r for path in args.problems
            for r in run(path, LEVERS if args.levers else args.variants, args.n, args.seed, args.simulate)]
    print(f"\n{args.n} environments per problem (seed {args.seed}), one process, {args.threads} torch thread(s); "
          f"{time.perf_counter() - t0:.0f} s in all")
    report(rows)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=str) + "\n")


if __name__ == "__main__":
    main()
