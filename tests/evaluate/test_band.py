"""`judgeopt evaluate band`: settings drawn where the user says, the same on every run, and the verdict
re-scored by the evidence stored with a calibration."""

from __future__ import annotations

import csv
import dataclasses
import json

import pytest

from judgeopt.cli import main
from judgeopt.errors import ExitCode
from judgeopt.evaluate.band import BandConfig, default_band, draw_setting, markdown_band, summarise_band
from judgeopt.files import resolve
from judgeopt.planners.problem import ProblemError, load_problem
from judgeopt.verdict.risk import HOLD_TOL


@pytest.fixture(scope="module")
def problem():
    return load_problem(resolve("problems/paper_sim.toml"))


def test_settings_are_drawn_inside_the_band_the_same_on_every_run(problem):
    band = default_band(problem.task)
    settings = [draw_setting(problem, band, 7, i) for i in range(200)]
    assert settings[3] == draw_setting(problem, band, 7, 3) != draw_setting(problem, band, 8, 3)
    for name, lo, hi in band.ranges:
        values = [s["limits"].get(name, s["environment"].get(name)) for s in settings]
        assert lo <= min(values) and max(values) <= hi
        assert min(values) < lo + 0.1 * (hi - lo) and max(values) > hi - 0.1 * (hi - lo)  # the whole band
    assert not any(s["constraints"] for s in settings)  # no share asked for
    some = [draw_setting(problem, dataclasses.replace(band, constrained=0.5), 7, i) for i in range(200)]
    share = sum(bool(s["constraints"]) for s in some) / len(some)
    assert 0.35 < share < 0.65 and all(set(s["constraints"]) == {"a_max", "jerk_max", "fdot_max", "bounds"}
                                      for s in some if s["constraints"])


@pytest.mark.parametrize("band, message", [
    (BandConfig((("stiffness", 0.0, 1.0),)), "--band stiffness: not a limit or environment variable"),
    (BandConfig((("f_max", 15.0, 11.0),)), "need finite LO <= HI"),
    (BandConfig((("f_max", 11.0, 15.0),), constrained=1.5), "a share of the settings"),
])
def test_a_band_that_cannot_be_drawn_is_one_line(problem, band, message):
    with pytest.raises(ProblemError, match=message):
        band.check(problem)


def test_bad_band_options_are_one_line_before_any_planning(capsys):
    assert main(["evaluate", "band", "--band", "stiffness=0,1", "--n", "1"]) == 2
    assert "not a limit or environment variable" in capsys.readouterr().err
    assert main(["evaluate", "sweep", "--constrained", "0.5"]) == 2
    assert "only for `judgeopt evaluate band`" in capsys.readouterr().err


def _row(i, method, verdict, success, **kw):
    return {"method": method, "env_index": i, "verdict": verdict, "simulated_success": success,
            "success_probability": 0.9 if verdict == "likely" else 0.3, "probability_source": "calibrated",
            "max_constraint_violation": 0.0, "band_constraints": {}, **kw}


def test_the_plan_to_run_is_counted_per_setting():
    rows = [_row(0, "amortized", "uncertain", True), _row(0, "direct", "likely", True),      # likely, succeeded
            _row(1, "amortized", "unlikely", False), _row(1, "direct", "likely", False),     # likely, none succeeded
            _row(2, "amortized", "unlikely", True), _row(2, "direct", "unlikely", False),    # one succeeded, not likely
            _row(3, "direct", "uncertain", False, band_constraints={"a_max": 3.0})]
    s = summarise_band(rows, ("amortized", "direct"))
    assert (s["settings"], s["constrained"]) == (4, 1)
    assert s["to_run"] == {"likely": 2, "likely_failed": 1, "likely_failed_bound_pct": pytest.approx(100 * 0.95 ** 0.5),
                           "some_succeeded": 2, "likely_and_succeeded": 1, "none_succeeded": 2,
                           "likely_where_none_succeeded": 1}
    direct = s["planners"][1]
    assert (direct["likely"], direct["likely_failed"], direct["uncertain"], direct["unlikely"]) == (2, 1, 1, 1)


