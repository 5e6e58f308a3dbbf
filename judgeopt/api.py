"""The library in a few calls, re-exported by `import judgeopt`: a problem, its planners, a
solve with its verdict and simulated outcome, the judge, and the task's simulator.

    import judgeopt

    problem = judgeopt.load_problem("paper_sim", qdot_max=0.4)
    report = judgeopt.solve(problem)                 # both planners, each plan replayed in simulation
    report = judgeopt.solve(qdot_max=0.4)            # the same: the default problem, a limit by name
    print(report)                                    # the verdict and one line per planner
    rows = report.summary()                          # a list of dicts, one per planner (a table when printed)
    report.plot("plan.png")                          # the plans against their limits, and what simulation measured

Each call is a thin door onto the module that does the work (named in its docstring), so what is
learnt here carries over to the deeper API.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

from judgeopt.planners.problem import FIELDS, Problem, ProblemError, find_problem
from judgeopt.planners.problem import load_problem as _load_problem_file
from judgeopt.robots import DEFAULT_ROBOT
from judgeopt.tasks import DEFAULT_TASK
from judgeopt.threads import DEFAULT_THREADS, torch_threads
from judgeopt.verdict.risk import RISK

if TYPE_CHECKING:  # the types only: `import judgeopt` stays light
    from judgeopt.judge.model import Judge
    from judgeopt.session.solve import SolveReport
    from judgeopt.planners.loaded import Planners
    from judgeopt.tasks.base import Task, TaskSimulator


def load_problem(name: str | Path = "paper_sim", **overrides: Any) -> Problem:
    """A problem file, given as a path or a shipped name ("paper_sim", "problems/scrape.toml"),
    with fields and environment values overridden by name (judgeopt.planners.problem)."""
    problem = _load_problem_file(find_problem(name))
    return problem.with_overrides(**overrides) if overrides else problem


def load_planners(problem: Problem | str | Path = "paper_sim", methods: Sequence[str] | None = None,
                  judge: str | Path | None = None, generator: str | Path | None = None,
                  models_dir: str | Path = "models") -> Planners:
    """The planners for `problem`, with its judge and (found or given) generator loaded once
    (judgeopt.planners.loaded.Planners; method names: judgeopt.planners.base.planner_names(), default:
    its default_planners())."""
    from judgeopt.planners.loaded import Planners

    problem = load_problem(problem) if not isinstance(problem, Problem) else problem
    return Planners.load(problem, methods, judge=judge, generator=generator, models_dir=models_dir)


#: the options `solve` hands to the session (judgeopt.session.solve.solve), not to the problem
SOLVE_OPTIONS = ("warm_start", "ranges", "range_case", "suggest")


def solve(problem: Problem | Planners | str | Path = "paper_sim", methods: Sequence[str] | None = None,
          simulate: bool = True, world: Mapping[str, float] | None = None, threads: int | None = DEFAULT_THREADS,
          risk: float = RISK, **options: Any) -> SolveReport:
    """Plan for the problem's environment and give the `SolveReport` (results, notes, verdict,
    suggestions) that `judgeopt solve` prints (judgeopt.session.solve.solve): `print(report)`
    gives its verdict in a few lines, `report.summary()` a table, `report.plot(path)` its plans.
    `problem`: a Problem, a name, or planners already loaded (`load_planners`, to solve again without
    reloading); `simulate`: replay each plan in the task's scene, in `world` where it differs
    from what the planners were told; `threads`: torch threads during the call (judgeopt.threads: one
    holds when the cores are busy; None leaves the process's setting); `options`: the problem's
    limits, other fields and environment values by name, as `load_problem` takes them
    (`solve(qdot_max=0.4)`: the default problem under that limit), and session.solve's (SOLVE_OPTIONS:
    warm_start, ranges, range_case, suggest); any other name is a one-line error, before anything loads.
    `risk`: the failure rate a "likely" may carry (`solve --risk`; docs/verdict.md)."""
    if not 0.0 < risk < 1.0:
        raise ProblemError(f"risk {risk!r}: a failure rate between 0 and 1 (0.02 is 2 %)")
    loaded = not isinstance(problem, (Problem, str, Path))  # planners already loaded
    given = problem.problem if loaded else problem if isinstance(problem, Problem) else load_problem(problem)
    overrides = {k: v for k, v in options.items() if k not in SOLVE_OPTIONS}
    _check_overrides(given, overrides)  # before torch is imported
    options = {k: v for k, v in options.items() if k in SOLVE_OPTIONS}
    from judgeopt.session import solve as session
    from judgeopt.planners.loaded import Planners

    if isinstance(problem, Planners):
        planners = problem.with_limits(**overrides) if overrides else problem
    else:
        planners = load_planners(given.with_overrides(**overrides) if overrides else given, methods)
    planners = dataclasses.replace(planners, risk=risk)
    sim = simulator(planners.problem.task, planners.problem.robot) if simulate else None
    try:
        with torch_threads(threads):
            return session.solve(planners, simulator=sim, world=world, **options)
    finally:
        if sim is not None and hasattr(sim, "close"):
            sim.close()


def _check_overrides(problem: Problem, overrides: Mapping[str, Any]) -> None:
    """A one-line error naming the options `solve` takes where `overrides` has a name that is none
    of the problem's fields or environment variables (found before any model loads)."""
    from judgeopt.tasks import get_task as task_of

    fields = [f for f in FIELDS if f not in ("environment", "world", "source")]
    env = list(dict.fromkeys([*problem.environment, *task_of(problem.task).env_names]))
    bad = [k for k in overrides if k not in fields and k not in env]
    if bad:
        raise ProblemError(f"judgeopt.solve got {', '.join(map(repr, bad))}: not a field of problem {problem.name!r}, "
                           f"an environment variable or an option; fields: {', '.join(fields)}; environment: "
                           f"{', '.join(env)}; options: {', '.join(SOLVE_OPTIONS)}")


def load_judge(path: str | Path | None = None) -> Judge:
    """A trained judge (judgeopt.judge.store.load_judge): `.predict_proba(trajectories, envs)`;
    by default the one `solve` plans with (the default task's default judge; `judgeopt models`)."""
    from judgeopt.files import resolve
    from judgeopt.judge.store import load_judge as load
    from judgeopt.tasks import get_task

    return load(resolve(path or get_task(DEFAULT_TASK).default_judge, (".json",)))[0]


def get_task(name: str = DEFAULT_TASK) -> Task:
    """A task: its channels, environment variables and scene (judgeopt.tasks)."""
    from judgeopt.tasks import get_task as get

    return get(name)


def simulator(task: str = DEFAULT_TASK, robot: str = DEFAULT_ROBOT) -> TaskSimulator:
    """A new simulator of the task's scene with the arm `robot` (`judgeopt robots`): `.simulate(plan,
    env)` replays a plan, `.execute(plan, env)` steps it (close it when done)."""
    t = get_task(task)
    return t.simulator(t.robot_settings(robot))
