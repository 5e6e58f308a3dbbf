"""The arm's joint limits along a plan (judgeopt.planners.joint_limits) against independent
computations: finite differences of IK, Pinocchio's gravity, a hand J^T f, the simulator's own
torques while pressing, and the CasADi rows against the exact numpy check."""

from __future__ import annotations

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")
cs = pytest.importorskip("casadi")

from judgeopt.planners import joint_limits as jl  # noqa: E402
from judgeopt.planners.problem import Problem, ProblemError, load_problem  # noqa: E402
from judgeopt.tasks.scoop import scoop_plan  # noqa: E402


@pytest.fixture(scope="module")
def problem() -> Problem:
    return load_problem("problems/paper_sim.toml")


@pytest.fixture(scope="module")
def jmap(problem: Problem) -> jl.JointMap:
    return jl.joint_map(problem)


def _ik(jmap: jl.JointMap, y: float) -> np.ndarray:
    """IK on the tabulated branch, unwrapped against it (finite differences across +-pi)."""
    ref = jmap.configs[int(np.argmin(np.abs(jmap.grid - y)))]
    q = jmap.arm.ik(np.array([y]), ref)
    return ref + (q - ref + np.pi) % (2 * np.pi) - np.pi


def _random_plan(rng: np.random.Generator, n: int = 30):
    y = rng.uniform(-0.2, 0.4, n + 1)
    return scoop_plan(0.05, y, rng.uniform(-1.0, 1.0, n + 1), rng.uniform(0.0, 40.0, n + 1))


def test_ur5_limits_come_from_the_urdf(jmap: jl.JointMap) -> None:
    print("velocity limits", jmap.velocity_limit, "effort limits", jmap.torque_limit)
    assert jmap.names == ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                          "wrist_2_joint", "wrist_3_joint")
    np.testing.assert_allclose(jmap.velocity_limit, [3.15, 3.15, 3.15, 3.2, 3.2, 3.2])
    np.testing.assert_allclose(jmap.torque_limit, [150, 150, 150, 28, 28, 28])


def test_tabulated_branch_is_continuous_and_starts_where_the_simulator_places_the_arm(jmap, problem) -> None:
    assert np.abs(np.diff(jmap.configs, axis=0)).max() < 0.02
    q0 = float(problem.vec("q0")[0])
    np.testing.assert_allclose(_ik(jmap, q0), jmap.arm.ik(np.array([q0]), None), atol=1e-8)


def test_joint_velocity_is_a_finite_difference_of_ik(jmap: jl.JointMap) -> None:
    y, ydot, h = 0.23, 0.7, 1e-5
    _, rate, _, _ = jl.joint_kinematics(jmap.arm, y, jmap.configs[int(np.argmin(np.abs(jmap.grid - y)))])
    fd = (_ik(jmap, y + h) - _ik(jmap, y - h)) / (2 * h) * ydot
    np.testing.assert_allclose(rate * ydot, fd, atol=1e-6)


def _axis(model, data, j: int) -> np.ndarray:
    """Joint j's axis in the world: its frame's x, y or z column (the URDF's revolute RX/RY/RZ)."""
    return data.oMi[j].rotation[:, "XYZ".index(model.joints[j].shortname()[-1])]


def _hand_gravity(model, q: np.ndarray) -> np.ndarray:
    """Gravity torques summed by hand over the serial chain: joint j holds the weight of every
    body from j outwards, g_j = sum_i m_i 9.81 (z_j x (c_i - p_j))_z (z_j the joint axis)."""
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    out = np.zeros(model.nv)
    for j in range(1, model.njoints):
        p_j, axis = data.oMi[j].translation, _axis(model, data, j)
        for i in range(j, model.njoints):
            c_i = data.oMi[i].act(model.inertias[i].lever)
            out[j - 1] += model.inertias[i].mass * 9.81 * np.cross(axis, c_i - p_j)[2]
    return out