def test_the_settings_with_a_constraint_set_are_counted_alone_too():
    cap = {"band_constraints": {"f_cap": 5.0}}
    rows = [_row(0, "direct", "likely", True),                                              # unconstrained
            _row(1, "direct", "likely", False, **cap), _row(1, "amortized", "unlikely", True, **cap),
            _row(2, "direct", "likely", True, **cap), _row(3, "direct", "unlikely", False, **cap)]
    s = summarise_band(rows, ("amortized", "direct"))
    alone = s["constrained_only"]
    assert (s["constrained"], s["to_run"]["likely"], s["to_run"]["likely_failed"]) == (3, 3, 1)
    assert alone["to_run"] == {"likely": 2, "likely_failed": 1, "likely_failed_bound_pct": pytest.approx(100 * 0.95 ** 0.5),
                               "some_succeeded": 2, "likely_and_succeeded": 1, "none_succeeded": 1,
                               "likely_where_none_succeeded": 0}
    assert [(d["method"], d["plans"], d["likely"]) for d in alone["planners"]] == [("amortized", 1, 0), ("direct", 3, 2)]
    page = markdown_band(s, "t", "cmd")
    assert "#### The 3 settings with a constraint set alone" in page and page.count("| direct | ") == 2


def _evidence_calibration(tmp_path, capsys):
    """A calibration file without calibrators (every p the judge's own), with held-out evidence built so
    that p >= 0.95 holds a 2 % risk, 0.5 a 6 % one and no threshold 0.1 %: 200 clean plans at p 0.996,
    10 failures in 100 at p 0.92, drawn over q̇_max 0.3-0.9 at f_max 20 and the paper's environments."""
    from judgeopt.judge.store import load_judge
    from judgeopt.verdict.calibration import save_calibration

    sha = load_judge(resolve("models/judge_refined"))[1]["weights_sha256"]
    rows = ([{"method": "direct", "judge_sha256": sha, "predicted_success": 0.996, "simulated_success": True,
              "max_constraint_violation": 0.0, "environment": {"y_obj": 0.1 + k * 0.0009, "mu": 1.0 + k * 0.01},
              "limits": {"qdot_max": 0.3 + k * 0.003, "f_max": 20.0}} for k in range(200)]
            + [{"method": "direct", "judge_sha256": sha, "predicted_success": 0.92, "simulated_success": k >= 10,
                "max_constraint_violation": 0.0, "environment": {"y_obj": 0.2, "mu": 2.0},
                "limits": {"qdot_max": 0.5, "f_max": 20.0}} for k in range(100)])
    (tmp_path / "band" / "partial").mkdir(parents=True)
    (tmp_path / "band" / "partial" / "chunk.json").write_text(json.dumps(rows))
    cal = save_calibration(tmp_path / "cal.json", {})
    assert main(["calibrate", "--evidence", str(tmp_path / "band"), "--out", str(cal)]) == 0
    assert "likely at p >= 0.95: of 200 held-out plans of direct with the judge's own p there, 0 failed" in capsys.readouterr().out
    return cal


def test_calibrate_stores_held_out_evidence_that_solve_reads(tmp_path, capsys):
    from judgeopt.verdict.calibration import load_calibration_file

    from judgeopt.judge.store import load_judge
    from judgeopt.verdict.risk import evidence_key

    cal = _evidence_calibration(tmp_path, capsys)
    ev = load_calibration_file(cal)[1][evidence_key("direct", load_judge(resolve("models/judge_refined"))[1]["weights_sha256"],
                                                kind="judge")]
    assert ev.ranges["qdot_max"] == [0.3, pytest.approx(0.897)] and ev.sources == [str(tmp_path / "band")]
    base = ["solve", "--method", "direct", "--json", "--no-simulate", "--calibration", str(cal), "--f-max", "20"]
    for risk, likely_at in (("0.02", 0.95), ("0.06", 0.5), ("0.001", None)):
        main([*base, "--qdot-max", "0.6", "--risk", risk])
        (r,) = json.loads(capsys.readouterr().out)["results"]
        assert r["likely_at"] == likely_at and r["risk"]["risk"] == float(risk)
        assert r["verdict"] == ("unlikely" if r["success_probability"] < 0.5 else
                                "likely" if likely_at is not None and r["success_probability"] >= likely_at else
                                "uncertain")
    main([*base, "--qdot-max", "1.0"])  # beyond the q̇_max the evidence was drawn over: unchecked
    (r,) = json.loads(capsys.readouterr().out)["results"]
    assert r["likely_at"] == 0.95 and "unchecked here" in r["risk"]["evidence"]  # held to the threshold inside


