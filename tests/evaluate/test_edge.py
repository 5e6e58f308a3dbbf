"""`judgeopt evaluate edge`: the edge found by bisection, the settings around it, and the counts
that check a printed probability where outcomes flip."""

from __future__ import annotations

import json

import pytest

from judgeopt.cli import main
from judgeopt.evaluate import edge as edge_mod
from judgeopt.evaluate.edge import EdgeConfig, edge_direction, find_edge, settings_around, summarise_edge
from judgeopt.files import resolve
from judgeopt.planners.problem import ProblemError, load_problem

PROBLEM = load_problem(resolve("problems/paper_sim.toml"))
ENV = {"y_obj": 0.2, "mu": 2.0}


def _search_found_above(threshold: float, limit: str, easier: int):
    """A feasibility search that finds a success exactly where the limit is at least as easy as `threshold`."""
    calls = []

    def search(problem, env, sim, seed, cfg):
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
    found = find_edge(PROBLEM, ENV, None, 0, cfg)["edge"]
    # on the easy side of the threshold, within the resolution
    assert 0 <= (found - threshold) * easier <= 0.05
    assert len(calls) <= 2 + 10  # the two ends, then halving a span of at most 30 to 0.05


def test_no_edge_when_the_easy_end_fails_and_the_hard_end_when_it_succeeds(monkeypatch):
    cfg = EdgeConfig(span=(12.0, 16.0))
    monkeypatch.setattr(edge_mod, "search", _search_found_above(99.0, "f_max", 1)[0])
    assert find_edge(PROBLEM, ENV, None, 0, cfg)["edge"] is None
    monkeypatch.setattr(edge_mod, "search", _search_found_above(0.0, "f_max", 1)[0])
    out = find_edge(PROBLEM, ENV, None, 0, cfg)
    assert out["edge"] == 12.0 and out["below_span"]


def test_settings_lie_around_the_edge_and_leave_out_limits_that_contradict_the_problem():
    cfg = EdgeConfig(offsets=(-2.0, 0.0, 1.0))
    assert settings_around(PROBLEM, 14.0, cfg) == [(-2.0, 12.0), (0.0, 14.0), (1.0, 15.0)]
    # f_max = 7.0 would lie below f_min = 7.5: left out
    assert settings_around(PROBLEM, 9.0, cfg) == [(0.0, 9.0), (1.0, 10.0)]
    # f_min: the easier side is lower
    assert settings_around(PROBLEM, 5.0, EdgeConfig(limit="f_min", offsets=(-1.0, 1.0))) == [(-1.0, 6.0), (1.0, 4.0)]
    # no edge found: only below the easy end, where every plan should be called unlikely
    assert settings_around(PROBLEM, None, EdgeConfig(span=(11.0, 20.0), offsets=(-1.0, 0.0, 1.0))) == [(-1.0, 19.0)]


def test_an_unknown_limit_or_a_task_without_a_feasibility_search_is_one_line(monkeypatch):
    with pytest.raises(ProblemError, match="--edge-limit q_min: choose one of"):
        edge_direction(PROBLEM, EdgeConfig(limit="q_min"))
    from judgeopt.tasks import get_task

    monkeypatch.setattr(type(get_task("scoop")), "graded_outcome", False)
    with pytest.raises(ProblemError, match="has no feasibility search"):
        edge_direction(PROBLEM, EdgeConfig())


def _row(env, off, method, verdict, p, sim, source="calibrated"):
    return {"env_index": env, "offset": off, "edge": 14.0, "method": method, "verdict": verdict,
            "success_probability": p, "simulated_success": sim, "probability_source": source}


def test_summary_counts_likely_failures_and_overall_likely_where_none_succeeded():
    rows = [_row(0, 0.0, "amortized", "likely", 0.9, False), _row(0, 0.0, "direct", "unlikely", 0.3, False),
            _row(0, 1.0, "amortized", "likely", 0.95, True), _row(0, 1.0, "direct", "likely", 0.8, True),
            _row(1, 0.0, "amortized", "unlikely", 0.2, True), _row(1, 0.0, "direct", "unlikely", 0.1, False),
            _row(1, 1.0, "amortized", "outside the judge's data", 0.99, False, "judge"),
            _row(1, 1.0, "direct", "unlikely", 0.4, False)]
    s = summarise_edge(rows, ("amortized", "direct"))
    am, di = s["planners"]
    assert (am["plans"], am["likely"], am["likely_failed"], am["unlikely_succeeded"], am["outside_judge_data"]) == (
        4, 2, 1, 1, 1)
    assert am["likely_failed_pct"] == 50.0 and am["calibrated"] == 3
    assert (di["likely"], di["likely_failed"], di["unlikely"], di["unlikely_succeeded"]) == (1, 0, 3, 0)
    # settings where no plan succeeded: (0, 0.0) says likely (the amortised plan's p 0.9), (1, 1.0) unlikely
    assert (s["settings"], s["none_succeeded"], s["likely_where_none_succeeded"]) == (4, 2, 1)
    # ECE by hand over 10 equal bins: direct's p 0.3, 0.8, 0.1, 0.4 against 0, 1, 0, 0
    assert di["ece"] == pytest.approx((0.3 + 0.2 + 0.1 + 0.4) / 4)


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
