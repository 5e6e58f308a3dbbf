"""The held-out sweep: no-judge baseline, feasibility search in simulation, the report, bad input."""

from __future__ import annotations


import numpy as np
import pytest

from judgeopt.files import REPO, resolve
from judgeopt.cli import main
from judgeopt.evaluate.feasibility import SearchConfig, random_plans, search
from judgeopt.evaluate.sweep import LimitSet, parse_limit_set, summarise_sweep, sweep_rows
from judgeopt.planners.problem import ProblemError, load_problem
from judgeopt.planners.result import constraint_residuals

ROOT = REPO  # the source checkout
PROBLEM = load_problem(resolve("problems/paper_sim.toml"))


@pytest.mark.parametrize("limits", [{}, {"qdot_max": 0.4, "f_min": 2.0, "f_max": 11.0}])
def test_random_plans_satisfy_every_constraint(limits):
    problem = PROBLEM.with_overrides(**limits)
    env = {"y_obj": 0.25, "mu": 2.0}
    plans = random_plans(problem, env, 20, seed=3)
    assert len(plans) == 20  # drawn until 20 end at q_end (clipping can spoil the end of a draw)
    for plan in plans:
        res = constraint_residuals(problem, plan, env)
        assert max(v for k, v in res.items() if k != "q_end") < 1e-9 and res["q_end"] <= 1e-3
    again = random_plans(problem, env, 20, seed=3)
    assert all(np.array_equal(a.as_array(), b.as_array()) for a, b in zip(plans, again))  # seeded per environment


def test_search_stops_at_its_first_success_and_is_seeded(sim):
    env = {"y_obj": 0.2, "mu": 0.5}  # low friction: random plans mostly succeed
    found = search(PROBLEM, env, sim, seed=0)
    assert found["status"] == "found" and found["simulated_success"] and found["tries"] <= 12
    assert search(PROBLEM, env, sim, seed=0)["tries"] == found["tries"]


def test_search_reports_tries_never_impossible(sim):
    # under 1 N of pressing force a high-friction object is never scooped: the search gives up
    problem = PROBLEM.with_overrides(f_min=0.0, f_max=1.0)
    out = search(problem, {"y_obj": 0.2, "mu": 3.0}, sim, seed=0, cfg=SearchConfig(population=4, iterations=2))
    assert out["status"] == "not_found" and out["tries"] == 8
    assert out["message"] == "no successful plan found in 8 tries"


def test_search_on_unreachable_limits_is_infeasible_not_a_crash(sim):
    out = search(PROBLEM.with_overrides(qdot_max=0.1), {"y_obj": 0.28, "mu": 2.0}, sim, seed=0)
    assert out["status"] == "infeasible" and out["tries"] == 0 and "out of reach" in out["message"]


def test_limit_sets_parse_and_bad_ones_are_named():
    assert parse_limit_set("qdot_max=0.6,f_max=18") == LimitSet("qdot_max 0.6, f_max 18",
                                                               (("qdot_max", 0.6), ("f_max", 18.0)))
    toml = parse_limit_set("problems/paper_sim_slow.toml")
    assert dict(toml.overrides)["qdot_max"] == 0.4
    with pytest.raises(ProblemError, match="'mu' is not a limit"):
        parse_limit_set("mu=2")
    with pytest.raises(ProblemError, match="'fast' is not a number"):
        parse_limit_set("qdot_max=fast")
    with pytest.raises(ProblemError, match="limit set 'f_min 30'"):
        sweep_rows(PROBLEM, [parse_limit_set("f_min=30")], ("mu", (1.0, 3.0)))