def test_each_arms_evidence_is_its_own_and_names_only_its_own_folder(tmp_path, capsys):
    """Two folders, the UR5's and the Kinova's: 200 clean plans at p 0.996 on the UR5 (p >= 0.95 then holds a
    2 % risk, bound 1.5 %), and on the Kinova 20 failures in 200 at the same p (bound above 13 %: no threshold
    holds it). Solve on the Kinova reads the Kinova's and is never likely; each key's sources are its folder."""
    from judgeopt.judge.store import load_judge
    from judgeopt.verdict.calibration import load_calibration_file
    from judgeopt.verdict.risk import evidence_key

    sha = load_judge(resolve("models/judge_refined"))[1]["weights_sha256"]

    def rows(robot, failures):
        return [{"method": "direct", "judge_sha256": sha, "robot": robot, "predicted_success": 0.996,
                 "simulated_success": k >= failures, "max_constraint_violation": 0.0,
                 "environment": {"y_obj": 0.1 + k * 0.0009, "mu": 1.0 + k * 0.01},
                 "limits": {"qdot_max": 0.3 + k * 0.0035, "f_max": 22.5}} for k in range(200)]

    for name, robot, failures in (("ur5", "ur5", 0), ("kinova", "kinova", 20)):
        (tmp_path / name / "partial").mkdir(parents=True)
        (tmp_path / name / "partial" / "chunk.json").write_text(json.dumps(rows(robot, failures)))
    cal = tmp_path / "cal.json"
    cal.write_bytes(resolve("models/calibration_default.json").read_bytes())
    assert main(["calibrate", "--evidence", str(tmp_path / "ur5"), str(tmp_path / "kinova"), "--out", str(cal)]) == 0
    out = capsys.readouterr().out
    assert "evidence, direct with the judge's own p on kinova (200 plans" in out and "no threshold holds a 2 % risk" in out
    evidence = load_calibration_file(cal)[1]
    ur5, kinova = evidence[evidence_key("direct", sha, kind="judge")], evidence[evidence_key("direct", sha, "kinova", "judge")]
    assert (ur5.sources, ur5.robots, ur5.at(0.02)["threshold"]) == ([str(tmp_path / "ur5")], ["ur5"], 0.5)
    assert (kinova.sources, kinova.robots, kinova.at(0.02)) == ([str(tmp_path / "kinova")], ["kinova"], None)
    # no plan had a calibrated p: that kind's evidence names no folder, and is never likely
    none = evidence[evidence_key("direct", sha, kind="calibrated")]
    assert (none.plans, none.sources, none.at(0.5)) == (0, [], None)
    main(["solve", "--robot", "kinova", "--method", "direct", "--json", "--no-simulate", "--calibration", str(cal),
          "--qdot-max", "0.4"])
    (r,) = json.loads(capsys.readouterr().out)["results"]
    assert r["likely_at"] is None and r["verdict"] != "likely" and "direct" in r["risk"]["evidence"]


@pytest.mark.parametrize("risk", ["0", "1", "nan", "2 %"])
def test_a_risk_that_is_not_a_rate_is_one_line(risk, capsys):
    with pytest.raises(SystemExit) as exit:
        main(["solve", "--risk", risk, "--no-simulate"])
    assert exit.value.code == 2
    err = capsys.readouterr().err.splitlines()[-1] + "\n"  # argparse's usage line, then the one line
    assert err.count("\n") == 1 and "--risk" in err


