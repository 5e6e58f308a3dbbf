"""Replay a plan on the simulated arm and judge the outcome from the object's final state.

Phases of one rollout (1 ms steps):
1. settle: the arm holds the plan's start position while the pressing force ramps from 0
   to the plan's first value (the blade starts touching the plate);
2. motion: the plan, interpolated to 1 ms, under hybrid position/force control;
3. lift: pure position control; the spatula rises `lift_height` and tilts its blade back
   by `lift_tilt_deg` (as a cook levels the spatula), then holds still.

Success criterion (`success_test = "clear"`, since 2026-11-23): at the end of the hold the
object is clear of the plate (its lowest point at least `success_clearance` above the plate's
surface), it touches the blade and not the plate, and its centre lies within `max_overhang` of
the blade centre, i.e. it came up with the spatula resting on the blade, not hanging off its
edge. A pushed object stays on the plate, one flicked over the blade falls back, one caught on
the edge overhangs: all fail. The test before (`success_test = "rise"`, every shipped dataset)
asked the object's centre to rise `success_rise` above its start height instead of clearing
the plate: on a softer mat the blade sinks deeper and a carried object rose less than that.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np
import pinocchio as pin
from judgeopt.sim.quiet import pb

from judgeopt.sim.arm import ArmDriver
from judgeopt.sim.controller import ControllerConfig, TaskCommand, solve_ik
from judgeopt.tasks.scoop.scene import Scene, SceneConfig, check_environment
from judgeopt.tasks.base import Outcome, TaskSimulator
from judgeopt.tasks.scoop.spec import CHANNELS
from judgeopt.trajectory import DEFAULT_DT, Plan, PlanError

#: reachable range of the commanded TCP y along the scooping line (m), and pressing force (N)
Y_RANGE = (-0.25, 0.45)
F_RANGE = (0.0, 60.0)


@dataclass(frozen=True)
class RolloutConfig:
    settle_time: float = 0.1
    lift_height: float = 0.05
    lift_tilt_deg: float = 12.0
    lift_time: float = 0.25
    hold_time: float = 0.15
    success_rise: float = 0.025  # success_test "rise": the object's centre rose this much from its start
    max_overhang: float = 0.035  # the object's centre at most this far from the blade centre
    success_test: str = "clear"  # "clear" (of the plate, on the blade) or "rise" (before 2026-11-23)
    success_clearance: float = 0.005  # success_test "clear": the object's lowest point this far above the plate


@dataclass
class RolloutResult:
    """Responses at the plan's sample times (same channels as the plan) and the outcome."""

    y: np.ndarray
    ydot: np.ndarray
    f: np.ndarray
    success: bool
    object_rise: float
    object_shift: float  # object's y displacement at the end of the motion phase
    info: dict = field(default_factory=dict)

    def as_array(self) -> np.ndarray:
        return np.stack([self.y, self.ydot, self.f], axis=1)


def check_plan(plan: Plan) -> None:
    """Reject commands the arm cannot follow, naming the value and the allowed range."""
    names = tuple(c.name for c in plan.channels)
    if names != tuple(c.name for c in CHANNELS):
        raise PlanError(f"the plan has channels {', '.join(names)}; the scoop's simulator takes "
                        f"{', '.join(c.name for c in CHANNELS)}")
    for name, (lo, hi), values in (("y", Y_RANGE, plan.y), ("f", F_RANGE, plan.f)):
        bad = np.flatnonzero((values < lo) | (values > hi))
        if bad.size:
            k = int(bad[0])
            raise PlanError(f"commanded {name} = {values[k]:.4g} at sample {k} is outside the reachable range [{lo}, {hi}]")


