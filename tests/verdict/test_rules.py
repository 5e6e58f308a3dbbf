"""A verdict on every plan, the plan to run, and re-planning under other limits."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from conftest import direct_result
from judgeopt.files import resolve
from judgeopt.cli import main
from judgeopt.verdict import rules as rules_module
from judgeopt.planners.problem import load_problem
from judgeopt.verdict.rules import LIKELY, assess
from judgeopt.planners.result import PlanResult


def test_the_probability_stood_behind_is_the_calibrated_one_where_it_exists():
    judged = assess(direct_result(0.99))
    assert (judged.success_probability, judged.probability_source, judged.verdict) == (0.99, "judge", "likely")
    calibrated = assess(direct_result(0.99, calibrated_success=0.2, calibration_covers=True))
    assert (calibrated.success_probability, calibrated.probability_source, calibrated.verdict) == (
        0.2, "calibrated", "unlikely")
    outside = assess(direct_result(0.1, calibrated_success=0.7, calibration_covers=False))  # no extrapolated map
    assert (outside.success_probability, outside.probability_source, outside.verdict) == (0.1, "judge", "unlikely")
    assert assess(direct_result(LIKELY)).verdict == "likely" and assess(direct_result(LIKELY - 1e-9)).verdict == "unlikely"
    no_plan = assess(PlanResult("direct", {}, None, None, "infeasible", 0.0))
    assert no_plan.verdict is None and no_plan.to_json()["verdict"] is None



def test_a_calibration_raises_a_low_judge_p_only_to_the_floor_its_evidence_backs():
    """A judge p of 0.3 that the calibration maps to 0.9 is lifted to the evidence's floor, no higher
    (and not at all without one); a calibrated p below the judge's is taken whatever the floor."""
    lifted = assess(direct_result(0.3, calibrated_success=0.9, calibration_covers=True, raise_floor=0.4))
    assert (lifted.success_probability, lifted.probability_source, lifted.verdict) == (0.4, "calibrated", "unlikely")
    assert assess(direct_result(0.3, calibrated_success=0.9, calibration_covers=True)).success_probability == 0.3
    lowered = assess(direct_result(0.8, calibrated_success=0.6, calibration_covers=True, raise_floor=0.7))
    assert lowered.success_probability == 0.6

# -- the command line ----------------------------------------------------------------------------------
def test_solve_reports_a_verdict_and_its_source(capsys):
    rc = main(["solve", "--qdot-max", "0.4", "--method", "direct", "--json", "--no-simulate"])
    out = json.loads(capsys.readouterr().out)
    (r,) = out["results"]
    assert r["verdict"] in ("likely", "unlikely") and r["probability_source"] in ("calibrated", "judge")
    assert 0.0 <= r["success_probability"] <= 1.0
    assert (rc, out["verdict"]) == ((0, "likely") if r["verdict"] == "likely" else (4, "unlikely"))


@pytest.mark.parametrize("suggest_flag", ["--no-suggest", "--suggest"])
def test_solve_exits_4_and_says_so_in_one_line_when_no_plan_is_likely(monkeypatch, capsys, suggest_flag):
    from judgeopt.planners import result as result_module
    from judgeopt.session import suggest as suggest_module
    from judgeopt.verdict import rows as rows_module

    # every module that took LIKELY by name, each restored after the test: one patched only while a
    # module was first imported would keep 1.01 for the rest of the session (no suggestion was then
    # ever likely in tests/planners/test_solve.py when it ran after this one)
    for module in (rules_module, result_module, rows_module, suggest_module):
        monkeypatch.setattr(module, "LIKELY", 1.01)
    rc = main(["solve", "--qdot-max", "0.4", "--method", "direct", "--no-simulate", suggest_flag])
    text = capsys.readouterr().out
    assert rc == 4
    verdict_lines = [line for line in text.splitlines() if line.startswith("judgeopt solve: no plan is likely")]
    assert len(verdict_lines) == 1 and "the plan to run: direct, p = " in verdict_lines[0]
    assert ("no single relaxation (f_max, qdot_max, f_min;" in text) == (suggest_flag == "--suggest")


def test_infeasible_stays_exit_3(capsys):
    assert main(["solve", "--qdot-max", "0.1", "--json"]) == 3
    assert json.loads(capsys.readouterr().out)["verdict"] == "infeasible"