def test_calibrate_refuses_evidence_the_calibration_was_fitted_on(tmp_path, capsys):
    """A calibration's own outcomes would be evidence that agrees with its map by construction."""
    rows = [{"method": "direct", "setting": "s1", "family": "s1", "setting_description": "direct",
             "predicted_success": 0.5 + k / 200, "simulated_success": k % 3 != 0, "max_constraint_violation": 0.0,
             "environment": {"y_obj": 0.1 + k / 500, "mu": 1.0 + k / 50}, "limits": {"qdot_max": 0.5}}
            for k in range(60)]
    (tmp_path / "fit" / "partial").mkdir(parents=True)
    (tmp_path / "fit" / "partial" / "chunk.json").write_text(json.dumps(rows))
    cal = tmp_path / "cal.json"
    assert main(["calibrate", str(tmp_path / "fit"), "--out", str(cal)]) == 0
    capsys.readouterr()
    assert main(["calibrate", "--evidence", str(tmp_path / "fit"), "--out", str(cal)]) == ExitCode.BAD_INPUT
    assert "60 of its 60 plans are at environments and limits the calibration was fitted on" in capsys.readouterr().err


@pytest.mark.slow
def test_a_small_band_plans_replays_reports_and_resumes(tmp_path, capsys):
    """Two settings, every default planner, replayed; a rerun plans nothing again."""
    out = tmp_path / "band"
    argv = ["evaluate", "band", "--n", "2", "--chunk", "1", "--jobs", "1", "--seed", "5", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    rows = [r for p in sorted((out / "partial").glob("*.json")) for r in json.loads(p.read_text())]
    assert sorted((r["env_index"], r["method"]) for r in rows) == [(0, "amortized"), (0, "direct"),
                                                                   (1, "amortized"), (1, "direct")]
    problem = load_problem(resolve("problems/paper_sim.toml"))
    for r in rows:  # each at its own drawn setting, replayed, with its plan's samples
        drawn = draw_setting(problem, default_band(problem.task), 5, r["env_index"])
        assert r["environment"] == drawn["environment"] and r["band_limits"] == drawn["limits"]
        assert all(r["limits"][k] == v for k, v in drawn["limits"].items())
        assert isinstance(r["simulated_success"], bool) and len(r["t"]) == problem.steps + 1
    summary = json.loads((out / "band.json").read_text())
    assert summary["settings"] == 2 and [s["plans"] for s in summary["planners"]] == [2, 2]
    assert (out / "band.md").exists() and (out / "band.png").stat().st_size > 10_000
    stamps = {p: p.stat().st_mtime_ns for p in (out / "partial").glob("*.json")}
    capsys.readouterr()
    assert main(argv) == 0  # resumed: every chunk read back, none planned again
    assert {p: p.stat().st_mtime_ns for p in (out / "partial").glob("*.json")} == stamps


@pytest.mark.slow
def test_a_sweep_counts_verdicts_at_the_risk_its_evidence_sets(tmp_path, capsys):
    """`evaluate sweep` (like edge and the tables) re-scores cached plans with the calibration's
    evidence: at a risk no threshold holds, no plan is 'likely', so the verdict is right exactly where
    a plan failed; at p >= 0.5 (risk 6 %) it is right where 'p >= 0.5 and held' matches the outcome."""
    cal = _evidence_calibration(tmp_path, capsys)
    out = tmp_path / "sweep"
    argv = ["evaluate", "sweep", "--limits", "qdot_max=0.6,f_max=20", "--n", "3", "--methods", "direct",
            "--no-baselines", "--calibration", str(cal), "--jobs", "1", "--quiet", "--out", str(out)]
    accuracy = {}
    for risk in ("0.001", "0.06"):
        assert main([*argv, "--risk", risk]) == 0
        (row,) = [r for r in csv.DictReader((out / "sweep.csv").open()) if r["method"] == "direct"]
        accuracy[risk] = float(row["verdict_accuracy_pct"])
    rows = [r for p in (out / "partial").glob("*.json") for r in json.loads(p.read_text()) if r.get("method") == "direct"]
    assert len(rows) == 3 and any(r["success_probability"] >= 0.5 for r in rows)  # 'likely' at p >= 0.5 somewhere
    failed = [not r["simulated_success"] for r in rows]
    assert accuracy["0.001"] == pytest.approx(100 * sum(failed) / 3)
    right = [(r["success_probability"] >= 0.5 and r["max_constraint_violation"] <= HOLD_TOL) == r["simulated_success"]
             for r in rows]
    assert accuracy["0.06"] == pytest.approx(100 * sum(right) / 3)
