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


def _torque(jmap: jl.JointMap, y: float, ydot: float, f: float, acc: float) -> np.ndarray:
    """A point's joint torques, from IK there (not the tables)."""
    q, rate, grav, per_f = jl.joint_kinematics(jmap.arm, y, _ik(jmap, y))
    per_acc, per_v2 = jl.joint_dynamics(jmap.arm, q, rate)
    return grav + per_f * f + per_v2 * ydot ** 2 + per_acc * acc


def test_casadi_rows_agree_with_the_exact_check(jmap: jl.JointMap) -> None:
    """The rows (tables) against IK at each point: velocities at samples 1..N, torques leaving samples
    0..N-1 and entering 1..N (the steps' accelerations on either side), then both at the midpoints; the
    check `exact` takes the larger torque of a sample's two sides."""
    plan = _random_plan(np.random.default_rng(3))
    n1 = plan.values.shape[0]
    q, v, f = (cs.MX.sym(name, n1, 1) for name in ("q", "v", "f"))
    a = cs.MX.sym("a", n1 - 1, 1)
    acc = np.diff(plan.ydot) / plan.dt
    fn = cs.Function("rows", [q, v, f, a], [jmap.rows(q, v, f, a)])
    rows = np.array(fn(plan.y, plan.ydot, plan.f, acc)).ravel()
    qd, tau = jmap.exact(plan)
    qd_b, _ = jmap.exact(plan, between=True)  # samples and midpoints interleaved
    y, yd, fk = plan.y, plan.ydot, plan.f
    leaving = np.array([_torque(jmap, y[k], yd[k], fk[k], acc[k]) for k in range(n1 - 1)])
    entering = np.array([_torque(jmap, y[k], yd[k], fk[k], acc[k - 1]) for k in range(1, n1)])
    mids = np.array([_torque(jmap, 0.5 * (y[k] + y[k + 1]), 0.5 * (yd[k] + yd[k + 1]), 0.5 * (fk[k] + fk[k + 1]),
                             acc[k]) for k in range(n1 - 1)])
    expected = np.concatenate([(qd / jmap.velocity_limit).ravel(), (leaving / jmap.torque_limit).ravel(),
                               (entering / jmap.torque_limit).ravel(), (qd_b[0::2] / jmap.velocity_limit).ravel(),
                               (mids / jmap.torque_limit).ravel()])
    assert rows.shape == (5 * (n1 - 1) * 6,)
    np.testing.assert_allclose(rows, expected, rtol=1e-6, atol=1e-6 * np.abs(expected).max())
    larger = np.where(np.abs(leaving[1:]) >= np.abs(entering[:-1]), leaving[1:], entering[:-1])
    np.testing.assert_allclose(tau[1:-1], larger, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(tau[[0, -1]], [leaving[0], entering[-1]], rtol=1e-9, atol=1e-9)
    # differentiable: a Jacobian exists and is finite
    jac = cs.Function("rows_jacobian", [q, v, f, a], [cs.jacobian(jmap.rows(q, v, f, a), cs.vertcat(q, v, f, a))])
    assert np.all(np.isfinite(np.array(jac(plan.y, plan.ydot, plan.f, acc))))


def test_torque_in_motion_is_the_inverse_dynamics_of_the_joints_ik_path(jmap: jl.JointMap) -> None:
    """A six-joint arm follows the IK path exactly, so its torque while the tool accelerates is Pinocchio's
    inverse dynamics (rnea) at q(y), with q' and q'' finite differences of IK along y: tau = rnea(q, q' ydot,
    q' yddot + q'' ydot^2) + J^T f. Independent of joint_dynamics' operational-space form."""
    model, data = jmap.arm.model, jmap.arm.model.createData()
    h = 1e-4
    for y, ydot, yddot, f in ((0.05, 0.8, 4.0, 10.0), (0.3, -0.5, -6.0, 0.0), (-0.1, 1.0, 0.0, 20.0)):
        qm, q0, qp = (_ik(jmap, y + d) for d in (-h, 0.0, h))
        d1, d2 = (qp - qm) / (2 * h), (qp - 2 * q0 + qm) / h ** 2
        _, _, _, per_f = jl.joint_kinematics(jmap.arm, y, q0)
        expected = pin.rnea(model, data, q0, d1 * ydot, d1 * yddot + d2 * ydot ** 2) + per_f * f
        np.testing.assert_allclose(_torque(jmap, y, ydot, f, yddot), expected, rtol=1e-5, atol=1e-4)
    q, rate, grav, _ = jl.joint_kinematics(jmap.arm, 0.1, None)
    per_acc, _ = jl.joint_dynamics(jmap.arm, q, rate)
    assert np.abs(per_acc).max() > 1.0  # the inertia is there: N m per m/s^2 on the UR5's base joints


def test_a_seven_joint_arm_s_inertial_torque_accelerates_the_tool_along_the_axis_and_turns_no_self_motion() -> None:
    """On the Panda the torque per unit axis acceleration, applied alone (M qdd = tau), accelerates the
    tool along the axis at 1 m/s^2 without turning it (J M^-1 tau = [axis; 0]), and its qdd lies in the
    dynamically consistent range (M qdd = J^T w for some wrench w: no null-space torque)."""
    problem = load_problem("problems/paper_sim.toml").with_overrides(robot="panda")
    panda = jl.joint_map(problem)
    model, data = panda.arm.model, panda.arm.model.createData()
    q, rate, _, _ = jl.joint_kinematics(panda.arm, 0.1, panda.configs[int(np.argmin(np.abs(panda.grid - 0.1)))])
    per_acc, _ = jl.joint_dynamics(panda.arm, q, rate)
    J = pin.computeFrameJacobian(model, data, q, panda.arm.tool_frame, pin.LOCAL_WORLD_ALIGNED)
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T
    np.testing.assert_allclose(J @ np.linalg.solve(M, per_acc), np.concatenate([panda.arm.axes[0], np.zeros(3)]),
                               atol=1e-8)
    wrench, *_ = np.linalg.lstsq(J.T, per_acc, rcond=None)
    np.testing.assert_allclose(J.T @ wrench, per_acc, atol=1e-8)


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
    the torque is gravity + J^T f at the mean position with the mean force (Pinocchio, by hand), and the
    inertia's at the mean velocity with the step's acceleration."""
    rng = np.random.default_rng(4)
    plan = _random_plan(rng, 6)
    qd, tau = jmap.exact(plan, between=True)
    assert qd.shape == (2 * 6, jmap.n_joints) and tau.shape == (2 * 6 + 1, jmap.n_joints)
    np.testing.assert_allclose(qd[1::2], jmap.exact(plan)[0], atol=1e-9)  # every sample still checked
    y, v, f = (plan.values[:, j] for j in (0, 1, 2))
    q, rate, grav, per_f = jl.joint_kinematics(jmap.arm, float(0.5 * (y[2] + y[3])), _ik(jmap, float(y[2])))
    per_acc, per_v2 = jl.joint_dynamics(jmap.arm, q, rate)
    mean_v, acc = 0.5 * (v[2] + v[3]), (v[3] - v[2]) / plan.dt
    np.testing.assert_allclose(tau[5], grav + per_f * 0.5 * (f[2] + f[3]) + per_v2 * mean_v ** 2 + per_acc * acc,
                               rtol=1e-6, atol=1e-6)


# --- the tables' arithmetic on a map made by hand (issue 44's mutation run) -------------------------------------
# Three joints whose tables are straight lines in the position y, so every figure below is worked out on paper:
#   pan       gravity 4 y,       0 N m per N pressed (a vertical axis),  rate 1 + y,  limits 2 N m, 1 rad/s
#   shoulder  gravity 12 + 2 y,  -0.3 N m per N,                          rate 0.5,    limits 10 N m, 2 rad/s
#   elbow     gravity 5 + 4 y,   -0.35 N m per N,                         rate 2 - y,  limits 8 N m, 3 rad/s
# |g + a f| <= lim gives f in [(g - lim) / 0.3, (g + lim) / 0.3] for the shoulder (a < 0), likewise the elbow; the
# pan holds whatever the force while |4 y| <= 2, i.e. up to y = 0.5 m, and no force helps beyond.


def _toy(gravity=None, force=None, rate=None, torque_limit=(2.0, 10.0, 8.0), names=("pan", "shoulder", "elbow")):
    g = np.linspace(-0.1, 1.1, 49)
    cols = lambda fs: np.column_stack([f(g) * np.ones_like(g) for f in fs])  # noqa: E731
    gravity = gravity or (lambda y: 4 * y, lambda y: 12 + 2 * y, lambda y: 5 + 4 * y)
    force = force or (lambda y: 0.0, lambda y: -0.3, lambda y: -0.35)
    rate = rate or (lambda y: 1 + y, lambda y: 0.5, lambda y: 2 - y)
    nj = len(names)
    return jl.JointMap(names=names, velocity_limit=np.array([1.0, 2.0, 3.0][:nj]),
                       torque_limit=np.array(torque_limit, dtype=float), grid=g, configs=np.zeros((len(g), nj)),
                       rate=cols(rate), gravity=cols(gravity), force=cols(force), arm=None)


def test_along_samples_every_fine_step_both_ends_included() -> None:
    toy = _toy()
    for lo, hi in ((0.0, 0.0004), (0.0, 0.0005), (0.1, 0.101), (0.2, 0.5), (0.3, 0.3)):
        ys, rate, grav, per_f = toy.along(lo, hi)
        n = len(ys)
        np.testing.assert_allclose(ys, np.linspace(lo, hi, n), atol=1e-15)  # both ends, evenly
        if hi > lo:  # no further apart than FINE_STEP, and no more points than that needs
            assert jl.FINE_STEP / 2 < (hi - lo) / (n - 1) <= jl.FINE_STEP * (1 + 1e-9), (lo, hi, n)
        else:
            assert n == 2
        np.testing.assert_allclose(grav, np.column_stack([4 * ys, 12 + 2 * ys, 5 + 4 * ys]), atol=1e-12)
        np.testing.assert_allclose(rate, np.column_stack([1 + ys, np.full(n, 0.5), 2 - ys]), atol=1e-12)
        np.testing.assert_allclose(per_f, np.tile([0.0, -0.3, -0.35], (n, 1)), atol=1e-12)


def test_the_force_window_is_the_hand_intersection_of_the_joints_intervals() -> None:
    toy = _toy()
    # on [0, 0.5]: the shoulder needs f >= (12 + 2 y - 10) / 0.3, most at y = 0.5: 10 N; the elbow allows
    # f <= (5 + 4 y + 8) / 0.35, least at y = 0: 37.14 N (the shoulder's own cap, 73.3 N, is higher)
    w = toy.force_window(0.0, 0.5, 1.0)
    assert (w.low_joint, w.high_joint, w.nowhere) == ("shoulder", "elbow", None)
    assert (w.low, w.low_at, w.high, w.high_at) == pytest.approx((10.0, 0.5, 13 / 0.35, 0.0), abs=1e-9)
    # at half the limits on [0, 0.2]: shoulder f >= (12.4 - 5) / 0.3 at y = 0.2, elbow f <= (5 + 4) / 0.35 at y = 0
    w = toy.force_window(0.0, 0.2, 0.5)
    assert (w.low_joint, w.high_joint, w.nowhere) == ("shoulder", "elbow", None)
    assert (w.low, w.low_at, w.high, w.high_at) == pytest.approx((7.4 / 0.3, 0.2, 9 / 0.35, 0.0), abs=1e-9)


def test_a_joint_no_force_reaches_holds_up_to_its_limit_and_nowhere_beyond() -> None:
    """The pan's gravity 4 y reaches its 2 N m at y = 0.5 exactly: held there (|g| <= limit), the next sample
    0.5005 m is the first where no force holds."""
    toy = _toy()
    assert toy.force_window(0.0, 0.5, 1.0).nowhere is None
    assert toy.force_window(0.0, 1.0, 1.0).nowhere == pytest.approx(0.5005, abs=1e-12)
    assert toy.force_window(0.3, 1.0, 0.5).nowhere == 0.3  # 1.2 N m against 1: from the first position on
    # a joint the force does not reach, within its limit everywhere, bounds no force
    w = _toy(gravity=(lambda y: 1.0, lambda y: 12 + 2 * y, lambda y: 5 + 4 * y)).force_window(0.0, 1.0, 1.0)
    assert w.nowhere is None and (w.low_joint, w.high_joint) == ("shoulder", "elbow")


def test_a_window_closed_to_one_force_still_holds() -> None:
    """Joint a holds f in [-1, 1], joint b (gravity 2) f in [-3, -1]: f = -1 N holds both, so some force holds."""
    toy = _toy(gravity=(lambda y: 0.0, lambda y: 2.0), force=(lambda y: 1.0, lambda y: 1.0),
               rate=(lambda y: 1.0, lambda y: 1.0), torque_limit=(1.0, 1.0), names=("a", "b"))
    w = toy.force_window(0.0, 0.1, 1.0)
    assert w.nowhere is None and w.low == pytest.approx(-1.0) and w.high == pytest.approx(-1.0)
    assert toy.force_window(0.0, 0.1, 0.99).nowhere == 0.0


def test_torque_at_and_speed_cap_by_hand() -> None:
    toy = _toy()
    assert toy.torque_at("elbow", 0.5, 4.0) == pytest.approx(5 + 2 - 0.35 * 4)
    assert toy.torque_at("shoulder", 0.25, -2.0) == pytest.approx(12.5 + 0.6)
    # the pan caps the tool at 1 / (1 + y), least at the far end; the elbow's 3 / (2 - y) >= 1.5, the shoulder's 4
    assert toy.speed_cap(0.0, 0.5, 1.0) == pytest.approx((1 / 1.5, "pan", 0.5))
    assert toy.speed_cap(0.0, 0.2, 0.6) == pytest.approx((0.6 / 1.2, "pan", 0.2))
    slow_elbow = _toy(rate=(lambda y: 0.1, lambda y: 0.5, lambda y: 2 + 4 * y))  # 3 / (2 + 4 y), least at y = 0.5
    assert slow_elbow.speed_cap(0.0, 0.5, 1.0) == pytest.approx((0.75, "elbow", 0.5))


def test_rounded_goes_towards_where_the_limit_holds() -> None:
    assert jl._rounded(6 / 0.7, -1) == 8.57 and jl._rounded(6 / 0.7, +1) == 8.58
    assert jl._rounded(-130 / 7, -1) == -18.6 and jl._rounded(-130 / 7, +1) == -18.5
    assert jl._rounded(12345.0, -1) == 12300 and jl._rounded(0.012345, +1) == 0.0124
    assert jl._rounded(7.69, -1) == 7.69 and jl._rounded(7.69, +1) == 7.69  # 769 units, not 768.99999
    assert jl._rounded(1.0, -1) == 1.0 and jl._rounded(0.0, -1) == 0.0
    assert jl._rounded(np.inf, -1) == np.inf and jl._rounded(-np.inf, +1) == -np.inf


class _Problem:
    """What check_path reads of a problem: its limits (one axis), the terminal position, the horizon."""

    def __init__(self, scale=1.0, end=0.5, steps=30, dt=0.05, **limits):
        self.joint_limit_scale, self.end, self.steps, self.dt = scale, end, steps, dt
        self.limits = {"q0": 0.0, "f_min": 0.0, "f_max": 20.0, "qdot_min": -1.0, "qdot_max": 1.0, **limits}

    def vec(self, key):
        return np.array([self.limits[key]])

    def terminal_positions(self, env):
        return np.array([self.end])


def _refusal(toy, problem, robot="toy") -> jl.InfeasibleProblemError:
    with pytest.raises(jl.InfeasibleProblemError) as exc:
        toy.check_path(problem, {}, robot)
    return exc.value


def test_check_path_a_force_below_the_window_names_the_joint_its_torque_and_the_force_that_holds() -> None:
    toy = _toy()
    e = _refusal(toy, _Problem(f_min=40.0, f_max=50.0))
    # the elbow at y = 0: |5 - 0.35 x 40| = 9 N m of its 8; at f_max |5 - 17.5| = 12.5; it holds up to 37.14 N
    assert str(e) == ("robot 'toy' is too weak for f_min = 40 N: elbow needs 9 N m of its 8 N m at y = 0 m on the "
                      "path from q0 = 0 to 0.5 m (at f_max = 50 N: 12.5 N m); every joint holds its torque there with "
                      "f_min <= 37.1 N (--f-min 37.1), or with a stronger arm")
    assert e.conflict == ["limits.f_min/f_max", "joint_limit_scale"]
    # at half the limits on [0, 0.2] (q0 0.2, end 0): elbow needs |5 - 0.35 x 30| = 5.5 N m of its 4, <= 25.7 N
    e = _refusal(toy, _Problem(scale=0.5, q0=0.2, end=0.0, f_min=30.0, f_max=30.0), robot=None)
    assert str(e).startswith("the arm is too weak for f_min = 30 N: elbow needs 5.5 N m of its 4 N m at y = 0 m on "
                             "the path from q0 = 0.2 to 0 m (at f_max = 30 N: 5.5 N m); every joint holds its torque "
                             "there with f_min <= 25.7 N (--f-min 25.7)")
    toy.check_path(_Problem(f_min=toy.force_window(0.0, 0.5, 1.0).high), {})  # the window's edge holds


def test_check_path_a_force_above_the_window_names_the_least_that_holds() -> None:
    toy = _toy()
    # standing at q0 = 0.5 (no path): the shoulder needs f >= (13 - 10) / 0.3 = 10 N there
    e = _refusal(toy, _Problem(q0=0.5, end=0.5, f_max=8.0))
    assert str(e) == ("robot 'toy' holds shoulder's torque at y = 0.5 m at q0 = 0.5 m only pressing with at least "
                      "10 N, above f_max = 8 N: --f-max 10, or a stronger arm")
    assert e.conflict == ["limits.f_min/f_max", "joint_limit_scale"]
    # the same, 1/0.7 N m more of the shoulder's gravity to hold: (13 + 1/0.7 ... ) rounded up, not to nearest
    e = _refusal(_toy(gravity=(lambda y: 4 * y, lambda y: 12 + 2 * y + 0.3 / 0.7, lambda y: 5 + 4 * y)),
                 _Problem(q0=0.5, end=float("nan"), f_max=8.0))
    assert "only pressing with at least 11.4 N, above f_max = 8 N: --f-max 11.5," in str(e)  # 10 + 1/0.7 = 11.43
    toy.check_path(_Problem(q0=0.5, end=0.5, f_max=toy.force_window(0.5, 0.5, 1.0).low), {})  # the edge holds


def test_check_path_where_no_force_holds_names_the_worst_joint_by_its_share_of_the_limit() -> None:
    """Joint a (50 N m of gravity, 100 per N, limit 100) holds f in [-1.5, 0.5]; joint b (10 N m, 1 per N, limit
    2) f in [-12, -8]: no force holds both anywhere. At f = max(f_min, 0) b is furthest over its limit by share
    (10 / 2 against a's 50 / 100; by N m a's is larger)."""
    toy = _toy(gravity=(lambda y: 50.0, lambda y: 10.0), force=(lambda y: 100.0, lambda y: 1.0),
               rate=(lambda y: 1.0, lambda y: 1.0), torque_limit=(100.0, 2.0), names=("a", "b"))
    e = _refusal(toy, _Problem(f_min=-5.0))
    assert str(e) == ("robot 'toy' cannot hold its joints' torques at y = 0 m on the path from q0 = 0 to 0.5 m "
                      "whatever the pressing force: b needs 10 N m of its 2 N m at f = 0 N; a stronger arm (its "
                      "limits x 1: a 100, b 2 N m), a lighter tool, or an end it reaches otherwise")
    assert e.conflict == ["limits.f_min/f_max", "joint_limit_scale"]
    e = _refusal(toy, _Problem(scale=0.5, f_min=2.0, q0=0.3, end=0.3), robot=None)
    assert str(e) == ("the arm cannot hold its joints' torques at y = 0.3 m at q0 = 0.3 m whatever the pressing "
                      "force: b needs 12 N m of its 1 N m at f = 2 N; a stronger arm (its limits x 0.5: a 50, "
                      "b 1 N m), a lighter tool, or an end it reaches otherwise")


def test_check_path_a_path_longer_than_the_horizon_at_the_joints_speed() -> None:
    """The pan caps the tool at 1 / (1 + y) m/s: 0 to 0.5 m takes at least the integral of (1 + y) dy = 0.625 s;
    backwards, the velocity box's 0.5 m/s (below the pan's cap) makes it 1 s."""
    toy = _toy()
    e = _refusal(toy, _Problem(steps=12, dt=0.05, qdot_max=10.0))
    assert str(e) == ("robot 'toy' is too slow on the path from q0 = 0 to 0.5 m: pan's 1 rad/s caps the tool at "
                      "0.667 m/s at y = 0.5 m, so the path takes at least 0.625 s of the 0.6 s horizon: a nearer end, "
                      "or a faster arm")
    assert e.conflict == ["limits.qdot_min/qdot_max", "joint_limit_scale"]
    toy.check_path(_Problem(steps=13, dt=0.05, qdot_max=10.0), {})  # 0.65 s: time enough
    e = _refusal(toy, _Problem(q0=0.5, end=0.0, steps=18, dt=0.05, qdot_max=10.0, qdot_min=-0.5), robot=None)
    assert "the arm is too slow on the path from q0 = 0.5 to 0 m" in str(e) and "at least 1 s of the 0.9 s" in str(e)
    toy.check_path(_Problem(q0=0.5, end=0.0, steps=21, dt=0.05, qdot_max=0.1, qdot_min=-0.5), {})
    # a box that allows no motion towards the end is the boxes' own conflict, reported elsewhere, not this one
    toy.check_path(_Problem(steps=12, dt=0.05, qdot_max=0.0), {})


def test_advice_names_the_limit_at_which_the_plan_s_positions_hold(monkeypatch) -> None:
    toy = _toy()
    plan = scoop_plan(0.05, np.linspace(0.0, 0.5, 11), np.zeros(11), np.linspace(10.0, 40.0, 11))
    monkeypatch.setattr(toy, "binding", lambda plan, scale: ("elbow", "torque", 1.0))
    assert toy.advice(plan, 1.0) == (
        "elbow caps the pressing force at 37.1 N at y = 0 m (pressing the plan's 40 N there, it would need "
        "9 N m of its 8); every joint's torque holds on these positions with f_max <= 37.1 N")
    assert toy.advice(plan, 1.0, f_min=37.1).endswith("f_max <= 37.1 N and f_min < 37.1 N")
    assert toy.advice(plan, 1.0, f_min=37.0).endswith("f_max <= 37.1 N")
    far = scoop_plan(0.05, np.linspace(0.0, 1.0, 11), np.zeros(11), np.full(11, 10.0))  # the pan, beyond 0.5 m
    assert toy.advice(far, 1.0) == "no pressing force holds elbow's torque on this plan's positions (at y = 0.501 m)"
    # the shoulder's gravity pulls the other way: it holds only f <= -(2 + 2 y) / 0.3, most negative at y = 0.5
    pulling = _toy(gravity=(lambda y: 4 * y, lambda y: -12 - 2 * y, lambda y: 0.0))
    assert toy.advice(plan, 1.0).startswith("elbow")
    monkeypatch.setattr(pulling, "binding", lambda plan, scale: ("shoulder", "torque", 1.2))
    assert pulling.advice(plan, 1.0) == ("no pressing force holds shoulder's torque on this plan's positions "
                                         "(at y = 0.5 m)")
    monkeypatch.setattr(toy, "binding", lambda plan, scale: ("pan", "velocity", 0.9995))
    assert toy.advice(plan, 1.0) == "every joint's speed holds on this plan's positions with qdot_max <= 0.666 m/s " \
                                    "(pan at y = 0.5 m)"
    # moving back, the same joint at the same cap is held by qdot_min (the pan's rate 1 + y: fastest at the
    # sample where |(1 + y) v| peaks, here the backward one at y = 0.5; forward at y = 0 is slower)
    back = scoop_plan(0.05, np.linspace(0.0, 0.5, 11), np.r_[0.3, np.zeros(9), -0.3], np.full(11, 10.0))
    assert toy.advice(back, 1.0) == "every joint's speed holds on this plan's positions with qdot_min >= -0.666 " \
                                    "m/s (pan at y = 0.5 m)"
    fwd = scoop_plan(0.05, np.linspace(0.0, 0.5, 11), np.r_[-0.3, np.zeros(9), 0.3], np.full(11, 10.0))
    assert "with qdot_max <= 0.666 m/s" in toy.advice(fwd, 1.0)
    monkeypatch.setattr(toy, "binding", lambda plan, scale: ("pan", "velocity", 0.998))
    assert toy.advice(plan, 1.0) == ""


def test_binding_is_the_joint_with_the_largest_share_over_every_point(monkeypatch) -> None:
    """Velocities at two points, shares of the limits (1, 2, 3 rad/s) [[.1, .1, .667], [.3, .05, .167]]: the
    elbow at 0.667, found at the first point; torques' shares of (2, 10, 8) N m at most (.1, .2, .0625)."""
    toy = _toy()
    qd = np.array([[0.1, 0.2, 2.0], [0.3, 0.1, 0.5]])
    tau = np.array([[0.1, 2.0, 0.5], [0.2, -1.0, 0.5], [0.0, 0.5, -0.5]])
    monkeypatch.setattr(toy, "exact", lambda plan, between=False: (qd, tau))
    assert toy.binding(None, 1.0) == pytest.approx(("elbow", "velocity", 2 / 3))
    assert toy.binding(None, 0.5) == pytest.approx(("elbow", "velocity", 4 / 3))
    # worst over by (|value| - 0.01 x limit): velocities (0.3 - 0.01, 0.2 - 0.02, 2 - 0.03), torques 2 - 0.1
    assert toy.residuals(None, 0.01) == pytest.approx({"joint_velocity": 1.97, "joint_torque": 1.9})
    assert toy.residuals(None, 1.0) == {"joint_velocity": 0.0, "joint_torque": 0.0}
    monkeypatch.setattr(toy, "exact", lambda plan, between=False: (-0.1 * qd, tau))  # elbow 0.0667 < shoulder 0.2
    assert toy.binding(None, 1.0) == pytest.approx(("shoulder", "torque", 0.2))



