"""The scrape's perturbed worlds: in-place changes equal a scene built with them, a misestimated
puck is replayed where it truly lies, and friction misestimated the other way decides."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from judgeopt.tasks import get_task
from judgeopt.tasks.scrape.scene import STIFF, PuckGeometry, ScrapeConfig, ScrapeSimulator
from test_scrape import straight

TASK = get_task("scrape")
ENV = {"x_obj": 0.27, "y_obj": 0.13, "mu": 0.3}


@pytest.fixture(scope="module")
def world():
    sim = TASK.simulator()
    yield sim
    sim.close()


def _same(a, b, atol=0.0):
    assert a.success == b.success
    np.testing.assert_allclose(a.response, b.response, rtol=0, atol=atol)
    np.testing.assert_allclose(a.details["puck_end"], b.details["puck_end"], rtol=0, atol=max(atol, 1e-12))


@pytest.mark.parametrize("values, config", [
    ({"mass_factor": 2.0}, ScrapeConfig(puck=PuckGeometry(mass=2.0))),
    ({"kp_factor": 0.5}, ScrapeConfig(controller=dataclasses.replace(STIFF, kp=(1e4, 1e4, 1000.0, 1e4, 1e4, 1e4)))),
])
def test_a_perturbation_changed_in_place_is_the_scene_built_with_it(world, values, config):
    fresh = ScrapeSimulator(config)
    try:
        expected = fresh.simulate(straight(12.0), ENV)
    finally:
        fresh.close()
    world.perturb(values)
    try:
        got = world.simulate(straight(12.0), ENV)
    finally:
        world.perturb({})
    _same(got, expected, atol=1e-9)


def test_the_puck_is_where_it_truly_lies_and_its_true_friction_decides(world):
    plain = ScrapeSimulator()
    try:
        world.perturb({"x_obj_offset": 0.02, "y_obj_offset": -0.01})
        true = TASK.true_env(ENV, world.world)
        assert true == pytest.approx({"x_obj": 0.29, "y_obj": 0.12, "mu": 0.3}, abs=1e-15)
        # (the exact float: the heel's chatter makes a 1e-17 m shift of the puck a different rollout)
        _same(world.simulate(straight(12.0), ENV), plain.simulate(straight(12.0), true))
        # 12 N pushes a puck at mu 0.3 and not at mu 0.6 (docs/tasks.md): told 0.3, the world has 0.6
        world.perturb({})
        assert world.simulate(straight(12.0), ENV).success
        world.perturb({"mu_factor": 2.0})
        assert not world.simulate(straight(12.0), ENV).success
    finally:
        world.perturb({})
        plain.close()
