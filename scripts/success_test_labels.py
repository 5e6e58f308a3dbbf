"""How many labels of a shipped scoop dataset the success test changes: replay its commands
(each demonstration's command in its recorded environment) once, and compare the label the old
test ("rise": the object's centre 2.5 cm above its start) and the new one ("clear": the object's
lowest point clear of the plate, on the blade) give, and both against the recorded label.

    .venv/bin/python scripts/success_test_labels.py data/test.h5 --n 1000 --jobs 2
"""

from __future__ import annotations

import argparse
import json

import numpy as np


def replay(commands: np.ndarray, env: np.ndarray, env_names: list[str]) -> list[dict]:
    from judgeopt.parallel import worker_cache
    from judgeopt.tasks import get_task

    task = get_task("scoop")
    sim = worker_cache("labels:scoop", task.simulator)
    out = []
    for c, e in zip(commands, env):
        d = sim.simulate(task.plan(c), dict(zip(env_names, map(float, e)))).details
        out.append({k: d[k] for k in ("success_rise_test", "success_clear_test", "object_rise", "object_bottom",
                                      "offset_from_blade", "on_blade", "on_plate")})
    return out


def main() -> None:
    from judgeopt.data.dataset import load
    from judgeopt.parallel import run_chunks

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("data")
    ap.add_argument("--n", type=int, default=1000, help="first N demonstrations (default 1000)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", metavar="FILE", help="also write every replay's figures here")
    args = ap.parse_args()
    ds = load(args.data)
    n = min(args.n, ds.n)
    parts = [(k, replay, (ds.commands[k:k + 25], ds.env[k:k + 25], list(ds.env_names))) for k in range(0, n, 25)]
    done = run_chunks(parts, lambda k, r: None, n_jobs=args.jobs, desc="replay", unit="chunk")
    rows = [r for k in sorted(done) for r in done[k]]
    old = np.array([r["success_rise_test"] for r in rows])
    new = np.array([r["success_clear_test"] for r in rows])
    recorded = ds.labels[:n].astype(bool)
    print(f"{args.data}: {n} demonstrations replayed")
    print(f"  old test reproduces the recorded label: {int((old == recorded).sum())}/{n}")
    print(f"  labels the new test changes: {int((old != new).sum())}/{n} ({100 * (old != new).mean():.2f} %): "
          f"{int((~old & new).sum())} failure -> success, {int((old & ~new).sum())} success -> failure")
    bottom = np.array([r["object_bottom"] for r in rows])
    rise = np.array([r["object_rise"] for r in rows])
    if new.any():
        print(f"  successes (new test): object's lowest point {100 * bottom[new].min():.2f} to "
              f"{100 * bottom[new].max():.2f} cm above the plate, rise {100 * rise[new].min():.2f} to "
              f"{100 * rise[new].max():.2f} cm")
    changed = np.flatnonzero(old != new)
    for i in changed[:20]:
        print(f"  changed: #{i} env {dict(zip(ds.env_names, ds.env[i].round(3).tolist()))} {rows[i]}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f)


if __name__ == "__main__":
    main()
