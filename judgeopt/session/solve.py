"""One planning request from start to verdict, as a library call: which planners run (and the
fallback when no generator covers the limits), the world they are simulated in (where planners that
plan while executing run), and what would make an unlikely plan likely. `judgeopt solve`
only formats the `SolveReport` and writes its files.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from judgeopt.planners.base import GROUP_ALIASES, GROUPS, group, spec_of, with_uses
from judgeopt.planners.problem import Problem, ProblemError
from judgeopt.session.views import ReportViews

#: samples per environment variable given as a range "somewhere in here" (env_grid): its ends and
#: middle, or five points where only one variable is uncertain
GRID_POINTS = {1: 5}
GRID_POINTS_DEFAULT = 3


def methods_for(problem: Problem, method: str, generator: str | None = None, models_dir: str = "models",
                simulate: bool = True) -> tuple[tuple[str, ...], str | None]:
    """The planners `method` names (a group: "default", "all"; or one planner, with the planners it
    is built on), and a note when a group's planners that need a generator fall away because none
    covers the limits. Without `simulate`, a group leaves out the planners that plan while executing."""
    if method not in GROUPS and method not in GROUP_ALIASES:
        return with_uses((method,)), None
    methods = group(method, simulate)
    needy = [m for m in methods if "generator" in spec_of(m).needs]
    kept = tuple(m for m in methods if m not in needy)
    if needy and kept and not generator:
        from judgeopt.planners.loaded import choose_models

        if choose_models(problem, methods, None, None, models_dir).generator is None:
            runs = "runs" if len(kept) == 1 else "run"
            return kept, (f"no generator covers these limits: {', '.join(kept)} {runs} without {', '.join(needy)} "
                          "(train one with `judgeopt train-generator`)")
    return methods, None


def env_grid(nominal: dict[str, float], ranges: dict[str, tuple[float, float]], judge_reads: Sequence[str]) -> list[dict[str, float]]:
    """The environments one plan is judged in when some variables are only known to lie in a
    range: a grid over the ranges (ends included: a worst case over a box is usually at a corner),
    the other variables at their nominal value. A range for a variable the judge does not read is
    refused: it could not change the plan."""
    unread = [k for k in ranges if k not in judge_reads]
    if unread:
        raise ProblemError(f"{', '.join(unread)} given as a range, but the judge does not read "
                           f"{'it' if len(unread) == 1 else 'them'} (it reads {', '.join(judge_reads)}): give one value")
    k = GRID_POINTS.get(len(ranges), GRID_POINTS_DEFAULT)
    axes = {name: np.linspace(lo, hi, k) for name, (lo, hi) in ranges.items()}
    grid = np.meshgrid(*axes.values(), indexing="ij")
    return [{**nominal, **{name: float(g.flat[i]) for name, g in zip(axes, grid)}} for i in range(grid[0].size)] \
        if ranges else [dict(nominal)]


def simulated_world(problem: Problem, items: Mapping[str, float] | None) -> dict[str, float]:
    """Where the simulated world differs from what the planners were told (`--simulate-env`):
    each a variable of the task, within its scene's physical range."""
    from judgeopt.tasks import get_task

    task = get_task(problem.task)
    out: dict[str, float] = {}
    for name, value in (items or {}).items():
        if name not in task.env_names:
            raise ProblemError(f"--simulate-env {name}={value:g}: {name!r} is not a variable of task {task.name!r} (it "
                               f"has {', '.join(task.env_names)})")
        lo, hi = next(v.physical for v in task.env_vars if v.name == name)
        if not lo <= value <= hi:
            raise ProblemError(f"--simulate-env {name}={value:g}: outside the {task.name} scene's physical range "
                               f"[{lo:g}, {hi:g}]")
        out[name] = float(value)
    return out


