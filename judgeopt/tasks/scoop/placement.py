"""Where an arm can hold the spatula on the scooping line: IK along the line, level, the blade on
the plate and lifted, with each configuration's distance to the joints' position limits and the
Jacobian's smallest singular value (how far from a singularity).

Why: an arm config's base placement and home posture (judgeopt.robots) are only right if the whole
line the plans use lies inside the workspace with margin; this measures it, for the tests, for
`judgeopt robots --reach` and for choosing a new arm's placement (scripts/place_arm.py).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import pinocchio as pin

from judgeopt.robots import get_robot
from judgeopt.sim.controller import solve_ik, wrap_angles
from judgeopt.tasks.scoop.arm_path import level_pose, tool_model
from judgeopt.tasks.scoop.rollout import Y_RANGE, RolloutConfig
from judgeopt.tasks.scoop.scene import SceneConfig


@dataclass(frozen=True)
class Reach:
    """The arm along the line: per sampled position y [m], whether IK reached the pose (blade on the
    plate and lifted as the rollout lifts it), the least distance of any joint to its position limits [rad] and the
    smallest singular value of the TCP's Jacobian over both poses."""

    robot: str
    y: np.ndarray
    reached: np.ndarray
    margin: np.ndarray
    sigma_min: np.ndarray

    def segment(self) -> tuple[float, float] | None:
        """The longest run of reached positions, as (first y, last y); None where none is reached."""
        best, start = None, None
        for i, ok in enumerate([*self.reached, False]):
            if ok and start is None:
                start = i
            elif not ok and start is not None:
                if best is None or i - start > best[1] - best[0]:
                    best = (start, i)
                start = None
        return None if best is None else (float(self.y[best[0]]), float(self.y[best[1] - 1]))


def scoop_line(robot: str, scene: SceneConfig | None = None, step: float = 0.025, home: np.ndarray | None = None,
               model: tuple[pin.Model, int] | None = None) -> Reach:
    """IK along the positions the rollout may command (rollout.Y_RANGE), from the arm's home posture
    outwards from y = 0, each pose started from its neighbour's solution (the branch the rollout keeps),
    angles wrapped to [-pi, pi) as the driver does."""
    cfg = replace(scene or SceneConfig(), robot=robot)
    lift = RolloutConfig().lift_height
    m, tcp = model or tool_model(cfg)
    data = m.createData()
    y = np.round(np.arange(Y_RANGE[0], Y_RANGE[1] + step / 2, step), 9)
    reached, margin, sigma = np.zeros(len(y), bool), np.full(len(y), -np.inf), np.zeros(len(y))
    start = np.array(get_robot(robot).home if home is None else home, dtype=float)
    centre = int(np.argmin(np.abs(y)))
    for order in (range(centre, len(y)), range(centre, -1, -1)):
        q_prev = start
        for i in order:
            try:
                qs = [solve_ik(m, tcp, level_pose(cfg, float(y[i]), h), q_prev) for h in (0.0, lift)]
            except ValueError:
                break
            q_prev = qs[0]
            wrapped = [wrap_angles(q) for q in qs]
            margin[i] = min(float(np.min(np.minimum(q - m.lowerPositionLimit, m.upperPositionLimit - q)))
                            for q in wrapped)
            sigma[i] = min(float(np.linalg.svd(pin.computeFrameJacobian(m, data, q, tcp, pin.LOCAL_WORLD_ALIGNED),
                                               compute_uv=False)[-1]) for q in wrapped)
            reached[i] = margin[i] >= 0.0
            if not reached[i]:
                break
    return Reach(robot, y, reached, margin, sigma)
