"""Record the plans the shipped problems and models give today, for tests/test_golden.py.

Run only at a commit whose plans are the reference (before a refactor that must not change
them): `.venv/bin/python tests/golden/make_golden.py` writes tests/golden/plans.npz and
tests/golden/cases.json. It refuses to replace them unless given --overwrite.
"""

from __future__ import annotations

import argparse
import io
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent

#: (problem file, overrides, environments): the default problem, the slow one, a limit set only
#: the limit-conditioned generator covers, and the y_obj-only judge
CASES = [
    ("problems/paper_sim.toml", {}, [(0.12, 1.2), (0.20, 2.0), (0.27, 2.9)]),
    ("problems/paper_sim_slow.toml", {}, [(0.15, 1.5), (0.25, 2.5)]),
    ("problems/paper_sim.toml", {"f_max": 14.0}, [(0.14, 1.1), (0.22, 2.4)]),
    ("problems/paper_sim.toml", {"judge": "models/experiments/judge_yobj_only"}, [(0.18, 2.0)]),
]
METHODS = ("amortized", "direct")


def plans() -> tuple[list[dict], dict[str, np.ndarray]]:
    from judgeopt.files import resolve
    from judgeopt.planners.problem import load_problem
    from judgeopt.planners.loaded import Planners

    cases, arrays = [], {}
    for i, (path, overrides, envs) in enumerate(CASES):
        problem = load_problem(resolve(path)).with_overrides(**overrides)
        planners = Planners.load(problem, METHODS)
        for j, e in enumerate(envs):
            env = dict(zip(problem.env_names, e))
            for r in planners.solve(env):
                key = f"c{i}_e{j}_{r.method}"
                arrays[key] = r.plan.as_array()
                cases.append({"key": key, "problem": path, "overrides": overrides, "env": env, "method": r.method,
                              "predicted_success": r.predicted_success})
    return cases, arrays


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--overwrite", action="store_true")
    args = ap.parse_args()
    out_npz, out_json = HERE / "plans.npz", HERE / "cases.json"
    if out_npz.exists() and not args.overwrite:
        print(f"{out_npz} exists: the reference plans are kept (--overwrite to replace them)", file=sys.stderr)
        return 2
    from judgeopt.files import atomic_write

    cases, arrays = plans()
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    atomic_write(out_npz, buf.getvalue())
    atomic_write(out_json, json.dumps(cases, indent=1) + "\n")
    print(f"wrote {len(arrays)} plans to {out_npz}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
