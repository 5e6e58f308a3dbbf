"""A plan request turned into what `judgeopt solve` would plan: the problem with the request's
changes, the environment ranges, the planners. Checked here as the command line checks the same
values (Problem.with_overrides, feasible.check), so a bad request gets the command line's message;
run in the server before a request takes a worker, and again in the worker (no torch is imported).
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

from judgeopt.errors import Infeasible
from judgeopt.files import PACKAGE
from judgeopt.recent import Recent
from judgeopt.planners.problem import Problem, ProblemError, load_problem
from judgeopt.serve.schema import PlanRequest, as_text


class InfeasibleRequest(Infeasible, ValueError):
    """Limits that admit no plan, found before any solver runs; `answer` is the object `judgeopt
    solve --json` prints for them (session.infeasible_json)."""

    def __init__(self, message: str, answer: dict[str, Any] | None = None):
        super().__init__(message)
        self.answer = answer or {}


@dataclass(frozen=True)
class Prepared:
    """A request as the planners take it."""

    problem: Problem
    methods: tuple[str, ...]  # one group or planner (as solve --method), or several planners
    ranges: dict[str, tuple[float, float]]  # environment variables given as [lo, hi]
    simulate: bool

    @functools.cached_property
    def planners_key(self) -> str:
        """The problem with the request's changes, but for its environment, as canonical JSON: which
        loaded planners serve it (Planners.in_environment: planners are built for a problem and plan
        for any environment, so a new object position loads nothing)."""
        return json.dumps(self.problem.without_environment(), sort_keys=True, default=str)


def problem_files(extra: Sequence[str] = ()) -> dict[str, Path]:
    """The problems a server plans, by name: the shipped ones, and `extra` files by their stem
    (a name given twice is refused: a request must not be able to mean two files)."""
    out = {p.stem: p.resolve() for p in sorted((PACKAGE / "tasks").glob("*/problems/*.toml"))}
    for f in extra:
        path = Path(f)
        if path.stem in out:
            raise ProblemError(f"--problem {f}: a problem named {path.stem!r} is already served ({out[path.stem]}); "
                               "rename the file")
        load_problem(path)  # one line now, if it cannot be read, rather than in every request
        out[path.stem] = path.resolve()
    return out


@functools.lru_cache(maxsize=64)
def base_problem(path: Path) -> Problem:
    """A problem file, read once (problems are immutable: every request's changes make a copy)."""
    return load_problem(path)


def checked_methods(methods: Sequence[str], simulate: bool) -> tuple[str, ...]:
    """The request's planners: one group or planner (as solve --method), or several planners, each
    known (plugins are never loaded for a request: a request cannot name code to import), those
    that plan while executing only with `simulate`."""
    from judgeopt.planners.base import GROUP_ALIASES, GROUPS, REGISTRY, planner_names

    groups = (*GROUPS, *GROUP_ALIASES)
    known = (*planner_names(), *groups)
    bad = [m for m in methods if m not in known]
    if bad:
        raise ProblemError(f"methods: {', '.join(map(repr, bad))} is no planner; choose one group ({', '.join(groups)}) or "
                           f"planners from {', '.join(planner_names())}")
    if len(methods) > 1 and any(m in groups for m in methods):
        raise ProblemError(f"methods: a group ({', '.join(groups)}) stands alone; list planners instead")
    closed = [m for m in methods if m in REGISTRY and REGISTRY[m].closed_loop]
    if closed and not simulate:
        raise ProblemError(f"methods: {', '.join(closed)} plans while the plan is executed in simulation; set simulate "
                           "to true")
    return tuple(dict.fromkeys(methods))


def prepare(request: PlanRequest, problems: Mapping[str, Path]) -> Prepared:
    """The problem the request asks for, checked before any model loads; an infeasible one is an
    InfeasibleRequest carrying the command line's answer for it."""
    from judgeopt.planners.feasible import check
    from judgeopt.session.solve import infeasible_json
    from judgeopt.tasks import get_task

    path = problems.get(request.problem)
    if path is None:
        raise ProblemError(f"problem {request.problem!r}: not one this server plans; choose one of "
                           f"{', '.join(problems)} (GET /v1/models)")
    problem = base_problem(path)
    values: dict[str, Any] = {k: v for k, v in request.limits.model_dump().items() if v is not None}
    values.update({k: v for k, v in request.constraints.model_dump().items() if v is not None})
    if request.constraints.bounds is not None:  # as --bound: added to the file's
        values["bounds"] = [*problem.bounds, *request.constraints.bounds]
    for name in ("objective", "robot"):
        if getattr(request, name) is not None:
            values[name] = getattr(request, name)
    task = get_task(problem.task)
    for name, value in request.environment.items():
        if name not in task.env_names:
            raise ProblemError(task.not_a_variable(f"environment {name}"))
        values[name] = as_text(value)  # as --NAME X or --NAME LO,HI: the problem reads and checks it
    problem = problem.with_overrides(**values)
    methods = checked_methods(request.methods, request.simulate)
    env = problem.nominal_env()
    try:
        check(problem, env)
    except ProblemError as exc:
        raise InfeasibleRequest(str(exc), infeasible_json(problem, env, exc)) from None
    ranges = {k: v for k, v in problem.environment.items() if k in request.environment and isinstance(v, tuple)}
    return Prepared(problem, methods, ranges, request.simulate)


class PreparedRequests:
    """`prepare` for requests as a server receives them (PlanRequest.model_dump()), the last `size`
    kept by their content: a request asked again (a robot re-planning under the same limits) skips
    the schema, the problem's copy and checks, and the key of its planners, about 0.7 ms each in the
    server and in the worker. Only a request that prepared is kept (an error is raised every time);
    `timeout_s` changes nothing planned, so requests that differ in it alone share one."""

    def __init__(self, problems: Mapping[str, Path], size: int):
        self.problems = problems
        self.kept = Recent(size)

    def get(self, request: Mapping[str, Any]) -> Prepared:
        key = json.dumps({k: v for k, v in request.items() if k != "timeout_s"}, sort_keys=True)
        return self.kept.get_or_make(key, lambda: prepare(PlanRequest.model_validate(request), self.problems))
