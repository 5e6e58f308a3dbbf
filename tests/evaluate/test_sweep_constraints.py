"""Held-out constraint sets (issue 36): parsed like limit sets, drawn so they bind and stay feasible,
held by the feasibility search's plans, and each planner's violations reported side by side."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.evaluate.feasibility import random_plans
from judgeopt.evaluate.report import markdown, summarise
from judgeopt.evaluate.sweep import (ConstraintRanges, LimitSet, markdown_sweep, parse_limit_set,
                                     random_constraint_sets, summarise_sweep, sweep_rows)
from judgeopt.evaluate.tables import Row
from judgeopt.files import resolve
from judgeopt.planners.feasible import check
from judgeopt.planners.problem import ProblemError, load_problem
from judgeopt.planners.result import constraint_residuals

PROBLEM = load_problem(resolve("problems/paper_sim.toml"))


def test_constraint_fields_parse_with_repeatable_bounds():
    ls = parse_limit_set("a_max=2,fdot_max=60,bound=f:0:12@0:0.4,bound=y:0.05:inf@0.6:1.5")
    assert ls == LimitSet("a_max 2, fdot_max 60, f:0:12@0:0.4, y:0.05:inf@0.6:1.5",
                          (("a_max", 2.0), ("fdot_max", 60.0), ("bounds", ("f:0:12@0:0.4", "y:0.05:inf@0.6:1.5"))))
    both = dict(parse_limit_set("qdot_max=0.4, jerk_max=40, joint_limit_scale=0.8").overrides)
    assert both == {"qdot_max": 0.4, "jerk_max": 40.0, "joint_limit_scale": 0.8}
    p = PROBLEM.with_overrides(**dict(ls.overrides))  # what the sweep's rows do
    assert p.a_max == 2.0 and list(p.bounds) == ["f:0:12@0:0.4", "y:0.05:inf@0.6:1.5"]


@pytest.mark.parametrize("text, message", [
    ("a_max=-2", "a_max = -2 must be a positive number"),
    ("jerk_max=steep", "'steep' is not a number for jerk_max"),
    ("bound=f:0@0:0.4", "must read NAME:LO:HI@T0:T1"),
    ("a_min=1", "'a_min' is not a limit or constraint"),
])
def test_a_bad_constraint_field_is_one_line(text, message):
    with pytest.raises(ProblemError, match=message) as exc:
        parse_limit_set(text)
    assert len(str(exc.value).splitlines()) == 1


def test_a_bad_bound_channel_names_the_set():
    with pytest.raises(ProblemError, match="limit set 'g:0:1'.*no channel 'g'"):
        sweep_rows(PROBLEM, [parse_limit_set("bound=g:0:1")], None, methods=("direct",), baselines=False)


def test_random_constraint_sets_are_seeded_feasible_and_bind():
    sets = random_constraint_sets(3, 7, PROBLEM)
    assert sets == random_constraint_sets(3, 7, PROBLEM) and sets != random_constraint_sets(3, 8, PROBLEM)
    r = ConstraintRanges()
    for ls in sets:
        o = dict(ls.overrides)
        assert r.a_max[0] <= o["a_max"] <= r.a_max[1] and r.jerk_max[0] <= o["jerk_max"] <= r.jerk_max[1]
        assert r.fdot_max[0] <= o["fdot_max"] <= r.fdot_max[1] and len(o["bounds"]) == 1
        p = PROBLEM.with_overrides(**o)
        for y in np.linspace(0.10, 0.28, 5):  # every terminal position the environments give
            check(p, {"y_obj": float(y), "mu": 2.0})


def test_random_constraint_sets_redraw_an_infeasible_set_and_say_when_none_is():
    # a_max this low cannot bring the blade to y_obj in 1.5 s: every draw is infeasible
    with pytest.raises(ProblemError, match="no feasible constraint set in 20 draws.*widen the ranges"):
        random_constraint_sets(1, 0, PROBLEM, ConstraintRanges(a_max=(0.01, 0.02)))
    # here about half the draws are: every set returned is feasible all the same
    half = ConstraintRanges(a_max=(0.2, 1.0))
    for ls in random_constraint_sets(4, 0, PROBLEM, half):
        check(PROBLEM.with_overrides(**dict(ls.overrides)), {"y_obj": 0.28, "mu": 1.0})
    with pytest.raises(ProblemError, match="at least one"):
        random_constraint_sets(0, 0, PROBLEM)


def test_random_plans_hold_the_new_constraints():
    """The no-judge baseline and the feasibility search try only plans that hold every constraint."""
    p = PROBLEM.with_overrides(a_max=2.5, jerk_max=30.0, fdot_max=25.0, bounds=("f:0:11@0:0.4", "y:-inf:0.05@0:0.3"))
    env = {"y_obj": 0.25, "mu": 2.0}
    plans = random_plans(p, env, 6, seed=1)
    assert len(plans) == 6
    for plan in plans:
        assert max(constraint_residuals(p, plan, env).values()) <= 1e-6
    assert all(np.array_equal(a.values, b.values) for a, b in zip(plans, random_plans(p, env, 6, seed=1)))


def _planned(i, violation, worst="jerk_max"):
    return {"env_index": i, "status": "solved", "success_probability": 0.9, "simulated_success": True,
            "verdict": "likely", "probability_source": "judge", "max_constraint_violation": violation,
            "worst_constraint": worst, "residuals": {"dynamics": 0.0, "jerk_max": violation}, "solve_time_s": 0.1,
            "predicted_success": 0.9}


def test_sweep_reports_each_planners_worst_violation_and_plans_held():
    ls = parse_limit_set("a_max=3,jerk_max=40")
    rows, _ = sweep_rows(PROBLEM, [ls], None, methods=("amortized", "direct"), baselines=False)
    by = {r.method: r for r in rows}
    results = {by["amortized"].key: [_planned(0, 12.5), _planned(1, 3e-7), _planned(2, 64.0, "a_max")],
               by["direct"].key: [_planned(0, 1e-16, "dynamics"), _planned(1, 2e-6), _planned(2, 0.0)]}
    summary = {s["method"]: s for s in summarise_sweep([ls], rows, results, ("amortized", "direct"))}
    a, d = summary["amortized"], summary["direct"]
    assert (a["violation_max"], a["worst_constraint"], a["held_plans"], a["plans_checked"]) == (64.0, "a_max", 1, 3)
    assert (d["violation_max"], d["worst_constraint"], d["held_plans"], d["plans_checked"]) == (2e-6, "jerk_max", 2, 3)
    md = markdown_sweep(list(summary.values()), "t")
    assert "| 6.4e+01 (a_max) | 1/3 |" in md and "| 2.0e-06 (jerk_max) | 2/3 |" in md


def test_planners_table_shows_held_plans_where_the_problem_has_constraints():
    rows = [Row("direct", "direct", None), Row("amortized", "amortized", None)]
    results = {rows[0].key: [_planned(0, 1e-9, "dynamics"), _planned(1, 0.0)],
               rows[1].key: [_planned(0, 30.0), _planned(1, 5.0)]}
    md = markdown(summarise(rows, results), "t")
    assert "held every constraint (1e-06)" in md
    assert "| 1.0e-09 | 2/2 |" in md and "| 3.0e+01 (jerk_max) | 0/2 |" in md
    plain = {k: [{**r, "residuals": {"dynamics": r["max_constraint_violation"]}} for r in v] for k, v in results.items()}
    assert "held every constraint" not in markdown(summarise(rows, plain), "t")  # no [constraints]: as before


def test_random_constraints_on_the_command_line(monkeypatch, capsys, tmp_path):
    import judgeopt.evaluate.tables as tables

    seen = []

    def fake_run_table(problem, rows, n, seed, out, **kwargs):
        seen.extend(rows)
        return {r.key: [_planned(0, 0.0 if r.method == "direct" else 20.0)] for r in rows}

    monkeypatch.setattr(tables, "run_table", fake_run_table)
    argv = ["evaluate", "sweep", "--random-constraints", "2", "--methods", "amortized", "direct", "--n", "1",
            "--no-baselines", "--quiet", "--seed", "3", "--out", str(tmp_path / "sweep")]
    assert main(argv) == 0
    out = capsys.readouterr().out
    sets = random_constraint_sets(2, 3, PROBLEM)
    assert {r.overrides for r in seen} == {ls.overrides for ls in sets}
    assert "Held-out constraint sets at the limits of paper_sim" in out and out.count("| 0/1 |") == 2
    assert main(argv[:4] + ["--limits", "a_max=2", "--out", str(tmp_path / "x")]) == 2
    assert "--random-constraints" in capsys.readouterr().err


def test_a_success_that_breaks_the_constraints_shows_no_scoop_is_possible_under_them():
    """Environment 0: only the generator succeeded, breaking jerk_max by 12.5: no witness, so it
    counts where none was found (and the direct solve's 'unlikely' there is right). Environment 1:
    the generator's success held every constraint (3e-7 < HOLD_TOL): a witness."""
    ls = parse_limit_set("a_max=3,jerk_max=40")
    rows, _ = sweep_rows(PROBLEM, [ls], None, methods=("amortized", "direct"), baselines=False)
    by = {r.method: r for r in rows}
    failed = {**_planned(0, 0.0, "dynamics"), "simulated_success": False, "verdict": "unlikely",
              "success_probability": 0.1}
    results = {by["amortized"].key: [_planned(0, 12.5), _planned(1, 3e-7)],
               by["direct"].key: [failed, {**failed, "env_index": 1}]}
    s = {x["method"]: x for x in summarise_sweep([ls], rows, results, ("amortized", "direct"))}["direct"]
    assert (s["feasible_found"], s["none_found"], s["unlikely_where_none_found_pct"]) == (1, 1, 100.0)
    assert (s["success_where_feasible"], s["feasible_planned"]) == (0, 1)
