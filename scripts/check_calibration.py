"""Held-out check of a calibration on a refinement round's replayed plans.

`judgeopt refine` round 1 plans with the starting judge and generator, i.e. the same setting
as the default direct solve, on environments no evaluation seed draws. Usage:

    python scripts/check_calibration.py out/refine2/round_1 --calibration models/calibration_default.json
"""

from __future__ import annotations

import argparse

import numpy as np

from judgeopt.evaluate.stored import read_rows
from judgeopt.verdict.calibration import load_calibration

RANGES = ((0.05, 0.5), (0.5, 1.0), (1.0, 3.0), (3.0, 3.5), (3.5, 4.0))  # Table 5's


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("round", help="a refinement round folder (with partial/*.json)")
    ap.add_argument("--calibration", default="models/calibration_default.json")
    ap.add_argument("--method", default="direct")
    args = ap.parse_args()
    rows = [r for r in read_rows(args.round)
            if r["method"] == args.method]
    cal = next(c for c in load_calibration(args.calibration).values()
               if c.method == args.method and "judge_demos_tcn" in c.description)
    env = np.array([r["env"] for r in rows])
    pred = np.array([r["predicted"] for r in rows])
    sim = np.array([r["success"] for r in rows], float)
    calibrated = cal.predict(env, pred)
    print(f"{cal.description}; {len(rows)} plans from {args.round}")
    print("| mu | plans | simulated | judge | calibrated | calibrated - simulated |\n|---|---|---|---|---|---|")
    for lo, hi in RANGES + ((0.05, 4.0),):
        m = (env[:, 1] >= lo) & (env[:, 1] <= hi)
        print(f"| [{lo:g}, {hi:g}] | {m.sum()} | {100 * sim[m].mean():.0f} % | {pred[m].mean():.3f} "
              f"| {calibrated[m].mean():.3f} | {100 * (calibrated[m].mean() - sim[m].mean()):+.0f} pts |")


if __name__ == "__main__":
    main()