# -- re-planning under other limits ----------------------------------------------------------------------
@pytest.mark.slow
def test_with_limits_plans_what_a_fresh_load_for_those_limits_plans():
    from judgeopt.planners.loaded import Planners

    problem = load_problem(resolve("problems/paper_sim.toml"))
    env = {"y_obj": 0.2, "mu": 2.0}
    base = Planners.load(problem, ("amortized", "direct"))
    relaxed = base.with_limits(qdot_max=0.5, f_max=20.0).solve(env)
    fresh = Planners.load(problem.with_overrides(qdot_max=0.5, f_max=20.0), ("amortized", "direct")).solve(env)
    assert [r.method for r in relaxed] == [r.method for r in fresh]
    for a, b in zip(relaxed, fresh):
        np.testing.assert_allclose(a.plan.as_array(), b.plan.as_array(), atol=1e-9)
        assert a.info["setting"] == b.info["setting"]
    assert max(relaxed[-1].plan.ydot) <= 0.5 + 1e-6 and max(relaxed[-1].plan.f) <= 20.0 + 1e-6


def test_a_calibration_for_other_models_is_refused_in_one_line(capsys, tmp_path):
    from judgeopt.verdict.calibration import save_calibration

    empty = save_calibration(tmp_path / "other.json", {})
    assert main(["solve", "--qdot-max", "0.4", "--method", "direct", "--no-simulate", "--calibration",
                 str(empty)]) == 2
    err = capsys.readouterr().err
    assert "has no calibration for these planners" in err and len(err.strip().splitlines()) == 1


# -- the verdict on the plan to run, where planners disagree -------------------------------------------
def _planned(method, p, violation=0.0, **info) -> PlanResult:
    r = direct_result(p, **info)
    r.method, r.residuals = method, {"qdot_max": violation}
    return assess(r)


def test_the_plan_to_run_holds_the_limits_first_then_has_the_highest_p():
    from judgeopt.verdict.risk import HOLD_TOL
    from judgeopt.verdict.rules import overall_verdict, recommended

    likely, unlikely = _planned("amortized", 0.9), _planned("direct", 0.2)
    assert recommended([likely, unlikely]) is likely and overall_verdict([likely, unlikely]) == "likely"
    assert recommended([unlikely, likely]) is likely  # not the order: the higher p
    breaking = _planned("amortized", 0.9, violation=0.006)  # a soft generator over q̇_max by 6 mm/s
    assert recommended([breaking, unlikely]) is unlikely and overall_verdict([breaking, unlikely]) == "unlikely"
    assert recommended([_planned("amortized", 0.9, violation=HOLD_TOL), unlikely]).method == "amortized"
    tie = [_planned("amortized", 0.99), _planned("direct", 0.99)]
    assert recommended(tie) is tie[0]
    both = [_planned("amortized", 0.3), _planned("direct", 0.2)]
    assert overall_verdict(both) == "unlikely" and recommended(both) is both[0]
    assert overall_verdict([]) == "unlikely" and recommended([]) is None
    assert overall_verdict([PlanResult("direct", {}, None, None, "infeasible", 0.0), likely]) == "infeasible"
    rows = [r.to_json() for r in (breaking, unlikely)]  # the same rule on evaluation rows
    assert recommended(rows)["method"] == "direct" and overall_verdict(rows) == "unlikely"


def test_a_plan_that_breaks_a_hard_limit_is_never_likely_whatever_its_p():
    from judgeopt.verdict.rules import BREAKS
    from judgeopt.verdict.risk import HOLD_TOL
    from judgeopt.verdict.rows import reassess

    over = _planned("amortized", 0.99, violation=48.0)  # over --fdot-max by 48 N/s
    assert over.verdict == BREAKS and over.to_json()["verdict"] == BREAKS
    checked = _planned("amortized", 0.2, violation=48.0, calibrated_success=0.97, calibration_covers=True)
    assert checked.probability_source == "calibrated" and checked.verdict == BREAKS
    assert _planned("amortized", 0.99, violation=HOLD_TOL).verdict == "likely"  # at the tolerance it holds
    from judgeopt.verdict.rules import LEGEND

    assert f"'{BREAKS}' where the plan breaks a hard limit by more than {HOLD_TOL:g}" in LEGEND  # --explain says so
    row = over.to_json()
    row["verdict"] = "likely"
    reassess([row])
    assert row["verdict"] == BREAKS


def test_the_plan_to_run_is_ranked_by_the_p_stood_behind_calibrated_before_the_judges_own():
    from judgeopt.verdict.rules import overall_verdict, recommended

    # CMA-ES at the judge's 0.999997, never checked, against a direct plan calibrated at 0.9 (judge 0.6)
    cmaes = _planned("cmaes", 0.999997)
    direct = _planned("direct", 0.6, calibrated_success=0.9, calibration_covers=True)
    assert recommended([cmaes, direct]) is direct and recommended([direct, cmaes]) is direct
    # the judge and the calibration rank two plans in opposite orders: the calibrated p decides
    a = _planned("amortized", 0.95, calibrated_success=0.7, calibration_covers=True)
    b = _planned("direct", 0.7, calibrated_success=0.8, calibration_covers=True)
    assert recommended([a, b]) is b and recommended([b, a]) is b
    # a checked 'unlikely' goes before an unchecked 'likely', and the verdict is the checked one
    low = _planned("direct", 0.9, calibrated_success=0.3, calibration_covers=True)
    assert recommended([cmaes, low]) is low and overall_verdict([cmaes, low]) == "unlikely"
    rows = [r.to_json() for r in (cmaes, a, b)]  # the same on evaluation rows
    assert recommended(rows)["method"] == "direct"



