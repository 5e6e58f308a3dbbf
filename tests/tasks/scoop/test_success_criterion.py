"""The scoop's success test on scenes whose outcome is known by construction, not by a planner.

The object is put where the answer is obvious (resting on the blade, or left on the plate while
the tool moves away), the lift's height is chosen so the object's rise falls on a known side of
2.5 cm, and the rise is measured here from the object's pose in PyBullet, not read from the
result. A changed threshold (1.5 or 3.5 cm instead of 2.5) or a test that ignores where the object
ended up fails here, whatever the shipped datasets and notebooks say.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from judgeopt.sim.quiet import pb
from judgeopt.tasks.scoop import scoop_plan
from judgeopt.tasks.scoop.rollout import RolloutConfig, Simulator

#: the rise the success test "rise" asks for, in m (README, docs/physics.md: 2.5 cm)
RISE = 0.025


@pytest.fixture(scope="module")
def own_sim():
    """A simulator of its own: these tests change its rollout settings (lift height, test)."""
    s = Simulator()
    yield s
    s.close()


def still(y: float, force: float, steps: int = 10) -> object:
    """The tool held at y, pressing lightly, for `steps` samples of 50 ms."""
    return scoop_plan(0.05, np.full(steps + 1, y), np.zeros(steps + 1), np.full(steps + 1, force))


def lift_with_object_on_blade(sim: Simulator, lift: float, test: str, at: tuple[float, float] = (0.0, 0.0)
                              ) -> tuple[object, float, float]:
    """The object dropped onto the blade, its centre `at` (x, y) m from the blade's centre, settled
    there, then lifted `lift` m. Returns (result, measured rise of the object's centre, its lowest
    point above the plate)."""
    sim.rollout_config = dataclasses.replace(RolloutConfig(), lift_height=lift, success_test=test)
    sc = sim.scene
    plan = still(0.0, 3.0)
    run = sim.start(plan, 0.25, 2.0)  # the object starts on the plate, well ahead of the blade
    z_start = sc.config.pancake.thickness / 2  # resting on the plate's surface z = 0
    tcp = sim.controller.position.copy()
    pb.resetBasePositionAndOrientation(sc.obj, [tcp[0] + at[0], tcp[1] + at[1], tcp[2] + 0.015 + 0.14 * abs(at[1])],
                                       [0, 0, 0, 1], physicsClientId=sc.client)
    run.advance(plan, plan.horizon)  # 0.5 s: it drops onto the blade and comes to rest
    assert sc.contacts(sc.blade_top) > 0  # on the blade (near its front edge, also on the plate there)
    assert at[1] > 0.03 or not sc.touches_plate()
    r = run.finish()
    p, q = pb.getBasePositionAndOrientation(sc.obj, physicsClientId=sc.client)
    R = np.array(pb.getMatrixFromQuaternion(q)).reshape(3, 3)
    bottom = float(np.min(np.asarray(sc.config.pancake.hull_vertices()) @ R[2]) + p[2])
    return r, float(p[2] - z_start), bottom


@pytest.mark.parametrize("test", ["clear", "rise"])
def test_an_object_resting_on_the_blade_and_lifted_is_a_success(own_sim, test):
    r, rise, bottom = lift_with_object_on_blade(own_sim, 0.05, test)
    assert rise > RISE + 0.005 and bottom > 0.02  # by construction: carried well clear
    assert r.success and r.info["on_blade"] and not r.info["on_plate"]


@pytest.mark.parametrize("test", ["clear", "rise"])
def test_an_object_left_on_the_plate_while_the_tool_moves_away_is_a_failure(own_sim, test):
    own_sim.rollout_config = dataclasses.replace(RolloutConfig(), success_test=test)
    sc = own_sim.scene
    t = np.arange(31) * 0.05
    y = -0.03 - 0.1 * np.clip(t / 1.0, 0, 1)  # backwards, away from the object
    plan = scoop_plan(0.05, y, np.gradient(y, 0.05), np.full(31, 8.0))
    r = own_sim.run(plan, 0.2, 2.0)
    p, _ = pb.getBasePositionAndOrientation(sc.obj, physicsClientId=sc.client)
    assert abs(p[1] - 0.2) < 0.002 and abs(p[2] - sc.config.pancake.thickness / 2) < 0.002  # never touched
    assert not r.success and r.info["on_plate"] and not r.info["on_blade"]


@pytest.mark.parametrize("lift, low, high, success", [
    (0.015, 0.015, RISE, False),  # carried, but risen 1.5-2.5 cm: not enough
    (0.032, RISE, 0.035, True),  # risen 2.5-3.5 cm: enough
])
def test_the_rise_test_asks_for_2_5_cm(own_sim, lift, low, high, success):
    """The same held object, lifted less or more: only the rise decides. Each rise lies at least
    2 mm inside its band, so a threshold of 1.5 or 3.5 cm gives the other answer."""
    r, rise, _ = lift_with_object_on_blade(own_sim, lift, "rise")
    assert low + 0.002 < rise < high - 0.002, rise
    assert r.info["on_blade"] and not r.info["on_plate"] and r.info["success_clear_test"]  # held: the rise decides
    assert r.success is success and r.info["success_rise_test"] is success


@pytest.mark.parametrize("at, success", [
    ((0.0, 0.028), True), ((0.03, 0.0), True),  # carried 2.8-3 cm off centre: within 3.5 cm
    ((0.0, 0.043), False), ((0.043, 0.0), False),  # 4.3 cm off centre: hanging over the blade's edge
])
def test_an_object_carried_off_centre_counts_only_within_3_5_cm(own_sim, at, success):
    """Carried clear of the plate either way; the test asks that it not hang off the blade (its
    centre within 3.5 cm of the blade's). The offset is measured here, at the end of the hold."""
    r, _, bottom = lift_with_object_on_blade(own_sim, 0.05, "clear", at)
    sc = own_sim.scene
    p, _ = pb.getBasePositionAndOrientation(sc.obj, physicsClientId=sc.client)
    tcp = own_sim.controller.position
    offset = float(np.hypot(p[0] - tcp[0], p[1] - tcp[1]))
    assert (offset < 0.035 - 0.004) if success else (offset > 0.035 + 0.004), offset
    assert bottom > 0.02 and r.info["on_blade"] and not r.info["on_plate"]
    assert r.success is success
