"""The two planners side by side on the same random in-range environments, replayed in simulation.

For each velocity limit (the paper's 1.0 and 0.4 m/s) and each method: simulated success
(k / n), mean predicted success, worst constraint violation, median and 95th-percentile
plan time, mean force. The direct solve is warm-started from the generator, as
`judgeopt solve` does; `--cold` adds the direct solve from the min-jerk guess.

    python benchmarks/bench_planners.py --n 100          # the issue's targets
    python benchmarks/bench_planners.py --n 10 --jobs 2  # quick look
    python benchmarks/bench_planners.py --n 20 --robot kinova  # on another arm, its joint limits held
    python benchmarks/bench_planners.py --n 20 --methods amortized direct held  # another planner beside them
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from judgeopt.evaluate.batch import plan_many
from judgeopt.planners.problem import load_problem
from judgeopt.files import resolve


def summarise(rows: list[dict], method: str) -> dict:
    rs = [r for r in rows if r["method"] == method and "t" in r]
    times = np.array([r["solve_time_s"] for r in rs])
    sim = [r["simulated_success"] for r in rs if r["simulated_success"] is not None]
    return {"method": method, "n": len(rs), "sim_success": int(sum(sim)), "sim_n": len(sim),
            "predicted_mean": float(np.mean([r["predicted_success"] for r in rs])),
            "violation_max": float(max(r["max_constraint_violation"] for r in rs)),
            "violation_median": float(np.median([r["max_constraint_violation"] for r in rs])),
            "time_median_s": float(np.median(times)), "time_p95_s": float(np.percentile(times, 95)),
            "force_mean": float(np.mean([np.mean(r["f"]) for r in rs])),
            "status": {s: sum(r["status"] == s for r in rs) for s in sorted({r["status"] for r in rs})}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100, help="environments per velocity limit")
    ap.add_argument("--seed", type=int, default=2024)
    ap.add_argument("--jobs", type=int, default=-1)
    ap.add_argument("--problems", nargs="+", default=["problems/paper_sim.toml", "problems/paper_sim_slow.toml"])
    ap.add_argument("--judge", dest="judge_model", help="the judge to plan against (default: each problem's)")
    ap.add_argument("--robot", help="the arm the plans are made for (its joint limits held) and replayed on "
                    "(default: each problem's, the UR5)")
    ap.add_argument("--methods", nargs="+", default=["amortized", "direct"], help="the planners side by side")
    ap.add_argument("--json", help="also write the summary as JSON here")
    args = ap.parse_args()

    summary = []
    t0 = time.perf_counter()
    for path in args.problems:
        problem = load_problem(resolve(path)).with_overrides(judge=args.judge_model, robot=args.robot)
        envs = problem.sample_env(np.random.default_rng(args.seed), args.n)
        rows = plan_many(problem, envs, methods=args.methods, n_jobs=args.jobs)
        for method in args.methods:
            s = summarise(rows, method)
            s["problem"], s["qdot_max"] = problem.name, problem.qdot_max
            summary.append(s)
    print(f"\n{args.n} environments per limit (seed {args.seed}), y_obj and mu uniform in the problems' ranges; "
          f"{time.perf_counter() - t0:.0f} s in all")
    head = f"{'q̇_max':>6} {'method':<10} {'simulated':>10} {'predicted':>9} {'worst viol.':>11} " \
           f"{'median t':>9} {'p95 t':>9} {'mean f [N]':>10}  solver status"
    print(head)
    for s in summary:
        t = lambda v: f"{v * 1e3:.2f} ms" if v < 1 else f"{v:.2f} s"
        print(f"{s['qdot_max']:>6} {s['method']:<10} {s['sim_success']:>4}/{s['sim_n']:<5} {s['predicted_mean']:>9.3f} "
              f"{s['violation_max']:>11.1e} {t(s['time_median_s']):>9} {t(s['time_p95_s']):>9} "
              f"{s['force_mean']:>10.1f}  {s['status']}")
    by = {(s["qdot_max"], s["method"]): s["force_mean"] for s in summary}
    for m in args.methods:
        if (0.4, m) in by and (1.0, m) in by:
            print(f"{m}: mean force {by[(0.4, m)]:.1f} N under q̇_max = 0.4 vs {by[(1.0, m)]:.1f} N under 1.0 "
                  f"(ratio {by[(0.4, m)] / by[(1.0, m)]:.2f})")
    if args.json:
        Path(args.json).write_text(json.dumps(summary, indent=2) + "\n")


if __name__ == "__main__":
    main()
