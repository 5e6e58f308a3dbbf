"""Every judgeopt error carries its exit code (judgeopt.errors), and the command line returns it:
the codes each error gave when cli/main.py listed them by class must not change."""

from __future__ import annotations

import ast
import builtins
import importlib

import pytest

from judgeopt.errors import EXIT_MEANINGS, ExitCode, JudgeoptError
from judgeopt.files import PACKAGE

#: error class -> the exit code it is documented (docs/cli.md) to give
TABLE: dict[str, ExitCode] = {
    "judgeopt.cli.common.CLIError": ExitCode.USAGE,
    "judgeopt.tasks.base.TaskError": ExitCode.USAGE,
    "judgeopt.tasks.base.EnvironmentRangeError": ExitCode.USAGE,
    "judgeopt.planners.problem.ProblemError": ExitCode.USAGE,
    "judgeopt.planners.constraints.ConstraintError": ExitCode.USAGE,
    "judgeopt.planners.problem.InfeasibleProblemError": ExitCode.INFEASIBLE,
    "judgeopt.planners.problem.ProblemFileError": ExitCode.BAD_INPUT,
    "judgeopt.planners.store.GeneratorFileError": ExitCode.BAD_INPUT,
    "judgeopt.verdict.calibration.CalibrationError": ExitCode.BAD_INPUT,
    "judgeopt.evaluate.stored.StoredRowsError": ExitCode.BAD_INPUT,
    "judgeopt.planners.trust_region.TrustRegionError": ExitCode.BAD_INPUT,
    "judgeopt.data.dataset.DatasetError": ExitCode.BAD_INPUT,
    "judgeopt.data.recording.ImportError_": ExitCode.BAD_INPUT,
    "judgeopt.trajectory.PlanError": ExitCode.BAD_INPUT,
    "judgeopt.formats.plan.PlanFileError": ExitCode.BAD_INPUT,
    "judgeopt.formats.mcap.RosExportError": ExitCode.BAD_INPUT,
    "judgeopt.formats.model_files.ModelFileError": ExitCode.BAD_INPUT,
    "judgeopt.formats.frame.FrameError": ExitCode.BAD_INPUT,
    "judgeopt.formats.table_csv.TableError": ExitCode.BAD_INPUT,
    "judgeopt.judge.errors.JudgeError": ExitCode.BAD_INPUT,
    "judgeopt.judge.errors.TrajectoryError": ExitCode.BAD_INPUT,
    "judgeopt.judge.store.JudgeFileError": ExitCode.BAD_INPUT,
    "judgeopt.judge.store.IncompatibleJudgeError": ExitCode.BAD_INPUT,
    "judgeopt.sim.chain.UnsupportedModel": ExitCode.BAD_INPUT,
    "judgeopt.files.OverwriteError": ExitCode.EXISTS,
    "judgeopt.files.OutputWriteError": ExitCode.BAD_INPUT,
    "judgeopt.judge.casadi_fn.CasadiBuildError": ExitCode.MISSING,
    "judgeopt.sim.robot.RobotDescriptionError": ExitCode.MISSING,
    "judgeopt.robots.spec.RobotError": ExitCode.BAD_INPUT,
    "judgeopt.cbuild.CompileError": ExitCode.MISSING,
    "judgeopt.serve.client.ServiceError": ExitCode.MISSING,
    "judgeopt.serve.request.InfeasibleRequest": ExitCode.INFEASIBLE,
}
#: the bases each class kept, so that `except ValueError` (and the like) still catches it
KEPT = {"ValueError": ValueError, "RuntimeError": RuntimeError, "FileExistsError": FileExistsError, "OSError": OSError}


def _load(dotted: str) -> type:
    module, name = dotted.rsplit(".", 1)
    return getattr(importlib.import_module(module), name)


def _error(cls: type) -> BaseException:
    try:
        return cls("the message naming the fix")
    except TypeError:  # InfeasibleProblemError also names the conflicting limits
        return cls("the message naming the fix", ["q_max"])


def _error_classes() -> set[str]:
    """Every exception class defined in the package, found by reading the source (a class whose
    base is a builtin exception or one of these); warnings are not errors."""
    builtin = {n for n in dir(builtins) if isinstance(getattr(builtins, n), type)
               and issubclass(getattr(builtins, n), BaseException) and not issubclass(getattr(builtins, n), Warning)}
    classes: dict[str, tuple[str, set[str]]] = {}
    for path in PACKAGE.rglob("*.py"):
        module = ".".join(("judgeopt", *path.relative_to(PACKAGE).with_suffix("").parts)).removesuffix(".__init__")
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef):
                bases = {b.id if isinstance(b, ast.Name) else b.attr for b in node.bases
                         if isinstance(b, (ast.Name, ast.Attribute))}
                classes[f"{module}.{node.name}"] = (node.name, bases)
    found: set[str] = set()
    names = set(builtin)
    while True:
        more = {dotted for dotted, (name, bases) in classes.items() if bases & names and dotted not in found}
        if not more:
            return {d for d in found if d.rsplit(".", 1)[0] != "judgeopt.errors"}
        found |= more
        names |= {classes[d][0] for d in more}


@pytest.mark.parametrize("dotted, code", TABLE.items())
def test_each_error_gives_its_documented_exit_code_through_the_cli(dotted, code, monkeypatch, capsys):
    cli = importlib.import_module("judgeopt.cli.main")  # judgeopt.cli.main is also the function

    cls = _load(dotted)
    assert issubclass(cls, JudgeoptError) and code in EXIT_MEANINGS

    def raises(args):
        raise _error(cls)

    monkeypatch.setattr(cli, "cmd_tasks", raises)
    assert cli.main(["tasks"]) == code
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["judgeopt tasks: error: the message naming the fix"]


@pytest.mark.parametrize("dotted", sorted(TABLE))
def test_errors_keep_their_other_bases(dotted):
    cls = _load(dotted)
    assert cls is _load("judgeopt.cli.common.CLIError") or any(issubclass(cls, b) for b in KEPT.values())


def test_every_error_class_in_the_package_derives_from_the_base_and_is_in_the_table():
    found = _error_classes()
    assert found == set(TABLE), "an error class was added or removed: give it a kind from judgeopt.errors " \
                                "and a row in TABLE"
    for dotted in found:
        assert issubclass(_load(dotted), JudgeoptError), dotted


def test_an_error_given_its_own_code_keeps_it():
    from judgeopt.cli.common import CLIError

    assert CLIError("x", ExitCode.BAD_INPUT).exit_code == ExitCode.BAD_INPUT == CLIError("x", ExitCode.BAD_INPUT).code


def test_a_bug_is_no_error_of_judgeopt_and_shows_its_traceback(monkeypatch):
    cli = importlib.import_module("judgeopt.cli.main")  # judgeopt.cli.main is also the function

    def raises(args):
        raise KeyError("a bug")

    monkeypatch.setattr(cli, "cmd_tasks", raises)
    with pytest.raises(KeyError):
        cli.main(["tasks"])
