"""Simulation speed, measured side by side in one run.

1. Closed-loop rollout rate (controller + physics, 1 ms steps) against bare physics stepping of
   the same scene: the torques the controller produced are replayed open-loop (as lists, the
   cheapest way to hand them to PyBullet), so the physics sees the same contacts; each rollout
   is timed both ways in turn, the fastest of 3 repeats counting. Target (issue
   20): ratio >= 0.8, i.e. the controller's step costs at most a quarter of the physics step.
2. Demonstrations per minute of `collect` on all local cores, once its worker processes are
   up (a first, untimed collection with the same --jobs starts them and builds their scenes),
   and the projected time for the paper's 10,000 (target: under 10 minutes on a 2-core machine).
3. With --focus JUDGE: the same for an active collection (`collect --focus`), timed right after
   the plain one: what judging the candidates adds per kept demonstration.

    python benchmarks/bench_rollout.py [--rollouts 20] [--demos 60] [--jobs -1] [--focus models/judge_demos_tcn] [--robot ur5]

Timings on a shared machine are noisy: compare the ratio, measured side by side, across runs.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np

from judgeopt.data.collect import CollectionSpec, collect
from judgeopt.judge.focus import JudgeFocus
from judgeopt.tasks.scoop.commands import random_command
from judgeopt.sim.quiet import pb
from judgeopt.robots import DEFAULT_ROBOT
from judgeopt.tasks.scoop.rollout import Simulator
from judgeopt.tasks.scoop.scene import SceneConfig


def rollout_rates(n: int, repeats: int = 3, robot: str = DEFAULT_ROBOT) -> tuple[float, float]:
    """Steps per second closed loop and bare physics (replaying the closed loop's torques),
    timed rollout by rollout in turn, so both see the same load on a shared machine; the
    fastest of `repeats` timings of each rollout counts. On the arm `robot`: a 7-joint arm's
    step solves for its null space as well."""
    sim = Simulator(SceneConfig(robot=robot))
    rng = np.random.default_rng(0)
    plans = [random_command(rng, 0.19) for _ in range(n)]
    torques = recorded_torques(sim, plans)  # rollouts are deterministic: the timed ones give the same
    closed, bare = np.full(n, np.inf), np.full(n, np.inf)
    for _ in range(repeats):
        for i, (p, seq) in enumerate(zip(plans, torques)):
            t0 = time.perf_counter()
            sim.run(p, 0.19, 2.0)
            closed[i] = min(closed[i], time.perf_counter() - t0)
            t0 = time.perf_counter()
            replay(sim, p, seq)
            bare[i] = min(bare[i], time.perf_counter() - t0)
    steps = sum(len(seq) for seq in torques)
    return steps / closed.sum(), steps / bare.sum()


def replay(sim: Simulator, plan, torques: list[list[float]]) -> None:
    """The physics alone: the rollout's reset, then its torques applied open loop."""
    sc = sim.scene
    sim.reset(float(plan.y[0]), 0.19, 2.0)
    for tau in torques:
        pb.setJointMotorControlArray(sc.robot, sc.arm_joints, pb.TORQUE_CONTROL, forces=tau, physicsClientId=sc.client)
        pb.stepSimulation(physicsClientId=sc.client)


def recorded_torques(sim: Simulator, plans: list) -> list[list[list[float]]]:
    """The torques of each plan's closed-loop rollout, step by step (a second, untimed run), as
    the arm driver hands them to PyBullet (whichever control step computed them)."""
    from judgeopt.sim import arm

    torques: list[list[list[float]]] = []
    original = arm._set_joint_motors

    def recording(*args, forces, **kwargs):
        torques[-1].append(list(forces))
        return original(*args, forces=forces, **kwargs)

    arm._set_joint_motors = recording
    try:
        for p in plans:
            torques.append([])
            sim.run(p, 0.19, 2.0)
    finally:
        arm._set_joint_motors = original
    return torques


def demos_per_minute(n: int, jobs: int, focus: JudgeFocus | None = None) -> float:
    with tempfile.TemporaryDirectory() as d:
        # warm up: the workers (kept by joblib between calls) import everything and build their scenes
        collect(CollectionSpec(seed=123, n=n, focus=focus), os.path.join(d, "bench.h5"), n_jobs=jobs, chunk_size=5,
                progress=False)
        t0 = time.perf_counter()
        collect(CollectionSpec(seed=124, n=n, focus=focus), os.path.join(d, "bench2.h5"), n_jobs=jobs, chunk_size=5,
                progress=False)
        return n / (time.perf_counter() - t0) * 60


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rollouts", type=int, default=20)
    ap.add_argument("--demos", type=int, default=60, help="0: skip the collection benchmark")
    ap.add_argument("--jobs", type=int, default=-1)
    ap.add_argument("--focus", metavar="JUDGE", help="also time an active collection focused by this judge")
    ap.add_argument("--robot", default=DEFAULT_ROBOT, help="the arm of the rollout-rate benchmark (`judgeopt robots`)")
    a = ap.parse_args()
    closed, bare = rollout_rates(a.rollouts, robot=a.robot)
    print(f"closed-loop (controller + physics): {closed:8.0f} steps/s")
    print(f"bare physics, same scene          : {bare:8.0f} steps/s")
    print(f"ratio closed/bare                 : {closed / bare:8.2f}   (target >= 0.8)")
    if a.demos <= 0:
        return
    rate = demos_per_minute(a.demos, a.jobs)
    cores = os.cpu_count()
    print(f"collection on {cores} cores         : {rate:8.1f} demonstrations/min")
    print(f"projected 10,000 demonstrations   : {10000 / rate:8.1f} min   (target < 10 min on 2 cores)")
    if a.focus:
        focused = demos_per_minute(a.demos, a.jobs, JudgeFocus.of(a.focus))
        print(f"focused on {a.focus}: {focused:8.1f} demonstrations/min, {focused / rate:.2f} x the plain rate")


if __name__ == "__main__":
    main()
