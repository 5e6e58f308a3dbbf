"""One value + gradient of the judge through each CasADi backend against torch autograd.

Any saved judge (--model, default the shipped LSTM 2 x 100, FC 2 x 102), or a random
default-size judge of an architecture (--arch), at its horizon (N = 30), one trajectory.
Prints per-call times (median of --repeat calls after a warm-up), their ratios to torch
autograd (float32 as trained, and float64) and to the torch32 callback (`/cb32`, the direct
solve's judge before l4casadi32; where torch:float32 or torch32 is among --backends), build
times, and the time of a second build (cache hit).
Backends the architecture does not offer (native and compiled need a CasADi graph) are skipped.

    .venv/bin/python benchmarks/bench_judge_casadi.py [--model models/judge_demos_tcn | --arch tcn] [--threads 1]
    .venv/bin/python benchmarks/bench_judge_casadi.py --model models/judge_refined --backends torch32,l4casadi32

--cache-dir defaults to a fresh temporary folder so the build times are real builds.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import torch

from judgeopt.judge.archs import ARCHS
from judgeopt.judge.casadi_fn import BACKENDS, backends_for, build_casadi_judge, torch_logit_and_grad
from judgeopt.judge.model import Judge, JudgeConfig
from judgeopt.judge.store import load_judge


def timeit(fn, x: np.ndarray, repeat: int) -> float:
    """Median seconds of fn(x') over fresh trajectories x' (x with a tiny shift of y_0), so no
    backend can answer from a cache of the previous point."""
    times = []
    for i in range(repeat + 2):
        xi = x.copy()
        xi[0, 0] += 1e-9 * (i + 1)
        t = time.perf_counter()
        fn(xi)
        times.append(time.perf_counter() - t)
    return statistics.median(times[2:])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--model", default="models/judge_demos_tcn", help="saved judge (random default-size one if absent)")
    p.add_argument("--arch", choices=list(ARCHS), help="a random default-size judge of this architecture instead")
    p.add_argument("--backends", default="native,compiled,torch,torch:float32,l4casadi,l4casadi32",
                   help=f"comma-separated from {list(BACKENDS)}; torch:float32 for the float32 callback")
    p.add_argument("--repeat", type=int, default=30)
    p.add_argument("--rounds", type=int, default=3, help="interleaved timing rounds (best median kept)")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--cache-dir", help="build cache (default: a fresh temporary folder)")
    p.add_argument("--json", help="also write the results here")
    args = p.parse_args()
    torch.set_num_threads(args.threads)

    if Path(args.model + ".json").exists() and not args.arch:
        model, _ = load_judge(args.model)
        source = args.model
    else:
        torch.manual_seed(0)
        model = Judge(JudgeConfig(arch=args.arch or "lstm")).eval()
        source = f"random default-size {model.config.arch} judge"
    cfg = model.config
    n1 = cfg.horizon + 1
    rng = np.random.default_rng(0)
    t = np.linspace(0, 1, n1)
    y = -0.03 + 0.25 * (3 * t**2 - 2 * t**3)
    x = np.stack([y, np.gradient(y, cfg.dt), 12 + rng.normal(0, 2, n1)], axis=1)
    e = np.array([0.19, 2.0][: cfg.n_env])
    print(f"judge: {source}; {cfg.arch}: {cfg.spec.describe(cfg.net)}, "
          f"{sum(q.numel() for q in model.parameters())} parameters, N = {cfg.horizon}, torch threads {args.threads}")

    results: dict[str, dict] = {}
    calls: dict[str, tuple] = {}
    for dtype in (torch.float32, torch.float64):
        m = Judge(cfg)
        m.load_state_dict(model.state_dict())
        m = m.to(dtype).eval()
        for prm in m.parameters():
            prm.requires_grad_(False)

        def value_grad(xi, m=m, dtype=dtype):
            xt = torch.tensor(xi[None], dtype=dtype, requires_grad=True)
            et = torch.tensor(e[None], dtype=dtype, requires_grad=True)
            logit = m(xt, et)
            gx, ge = torch.autograd.grad(logit, (xt, et))
            return logit.item(), gx, ge

        def value(xi, m=m, dtype=dtype):
            with torch.no_grad():
                return m(torch.tensor(xi[None], dtype=dtype), torch.tensor(e[None], dtype=dtype)).item()

        name = f"torch autograd {str(dtype).split('.')[-1]}"
        results[name] = {}
        calls[name] = (value_grad, value)
    _, tgx, _ = torch_logit_and_grad(model, x, e)

    cache = Path(args.cache_dir) if args.cache_dir else Path(tempfile.mkdtemp(prefix="judge_bench_"))
    for spec in args.backends.split(","):
        backend, _, precision = spec.partition(":")
        precision = precision or "float64"
        if backend not in backends_for(cfg):
            print(f"skipped {spec}: a {cfg.arch} judge has no CasADi graph")
            continue
        cj = build_casadi_judge(model, backend, cache_dir=cache, precision=precision)
        t0 = time.perf_counter()
        cj2 = build_casadi_judge(model, backend, cache_dir=cache, precision=precision)
        second = time.perf_counter() - t0
        grad = cj._grad_fn()
        _, gx, _ = cj.value_and_gradient(x, e)
        err = float(np.abs(gx - tgx).max() / np.abs(tgx).max())
        results[f"casadi {spec}"] = {"build_s": cj.build_seconds, "cache_hit": cj.cache_hit, "second_build_s": second,
                                     "second_build_cache_hit": cj2.cache_hit, "grad_rel_err": err}
        calls[f"casadi {spec}"] = (lambda xi, g=grad: g(xi.ravel(), e), lambda xi, f=cj.fn: f(xi.ravel(), e), cj)

    # interleaved rounds, best median of each: the other processes on the machine come and go
    for _ in range(args.rounds):
        for name, (vg, v, *_) in calls.items():
            r = results[name]
            r["value_grad_s"] = min(r.get("value_grad_s", np.inf), timeit(vg, x, args.repeat))
            r["value_s"] = min(r.get("value_s", np.inf), timeit(v, x, args.repeat))
    ref = results["torch autograd float64"]["value_grad_s"]
    ref32 = results["torch autograd float32"]["value_grad_s"]
    cb32 = next((results[k]["value_grad_s"] for k in ("casadi torch32", "casadi torch:float32") if k in results), None)

    print(f"\n{'':26s} {'value+grad':>11s} {'value':>9s} {'/torch64':>9s} {'/torch32':>9s} {'/cb32':>6s} {'build':>8s} "
          f"{'2nd build':>10s} {'grad err':>9s}")
    for name, r in results.items():
        build = f"{r['build_s']:7.2f}s" if "build_s" in r else ""
        second = (f"{r['second_build_s']:6.3f}s{' hit' if r['second_build_cache_hit'] else ''}"
                  if "build_s" in r else "")
        err = f"{r['grad_rel_err']:.1e}" if "grad_rel_err" in r else ""
        if cb32 is not None:
            r["per_torch32_callback"] = r["value_grad_s"] / cb32
        vs_cb = f"{r['value_grad_s'] / cb32:6.2f}" if cb32 is not None else ""
        print(f"{name:26s} {1e3 * r['value_grad_s']:9.2f}ms {1e3 * r['value_s']:7.2f}ms "
              f"{r['value_grad_s'] / ref:9.2f} {r['value_grad_s'] / ref32:9.2f} {vs_cb:>6s} {build:>8s} "
              f"{second:>10s} {err:>9s}")
    if args.json:
        Path(args.json).write_text(json.dumps({"model": source, "arch": cfg.arch, "threads": args.threads, "repeat": args.repeat,
                                               "rounds": args.rounds, "results": results}, indent=1) + "\n")



if __name__ == "__main__":
    main()
