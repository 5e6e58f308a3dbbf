"""`judgeopt models`: what each shipped model is and which ones the task's problems plan with."""

from __future__ import annotations

import argparse
import json
from typing import Any

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


def text(found: dict[str, list[dict[str, Any]]]) -> str:
    """The index as lines for a terminal."""
    from judgeopt.tasks import get_task

    lines = []
    for t, entries in found.items():
        lines.append(f"{t} (default judge: {get_task(t).default_judge})")
        for label, roles in problems(entries).items():
            lines.append(f"  {label:<34} judge {roles['judge']}, generator {roles.get('generator', 'none')}")
        for e in entries:
            lines += [f"  {e['name']:<44} {e['kind']}{_marks(e)}", f"      {e['what']}"]
            lines += [f"      {label}: {_value(e[key])}" for key, label in DETAILS if e[key]]
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
    m = sub.add_parser("models", help="list the shipped models: what each is, and the defaults solve uses",
                       description="Every model of a task (judges, generators, the ensemble, calibration, trust "
                       "region) read from its own metadata: what it is, its held-out figure and the command that "
                       "gives it, which judge a generator was trained against, what made it, and which of the task's "
                       "problem files plan with it (the choice `judgeopt solve` makes). Models kept only to reproduce "
                       "a table or an experiment are marked; they live in models/experiments/ and are not in the "
                       "wheel.", parents=[JSON])
    m.add_argument("--task", help="one task (`judgeopt tasks` lists them; default: every task)")
    m.add_argument("--markdown", action="store_true", help="print Markdown (the index in docs/models.md)")
    m.set_defaults(func=cmd_models)
