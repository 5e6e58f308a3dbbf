"""The CEM sampling baseline and the calibration figures every evaluation reports."""

from __future__ import annotations


import numpy as np
import pytest

from judgeopt.files import REPO, resolve
from judgeopt.evaluate.report import calibration_error, reliability, summarise, write_report
from judgeopt.evaluate.tables import Row, table_planners
from judgeopt.tasks.scoop.tables import compare
from judgeopt.judge.store import load_judge
from judgeopt.planners.cem import CEMConfig, CEMPlanner
from judgeopt.planners.problem import load_problem

ROOT = REPO  # the source checkout


@pytest.fixture(scope="module")
def cem():
    p = load_problem(resolve("problems/paper_sim_slow.toml"))
    judge, _ = load_judge(ROOT / "models" / "judge_demos_tcn")
    return CEMPlanner(p, judge, CEMConfig(population=64, iterations=4))


def test_cem_holds_the_limits_and_improves_on_its_first_guess(cem):
    env = {"y_obj": 0.2, "mu": 1.5}
    r = cem.solve(env)
    assert r.max_constraint_violation < 1e-9, r.residuals
    assert abs(r.plan.y[-1] - 0.2) < 1e-9 and r.plan.ydot[-1] == 0.0
    assert r.plan.ydot.max() <= 0.4 + 1e-12 and 7.5 <= r.plan.f.min() and r.plan.f.max() <= 22.5
    first = CEMPlanner(cem.problem, cem.judge, CEMConfig(population=1, iterations=1)).solve(env)
    assert r.predicted_success > first.predicted_success


def test_cem_is_deterministic_per_environment(cem):
    a = cem.solve({"y_obj": 0.15, "mu": 2.5})
    cem.solve({"y_obj": 0.25, "mu": 1.0})  # another plan in between changes nothing
    b = cem.solve({"y_obj": 0.15, "mu": 2.5})
    assert np.array_equal(a.plan.as_array(), b.plan.as_array())


def test_cem_reports_an_unreachable_end_instead_of_searching(cem):
    far = cem.problem.with_overrides(q_end=0.39, qdot_max=0.1)
    r = CEMPlanner(far, cem.judge, cem.config).solve({"y_obj": 0.2, "mu": 2.0})
    assert r.status == "infeasible" and r.plan is None and "qdot_max" in " ".join(r.info["conflict"])


def test_reliability_and_calibration_error():
    pred = np.array([0.99] * 10 + [0.6] * 10)
    sim = np.array([1] * 7 + [0] * 3 + [1] * 6 + [0] * 4)
    cells = reliability(pred, sim)
    assert [(c["n"], round(c["observed"], 2)) for c in cells] == [(10, 0.6), (10, 0.7)]
    assert calibration_error(pred, sim) == pytest.approx(0.5 * 0.0 + 0.5 * 0.29)
    assert calibration_error(np.full(4, 0.75), np.array([1, 1, 1, 0])) == pytest.approx(0.0)


def test_compare_report_has_every_planner_and_a_reliability_diagram(tmp_path):
    rows = compare(table_planners())
    assert [r.method for r in rows][:3] == ["amortized", "direct", "cem"]
    assert {r.method for r in rows[3:]} == {"amortized", "direct"}
    assert all(r.overrides or r.judge != rows[1].judge for r in rows[3:])
    fake = {r.key: [{"simulated_success": i % 4 != 0, "predicted_success": 0.95, "max_constraint_violation": 0.0,
                     "solve_time_s": 0.1, "env_index": i} for i in range(8)] for r in rows}
    summary = summarise(rows, fake)
    assert {s["successes"] for s in summary} == {6}
    assert summary[0]["calibration_gap_pct"] == pytest.approx(20.0)
    files = write_report(summary, tmp_path, "compare", "test", fake, rows)
    assert [f.name for f in files] == ["compare.md", "compare.csv", "compare.png", "compare_reliability.png"]
    assert "ECE" in files[0].read_text()


def test_the_calibrated_column_counts_only_plans_the_calibration_covers():
    """Outside its fitted ranges a calibration map extrapolates a rate, and `solve` reports the
    judge's p there; a table's 'calibrated' column must not show the extrapolated value either."""
    rows = compare(table_planners())[:1]
    plans = [{"simulated_success": i < 3, "predicted_success": 0.99, "calibrated_success": c, "calibration_covers": cov,
              "max_constraint_violation": 0.0, "solve_time_s": 0.1, "env_index": i}
             for i, (c, cov) in enumerate([(0.6, True), (0.6, True), (1.0, False), (1.0, False)])]
    (s,) = summarise(rows, {rows[0].key: plans})
    assert s["calibrated_mean"] == pytest.approx(0.6) and s["calibrated_gap_pct"] == pytest.approx(-40.0)
    (none,) = summarise(rows, {rows[0].key: [dict(p, calibration_covers=False) for p in plans]})
    assert none["calibrated_mean"] is None


def test_row_overrides_change_the_problem_for_that_row_only():
    row = Row("slow", "cem", "models/judge_demos_tcn", overrides=(("qdot_max", 0.3),))
    assert row.key != Row("fast", "cem", "models/judge_demos_tcn").key
    assert dict(row.overrides)["qdot_max"] == 0.3