def test_a_plan_called_likely_goes_before_an_uncertain_one_of_higher_p():
    """Each planner's evidence sets its own threshold: the amortised plan is likely at 0.92 (its
    threshold 0.9), the direct plan uncertain at 0.97 (its threshold 0.99). The stated risk decides."""
    from judgeopt.verdict.rules import UNCERTAIN, overall_verdict, recommended

    likely = _planned("amortized", 0.6, calibrated_success=0.92, calibration_covers=True, likely_at=0.9)
    uncertain = _planned("direct", 0.6, calibrated_success=0.97, calibration_covers=True, likely_at=0.99)
    assert (likely.verdict, uncertain.verdict) == ("likely", UNCERTAIN)
    assert recommended([uncertain, likely]) is likely and overall_verdict([uncertain, likely]) == "likely"
    assert recommended([r.to_json() for r in (uncertain, likely)])["method"] == "amortized"

def test_outside_the_judges_data_the_verdict_says_so_unless_a_calibration_checked_it():
    from judgeopt.verdict.rules import OUTSIDE, overall_verdict
    from judgeopt.verdict.rows import reassess

    far = ["y_obj = 0.35 m is outside the judge's data (0.10-0.28)"]
    judged = _planned("direct", 0.999, outside_judge_data=far)
    assert judged.verdict == OUTSIDE and judged.to_json()["verdict"] == OUTSIDE
    checked = _planned("direct", 0.6, outside_judge_data=far, calibrated_success=0.9, calibration_covers=True)
    assert checked.verdict == "likely"  # a calibrated p was checked against replayed outcomes there
    inside = _planned("amortized", 0.4)
    assert overall_verdict([judged, inside]) == "unlikely"  # a plan inside the data is preferred
    assert overall_verdict([judged]) == OUTSIDE
    row = judged.to_json()
    row["verdict"] = None
    reassess([row])
    assert row["verdict"] == OUTSIDE


def _report(monkeypatch, results):
    """`judgeopt solve` on a report whose results are given (the planners are loaded for real)."""
    from judgeopt.session import solve as session

    def fake_solve(planners, **kw):
        return session.SolveReport(planners.problem, planners.problem.nominal_env(), planners, results)

    monkeypatch.setattr(session, "solve", fake_solve)


@pytest.mark.parametrize("case", ["mixed", "breaking", "outside"])
def test_solve_exit_code_and_summary_follow_the_plan_to_run(monkeypatch, capsys, case):
    far = ["y_obj = 0.35 m is outside the judge's data (0.10-0.28)"]
    results = {"mixed": [_planned("amortized", 0.9), _planned("direct", 0.2)],
               "breaking": [_planned("amortized", 0.9, violation=0.006), _planned("direct", 0.2)],
               "outside": [_planned("amortized", 0.99, outside_judge_data=far),
                           _planned("direct", 0.98, outside_judge_data=far)]}[case]
    _report(monkeypatch, results)
    code = main(["solve", "--no-simulate", "--no-suggest"])
    out = capsys.readouterr().out
    if case == "mixed":
        assert code == 0 and "the planners disagree" in out and "run the amortized plan" in out
        assert "no plan is likely" not in out
    elif case == "breaking":
        assert code == 4 and "run the direct plan" in out and "the plan to run: direct, p = 0.20" in out
    else:
        assert code == 4 and "note: y_obj = 0.35 m is outside the judge's data" in out and "no plan is likely" not in out
        assert "the plan to run (amortized) is outside the judge's data" in out
    _report(monkeypatch, results)
    assert main(["solve", "--no-simulate", "--no-suggest", "--json"]) == code
    doc = json.loads(capsys.readouterr().out)
    assert doc["verdict"] == {"mixed": "likely", "breaking": "unlikely", "outside": rules_module.OUTSIDE}[case]
    assert doc["recommended"] == {"mixed": "amortized", "breaking": "direct", "outside": "amortized"}[case]


