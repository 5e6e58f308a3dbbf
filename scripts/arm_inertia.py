"""The joint torques of an arm's direct plan, checked independently of the rows the solve holds
(joint_limits: g(q) + J^T F + the inertia's m(q) yddot + c(q) ydot^2): the plan as the controller follows
it (resampled at 1 ms), its joint path by IK at each point, and the torque g(q) + J^T F (quasi-static)
plus M(q) q'' + C(q, q') q' (Pinocchio's RNEA less gravity, q' and q'' central differences of the IK path),
per joint, at their worst over the plan.

    python scripts/arm_inertia.py so100 --q-min -0.05 --q-max 0.15 --y-obj 0.12 --qdot-max 0.4
"""

from __future__ import annotations

import argparse

import numpy as np
import pinocchio as pin

from judgeopt.api import load_problem
from judgeopt.planners.joint_limits import joint_kinematics, joint_map
from judgeopt.planners.loaded import Planners


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("robot")
    for name in ("q_min", "q_max", "y_obj", "qdot_max", "f_min", "f_max"):
        ap.add_argument(f"--{name.replace('_', '-')}", dest=name, type=float)
    args = ap.parse_args()
    values = {k: v for k, v in vars(args).items() if v is not None}
    problem = load_problem("paper_sim", **values)
    result = Planners.load(problem, ("direct",)).solve(problem.nominal_env())[0]
    jm = joint_map(problem)
    arm, step = jm.arm, 0.001
    model, data = arm.model, arm.model.createData()
    _, fine = result.plan.resample(step)  # the controller's command: cubic Hermite positions, linear force
    y, f = fine[:, 0], fine[:, 2]
    static, qs = [], []
    for yk, fk in zip(y, f):
        q, _, grav, per_f = joint_kinematics(arm, float(yk), jm.configs[int(np.argmin(np.abs(jm.grid - yk)))])
        qs.append(q)
        static.append(grav + per_f * fk)
    qs, static = np.array(qs), np.array(static)
    qd = np.gradient(qs, step, axis=0)
    qdd = np.gradient(qd, step, axis=0)
    inertial = np.array([pin.rnea(model, data, qs[k], qd[k], qdd[k]) - pin.computeGeneralizedGravity(model, data, qs[k])
                         for k in range(len(y))])
    print(f"{args.robot}: direct plan, p = {result.predicted_success:.2f}, force {f.min():.2f} to {f.max():.2f} N")
    print(f"{'joint':<24}{'limit':>8}{'static':>9}{'inertial':>10}{'both':>8}  [N m, worst over the plan]")
    for j, name in enumerate(jm.names):
        print(f"{name:<24}{jm.torque_limit[j]:>8.3f}{np.abs(static[:, j]).max():>9.3f}{np.abs(inertial[:, j]).max():>10.4f}"
              f"{np.abs(static[:, j] + inertial[:, j]).max():>8.3f}")


if __name__ == "__main__":
    main()
