"""The amortised planner (the paper's NN_trajectory, Fig. 3) as it plans: the generator's rollout in numpy.

Why its own module, with no torch: a plan is 31 tiny matrix-vector products, which numpy runs
faster than torch's per-call overhead, and a one-shot `judgeopt solve` then needs no torch at all
(the weights come from the cache's numpy copy, judgeopt.formats.model_files.read_arrays). The network
itself, its training and its batched rollout stay in judgeopt.planners.generator (torch).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from functools import cached_property
from typing import Any, Mapping

import numpy as np

from judgeopt.planners.base import BuildContext, Planner
from judgeopt.planners.dynamics import plan_from_parts, step
from judgeopt.planners.limits import CONDITION_NAMES, LimitRanges, limits_of
from judgeopt.planners.problem import Problem
from judgeopt.planners.result import PlanResult, constraint_residuals
from judgeopt.trajectory import Plan


@dataclass(frozen=True)
class GeneratorConfig:
    """Table 3: two fully connected layers of 150 units."""

    hidden: int = 150
    layers: int = 2

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class OutputScales:
    """What scales the generator's inputs and outputs, from its problem's limits: positions around
    the middle of their range, velocities by half theirs, forces around the middle of their range,
    accelerations that can cross the velocity range in a few steps."""

    q_mid: np.ndarray
    q_half: np.ndarray
    v_half: np.ndarray
    f_mid: np.ndarray
    f_half: np.ndarray
    a_scale: np.ndarray

    @classmethod
    def of(cls, problem: Problem) -> "OutputScales":
        v = {k: problem.vec(k) for k in ("f_min", "f_max", "qdot_min", "qdot_max", "q_min", "q_max")}
        return cls(0.5 * (v["q_min"] + v["q_max"]), 0.5 * (v["q_max"] - v["q_min"]), 0.5 * (v["qdot_max"] - v["qdot_min"]),
                   0.5 * (v["f_min"] + v["f_max"]), 0.5 * (v["f_max"] - v["f_min"]),
                   (v["qdot_max"] - v["qdot_min"]) / (4 * problem.dt))


def input_size(problem: Problem, conditioned: LimitRanges | None) -> int:
    """The network's inputs: positions and velocities per axis, time, environment (and limits)."""
    return 2 * problem.n_axes + 1 + len(problem.env_names) + (len(CONDITION_NAMES) if conditioned is not None else 0)


@dataclass(frozen=True)
class GeneratorArrays:
    """A trained generator as numpy float64 arrays: what the amortised planner runs."""

    problem: Problem
    config: GeneratorConfig
    conditioned: LimitRanges | None
    weights: tuple[tuple[np.ndarray, np.ndarray], ...]  # (W, b) per Linear layer
    e_mid: np.ndarray
    e_half: np.ndarray
    c_mid: np.ndarray | None
    c_half: np.ndarray | None

    @property
    def n_axes(self) -> int:
        return self.problem.n_axes

    @property
    def n_forces(self) -> int:
        return self.problem.n_forces

    @classmethod
    def from_state(cls, problem: Problem, config: GeneratorConfig, conditioned: LimitRanges | None,
                   state: Mapping[str, Any]) -> "GeneratorArrays":
        """From a generator's state_dict as arrays (torch's or the cache's numpy copy); a ValueError
        naming the first array missing or of the wrong shape."""
        def get(key: str, shape: tuple[int, ...]) -> np.ndarray:
            if key not in state:
                raise ValueError(f"no {key} in the weights")
            a = np.asarray(state[key], dtype=np.float64)
            if a.shape != shape:
                raise ValueError(f"{key} has shape {a.shape}, the architecture needs {shape}")
            return a

        n_in, weights = input_size(problem, conditioned), []
        for i in range(config.layers + 1):
            n_out = config.hidden if i < config.layers else problem.n_forces + problem.n_axes
            weights.append((get(f"net.{2 * i}.weight", (n_out, n_in)), get(f"net.{2 * i}.bias", (n_out,))))
            n_in = n_out
        ne, nc = len(problem.env_names), len(CONDITION_NAMES)
        cond = conditioned is not None
        return cls(problem, config, conditioned, tuple(weights), get("e_mid", (ne,)), get("e_half", (ne,)),
                   get("c_mid", (nc,)) if cond else None, get("c_half", (nc,)) if cond else None)


