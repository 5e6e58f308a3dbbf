"""How a lab's motions of 0.9-2.2 s are fitted to the planner's horizon, measured (docs/recordings.md):
`--fit crop` at N = 30, `--fit resample` at N = 30, `--fit crop` at N = 45. For each: how many
recordings are kept, the judge's held-out accuracy (labels as given and true outcomes), and the
direct solve's plans under Table 8 tried 10 times each.

    python -m judgeopt.tasks.scoop.lab_recordings --out out/lab1115 --n 1115 --seed 0
    python scripts/compare_fits.py out/lab1115 --out out/s5     # about 10 min on 2 cores

The first 1,000 recordings train, the last 115 are held out.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from judgeopt.cli import main
from judgeopt.data.dataset import load
from judgeopt.evaluate.trials import trials
from judgeopt.files import resolve
from judgeopt.judge.evaluate import evaluate_judge
from judgeopt.judge.store import load_judge
from judgeopt.planners.problem import load_problem
from judgeopt.planners.loaded import Planners
from judgeopt.tasks import get_task

VARIANTS = {"crop": ["--fit", "crop"], "resample": ["--fit", "resample"], "crop45": ["--fit", "crop", "--horizon", "45"]}
IMPORT = ["--columns", "t=time,y=tool_y_m,f=fz_N", "--scale", "f=-1", "--tare", "--env-names", "y_obj",
          "--env", "y_obj=0.246", "--align", "onset", "--overwrite"]


def run(lab: Path, out: Path, name: str, flags: list[str]) -> dict:
    files = sorted(str(p) for p in (lab / "recordings").glob("demo_*.csv"))
    parts = {"train": files[:1000], "test": files[1000:]}
    for part, chosen in parts.items():
        for labels in ("labels", "labels_true"):
            main(["import-demos", *chosen, "--labels", str(lab / f"{labels}.csv"), *IMPORT, *flags,
                  "--out", str(out / f"{name}_{part}_{labels}.h5")])
    judge = out / f"judge_{name}"
    main(["train-judge", "--train", str(out / f"{name}_train_labels.h5"), "--env-names", "y_obj", "--seed", "0",
          "--threads", "2", "--quiet", "--overwrite", "--out", str(judge)])
    model, _ = load_judge(judge.with_suffix(".json"))
    row = {"variant": name, "kept_train": load(out / f"{name}_train_labels.h5").n,
           "kept_test": load(out / f"{name}_test_labels.h5").n}
    for labels in ("labels", "labels_true"):
        row[f"accuracy_{labels}"] = evaluate_judge(model, load(out / f"{name}_test_{labels}.h5"))["accuracy"]
    task = get_task("scoop")
    sim = task.simulator()
    steps = int(flags[flags.index("--horizon") + 1]) if "--horizon" in flags else 30
    problem = load_problem(resolve("problems/paper_real.toml")).with_overrides(steps=steps)
    for qd in (1.0, 0.4):
        p = problem.with_overrides(qdot_max=qd)
        env = p.nominal_env()
        (r,) = Planners.load(p, ("direct",), judge=str(judge)).solve(env)
        done = trials(task, r.plan, p.world_env(env), n=10, seed=0, simulator=sim)
        row[f"direct_{qd:g}"] = f"{sum(o.success for _, o in done)}/10 (p {r.predicted_success:.3f})"
    return row


def cli(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("lab", type=Path, help="a folder written by judgeopt.tasks.scoop.lab_recordings (1,115 recordings)")
    ap.add_argument("--out", type=Path, default=Path("out/s5"))
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = [run(args.lab, args.out, name, flags) for name, flags in VARIANTS.items()]
    for r in rows:
        print(json.dumps(r))
    return 0


if __name__ == "__main__":
    sys.exit(cli())
