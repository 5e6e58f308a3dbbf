"""The service's request and answers on the wire (pydantic): the OpenAPI schema is made from these,
so what is documented is what is checked.

A request names a problem (never a path), and changes only what the command line changes: the
limits, the environment, the [constraints], the planners and the objective. Every model refuses
a field it does not know (extra="forbid"), and every value is checked by the command line's own
argument type for its field (judgeopt.field_text), so a bad value gets the message the
command line gives; what a value means (a limit below its partner, an infeasible set) is checked
where the command line checks it, by the problem (judgeopt.serve.request).
"""

from __future__ import annotations

import argparse
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, Strict, StringConstraints, create_model

from judgeopt.field_text import field_type
from judgeopt.planners.problem import FIELD_HELP, LIMIT_NAMES, OBJECTIVES, SECTIONS

#: the most values a per-axis field, the environment, the bounds and the planners may hold: a
#: request is a handful of numbers, and anything far larger is refused before it is read into a problem
MAX_AXES, MAX_ENVIRONMENT, MAX_BOUNDS, MAX_METHODS = 8, 16, 32, 8

Number = Annotated[float, Strict()]  # a JSON number (true, "0.4" are refused)
PerAxis = Number | Annotated[list[Number], Field(min_length=1, max_length=MAX_AXES)]
Name = Annotated[str, StringConstraints(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")]


def as_text(value: Any) -> str:
    """A value as it is typed on the command line: 0.4, or 0.3,0.0 for one per axis."""
    return ",".join(map(repr, value)) if isinstance(value, list) else repr(value)


def cli_checked(name: str) -> AfterValidator:
    """The command line's argument type of field `name`, run on the value as it would be typed
    there: the same value, or the same one-line message (nan, inf where a finite number belongs)."""
    parse = field_type(name)

    def check(value: Any) -> Any:
        try:
            return parse(as_text(value))
        except (argparse.ArgumentTypeError, ValueError) as exc:
            raise ValueError(str(exc) or f"invalid value {as_text(value)!r}") from None

    return AfterValidator(check)


def fields_model(model: str, names: tuple[str, ...], doc: str) -> type[BaseModel]:
    """A model of problem fields by name, each optional (left out: the problem's value), each
    documented by the problem's own help text and checked by the command line's type."""
    fields: dict[str, Any] = {}
    for name in names:
        if name == "bounds":  # text, as --bound takes it; the problem parses and checks it
            kind: Any = Annotated[list[Annotated[str, StringConstraints(max_length=128)]], Field(max_length=MAX_BOUNDS)]
            fields[name] = (kind | None, Field(None, description=f"{FIELD_HELP[name]}; added to the problem's"))
        else:
            fields[name] = (Annotated[PerAxis, cli_checked(name)] | None, Field(None, description=FIELD_HELP[name]))
    return create_model(model, __config__=ConfigDict(extra="forbid"), __doc__=doc, **fields)


Limits = fields_model("Limits", LIMIT_NAMES, "Position, velocity and force limits (left out: the problem's); one "
                      "value for every axis or one per axis, as --qdot-max 0.4 or --q-min 0.3,0 on the command line.")
Constraints = fields_model("Constraints", SECTIONS["constraints"], "The direct solve's [constraints] (left out: the "
                           "problem's), as --a-max, --jerk-max, --fdot-max, --bound and --joint-limit-scale.")


def example_request() -> dict[str, Any]:
    """A request in the documentation, built from the default task's own names."""
    from judgeopt.tasks import DEFAULT_TASK, get_task

    v = get_task(DEFAULT_TASK).env_vars[0]
    return {"problem": "paper_sim", "limits": {"qdot_max": 0.4}, "environment": {v.name: v.default},
            "methods": ["default"], "simulate": False, "timeout_s": 5.0}


class PlanRequest(BaseModel):
    """One plan: the answer is the object `judgeopt solve --json` prints for the same request."""

    model_config = ConfigDict(extra="forbid", json_schema_extra=lambda schema: schema.update(
        examples=[example_request()]))

    problem: Name = Field("paper_sim", description="a problem by name: a shipped one (GET /v1/models lists them) or "
                          "one the server was started with (--problem FILE); never a path")
    robot: Name | None = Field(None, description="the arm that runs the plan (GET /v1/models lists them; left out: "
                               "the problem's), as solve --robot: its joint limits held, its simulation")
    limits: Limits = Field(default_factory=Limits)  # type: ignore[valid-type]
    environment: dict[Name, Number | Annotated[list[Number], Field(min_length=2, max_length=2)]] = Field(
        default_factory=dict, max_length=MAX_ENVIRONMENT,
        description="environment variables by name: one value, or [lo, hi] (somewhere in there: the direct solve "
                    "plans for the worst case over a grid), as --NAME X or --NAME LO,HI")
    constraints: Constraints = Field(default_factory=Constraints)  # type: ignore[valid-type]
    methods: list[Name] = Field(default_factory=lambda: ["default"], min_length=1, max_length=MAX_METHODS,
                                description="one group (default, all) or planners by name, as solve --method")
    objective: Literal[OBJECTIVES] | None = Field(None, description=FIELD_HELP["objective"])  # type: ignore[valid-type]
    simulate: Annotated[bool, Strict()] = Field(False, description="replay each plan in the task's simulated scene (tenths of a second more)")
    timeout_s: Annotated[float, Strict(), Field(gt=0)] | None = Field(
        None, description="the deadline in seconds from arrival (default and largest: the server's --timeout and "
                          "--max-timeout); past it the answer is 504, saying what was cut short")


class ErrorAnswer(BaseModel):
    """Every error: one line saying what is wrong and how to fix it."""

    error: str


class PlanAnswer(BaseModel):
    """The object `judgeopt solve --json` prints (its main fields; each result carries its plan)."""

    model_config = ConfigDict(extra="allow")

    status: Literal["ok", "infeasible"]
    verdict: str = Field(description="likely, uncertain, unlikely, outside the judge's data, or infeasible")
    recommended: str | None = Field(description="the planner whose plan to run")
    results: list[dict[str, Any]] = Field(description="one per planner: method, status, verdict, success_probability, "
                                                      "t, each channel's samples, residuals, solve_time_s, ...")
    notes: list[str] = []
    problem: dict[str, Any]
    environment: dict[str, Any]


class WorkerState(BaseModel):
    pid: int
    ready: bool
    busy: bool


class Health(BaseModel):
    """The server answers (it may not be ready: GET /v1/ready)."""

    status: Literal["alive"]
    version: str
    workers: list[WorkerState]
    queued: int


class Ready(BaseModel):
    """At least one worker has its models loaded and takes requests."""

    ready: bool
    workers_ready: int
    workers: int


#: the models whose fields an error may name, by the field that holds them
MODELS: dict[tuple[str, ...], type[BaseModel]] = {(): PlanRequest, ("limits",): Limits, ("constraints",): Constraints}


def where(loc: tuple) -> list[str]:
    """An error's path inside the body, without FastAPI's "body" and pydantic's union-member tags
    ("float", "list[float]")."""
    return [str(p) for p in loc[1 if loc[:1] == ("body",) else 0:]
            if not (isinstance(p, str) and (p in ("float", "str", "int", "bool") or "[" in p))]


def describe_errors(errors: list[dict[str, Any]]) -> str:
    """pydantic's (or FastAPI's) errors of a request body as one line: where, and what is wrong
    (the first error; how many more fields are wrong). A value error's text is the command line's."""
    first = errors[0]
    if first["type"] == "json_invalid":
        return f"the body is not valid JSON: {first.get('ctx', {}).get('error', first['msg'])}; send one JSON object"
    at = where(first["loc"])
    # of a union's members' errors for the same value, the one about its content, not its type
    # (a list too long, not "not a number")
    first = next((e for e in errors if where(e["loc"]) == at and not e["type"].endswith("_type")), first)
    path = ".".join(at) or "the body"
    if first["type"] == "extra_forbidden":
        model = MODELS.get(tuple(at[:-1]))
        takes = f"; {'.'.join(at[:-1]) or 'a request'} takes {', '.join(model.model_fields)}" if model else ""
        text = f"{path}: unknown field{takes}"
    elif first["type"] in ("model_attributes_type", "dict_type") and not at:
        text = "the body must be one JSON object (a plan request)"
    else:
        text = f"{path}: {first['msg'].removeprefix('Value error, ')}"
    more = len({tuple(where(e["loc"])) for e in errors}) - 1
    return text + (f" (and {more} more)" if more > 0 else "")
