"""Repeated trials of one plan, as a lab runs them: the same motion ten times, the world a
little different each time (the object put back by hand, the friction and the sensor never
quite the same).

Why: a simulated replay is deterministic, so "9 of 10 scoops" in simulation means nothing
unless each trial draws its own small differences. They go through the task's perturbations
(`Task.perturbations`, `TaskSimulator.perturb`), so any task that declares them has trials.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from judgeopt.tasks.base import Outcome, Task


@dataclass(frozen=True)
class TrialSpread:
    """Per perturbation name, the half-width of the uniform draw around its nominal value (a
    factor's nominal is 1, an offset's or noise's 0; a noise is drawn from [0, width]). None:
    the task's own (`Task.trial_spread`), so each task says how much its lab's trials differ."""

    widths: Mapping[str, float] | None = None

    @classmethod
    def of(cls, task: Task | str) -> "TrialSpread":
        """The spread of `task` (a Task or its name), with its widths written out (for reports)."""
        from judgeopt.tasks import get_task

        return cls(dict((get_task(task) if isinstance(task, str) else task).trial_spread))

    def draw(self, task: Task, rng: np.random.Generator) -> dict[str, float]:
        out = {}
        widths = task.trial_spread if self.widths is None else self.widths
        for name, w in widths.items():
            if name.endswith("_factor"):
                out[name] = float(rng.uniform(1 - w, 1 + w))
            elif name.endswith("_noise"):
                out[name] = float(rng.uniform(0, w))
            else:
                out[name] = float(rng.uniform(-w, w))
        task.check_perturbation(out)  # an unknown name or a draw outside the task's range: one line
        return out


def trials(task: Task, plan: Any, world: Mapping[str, float], n: int = 10, spread: TrialSpread | None = None,
           seed: int = 0, simulator: Any = None) -> list[tuple[dict[str, float], Outcome]]:
    """`plan` replayed unchanged `n` times, each in a world drawn from `spread` around `world`
    (the full environment the simulator needs); each trial's draw and outcome. Seeded."""
    spread = spread or TrialSpread()
    sim = simulator or task.simulator()
    rng = np.random.default_rng(seed)
    out = []
    try:
        for k in range(n):
            drawn = spread.draw(task, rng)
            sim.perturb(drawn, seed=[seed, k])
            out.append((drawn, sim.simulate(plan, dict(world))))
    finally:
        sim.perturb({})
    return out


def run_trials(problem: Any, plans: dict[str, list[dict]], k: int, seed: int, spread: TrialSpread | None = None,
               progress: bool = True) -> list[dict]:
    """Every planned row (`run_table`'s results) tried `k` times; one summary row per plan:
    its predicted success, successes out of `k`, and each trial's draw and outcome."""
    from judgeopt.evaluate.robustness import plan_of
    from judgeopt.tasks import get_task

    task = get_task(problem.task)
    sim = task.simulator()
    items = [(name, r) for name, rs in plans.items() for r in rs]
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(items) * k, desc="trials", unit="replay")
    out = []
    for name, r in items:
        env = {n: float(v) for n, v in r["environment"].items()}
        row = {"row": name, "env_index": r["env_index"], "predicted": r.get("predicted_success"), "trials": k}
        if "channels" not in r:
            out.append({**row, "successes": None})
            continue
        done = trials(task, plan_of(task, r, problem.dt), problem.world_env(env), k, spread,
                      seed=seed * 1000 + r["env_index"], simulator=sim)
        out.append({**row, "successes": sum(o.success for _, o in done),
                    "draws": [d for d, _ in done], "outcomes": [bool(o.success) for _, o in done]})
        if bar is not None:
            bar.update(k)
    if bar is not None:
        bar.close()
    return out


def markdown_trials(summary: list[dict], title: str, spread: TrialSpread) -> str:
    """Successes per plan, with the spread each trial drew from (`TrialSpread.of(task)`: its widths)."""
    if spread.widths is None:
        raise ValueError("markdown_trials needs the spread's widths: give TrialSpread.of(task)")
    drawn = ", ".join(f"{k} +-{v:g}" if not k.endswith("_noise") else f"{k} up to {v:g}"
                      for k, v in spread.widths.items())
    lines = [f"# {title}", "", "Each plan made once and tried unchanged; " + (
             f"each trial draws its world anew: {drawn}." if drawn else
             "every trial in the nominal world (the task declares no trial spread, Task.trial_spread)."), "",
             "| planner | environment | predicted success | successful trials |", "|---|---|---|---|"]
    for s in summary:
        p = "-" if s["predicted"] is None else f"{s['predicted']:.3f}"
        got = "no plan" if s["successes"] is None else f"{s['successes']} of {s['trials']}"
        lines.append(f"| {s['row']} | {s['env_index']} | {p} | {got} |")
    return "\n".join(lines) + "\n"
