"""`judgeopt models`: what each shipped model is and which ones the task's problems plan with."""

from __future__ import annotations

import argparse
import json
import re
from typing import Any

from judgeopt.cli.commands import HELP
from judgeopt.cli.common import JSON

#: (key, label) of the lines under a model's name, in the order they are shown
DETAILS = (("held_out", "held out"), ("trained_against", "against"), ("generators", "generators"),
           ("made_by", "made by"), ("renamed_since", "renamed since"), ("formerly", "formerly"), ("note", "note"))


def _marks(e: dict[str, Any]) -> str:
    marks = (["default: " + "; ".join(e["defaults"])] if e["defaults"] else []) + (
        ["experiment, not in the wheel"] if e["experiment"] else [])
    return "  [" + "] [".join(marks) + "]" if marks else ""


def _value(v: Any) -> str:
    return ", ".join(v) if isinstance(v, list) else str(v)


def problems(entries: list[dict[str, Any]]) -> dict[str, dict[str, str]]:
    """problem file -> role -> model, from the default marks (every problem has a judge; a role with no
    model is left out)."""
    out: dict[str, dict[str, str]] = {}
    for e in entries:
        for mark in e["defaults"]:
            role, label = mark.split(" of ", 1)
            out.setdefault(label, {})[role] = e["name"]
    return dict(sorted(out.items()))


#: how to plan with a model that is not a problem's default, by kind (`judgeopt solve`'s options)
OPTION = {"judge": "--judge {}", "generator": "--generator {}", "ensemble": "--ensemble {} --pessimism K",
          "calibration": "--calibration {}", "trust region": "--trust-model {} --trust-region X"}


def _purpose(e: dict[str, Any], labels: list[str]) -> str:
    """What a model is for: the problems that plan with it, or the option that names it."""
    from judgeopt.planners.problem import ModelRefs

    roles: dict[str, list[str]] = {}
    for mark in e["defaults"]:
        role, label = mark.split(" of ", 1)
        roles.setdefault(role, []).append(label)
    said = [f"the {role} of " + ("every problem of the task" if len(ps) == len(labels) > 1 else ", ".join(ps))
            for role, ps in roles.items()]
    if e["kind"] == "generator" and e["trained_against"]:
        said.append(f"the amortised plan (and the direct solve's start) under the judge {e['trained_against']}")
    if not e["defaults"] and e["kind"] == "trust region" and e["name"] == ModelRefs.trust_model:
        said.append("the demonstrations `judgeopt solve --trust-region X` keeps the direct solve near (the default "
                    "trust model; no shipped problem sets a trust region)")
    elif not e["defaults"]:
        said.append(f"not a default: name it with `judgeopt solve {OPTION[e['kind']].format(e['name'])}`")
    if e["kind"] == "judge" and e["generators"]:
        said.append(f"its generators: {', '.join(e['generators'])}")
    return "; ".join(said)


def _figure(e: dict[str, Any]) -> str | None:
    """Its key figure as recorded; a working file (out/...) a user does not have is not named."""
    held = e["held_out"]
    return None if held is None else re.sub(r"\bout/[^\s,;)]*", "a file not shipped", held)


def text(found: dict[str, list[dict[str, Any]]]) -> str:
    """The index as lines for a terminal: for each task, what its problems plan with, then each shipped
    model: what it is, what it is for and its key figure. What made each and how it was renamed
    (the history) is in docs/models.md and `--json`; experiments are counted, not listed."""
    from judgeopt.tasks import get_task

    lines = []
    for t, entries in found.items():
        by_problem = problems(entries)
        lines.append(f"{t} (default judge {get_task(t).default_judge}: a {t} problem that names no judge plans with it)")
        lines.append("  problem file                       judge, generator")
        for label, roles in by_problem.items():
            lines.append(f"  {label:<34} {roles['judge']}, {roles.get('generator', 'none (the direct solve alone)')}")
        shipped = [e for e in entries if not e["experiment"]]
        for e in shipped:
            lines += [f"  {e['name']} ({e['kind']})", f"      what: {e['what']}",
                      f"      for: {_purpose(e, list(by_problem))}"]
            figure = _figure(e)
            if figure:
                lines.append(f"      figure: {figure}")
        kept = len(entries) - len(shipped)
        if kept:
            lines.append(f"  and {kept} models kept to reproduce the paper's tables and experiments "
                         "(models/experiments/, not in the wheel): `judgeopt models --json` lists them")
    lines.append("What made each model and its earlier names: docs/models.md.")
    return "\n".join(lines)


def markdown(found: dict[str, list[dict[str, Any]]]) -> str:
    """The index as Markdown (docs/models.md holds it; tests/test_models_folder.py checks it is current)."""
    from judgeopt.tasks import get_task

    out = []
    for t, entries in found.items():
        out.append(f"### {t}\n\nDefault judge: `{get_task(t).default_judge}` (a {t} problem that names no judge plans "
                   "with it). What each shipped problem plans with, as `judgeopt solve` chooses it:")
        rows = [f"| `{label}` | `{r['judge']}` | " + (f"`{r['generator']}`" if "generator" in r else
                                                     "none: the direct solve starts from the min-jerk guess") + " |"
                for label, r in problems(entries).items()]
        out.append("\n".join(["| problem | judge | generator |", "|---|---|---|", *rows]))
        for title, group in (("Shipped", [e for e in entries if not e["experiment"]]),
                             ("Experiments (`models/experiments/`, not in the wheel)",
                              [e for e in entries if e["experiment"]])):
            if not group:
                continue
            out.append(f"#### {title}")
            for e in group:
                head = f"- **`{e['name']}`**: {e['kind']}" + (f" (default: {'; '.join(e['defaults'])})"
                                                             if e["defaults"] else "")
                rows = [f"  - what: {e['what']}"] + [
                    f"  - {label}: " + (f"`{e[key]}`" if key == "made_by" and " --" in e[key] else _value(e[key]))
                    for key, label in DETAILS if e[key]]
                out.append("\n".join([head, *rows]))
    return "\n\n".join(out) + "\n"


def cmd_models(args: argparse.Namespace) -> int:
    from judgeopt.model_index import index
    from judgeopt.tasks import get_task, task_names

    tasks = [args.task] if args.task else task_names()
    for t in tasks:
        get_task(t)  # an unknown task: one line naming the known ones
    found = {t: [e.to_dict() for e in index(t)] for t in tasks}
    if args.markdown:
        print(markdown(found), end="")
    else:
        print(json.dumps(found) if args.json else text(found))
    return 0


def add_models_command(sub: argparse._SubParsersAction) -> None:
    m = sub.add_parser("models", help=HELP["models"],
                       description="Every shipped model of a task (judges, generators, the ensemble, calibration, "
                       "trust region) read from its own metadata: what it is, what it is for (which of the task's "
                       "problem files plan with it, the choice `judgeopt solve` makes, or the option that names it) "
                       "and its key figure with the command that gives it. --json and --markdown add what made each, "
                       "its earlier names and the models kept only to reproduce a table or an experiment (in "
                       "models/experiments/, not in the wheel); docs/models.md holds that history.", parents=[JSON])
    m.add_argument("--task", help="one task (`judgeopt tasks` lists them; default: every task)")
    m.add_argument("--markdown", action="store_true", help="print Markdown (the index in docs/models.md)")
    m.set_defaults(func=cmd_models)