@dataclass(repr=False)  # ReportViews' short repr, not every sample of every plan
class SolveReport(ReportViews):
    """Every planner's result for the problem's environment, with the notes, the world it was
    simulated in and, where no plan is likely, the limit changes that would make one."""

    problem: Problem
    env: dict[str, float]
    planners: Any  # judgeopt.planners.loaded.Planners
    results: list
    world: dict[str, float] = field(default_factory=dict)  # what the simulated world has besides env, or instead
    suggestions: list = field(default_factory=list)
    suggest_seconds: float | None = None

    @property
    def notes(self) -> list[str]:
        return self.planners.notes

    @property
    def infeasible(self) -> bool:
        return any(r.status == "infeasible" for r in self.results)

    @property
    def recommended(self) -> Any:
        """The plan to run (`result.recommended`): one that holds the limits, then the highest p."""
        from judgeopt.verdict.rules import recommended

        return recommended(self.results)

    @property
    def verdict(self) -> str:
        """The recommended plan's verdict: "likely", "unlikely", "outside the judge's data", or
        "infeasible" where the limits admit no plan."""
        from judgeopt.verdict.rules import overall_verdict

        return overall_verdict(self.results)

    @property
    def unlikely(self) -> bool:
        """No plan to run is likely (unlikely, or uncertain at the risk asked for): the exit code and
        the suggestions follow."""
        from judgeopt.verdict.rules import UNCERTAIN

        return self.verdict in ("unlikely", UNCERTAIN)

    @property
    def outside(self) -> list[str]:
        """What in the request lies outside the judge's data (one phrase each; empty: nothing)."""
        return list(dict.fromkeys(x for r in self.results for x in r.info.get("outside_judge_data", ())))

    @property
    def disagreement(self) -> str | None:
        """Where the planners' verdicts differ: which says what, and the plan to run."""
        verdicts = {r.method: r.verdict for r in self.results if r.verdict is not None}
        top = self.recommended
        if len(set(verdicts.values())) < 2 or top is None:
            return None
        said = ", ".join(f"{r.method} {r.verdict} (p {r.success_probability:.2f})" for r in self.results
                         if r.verdict is not None)
        return f"the planners disagree: {said}; run the {top.method} plan"

    def to_json(self, files: Sequence[Any] = (), failed: Any = None) -> dict[str, Any]:
        """The one object `judgeopt solve --json` prints and a planning service answers (judgeopt
        serve): the verdict, the plan to run, every result with its plan, and the models that made
        them. `files`: what the command wrote; `failed`: the error of the output it could not write
        (a JudgeoptError), said in the object with its exit code."""
        top, planners = self.recommended, self.planners
        return {"status": "infeasible" if self.infeasible else "ok", "verdict": self.verdict,
                "recommended": top.method if top is not None else None,
                "disagreement": self.disagreement, "outside_judge_data": self.outside,
                "suggestions": [x.to_json() for x in self.suggestions], "problem": self.problem.to_dict(),
                "environment": self.env, "judge": str(planners.judge_path),
                "judge_sha256": planners.judge_meta["weights_sha256"],
                "generator": str(planners.generator_path) if planners.generator_path else None,
                "notes": planners.notes, "files": [str(f) for f in files],
                "results": [r.to_json() for r in self.results],
                **({"error": str(failed), "exit_code": int(failed.exit_code)} if failed else {})}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "SolveReport":
        """A report as `to_json` wrote it (a planning service's answer), to print as a local solve
        prints its own: the problem, results with their plans, notes and suggestions. What only
        the planners in memory know (a planner's own detail lines, the search's duration) is not
        in the object."""
        from judgeopt.planners.result import PlanResult
        from judgeopt.session.suggest import Suggestion

        problem = Problem.from_dict(d["problem"])
        results = [PlanResult.from_json(r, problem.dt, problem.task) for r in d["results"]]
        answered = AnsweredPlanners(list(d["notes"]), d["judge"], {"weights_sha256": d["judge_sha256"]},
                                    d["generator"])
        env = dict(d["environment"])
        world = {k: v for k, v in problem.world_env(env).items() if k not in env}  # as `solve` sets it
        return cls(problem, env, answered, results, world, [Suggestion.from_json(x) for x in d["suggestions"]])


@dataclass
class AnsweredPlanners:
    """What a report read back from JSON (`SolveReport.from_json`) keeps of the planners that made
    it: their notes and models; no planner is in memory, so none has detail lines to add."""

    notes: list[str]
    judge_path: str
    judge_meta: dict[str, Any]
    generator_path: str | None

    def __getitem__(self, method: str) -> "AnsweredPlanners":
        return self  # stands for each planner: `report.planners[method].details(result)`

    def details(self, result: Any) -> list[str]:
        return []


def infeasible_json(problem: Problem, env: Mapping[str, float], exc: Exception) -> dict[str, Any]:
    """The object `judgeopt solve --json` prints, and a planning service answers, for limits that
    admit no plan (found before any solver runs): the message and the limits in conflict."""
    return {"status": "infeasible", "verdict": "infeasible", "message": str(exc),
            "conflict": getattr(exc, "conflict", []), "environment": dict(env), "problem": problem.to_dict(),
            "results": []}


def solve(planners: Any, *, simulator: Any = None, world: Mapping[str, float] | None = None,
          warm_start: str = "generator", ranges: Mapping[str, tuple[float, float]] | None = None,
          range_case: str = "worst", suggest: bool = True) -> SolveReport:
    """Plan for the problem's nominal environment with `planners` (`loaded.Planners.load`).
    `simulator`: replay each plan there (and run the planners that plan while executing), in
    the problem's world changed by `world`; `ranges`: the planners that plan over sets (the direct solve) plan
    over a grid of these (env_grid), in their `range_case`; `suggest`: where the plan to run is unlikely, search for the
    limit changes that would make one likely."""
    problem = planners.problem
    env = problem.nominal_env()
    world = simulated_world(problem, world)
    env_set = None
    over = planners.over_env_sets()
    if ranges and over:
        env_set = env_grid(env, dict(ranges), planners.judge.config.env_names)
        where = ", ".join(f"{k} in [{lo:g}, {hi:g}]" for k, (lo, hi) in ranges.items())
        planners.notes.append(f"{', '.join(over)}: planned for the {range_case} case over {len(env_set)} environments "
                              f"({where}); the others for its middle ({', '.join(f'{k} = {env[k]:g}' for k in ranges)})")
    planners.warm_up(cold=warm_start == "none")  # what a first solve pays, paid before any plan is timed
    results = planners.solve(env, simulator=simulator, warm_start=warm_start, env_set=env_set, case=range_case,
                             world=world)
    report = SolveReport(problem, env, planners, results,
                         {**{k: v for k, v in problem.world_env(env).items() if k not in env}, **world})
    if report.unlikely and suggest:
        from judgeopt.session.suggest import suggest as search

        t0 = time.perf_counter()
        report.suggestions = search(planners, env, results)
        report.suggest_seconds = time.perf_counter() - t0
    return report

