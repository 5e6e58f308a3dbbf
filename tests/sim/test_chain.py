"""The CasADi expressions of the arm's kinematics and dynamics equal Pinocchio's (judgeopt/sim/chain.py)."""

import casadi as cs
import numpy as np
import pinocchio as pin
import pytest

from judgeopt.sim import chain
from judgeopt.sim.robot import SpatulaGeometry, robot_urdf


@pytest.fixture(scope="module")
def arm():
    model = pin.buildModelFromUrdf(str(robot_urdf(SpatulaGeometry())))
    tcp = model.getFrameId("tcp")
    d = chain.model_data(model, tcp)
    q, v, a = cs.SX.sym("q", model.nq), cs.SX.sym("v", model.nv), cs.SX.sym("a", model.nv)
    kin = chain.kinematics(d, q)
    fn = cs.Function("arm", [q, v, a], [kin.frame_p, kin.frame_R, chain.frame_jacobian(d, kin),
                                        chain.mass_matrix(d, kin), chain.rnea(d, kin, v, a)])
    return model, model.createData(), tcp, fn


def test_kinematics_jacobian_mass_matrix_and_rnea_equal_pinocchio(arm):
    model, data, tcp, fn = arm
    rng = np.random.default_rng(0)
    for _ in range(100):
        q, v, a = rng.uniform(-np.pi, np.pi, 6), 2 * rng.normal(size=6), 10 * rng.normal(size=6)
        p, R, J, M, tau = (np.array(x) for x in fn(q, v, a))
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacement(model, data, tcp)
        M_pin = pin.crba(model, data, q)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        tau_pin = pin.rnea(model, data, q, v, a)
        np.testing.assert_allclose(p.ravel(), data.oMf[tcp].translation, rtol=0, atol=1e-12)
        np.testing.assert_allclose(R, data.oMf[tcp].rotation, rtol=0, atol=1e-12)
        np.testing.assert_allclose(J, pin.getFrameJacobian(model, data, tcp, pin.LOCAL_WORLD_ALIGNED), rtol=0, atol=1e-12)
        np.testing.assert_allclose(M, M_pin, rtol=0, atol=1e-12 * np.abs(M_pin).max())
        np.testing.assert_allclose(tau.ravel(), tau_pin, rtol=0, atol=1e-12 * np.abs(tau_pin).max())


def test_a_random_branching_model_with_every_revolute_joint_type():
    """Not only the UR5 (whose placements turn about its joint axes): random placements, inertias
    and axes, unaligned axes and a joint with two children."""
    rng = np.random.default_rng(2)
    model = pin.Model()
    joints = [pin.JointModelRX(), pin.JointModelRY(), pin.JointModelRZ(),
              pin.JointModelRevoluteUnaligned(*(rng.normal(size=3) / np.linalg.norm(rng.normal(size=3)))),
              pin.JointModelRZ(), pin.JointModelRevoluteUnaligned(0.6, 0.0, 0.8)]
    parents = [0, 1, 2, 3, 2, 5]
    for i, (j, parent) in enumerate(zip(joints, parents)):
        jid = model.addJoint(parent, j, pin.SE3.Random(), f"j{i}")
        model.appendBodyToJoint(jid, pin.Inertia.Random(), pin.SE3.Identity())
    model.addFrame(pin.Frame("tip", 4, 0, pin.SE3.Random(), pin.FrameType.OP_FRAME))
    tip = model.getFrameId("tip")
    data = model.createData()
    d = chain.model_data(model, tip)
    q, v, a = cs.SX.sym("q", 6), cs.SX.sym("v", 6), cs.SX.sym("a", 6)
    kin = chain.kinematics(d, q)
    fn = cs.Function("arm", [q, v, a], [kin.frame_p, kin.frame_R, chain.frame_jacobian(d, kin),
                                        chain.mass_matrix(d, kin), chain.rnea(d, kin, v, a)])
    for _ in range(20):
        qq, vv, aa = rng.uniform(-np.pi, np.pi, 6), rng.normal(size=6), rng.normal(size=6)
        p, R, J, M, tau = (np.array(x) for x in fn(qq, vv, aa))
        pin.computeJointJacobians(model, data, qq)
        pin.updateFramePlacement(model, data, tip)
        M_pin = pin.crba(model, data, qq)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        np.testing.assert_allclose(p.ravel(), data.oMf[tip].translation, atol=1e-12)
        np.testing.assert_allclose(R, data.oMf[tip].rotation, atol=1e-12)
        np.testing.assert_allclose(J, pin.getFrameJacobian(model, data, tip, pin.LOCAL_WORLD_ALIGNED), atol=1e-12)
        np.testing.assert_allclose(M, M_pin, atol=1e-12 * np.abs(M_pin).max())
        np.testing.assert_allclose(tau.ravel(), pin.rnea(model, data, qq, vv, aa), atol=1e-11)


def test_log3_renormalises_a_rotation_as_pinocchio_does():
    R_sym = cs.SX.sym("R", 3, 3)
    log3 = cs.Function("log3", [R_sym], [chain.log3(R_sym)])
    rng = np.random.default_rng(3)
    for _ in range(20):
        R = pin.exp3(rng.normal(size=3)) + 1e-4 * rng.normal(size=(3, 3))  # drifted off SO(3)
        # 1e-10: acos near pi amplifies the last bits (a missed renormalisation shows at 1e-5)
        np.testing.assert_allclose(np.array(log3(R)).ravel(), pin.log3(R), rtol=0, atol=1e-10)


@pytest.mark.parametrize("angle", [0.0, 1e-9, 1e-6, 1e-3, 0.3, 2.0, np.pi - 1e-3, np.pi - 1e-7, np.pi])
def test_log3_equals_pinocchio_from_zero_to_pi(angle):
    R_sym = cs.SX.sym("R", 3, 3)
    log3 = cs.Function("log3", [R_sym], [chain.log3(R_sym)])
    rng = np.random.default_rng(1)
    for _ in range(20):
        axis = rng.normal(size=3)
        R = pin.exp3(angle * axis / np.linalg.norm(axis))
        np.testing.assert_allclose(np.array(log3(R)).ravel(), pin.log3(R), rtol=0, atol=1e-12)


def test_an_unsupported_joint_is_named():
    model = pin.Model()
    model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "slider")
    with pytest.raises(chain.UnsupportedModel, match="JointModelPX"):
        chain.joint_axes(model)