#: where the arm's joints cap the tool's speed below q̇_max, the generator is asked again at most this often
JOINT_SPEED_TRIES = 3


class AmortizedPlanner(Planner):
    """Plans with a trained generator in milliseconds; constraints are soft (penalties in
    training), so the residuals are measured and reported, never assumed to be zero."""

    method = "amortized"

    def __init__(self, generator: Any, problem: Problem, judge: Any = None):
        """`generator`: GeneratorArrays, or the torch Generator (its arrays are taken)."""
        g = generator if isinstance(generator, GeneratorArrays) else generator.arrays()
        self.generator, self.problem, self.judge = g, problem, judge
        self._weights = g.weights
        self._e_mid, self._e_half = g.e_mid, g.e_half
        s = OutputScales.of(g.problem)
        self._q_mid, self._q_half = s.q_mid, s.q_half
        self._c, self._scales = self._conditioning(limits_of(problem)) if g.conditioned is not None else \
            (np.empty(0), (s.f_mid, s.f_half, s.a_scale, s.v_half))

    def _conditioning(self, limits: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
        """A conditioned generator's extra inputs for these limits (q̇_max, f_min, f_max), and its output
        scales (force middle and half-range, acceleration scale, velocity half-range)."""
        g = self.generator
        qmax, fmin, fmax = limits
        qdot_min = g.problem.vec("qdot_min")
        return (limits - g.c_mid) / g.c_half, (np.full(g.n_forces, 0.5 * (fmin + fmax)),
                                               np.full(g.n_forces, 0.5 * (fmax - fmin)),
                                               (qmax - qdot_min) / (4 * g.problem.dt), 0.5 * (qmax - qdot_min))

    @classmethod
    def build(cls, context: BuildContext) -> "AmortizedPlanner":
        """With the generator found for the context's limits (the registry leaves this planner out
        where none covers them)."""
        return cls(context.generator, context.problem, context.judge)

    def plan(self, env: dict[str, float]) -> Plan:
        """The generator's plan (see `asked`)."""
        return self.asked(env)[0]

    def asked(self, env: dict[str, float]) -> tuple[Plan, str]:
        """The generator's plan, and "" or what it was asked instead of the problem's q̇_max. On an arm whose
        joint limits the problem holds, where the plan moves faster than the arm's joints allow at every
        position it passes (JointMap.speed_cap), a generator conditioned on q̇_max is asked again at that
        speed (at most JOINT_SPEED_TRIES times). Why: it knows tool limits only; asked for 1 m/s on the
        Kinova its plans broke joint 1's speed limit by 2-2.5x, so the direct solve started cold, far from
        the demonstrations, and 5 of 50 of its plans failed; asked at the joints' speed, none broke it
        and the direct solve, started from them, succeeded in all 50 (docs/guides/arm.md, "A slow arm")."""
        plan, qs, vs = self._rollout(env, self._c, self._scales)
        scale = self.problem.joint_limit_scale
        # no joint limits held, a generator that cannot be asked, or no position within the limits where a joint binds
        if scale is None or self.generator.conditioned is None or vs.max() <= self._joint_speed_everywhere:
            return plan, ""
        from judgeopt.planners.joint_limits import joint_map

        arm = joint_map(self.problem)
        limits = limits_of(self.problem)
        speed, lowest, said = float(limits[0]), self.generator.conditioned.qdot_max[0], ""
        for _ in range(JOINT_SPEED_TRIES):
            cap, joint, _ = arm.speed_cap(float(qs.min()), float(qs.max()), scale)
            if vs.max() <= cap or speed <= lowest:
                break
            speed = max(min(speed, cap), lowest)
            plan, qs, vs = self._rollout(env, *self._conditioning(np.array([speed, *limits[1:]])))
            said = (f"the generator was asked for q̇_max {speed:.3g} m/s, the most {joint}'s speed limit allows "
                    "along its plan")
        return plan, said

    @cached_property
    def _joint_speed_everywhere(self) -> float:
        """The tool speed the arm's joints allow at every position within the problem's limits: a plan no
        faster needs no check of its own (one evaluation of the joint tables, 2-3 ms, instead of one per plan)."""
        from judgeopt.planners.joint_limits import joint_map

        lo, hi = (float(self.problem.vec(k)[0]) for k in ("q_min", "q_max"))
        return joint_map(self.problem).speed_cap(lo, hi, self.problem.joint_limit_scale)[0]

    def _rollout(self, env: dict[str, float], c: np.ndarray,
                 scales: tuple[np.ndarray, ...]) -> tuple[Plan, np.ndarray, np.ndarray]:
        """The generator's rollout in numpy float64 (equal to Generator.rollout to float32 rounding), with
        its conditioning `c` and output `scales`; and its positions and velocities."""
        g, pr = self.generator, self.generator.problem
        n, dt = pr.steps, pr.dt
        f_mid, f_half, a_scale, v_half = scales
        na, nf = g.n_axes, g.n_forces
        en = (np.array([env[k] for k in pr.env_names]) - self._e_mid) / self._e_half
        x = np.empty(2 * na + 1 + en.size + c.size)
        x[2 * na + 1:2 * na + 1 + en.size] = en
        x[2 * na + 1 + en.size:] = c
        q, v = pr.vec("q0"), pr.vec("qdot0")
        qs, vs, fs = np.empty((n + 1, na)), np.empty((n + 1, na)), np.empty((n + 1, nf))
        for k in range(n + 1):
            x[:na], x[na:2 * na], x[2 * na] = (q - self._q_mid) / self._q_half, v / v_half, 2 * k / n - 1
            h = x
            for w, b in self._weights[:-1]:
                h = np.tanh(w @ h + b)
            w, b = self._weights[-1]
            o = w @ h + b
            qs[k], vs[k], fs[k] = q, v, f_mid + f_half * o[:nf]
            q, v = step(q, v, a_scale * o[nf:], dt)
        return plan_from_parts(self.problem, qs, vs, fs), qs, vs

    def warm_start_plan(self, env: dict[str, float], guess: Any = None) -> Plan:
        """The plan `solve` returns, without judging it: a warm start needs only the plan (the
        judge's p and the residuals cost a service's request about as much as the rollout)."""
        return self.plan(self.problem.env_dict(env))

    def solve(self, env: dict[str, float], guess: Any = None) -> PlanResult:
        env = self.problem.env_dict(env)
        t0 = time.perf_counter()
        plan, asked = self.asked(env)
        elapsed = time.perf_counter() - t0
        prob = None
        if self.judge is not None:
            from judgeopt.planners.direct import judge_env

            prob = float(self.judge.predict_proba(plan.as_array()[None], judge_env(self.judge, env)[None])[0])
        result = PlanResult(self.method, env, plan, prob, "generated", elapsed,
                            constraint_residuals(self.problem, plan, env), iterations=None,
                            message="one forward rollout (constraints soft)" + (f"; {asked}" if asked else ""))
        if asked:
            result.info["generator_asked"] = asked
        return result

    def details(self, result: PlanResult) -> list[str]:
        """Planner.details (the binding joint), and the speed the generator was asked at instead of q̇_max."""
        lines = super().details(result)
        asked = result.info.get("generator_asked")
        return [f"{lines[0]}; {asked}", *lines[1:]] if asked else lines  # asked: joint limits held, so a line
