"""One command line: the same option means the same thing everywhere, every help shows its
defaults, errors carry documented exit codes (as JSON under --json), inspect reads every file."""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys

import pytest

from judgeopt.cli import main
from judgeopt.cli.common import EXIT_MEANINGS, ExitCode
from judgeopt.cli.main import build_parser
from judgeopt.files import REPO

#: what a command that made a plan returns, likely or not (exit 4: none likely)
PLANNED = (ExitCode.OK, ExitCode.UNLIKELY)


def subcommands() -> dict[str, argparse.ArgumentParser]:
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


def visible(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    return [a for a in parser._actions if a.option_strings and a.help is not argparse.SUPPRESS
            and not isinstance(a, argparse._HelpAction)]


def test_every_option_says_what_it_is_and_its_default():
    for name, parser in subcommands().items():
        text = " ".join(parser.format_help().split())
        for a in visible(parser):
            assert a.help, f"{name} {a.option_strings[0]} has no help"
            if not (a.default is None or a.default is False or a.default == []):
                shown = a.help if "%(default)" not in a.help else a.help % {"default": a.default}
                assert "default" in shown.lower() or f"(default: {a.default})" in text, \
                    f"{name} {a.option_strings[0]}: default {a.default!r} not shown"


def test_the_same_option_means_the_same_thing_everywhere():
    for name, parser in subcommands().items():
        opts = {o: a for a in visible(parser) for o in a.option_strings}
        if "--jobs" in opts:
            assert "processes" in opts["--jobs"].help, f"{name} --jobs is not processes"
        if "--threads" in opts:
            assert "threads" in opts["--threads"].help
        assert not ("--judge" in opts and "--judge-model" in opts), f"{name} shows two judge flags"
        if "--out" in opts:
            assert opts["--out"].metavar in ("FILE", "DIR", "STEM"), f"{name} --out is {opts['--out'].metavar}"
        for o, a in opts.items():
            assert a.nargs != 2, f"{name} {o}: ranges are written LO,HI, not LO HI"


def test_help_prints_no_simulator_banner():
    for cmd in ("solve", "collect", "evaluate"):
        r = subprocess.run([sys.executable, "-m", "judgeopt.cli", cmd, "--help"], capture_output=True, text=True)
        assert r.returncode == 0 and r.stdout.startswith("usage: judgeopt " + cmd)
        assert "pybullet build time" not in r.stdout + r.stderr


def test_exit_codes_are_documented_in_the_docs():
    page = (REPO / "docs" / "cli.md").read_text()
    table = page[page.index("## Exit codes"):]
    for code in ExitCode:
        assert re.search(rf"^\| {code.value} \|", table, re.M), f"exit code {code.value} missing from docs/cli.md"
    assert set(EXIT_MEANINGS) == set(ExitCode)


@pytest.mark.parametrize("argv, code", [
    (["solve", "--qdot-max", "fast", "--json"], ExitCode.USAGE),
    (["test-judge", "--data", "nope.h5", "--json"], ExitCode.BAD_INPUT),
    (["inspect", "nope.json", "--json"], ExitCode.BAD_INPUT),
])
def test_json_errors_are_one_object_on_stdout(argv, code, tmp_path):
    r = subprocess.run([sys.executable, "-m", "judgeopt.cli", *argv], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == code
    err = json.loads(r.stdout)
    assert err["exit_code"] == code and err["error"] and "Traceback" not in r.stderr


def test_env_option_is_the_named_shortcut(capsys):
    from judgeopt.cli.planners import problem_from_args

    parser = subcommands()["solve"]
    by_name = problem_from_args(parser.parse_args(["--mu", "2.5", "--y-obj", "0.15"]))
    by_env = problem_from_args(parser.parse_args(["--env", "mu=2.5", "--env", "y_obj=0.15"]))
    assert by_name.environment == by_env.environment and by_env.environment["mu"] == 2.5
    assert main(["solve", "--env", "x_obj=0.1", "--no-simulate"]) == ExitCode.USAGE
    assert "not an environment variable of task 'scoop'" in capsys.readouterr().err


def test_inspect_reads_every_kind_of_file(tmp_path, capsys):
    plan = tmp_path / "plan.json"
    bag = tmp_path / "plan.mcap"
    assert main(["solve", "--no-simulate", "--method", "amortized", "--save-json", str(plan), "--export", str(bag),
                 "--quiet"]) in PLANNED
    evaluation = tmp_path / "evaluation"
    (evaluation / "partial").mkdir(parents=True)
    rows = [{"method": "direct", "setting_description": "direct, judge j", "simulated_success": s} for s in (1, 0, 1)]
    (evaluation / "partial" / "a.json").write_text(json.dumps(rows))
    expected = {"data/test.h5": "dataset", "models/judge_demos_tcn": "judge", "models/generator_paper_sim.pt": "generator",
                "models/judge_ensemble": "ensemble", "models/calibration_default.json": "calibration",
                "models/trust_region_default.json": "trust region", str(plan): "plan", str(bag): "ros bag",
                str(evaluation): "evaluation"}
    capsys.readouterr()
    for path, kind in expected.items():
        assert main(["inspect", path, "--json"]) == 0, path
        info = json.loads(capsys.readouterr().out)
        assert info["kind"] == kind, path
    assert info["settings"][0]["plans"] == 3 and info["settings"][0]["successes"] == 2
    assert main(["inspect", str(bag), "--json"]) == 0
    topics = json.loads(capsys.readouterr().out)["topics"]
    assert topics["/judgeopt/pose"]["messages"] == 1501 and topics["/judgeopt/plan_info"]["messages"] == 1
    (tmp_path / "notes.txt").write_text("hello")
    assert main(["inspect", str(tmp_path / "notes.txt")]) == ExitCode.BAD_INPUT
    assert "a file inspect does not read" in capsys.readouterr().err
    other = tmp_path / "other.json"
    other.write_text('{"format": "something-else"}')
    assert main(["inspect", str(other)]) == ExitCode.BAD_INPUT
    assert "not a file judgeopt writes" in capsys.readouterr().err


def test_a_missing_optional_dependency_names_its_extra(tmp_path):
    code = ("import sys; sys.modules['pybullet'] = None\n"
            "from judgeopt.cli import main; sys.exit(main(['solve', '--qdot-max', '0.4', '--method', 'amortized']))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == ExitCode.MISSING
    assert "pip install 'judgeopt[sim]'" in r.stderr and "Traceback" not in r.stderr
