"""An arm too weak for the task (issue 44, item 6): the SO-100's hobby servos. Its limits are the servo maker's,
the torques the planners hold are what a force at the tool makes through the arm's geometry, and a request it
cannot meet is one line naming the joint and the value of a limit at which it holds, which, used, holds."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pinocchio as pin
import pytest

from judgeopt.api import load_problem
from judgeopt.cli import main
from judgeopt.errors import ExitCode
from judgeopt.planners.feasible import check
from judgeopt.planners.joint_limits import joint_kinematics, joint_map
from judgeopt.planners.problem import InfeasibleProblemError
from judgeopt.robots import get_robot, register_robot, unregister_robot
from judgeopt.robots.spec import Correction
from judgeopt.sim.robot import robot_urdf
from judgeopt.trajectory import Plan
from judgeopt.verdict.risk import HOLD_TOL

#: the segment of the scooping line the SO-100 reaches (`judgeopt robots so100 --reach`): its box, and an object in it
SHORT = {"q_min": -0.05, "q_max": 0.15, "y_obj": 0.12, "qdot_max": 0.4}
SOLVE = ["solve", "--robot", "so100", "--qdot-max", "0.4", "--q-min", "-0.05", "--q-max", "0.15", "--y-obj", "0.12",
         "--no-simulate", "--no-suggest", "--method", "direct"]


def _problem(**changes):
    return load_problem("paper_sim", robot="so100", **{**SHORT, **changes})


def test_the_so100_written_carries_the_servo_makers_figures():
    """16.5 kg cm at 6 V (TheRobotStudio's SO-ARM100 README) and 0.22 s per 60 degrees (45 rpm), in SI units,
    on the five arm joints of the URDF the simulator and the planners load; the file's own are 35 N m, 1 rad/s."""
    model = pin.buildModelFromUrdf(str(robot_urdf(robot="so100")))
    assert tuple(model.names[1:]) == get_robot("so100").joints  # the gripper's jaw removed
    np.testing.assert_allclose(model.effortLimit, 16.5 * 9.80665 / 100, rtol=1e-3)  # kg cm -> N m
    np.testing.assert_allclose(model.velocityLimit, 45 * 2 * math.pi / 60, rtol=1e-3)  # rpm -> rad/s


def test_the_torque_a_pressing_force_makes_is_the_force_times_each_joints_lever():
    """At the IK posture of y = 0.1 m, the torque per newton pressed down at the TCP (J^T, from Pinocchio's
    Jacobian) against the geometry alone: the pan and roll axes are vertical (no torque from a vertical force);
    each pitch axis is horizontal, so its torque is the force times the axis' horizontal distance to the TCP
    along the line, (r x F) . axis with r from the joint's origin (forward kinematics only)."""
    arm = joint_map(_problem()).arm
    q, _, _, per_f = joint_kinematics(arm, 0.1)
    data = arm.model.createData()
    pin.forwardKinematics(arm.model, data, q)
    pin.updateFramePlacements(arm.model, data)
    tcp = data.oMf[arm.tool_frame].translation
    force = np.array([0.0, 0.0, -1.0])  # 1 N exerted on the plate
    for j, name in enumerate(arm.joints):
        joint = data.oMi[j + 1]
        model = arm.model.joints[j + 1]
        local = {"JointModelRX": (1.0, 0, 0), "JointModelRY": (0, 1.0, 0), "JointModelRZ": (0, 0, 1.0)}
        # its unit axis in the world
        axis = joint.rotation @ np.array(local.get(model.shortname(), None) or model.extract().axis)
        lever = float(np.cross(tcp - joint.translation, force) @ axis)
        assert per_f[j] == pytest.approx(lever, abs=1e-9), name
    assert abs(per_f[0]) < 1e-9 and abs(per_f[4]) < 1e-9  # shoulder_pan, wrist_roll
    assert min(abs(per_f[1:4])) > 0.05  # every pitch joint carries the force on a lever of centimetres


def test_a_force_the_servos_cannot_press_is_infeasible_naming_the_joint_and_a_force_that_holds():
    """f_min = 10 N: the shoulder servo (1.62 N m) cannot press that hard near the object; the message names
    it and f_min <= X; with f_min = X the check passes and the arm pressing X N at rest at each position of the
    path holds every joint's torque, by IK at each sample (not the planner's tables). At rest: the check is
    quasi-static; moving adds the arm's inertia (at 0.1 m/s, 1.6 mN m on the shoulder)."""
    problem = _problem(f_min=10.0)
    env = problem.nominal_env()
    with pytest.raises(InfeasibleProblemError) as exc:
        check(problem, env)
    text = str(exc.value)
    assert "shoulder_lift needs" in text and "of its 1.62 N m" in text and "\n" not in text
    value = float(re.search(r"--f-min ([0-9.]+)\)", text).group(1))
    assert 5.0 < value < 10.0
    fixed = _problem(f_min=value)
    check(fixed, env)  # no error
    jm = joint_map(fixed)
    y = np.linspace(-0.03, 0.12, 31)
    plan = Plan.from_array(fixed.dt, np.stack([y, np.zeros(31), np.full(31, value)], axis=1),
                           fixed.channel_spec)
    assert jm.residuals(plan, 1.0)["joint_torque"] <= HOLD_TOL
    over = Plan.from_array(fixed.dt, np.stack([y, np.gradient(y, fixed.dt), np.full(31, value + 0.2)], axis=1),
                           fixed.channel_spec)
    assert jm.residuals(over, 1.0)["joint_torque"] > 0  # the value found is the edge, not a guess far inside


def test_the_command_line_says_it_in_one_line_and_exit_3(capsys):
    assert main([*SOLVE, "--f-min", "10"]) == ExitCode.INFEASIBLE
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "robot 'so100' is too weak for f_min = 10 N: shoulder_lift" in err[0], err
    assert "--f-min 7.69" in err[0]


@pytest.mark.slow
def test_a_plan_it_can_make_names_the_joint_that_binds_and_the_force_at_which_every_joint_holds(capsys):
    """Within the limits it can meet (f_min = 7.5 N) the direct solve holds the torques: its plan names the
    shoulder as binding and the f_max at which every plan on its positions holds every joint; a plan pressing
    that force at each of its positions holds them (IK at each sample)."""
    from judgeopt.planners.loaded import Planners

    problem = _problem()
    planners = Planners.load(problem, ("direct",))
    env = problem.nominal_env()
    result = planners.solve(env)[0]
    assert result.residuals["joint_torque"] <= HOLD_TOL
    line = " ".join(planners["direct"].details(result))
    assert "shoulder_lift's torque" in line and "f_max <=" in line, line
    cap = float(re.search(r"f_max <= ([0-9.]+) N", line).group(1))
    plan = result.plan
    held = Plan.from_array(plan.dt, np.column_stack([plan.values[:, :2], np.full(len(plan.values), cap)]),
                           problem.channel_spec)
    assert joint_map(problem).residuals(held, 1.0)["joint_torque"] <= HOLD_TOL


def test_gravity_alone_beyond_the_servos_is_infeasible_whatever_the_force():
    """Servos at a twentieth of their torque cannot hold the arm's own weight: no force helps, and it says so."""
    with pytest.raises(InfeasibleProblemError, match=r"whatever the pressing force: shoulder_lift needs"):
        check(_problem(joint_limit_scale=0.05), _problem().nominal_env())


def test_servos_too_slow_for_the_horizon_are_infeasible_naming_the_joint():
    """At 0.3 rad/s (a sixteenth of the STS3215's) the elbow caps the tool below 0.04 m/s: 0.15 m takes over
    the 1.5 s horizon."""
    slow = dataclasses.replace(get_robot("so100"), name="so100_slow",
                               velocity_limits={j: Correction(0.3, "test") for j in get_robot("so100").joints})
    register_robot(slow)
    try:
        problem = load_problem("paper_sim", robot="so100_slow", **SHORT)
        with pytest.raises(InfeasibleProblemError, match=r"too slow .*elbow_flex's 0.3 rad/s caps the tool at"):
            check(problem, problem.nominal_env())
    finally:
        unregister_robot("so100_slow")


def test_the_default_scoop_is_beyond_its_reach_in_one_line(capsys):
    """The default positions [-0.2, 0.4] m: 0.6 m of line for an arm of about 0.25 m."""
    assert main(["solve", "--robot", "so100", "--qdot-max", "0.4", "--no-simulate"]) == ExitCode.INFEASIBLE
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "robot 'so100' cannot hold the tool at position" in err[0], err
    assert "judgeopt robots so100 --reach" in err[0]
