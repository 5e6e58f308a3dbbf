"""A fast start: building the command line's parsers and printing every help (`judgeopt --help`,
`judgeopt solve --help`, ...) imports none of the heavy libraries (torch alone takes seconds to
import). Checked in a fresh process, whose sys.modules says what was imported, not by a clock."""

from __future__ import annotations

import json
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


def test_a_second_solve_imports_no_torch_and_plans_the_same():
    """Once a run has left the judge's library record and the generator's weights copy (the first
    builds them, judge.compiled), `solve --no-simulate` runs without torch's Python package: the same
    plans, verdicts and table, the amortised plan's judge p computed by the library the direct solve
    constrains (float32 inside l4casadi, as the direct solve's own p)."""
    args = ["solve", "--qdot-max", "0.4", "--no-simulate"]
    first = subprocess.run([sys.executable, "-m", "judgeopt", *args, "--json"], capture_output=True, text=True)
    assert first.returncode == 0, first.stderr
    second = subprocess.run([sys.executable, "-c", NO_TORCH, *args, "--json"], capture_output=True, text=True)
    assert second.returncode == 0, second.stderr[-2000:]
    a, b = json.loads(first.stdout), json.loads(second.stdout)
    assert (a["verdict"], a["recommended"]) == (b["verdict"], b["recommended"])
    for ra, rb in zip(a["results"], b["results"], strict=True):
        assert (ra["method"], ra["status"], ra["iterations"], ra["verdict"]) == \
            (rb["method"], rb["status"], rb["iterations"], rb["verdict"])
        for k in ("y", "ydot", "f"):
            assert ra[k] == rb[k], (ra["method"], k)  # the generator's numpy rollout, the same solve
        assert abs(ra["predicted_success"] - rb["predicted_success"]) < 1e-6
    table = subprocess.run([sys.executable, "-c", NO_TORCH, *args], capture_output=True, text=True)
    assert table.returncode == 0, table.stderr[-2000:]
    assert "method     judge  success p" in table.stdout and "direct plan (every 5th" in table.stdout
