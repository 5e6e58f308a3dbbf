"""A request turned into what solve plans, without a server: the problems a server may be given
besides the shipped ones, and what a prepared request holds."""

from __future__ import annotations

import pytest

from judgeopt.planners.problem import ProblemError
from judgeopt.serve.request import InfeasibleRequest, PreparedRequests, prepare, problem_files
from judgeopt.serve.schema import PlanRequest


def test_a_problem_file_given_to_the_server_is_planned_by_its_name(tmp_path):
    mine = tmp_path / "slow_scoop.toml"
    mine.write_text('base = "problems/paper_sim.toml"\n[limits]\nqdot_max = 0.3\n')
    problems = problem_files([str(mine)])
    assert problems["slow_scoop"] == mine.resolve() and "paper_sim" in problems
    prepared = prepare(PlanRequest(problem="slow_scoop"), problems)
    assert prepared.problem.qdot_max == 0.3 and prepared.methods == ("default",)
    with pytest.raises(ProblemError, match="not one this server plans"):
        prepare(PlanRequest(problem="slow_scoop"), problem_files())


def test_a_file_named_as_a_shipped_problem_is_refused(tmp_path):
    (tmp_path / "paper_sim.toml").write_text('base = "problems/paper_sim.toml"\n')
    with pytest.raises(ProblemError, match="already served"):
        problem_files([str(tmp_path / "paper_sim.toml")])


def test_a_range_is_planned_over_and_a_value_is_not():
    prepared = prepare(PlanRequest(environment={"y_obj": [0.15, 0.2], "mu": 2.5}), problem_files())
    assert prepared.ranges == {"y_obj": (0.15, 0.2)}
    assert prepared.problem.nominal_env()["mu"] == 2.5


def test_a_request_asked_again_is_prepared_once_and_an_error_every_time():
    kept = PreparedRequests(problem_files(), size=2)
    ask = PlanRequest(limits={"qdot_max": 0.4}, methods=["direct"]).model_dump()
    first = kept.get(ask)
    assert first == prepare(PlanRequest.model_validate(ask), problem_files())
    assert kept.get({**ask, "timeout_s": 9.0}) is first  # its deadline changes nothing planned
    assert kept.get({**ask, "limits": {**ask["limits"], "qdot_max": 0.3}}).problem.qdot_max == 0.3
    assert first.planners_key != kept.get({**ask, "limits": {**ask["limits"], "qdot_max": 0.3}}).planners_key
    moved = kept.get({**ask, "environment": {"y_obj": 0.23}})  # the same planners, in another environment
    assert moved.problem.nominal_env()["y_obj"] == 0.23 and moved.planners_key == first.planners_key
    infeasible = {**ask, "limits": {**ask["limits"], "qdot_max": 0.05}}
    for _ in range(2):
        with pytest.raises(InfeasibleRequest):
            kept.get(infeasible)
    kept.get({**ask, "methods": ["amortized"]})  # the third kept: the least recently asked is dropped
    assert len(kept.kept) == 2 and kept.get(ask) is not first
