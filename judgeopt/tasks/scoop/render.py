"""Render a rollout to an animated GIF with PyBullet's headless (TinyRenderer) camera."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from judgeopt.files import atomic_path
from judgeopt.sim.quiet import pb
from PIL import Image, ImageDraw

from judgeopt.tasks.scoop.rollout import RolloutResult, Simulator
from judgeopt.trajectory import Plan


@dataclass(frozen=True)
class CameraConfig:
    width: int = 480
    height: int = 320
    eye: tuple[float, float, float] = (0.62, 0.16, 0.09)  # side view: y runs left to right
    target: tuple[float, float, float] = (0.3, 0.16, 0.02)
    fov_deg: float = 50.0
    frame_every_ms: int = 20
    slow_motion: float = 2.0


def render_rollout(sim: Simulator, plan: Plan, y_obj: float, mu: float, out: str | Path,
                   camera: CameraConfig = CameraConfig(), caption: str = "") -> RolloutResult:
    """Replay `plan`, then draw the recorded states; the GIF is written atomically."""
    if not sim.scene.visual_shapes:
        raise ValueError("this simulator was built without the arm's meshes, which a camera needs; make it with "
                         "task.simulator(render=True) or Simulator(visual_shapes=True)")
    result = sim.run(plan, y_obj, mu, record=camera.frame_every_ms)
    sc, c = sim.scene, sim.scene.client
    view = pb.computeViewMatrix(camera.eye, camera.target, [0, 0, 1])
    proj = pb.computeProjectionMatrixFOV(camera.fov_deg, camera.width / camera.height, 0.01, 3.0)
    label = f"{caption}  {'SUCCESS' if result.success else 'FAILURE'}  y_obj={y_obj:.3f} m  mu={mu:.2f}"
    images = []
    for k, frame in enumerate(result.info["frames"]):
        for j, qi in zip(sc.arm_joints, frame["q"]):
            pb.resetJointState(sc.robot, j, qi, physicsClientId=c)
        pb.resetBasePositionAndOrientation(sc.obj, frame["obj_pos"], frame["obj_orn"], physicsClientId=c)
        w, h, rgb, _, _ = pb.getCameraImage(camera.width, camera.height, view, proj, renderer=pb.ER_TINY_RENDERER,
                                            physicsClientId=c)
        img = Image.fromarray(np.reshape(np.asarray(rgb, dtype=np.uint8), (h, w, 4))[:, :, :3])
        draw = ImageDraw.Draw(img)
        draw.text((8, 6), f"{label}  t={(k + 1) * camera.frame_every_ms / 1000:.2f} s", fill=(0, 0, 0))
        images.append(img)
    duration = int(camera.frame_every_ms * camera.slow_motion)
    with atomic_path(out) as tmp:
        images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:], duration=duration, loop=0)
    return result