def test_summary_counts_feasibility_verdicts_and_the_no_judge_rate():
    ls = LimitSet("tight", (("f_max", 9.0),))
    rows, _ = sweep_rows(PROBLEM, [ls], ("mu", (1.0, 3.0)))
    by = {r.method: r for r in rows}

    def planned(i, p, ok):
        return {"env_index": i, "status": "solved", "success_probability": p, "simulated_success": ok,
                "verdict": "likely" if p >= 0.5 else "unlikely", "probability_source": "judge"}

    results = {r.key: [] for r in rows}
    # env 0: the direct plan succeeds; env 1: nothing succeeds anywhere; env 2: only the search succeeds
    results[by["direct"].key] = [planned(0, 0.9, True), planned(1, 0.2, False), planned(2, 0.7, False)]
    results[by["cem"].key] = [planned(0, 0.6, False), planned(1, 0.8, False), planned(2, 0.4, False)]
    results[by["nojudge"].key] = [{"env_index": i, "status": "sampled", "simulated_success": i == 0} for i in
                                  (0, 0, 1, 2)]
    results[by["search"].key] = [{"env_index": 0, "status": "found", "simulated_success": True, "tries": 1},
                                 {"env_index": 1, "status": "not_found", "simulated_success": False, "tries": 96},
                                 {"env_index": 2, "status": "found", "simulated_success": True, "tries": 40}]
    if "amortized" in by:
        results[by["amortized"].key] = [planned(i, 0.5, False) for i in range(3)]
    summary = {s["method"]: s for s in summarise_sweep([ls], rows, results)}
    d = summary["direct"]
    assert (d["feasible_found"], d["none_found"], d["search_tries_where_none_found"]) == (2, 1, 96)
    assert (d["success_where_feasible"], d["feasible_planned"]) == (1, 2)
    assert d["p_where_none_found"] == pytest.approx(0.2) and d["unlikely_where_none_found_pct"] == 100
    assert d["verdict_accuracy_pct"] == pytest.approx(200 / 3)  # env 2: "likely" but failed
    assert d["gap_pct"] == pytest.approx(100 * (1.8 / 3 - 1 / 3))
    assert summary["cem"]["unlikely_where_none_found_pct"] == 0 and d["nojudge_success_pct"] == 50


def test_only_the_methods_asked_for_are_reported(monkeypatch, capsys, tmp_path):
    import judgeopt.evaluate.tables as tables

    def fake_run_table(problem, rows, n, seed, out, **kwargs):  # one planned, replayed environment per row
        return {r.key: [{"env_index": 0, "status": "solved", "success_probability": 0.9, "simulated_success": True,
                         "verdict": "likely", "probability_source": "judge", "tries": 1}] for r in rows}

    monkeypatch.setattr(tables, "run_table", fake_run_table)
    assert main(["evaluate", "sweep", "--methods", "direct", "--limits", "f_max=20", "--n", "1", "--quiet",
                 "--no-baselines", "--out", str(tmp_path / "sweep")]) == 0
    table = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| f_max 20")]
    assert len(table) == 1 and "| direct |" in table[0]


@pytest.mark.parametrize("argv, message", [
    (["evaluate", "sweep", "--vary", "mu=3,1"], "lower bound first"),
    (["evaluate", "sweep", "--vary", "mu=1,9"], "physical range"),
    (["evaluate", "sweep", "--limits", "qdot=1"], "'qdot' is not a limit"),
    (["refine", "--sample-limits", "--f-max-range", "20,12"], "lo <= hi"),
    (["refine", "--sample-limits", "--f-max-range", "12,45"], "what the demonstrations cover"),
    (["refine", "--sample-limits", "--qdot-max-range", "0.1,1"], "cannot reach"),
])
def test_bad_ranges_are_one_line(argv, message, capsys, tmp_path):
    assert main(argv + ["--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


@pytest.mark.slow
def test_sweep_end_to_end_with_an_unreachable_set(tmp_path, capsys):
    """Small settings: two limit sets (one leaves every environment out of reach), 2 environments."""
    argv = ["evaluate", "sweep", "--n", "2", "--limits", "qdot_max=0.6,f_max=18", "qdot_max=0.05",
            "--jobs", "1", "--chunk", "2", "--quiet", "--out", str(tmp_path)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "| qdot_max 0.05 | 0/2, 2 infeasible before solving |" in text
    for name in ("sweep.md", "sweep.csv", "sweep.png"):
        assert (tmp_path / name).stat().st_size > 100
    chunks = sorted((tmp_path / "partial").glob("*.json"))
    assert chunks and main(argv) == 0  # a rerun plans nothing again
    assert sorted((tmp_path / "partial").glob("*.json")) == chunks


def test_sweep_plans_against_the_judge_given(tmp_path, capsys):
    """--judge replaces the problem's judge in every row (here a set no plan can meet: nothing is solved)."""
    argv = ["evaluate", "sweep", "--n", "1", "--limits", "qdot_max=0.05", "--judge", "models/judge_demos_tcn",
            "--no-baselines", "--methods", "direct", "--jobs", "1", "--quiet", "--out", str(tmp_path)]
    assert main(argv) == 0
    assert "judge models/judge_demos_tcn)" in (tmp_path / "sweep.md").read_text()
