"""Plans made for the UR5, replayed on another arm, beside plans made for that arm (its joint velocity
and torque limits held by the direct solve): the paper's point about reusing demonstrations between
robots with different constraints. Per arm and speed limit, over the same held-out environments:
simulated success on the arm, and the share of plans that hold the arm's joint limits (to 1e-6, at
the samples and halfway between them). Resumable: each (arm, speed limit) is written once to OUT/.

    python scripts/arm_plans.py --n 50 --seed 21 --out out/arm_plans
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from tqdm import tqdm

import judgeopt
from judgeopt.files import atomic_write
from judgeopt.planners.joint_limits import joint_map
from judgeopt.robots import DEFAULT_ROBOT, robot_names

HOLD = 1e-6


def run(robot: str, qdot_max: float, n: int, seed: int, judge: str | None = None) -> dict:
    own = judgeopt.load_problem("paper_sim", qdot_max=qdot_max, robot=robot, **({"judge": judge} if judge else {}))
    ur5 = judgeopt.load_problem("paper_sim", qdot_max=qdot_max)
    planners = {"made for the UR5": judgeopt.load_planners(ur5, ["direct"]),
                f"made for the {robot}": judgeopt.load_planners(own, ["direct"])}
    sim = judgeopt.simulator(own.task, robot)
    arm_joints = joint_map(own)
    envs = own.sample_env(np.random.default_rng(seed), n)
    out: dict[str, dict] = {k: {"success": 0, "held": 0, "planned": 0, "likely": 0, "likely_failed": 0, "binding": {}}
                            for k in planners}
    for e in tqdm(envs, desc=f"{robot} q̇_max {qdot_max:g}", leave=False):
        env = own.env_dict(dict(zip(own.env_names, map(float, e))))
        for name, p in planners.items():
            r = p.solve(env)[0]
            if r.plan is None:
                continue
            o = out[name]
            o["planned"] += 1
            ok = bool(sim.simulate(r.plan, env).success)
            o["success"] += int(ok)
            if r.verdict == "likely":  # as solve says it for the arm it planned for (the UR5's plan: for the UR5)
                o["likely"] += 1
                o["likely_failed"] += int(not ok)
            o["held"] += int(max(arm_joints.residuals(r.plan, 1.0).values()) <= HOLD)
            joint, kind, ratio = arm_joints.binding(r.plan, 1.0)
            if ratio > 1.0 + HOLD:
                o["binding"][f"{joint} {kind}"] = o["binding"].get(f"{joint} {kind}", 0) + 1
    return {"robot": robot, "qdot_max": qdot_max, "n": n, "seed": seed, "plans": out}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=50)
    ap.add_argument("--seed", type=int, default=21)
    ap.add_argument("--robots", nargs="+", default=[r for r in robot_names() if r != DEFAULT_ROBOT])
    ap.add_argument("--qdot-max", type=float, nargs="+", default=[1.0, 0.4])
    ap.add_argument("--out", default="out/arm_plans")
    ap.add_argument("--judge", help="the judge the arm's own plans are made and judged with (default: the problem's, "
                    "the UR5's); the UR5's plans keep the problem's")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    results = []
    lines = ["| arm | q̇_max [m/s] | plan | simulated success on the arm | holds the arm's joint limits | called likely / "
             "of them failed on the arm | joints over their limit (plans) |", "|---|---|---|---|---|---|---|"]
    for robot in args.robots:
        for q in args.qdot_max:
            path = out / f"{robot}_{q:g}_s{args.seed}_n{args.n}.json"
            if not path.exists():
                atomic_write(path, json.dumps(run(robot, q, args.n, args.seed, args.judge)))
            res = json.loads(path.read_text())
            results.append(res)
            for name, o in res["plans"].items():
                over = ", ".join(f"{k} ({v})" for k, v in sorted(o["binding"].items(), key=lambda kv: -kv[1])) or "-"
                lines.append(f"| {robot} | {q:g} | {name} | {o['success']}/{o['planned']} | {o['held']}/{o['planned']} "
                             f"| {o['likely']} / {o['likely_failed']} | {over} |")
    table = "\n".join(lines) + "\n"
    judge = f" --judge {args.judge}" if args.judge else ""
    atomic_write(out / "arm_plans.md", f"Command: `python scripts/arm_plans.py --n {args.n} --seed {args.seed}{judge}`\n\n"
                 + table)
    print(table)
    plot(results, out / "arm_plans.png")


def plot(results: list[dict], path: Path) -> None:
    """Per arm and speed limit: the share of plans that succeeded on the arm and the share that held its
    joint limits, the UR5's plans beside the arm's own."""
    import matplotlib.pyplot as plt

    from judgeopt.files import save_figure

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.2), sharey=True)
    labels = [f"{r['robot']}\n{r['qdot_max']:g} m/s" for r in results]
    x = np.arange(len(results))
    for ax, key, title in zip(axes, ("success", "held"), ("simulated success on the arm", "holds the arm's joint limits")):
        for k, (name, colour) in enumerate((("made for the UR5", "tab:gray"), ("made for the arm", "tab:blue"))):
            values = [list(r["plans"].values())[k] for r in results]
            ax.bar(x + (k - 0.5) * 0.4, [v[key] / max(v["planned"], 1) for v in values], 0.4, label=name, color=colour)
        ax.set_xticks(x, labels, fontsize=7)
        ax.set_title(title, fontsize=9)
    axes[0].set_ylabel("share of plans")
    axes[0].legend(fontsize=7, loc="lower left")
    save_figure(fig, path, dpi=110)


if __name__ == "__main__":
    main()
