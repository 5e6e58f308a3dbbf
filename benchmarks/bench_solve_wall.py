"""The main command's wall time as a user meets it, against what it cannot avoid, in one run.

Runs `judgeopt solve --qdot-max 0.4` (both planners, both plans replayed) --runs times, each a
fresh process (the first run also builds what is cached: the second is the figure), and beside it
fresh processes that only import what the command must: Python itself, torch (the judge and the
generator are torch modules), casadi (Ipopt), pybullet and pinocchio (the replay). Then one run
profiled by phase inside the process: imports, loading the models, planning, simulating.

    python benchmarks/bench_solve_wall.py [--runs 3] [--busy]

--busy spins every core with another process while timing, as on a robot's computer.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time

from busy import Load

COMMAND = ["solve", "--qdot-max", "0.4"]
FLOORS = {"python": "pass", "torch": "import torch", "casadi + numpy": "import casadi, numpy",
          "pybullet + pinocchio": "import pybullet, pinocchio",
          "all four": "import torch, casadi, numpy, pybullet, pinocchio"}


def wall(args: list[str]) -> float:
    t0 = time.perf_counter()
    subprocess.run(args, capture_output=True, check=False)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--busy", action="store_true")
    args = ap.parse_args()
    load = Load(args.busy)
    cli = [sys.executable, "-m", "judgeopt.cli", *COMMAND]
    with load.busy():
        runs = [wall(cli) for _ in range(args.runs)]
        floors = {name: statistics.median(wall([sys.executable, "-c", code]) for _ in range(args.runs))
                  for name, code in FLOORS.items()}
        profile = subprocess.run([sys.executable, "-X", "importtime", *cli[1:]], capture_output=True, text=True)
    load.close()
    imports = sum(int(line.split("|")[0].split(":")[1]) for line in profile.stderr.splitlines()
                  if line.startswith("import time:") and line.split("|")[0].split(":")[1].strip().isdigit())
    print(f"`judgeopt {' '.join(COMMAND)}`, {'cores busy' if load.procs else 'idle'}: wall per run "
          + ", ".join(f"{t:.2f}" for t in runs) + f" s (second run {runs[min(1, len(runs) - 1)]:.2f} s)")
    print(f"  of which imports (python -X importtime, all modules): {imports / 1e6:.2f} s")
    for name, t in floors.items():
        print(f"  a fresh process importing {name:<22} {t:.2f} s")


if __name__ == "__main__":
    main()
