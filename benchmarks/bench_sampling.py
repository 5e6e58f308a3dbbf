"""The sampling baseline's two searches side by side: the hand-written cross-entropy method
(judgeopt.planners.cem) and CMA-ES from the `cmaes` library (judgeopt.planners.cmaes_search),
over the same space of spline commands, with the same score and the same number of judge
evaluations, on the same random in-range environments, every plan replayed in simulation.

For each velocity limit and search: simulated success (k / n, 95 % Wilson interval), mean
predicted success, worst constraint violation (the plans' residuals, and which constraint),
median and 95th-percentile plan time, and the environments where only one of the two succeeded.
`--cmaes-population` adds CMA-ES with other populations at the same budget (more generations):
CMA-ES's own default population for 12 knots is 11, the CEM's 256.

    python benchmarks/bench_sampling.py                  # 100 environments, q̇_max 1.0 and 0.4
    python benchmarks/bench_sampling.py --n 10           # quick look
    python benchmarks/bench_sampling.py --judge models/judge_demos_tcn --cmaes-population 256 32
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from judgeopt.evaluate.batch import simulator
from judgeopt.evaluate.report import wilson
from judgeopt.files import resolve
from judgeopt.parallel import run_chunks, worker_cache
from judgeopt.planners.cem import CEMConfig
from judgeopt.planners.problem import Problem, load_problem
from judgeopt.trajectory import PlanError

CHUNK = 5  # environments per job


def label(population: int) -> str:
    """A CMA-ES row's name: "cmaes" at the CEM's population, else with its population."""
    return "cmaes" if population == CEMConfig.population else f"cmaes{population}"


def searches(problem: Problem, populations: tuple[int, ...]) -> dict:
    """This process's planners for the problem against its judge (what `solve` plans with): the
    CEM, and CMA-ES with each population at the CEM's budget (population x iterations)."""
    def build() -> dict:
        from judgeopt.judge.store import load_judge
        from judgeopt.planners.cem import CEMPlanner
        from judgeopt.planners.cmaes_search import CMAESConfig, CMAESPlanner

        judge, _ = load_judge(resolve(problem.judge, (".json",)))
        budget = CEMConfig.population * CEMConfig.iterations
        return {"cem": CEMPlanner(problem, judge), **{
            label(n): CMAESPlanner(problem, judge, CMAESConfig(population=n, iterations=max(1, budget // n)))
            for n in populations}}

    return worker_cache(f"bench_sampling:{problem.judge}:{problem.qdot_max}:{populations}", build)


def plan_chunk(problem: Problem, envs: np.ndarray, populations: tuple[int, ...]) -> list[dict]:
    """Plan each environment with every search and replay each plan: one row per (env, search)."""
    import torch

    torch.set_num_threads(1)
    sim, rows = simulator(problem.task), []
    for e in envs:
        env = dict(zip(problem.env_names, map(float, e)))
        for name, planner in searches(problem, populations).items():
            r = planner.solve(env)
            try:  # a plan the arm cannot be commanded to follow fails, as in `judgeopt solve`
                ok = bool(sim.simulate(r.plan, problem.world_env(env)).success) if r.plan is not None else False
            except PlanError:
                ok = False
            rows.append({"search": name, "sim": ok, "p": r.predicted_success, "t": r.solve_time_s,
                         "violation": r.max_constraint_violation, "worst": r.worst_constraint})
    return rows


def summarise(rows: list[dict], search: str) -> dict:
    rs = [r for r in rows if r["search"] == search]
    k, n = sum(r["sim"] for r in rs), len(rs)
    times = np.array([r["t"] for r in rs])
    return {"search": search, "k": k, "n": n, "wilson": wilson(k, n),
            "p_mean": float(np.mean([r["p"] for r in rs if r["p"] is not None])),
            "violation_max": float(max(r["violation"] for r in rs if r["violation"] is not None)),
            "worst": max(rs, key=lambda r: r["violation"] or 0.0)["worst"],
            "t_median": float(np.median(times)), "t_p95": float(np.percentile(times, 95))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100, help="environments per velocity limit")
    ap.add_argument("--qdot-max", type=float, nargs="+", default=[1.0, 0.4], help="velocity limits [m/s]")
    ap.add_argument("--seed", type=int, default=2024, help="the environments' seed (as bench_planners.py)")
    ap.add_argument("--jobs", type=int, default=1, help="worker processes (timings are fair only with 1)")
    ap.add_argument("--problem", default="problems/paper_sim.toml")
    ap.add_argument("--judge", help="the judge both search against (default: the problem's, as `judgeopt solve`)")
    ap.add_argument("--cmaes-population", type=int, nargs="+", default=[CEMConfig.population],
                    help="CMA-ES populations to measure, each at the CEM's budget")
    args = ap.parse_args()

    base = load_problem(resolve(args.problem)).with_overrides(judge=args.judge)
    populations = tuple(args.cmaes_population)
    names = ("cem", *map(label, populations))
    envs = base.sample_env(np.random.default_rng(args.seed), args.n)
    t0 = time.perf_counter()
    lines = []
    for qdot_max in args.qdot_max:
        problem = base.with_overrides(qdot_max=qdot_max)
        work = [(i, plan_chunk, (problem, envs[i:i + CHUNK], populations)) for i in range(0, args.n, CHUNK)]
        found = run_chunks(work, lambda key, result: None, n_jobs=args.jobs, desc=f"q̇_max={qdot_max:g}",
                           unit="env", sizes={i: len(envs[i:i + CHUNK]) for i, _, _ in work})
        rows = [r for i in sorted(found) for r in found[i]]
        for s in (summarise(rows, m) for m in names):
            lo, hi = s["wilson"]
            lines.append(f"{qdot_max:>6g} {s['search']:<9} {s['k']:>4}/{s['n']:<4} [{lo:.2f}, {hi:.2f}] "
                         f"{s['p_mean']:>9.3f} {s['violation_max']:>11.1e} {s['worst'] or '-':<10} "
                         f"{s['t_median']:>8.3f} s {s['t_p95']:>7.3f} s")
        by = {m: [r["sim"] for r in rows if r["search"] == m] for m in names}
        for m in names[1:]:  # paired with the CEM on the same environments
            only = sum(a and not b for a, b in zip(by[m], by["cem"])), sum(b and not a for a, b in zip(by[m], by["cem"]))
            lines.append(f"{'':>6} {m} succeeded where the CEM failed: {only[0]}, the CEM where it failed: {only[1]}")
    print(f"\n{args.n} environments per limit (seed {args.seed}), {base.name}, judge {base.judge}; "
          f"{time.perf_counter() - t0:.0f} s in all, {args.jobs} job(s); {CEMConfig.population * CEMConfig.iterations} "
          "judged samples per plan")
    print(f"{'q̇_max':>6} {'search':<9} {'simulated':>9} {'95 % Wilson':>12} {'predicted':>9} {'worst viol.':>11} "
          f"{'(which)':<10} {'median t':>10} {'p95 t':>9}")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
