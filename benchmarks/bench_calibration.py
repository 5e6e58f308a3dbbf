"""What the calibration adds to every plan, measured side by side in one run.

Every planner result is annotated with its calibrated p and whether the calibration covers it
(`Calibrator.annotate`: the map, and the k-th nearest fitted outcome in the joint space, found
by brute force). Timed for the shipped direct-solve calibrator against the same with a scipy
k-d tree built once (the way before), alternated, the median of --n calls each; and the import
of scipy.spatial the tree needs, in a fresh process. For scale: the direct solve takes 20-30 ms,
the generator 1-2 ms per plan.

    python benchmarks/bench_calibration.py [--n 500] [--busy]

--busy keeps every core busy with a spinning process while timing, as on a robot's computer.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time

import numpy as np

from busy import Load

from judgeopt.files import resolve
from judgeopt.verdict.calibration import NEIGHBOURS, inputs, load_calibration
from judgeopt.planners.problem import LIMIT_NAMES, load_problem


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=500)
    ap.add_argument("--busy", action="store_true")
    args = ap.parse_args()
    load = Load(args.busy)
    problem = load_problem(resolve("problems/paper_sim.toml")).with_overrides(qdot_max=0.4)
    cal = next(c for c in load_calibration(resolve(problem.calibration)).values() if c.method == "direct"
               and c.judge_sha256 and len(c.points) > 100)
    x = inputs({k: getattr(problem, k) for k in LIMIT_NAMES}, problem.nominal_env())
    e, p = np.array([[x[k] for k in cal.env_names]]), np.array([0.99])
    from scipy.spatial import cKDTree

    tree = cKDTree(np.asarray(cal.points))
    brute, kd = [], []
    with load.busy():
        for _ in range(args.n):
            t = time.perf_counter()
            cal.annotate(x, 0.99)
            brute.append(time.perf_counter() - t)
            t = time.perf_counter()
            cal.predict(e, p)
            tree.query(cal._scaled(e, p), k=[NEIGHBOURS])
            kd.append(time.perf_counter() - t)
    load.close()
    t = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import numpy"], check=True)
    bare = time.perf_counter() - t
    t = time.perf_counter()
    subprocess.run([sys.executable, "-c", "import numpy, scipy.spatial"], check=True)
    spatial = time.perf_counter() - t - bare
    a, b = 1e3 * np.median(brute), 1e3 * np.median(kd)
    print(f"{'busy' if load.procs else 'idle'} ({len(cal.points)} fitted points): annotate {a:.3f} ms by brute force, "
          f"{b:.3f} ms with a k-d tree built once; ratio {b / a:.2f}x; importing scipy.spatial for the tree: "
          f"{1e3 * spatial:.0f} ms per process")


if __name__ == "__main__":
    main()
