"""Judges scored on the same replayed plans: the rows of `judgeopt evaluate band` folders (each holds
its plan's samples and the simulated outcome). Prints, per judge, accuracy at 0.5, the Brier score,
and how many plans it scored >= 0.99 that failed: what a judge refined on band outcomes must improve
where the planners' plans land (issue 43, item 1).

    python scripts/band_judge_accuracy.py out/band/heldout_s202 --judges models/judge_refined out/refine_band/round_2/judge
"""

from __future__ import annotations

import argparse

import numpy as np

from judgeopt.evaluate.stored import read_rows


def plans_of(folders: list[str], method: str | None) -> tuple[np.ndarray, list[dict], np.ndarray]:
    """The plans' samples (B, N + 1, channels), their environments and outcomes."""
    rows = [r for r in read_rows(folders)
            if r.get("channels") and r.get("simulated_success") is not None and (method is None or r["method"] == method)]
    if not rows:
        raise SystemExit(f"{folders}: no replayed plans with their samples (rows from `judgeopt evaluate band`)")
    x = np.stack([np.stack([r[c] for c in r["channels"]], axis=1) for r in rows])
    return x, [r["environment"] for r in rows], np.array([bool(r["simulated_success"]) for r in rows])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+")
    ap.add_argument("--judges", nargs="+", required=True)
    ap.add_argument("--method", help="only this planner's plans")
    args = ap.parse_args()
    from judgeopt.files import resolve
    from judgeopt.judge.store import load_judge

    x, envs, y = plans_of(args.folders, args.method)
    print(f"{len(y)} plans, {int(y.sum())} succeeded ({args.folders})")
    print("| judge | accuracy at 0.5 | Brier | scored >= 0.99 | of those failed |")
    print("|---|---|---|---|---|")
    for name in args.judges:
        judge, _ = load_judge(resolve(name))
        e = np.array([[env[k] for k in judge.config.env_names] for env in envs])
        p = judge.predict_proba(x, e)
        high = p >= 0.99
        print(f"| {name} | {np.mean((p >= 0.5) == y):.3f} | {np.mean((p - y) ** 2):.3f} | {int(high.sum())} "
              f"| {int((~y[high]).sum())} |")


if __name__ == "__main__":
    main()
