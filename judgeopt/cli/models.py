"""`judgeopt models`: what each shipped model is and which ones the task's problems plan with."""

from __future__ import annotations

import argparse
import json

from judgeopt.cli.common import JSON


def cmd_models(args: argparse.Namespace) -> int:
    from judgeopt.model_index import index
    from judgeopt.tasks import get_task, task_names

    tasks = [args.task] if args.task else task_names()
    for t in tasks:
        get_task(t)  # an unknown task: one line naming the known ones
    found = {t: [e.to_dict() for e in index(t)] for t in tasks}
    if args.json:
        print(json.dumps(found))
        return 0
    for t, entries in found.items():
        print(f"{t} (default judge: {get_task(t).default_judge})")
        for e in entries:
            mark = "  [default: " + "; ".join(e["defaults"]) + "]" if e["defaults"] else ""
            print(f"  {e['name']:<44} {e['kind']}{mark}")
            print(f"      {e['what']}")
            for key, label in (("held_out", "held out"), ("trained_against", "against"), ("made_by", "made by")):
                if e[key]:
                    print(f"      {label}: {e[key]}")
    return 0


def add_models_command(sub: argparse._SubParsersAction) -> None:
    m = sub.add_parser("models", help="list the shipped models: what each is, and the defaults solve uses",
                       description="Every model of a task (judges, generators, the ensemble, calibration, trust "
                       "region) read from its own metadata: what it is, its held-out figure, which judge a generator "
                       "was trained against, what made it, and which of the task's problem files plan with it (the "
                       "choice `judgeopt solve` makes).", parents=[JSON])
    m.add_argument("--task", help="one task (`judgeopt tasks` lists them; default: every task)")
    m.set_defaults(func=cmd_models)
