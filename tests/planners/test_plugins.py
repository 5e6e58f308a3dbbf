"""A planner of one's own, built with the toolkit (judgeopt.planners.toolkit), in a module of the
user's: it reaches `judgeopt solve` through --plugin MODULE and $JUDGEOPT_PLUGINS (imported at run
time, never to build the parser), and a planner whose solve returns no PlanResult is one line
naming it."""

from __future__ import annotations

import json
import sys
import textwrap

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.planners.base import PLUGINS_ENV, REGISTRY, Planner, group, load_plugins, spec_of, unregister
from judgeopt.planners.problem import ProblemError
from judgeopt.planners.toolkit import judge_plans, min_jerk_plan, plan_from_velocities, plan_result
from judgeopt.trajectory import PlanError

PLUGIN = '''
import time
from judgeopt.planners.base import Planner, PlannerSpec, register
from judgeopt.planners.toolkit import min_jerk_plan, plan_result

class Mine(Planner):
    method = "{name}"

    def solve(self, env, guess=None):
        started = time.perf_counter()
        return plan_result(self, env, min_jerk_plan(self.problem, env), started, info={{"mine": True}})

class Nothing(Planner):
    method = "{name}_none"

    def solve(self, env, guess=None):
        return None

register(PlannerSpec("{name}", "the min-jerk move, from a plugin", "{module}:Mine"))
register(PlannerSpec("{name}_none", "forgets to return", "{module}:Nothing"))
'''


@pytest.fixture
def plugin(tmp_path, monkeypatch):
    """A module in the current folder (not on the Python path) that registers two planners; both
    gone afterwards."""
    module, name = f"plugin_{tmp_path.name.replace('-', '_')}", "mine"
    (tmp_path / f"{module}.py").write_text(textwrap.dedent(PLUGIN.format(name=name, module=module)))
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv(PLUGINS_ENV, raising=False)
    yield module, name
    for n in (name, f"{name}_none"):
        unregister(n)
    sys.modules.pop(module, None)


def solved(argv, capsys) -> dict:
    code = main(["solve", "--no-simulate", "--no-suggest", "--json", *argv])
    out = json.loads(capsys.readouterr().out)
    assert code in (0, 4), out
    return out


@pytest.mark.slow
def test_a_plugin_module_reaches_solve_by_option_and_by_environment(plugin, capsys, monkeypatch):
    module, name = plugin
    for argv in (["--plugin", module, "--method", name], ["--method", name, "--plugin", module]):  # either order
        (r,) = solved(argv, capsys)["results"]
        assert r["method"] == name and r["status"] == "solved" and r["mine"] is True and len(r["y"]) == 31
        unregister(name), unregister(f"{name}_none"), sys.modules.pop(module)  # imported anew each time
    monkeypatch.setenv(PLUGINS_ENV, f" {module} ,")
    (r,) = solved(["--method", name], capsys)["results"]
    assert r["method"] == name
    assert name in group("all")  # what `--method all` runs


def test_the_parser_imports_no_plugin_and_a_bad_one_is_one_line(plugin, capsys, monkeypatch):
    from judgeopt.cli.main import build_parser

    module, name = plugin
    monkeypatch.setenv(PLUGINS_ENV, module)
    build_parser().parse_args(["solve", "--method", "direct"])  # a built-in named: nothing imported
    with pytest.raises(SystemExit):
        build_parser().parse_args(["solve", "--help"])
    assert module not in sys.modules and name not in REGISTRY
    assert spec_of(name).name == name  # imported where a planner not registered yet is asked for (a worker)

    monkeypatch.setenv(PLUGINS_ENV, "no_such_module_here")
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:  # named a planner not registered: the plugins are imported, and fail
        build_parser().parse_args(["solve", "--method", "nowhere"])
    assert exc.value.code == 2
    assert main(["solve", "--plugin", "no_such_module_here", "--method", "direct", "--no-simulate"]) == 2
    for err in capsys.readouterr().err.strip().splitlines():  # one line each
        assert "plugin 'no_such_module_here' does not import (ModuleNotFoundError: No module named" in err


def test_a_plugin_whose_registration_fails_names_the_module(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "taken_name_plugin.py").write_text(
        "from judgeopt.planners.base import PlannerSpec, register\nregister(PlannerSpec('direct', 'x', 'm:C'))\n")
    with pytest.raises(ProblemError, match=r"^plugin taken_name_plugin: planner name 'direct' is taken"):
        load_plugins(["taken_name_plugin"])
    sys.modules.pop("taken_name_plugin", None)


