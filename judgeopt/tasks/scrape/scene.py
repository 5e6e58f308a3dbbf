"""The scrape scene in PyBullet and its rollout: a rigid plate with its front edge at y = 0.24 m,
a tray below the edge, a wedge-sided puck, and the UR5 with the scoop's spatula.

Frames as in the scoop: world = UR5 base, z up, the plate's top is z = 0. The TCP is the blade
centre; its commanded rotation tilts the blade `pitch_up_deg` front-edge-up beyond its usual
angle, so it rests on its heel with the front edge a few mm above the plate.

Facts measured while designing it (docs/tasks.md has the figures):
- The paper's task-space gains (Kp = 1000 1/s^2) let 1 N of sideways load move the TCP ~7 mm
  and tilt the blade ~3 deg; pushing a 1 kg puck needs stiff x-y gains (`STIFF`). Force control
  in z is unchanged.
- A blade whose front edge touches the plate pushes any puck flat, whatever the force: the
  contact normal is the 0.3 mm front face's. Lifted a few mm, its edge meets the puck's sloped
  side, and the pressing force decides whether it stays down or rides up the wedge.
- The heel chatters on the rigid plate, so the measured force is averaged over each 50 ms
  sample window; it still reads above the command (about 1.3x at rest, more while pushing).

Success: at the end (after a 5 cm lift and 0.6 s to fall) the puck's centre is inside the tray's
walls and below their top.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np
import pinocchio as pin

from judgeopt.sim.quiet import pb
from judgeopt.sim.arm import ArmDriver, connect, load_arm
from judgeopt.sim.controller import ControllerConfig, TaskCommand
from judgeopt.sim.robot import SpatulaGeometry
from judgeopt.tasks.base import Outcome, TaskSimulator
from judgeopt.tasks.scrape.spec import CHANNELS, START
from judgeopt.trajectory import DEFAULT_DT, Plan, PlanError

Y_EDGE = 0.24  # the plate's front edge (m)
#: what the arm can be commanded to (wider than the demonstrated ranges a problem's limits use:
#: a plan that overshoots them a little is replayed, and judged by what happens)
REACH = {"x": (0.10, 0.50), "y": (-0.10, 0.30), "f": (0.0, 60.0)}

#: stiff in x, y and rotation; z (force-controlled) as the paper's Table 1
STIFF = ControllerConfig(kp=(2e4, 2e4, 1000.0, 2e4, 2e4, 2e4), kv=(300.0,) * 6, cutoff_hz=50.0)


@dataclass(frozen=True)
class PuckGeometry:
    """A truncated cone: 6 mm high, its side sloped 30 deg, heavy enough to need pushing."""

    r_bottom: float = 0.040
    r_top: float = 0.0296
    height: float = 0.006
    mass: float = 1.0
    sides: int = 32

    def vertices(self) -> list[list[float]]:
        return [[r * math.cos(2 * math.pi * k / self.sides), r * math.sin(2 * math.pi * k / self.sides), z]
                for r, z in ((self.r_bottom, -self.height / 2), (self.r_top, self.height / 2)) for k in range(self.sides)]


@dataclass(frozen=True)
class ScrapeConfig:
    timestep: float = 1e-3
    solver_iterations: int = 50
    spatula: SpatulaGeometry = field(default_factory=SpatulaGeometry)
    puck: PuckGeometry = field(default_factory=PuckGeometry)
    controller: ControllerConfig = STIFF
    pitch_up_deg: float = 2.0  # the blade's front edge up by this angle beyond its usual tilt
    blade_puck_friction: float = 0.2
    blade_plate_friction: float = 0.15  # independent of mu
    tray_x: float = 0.30
    tray_inner_half_x: float = 0.14  # catches any straight push of a puck in the sampled x_obj range
    tray_length: float = 0.20
    tray_floor_z: float = -0.08
    tray_wall_top: float = -0.02
    settle_time: float = 0.1
    lift_height: float = 0.05
    lift_time: float = 0.2
    fall_time: float = 0.6


def check_plan(plan: Plan) -> None:
    names = tuple(c.name for c in plan.channels)
    if names != tuple(c.name for c in CHANNELS):
        raise PlanError(f"the plan has channels {', '.join(names)}; the scrape's simulator takes "
                        f"{', '.join(c.name for c in CHANNELS)}")
    for name, (lo, hi) in REACH.items():
        values = getattr(plan, name)
        bad = np.flatnonzero((values < lo - 1e-6) | (values > hi + 1e-6))  # a solver's bound tolerance passes
        if bad.size:
            k = int(bad[0])
            raise PlanError(f"commanded {name} = {values[k]:.4g} at sample {k} is outside the reachable range [{lo}, {hi}]")


class ScrapeSimulator(TaskSimulator):
    """One PyBullet client with the scrape scene; every rollout starts from the same snapshot."""

    def __init__(self, config: ScrapeConfig | None = None):
        from judgeopt.tasks import get_task

        self.task = get_task("scrape")
        self.config = cfg = config or ScrapeConfig()
        self.client = c = connect(cfg.timestep, cfg.solver_iterations)
        self.arm = load_arm(c, cfg.spatula, visual_shapes=False)  # nothing renders the scrape: physics only
        links = self.arm.links
        self.blade_top, self.blade_bottom = links["blade_top"], links["blade_bottom"]
        self.plate = self._box([0.25, 0.25, 0.05], [0.3, Y_EDGE - 0.25, -0.05], [0.45, 0.5, 0.42, 1])
        t, fz, hx, length = 0.005, cfg.tray_floor_z, cfg.tray_inner_half_x, cfg.tray_length
        wall = (cfg.tray_wall_top - fz) / 2
        blue = [0.3, 0.3, 0.6, 1]
        tray = [self._box([hx + 2 * t, length / 2, t], [cfg.tray_x, Y_EDGE + length / 2, fz - t], blue),
                self._box([t, length / 2, wall], [cfg.tray_x - hx - t, Y_EDGE + length / 2, fz + wall], blue),
                self._box([t, length / 2, wall], [cfg.tray_x + hx + t, Y_EDGE + length / 2, fz + wall], blue),
                self._box([hx + 2 * t, t, wall], [cfg.tray_x, Y_EDGE + length + t, fz + wall], blue)]
        floor = self._box([1.0, 1.0, 0.01], [0.3, 0.2, -0.31], [0.8, 0.8, 0.8, 1])
        col = pb.createCollisionShape(pb.GEOM_MESH, vertices=cfg.puck.vertices(), physicsClientId=c)
        self.puck = pb.createMultiBody(cfg.puck.mass, col, -1, [0.3, 0.1, 0.5], physicsClientId=c)
        pb.changeDynamics(self.puck, -1, lateralFriction=1.0, physicsClientId=c)
        # collision layers: blade top <-> puck, blade bottom <-> plate, puck <-> plate, tray, floor
        robot = self.arm.robot
        pb.setCollisionFilterGroupMask(robot, self.blade_top, 1, 1, physicsClientId=c)
        pb.setCollisionFilterGroupMask(robot, self.blade_bottom, 2, 2, physicsClientId=c)
        pb.setCollisionFilterGroupMask(self.puck, -1, 1, 1 | 4, physicsClientId=c)
        for b in [self.plate, *tray, floor]:
            pb.setCollisionFilterGroupMask(b, -1, 2 | 4, 2 | 4, physicsClientId=c)
        for b in [*tray, floor]:
            pb.changeDynamics(b, -1, lateralFriction=0.5, physicsClientId=c)
        pb.changeDynamics(robot, self.blade_top, lateralFriction=cfg.blade_puck_friction, physicsClientId=c)
        self.driver = ArmDriver(self.arm, cfg.spatula, cfg.controller)
        g, tilt = cfg.spatula, math.radians(cfg.pitch_up_deg)
        self.rotation = pin.rpy.rpyToMatrix(math.radians(g.blade_tilt_deg) + tilt, 0.0, 0.0)
        self.z_contact = 0.5 * g.blade_length * math.sin(tilt) + 0.5 * g.blade_thickness * math.cos(tilt)
        self.start_joints = self.driver.joints_for(pin.SE3(self.rotation, np.array([*START, self.z_contact])))
        self.state_id = pb.saveState(physicsClientId=c)

    def _box(self, half: list[float], pos: list[float], rgba: list[float]) -> int:
        c = self.client
        col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=c)
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=rgba, physicsClientId=c)
        return pb.createMultiBody(0, col, vis, pos, physicsClientId=c)

    def _reset(self, env: Mapping[str, float]) -> None:
        c, cfg = self.client, self.config
        pb.restoreState(self.state_id, physicsClientId=c)
        self.driver.reset(self.start_joints)
        pb.changeDynamics(self.plate, -1, lateralFriction=env["mu"], physicsClientId=c)
        # Bullet multiplies the two bodies' coefficients: keep the blade-plate friction fixed
        pb.changeDynamics(self.arm.robot, self.blade_bottom, lateralFriction=cfg.blade_plate_friction / env["mu"],
                          physicsClientId=c)
        pb.resetBasePositionAndOrientation(self.puck, [env["x_obj"], env["y_obj"], cfg.puck.height / 2], [0, 0, 0, 1],
                                           physicsClientId=c)
        pb.resetBaseVelocity(self.puck, [0, 0, 0], [0, 0, 0], physicsClientId=c)

    def puck_position(self) -> np.ndarray:
        return np.array(pb.getBasePositionAndOrientation(self.puck, physicsClientId=self.client)[0])

    def simulate(self, plan: Any, env: Mapping[str, float], record: int = 0) -> Outcome:
        """Replay `plan` ([x, y, xdot, ydot, f]; a Plan or an array at the default period): an
        `Execution` stepped through at once."""
        run = self.start(plan, env, record)
        run.advance(run.plan, run.plan.horizon)
        return run.outcome()

    def start(self, plan: Any, env: Mapping[str, float], record: int = 0) -> "Execution":
        """Start executing `plan` in `env` as it is (settled onto its first force at its first
        position), to be stepped with `Execution.advance`, which may be given a re-planned command."""
        plan = plan if isinstance(plan, Plan) else Plan.from_array(DEFAULT_DT, plan, CHANNELS)
        check_plan(plan)
        return Execution(self, plan, self.task.check_env(env), record)

    def execute(self, plan: Any, env: Mapping[str, float], record: int = 0) -> "Execution":
        """The task interface's stepping (`start`; a perturbed world's simulator overrides it)."""
        return self.start(plan, env, record)

    def close(self) -> None:
        if pb.isConnected(self.client):
            pb.disconnect(self.client)


class Execution:
    """One scrape, stepped: `advance(plan, k)` runs the control steps up to planner sample k of
    `plan` (which may differ from the plan it started with), `measured()` is the response so far
    (the force of each sample averaged over the steps around it that have been taken), `outcome()`
    finishes the plan, lifts and judges."""

    def __init__(self, sim: ScrapeSimulator, plan: Plan, env: Mapping[str, float], record: int = 0):
        self.sim, self.plan, self.record = sim, plan, record
        cfg, step = sim.config, sim.config.timestep
        sim._reset(env)
        self.start = sim.puck_position()
        self.cmd = TaskCommand(position=np.array([plan.x[0], plan.y[0], sim.z_contact]), rotation=sim.rotation)
        for i in range(n_settle := int(round(cfg.settle_time / step))):
            self.cmd.force_z = plan.f[0] * (i + 1) / n_settle
            sim.driver.step(self.cmd)
        self.every = int(round(plan.dt / step))
        self.n_fine = plan.horizon * self.every + 1
        self.response = np.zeros((plan.horizon + 1, 5))
        self.force = np.zeros(self.n_fine)
        self.velocity = np.zeros(6)
        self.max_lift = 0.0
        self.frames: list = []
        self.i = 0

    @property
    def k(self) -> int:
        """Planner samples measured so far."""
        return -(-self.i // self.every)

    def _force(self, k: int, upto: int) -> float:
        """Sample k's force: the mean over the steps within half a period of it, of those taken."""
        return self.force[max(0, k * self.every - self.every // 2):min(upto, k * self.every + self.every // 2 + 1)].mean()

    def measured(self) -> np.ndarray:
        out = self.response[:self.k].copy()
        for k in range(self.k):
            out[k, 4] = self._force(k, self.i)
        return out

    def advance(self, plan: Plan, k: int) -> None:
        if plan.dt != self.plan.dt or plan.horizon != self.plan.horizon:
            raise ValueError("a re-planned command must keep the period and horizon of the first")
        self.plan = plan
        sim, ctl = self.sim, self.sim.driver.controller
        _, fine = plan.resample(sim.config.timestep)
        cmd, velocity = self.cmd, self.velocity
        last = min(k * self.every, len(fine) - 1)
        start = self.i
        rows = fine[start:last + 1].tolist()  # Python floats: indexing an array costs more at 1 kHz
        while self.i <= last:
            i = self.i
            cmd.position[0], cmd.position[1], velocity[0], velocity[1], cmd.force_z = rows[i - start]
            cmd.velocity = velocity
            if i % self.every == 0:  # sample the response before the step that starts at t_k
                self.response[i // self.every, :4] = ctl.position[0], ctl.position[1], ctl.velocity[0], ctl.velocity[1]
            sim.driver.step(cmd)
            self.force[i] = ctl.f_est[2]
            self.max_lift = max(self.max_lift, ctl.position[2] - sim.z_contact)
            if self.record and i % self.record == 0:
                self.frames.append((ctl.position.copy(), sim.puck_position()))
            self.i += 1

    def outcome(self) -> Outcome:
        self.advance(self.plan, self.plan.horizon)
        sim, cfg, ctl, step = self.sim, self.sim.config, self.sim.driver.controller, self.sim.config.timestep
        response = self.response
        for k in range(self.plan.horizon + 1):  # the force over the window centred on each sample
            response[k, 4] = self._force(k, self.n_fine)
        after_motion = sim.puck_position()
        lift = TaskCommand(position=ctl.position.copy(), rotation=sim.rotation, selection=np.ones(6))
        z0, n_lift = ctl.position[2], int(round(cfg.lift_time / step))
        for i in range(n_lift + int(round(cfg.fall_time / step))):
            s = min(1.0, (i + 1) / n_lift)
            lift.position[2] = z0 + cfg.lift_height * (0.5 - 0.5 * math.cos(math.pi * s))
            sim.driver.step(lift)
        end = sim.puck_position()
        in_tray = bool(abs(end[0] - cfg.tray_x) <= cfg.tray_inner_half_x and Y_EDGE < end[1] <= Y_EDGE + cfg.tray_length
                       and end[2] < cfg.tray_wall_top)
        pushed = float(after_motion[1] - self.start[1])
        details = {"in_tray": in_tray, "pushed": pushed, "blade_max_lift": float(self.max_lift),
                   "puck_end": end.tolist(), "puck_after_motion": after_motion.tolist()}
        if self.record:
            details["frames"] = self.frames
        # a search scored by the simulator: success first, then how far towards the edge
        progress = 10.0 * in_tray + min(max(pushed / max(Y_EDGE - self.start[1], 1e-6), 0.0), 1.0)
        return Outcome(in_tray, response, details, progress)

