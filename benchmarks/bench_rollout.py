"""Simulation speed, measured side by side in one run.

1. Closed-loop rollout rate (controller + physics, 1 ms steps) against bare physics stepping of
   the same scene: the torques the controller produced are replayed open-loop, so the physics
   sees the same contacts. Target: ratio >= 0.5 (the controller costs no more than the physics).
2. Demonstrations per minute of `collect` on all local cores, and the projected time for the
   paper's 10,000 (target: under 15 minutes on a 2-core machine).

    python benchmarks/bench_rollout.py [--rollouts 20] [--demos 60] [--jobs -1]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import numpy as np

from judgeopt.data.collect import CollectionSpec, collect
from judgeopt.tasks.scoop.commands import random_command
from judgeopt.sim.quiet import pb
from judgeopt.tasks.scoop.rollout import Simulator


def rollout_rates(n: int) -> tuple[float, float]:
    sim = Simulator()
    sc = sim.scene
    rng = np.random.default_rng(0)
    plans = [random_command(rng, 0.19) for _ in range(n)]
    torques: list[list[np.ndarray]] = []
    original = sim.controller.step

    def recording(q, ft, cmd):
        tau = original(q, ft, cmd)
        torques[-1].append(tau)
        return tau

    sim.controller.step = recording
    steps = 0
    t0 = time.perf_counter()
    for p in plans:
        torques.append([])
        sim.run(p, 0.19, 2.0)
        steps += len(torques[-1])
    closed = steps / (time.perf_counter() - t0)
    sim.controller.step = original

    t0 = time.perf_counter()
    for p, seq in zip(plans, torques):
        sim.reset(float(p.y[0]), 0.19, 2.0)
        for tau in seq:
            pb.setJointMotorControlArray(sc.robot, sc.arm_joints, pb.TORQUE_CONTROL, forces=tau, physicsClientId=sc.client)
            pb.stepSimulation(physicsClientId=sc.client)
    bare = steps / (time.perf_counter() - t0)
    return closed, bare


def demos_per_minute(n: int, jobs: int) -> float:
    with tempfile.TemporaryDirectory() as d:
        collect(CollectionSpec(seed=123, n=n), os.path.join(d, "bench.h5"), n_jobs=1, progress=False)  # warm caches
        t0 = time.perf_counter()
        collect(CollectionSpec(seed=124, n=n), os.path.join(d, "bench2.h5"), n_jobs=jobs, chunk_size=5, progress=False)
        return n / (time.perf_counter() - t0) * 60


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rollouts", type=int, default=20)
    ap.add_argument("--demos", type=int, default=60)
    ap.add_argument("--jobs", type=int, default=-1)
    a = ap.parse_args()
    closed, bare = rollout_rates(a.rollouts)
    print(f"closed-loop (controller + physics): {closed:8.0f} steps/s")
    print(f"bare physics, same scene          : {bare:8.0f} steps/s")
    print(f"ratio closed/bare                 : {closed / bare:8.2f}   (target >= 0.5)")
    rate = demos_per_minute(a.demos, a.jobs)
    cores = os.cpu_count()
    print(f"collection on {cores} cores         : {rate:8.1f} demonstrations/min")
    print(f"projected 10,000 demonstrations   : {10000 / rate:8.1f} min   (target < 15 min on 2 cores)")


if __name__ == "__main__":
    main()