def test_torque_is_gravity_plus_a_hand_jacobian_transpose_product(jmap: jl.JointMap) -> None:
    y, f = 0.05, 18.0
    q, _, grav, per_f = jl.joint_kinematics(jmap.arm, y, None)
    model = jmap.arm.model
    data = model.createData()
    np.testing.assert_allclose(grav, pin.computeGeneralizedGravity(model, data, q), atol=1e-12)
    np.testing.assert_allclose(grav, _hand_gravity(model, q), atol=1e-9)
    J = pin.computeFrameJacobian(model, data, q, jmap.arm.tool_frame, pin.LOCAL_WORLD_ALIGNED)
    # the tool pushes down on the plate with f: wrench (0, 0, -f, 0, 0, 0) at the TCP, so J^T w = -f J[2]
    hand = np.array([J[2, j] * -f for j in range(6)])
    np.testing.assert_allclose(per_f * f, hand, atol=1e-12)
    # and J[2] by hand: the TCP's height change per joint turn, z_j x (p_tcp - p_j)
    pin.framesForwardKinematics(model, data, q)
    p_tcp = data.oMf[jmap.arm.tool_frame].translation
    dz = [np.cross(_axis(model, data, j), p_tcp - data.oMi[j].translation)[2] for j in range(1, 7)]
    np.testing.assert_allclose(J[2], dz, atol=1e-12)


def test_torque_sign_matches_what_the_simulated_arm_applies_while_pressing(jmap: jl.JointMap) -> None:
    """At rest on the plate, pressing with f, the controller's torques are g + J^T (0, 0, -f):
    the modelled ones to within the contact's moment and friction (< 1.5 N m), the opposite sign
    many N m away."""
    from judgeopt.tasks.scoop.rollout import Simulator

    sim = Simulator(visual_shapes=False)
    try:
        applied = []
        step = sim.controller.step

        def recording(q, ft, cmd):
            tau = step(q, ft, cmd)
            applied.append(np.array(tau))
            return tau

        sim.controller.step = recording
        sim.driver.sensor_model = lambda force: force  # the Python step path, through controller.step
        y, f, n = 0.1, 15.0, 30
        plan = scoop_plan(0.05, np.full(n + 1, y), np.zeros(n + 1), np.full(n + 1, f))
        run = sim.start(plan, 0.3, 0.5)  # object well ahead of the blade
        run.advance(plan, 10)
    finally:
        sim.close()
    _, _, grav, per_f = jl.joint_kinematics(jmap.arm, y, None)
    tau = applied[-1]
    assert np.abs(tau - (grav + per_f * f)).max() < 1.5
    assert np.abs(tau - (grav - per_f * f)).max() > 5.0


def test_casadi_rows_agree_with_the_exact_check(jmap: jl.JointMap) -> None:
    plan = _random_plan(np.random.default_rng(3))
    n1 = plan.values.shape[0]
    q, v, f = (cs.MX.sym(name, n1, 1) for name in ("q", "v", "f"))
    fn = cs.Function("rows", [q, v, f], [jmap.rows(q, v, f)])
    rows = np.array(fn(plan.y, plan.ydot, plan.f)).ravel()
    qd, tau = jmap.exact(plan)
    qd_b, tau_b = jmap.exact(plan, between=True)  # samples and midpoints interleaved
    expected = np.concatenate([(qd / jmap.velocity_limit).ravel(), (tau / jmap.torque_limit).ravel(),
                               (qd_b[0::2] / jmap.velocity_limit).ravel(), (tau_b[1::2] / jmap.torque_limit).ravel()])
    assert rows.shape == ((n1 - 1) * 6 + n1 * 6 + 2 * (n1 - 1) * 6,)
    np.testing.assert_allclose(rows, expected, rtol=1e-6, atol=1e-6 * np.abs(expected).max())
    # differentiable: a Jacobian exists and is finite
    jac = cs.Function("rows_jacobian", [q, v, f], [cs.jacobian(jmap.rows(q, v, f), cs.vertcat(q, v, f))])
    assert np.all(np.isfinite(np.array(jac(plan.y, plan.ydot, plan.f))))


