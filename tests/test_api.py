"""`import judgeopt`: the top-level API loads problems by shipped name, plans, simulates and
judges without deep imports, and stays light until used."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import judgeopt
from judgeopt.planners.problem import ProblemFileError


def test_importing_judgeopt_loads_nothing_heavy():
    code = "import sys, judgeopt; print(sorted(m for m in ('torch', 'casadi', 'pybullet') if m in sys.modules))"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip() == "[]"
    assert {"load_problem", "load_planners", "solve", "load_judge", "get_task", "simulator"} <= set(dir(judgeopt))
    with pytest.raises(AttributeError, match="no attribute 'nowhere'"):
        judgeopt.nowhere


def test_a_shipped_problem_by_name_with_overrides():
    p = judgeopt.load_problem("paper_sim_slow", mu=2.5)
    assert p.qdot_max == 0.4 and p.environment["mu"] == 2.5  # paper_sim_slow.toml is paper_sim at 0.4 m/s
    assert judgeopt.load_problem("problems/scrape.toml").task == "scrape"
    with pytest.raises(ProblemFileError, match="not found: .*paper_sim, paper_sim_ensemble"):
        judgeopt.load_problem("paper_nowhere")


@pytest.mark.slow
def test_solve_plans_within_the_limits_and_the_plan_succeeds_in_simulation():
    problem = judgeopt.load_problem(qdot_max=0.4, y_obj=0.22, mu=2.0)
    report = judgeopt.solve(problem, methods=("direct",), suggest=False)
    (r,) = report.results
    assert r.simulated_success is True and report.verdict == "likely"
    assert len(str(report)) < 2000 and "direct" in str(report) and report.summary()[0]["method"] == "direct"
    v = r.plan.values
    assert np.abs(v[:, 1]).max() <= 0.4 + 1e-9 and abs(v[-1, 0] - 0.22) < 1e-6
    judge = judgeopt.load_judge(problem.judge)
    p = judge.predict_proba(v[None].copy(), [[0.22, 2.0]])[0]
    assert abs(p - r.predicted_success) < 1e-4 * max(1.0, r.predicted_success)  # its judge, loaded on its own


@pytest.mark.slow
def test_the_readme_first_python_example_runs_on_the_top_level_api_alone(capsys):
    from judgeopt.files import REPO

    text = (REPO / "README.md").read_text()
    code = text.split("```python\n", 1)[1].split("```", 1)[0]
    imports = [line for line in code.splitlines() if line.startswith(("import ", "from "))]
    assert imports == ["import judgeopt"]
    exec(compile(code, "README.md", "exec"), {})
    assert capsys.readouterr().out.splitlines()[0] in ("likely", "unlikely", "infeasible")


def test_the_default_judge_is_the_one_solve_plans_with_and_models_marks_it(capsys):
    import json

    from judgeopt.cli.main import main
    from judgeopt.judge.casadi_fn import model_hash

    planners = judgeopt.load_planners("paper_sim", methods=("amortized",))
    assert model_hash(judgeopt.load_judge()) == model_hash(planners.judge)
    assert main(["models", "--task", "scoop", "--json"]) == 0
    entries = json.loads(capsys.readouterr().out)["scoop"]
    marked = [e["name"] for e in entries if "judge of problems/paper_sim.toml" in e["defaults"]]
    assert marked == [str(planners.judge_path.relative_to(planners.judge_path.parents[1]).with_suffix(""))]
    gen = [e for e in entries if "generator of problems/paper_sim.toml" in e["defaults"]]
    assert len(gen) == 1 and gen[0]["trained_against"] == marked[0]  # the pair solve uses, named as a pair


def _report():
    """A SolveReport as `solve` gives one, built by hand: a replayed plan, a plan with a
    violated limit and no replay, and a planner that found no plan."""
    from judgeopt.planners.result import PlanResult
    from judgeopt.session.solve import SolveReport
    from judgeopt.trajectory import Plan

    problem = judgeopt.load_problem("paper_sim")
    env = problem.nominal_env()
    t = np.arange(problem.steps + 1) * problem.dt
    plan = Plan.from_columns(problem.dt, problem.channel_spec, 0.2 * t / t[-1], np.full_like(t, 0.2),
                             np.full_like(t, 15.0))
    direct = PlanResult("direct", env, plan, 0.97, "solved", 0.42, residuals={"q_end": 0.0, "f_max": 0.0},
                        iterations=12, simulated_success=True, success_probability=0.93,
                        probability_source="calibrated", response=plan.values + 0.01)
    amortized = PlanResult("amortized", env, plan, 0.31, "solved", 0.004, residuals={"q_end": 0.02, "f_max": 0.0},
                           success_probability=0.31, probability_source="judge")
    cem = PlanResult("cem", env, None, None, "not_converged", 3.5, message="no sample passed the limits\nmore")
    return SolveReport(problem, env, None, [amortized, direct, cem])


def test_a_report_prints_in_a_few_lines_naming_each_method_and_its_verdict():
    report = _report()
    text = str(report)
    assert text == repr(report) and len(text) < 2000 and len(text.splitlines()) <= 8, text
    assert text.splitlines()[0] == "SolveReport paper_sim (task scoop): likely, run the direct plan"
    assert all(m in text for m in ("amortized", "direct", "cem", "likely", "breaks a hard limit", "calibrated", "0.93"))
    for r in report.results:
        assert len(repr(r)) < 500 and str(r).startswith(f"PlanResult {r.method}: ")
    direct, cem = report.results[1], report.results[2]
    assert "likely, success p 0.930 (calibrated)" in str(direct) and "simulated: success" in str(direct)
    assert str(cem) == "PlanResult cem: no plan (not_converged)\n  no sample passed the limits"


def test_the_summary_has_one_row_per_result_with_its_values():
    report = _report()
    rows = report.summary()
    assert isinstance(rows, list) and len(rows) == len(report.results)
    for row, r in zip(rows, report.results):
        assert row == r.row() and r.summary() == [row]
        for key in ("method", "verdict", "success_probability", "predicted_success", "simulated_success", "status",
                    "max_constraint_violation", "worst_constraint", "iterations", "solve_time_s"):
            assert row[key] == getattr(r, key), key
        assert row["probability_source"] == (r.probability_source or None)
    assert [row["verdict"] for row in rows] == ["breaks a hard limit", "likely", None]  # amortized: q_end off 2 cm
    lines = str(rows).splitlines()  # a text table: a header, a rule, one line per result
    assert lines[0].split()[:3] == ["method", "verdict", "success_probability"] and len(lines) == 2 + len(rows)
    assert lines[3].split()[:3] == ["direct", "likely", "0.93"]


def test_a_report_plots_its_plans_to_a_png(tmp_path):
    from matplotlib.figure import Figure

    fig = _report().plot(tmp_path / "plan.png")
    assert isinstance(fig, Figure) and (tmp_path / "plan.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    labels = [ln.get_label() for ax in fig.axes for ln in ax.get_lines()]
    assert any("direct: simulated response (success)" in k for k in labels)


def test_every_top_level_function_has_a_return_type_and_the_stub_names_each_lazy_name():
    import ast
    import inspect

    from judgeopt.files import REPO

    lazy = set(judgeopt._API)
    for name in lazy:
        value = getattr(judgeopt, name)
        if inspect.isfunction(value):
            returns = inspect.signature(value).return_annotation
            assert returns not in (inspect.Signature.empty, "Any"), name
    stub = ast.parse((REPO / "judgeopt" / "__init__.pyi").read_text())
    named = {a.asname for node in stub.body if isinstance(node, ast.ImportFrom) for a in node.names}
    assert named == lazy and (REPO / "judgeopt" / "py.typed").exists()


def test_solve_refuses_an_unknown_option_in_one_line_before_anything_loads(monkeypatch):
    from judgeopt import api
    from judgeopt.planners.problem import ProblemError

    def never(*args, **kwargs):
        raise AssertionError("the planners were loaded before the options were checked")

    monkeypatch.setattr(api, "load_planners", never)
    with pytest.raises(ProblemError) as exc:
        judgeopt.solve(qdotmax=0.4)
    said = str(exc.value)
    assert said.startswith("judgeopt.solve got 'qdotmax': not a field of problem 'paper_sim'") and "\n" not in said
    for valid in ("qdot_max", "f_max", "y_obj", "mu", "warm_start", "suggest"):  # the names it takes
        assert valid in said
    with pytest.raises(ProblemError, match="got 'nowhere'"):
        judgeopt.solve("paper_sim_slow", nowhere=1)
    for risk in (0.0, 2.0, float("nan")):  # a failure rate, as `solve --risk` takes it
        with pytest.raises(ProblemError, match="a failure rate between 0 and 1"):
            judgeopt.solve(risk=risk)
    code = ("import sys, judgeopt\ntry:\n    judgeopt.solve(qdotmax=0.4)\nexcept ValueError:\n"
            "    print('torch' in sys.modules)")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip() == \
        "False"  # at once: refused before torch (or any model) is loaded


@pytest.mark.slow
def test_solve_takes_limits_and_environment_values_by_name():
    report = judgeopt.solve(qdot_max=0.3, mu=2.5, methods=("direct",), simulate=False, suggest=False)
    (r,) = report.results
    assert judgeopt.load_problem().qdot_max == 1.0  # the file's, which a plan here may exceed 0.3 under
    assert report.problem.qdot_max == 0.3 and report.env["mu"] == 2.5 and r.env["mu"] == 2.5
    assert r.plan is not None and np.abs(r.plan.ydot).max() <= 0.3 + 1e-9
    again = judgeopt.solve(report.planners, qdot_max=0.5, simulate=False, suggest=False)  # loaded planners, new limit
    assert again.problem.qdot_max == 0.5 and report.planners.problem.qdot_max == 0.3
