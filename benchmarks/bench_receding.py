"""The receding planner against the open-loop direct solve, side by side in one run: simulated
success in the world planned for and in worlds unlike it (the object nearer or further than
said, the friction twice or half what was said), and the time each re-plan takes.

    python benchmarks/bench_receding.py --n 20 --jobs 2

Each environment is drawn from the problem's ranges (seeded); the planners are told it, the
simulated world differs from it by the named amount. The open-loop plan is the direct solve's,
warm-started from the generator; the receding planner starts from the same plan.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from joblib import Parallel, delayed

#: name -> how the simulated world differs from what the planners are told
WORLDS = {
    "as told": {},
    "object 3 cm further": {"y_obj": 0.03},
    "object 3 cm nearer": {"y_obj": -0.03},
    "object 4 cm further": {"y_obj": 0.04},
    "friction x2": {"mu": 2.0},
    "friction x0.5": {"mu": 0.5},
}


def _world(env: dict[str, float], change: dict[str, float]) -> dict[str, float]:
    out = dict(env)
    if "y_obj" in change:
        out["y_obj"] = env["y_obj"] + change["y_obj"]
    if "mu" in change:
        out["mu"] = float(np.clip(env["mu"] * change["mu"], 0.01, 5.0))
    return out


def work(problem_file: str, qdot_max: float, envs: list[dict[str, float]], worlds: list[str],
         trigger: str) -> list[dict]:
    from judgeopt.files import resolve
    from judgeopt.planners.problem import load_problem
    from judgeopt.planners.receding import PLAN_KEPT, RecedingConfig, RecedingPlanner
    from judgeopt.planners.loaded import Planners
    from judgeopt.tasks import get_task

    import torch

    torch.set_num_threads(1)
    problem = load_problem(resolve(problem_file)).with_overrides(qdot_max=qdot_max)
    planners = Planners.load(problem, ("amortized", "direct"))
    sim = get_task(problem.task).simulator()
    receding = RecedingPlanner(planners["direct"], RecedingConfig(problem.replan_period, trigger))
    rows = []
    for i, env in enumerate(envs):
        first = planners.solve(env)[1]
        for name in worlds:
            world = _world(env, WORLDS[name])
            open_loop = bool(sim.simulate(first.plan, world).success)
            t0 = time.perf_counter()
            loop = receding.execute(sim, first, env, world)
            rows.append({"qdot_max": qdot_max, "world": name, "env": i, "open_loop": open_loop,
                         "receding": bool(loop.outcome.success),
                         "replan_s": [r.seconds for r in loop.replans if r.status != PLAN_KEPT],
                         "dropped": sum(not r.kept and r.status != PLAN_KEPT for r in loop.replans),
                         "seconds": time.perf_counter() - t0})
    sim.close()
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--problem", default="problems/paper_sim.toml")
    ap.add_argument("--qdot-max", default="1.0,0.4")
    ap.add_argument("--n", type=int, default=20, help="environments per velocity limit")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--trigger", default="always", choices=("always", "judge"),
                    help="re-solve at every period, or only when the judge falls below p_target")
    ap.add_argument("--worlds", nargs="+", default=list(WORLDS), choices=list(WORLDS), metavar="WORLD")
    args = ap.parse_args()

    from judgeopt.files import resolve
    from judgeopt.planners.problem import load_problem

    problem = load_problem(resolve(args.problem))
    envs = [dict(zip(problem.env_names, e)) for e in problem.sample_env(np.random.default_rng(args.seed), args.n)]
    qdots = [float(q) for q in args.qdot_max.split(",")]
    chunks = [(q, envs[k::args.jobs]) for q in qdots for k in range(args.jobs)]
    t0 = time.perf_counter()
    parts = Parallel(n_jobs=args.jobs)(delayed(work)(args.problem, q, c, args.worlds, args.trigger) for q, c in chunks if c)
    rows = [r for p in parts for r in p]
    print(f"{args.problem}, {args.n} environments (seed {args.seed}) per velocity limit, trigger {args.trigger}, "
          f"{args.jobs} worker(s), "
          f"{time.perf_counter() - t0:.0f} s")
    print("| q̇_max | world | open-loop direct | receding | re-solves | median | p95 | max | dropped |")
    print("|---|---|---|---|---|---|---|---|---|")
    for q in qdots:
        for name in args.worlds:
            sel = [r for r in rows if r["qdot_max"] == q and r["world"] == name]
            s = np.concatenate([r["replan_s"] for r in sel]) * 1e3
            times = (f"{np.median(s):.0f} ms | {np.percentile(s, 95):.0f} ms | {s.max():.0f} ms" if s.size
                     else "- | - | -")
            print(f"| {q:g} | {name} | {sum(r['open_loop'] for r in sel)}/{len(sel)} | "
                  f"{sum(r['receding'] for r in sel)}/{len(sel)} | {len(s)} | {times} | "
                  f"{sum(r['dropped'] for r in sel)} |")


if __name__ == "__main__":
    main()
