"""The judge inside Ipopt, per CasADi backend: does the backend's precision and speed hold
up in the use it is built for?

Problem (a stand-in for the planner's): start from a test-set response the judge calls a
failure and find the nearest trajectory (scaled per channel) that it judges a success,

    min_x  -logit(x, e) + w * || (x - x0) / s ||^2

with the limited-memory Hessian (the judge has first derivatives only). Reports Ipopt's
status, iterations, wall time and final logit per backend.

    .venv/bin/python benchmarks/bench_judge_ipopt.py --model models/judge_demos_tcn --data data/test.h5
"""

from __future__ import annotations

import argparse
import tempfile
import time

import casadi as cs
import numpy as np
import torch

from judgeopt.data.dataset import load
from judgeopt.judge.casadi_fn import build_casadi_judge
from judgeopt.judge.model import select_env
from judgeopt.judge.store import load_judge


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--model", default="models/judge_demos_tcn")
    p.add_argument("--data", default="data/test.h5")
    p.add_argument("--backends", default="torch,torch:float32,native,l4casadi")
    p.add_argument("--cases", type=int, default=3, help="number of failing demonstrations to start from")
    p.add_argument("--weight", type=float, default=0.05)
    p.add_argument("--tol", type=float, default=1e-8, help="Ipopt tol (its default is 1e-8)")
    p.add_argument("--max-iter", type=int, default=300)
    args = p.parse_args()
    torch.set_num_threads(1)

    model, _ = load_judge(args.model)
    ds = load(args.data)
    env = select_env(ds.env, ds.env_names, model.config.env_names)
    prob = model.predict_proba(ds.responses, env)
    fails = np.flatnonzero((ds.labels == 0) & (prob < 0.2))[: args.cases]
    scale = np.tile(model.x_std.double().numpy(), model.config.horizon + 1)
    cache = tempfile.mkdtemp(prefix="judge_ipopt_")
    print(f"{'backend':16s} {'case':>4s} {'status':>28s} {'iter':>5s} {'time':>8s} {'logit0':>8s} {'logit':>8s}")
    for spec in args.backends.split(","):
        backend, _, precision = spec.partition(":")
        cj = build_casadi_judge(model, backend, cache_dir=cache, precision=precision or "float64")
        for i in fails:
            x0 = ds.responses[i].ravel()
            x = cs.MX.sym("x", x0.size)
            e = cs.DM(env[i])
            f = -cj.fn(x, e)[0] + args.weight * cs.sumsqr((x - x0) / scale)
            solver = cs.nlpsol("s", "ipopt", {"x": x, "f": f}, {
                "ipopt.print_level": 0, "print_time": False, "ipopt.hessian_approximation": "limited-memory",
                "ipopt.tol": args.tol, "ipopt.max_iter": args.max_iter})
            t = time.perf_counter()
            sol = solver(x0=x0)
            dt = time.perf_counter() - t
            st = solver.stats()
            logit = float(cj.fn(sol["x"], e)[0])
            print(f"{spec:16s} {int(i):4d} {st['return_status']:>28s} {st['iter_count']:5d} {dt:7.2f}s "
                  f"{float(cj.fn(x0, e)[0]):8.3f} {logit:8.3f}")


if __name__ == "__main__":
    main()
