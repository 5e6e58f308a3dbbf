"""How fast a one-shot command answers: `judgeopt --help` and `judgeopt solve --qdot-max 0.4
--no-simulate`, each the median of --runs fresh processes, and `judgeopt serve --workers 1` until
/v1/ready (its worker has loaded the models and planned once), idle and with every core busy, side
by side, beside fresh processes that only do what the solve cannot avoid (start Python; import numpy
and casadi; load libtorch, which the judge's l4casadi library links; import torch's Python package,
which the fast start avoids).

    python benchmarks/bench_start.py [--runs 5] [--before DIR] [--no-busy] [--no-serve]

The solve runs once unmeasured first (per tree): the first run builds what a fast start reads (the
judge library's record and the generator's numpy weights, judgeopt.judge.compiled), the second is
the figure. --before DIR: the same commands on the judgeopt in DIR as well (an earlier commit's
tree, e.g. `git archive REV | tar -x -C DIR`), on the same machine in the same run. Each process may
write and read Python's bytecode cache (PYTHONDONTWRITEBYTECODE is dropped), as an installed package
has it. CPU seconds (user + system) are printed beside the wall time: under load the wall time also
counts the waits for a core.
"""

from __future__ import annotations

import argparse
import os
import select
import signal
import statistics
import subprocess
import sys
import time
from pathlib import Path

from bench_help import timed
from busy import Load

REPO = Path(__file__).resolve().parents[1]

COMMANDS = {"judgeopt --help": ["--help"],
            "judgeopt solve --qdot-max 0.4 --no-simulate": ["solve", "--qdot-max", "0.4", "--no-simulate"]}
FLOORS = {"python alone": "pass", "import numpy, casadi": "import numpy, casadi",
          "load libtorch (ctypes)": "import ctypes, importlib.metadata as m; "
          "ctypes.CDLL(str(m.distribution('torch').locate_file('torch/lib/libtorch_cpu.so')))",
          "import torch": "import torch"}


def serve_ready(code: str) -> float:
    """Seconds from starting `judgeopt serve --port 0 --workers 1` (the judgeopt in `code`) until
    /v1/ready answers 200; the server is stopped after."""
    from urllib.error import URLError
    from urllib.request import urlopen

    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"} | {"PYTHONPATH": code}
    t0 = time.perf_counter()
    server = subprocess.Popen([sys.executable, "-m", "judgeopt.cli", "serve", "--port", "0", "--workers", "1"],
                              cwd=code, env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        if not select.select([server.stdout], [], [], 60)[0]:
            raise SystemExit("the server did not start")
        url = server.stdout.readline().split("listening on ")[1].split()[0]
        while time.perf_counter() - t0 < 120:
            try:
                with urlopen(f"{url}/v1/ready", timeout=5) as answer:
                    if answer.status == 200:
                        return time.perf_counter() - t0
            except (URLError, OSError):
                pass
            time.sleep(0.02)
        raise SystemExit("the server did not get ready")
    finally:
        server.send_signal(signal.SIGTERM)
        server.wait(60)


def median_of(cmd: list[str] | None, runs: int, code: str | None = None) -> str:
    """Median wall and CPU seconds over `runs` fresh processes, as "wall (CPU)"; `cmd` None: the
    service's start until ready (wall only)."""
    if cmd is None:
        return f"{statistics.median(serve_ready(code or str(REPO)) for _ in range(runs)):.2f}"
    times = [timed(cmd, code) for _ in range(runs)]
    return f"{statistics.median(t[0] for t in times):.2f} ({statistics.median(t[1] for t in times):.2f})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5, help="fresh processes per figure (the median is printed)")
    ap.add_argument("--before", metavar="DIR", help="also time the judgeopt in DIR (an earlier commit's tree)")
    ap.add_argument("--no-busy", action="store_true", help="time idle only")
    ap.add_argument("--no-serve", action="store_true", help="leave out the service's start (needs judgeopt[serve])")
    args = ap.parse_args()
    trees = [("", str(REPO))] + ([("before: ", os.path.abspath(args.before))] if args.before else [])
    rows: list[tuple[str, list[str] | None, str | None]] = []
    for label, code in trees:
        for name, argv in COMMANDS.items():
            cmd = [sys.executable, "-m", "judgeopt.cli", *argv]
            timed(cmd, code)  # fills the bytecode cache, and for solve what a fast start reads
            rows.append((label + name, cmd, code))
        if not args.no_serve:
            rows.append((label + "judgeopt serve --workers 1, until ready (wall)", None, code))
    rows += [(name, [sys.executable, "-c", snippet], None) for name, snippet in FLOORS.items()]
    load = Load(not args.no_busy)
    idle = [median_of(cmd, args.runs, code) for _, cmd, code in rows]
    busy = []
    if load.procs:
        with load.busy():
            busy = [median_of(cmd, args.runs, code) for _, cmd, code in rows]
    load.close()
    print(f"median of {args.runs} fresh processes, wall s (CPU s); {os.cpu_count()} cores")
    print(f"  {'':<60} {'idle':<13} {'cores busy' if busy else ''}")
    for i, (name, _, _) in enumerate(rows):
        print(f"  {name:<60} {idle[i]:<13} {busy[i] if busy else ''}")


if __name__ == "__main__":
    main()