def test_a_joint_over_its_speed_only_between_samples_is_found_and_named(jmap: jl.JointMap) -> None:
    """From y = 0.4 to -0.2 m in one step at 1 m/s the pan turns fastest halfway, at y = 0.1 m, where the tool passes
    nearest the base's axis: 3.18 rad/s by a finite difference of IK, over its 3.15; at both samples well under it."""
    h = 1e-5
    pan = [abs(float((_ik(jmap, y + h) - _ik(jmap, y - h))[0] / (2 * h))) for y in (0.4, 0.1, -0.2)]
    assert pan[1] > 3.15 > max(pan[0], pan[2]) + 0.5
    plan = scoop_plan(0.05, np.array([0.4, 0.4, 0.4, -0.2]), np.ones(4), np.zeros(4))
    assert jmap.residuals(plan, 1.0)["joint_velocity"] == pytest.approx(pan[1] - 3.15, abs=1e-5)
    joint, quantity, ratio = jmap.binding(plan, 1.0)
    assert (joint, quantity) == ("shoulder_pan_joint", "velocity") and ratio == pytest.approx(pan[1] / 3.15, abs=1e-6)


def test_the_exact_check_follows_the_tabulated_branch_where_ik_from_home_jumps(jmap: jl.JointMap) -> None:
    """Near y = 0.4 m IK from the home posture lands on another branch (the tables follow the arm's continuous
    one): the joint velocities checked there are the finite differences along the continuous branch."""
    y = float(jmap.grid[int(np.argmin(np.abs(jmap.grid - 0.398)))])
    home = jmap.arm.ik(np.array([y]), None)
    assert np.abs((home - _ik(jmap, y) + np.pi) % (2 * np.pi) - np.pi).max() > 1.0  # the jump
    h = 1e-5
    fd = (_ik(jmap, y + h) - _ik(jmap, y - h)) / (2 * h) * 0.5
    qd, _ = jmap.exact(scoop_plan(0.05, np.full(2, y), np.full(2, 0.5), np.zeros(2)))
    np.testing.assert_allclose(qd[0], fd, atol=1e-6)


