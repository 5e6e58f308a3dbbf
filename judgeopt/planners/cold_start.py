"""Where the direct solve starts when no generator gives it a plan (a new task, new limits).

The min-jerk move (default_guess) knows nothing of the task: a scrape from it starts
where the judge is flat (p ~ 0 and no gradient to follow), and the solve stalls there. The task
itself knows what a plausible motion looks like: its random demonstration commands. So where the judge
does not already call the min-jerk move a success, the cold start is the best, by the judge, of
it and a few such commands, each made to fit
the problem (velocities clipped to their limits and integrated from the start by the shared
model, forces clipped): one batched judge call, a few milliseconds.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from judgeopt.planners.dynamics import plan_from_parts, positions
from judgeopt.planners.problem import Problem
from judgeopt.tasks import get_task
from judgeopt.trajectory import Plan

if TYPE_CHECKING:
    from judgeopt.judge.compiled import CompiledJudge
    from judgeopt.judge.model import Judge

#: random demonstration commands tried beside the min-jerk move, and their seed (fixed: the same
#: problem and environment always start from the same plan)
CANDIDATES = 12
SEED = 0


def default_guess(problem: Problem, env: dict[str, float]) -> Plan:
    """The documented warm start when no generator is available: per axis a minimum-jerk move
    from q0 to q_end (a free end: the middle of the position limits) over the horizon (velocity
    clipped to the limits), pressing at the middle of the force range."""
    n, dt = problem.steps, problem.dt
    s = np.linspace(0.0, 1.0, n + 1)
    T = n * dt
    ends = problem.terminal_positions(env)
    q0, qd0, qd_end = problem.vec("q0"), problem.vec("qdot0"), problem.vec("qdot_end")
    lo, hi = problem.vec("qdot_min"), problem.vec("qdot_max")
    qs, vs = [], []
    for i in range(problem.n_axes):
        end = ends[i] if not np.isnan(ends[i]) else 0.5 * (problem.vec("q_min")[i] + problem.vec("q_max")[i])
        d = end - q0[i]
        v = np.clip(d / T * (30 * s**2 - 60 * s**3 + 30 * s**4), lo[i], hi[i])
        v[0], v[-1] = qd0[i], qd_end[i]
        qs.append(positions(q0[i], v, dt))
        vs.append(v)
    f = [np.full(n + 1, m) for m in 0.5 * (problem.vec("f_min") + problem.vec("f_max"))]
    return plan_from_parts(problem, np.stack(qs, 1), np.stack(vs, 1), np.stack(f, 1))


def fit_to_limits(problem: Problem, values: np.ndarray) -> Plan:
    """A (horizon + 1, channels) command made a plan of `problem`: its velocities clipped to the
    limits and pinned at the start and end values, positions integrated from q0 (so the shared
    model holds), forces clipped."""
    task = get_task(problem.task)
    cols = {c.name: i for i, c in enumerate(task.channels)}
    pos = task.channels_of("position")
    vel = {c.of: c.name for c in task.channels_of("velocity")}
    qd0, qd_end = problem.vec("qdot0"), problem.vec("qdot_end")
    lo, hi = problem.vec("qdot_min"), problem.vec("qdot_max")
    qs, vs = [], []
    for i, c in enumerate(pos):
        v = np.clip(values[:, cols[vel[c.name]]], lo[i], hi[i])
        v[0], v[-1] = qd0[i], qd_end[i]
        vs.append(v)
        qs.append(positions(problem.vec("q0")[i], v, problem.dt))
    f = [np.clip(values[:, cols[c.name]], lo_f, hi_f) for c, lo_f, hi_f in
         zip(task.channels_of("force"), problem.vec("f_min"), problem.vec("f_max"))]
    return plan_from_parts(problem, np.stack(qs, 1), np.stack(vs, 1), np.stack(f, 1))


def cold_start(problem: Problem, env: dict[str, float], judge: "Judge | CompiledJudge", min_jerk: Plan,
               target_logit: float = np.inf) -> tuple[Plan, str]:
    """`min_jerk` where the judge already scores it at `target_logit` (or the task's commands
    are for another horizon), else the judge's best of it and CANDIDATES of the task's random
    commands fitted to the limits; and which it was."""
    e = np.array([[env[k] for k in judge.config.env_names]])
    if judge.predict_logit(min_jerk.as_array()[None], e)[0] >= target_logit:
        return min_jerk, "min-jerk guess"
    task = get_task(problem.task)
    if (task.horizon, task.dt) != (problem.steps, problem.dt):  # its commands are for another horizon
        return min_jerk, "min-jerk guess"
    rng = np.random.default_rng(SEED)
    full = {**task.env_ranges("sampled"), **env}
    full = {k: (0.5 * (v[0] + v[1]) if isinstance(v, tuple) else float(v)) for k, v in full.items()}
    plans = [min_jerk] + [fit_to_limits(problem, task.random_command(rng, full)) for _ in range(CANDIDATES)]
    logits = judge.predict_logit(np.stack([p.as_array() for p in plans]), np.repeat(e, len(plans), axis=0))
    best = int(np.argmax(logits))
    return plans[best], "min-jerk guess" if best == 0 else f"best of {CANDIDATES} task commands"
