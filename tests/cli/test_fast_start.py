"""A fast start: building the command line's parsers and printing every help (`judgeopt --help`,
`judgeopt solve --help`, ...) imports none of the heavy libraries (torch alone takes seconds to
import). Checked in a fresh process, whose sys.modules says what was imported, not by a clock."""

from __future__ import annotations

import json
import re
import subprocess
import sys

from judgeopt.cli.main import build_parser

HEAVY = ("torch", "casadi", "pybullet", "scipy", "matplotlib")

#: in a fresh process: every parser built, every help printed through main(), then what was imported
CODE = """
import argparse, contextlib, io, json, sys
from judgeopt.cli.main import build_parser, main

def walk(prefix, parser):
    yield prefix
    for a in parser._actions:
        if isinstance(a, argparse._SubParsersAction):
            for name, p in a.choices.items():
                yield from walk(prefix + [name], p)

paths = list(walk([], build_parser()))
codes = []
for path in paths:
    with contextlib.redirect_stdout(io.StringIO()) as out:
        try:
            main(path + ["--help"])
        except SystemExit as e:
            codes.append(e.code)
    assert "usage: judgeopt" in out.getvalue(), path
print(json.dumps({"paths": paths, "codes": codes, "heavy": sorted(m for m in %r if m in sys.modules)}))
""" % (HEAVY,)


def test_every_help_builds_without_heavy_imports():
    res = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, check=True)
    found = json.loads(res.stdout)
    assert [] in found["paths"] and ["solve"] in found["paths"] and ["train-judge"] in found["paths"]
    assert len(found["paths"]) > 10  # the main command and every subcommand were built
    assert found["codes"] == [0] * len(found["paths"])  # each --help printed and exited cleanly
    assert found["heavy"] == []


def test_the_main_help_imports_not_even_numpy_and_lists_every_command_by_its_line():
    """`judgeopt --help` builds no command's parser (cli.commands lists them): numpy, the tasks and
    the problems stay unimported; the listing is the full parser's, command by command."""
    code = ("import contextlib, io, json, sys\nfrom judgeopt.cli.main import main\n"
            "with contextlib.redirect_stdout(io.StringIO()) as out:\n"
            "    try:\n        main(['--help'])\n    except SystemExit:\n        pass\n"
            "print(json.dumps({'help': out.getvalue(), 'heavy': sorted(m for m in ('numpy', *%r) if m in sys.modules)}))"
            % (HEAVY,))
    found = json.loads(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
    assert found["heavy"] == []
    full = build_parser().format_help()
    assert found["help"] == full  # the same listing, in the same order, as every parser built in full


def test_one_command_is_parsed_as_the_full_parser_parses_it():
    from judgeopt.cli.commands import COMMANDS

    full = next(a for a in build_parser()._actions if a.dest == "command")
    assert list(full.choices) == list(COMMANDS)
    for name in COMMANDS:
        only = next(a for a in build_parser(name)._actions if a.dest == "command")
        assert list(only.choices) == list(COMMANDS)
        assert only.choices[name].format_help() == full.choices[name].format_help(), name


#: judgeopt's command line in a fresh process where importing torch fails (a finder that raises), and
#: an assertion after it that torch was not imported either way
NO_TORCH = """
import sys

from judgeopt.cli.main import build_parser

class NoTorch:
    def find_spec(self, name, path=None, target=None):
        if name == "torch" or name.startswith("torch."):
            raise ImportError(f"{name}: blocked by the fast-start test")
        return None

sys.meta_path.insert(0, NoTorch())
from judgeopt.cli import main
code = main(sys.argv[1:])
assert "torch" not in sys.modules, "torch was imported"
sys.exit(code)
"""


def test_a_second_solve_imports_no_torch_and_answers_as_the_first(tmp_path):
    """In an empty cache the first `solve --no-simulate` builds the judge's library with torch and
    leaves its record and the generator's weights copy (judge.compiled); the second runs without
    torch's Python package (its import fails there) and prints the same object, plans, verdicts and
    every p alike, and the same table."""
    import os

    env = {**os.environ, "JUDGEOPT_CACHE": str(tmp_path / "cache")}
    args = ["solve", "--qdot-max", "0.4", "--no-simulate"]
    runs = [subprocess.run(cmd, capture_output=True, text=True, env=env)
            for cmd in ([sys.executable, "-m", "judgeopt", *args, "--json"], [sys.executable, "-c", NO_TORCH, *args, "--json"],
                        [sys.executable, "-m", "judgeopt", *args], [sys.executable, "-c", NO_TORCH, *args])]
    for r in runs:
        assert r.returncode == 0, r.stderr[-2000:]
    assert "building the judge library" in runs[0].stderr  # the first run built it, in this cache
    first, second = (json.loads(r.stdout) for r in runs[:2])
    for a in (first, second):
        for r in a["results"]:
            r.pop("solve_time_s")
    assert first == second
    assert [r["method"] for r in first["results"]] == ["amortized", "direct"]
    def cells(text: str) -> list[list[str]]:  # the printed lines as cells, the times and the column rules left out
        rows = [re.split(r"\s{2,}", line.strip()) for line in text.splitlines() if not line.startswith("total ")]
        return [[c for c in row if not re.fullmatch(r"[\d.]+ m?s|-+", c)] for row in rows]

    assert cells(runs[2].stdout) == cells(runs[3].stdout) and "method     judge  success p" in runs[3].stdout


#: the process as the command (main() with no argv), an exit handler of its own, and optionally a
#: thread still running when the command is done
AS_COMMAND = """
import atexit, sys, threading
atexit.register(lambda: print("exit handler ran"))
released = threading.Event()
if sys.argv[1] == "thread":  # alive until the command has returned, however long it takes
    threading.Thread(target=lambda: (released.wait(), print("thread finished"))).start()
sys.argv = ["judgeopt", "solve", "--qdot-max", "0.1", "--no-simulate", "--json"]
from judgeopt.cli import main
code = main()
print("main returned", flush=True)
released.set()
sys.exit(code)
"""


def test_a_solve_ends_its_process_with_its_code_its_output_whole_and_its_exit_handlers_run():
    """`judgeopt solve` ends its process itself, skipping the interpreter's teardown (libtorch's
    unload); what a normal exit does first still happens: the exit code is the command's (3, the
    limits are infeasible), block-buffered output reaches the pipe, exit handlers run. With another
    thread still running it returns as before, and the normal exit waits for the thread."""
    alone, thread = (subprocess.run([sys.executable, "-c", AS_COMMAND, case], capture_output=True, text=True)
                     for case in ("alone", "thread"))
    assert alone.returncode == 3 and thread.returncode == 3, (alone.stderr[-2000:], thread.stderr[-2000:])
    answer, _, rest = alone.stdout.rpartition("}")
    assert json.loads(answer + "}")["status"] == "infeasible" and rest.split() == ["exit", "handler", "ran"]
    assert thread.stdout.split("\n")[-4:] == ["main returned", "thread finished", "exit handler ran", ""]
