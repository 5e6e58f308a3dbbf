"""Limit ranges belong to a task: bounded by its demonstrations, checked against its axes, and
read by a calibration one input per axis."""

from __future__ import annotations

import pytest

from judgeopt.files import resolve
from judgeopt.verdict.calibration import inputs
from judgeopt.planners.limits import WIDE_LIMITS, LimitRanges, wide_limits
from judgeopt.planners.problem import ProblemError, load_problem


def test_each_task_has_its_own_wide_ranges():
    scrape = load_problem(resolve("problems/scrape.toml"))
    ranges = wide_limits("scrape")
    ranges.check(scrape)
    assert ranges.task == "scrape" and ranges.qdot_max[1] <= 0.6  # the scrape's demonstrations stop at 0.6 m/s
    with pytest.raises(ProblemError, match="limit ranges of task 'scoop' for a problem of task 'scrape'"):
        WIDE_LIMITS.check(scrape)
    with pytest.raises(ProblemError, match="what the demonstrations cover"):
        LimitRanges(qdot_max=(0.2, 1.0), f_min=(0, 2), f_max=(3, 30), task="scrape")


def test_a_task_is_kept_through_files_and_the_scoops_files_are_unchanged():
    assert "task" not in WIDE_LIMITS.to_dict()
    assert LimitRanges.from_dict(WIDE_LIMITS.to_dict()) == WIDE_LIMITS
    assert LimitRanges.from_dict(wide_limits("scrape").to_dict()) == wide_limits("scrape")


def test_reach_is_checked_on_every_axis():
    problem = load_problem(resolve("problems/scrape.toml")).with_overrides(q_end=[0.44, 0.18])
    with pytest.raises(ProblemError, match="cannot reach q_end"):
        LimitRanges(qdot_max=(0.05, 0.6), f_min=(0, 2), f_max=(3, 30), task="scrape").check(problem)


def test_per_axis_limits_are_one_calibration_input_per_axis():
    values = inputs({"q_min": [0.16, -0.05], "qdot_max": 0.4}, {"mu": 0.5})
    assert values == {"q_min[0]": 0.16, "q_min[1]": -0.05, "qdot_max": 0.4, "mu": 0.5}
