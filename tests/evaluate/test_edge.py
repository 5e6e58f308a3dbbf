"""`judgeopt evaluate edge`: the edge found by bisection, the settings around it, and the counts
that check a printed probability where outcomes flip."""

from __future__ import annotations

import json

import pytest

from judgeopt.cli import main
from judgeopt.evaluate import edge as edge_mod
from judgeopt.evaluate.edge import (EdgeConfig, edge_direction, find_edge, markdown_edge, plot_edge, settings_around,
                                   summarise_edge)
from judgeopt.files import resolve
from judgeopt.planners.problem import ProblemError, load_problem

PROBLEM = load_problem(resolve("problems/paper_sim.toml"))
ENV = {"y_obj": 0.2, "mu": 2.0}


def _search_found_above(threshold: float, limit: str, easier: int):
    """A feasibility search that finds a success exactly where the limit is at least as easy as `threshold`."""
    calls = []

    def search(problem, env, sim, seed, cfg):
        assert env == ENV and sim == "sim" and seed == 7 and cfg == EdgeConfig().search
        v = getattr(problem, limit)
        calls.append(v)
        ok = v >= threshold if easier > 0 else v <= threshold
        return {"status": "found" if ok else "not_found", "tries": 1 if ok else 48}

    return search, calls


@pytest.mark.parametrize("limit,threshold,easier", [("f_max", 14.2, 1), ("qdot_max", 0.61, 1), ("f_min", 5.3, -1)])
def test_the_edge_is_the_first_value_where_the_search_finds_a_success(monkeypatch, limit, threshold, easier):
    search, calls = _search_found_above(threshold, limit, easier)
    monkeypatch.setattr(edge_mod, "search", search)
    cfg = EdgeConfig(limit=limit, resolution=0.05)
    assert edge_direction(PROBLEM, cfg)[0] == easier
    found = find_edge(PROBLEM, ENV, "sim", 7, cfg)["edge"]
    # on the easy side of the threshold, within the resolution
    assert 0 <= (found - threshold) * easier <= 0.05
    assert len(calls) <= 2 + 10  # the two ends, then halving a span of at most 30 to 0.05
    probes = find_edge(PROBLEM, ENV, "sim", 7, cfg)["probes"]
    assert [p["value"] for p in probes] == calls[len(calls) // 2:]
    assert all(p["found"] == ((p["value"] - threshold) * easier >= 0) and p["tries"] == (1 if p["found"] else 48)
               for p in probes)


def test_no_edge_when_the_easy_end_fails_and_the_hard_end_when_it_succeeds(monkeypatch):
    cfg = EdgeConfig(span=(12.0, 16.0))
    monkeypatch.setattr(edge_mod, "search", _search_found_above(99.0, "f_max", 1)[0])
    assert find_edge(PROBLEM, ENV, "sim", 7, cfg)["edge"] is None
    monkeypatch.setattr(edge_mod, "search", _search_found_above(0.0, "f_max", 1)[0])
    out = find_edge(PROBLEM, ENV, "sim", 7, cfg)
    assert out["edge"] == 12.0 and out["below_span"] and [p["value"] for p in out["probes"]] == [16.0, 12.0]
    # a span whose hard end contradicts f_min = 7.5: that probe finds nothing and costs no rollout
    out = find_edge(PROBLEM, ENV, "sim", 7, EdgeConfig(span=(5.0, 16.0)))
    assert out["probes"][1] == {"value": 5.0, "found": False, "tries": 0} and 7.5 <= out["edge"] <= 7.5 + 1.0


def test_settings_lie_around_the_edge_and_leave_out_limits_that_contradict_the_problem():
    cfg = EdgeConfig(offsets=(-2.0, 0.0, 1.0))
    assert settings_around(PROBLEM, 14.0, cfg) == [(-2.0, 12.0), (0.0, 14.0), (1.0, 15.0)]
    # f_max = 7.0 would lie below f_min = 7.5: left out
    assert settings_around(PROBLEM, 9.0, cfg) == [(0.0, 9.0), (1.0, 10.0)]
    # f_min: the easier side is lower
    assert settings_around(PROBLEM, 5.0, EdgeConfig(limit="f_min", offsets=(-1.0, 1.0))) == [(-1.0, 6.0), (1.0, 4.0)]
    # no edge found: only below the easy end, where every plan should be called unlikely
    assert settings_around(PROBLEM, None, EdgeConfig(span=(11.0, 20.0), offsets=(0.0, 1.0, -1.0))) == [(-1.0, 19.0)]


def test_an_unknown_limit_or_a_task_without_a_feasibility_search_is_one_line(monkeypatch):
    with pytest.raises(ProblemError, match="--edge-limit q_min: choose one of"):
        edge_direction(PROBLEM, EdgeConfig(limit="q_min"))
    from judgeopt.tasks import get_task

    monkeypatch.setattr(type(get_task("scoop")), "wide_limits", {"qdot_max": (0.2, 1.0)})
    with pytest.raises(ProblemError, match="declares no wide range of f_max: give --edge-span"):
        edge_direction(PROBLEM, EdgeConfig())
    assert edge_direction(PROBLEM, EdgeConfig(span=(11.0, 20.0)))[1] == (11.0, 20.0)
    monkeypatch.setattr(type(get_task("scoop")), "graded_outcome", False)
    with pytest.raises(ProblemError, match="has no feasibility search"):
        edge_direction(PROBLEM, EdgeConfig())


def _row(env, off, method, verdict, p, sim, source="calibrated", qdot_max=0.4):
    return {"env_index": env, "offset": off, "edge": 14.0, "method": method, "verdict": verdict,
            "success_probability": p, "simulated_success": sim, "probability_source": source,
            "environment": {"y_obj": 0.1 + 0.01 * env, "mu": 2.0}, "edge_limit": "f_max",
            "limits": {"qdot_max": qdot_max, "f_max": 14.0 + off}}


def test_summary_counts_likely_failures_and_overall_likely_where_none_succeeded():
    rows = [_row(0, 0.0, "amortized", "likely", 0.9, False), _row(0, 0.0, "direct", "unlikely", 0.3, False),
            _row(0, 1.0, "amortized", "likely", 0.95, True), _row(0, 1.0, "direct", "likely", 0.8, True),
            _row(1, 0.0, "amortized", "unlikely", 0.2, True), _row(1, 0.0, "direct", "unlikely", 0.1, False),
            _row(1, 1.0, "amortized", "outside the judge's data", 0.99, False, "judge"),
            _row(1, 1.0, "direct", "unlikely", 0.4, False), _row(2, 0.0, "direct", "likely", 0.7, True),
            {**_row(2, 1.0, "direct", None, None, None), "status": "not planned"}]  # no verdict: not counted
    rows[-2]["edge"] = rows[-1]["edge"] = None  # environment 2: no edge found there
    rows.insert(0, {"method": None, "env_index": 3, "environment": {"y_obj": 0.2, "mu": 2.0}, "status": "skipped",
                    "edge": None, "offset": 0.0})  # a setting no planner could plan at, first
    s = summarise_edge(rows, ("amortized", "direct"))
    am, di = s["planners"]
    assert {k: v for k, v in am.items() if k not in ("reliability", "ece", "mean_p")} == {
        "method": "amortized", "plans": 4, "successes": 2, "likely": 2, "likely_failed": 1, "likely_failed_pct": 50.0,
        "unlikely": 1, "unlikely_succeeded": 1, "outside_judge_data": 1, "breaks_limits": 0, "calibrated": 3,
        "success_pct": 50.0, "uncertain": 0, "likely_failed_bound_pct": pytest.approx(100 * 0.95 ** 0.5)}  # 1 of 2: 1 - u² = 0.05
    broken = summarise_edge([_row(0, 0.0, "amortized", "breaks a hard limit", 0.97, False)], ("amortized",))
    assert broken["planners"][0]["breaks_limits"] == 1 and broken["planners"][0]["outside_judge_data"] == 0
    assert broken["planners"][0]["likely"] == 0
    assert am["mean_p"] == pytest.approx((0.9 + 0.95 + 0.2 + 0.99) / 4)
    assert (di["plans"], di["successes"], di["likely"], di["likely_failed"], di["unlikely"], di["unlikely_succeeded"]) == (
        5, 2, 2, 0, 3, 0)
    assert di["likely_failed_pct"] == 0.0 and di["success_pct"] == 40.0
    # ECE by hand over 10 equal bins: direct's p 0.3, 0.8, 0.1, 0.4, 0.7 against 0, 1, 0, 0, 1
    assert di["ece"] == pytest.approx((0.3 + 0.2 + 0.1 + 0.4 + 0.3) / 5)
    assert [(c["lo"], c["n"], c["observed"]) for c in di["reliability"]] == [
        (pytest.approx(0.0), 1, 0.0), (pytest.approx(0.2), 1, 0.0), (pytest.approx(0.3), 1, 0.0),
        (pytest.approx(0.6), 1, 1.0), (pytest.approx(0.7), 1, 1.0)]
    # settings where no plan succeeded: (0, 0.0) says likely (the amortised plan's p 0.9), (1, 1.0) unlikely
    assert (s["settings"], s["environments"], s["none_succeeded"], s["likely_where_none_succeeded"]) == (6, 3, 3, 1)
    assert (s["edges_found"], s["edge_values"]) == (2, [14.0, 14.0])
    # the same environments and offsets under another q̇_max are other settings (sweeps share env indices)
    planned = [r for r in rows if r["method"]]
    again = summarise_edge(planned + [{**r, "limits": {**r["limits"], "qdot_max": 1.0}} for r in planned], ("direct",))
    assert (again["settings"], again["environments"], again["none_succeeded"]) == (12, 6, 6)
    assert summarise_edge([], ("direct",))["planners"][0] == {
        "method": "direct", "plans": 0, "successes": 0, "likely": 0, "likely_failed": 0, "likely_failed_pct": None,
        "unlikely": 0, "unlikely_succeeded": 0, "outside_judge_data": 0, "breaks_limits": 0, "calibrated": 0,
        "mean_p": None, "uncertain": 0, "likely_failed_bound_pct": None,
        "success_pct": None, "ece": None, "reliability": []}


def test_the_report_names_every_figure():
    rows = [_row(0, 0.0, "direct", "likely", 0.9, False), _row(0, 1.0, "direct", "likely", 0.97, True)]
    s = summarise_edge(rows, ("direct",))
    md = markdown_edge(s, "T", "judgeopt evaluate edge --n 1")
    assert "### T" in md and "`judgeopt evaluate edge --n 1`" in md
    # ECE: p 0.9 falls in the bin (0.8, 0.9] (observed 0), 0.97 in (0.9, 1] (observed 1): (0.9 + 0.03) / 2
    assert "| direct | 2 | 1 (50 %) | 2 | 1 (50.0 %) | 0 | 0 | 0 | 0 | 2 | 0.935 | 0.465 |" in md
    assert "1 environments, an edge found in 1 (the limit's value at the edge: 14.0 to 14.0 (median 14.0)); " \
           "2 settings" in md and "said 'likely' in 1 of them" in md
    fig = plot_edge(s, rows, "T")
    assert len(fig.axes) == 2 and fig.axes[1].get_xlabel().startswith("f_max beyond the edge")


@pytest.mark.slow
def test_edge_sweep_end_to_end_resumes_and_writes_the_rows_calibrate_reads(tmp_path, capsys):
    """One environment at a narrow span: the report, a resumed rerun, and rows `calibrate` reads."""
    out = tmp_path / "edge"
    args = ["evaluate", "edge", "--n", "1", "--qdot-max", "0.5", "--edge-span", "13,16", "--offsets=-1,0,1",
            "--jobs", "1", "--chunk", "1", "--out", str(out), "--quiet"]
    assert main(args) == 0
    summary = json.loads((out / "edge.json").read_text())
    assert summary["environments"] == 1 and summary["settings"] >= 2
    assert {p["method"] for p in summary["planners"]} == {"amortized", "direct"}
    assert (out / "edge.png").exists() and "likely' and failed" in (out / "edge.md").read_text()
    (chunk,) = (out / "partial").glob("*.json")
    rows = [r for r in json.loads(chunk.read_text()) if r.get("method")]
    assert all(r["setting"] and r["family"] and "f_max" in r["limits"] and r["predicted_success"] is not None
               and r["simulated_success"] is not None for r in rows)
    assert {r["limits"]["f_max"] for r in rows} == {r["edge_value"] for r in rows}
    before = chunk.stat().st_mtime_ns
    capsys.readouterr()
    assert main(args) == 0 and chunk.stat().st_mtime_ns == before  # resumed: the chunk on disk is reused
    assert main(["evaluate", "edge", "--offsets=1", "--out", str(tmp_path / "x"), "--edge-limit", "q_min"]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--edge-limit q_min: choose one of" in err[0]
    assert main(["evaluate", "sweep", "--offsets=1"]) != 0
    assert "only for `judgeopt evaluate edge`" in capsys.readouterr().err


@pytest.mark.parametrize("table", ["edge", "sweep", "planners"])
def test_an_output_folder_that_is_a_file_is_one_line(tmp_path, capsys, table):
    (tmp_path / "taken").write_text("x")
    with pytest.raises(SystemExit) as exit_:
        main(["evaluate", table, "--out", str(tmp_path / "taken")])
    assert exit_.value.code == 2 and "is a file; give a folder" in capsys.readouterr().err
    assert (tmp_path / "taken").read_text() == "x"
