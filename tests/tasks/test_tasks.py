"""The task registry and what the interface checks for every task."""

from __future__ import annotations

import json

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.tasks import (EnvironmentRangeError, TaskError, get_task, register_task, task_names,
                            unregister_task)
from judgeopt.tasks.base import with_setting
from judgeopt.tasks.scoop import ScoopTask
from judgeopt.trajectory import Channel, PlanError


def test_builtin_tasks_are_listed_with_their_channels(capsys):
    assert {"scoop", "scrape"} <= set(task_names())
    assert main(["tasks", "--json"]) == 0
    tasks = {t["name"]: t for t in json.loads(capsys.readouterr().out)}
    assert [c["name"] for c in tasks["scoop"]["channels"]] == ["y", "ydot", "f"]
    assert tasks["scrape"]["env_names"] == ["x_obj", "y_obj", "mu"]
    assert main(["tasks"]) == 0
    assert "channels: x [m], y [m], xdot [m/s], ydot [m/s], f [N]" in capsys.readouterr().out


def test_unknown_task_and_bad_environment_are_one_line_errors():
    with pytest.raises(TaskError, match="unknown task 'wipe': known tasks are .*scoop"):
        get_task("wipe")
    scoop = get_task("scoop")
    with pytest.raises(TaskError, match="needs environment values mu"):
        scoop.check_env({"y_obj": 0.2})
    with pytest.raises(EnvironmentRangeError, match=r"mu = 9.0 is outside the scoop scene's physical range"):
        scoop.check_env({"y_obj": 0.2, "mu": 9.0})


def test_a_registered_task_replaces_nothing_else():
    class Tiny(ScoopTask):
        name = "tiny"

    register_task("tiny", Tiny)
    try:
        assert "tiny" in task_names() and get_task("tiny").channel_names == ("y", "ydot", "f")
    finally:
        unregister_task("tiny")
    assert "tiny" not in task_names() and "scoop" in task_names()


def test_settings_are_set_by_dotted_name_with_their_type():
    s = get_task("scoop").settings()
    s2 = with_setting(s, "commands.constant_force_share", "0.4")
    assert s2.commands.constant_force_share == 0.4 and s.commands.constant_force_share == 0.0
    assert with_setting(s, "commands.mean_speed", "0.3,0.5").commands.mean_speed == (0.3, 0.5)
    with pytest.raises(TaskError, match="no setting 'nope'"):
        with_setting(s, "commands.nope", "1")
    with pytest.raises(TaskError, match="is a group"):
        with_setting(s, "commands", "1")


def test_a_plan_of_another_task_is_refused_by_the_simulator(sim):
    scrape = get_task("scrape")
    plan = scrape.plan(np.zeros((31, 5)))
    with pytest.raises(PlanError, match="the plan has channels x, y, xdot, ydot, f; the scoop's simulator takes y, ydot, f"):
        sim.simulate(plan, {"y_obj": 0.2, "mu": 2.0})
    with pytest.raises(PlanError, match="a velocity names its position"):
        Channel("v", "m/s", "velocity")
