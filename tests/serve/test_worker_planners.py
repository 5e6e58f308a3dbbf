"""A worker keeps its loaded planners by what a request asks for: the same request again chooses
no models (no generator metadata read) and loads nothing; another set of planners, or another
problem, loads its own, and the least recently used is dropped beyond the cache's size."""

from __future__ import annotations

from judgeopt.serve.request import problem_files
from judgeopt.serve.schema import PlanRequest
from judgeopt.serve.worker import Planning, WorkerOptions
from judgeopt.session import solve as session


def request(**fields) -> dict:
    return PlanRequest(problem="paper_sim", **fields).model_dump()


def test_a_request_asked_again_chooses_and_loads_nothing(monkeypatch):
    planning = Planning(WorkerOptions(problem_files(), "models", (), cache=2))
    chosen, loads = [], []
    real = session.methods_for
    monkeypatch.setattr(session, "methods_for", lambda *a, **k: chosen.append(a[1]) or real(*a, **k))

    def planners(fields: dict):
        return planning.planners(planning.prepared.get(request(**fields)), loads.append)

    first = planners({"limits": {"qdot_max": 0.4}})
    again = planners({"limits": {"qdot_max": 0.4}, "timeout_s": 5.0})
    assert (chosen, len(loads)) == (["default"], 1)
    assert again.built is first.built and again.methods == ("amortized", "direct")

    moved = planners({"limits": {"qdot_max": 0.4}, "environment": {"y_obj": 0.2}})  # same planners, new place
    assert len(loads) == 1 and moved.built is first.built and moved.problem.environment["y_obj"] == 0.2

    planners({"limits": {"qdot_max": 0.4}, "methods": ["direct"]})  # another set: its own planners
    planners({"limits": {"qdot_max": 0.5}})  # other limits: their own, and the cache of 2 drops the first
    assert len(loads) == 3 and len(planning.loaded) == 2
    assert planners({"limits": {"qdot_max": 0.4}}).built is not first.built and len(loads) == 4
