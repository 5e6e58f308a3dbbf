"""A fast start: building the command line's parsers and printing every help (`judgeopt --help`,
`judgeopt solve --help`, ...) imports none of the heavy libraries (torch alone takes seconds to
import). Checked in a fresh process, whose sys.modules says what was imported, not by a clock."""

from __future__ import annotations

import json
import subprocess
import sys

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