class Simulator(TaskSimulator):
    """A scene, its controller and the rollout procedure; one per process (PyBullet client)."""

    def __init__(self, scene: SceneConfig | None = None, controller: ControllerConfig | None = None,
                 rollout: RolloutConfig | None = None, visual_shapes: bool = True):
        self.scene = Scene(scene, visual_shapes)
        self.rollout_config = rollout or RolloutConfig()
        g = self.scene.config.spatula
        self.driver = ArmDriver(self.scene.arm, g, controller)
        self.controller = self.driver.controller
        self.z_contact = g.tcp_height_on_plate()
        self._ik_cache: dict[float, np.ndarray] = {}

    # -- arm placement -----------------------------------------------------------------
    def home_joints(self, y0: float) -> np.ndarray:
        key = round(float(y0), 9)
        if key not in self._ik_cache:
            self._ik_cache[key] = self.driver.joints_for(
                pin.SE3(np.eye(3), np.array([self.scene.config.x_home, y0, self.z_contact])))
        return self._ik_cache[key]

    def reset(self, y0: float, y_obj: float, mu: float, height: float = 0.0) -> None:
        """Arm at TCP (x_home, y0, contact height + `height`), object at y_obj, friction mu."""
        check_environment(y_obj, mu)
        target = pin.SE3(np.eye(3), np.array([self.scene.config.x_home, y0, self.z_contact + height]))
        q0 = self.home_joints(y0) if height == 0.0 else solve_ik(self.controller.model, self.controller.tcp, target,
                                                                  self.home_joints(y0))
        self._reset(q0, y_obj, mu)

    def step(self, cmd: TaskCommand) -> None:
        """One 1 ms control step: read the sensors, compute the torques, step the physics."""
        self.driver.step(cmd)

    def _reset(self, q0: np.ndarray, y_obj: float, mu: float) -> None:
        sc = self.scene
        sc.restore()
        self.driver.reset(q0)
        sc.set_mu(mu)
        sc.place_object(y_obj)

    # -- the rollout -------------------------------------------------------------------
    def simulate(self, plan: np.ndarray | Plan, env: Mapping[str, float], record: int = 0) -> Outcome:
        """The task interface: a Plan, or a (N + 1, 3) [y, ydot, f] array at the default period."""
        if not isinstance(plan, Plan):
            plan = Plan.from_array(DEFAULT_DT, plan, CHANNELS)
        return self.outcome(self.run(plan, float(env["y_obj"]), float(env["mu"]), record=record))

    def outcome(self, r: RolloutResult) -> Outcome:
        """A rollout's result as the task interface's Outcome."""
        cfg = self.rollout_config
        # success dominates; below it, rising with the blade and ending near its centre
        rise = min(max(r.object_rise, 0.0) / cfg.success_rise, 1.0)
        offset = min(r.info["offset_from_blade"] / cfg.max_overhang, 3.0)
        progress = 10.0 * float(r.success) + rise - 0.3 * offset
        return Outcome(r.success, r.as_array(), {"object_rise": r.object_rise, "object_shift": r.object_shift, **r.info},
                       progress)

    def run(self, plan: Plan, y_obj: float, mu: float, record: int = 0) -> RolloutResult:
        """Replay `plan` in environment (y_obj, mu). `record` > 0 keeps every record-th
        step's scene state in info["frames"] for rendering. The same as an `Execution`
        stepped through the whole plan at once."""
        run = self.start(plan, y_obj, mu, record)
        run.advance(plan, plan.horizon)
        return run.finish()

    def start(self, plan: Plan, y_obj: float, mu: float, record: int = 0) -> "Execution":
        """Start executing `plan` (the arm placed at its first position, settled onto its first
        force); step it with `Execution.advance`, which may be given a re-planned command."""
        check_environment(y_obj, mu)
        check_plan(plan)
        return Execution(self, plan, y_obj, mu, record)

    def execute(self, plan: Plan, env: Mapping[str, float], record: int = 0) -> "Execution":
        """The task interface's stepping: `start` in environment `env`."""
        return self.start(plan, float(env["y_obj"]), float(env["mu"]), record)

    def _snapshot(self) -> dict:
        sc = self.scene
        q = [s[0] for s in pb.getJointStates(sc.robot, sc.arm_joints, physicsClientId=sc.client)]
        p, o = pb.getBasePositionAndOrientation(sc.obj, physicsClientId=sc.client)
        return {"q": q, "obj_pos": p, "obj_orn": o}

    def close(self) -> None:
        self.scene.close()