def test_suggestions_are_searched_only_when_the_plan_to_run_is_unlikely(monkeypatch):
    from judgeopt.session import solve as session
    from judgeopt.session import suggest as suggest_mod

    problem = load_problem(resolve("problems/paper_sim.toml"))
    calls = []
    monkeypatch.setattr(suggest_mod, "suggest", lambda planners, env, results: calls.append(results) or ["x"])

    @dataclasses.dataclass
    class Given:
        problem: object
        results: list
        notes: list = dataclasses.field(default_factory=list)

        def over_env_sets(self):
            return []

        def warm_up(self, cold=False):
            pass

        def solve(self, env, **kw):
            return self.results

    mixed = session.solve(Given(problem, [_planned("amortized", 0.9), _planned("direct", 0.2)]))
    assert mixed.verdict == "likely" and not calls and mixed.suggestions == []
    breaking = session.solve(Given(problem, [_planned("amortized", 0.9, violation=0.006), _planned("direct", 0.2)]))
    assert breaking.unlikely and len(calls) == 1 and breaking.suggestions == ["x"]
    assert "run the direct plan" in breaking.disagreement


@pytest.mark.parametrize("option,value,name", [("--y-obj", "0.35", "y_obj"), ("--mu", "4.5", "mu"),
                                               ("--qdot-max", "1.3", "qdot_max")])
def test_a_request_outside_the_judges_data_is_named_in_one_line(capsys, option, value, name):
    """The shipped refined judge learnt y_obj 0.10-0.28 m, mu 0.05-4, q̇_max 0.22-1.2 m/s."""
    code = main(["solve", option, value, "--method", "direct", "--no-simulate", "--no-suggest"])
    out = capsys.readouterr().out
    notes = [line for line in out.splitlines() if line.startswith(f"note: {name} = ")]
    assert code == 4 and len(notes) == 1 and "outside the judge's data" in notes[0]
    assert "the plan to run (direct) is outside the judge's data" in out
    inside = {"y_obj": "0.27", "mu": "3.9", "qdot_max": "1.15"}[name]
    assert main(["solve", option, inside, "--method", "direct", "--no-simulate", "--no-suggest"]) in (0, 4)
    assert "outside the judge's data" not in capsys.readouterr().out


def test_reassessed_rows_take_the_calibrated_p_only_where_it_covers():
    """Evaluation rows re-judged after a calibration was fitted (what `evaluate` does with old plans)."""
    from judgeopt.verdict.rows import reassess

    rows = [{"success_probability": None, "predicted_success": None, "verdict": None},
            {"success_probability": 0.99, "predicted_success": 0.99, "calibrated_success": 0.2,
             "calibration_covers": True},
            {"success_probability": 0.99, "predicted_success": 0.99, "calibrated_success": 0.2,
             "calibration_covers": False},
            {"success_probability": 0.3, "predicted_success": 0.3},
            {"success_probability": 0.6, "predicted_success": 0.6, "calibrated_success": 0.8,
             "calibration_covers": True, "outside_judge_data": ["mu = 4.5 is outside the judge's data (0.05-4.0)"]},
            # a calibrated p lifting a judge's below 0.5: only as far as held-out evidence of such lifts backs
            {"success_probability": 0.3, "predicted_success": 0.3, "calibrated_success": 0.8, "calibration_covers": True},
            {"success_probability": 0.3, "predicted_success": 0.3, "calibrated_success": 0.8, "calibration_covers": True,
             "raise_floor": 0.6},
            # held-out evidence sets 'likely' at 0.99: below it, uncertain; none holds the risk: never likely
            {"success_probability": 0.95, "predicted_success": 0.95, "likely_at": 0.99},
            {"success_probability": 0.995, "predicted_success": 0.995, "likely_at": 0.99},
            {"success_probability": 0.995, "predicted_success": 0.995, "likely_at": None}]
    reassess(rows)
    assert [(r["success_probability"], r.get("probability_source"), r["verdict"]) for r in rows] == [
        (None, None, None), (0.2, "calibrated", "unlikely"), (0.99, "judge", "likely"), (0.3, "judge", "unlikely"),
        (0.8, "calibrated", "likely"), (0.3, "calibrated", "unlikely"), (0.6, "calibrated", "likely"),
        (0.95, "judge", "uncertain"), (0.995, "judge", "likely"), (0.995, "judge", "uncertain")]
    from judgeopt.verdict.rules import stood_behind

    assert stood_behind(None, None, False, 0.0) == (None, "") and stood_behind(None, 0.7, False, 0.0) == (None, "")


def test_a_results_json_carries_its_verdict_and_where_its_p_comes_from():
    r = _planned("direct", 0.7, violation=0.0002, calibrated_success=0.4, calibration_covers=True)
    d = r.to_json()
    assert (d["method"], d["predicted_success"], d["success_probability"], d["probability_source"], d["verdict"]) == (
        "direct", 0.7, 0.4, "calibrated", "unlikely")
    assert d["max_constraint_violation"] == 0.0002 and d["worst_constraint"] == "qdot_max"
    assert d["calibration_covers"] is True and d["channels"] == ["y", "ydot", "f"] and len(d["t"]) == len(d["y"])
    assert d["units"]["t"] == "s" and d["environment"] == {"y_obj": 0.2, "mu": 2.0}
