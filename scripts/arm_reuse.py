"""The paper's open claim, measured: demonstrations (and the judge trained on them) reused between
arms. The same random demonstrations (same seed: the same environments and commands) run on each
arm under the same hybrid controller; per arm: the success ratio, how often its outcome equals the
UR5's for the same command, and each UR5-trained judge's accuracy on the arm's own outcomes.
Resumable (each arm's collection resumes from its .partial folder); writes a Markdown table and a
figure.

    python scripts/arm_reuse.py --n 1000 --seed 12 --out out/arms_reuse
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from judgeopt.data.collect import CollectionSpec, collect
from judgeopt.data.dataset import load
from judgeopt.files import atomic_write, resolve, save_figure
from judgeopt.judge.evaluate import evaluate_judge
from judgeopt.judge.store import load_judge
from judgeopt.robots import DEFAULT_ROBOT, robot_names
from judgeopt.tasks import get_task


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=12)
    ap.add_argument("--robots", nargs="+", default=robot_names())
    ap.add_argument("--judges", nargs="+", default=["models/judge_demos_tcn", "models/judge_refined"])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", default="out/arms_reuse")
    ap.add_argument("--finetune", type=int, metavar="SEED",
                    help="also fine-tune the first --judges judge on each arm's own demonstrations of this seed (another "
                    "collection), the first 100, 300 and 1,000, and score it on the test demonstrations above")
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 300, 1000])
    ap.add_argument("--epochs", type=int, default=15)
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    task = get_task("scoop")
    robots = [DEFAULT_ROBOT] + [r for r in args.robots if r != DEFAULT_ROBOT]
    data = {}
    for r in robots:
        spec = CollectionSpec(task="scoop", seed=args.seed, n=args.n, settings=task.robot_settings(r))
        path = out / f"{r}.h5"
        data[r] = load(path) if path.exists() else collect(spec, path, n_jobs=args.jobs, progress=True)
    judges = {Path(j).name: load_judge(resolve(j, (".json",)))[0] for j in args.judges}
    ref = data[DEFAULT_ROBOT]
    rows = []
    for r, ds in data.items():
        assert np.array_equal(ds.commands, ref.commands), "the arms' demonstrations must share their commands"
        row = {"robot": r, "n": ds.n, "success": float(ds.labels.mean()),
               "same_as_ur5": float((ds.labels == ref.labels).mean())}
        for name, judge in judges.items():
            row[name] = evaluate_judge(judge, ds)["accuracy"]
            row[f"{name} (command)"] = evaluate_judge(judge, ds, view="command")["accuracy"]
        rows.append(row)
    judges_views = [k for j in judges for k in (j, f"{j} (command)")]
    head = ["arm", "demonstrations", "success ratio", "outcome = UR5's",
            *(f"{j} accuracy" for j in judges_views)]
    lines = [f"| {' | '.join(head)} |", f"|{'---|' * len(head)}"]
    for row in rows:
        lines.append(f"| {row['robot']} | {row['n']} | {row['success']:.3f} | {row['same_as_ur5']:.3f} | "
                     + " | ".join(f"{row[j]:.3f}" for j in judges_views) + " |")
    table = "\n".join(lines) + "\n"
    atomic_write(out / "reuse.md", f"Command: `python scripts/arm_reuse.py --n {args.n} --seed {args.seed} --robots "
                 f"{' '.join(robots)} --out {args.out}`\n\n" + table)
    print(table)

    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.2))
    x = np.arange(len(rows))
    width = 0.8 / (len(judges) + 1)
    ax.bar(x, [row["same_as_ur5"] for row in rows], width, label="outcome = UR5's (same command)")
    for k, j in enumerate(judges, 1):
        ax.bar(x + k * width, [row[j] for row in rows], width, label=f"{j} accuracy")
    ax.set_xticks(x + width * len(judges) / 2, [row["robot"] for row in rows])
    ax.set_ylim(0.5, 1.0)
    ax.set_ylabel("share of demonstrations")
    ax.legend(fontsize=7, loc="lower left")
    ax.set_title(f"UR5 demonstrations and judges on other arms ({args.n} random demonstrations each)", fontsize=9)
    save_figure(fig, out / "reuse.png", dpi=110)
    print(f"wrote {out / 'reuse.md'} and {out / 'reuse.png'}")
    if args.finetune is not None:
        finetune(args, data, out)


def finetune(args: argparse.Namespace, tests: dict, out: Path) -> None:
    """The first judge fine-tuned (its architecture and normalisation kept) on the first k of each arm's
    own demonstrations of seed --finetune, for each k of --sizes; accuracy on that arm's test set."""
    import json

    from judgeopt.judge.errors import JudgeError
    from judgeopt.judge.train import TrainConfig, train_judge

    task = get_task("scoop")
    base, _ = load_judge(resolve(args.judges[0], (".json",)))
    name = Path(args.judges[0]).name
    done_path = out / f"finetune_s{args.finetune}.json"
    done = json.loads(done_path.read_text()) if done_path.exists() else {}
    for r in tests:
        if r == DEFAULT_ROBOT:
            continue
        path = out / f"{r}_train_s{args.finetune}.h5"
        spec = CollectionSpec(task="scoop", seed=args.finetune, n=max(args.sizes), settings=task.robot_settings(r))
        train = load(path) if path.exists() else collect(spec, path, n_jobs=args.jobs, progress=True)
        for k in args.sizes:
            key = f"{r}:{k}"
            if key not in done:
                try:
                    model, _ = train_judge(train.subset(np.arange(k)), None, None,
                                           TrainConfig(epochs=args.epochs, lr=5e-4, seed=0, progress=False), init=base)
                    done[key] = evaluate_judge(model, tests[r])["accuracy"]
                except JudgeError as exc:  # too few of one class to split off a validation set
                    done[key] = None
                    print(f"{r}, {k} demonstrations: not fine-tuned: {exc}", flush=True)
                atomic_write(done_path, json.dumps(done))  # resumable: one fine-tune at a time
            if done[key] is not None:
                print(f"{r}: {name} fine-tuned on {k} of its demonstrations: accuracy {done[key]:.3f}", flush=True)
    head = ["arm", f"{name} as trained", *(f"fine-tuned on {k}" for k in args.sizes)]
    lines = [f"| {' | '.join(head)} |", f"|{'---|' * len(head)}"]
    for r, ds in tests.items():
        if r != DEFAULT_ROBOT:
            lines.append(f"| {r} | {evaluate_judge(base, ds)['accuracy']:.3f} | "
                         + " | ".join("too few successes" if done[f"{r}:{k}"] is None else f"{done[f'{r}:{k}']:.3f}"
                                      for k in args.sizes) + " |")
    atomic_write(out / "finetune.md", f"Command: `python scripts/arm_reuse.py --n {args.n} --seed {args.seed} "
                 f"--finetune {args.finetune} --out {args.out}`\n\n" + "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
