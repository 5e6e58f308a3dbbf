"""The scene's physics: the friction coefficients are what the environment says they are."""

import math

import numpy as np
import pytest

from judgeopt.sim.quiet import pb
from judgeopt.sim.controller import TaskCommand
from judgeopt.tasks.scoop.scene import ENV_RANGES, EnvironmentRangeError, check_environment

G = 9.81


def _deceleration(sim, place, v0: float = 0.5, steps: int = 40, hold=None) -> float:
    """Slide the object at v0 along y and measure its deceleration over the first contact phase."""
    sc = sim.scene

    def step():
        if hold is not None:
            sim.step(hold)
        else:
            pb.stepSimulation(physicsClientId=sc.client)

    pb.resetBasePositionAndOrientation(sc.obj, place(), [0, 0, 0, 1], physicsClientId=sc.client)
    for _ in range(150):  # let it land and come to rest first
        step()
    pb.resetBaseVelocity(sc.obj, [0, v0, 0], [0, 0, 0], physicsClientId=sc.client)
    speeds = []
    for _ in range(steps):
        step()
        speeds.append(pb.getBaseVelocity(sc.obj, physicsClientId=sc.client)[0][1])
    speeds = np.array(speeds)
    moving = np.flatnonzero(speeds > 0.05 * v0)
    a, b = 5, min(int(moving[-1]), steps - 1) - 2  # skip the landing and the stop
    return (speeds[a] - speeds[b]) / ((b - a) * 1e-3)


@pytest.mark.parametrize("mu", [0.3, 0.8])
def test_spatula_object_friction_equals_mu(sim, mu):
    """The object slides on the levelled blade: deceleration / g is the effective coefficient."""
    import pinocchio as pin

    from judgeopt.sim.controller import solve_ik

    level = pin_rpy(math.radians(sim.scene.config.spatula.blade_tilt_deg))
    ctl = sim.controller
    hold = TaskCommand(position=np.array([0.3, -0.03, sim.z_contact + 0.05]), rotation=level, selection=np.ones(6))
    q = solve_ik(ctl.model, ctl.tcp, pin.SE3(level, hold.position), sim.home_joints(-0.03))
    sim._reset(q, 0.35, mu)  # the arm starts with the blade level, in the air
    for _ in range(200):
        sim.step(hold)
    assert np.linalg.norm(ctl.position - hold.position) < 1e-3
    g = sim.scene.config.spatula
    h = sim.scene.config.pancake.thickness

    def place():
        p = ctl.position
        return [0.3, p[1] - 0.005, p[2] + g.blade_thickness / 2 + h / 2 + 2e-3]

    decel = _deceleration(sim, place, v0=0.3, hold=hold)
    assert decel / G == pytest.approx(mu, rel=0.08)


@pytest.mark.parametrize("mu", [1.0, 3.0])
def test_object_plate_friction_does_not_depend_on_mu(sim, mu):
    sim.reset(-0.03, 0.35, mu, height=0.05)
    h = sim.scene.config.pancake.thickness
    decel = _deceleration(sim, lambda: [0.3, 0.2, h / 2 + 2e-3], v0=0.8, steps=60)
    assert decel / G == pytest.approx(sim.scene.config.plate_friction, rel=0.1)


def test_blade_plate_friction_does_not_depend_on_mu(sim):
    sc = sim.scene
    plate = pb.getDynamicsInfo(sc.plate, -1, physicsClientId=sc.client)[1]
    for mu in (0.5, 3.0):
        sc.set_mu(mu)
        blade = pb.getDynamicsInfo(sc.robot, sc.blade_bottom, physicsClientId=sc.client)[1]
        assert blade * plate == pytest.approx(sc.config.blade_plate_friction)


@pytest.mark.parametrize("y_obj,mu", [(0.01, 1.0), (0.2, -1.0), (0.2, float("nan")), (0.5, 2.0)])
def test_environment_outside_physical_range_is_rejected(y_obj, mu):
    with pytest.raises(EnvironmentRangeError) as err:
        check_environment(y_obj, mu)
    name = "y_obj" if not ENV_RANGES["y_obj"][0] <= y_obj <= ENV_RANGES["y_obj"][1] else "mu"
    assert name in str(err.value) and "range" in str(err.value)


def pin_rpy(roll: float) -> np.ndarray:
    import pinocchio as pin

    return pin.rpy.rpyToMatrix(roll, 0.0, 0.0)


@pytest.mark.parametrize("plant, wrists, agree", [("urdf", "universal_robots", True),
                                                  ("collision_shapes", "example_robot_data", False)])
def test_plant_mass_matrix_is_the_controllers(plant, wrists, agree):
    """PyBullet's mass matrix (the plant) against Pinocchio's CRBA on the same URDF (the model
    in the controller's M and Lambda), at random postures. The default scene must agree; the
    documented model-error option must really differ (else this check could not fail)."""
    from judgeopt.sim.checks import mass_matrix_error
    from judgeopt.tasks.scoop.scene import Scene, SceneConfig

    sc = Scene(SceneConfig(plant_inertia=plant, wrist_inertia=wrists))
    try:
        worst = mass_matrix_error(sc.client, sc.robot, sc.urdf_path, n=8, seed=7)
    finally:
        sc.close()
    assert (worst < 1e-9) if agree else (worst > 0.05), worst


def test_wrist_inertias_are_physically_plausible(sim):
    """A UR5 wrist is a ~1.2 kg body a few cm across: its inertia about any axis is of the
    order m r^2 with r < 0.1 m (example-robot-data's file says 0.22 kg m^2, a 0.6 m radius)."""
    import xml.etree.ElementTree as ET

    links = {link.get("name"): link for link in ET.parse(sim.scene.urdf_path).getroot().iter("link")}
    for name in ("wrist_1_link", "wrist_2_link", "wrist_3_link"):
        inertial = links[name].find("inertial")
        mass = float(inertial.find("mass").get("value"))
        moments = [float(inertial.find("inertia").get(k)) for k in ("ixx", "iyy", "izz")]
        assert 0 < max(moments) < mass * 0.1**2, name


def test_bad_scene_inertia_option_is_named():
    from judgeopt.tasks.scoop.scene import Scene, SceneConfig

    with pytest.raises(ValueError, match="plant_inertia"):
        Scene(SceneConfig(plant_inertia="meshes"))
