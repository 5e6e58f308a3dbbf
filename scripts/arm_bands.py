"""Each arm's verdict on a held-out band, side by side: from the band.json that `judgeopt evaluate band
--robot ARM` writes, the plan to run's 'likely' and its failures (with the 95 % upper bound), split into
the settings without and with a constraint set (a constrained plan's p is the judge's own: no calibrator
covers its constraint set), and 'likely' where no plan succeeded.

    python scripts/arm_bands.py --seed 707 --robots kinova panda xarm7 ur3 ur10
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from judgeopt.verdict.risk import upper_bound


def cell(likely: int, failed: int) -> str:
    return f"{likely} / {failed} (<= {100 * upper_bound(failed, likely):.1f} %)" if likely else "0 / 0"


def row(robot: str, summary: dict) -> str:
    run, alone = summary["to_run"], summary["constrained_only"]["to_run"] if summary.get("constrained_only") else None
    c_likely, c_failed = (alone["likely"], alone["likely_failed"]) if alone else (0, 0)
    return (f"| {robot} | {summary['settings']} | {cell(run['likely'], run['likely_failed'])} "
            f"| {cell(run['likely'] - c_likely, run['likely_failed'] - c_failed)} | {cell(c_likely, c_failed)} "
            f"| {run['likely_and_succeeded']} of {run['some_succeeded']} "
            f"| {run['likely_where_none_succeeded']} of {run['none_succeeded']} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=707)
    ap.add_argument("--robots", nargs="+", default=["kinova", "panda", "xarm7", "ur3", "ur10"])
    ap.add_argument("--folder", default="out/band/{robot}_s{seed}", help="each arm's evaluate band --out")
    args = ap.parse_args()
    lines = ["| arm | settings | plan to run: likely / failed (95 % bound) | without constraints | with a constraint set "
             "| likely and succeeded, where a plan succeeded | likely where none succeeded |",
             "|---|---|---|---|---|---|---|"]
    for robot in args.robots:
        path = Path(args.folder.format(robot=robot, seed=args.seed)) / "band.json"
        if not path.exists():
            raise SystemExit(f"{path}: missing; run `judgeopt evaluate band --robot {robot} --seed {args.seed} "
                             f"--out {path.parent}` first")
        lines.append(row(robot, json.loads(path.read_text())))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
