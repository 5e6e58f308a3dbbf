"""Choose an arm's base placement and home posture for the scoop (judgeopt.robots): over a grid of
base positions (x behind the plate's home point, height above the plate), and IK solutions from
random starts, the one whose whole scooping line (judgeopt.tasks.scoop.placement.scoop_line) is reached
with the largest distance to the joint limits and to a singularity. Prints the fields to put in
the arm's file; the tests (tests/robots) check the chosen ones.

    python scripts/place_arm.py panda
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
import pinocchio as pin

from judgeopt.robots import get_robot, register_robot
from judgeopt.sim.controller import solve_ik, wrap_angles
from judgeopt.tasks.scoop.arm_path import level_pose, tool_model
from judgeopt.tasks.scoop.placement import scoop_line
from judgeopt.tasks.scoop.scene import SceneConfig


def score(reach) -> float:
    """Every position reached first; then the joint-limit margin (rad, counted up to 1) plus ten
    times the smallest singular value (counted up to 1): far from the limits and from a singularity."""
    if not reach.reached.all():
        return float(reach.reached.mean()) - 1.0
    return min(float(reach.margin.min()), 1.0) + min(10 * float(reach.sigma_min.min()), 1.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("robot")
    ap.add_argument("--seeds", type=int, default=12)
    args = ap.parse_args()
    spec = get_robot(args.robot)
    # the search moves the base from the world's origin: the arm as written with its own placement undone
    unplaced = dataclasses.replace(spec, name=f"{spec.name}_unplaced", base_xyz=(0.0, 0.0, 0.0), base_yaw=0.0)
    register_robot(unplaced)
    scene = SceneConfig(robot=unplaced.name)
    base_model, tcp = tool_model(scene)
    first = base_model.jointPlacements[1].copy()
    rng = np.random.default_rng(0)
    lo, hi = base_model.lowerPositionLimit, base_model.upperPositionLimit
    best = (-np.inf, None)
    for bx in np.arange(-0.45, 0.151, 0.05):
        for bz in np.arange(0.0, 0.501, 0.05):
            base = pin.SE3(np.eye(3), np.array([bx, 0.0, bz]))
            base_model.jointPlacements[1] = base * first
            for k in range(args.seeds):
                seed = np.array(spec.home) if k == 0 else rng.uniform(np.maximum(lo, -np.pi), np.minimum(hi, np.pi))
                try:
                    home = solve_ik(base_model, tcp, level_pose(scene, 0.0), seed)
                except ValueError:
                    continue
                home = wrap_angles(home)
                s = score(scoop_line(unplaced.name, home=home, model=(base_model, tcp)))
                if s > best[0]:
                    best = (s, (round(float(bx), 3) + 0.0, round(float(bz), 3) + 0.0, home.round(3).tolist()))
        print(f"base x {bx:+.2f}: best so far {best[0]:.3f} {best[1]}", flush=True)
    if best[1] is None:
        raise SystemExit(f"no base placement on the grid holds the tool level at the home point from {args.seeds} "
                         "IK starts: try more --seeds, or a base grid that suits this arm")
    s, (bx, bz, home) = best
    print(f"\nscore {s:.3f}\nbase_xyz=({bx}, 0.0, {bz}),\nhome={tuple(home)},")


if __name__ == "__main__":
    main()
