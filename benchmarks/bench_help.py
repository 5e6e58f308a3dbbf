"""How fast `judgeopt --help` answers: the wall time of a fresh process printing the help of the
main command and of each subcommand, the median of --runs runs each, beside a fresh process
that only starts Python and one that only imports numpy (what the options' defaults need).

    python benchmarks/bench_help.py [--runs 5] [--commands solve train-judge] [--before DIR]

--before DIR: the same on the judgeopt in DIR as well (an earlier commit's tree, e.g.
`git worktree add /tmp/before REV`), before and after in one run on the same machine. The CPU
time of each process (user + system) is printed beside its wall time: on a shared machine the
wall time also counts the waits for a core, the CPU time does not. Each process may write and
read Python's bytecode cache (PYTHONDONTWRITEBYTECODE is dropped; one unmeasured run fills it), as
an installed package has it: without the cache every module is compiled again, about 0.15 s.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import time

FLOORS = {"python": "pass", "numpy": "import numpy"}


def timed(cmd: list[str], code: str | None = None) -> tuple[float, float]:
    """(wall, CPU) seconds of one fresh process running `cmd` (on the judgeopt in `code` if given)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    if code:
        env["PYTHONPATH"] = code
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=code)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode not in (0, 4):  # 4: a plan unlikely to succeed is still an answer
        raise SystemExit(f"{' '.join(cmd)} failed: {res.stderr.strip()[-500:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def median_of(cmd: list[str], runs: int, code: str | None = None) -> tuple[float, float]:
    """Median wall and median CPU seconds over `runs` fresh processes (after one that fills the
    bytecode cache)."""
    timed(cmd, code)
    times = [timed(cmd, code) for _ in range(runs)]
    return statistics.median(t[0] for t in times), statistics.median(t[1] for t in times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5, help="fresh processes per figure (the median is printed)")
    ap.add_argument("--commands", nargs="*", default=["solve", "train-judge", "evaluate", "import-demos"],
                    help="subcommands whose --help is timed besides the main command's")
    ap.add_argument("--before", metavar="DIR", help="also time the judgeopt in DIR (an earlier commit's tree)")
    args = ap.parse_args()
    trees = [("", None)] + ([("before: ", os.path.abspath(args.before))] if args.before else [])
    print(f"median of {args.runs} fresh processes, wall s (CPU s)")
    for name, code in FLOORS.items():
        w, c = median_of([sys.executable, "-c", code], args.runs)
        print(f"  {'a process importing ' + name if code != 'pass' else 'python alone':<44} {w:.2f} ({c:.2f})")
    for label, code in trees:
        for command in [[], *([c] for c in args.commands)]:
            w, c = median_of([sys.executable, "-m", "judgeopt.cli", *command, "--help"], args.runs, code)
            print(f"  {label + 'judgeopt ' + ' '.join([*command, '--help']):<44} {w:.2f} ({c:.2f})")


if __name__ == "__main__":
    main()