@pytest.mark.slow
def test_a_solve_that_returns_none_is_one_line_naming_the_planner(plugin, capsys):
    module, name = plugin
    assert main(["solve", "--no-simulate", "--plugin", module, "--method", f"{name}_none"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (f"judgeopt solve: error: planner '{name}_none': Nothing.solve returned NoneType; it must return a "
                   "PlanResult, e.g. judgeopt.planners.toolkit.plan_result(self, env, plan, started)")


# -- the toolkit, against figures worked out by hand -------------------------------------
@pytest.fixture(scope="module")
def problem():
    import judgeopt

    return judgeopt.load_problem("paper_sim", qdot_max=0.4)


class _Judged(Planner):
    method = "judged"

    def solve(self, env, guess=None):
        raise NotImplementedError


class _ConstantJudge:
    """p = 0.25 + 0.01 * (its call's row): the toolkit must hand it the plan and the environment in its order."""

    class config:
        env_names = ("mu", "y_obj")

    def predict_proba(self, x, e):
        self.seen = (np.asarray(x), np.asarray(e))
        return 0.25 + 0.01 * np.arange(len(x))


def test_plan_from_velocities_integrates_from_the_start_and_broadcasts_forces(problem):
    n, dt, q0 = problem.steps, problem.dt, problem.vec("q0")[0]
    plan = plan_from_velocities(problem, np.full(n + 1, 0.1), 12.0)
    assert np.allclose(plan.y, q0 + 0.1 * dt * np.arange(n + 1))  # constant velocity: q0 + v t
    assert np.allclose(plan.ydot, 0.1) and np.allclose(plan.f, 12.0)
    ramp = np.linspace(0, 0.2, n + 1)  # v = a t: q = q0 + a t^2 / 2 (the trapezoid is exact for it)
    assert np.allclose(plan_from_velocities(problem, ramp, np.arange(n + 1.0)).y, q0 + 0.5 * 0.2 / (n * dt) * plan.t ** 2)
    with pytest.raises(PlanError, match=rf"give \({n + 1},\) or \({n + 1}, 1\)"):
        plan_from_velocities(problem, np.zeros(n), 12.0)
    with pytest.raises(PlanError, match="forces of shape"):
        plan_from_velocities(problem, np.zeros(n + 1), [1.0, 2.0, 3.0])


def test_plan_result_judges_and_measures_the_plan(problem):
    judge = _ConstantJudge()
    planner = _Judged(problem, judge)
    env = {"y_obj": 0.2, "mu": 2.5}
    n = problem.steps
    v = np.zeros(n + 1)
    v[10:20] = problem.vec("qdot_max")[0] + 0.1  # 0.1 m/s over the limit; ends far from q_end
    r = plan_result(planner, env, plan_from_velocities(problem, v, problem.vec("f_max") + 2.0), started=0.0)
    assert r.method == "judged" and r.status == "solved" and r.predicted_success == 0.25
    assert judge.seen[1].tolist() == [[2.5, 0.2]]  # the judge's order, not the environment's
    assert r.residuals["qdot_max"] == pytest.approx(0.1) and r.residuals["f_max"] == pytest.approx(2.0)
    assert r.residuals["dynamics"] == pytest.approx(0.0, abs=1e-12) and r.solve_time_s > 0
    assert list(judge_plans(judge, [r.plan, r.plan], env)) == [0.25, 0.26]
    none = plan_result(planner, env, None, started=0.0, message="no move found")
    assert (none.plan, none.status, none.predicted_success, none.message) == (None, "failed", None, "no move found")
    move = min_jerk_plan(problem, env)
    with pytest.raises(PlanError, match="not of the problem's channels"):
        plan_result(planner, env, type(move)(move.dt, move.values[:10], move.channels), started=0.0)
    with pytest.raises(ProblemError, match="the judge reads y_obj"):
        judge_plans(judge, [move], {"mu": 1.0})


def test_every_command_that_plans_takes_plugin_and_hands_it_to_its_workers(plugin, monkeypatch):
    """evaluate, calibrate and refine take --plugin as solve does, and name the module in
    $JUDGEOPT_PLUGINS for the worker processes they start (which import it when they meet its planner)."""
    import os

    from judgeopt.cli import evaluate, refine

    module, name = plugin
    monkeypatch.setenv(PLUGINS_ENV, "")
    seen = {}
    for mod, cmd in ((evaluate, "cmd_evaluate"), (evaluate, "cmd_calibrate"), (refine, "cmd_refine")):
        monkeypatch.setattr(mod, cmd, lambda args, cmd=cmd: seen.setdefault(cmd, (args.methods, os.environ[PLUGINS_ENV]))
                            and 0)
    assert main(["evaluate", "planners", "--plugin", module, "--methods", name, "direct"]) == 0
    assert main(["calibrate", "somewhere", "--plugin", module, "--methods", name]) == 0
    assert main(["refine", "--methods", name, "--plugin", module]) == 0
    # the module named once in the environment the command's workers inherit, and only while it runs
    assert seen == {"cmd_evaluate": ([name, "direct"], module), "cmd_calibrate": ([name], module),
                    "cmd_refine": ([name], module)}
    assert os.environ[PLUGINS_ENV] == ""