def test_a_fast_sample_violates_joint_velocity_by_the_hand_computed_amount(jmap: jl.JointMap) -> None:
    n, y, k, fast, scale = 30, 0.12, 7, 1.5, 1.0
    ydot = np.zeros(n + 1)
    ydot[k] = fast
    plan = scoop_plan(0.05, np.full(n + 1, y), ydot, np.full(n + 1, 10.0))
    h = 1e-5
    hand = np.abs((_ik(jmap, y + h) - _ik(jmap, y - h)) / (2 * h) * fast) - scale * jmap.velocity_limit
    assert hand.max() > 0  # the pan joint turns faster than 3.15 rad/s
    res = jmap.residuals(plan, scale)
    assert res["joint_velocity"] == pytest.approx(hand.max(), abs=1e-5)
    assert res["joint_torque"] == 0.0
    assert jmap.residuals(plan, 10.0)["joint_velocity"] == 0.0


def test_binding_names_the_joint_that_binds(jmap: jl.JointMap) -> None:
    n = 30
    # at rest without pressing only gravity loads the arm: in the tool-down posture the upper arm
    # stands near vertical over the shoulder and the forearm reaches out level, so the elbow
    # carries the largest share of its limit (hand sum of the weights' moments)
    still = scoop_plan(0.05, np.full(n + 1, 0.3), np.zeros(n + 1), np.zeros(n + 1))
    joint, quantity, ratio = jmap.binding(still, 1.0)
    q = jmap.arm.ik(np.array([0.3]), jmap.configs[0])
    hand = np.abs(_hand_gravity(jmap.arm.model, q)) / jmap.torque_limit
    assert int(np.argmax(hand)) == 2
    assert (joint, quantity) == ("elbow_joint", "torque")
    assert ratio == pytest.approx(hand[2], rel=1e-8)
    assert jmap.binding(still, 0.5)[2] == pytest.approx(2 * ratio)
    # moving along y at x = 0.3 m turns the base: the pan joint (3.15 rad/s, below wrist 3's 3.2) binds
    moving = scoop_plan(0.05, np.full(n + 1, 0.0), np.full(n + 1, 1.0), np.zeros(n + 1))
    assert jmap.binding(moving, 1.0)[:2] == ("shoulder_pan_joint", "velocity")


def test_tasks_without_an_arm_or_with_two_axes_are_refused() -> None:
    from judgeopt.tasks import BUILTIN, get_task

    others = [t for t in BUILTIN if t != "scoop"]
    assert others, "no second task to refuse"
    for name in others:
        task = get_task(name)
        with pytest.raises(ProblemError, match=name):
            jl.joint_map(Problem(task=name, **_fit(task)))


def _fit(task) -> dict:
    """Limits that validate for `task` (its own problem files would do as well)."""
    n = len(task.channels_of("position"))
    return {} if n == 1 else {k: [v] * n for k, v in (("q0", 0.0), ("qdot0", 0.0), ("q_min", -0.2), ("q_max", 0.4),
                                                       ("qdot_min", -0.05), ("qdot_max", 1.0))}


def test_the_check_between_samples_reads_the_mean_of_its_neighbours(jmap: jl.JointMap) -> None:
    """The check halfway between samples: every sample still checked, and between samples 2 and 3
    the torque is gravity + J^T f at the mean position with the mean force (Pinocchio, by hand)."""
    rng = np.random.default_rng(4)
    plan = _random_plan(rng, 6)
    qd, tau = jmap.exact(plan, between=True)
    assert qd.shape == (2 * 6, jmap.n_joints) and tau.shape == (2 * 6 + 1, jmap.n_joints)
    np.testing.assert_allclose(qd[1::2], jmap.exact(plan)[0], atol=1e-9)  # every sample still checked
    y, f = (plan.values[:, j] for j in (0, 2))
    _, _, grav, per_f = jl.joint_kinematics(jmap.arm, float(0.5 * (y[2] + y[3])), _ik(jmap, float(y[2])))
    np.testing.assert_allclose(tau[5], grav + per_f * 0.5 * (f[2] + f[3]), rtol=1e-6, atol=1e-6)