class Execution:
    """One rollout, stepped: the arm follows a command sample by sample and the response is
    measured as it goes, so a planner can re-plan from what the arm measured (receding
    horizon). `advance(plan, k)` runs the control steps up to planner sample k of `plan`,
    which may differ from the plan the execution started with; `finish` lifts and judges."""

    def __init__(self, sim: Simulator, plan: Plan, y_obj: float, mu: float, record: int = 0):
        self.sim, self.record, self.plan = sim, record, plan
        cfg, sc = sim.rollout_config, sim.scene
        self.step_s = sc.config.timestep
        self.every = int(round(plan.dt / self.step_s))
        sim.reset(float(plan.y[0]), y_obj, mu)
        self.obj_start, _ = sc.object_pose()
        self.cmd = TaskCommand(position=np.array([sc.config.x_home, plan.y[0], sim.z_contact]))
        self.frames: list = []
        self.k_total = 0
        self.i = 0  # control steps of the motion taken
        self.resp = np.zeros((plan.horizon + 1, 3))
        self.vel = np.zeros(6)
        n_settle = int(round(cfg.settle_time / self.step_s))
        for i in range(n_settle):
            self.cmd.force_z = plan.f[0] * (i + 1) / n_settle
            self._step(self.cmd)

    def _step(self, c: TaskCommand) -> None:
        self.sim.step(c)
        self.k_total += 1
        if self.record and self.k_total % self.record == 0:
            self.frames.append(self.sim._snapshot())

    @property
    def k(self) -> int:
        """Planner samples measured so far (the next one to measure)."""
        return -(-self.i // self.every)

    def measured(self) -> np.ndarray:
        """(k, 3) [y, ydot, f] sampled at the planner's period so far: the arm's own readings."""
        return self.resp[:self.k].copy()

    def state(self) -> np.ndarray:
        """The arm's [y, ydot, f] now (before the next control step)."""
        ctl = self.sim.controller
        return np.array([ctl.position[1], ctl.velocity[1], ctl.f_est[2]])

    def advance(self, plan: Plan, k: int) -> None:
        """Control steps from now up to (and including the one that starts at) planner sample k
        of `plan`, each following its 1 ms resampling; the response sampled before each planner
        sample's step."""
        if plan.dt != self.plan.dt or plan.horizon != self.plan.horizon:
            raise ValueError("a re-planned command must keep the period and horizon of the first")
        self.plan = plan
        ctl = self.sim.controller
        _, x = plan.resample(self.step_s)
        last = min(k * self.every, len(x) - 1)
        # the 1 kHz loop: rows as Python floats, names bound once (a step's Python overhead counts
        # next to the physics step; docs/physics.md, "The compiled control step")
        start = self.i
        rows = x[start:last + 1].tolist()
        cmd, vel, every = self.cmd, self.vel, self.every
        step = self._step if self.record else self.sim.step  # _step keeps the frames
        cmd.velocity = vel
        for i in range(start, last + 1):
            cmd.position[1], vel[1], cmd.force_z = rows[i - start]
            if i % every == 0:  # sample the response before the step that starts at t_k
                self.resp[i // every] = (ctl.position[1], ctl.velocity[1], ctl.f_est[2])
            step(cmd)
        if last >= start:
            self.i = last + 1
            if not self.record:
                self.k_total += last + 1 - start

    def outcome(self) -> Outcome:
        """`finish`, as the task interface's Outcome."""
        return self.sim.outcome(self.finish())

    def finish(self) -> RolloutResult:
        """The rest of the current plan, then the lift and the success test."""
        self.advance(self.plan, self.plan.horizon)
        cfg, ctl, sc = self.sim.rollout_config, self.sim.controller, self.sim.scene
        plan = self.plan
        obj_after_motion, _ = sc.object_pose()
        # lift: pure position control, rise and tilt the blade back
        full = np.ones(6)
        n_lift = int(round(cfg.lift_time / self.step_s))
        n_hold = int(round(cfg.hold_time / self.step_s))
        z0 = ctl.position[2]
        tilt = math.radians(cfg.lift_tilt_deg)
        cmd = TaskCommand(position=np.array([sc.config.x_home, plan.y[-1], z0]), selection=full)
        for i in range(n_lift + n_hold):
            s = min(1.0, (i + 1) / n_lift)
            blend = 0.5 - 0.5 * math.cos(math.pi * s)
            cmd.position[2] = z0 + cfg.lift_height * blend
            cmd.rotation = pin.rpy.rpyToMatrix(tilt * blend, 0.0, 0.0)
            self._step(cmd)

        obj_end, _ = sc.object_pose()
        rise = float(obj_end[2] - self.obj_start[2])
        on_blade = sc.contacts(sc.blade_top) > 0
        on_plate = sc.touches_plate()
        offset = float(np.linalg.norm(obj_end[:2] - ctl.position[:2]))
        bottom = sc.object_lowest_point()
        held = on_blade and not on_plate and offset <= cfg.max_overhang
        passed = {"rise": rise >= cfg.success_rise, "clear": bottom >= cfg.success_clearance}
        if cfg.success_test not in passed:
            raise ValueError(f"success_test = {cfg.success_test!r}; choose one of {', '.join(passed)}")
        success = held and passed[cfg.success_test]
        info = {"on_blade": on_blade, "on_plate": on_plate, "object_end": obj_end.tolist(), "offset_from_blade": offset,
                "object_ahead": float(obj_end[1] - ctl.position[1]), "object_bottom": bottom,
                **{f"success_{k}_test": bool(held and v) for k, v in passed.items()}}
        if self.record:
            info["frames"] = self.frames
        r = self.resp
        return RolloutResult(r[:, 0], r[:, 1], r[:, 2], bool(success), rise,
                             float(obj_after_motion[1] - self.obj_start[1]), info)

