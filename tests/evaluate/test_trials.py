"""Repeated trials: each draws its own world within the spread, seeded; a plan that cannot
succeed fails every trial."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.evaluate.trials import TrialSpread, trials
from judgeopt.tasks import get_task
from judgeopt.tasks.base import TaskError


def test_each_trial_draws_within_the_spread_and_the_draws_are_seeded():
    task = get_task("scoop")
    rng = np.random.default_rng(0)
    draws = [TrialSpread().draw(task, rng) for _ in range(200)]
    assert set(task.trial_spread) == {"y_obj_offset", "mu_factor", "mass_factor", "sensor_noise"}  # the task's own
    for name, w in task.trial_spread.items():
        v = np.array([d[name] for d in draws])
        lo, hi = (1 - w, 1 + w) if name.endswith("_factor") else (0, w) if name.endswith("_noise") else (-w, w)
        assert lo <= v.min() and v.max() <= hi and np.ptp(v) > 0.8 * (hi - lo)  # spread over the whole range
    again = [TrialSpread().draw(task, np.random.default_rng(0)) for _ in range(1)]
    assert again[0] == draws[0]
    with pytest.raises(TaskError):
        TrialSpread({"warp_factor": 0.1}).draw(task, rng)
    assert TrialSpread.of("scoop").widths == dict(task.trial_spread) == TrialSpread.of(task).widths


def test_a_task_that_declares_no_spread_tries_its_nominal_world_and_its_report_says_so():
    from judgeopt.evaluate.trials import markdown_trials
    from judgeopt.tasks.base import Task

    class Still(Task):
        perturbations = ()
        random_command = simulator = None

    assert TrialSpread().draw(Still(), np.random.default_rng(0)) == {}
    assert "every trial in the nominal world" in markdown_trials([], "t", TrialSpread.of(Still()))
    with pytest.raises(ValueError, match="TrialSpread.of"):
        markdown_trials([], "t", TrialSpread())


@pytest.mark.slow
def test_a_plan_that_never_reaches_the_object_fails_every_trial():
    task = get_task("scoop")
    still = task.plan(np.tile([[-0.03, 0.0, 10.0]], (31, 1)))  # pressing in place, never under the object
    out = trials(task, still, {"y_obj": 0.19, "mu": 2.0}, n=3, seed=1)
    assert [o.success for _, o in out] == [False] * 3 and len({tuple(d.values()) for d, _ in out}) == 3
