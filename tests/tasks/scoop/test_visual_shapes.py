"""Simulators for planning skip the arm's meshes (most of a scene's build); only a camera needs them."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.tasks import get_task
from judgeopt.tasks.scoop.commands import random_command
from judgeopt.tasks.scoop.rollout import Simulator


def test_the_physics_never_reads_the_meshes_a_rollout_is_bit_identical_without_them():
    plan = random_command(np.random.default_rng(3), 0.2)
    runs = [Simulator(visual_shapes=v).run(plan, 0.2, 2.0) for v in (True, False)]
    assert np.array_equal(runs[0].as_array(), runs[1].as_array())
    assert runs[0].info["object_end"] == runs[1].info["object_end"] and runs[0].success == runs[1].success


def test_planning_simulators_skip_the_meshes_and_rendering_asks_for_them(tmp_path):
    from judgeopt.tasks.scoop.render import render_rollout

    task = get_task("scoop")
    assert not task.simulator().scene.visual_shapes and task.simulator(render=True).scene.visual_shapes
    plan = random_command(np.random.default_rng(3), 0.2)
    with pytest.raises(ValueError, match="render=True"):
        render_rollout(task.simulator(), plan, 0.2, 2.0, tmp_path / "x.gif")