def test_a_joint_the_tool_s_motion_does_not_turn_caps_no_speed_and_warns_of_nothing() -> None:
    """The pan's rate 0 (the tool moving along its axis): no cap from it, no division warning; the shoulder's
    2 / (0.5 + 0.4 y) caps the tool, least at y = 0.5 (2.86 m/s), so 0 to 0.5 m takes the integral of
    (0.5 + 0.4 y) / 2 dy = 0.15 s. The pan, 0 N m per N, bounds no force either."""
    import warnings

    still_pan = _toy(rate=(lambda y: 0.0, lambda y: 0.5 + 0.4 * y, lambda y: 0.1))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert still_pan.speed_cap(0.0, 0.5, 1.0) == pytest.approx((2 / 0.7, "shoulder", 0.5))
        still_pan.check_path(_Problem(steps=4, dt=0.05, qdot_max=10.0, f_min=12.0), {})  # 0.2 s >= 0.15 s
        e = _refusal(still_pan, _Problem(steps=2, dt=0.05, qdot_max=10.0, f_min=12.0))
        assert ("shoulder's 2 rad/s caps the tool at 2.86 m/s at y = 0.5 m, so the path takes at least 0.15 s of "
                "the 0.1 s horizon") in str(e)
        assert still_pan.force_window(0.0, 0.5, 1.0).high_joint == "elbow"


def test_a_plan_checked_again_is_not_computed_again_and_a_changed_one_is(jmap: jl.JointMap, monkeypatch) -> None:
    """The exact check keeps its last plans by content: the same plan again (a solve's warm start, then the
    verdict's binding joint) runs no IK; one value changed runs it at every point again; what it returns
    cannot be changed by a caller (it is shared)."""
    calls = []
    real = jl.joint_kinematics
    monkeypatch.setattr(jl, "joint_kinematics", lambda *a, **k: calls.append(1) or real(*a, **k))
    plan = _random_plan(np.random.default_rng(7), 6)
    first = jmap.exact(plan, between=True)
    assert len(calls) == 13
    again = jmap.exact(scoop_plan(0.05, plan.y.copy(), plan.ydot.copy(), plan.f.copy()), between=True)
    assert len(calls) == 13 and all(a is b for a, b in zip(first, again))
    f = plan.f.copy()
    f[3] += 1.0
    changed = jmap.exact(scoop_plan(0.05, plan.y, plan.ydot, f), between=True)
    assert len(calls) == 26 and not np.array_equal(changed[1], first[1])
    with pytest.raises(ValueError):
        first[1][0, 0] = 0.0
