"""`judgeopt solve` and `judgeopt train-generator`: problem options shared by both."""

from __future__ import annotations

import argparse
import json
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Callable


from judgeopt.cli.commands import HELP
from judgeopt.cli.common import (JSON, OVERWRITE, QUIET, CLIError, ExitCode, add_plugin_option, command_line, env_assignment,
                                 risk_rate,
                                 figure_path,
                                 file_path, number, out_option, positive, seed_option, threads_option, value_range)
from judgeopt.cli.examples import example_assignment, example_range, example_shift, example_variable, option
from judgeopt.files import OutputWriteError, refuse_overwrite, resolve
from judgeopt.field_text import field_type
from judgeopt.verdict.rules import LEGEND, OUTSIDE
from judgeopt.verdict.risk import CONFIDENCE, RISK
from judgeopt.planners.problem import SECTIONS, Problem, ProblemError, load_problem

DEFAULT_PROBLEM = "problems/paper_sim.toml"



def add_problem_arguments(p: argparse.ArgumentParser) -> None:
    """--problem FILE, one option per problem field (`--qdot-max 0.4`), the environment by name
    (`--NAME 2`) or as --env NAME=VALUE. Each help names the unit and the default problem's value."""
    from judgeopt.files import resolve
    from judgeopt.planners.problem import FIELD_HELP

    default = load_problem(resolve(DEFAULT_PROBLEM))
    g = p.add_argument_group("problem", "a problem file, and any of its values overridden; a position, velocity or "
                             "terminal value is one number for every axis or one per axis (0.3,0)")
    g.add_argument("--problem", default=DEFAULT_PROBLEM, metavar="FILE", help="problem TOML file")
    g.add_argument("--robot", dest="set_robot", metavar="NAME",
                   help=f"the arm that runs the plan: its simulation, and its joint velocity and torque limits held "
                   f"(--joint-limit-scale 1 unless given) (`judgeopt robots` lists them; {Path(DEFAULT_PROBLEM).name}: "
                   f"{default.robot})")
    for section, names in SECTIONS.items():
        for name in names:
            shown = getattr(default, name)
            if name == "bounds":  # one option per bound, added to the file's
                g.add_argument("--bound", dest="add_bounds", action="append", metavar="NAME:LO:HI@T0:T1",
                               help=f"{FIELD_HELP[name]}; repeat for more, added to the file's [{section}] {name} "
                               "(inf: no bound on that side; without @T0:T1 the whole motion)")
                continue
            g.add_argument(f"--{name.replace('_', '-')}", dest=f"set_{name}", type=field_type(name), metavar="X",
                           help=f"{FIELD_HELP[name]} ([{section}] {name}; {Path(DEFAULT_PROBLEM).name}: {shown})")
            if name == "judge":  # the name older scripts use; one flag in --help
                g.add_argument("--judge-model", dest="set_judge", help=argparse.SUPPRESS)
    from judgeopt.tasks import get_task, task_names

    variables: dict[str, list] = {}
    for t in task_names():  # one option per environment variable of any task (--NAME)
        for v in get_task(t).env_vars:
            variables.setdefault(v.name, []).append((t, v))
    for name, owners in variables.items():
        v = owners[0][1]
        unit = f" in {v.unit}" if v.unit else ""
        g.add_argument(f"--{name.replace('_', '-')}", dest=f"env_{name}", metavar="X or LO,HI",
                       help=f"{v.description or name}{unit}: one value, or a range to draw from (task "
                       f"{', '.join(t for t, _ in owners)}; default: the problem's)")
    g.add_argument("--env", type=env_assignment, action="append", metavar="NAME=X or NAME=LO,HI",
                   help=f"any environment variable by name, e.g. --env {example_assignment()} (the same as "
                   f"{option(example_variable().name)} {example_variable().default:g})")


def ranges_given(args: argparse.Namespace, problem: Problem) -> dict[str, tuple[float, float]]:
    """The environment variables given on the command line as a range (--NAME LO,HI, --env NAME=LO,HI):
    "somewhere in here", as opposed to the problem file's ranges (what demonstrations and
    evaluations draw from)."""
    named = {k[4:] for k, v in vars(args).items() if k.startswith("env_") and v is not None}
    named |= {name for name, _ in getattr(args, "env", None) or []}
    return {k: v for k, v in problem.environment.items() if k in named and isinstance(v, tuple)}


def problem_from_args(args: argparse.Namespace) -> Problem:
    from judgeopt.files import resolve

    problem = load_problem(resolve(args.problem))
    values: dict[str, Any] = {k[4:]: v for k, v in vars(args).items() if k.startswith("set_") and v is not None}
    values.update({k[4:]: v for k, v in vars(args).items() if k.startswith("env_") and v is not None})
    if getattr(args, "add_bounds", None):
        values["bounds"] = [*problem.bounds, *args.add_bounds]
    from judgeopt.tasks import get_task

    task = get_task(problem.task)
    for name, value in args.env or []:
        if name not in task.env_names:
            raise CLIError(task.not_a_variable(f"--env {name}"))
        values[name] = value
    return problem.with_overrides(**values)


# -- solve -----------------------------------------------------------------------------------
def _table(results) -> str:
    head = ("method", "judge", "success p", "verdict", "simulated", "max q̇ [m/s]", "force [N]", "worst violation",
            "status", "time")
    rows = [head]
    for r in results:
        sim = "-" if r.simulated_success is None else ("success" if r.simulated_success else "FAILURE")
        if r.plan is None:
            rows.append((r.method, "-", "-", "-", sim, "-", "-", "-", r.status, f"{r.solve_time_s * 1e3:.1f} ms"))
            continue
        viol = f"{r.max_constraint_violation:.1e} ({r.worst_constraint})" if r.max_constraint_violation > 0 else "0"
        t = r.solve_time_s
        p = f"{r.success_probability:.3f} " + ("(calibrated)" if r.probability_source == "calibrated" else
                                               "(judge, uncalibrated)")
        v, f = (r.plan.values[:, r.plan.columns(kind)] for kind in ("velocity", "force"))
        rows.append((r.method, f"{r.predicted_success:.3f}", p, r.verdict, sim, f"{v.max():.3f}",
                     f"{f.min():.1f} to {f.max():.1f}", viol,
                     r.status + (f" ({r.iterations} it)" if r.iterations is not None else ""),
                     f"{t * 1e3:.1f} ms" if t < 1 else f"{t:.2f} s"))
    widths = [max(len(str(row[i])) for row in rows) for i in range(len(head))]
    lines = ["  ".join(str(c).ljust(w) for c, w in zip(row, widths)) for row in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _plan_rows(plan, every: int = 5) -> str:
    heads = ["t [s]"] + [f"{c.name} [{c.unit}]" for c in plan.channels]
    width = max(9, max(len(h) for h in heads) + 1)
    rows = ["".join(h.rjust(width) for h in heads)]
    for k in range(0, plan.horizon + 1, every):
        rows.append(f"{plan.t[k]:{width}.2f}" + "".join(f"{x:{width}.3f}" for x in plan.values[k]))
    return "\n".join(rows)


def _with_method(path: str, method: str, several: bool) -> Path:
    p = Path(path)
    return p.with_name(f"{p.stem}_{method}{p.suffix}") if several else p


#: what solve --server sends: problem fields by the request's part (judgeopt.serve.schema.PlanRequest)
SENT = {"limits": SECTIONS["limits"], "constraints": SECTIONS["constraints"], "objective": ("objective",)}


def remote_request(args: argparse.Namespace) -> dict[str, Any]:
    """The plan request for a service that solve's options make: the problem by name, the limits,
    constraints, objective, environment and planners; an option a service is not sent is one line."""
    from judgeopt.planners.problem import find_problem

    local = {"--out": args.out, "--save-json": args.save_json, "--export": args.export, "--plot": args.plot,
             "--generator": args.generator, "--models": args.models != "models", "--plugin": args.plugin,
             "--simulate-env": args.simulate_env, "--warm-start": args.warm_start != "generator",
             "--env-case": args.range_case != "worst", "--no-suggest": not args.suggest, "--risk": args.risk != RISK,
             "--casadi-backend": args.casadi_backend != "auto"}
    sent = {"robot", *(n for names in SENT.values() for n in names)}
    local.update({f"--{k[4:].replace('_', '-')}": v for k, v in vars(args).items()
                  if k.startswith("set_") and k[4:] not in sent and v is not None})
    given = [flag for flag, v in local.items() if v]
    if given:
        raise CLIError(f"{', '.join(given)}: not sent to a planning service (--server sends the problem's name, the "
                       "robot, limits, constraints, objective and environment, and --method); drop it, or solve here")
    name = Path(args.problem).name.removesuffix(".toml")
    if args.problem not in (name, f"{name}.toml", f"problems/{name}.toml") or \
            (Path(args.problem).exists() and Path(args.problem).resolve() != find_problem(name).resolve()):
        raise CLIError(f"--problem {args.problem}: a planning service plans problems by name; give a shipped "
                       "problem's name or one the service was started with (--problem NAME)")
    body: dict[str, Any] = {"problem": name, "methods": [args.method], "simulate": args.simulate}
    if args.set_robot is not None:
        body["robot"] = args.set_robot
    for part, names in SENT.items():
        values = {n: getattr(args, f"set_{n}") for n in names if getattr(args, f"set_{n}", None) is not None}
        if part == "constraints" and args.add_bounds:
            values["bounds"] = list(args.add_bounds)
        if values:
            body[part] = values["objective"] if part == "objective" else values
    environment = {k[4:]: v for k, v in vars(args).items() if k.startswith("env_") and v is not None}
    environment.update(dict(args.env or []))
    for k, text in environment.items():
        try:
            values = [float(x) for x in text.split(",")]
        except ValueError:
            raise CLIError(f"--{k.replace('_', '-')} {text}: give a number or LO,HI") from None
        environment[k] = values[0] if len(values) == 1 else values
    if environment:
        body["environment"] = environment
    return body


def solve_remote(args: argparse.Namespace) -> int:
    """solve --server URL: the plan made by a planning service (judgeopt serve), printed as a local
    solve prints it (--json: the service's object as it came)."""
    import time

    from judgeopt.session.solve import SolveReport
    from judgeopt.serve.client import Client, ServiceError

    t0 = time.perf_counter()
    token = None
    if args.token_file:
        from judgeopt.serve.config import read_token

        token = read_token(args.token_file)
    body = remote_request(args)
    try:
        answer = Client(args.server, token).request("POST", "/v1/plan", body)
    except ServiceError as exc:
        if exc.answer.get("status") == "infeasible":
            if args.json:
                print(json.dumps(exc.answer))
            else:
                print(f"judgeopt solve: infeasible: {exc.answer['message']}", file=sys.stderr)
            return ExitCode.INFEASIBLE
        if exc.status is not None and 400 <= exc.status < 500:  # the request's to fix
            raise CLIError(str(exc)) from None
        raise
    report = SolveReport.from_json(answer)
    if args.json:
        print(json.dumps(answer))
    else:
        print_report(report, simulate=args.simulate, explain=args.explain, suggest=args.suggest)
        print(f"total {time.perf_counter() - t0:.1f} s (planned by {args.server})")
    return solve_exit_code(report)


def _check_named_models(args: argparse.Namespace, problem: Problem) -> None:
    """The calibration, ensemble and trust model named on the command line, checked before any
    model loads: one missing, a folder where a file belongs or a file of another kind is one line."""
    if args.set_calibration:
        from judgeopt.verdict.calibration import load_calibration

        load_calibration(resolve(problem.calibration))
    if args.set_ensemble:
        from judgeopt.judge.ensemble import is_ensemble

        if not is_ensemble(resolve(problem.ensemble)):
            raise CLIError(f"--ensemble {args.set_ensemble}: not a judge ensemble (a folder with ensemble.json); make "
                           "one with `judgeopt train-ensemble --out DIR`", ExitCode.BAD_INPUT)
    if args.set_trust_model:
        from judgeopt.planners.trust_region import load_trust_region

        load_trust_region(resolve(problem.trust_model, (".json",)))


def risk_line(r) -> str:
    """What stands behind a result's "likely": the held-out evidence at the risk asked for, or that none does."""
    risk = r.info.get("risk")
    if risk is None:  # no evidence at all (another judge, or none computed)
        return (f"unchecked: no held-out replayed plans of {r.method} with this judge are stored with the calibration, "
                "so 'likely' is p >= 0.5 (`judgeopt evaluate band`, then `judgeopt calibrate --evidence FOLDER`)")
    return risk["evidence"]


def _own_evidence(planners, methods) -> bool:
    """Whether the calibration file holds held-out evidence for one of these planners, with this judge, on
    this arm (a file of evidence for an arm the maps were not fitted on is still this request's file)."""
    from judgeopt.verdict.risk import evidence_key, whose

    sha = planners.judge_meta["weights_sha256"]
    return bool({evidence_key(m, sha, planners.problem.robot) for m in methods} & {whose(k) for k in planners.evidence})


def cmd_solve(args: argparse.Namespace) -> int:
    import time

    if args.server:
        return solve_remote(args)
    from judgeopt.session import solve as session
    from judgeopt.planners.feasible import check as check_constraints
    from judgeopt.planners.loaded import Planners

    t0 = time.perf_counter()
    problem = problem_from_args(args)
    env = problem.nominal_env()
    told = session.simulated_world(problem, _assignments(args.simulate_env))  # checked before any solver runs
    from judgeopt.planners.base import REGISTRY, load_plugins

    load_plugins(args.plugin or ())  # their planners join the groups (--method all) too

    spec = REGISTRY.get(args.method)
    if spec is not None and spec.closed_loop and not args.simulate:
        raise CLIError(f"--method {args.method} plans while the plan is executed in simulation; drop --no-simulate")
    try:
        check_constraints(problem, env)
    except ProblemError as exc:
        return _infeasible(args, problem, env, exc)
    methods, fallback = session.methods_for(problem, args.method, args.generator, args.models, args.simulate)
    several = len(methods) > 1
    if args.export:  # its format from the suffix, checked before any solver runs
        from judgeopt.cli.export import export_format

        export_format(args.export)
    # an output that cannot be written is not refused here: the plans are solved and shown, then
    # the write fails in one line (exit 5), so that a typo in a folder never costs the solve
    for flag, path in (("--out", args.out), ("--save-json", args.save_json), ("--export", args.export)):
        if path:  # the message names the option to change
            refuse_overwrite([_with_method(path, m, several) for m in methods], args.overwrite, flag, writable=False)
    refuse_overwrite([args.plot] if args.plot else [], args.overwrite, "--plot", writable=False)
    _check_named_models(args, problem)
    planners = Planners.load(problem, methods, generator=args.generator, models_dir=args.models,
                             casadi_backend=args.casadi_backend)
    planners.risk = args.risk
    if fallback:
        planners.notes.append(fallback)
    if args.set_calibration:  # asked for by name: another judge's is refused
        from judgeopt.verdict.calibration import for_judge

        for_judge(planners.calibration_file, planners.judge_meta["weights_sha256"], args.set_calibration)
    if args.set_calibration and not planners.calibrators and not _own_evidence(planners, methods):
        # and it knows none of these planners: no map for them, nor held-out evidence on this arm
        fitted = sorted({c.description for c in planners.calibration_file.values()})
        raise ProblemError(f"--calibration {args.set_calibration} has no calibration for these planners (judge "
                           f"{planners.judge_path.name}, these limits); it was fitted for: {'; '.join(fitted) or 'nothing'}."
                           " Fit one with `judgeopt evaluate ... && judgeopt calibrate FOLDER --out FILE`, or leave "
                           "--calibration out")
    sim = None
    if args.simulate:
        from judgeopt.api import simulator

        sim = simulator(problem.task, problem.robot)
    report = session.solve(planners, simulator=sim, world=told, warm_start=args.warm_start,
                           ranges=ranges_given(args, problem), range_case=args.range_case, suggest=args.suggest)
    writes = _outputs(args, problem, planners, report.results, several)
    if args.json:  # written first, so that the one object says what was written (and what not)
        files, failed = _write(writes)
        print(json.dumps(report.to_json(files, failed)))
        if failed:
            return failed.exit_code
    else:
        failed = print_report(report, simulate=args.simulate, explain=args.explain, suggest=args.suggest,
                              write=lambda: _write(writes))
        print(f"total {time.perf_counter() - t0:.1f} s")
        if failed:  # everything above is printed; the one line says what could not be written
            raise failed
    return solve_exit_code(report)


def solve_exit_code(report) -> int:
    """What `judgeopt solve` returns for a report: 3 infeasible, 0 a likely plan, else 4."""
    return ExitCode.INFEASIBLE if report.infeasible else ExitCode.OK if report.verdict == "likely" else ExitCode.UNLIKELY


def print_report(report, *, simulate: bool, explain: bool, suggest: bool,
                 write: Callable[[], tuple[list[Path], OutputWriteError | None]] = lambda: ([], None)
                 ) -> OutputWriteError | None:
    """A solve's report as `judgeopt solve` prints it (the problem, notes, the table, the plan, what
    each planner adds, the verdict and suggestions), for a local solve and a service's answer
    alike; `write` writes the outputs between the table and the verdict, and the error of one that
    could not be written is returned (everything is printed first)."""
    import numpy as np

    problem, env, results, planners = report.problem, report.env, report.results, report.planners
    envs = ", ".join(f"{k} = {v:g}" for k, v in env.items())
    if simulate and report.world:  # what the simulated world has besides (or instead of) what was said
        envs += f"; simulated with {', '.join(f'{k} = {v:g}' for k, v in report.world.items())}"
    ends = ", ".join("free" if np.isnan(e) else f"{e:g}" for e in problem.terminal_positions(env))
    print(f"{problem.name} ({problem.task}): q̇ in [{problem.qdot_min}, {problem.qdot_max}] m/s, f in "
          f"[{problem.f_min}, {problem.f_max}] N, q from {problem.q0} to {ends} m in "
          f"{problem.horizon_time:g} s; environment {envs}")
    for note in planners.notes:
        print(f"note: {note}")
    for x in report.outside:
        print(f"note: {x}")
    print(_table(results))
    shown = next((r for r in reversed(results) if r.plan is not None), None)
    if shown is not None:
        print(f"\n{shown.method} plan (every 5th of {shown.plan.horizon + 1} samples):")
        print(_plan_rows(shown.plan))
    from judgeopt.tasks import get_task

    task = get_task(problem.task)
    for r in results:
        if r.status not in ("solved", "generated", "executed"):
            print(f"{r.method}: {r.message}")
        if "sim_refused" in r.info:
            print(f"{r.method}, simulated: the simulator refused the plan ({r.info['sim_refused']}): a failure")
        elif r.simulated_success is not None:
            details = {k[4:]: v for k, v in r.info.items() if k.startswith("sim_")}
            print(f"{r.method}, simulated: {'success' if r.simulated_success else 'FAILURE'}: "
                  f"{task.explain(details)}")
    for r in results:  # what each planner has to say about its own result
        for line in planners[r.method].details(r):
            print(line)
    uncovered = [r.method for r in results if r.probability_source == "judge"
                 and r.info.get("calibrated_success") is not None]
    if uncovered:
        print(f"note: the calibration does not cover the {' and '.join(uncovered)} plan here (limits, "
              "environment and judge's p far from the outcomes it was fitted on): its success p is the judge's own")
    if explain:
        for r in results:
            if r.verdict is not None:
                print(f"risk ({r.method}): {risk_line(r)}")
    print(f"legend: {LEGEND}" if explain else "(judge: the judge's own p; success p: the p judgeopt stands "
          "behind; --explain says more)")
    files, failed = write()
    for f in files:
        print(f"wrote {f}")
    top = report.recommended
    if report.disagreement:
        print(f"note: {report.disagreement}")
    if report.verdict == OUTSIDE:
        print(f"judgeopt solve: the plan to run ({top.method}) is {OUTSIDE}: its p = {top.success_probability:.2f} "
              "is the judge's guess where it never learnt; replay it in simulation or on the robot before trusting "
              "it, or bring the request inside the judge's ranges (`judgeopt inspect` lists them)")
    elif report.unlikely:
        best = f" (the plan to run: {top.method}, p = {top.success_probability:.2f})" if top is not None else ""
        print(f"judgeopt solve: no plan is likely to succeed under these limits{best}")
        for x in report.suggestions:
            print(f"  {x.text()}")
        if suggest:
            from judgeopt.session.suggest import searched

            if not report.suggestions:
                print(f"  no single relaxation ({', '.join(searched(problem))}; each within the demonstrations' "
                      "range or its reach) makes a plan likely")
            elif report.suggest_seconds is not None:  # a service's answer does not say how long it searched
                print(f"  (searched by re-planning in {report.suggest_seconds:.1f} s)")
    return failed


#: one output of solve, not yet written: (the option that named it, the writer returning its path)
Output = tuple[str, Callable[[], Path]]


def _outputs(args: argparse.Namespace, problem: Problem, planners, results, several: bool) -> list[Output]:
    """The files solve writes (--out, --save-json, --export per method, --plot), each as a writer
    run after the plans are shown (`_write`)."""
    writes: list[Output] = []
    prov = None
    if args.save_json or args.export:  # once per run: every file written says the same
        from judgeopt.formats.plan import plan_provenance, plan_record, write_record

        prov = plan_provenance(planners.judge_path, planners.judge_meta["weights_sha256"], planners.generator_path,
                               command_line())
    for r in results:
        if r.plan is not None and args.out:
            from judgeopt.formats.table_csv import write_plan_csv

            writes.append(("--out", lambda r=r: write_plan_csv(r.plan, _with_method(args.out, r.method, several),
                                                                env=r.env)))
        rec = plan_record(r, problem, prov) if r.plan is not None and prov is not None else None
        if rec is not None and args.save_json:
            writes.append(("--save-json", lambda rec=rec, r=r: write_record(rec, _with_method(args.save_json, r.method,
                                                                                               several))))
        if rec is not None and args.export:
            from judgeopt.cli.export import export_record_to

            writes.append(("--export", lambda rec=rec, r=r: export_record_to(rec, _with_method(args.export, r.method,
                                                                                                several))))
    if args.plot and any(r.plan is not None for r in results):
        from judgeopt.files import save_figure
        from judgeopt.planners.plots import plot_plans

        writes.append(("--plot", lambda: save_figure(plot_plans(problem, results), args.plot)))
    return writes


def _write(writes: list[Output]) -> tuple[list[Path], OutputWriteError | None]:
    """Every output that can be written, and the first that could not (naming its option): one
    unwritable folder neither stops the other files nor hides the plans already shown."""
    files: list[Path] = []
    failed = None
    for flag, write in writes:
        try:
            files.append(write())
        except OutputWriteError as exc:
            failed = failed or exc.with_flag(flag)
    return files, failed


def _assignments(items: list[str] | None) -> dict[str, float]:
    """--simulate-env NAME=VALUE ... as numbers (what they name is checked by the session)."""
    out: dict[str, float] = {}
    for item in items or ():
        name, _, value = (x.strip() for x in item.partition("="))
        try:
            out[name] = float(value)
        except ValueError:
            raise CLIError(f"--simulate-env {item}: {value!r} is not a number (NAME=VALUE, e.g. "
                           f"{example_assignment()})") from None
    return out


def _infeasible(args: argparse.Namespace, problem: Problem, env: dict, exc: ProblemError) -> int:
    if args.json:
        from judgeopt.session.solve import infeasible_json

        print(json.dumps(infeasible_json(problem, env, exc)))
    else:
        print(f"judgeopt solve: infeasible: {exc}", file=sys.stderr)
    return ExitCode.INFEASIBLE


# -- train-generator -------------------------------------------------------------------------

def margin_shifts(given: list[tuple[str, str]], problem: Problem) -> tuple[tuple[str, float], ...]:
    """--margin NAME=DELTA, checked against the problem's environment variables."""
    out = []
    for name, value in given:
        if name not in problem.env_names:
            raise CLIError(f"--margin {name}={value}: {name} is not an environment variable of this problem "
                           f"(it has {', '.join(problem.env_names)})")
        try:
            out.append((name, float(value)))
        except ValueError:
            raise CLIError(f"--margin {name}={value}: DELTA must be a number, e.g. {name}=0.03") from None
    return tuple(out)


def cmd_train_generator(args: argparse.Namespace) -> int:
    import numpy as np

    import torch

    from judgeopt.judge.store import check_compatible, load_judge
    from judgeopt.planners.generator import AmortizedPlanner
    from judgeopt.planners.limits import CONDITION_NAMES, coverage_notes
    from judgeopt.planners.generator_train import GeneratorTrainConfig, train_config_dict, train_generator
    from judgeopt.files import resolve
    from judgeopt.planners.store import save_generator

    from judgeopt.judge.store import model_paths

    refuse_overwrite(model_paths(args.out), args.overwrite)
    problem = problem_from_args(args)
    ranges = None
    given = {k: getattr(args, f"{k}_range") for k in CONDITION_NAMES if getattr(args, f"{k}_range") is not None}
    if args.conditioned:  # default: the shipped conditioned generator's ranges; another task's wide ones
        from judgeopt.planners.limits import LimitRanges, wide_limits
        from judgeopt.tasks import DEFAULT_TASK

        ranges = limit_ranges_from_args(args, LimitRanges() if problem.task == DEFAULT_TASK else wide_limits(problem.task))
        ranges.check(problem)
    elif given:
        raise ProblemError(f"--{next(iter(given)).replace('_', '-')}-range needs --conditioned")
    jpath = resolve(problem.judge, (".json",))
    judge, jmeta = load_judge(jpath)
    check_compatible(jmeta, horizon=problem.steps, dt=problem.dt, channels=problem.channels, env_names=problem.env_names)
    for note in coverage_notes(problem, jmeta):
        print(f"judgeopt train-generator: warning: {note}", file=sys.stderr)
    tc = GeneratorTrainConfig(epochs=args.epochs, batch=args.batch, lr=args.lr, seed=args.seed,
                              threads=args.threads, progress=not args.quiet, margin=margin_shifts(args.margin, problem),
                              margin_weight=args.margin_weight)
    loss_judge, pessimistic = judge, None
    if problem.ensemble:  # train against the ensemble's pessimistic score instead of the one judge
        from judgeopt.judge.ensemble import PessimisticJudge, load_ensemble
        from judgeopt.files import sha256_file

        members, _ = load_ensemble(resolve(problem.ensemble))
        for m in members:
            check_compatible(m.config, horizon=problem.steps, dt=problem.dt, channels=problem.channels, env_names=problem.env_names)
        loss_judge = PessimisticJudge(members, problem.pessimism)
        pessimistic = {"ensemble": problem.ensemble, "pessimism": problem.pessimism,
                       "manifest_sha256": sha256_file(resolve(problem.ensemble) / "ensemble.json")}
    init = None
    if args.init:  # fine-tune (e.g. against an ensemble or a refined judge) instead of starting afresh
        from judgeopt.planners.store import load_generator, matches

        init, imeta = load_generator(resolve(args.init, (".json",)))
        # fine-tuning may move the end (end_margin): the rest of the limits must be the init's
        if (imeta.get("conditioned") is not None) != (ranges is not None) \
                or not matches(imeta, problem.with_overrides(end_margin=0.0)):
            raise ProblemError(f"--init {args.init}: trained for other limits (or {'not ' if ranges else ''}"
                               "conditioned); fine-tune a generator made for this problem's limits")
    gen, history = train_generator(problem, loss_judge, tc=tc, conditioned=ranges, init=init)
    # held-out check: fresh environments (another seed; for a conditioned generator, fresh
    # limits from its ranges too), judged and measured like a solve
    rng = np.random.default_rng(args.seed + 1_000_003)
    envs = problem.sample_env(rng, 200)
    if ranges is None:
        planner = AmortizedPlanner(gen, problem, judge)
        res = [planner.solve(dict(zip(problem.env_names, e))) for e in envs]
    else:
        lims = ranges.sample(rng, len(envs))
        res = [AmortizedPlanner(gen, problem.with_overrides(**dict(zip(CONDITION_NAMES, map(float, lim)))),
                                judge).solve(dict(zip(problem.env_names, e))) for e, lim in zip(envs, lims)]
    metrics = {"predicted_success_mean": float(np.mean([r.predicted_success for r in res])),
               "max_constraint_violation_max": float(max(r.max_constraint_violation for r in res)),
               "max_constraint_violation_median": float(np.median([r.max_constraint_violation for r in res])),
               "n_envs": len(res), **({"limits_sampled_from_ranges": True} if ranges is not None else {}),
               "final": history[-1] if history else {}}
    meta = {"created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "command": command_line(),
            "seed": args.seed, "train_config": train_config_dict(tc), "torch_version": torch.__version__,
            "judge": {"path": str(problem.judge), "weights_sha256": jmeta["weights_sha256"]},
            "metrics": metrics, **({"loss_judge": pessimistic} if pessimistic else {}),
            # where the environments were drawn from: a fine-tuned generator keeps its first
            # problem (and input scaling) in "problem", but may have been trained on wider ranges
            "train_environment": problem.to_dict()["environment"],
            **({"fine_tuned_from": str(args.init)} if args.init else {})}
    pt, js = save_generator(gen, args.out, meta)
    _write_history(history, Path(args.out))
    what = "environments" if ranges is None else "environments and limits"
    print(f"wrote {pt} and {js}: on 200 new {what} predicted success {metrics['predicted_success_mean']:.3f}, "
          f"worst constraint violation {metrics['max_constraint_violation_max']:.2e} "
          f"(median {metrics['max_constraint_violation_median']:.2e})")
    return 0


def _write_history(history: list[dict], out: Path) -> None:
    from judgeopt.formats.table_csv import write_records
    from judgeopt.judge.store import model_paths

    if history:
        write_records(model_paths(out)[1].with_suffix(".history.csv"), history)


def add_planner_commands(sub: argparse._SubParsersAction) -> None:
    s = sub.add_parser("solve", help=HELP["solve"],
                       parents=[out_option("FILE", "write each plan as CSV at 1 kHz, the importer's columns (one file "
                                           "per method: NAME_METHOD.csv)"), OVERWRITE, JSON, QUIET, threads_option()],
                       description="Plan with the amortised generator and/or the direct Ipopt solve against the "
                       "judge; show each plan's success probability and verdict (and with --simulate, the simulated outcome). "
                       "Exit 3 if the limits are infeasible, 4 if no plan is likely to succeed.")
    add_problem_arguments(s)
    from judgeopt.cli.common import PlannerChoices
    from judgeopt.planners.base import GROUP_ALIASES, GROUPS, REGISTRY, WARM_STARTS, default_planners

    each = "; ".join(f"{n}: {s.description}" for n, s in REGISTRY.items())
    s.add_argument("--method", choices=PlannerChoices(extra=(*GROUPS, *GROUP_ALIASES)), default="default",
                   help=(f"default (the default): {' and '.join(default_planners())}; all: every planner; or one: "
                         f"{each}; or a plugin's (--plugin); both: the older name of default").replace("%", "%%"))
    add_plugin_option(s)
    s.add_argument("--simulate-env", action="append", metavar="NAME=VALUE",
                   help=f"simulate in a world that differs from the one planned for (e.g. {example_assignment()}: "
                   "a value other than the planners were told); repeatable (default: the world planned for)")
    s.add_argument("--simulate", action=argparse.BooleanOptionalAction, default=True,
                   help="replay each plan in PyBullet and report the outcome (default: on; about 2 s)")
    s.add_argument("--save-json", metavar="PATH", type=file_path, help="write the plan with its problem, outcome, residuals and "
                   "provenance (models' sha256, git commit, command) as one JSON file (one per method: "
                   "NAME_METHOD.json); read back with judgeopt.formats.plan.read_plan_json")
    s.add_argument("--export", metavar="FILE", type=file_path, help="write the plan for a robot (one per method: NAME_METHOD.EXT): "
                   ".csv with the importer's columns, or .mcap with ROS 2 messages along the problem's [frame] "
                   "(pip install 'judgeopt[ros]'); as `judgeopt export` does from a --save-json file")
    s.add_argument("--plot", metavar="FILE", type=figure_path,
                   help="write q, q̇ and f against time with the allowed region (PNG, PDF or SVG by suffix)")
    s.add_argument("--generator", help="generator model (default: one in --models trained for these limits)")
    s.add_argument("--models", default="models", metavar="DIR",
                   help="folder searched for generators (models/: $JUDGEOPT_MODELS, then the shipped models)")
    add_backend_argument(s)
    s.add_argument("--warm-start", choices=WARM_STARTS, default=WARM_STARTS[0],
                   help="where the direct solve starts: generator (default: its plan, where a generator covers the "
                   "limits) or none (cold, as for a new task or new limits: a min-jerk move, or where the judge calls that a "
                   "failure its best of a few of the task's own commands)")
    s.add_argument("--env-case", dest="range_case", choices=("worst", "expected"), default="worst",
                   help=f"an environment variable given here as a range ({example_range()}: somewhere in here): the "
                   "direct solve plans for the worst case over a grid of it (default) or for the expected success "
                   "over the grid; the other planners plan for its middle")
    s.add_argument("--explain", action="store_true", help="also print what the table's judge, success p and verdict "
                   "columns mean, and the held-out evidence behind each planner's 'likely'")
    s.add_argument("--risk", type=risk_rate, default=RISK, metavar="R",
                   help=f"the failure rate a 'likely' may carry, as a {100 * CONFIDENCE:g} %% upper confidence bound on "
                   f"held-out replayed plans of the planner (default {RISK:g}); a plan above 0.5 but under the threshold "
                   "that risk sets is 'uncertain'")
    s.add_argument("--server", metavar="URL", help="ask a planning service (`judgeopt serve`, e.g. "
                   "http://127.0.0.1:8000) instead of planning here: the same table, no models loaded here; it is sent "
                   "the problem by name, the limits, constraints, objective, environment and --method")
    s.add_argument("--token-file", metavar="FILE", help="with --server: the service's bearer token (its first line)")
    s.add_argument("--suggest", action=argparse.BooleanOptionalAction, default=True,
                   help="when no plan is likely, re-plan under relaxed limits and name the smallest change of one "
                   "limit that makes a plan likely (default: on; --no-suggest turns it off)")
    s.set_defaults(func=cmd_solve)

    t = sub.add_parser("train-generator", help=HELP["train-generator"],
                       parents=[out_option("STEM", "model path without suffix, e.g. out/generator_slow (writes "
                                           "STEM.pt and STEM.json)", required=True), OVERWRITE, seed_option(),
                                threads_option(), QUIET],
                       description="Each epoch samples --batch environments from the problem's ranges and takes one "
                       "Adam step on L = L1 + L2. Seeded and deterministic for a given thread count.")
    add_problem_arguments(t)
    t.add_argument("--epochs", type=positive, default=5000, help="Adam steps")
    t.add_argument("--init", metavar="GENERATOR", help="fine-tune this generator instead of starting from scratch")
    t.add_argument("--batch", type=positive, default=100, help="environments per epoch")
    t.add_argument("--lr", type=number, default=1e-3, help="Adam learning rate")
    t.add_argument("--margin", type=env_assignment, action="append", default=[], metavar="NAME=DELTA",
                   help="also ask the judge to pass each plan with this environment variable shifted by DELTA "
                   f"(the world unlike the one told, e.g. {example_shift()}); repeatable")
    t.add_argument("--margin-weight", type=number, default=1.0, metavar="X",
                   help="weight of each --margin term, relative to P (default 1)")
    c = t.add_argument_group("conditioned generator", "one generator for any q̇_max, f_min, f_max in ranges: the "
                             "limits are extra inputs, drawn per training trajectory (uniform)")
    c.add_argument("--conditioned", action="store_true",
                   help="condition on the limits (the problem's other limits stay fixed)")
    from judgeopt.planners.limits import LimitRanges

    add_limit_range_arguments(c, LimitRanges())  # the scoop's; another task: its wide ranges
    t.set_defaults(func=cmd_train_generator)


def add_backend_argument(p: argparse.ArgumentParser) -> None:
    from judgeopt.judge.backends import BACKENDS, DEFAULT_BACKEND

    p.add_argument("--casadi-backend", choices=("auto", *BACKENDS), default=DEFAULT_BACKEND,
                   help="how the direct solve evaluates the judge: auto takes torch32 (the float32 network, fastest) "
                   "under the objective target, and l4casadi where installed under log_p (float64; its library "
                   "builds once per judge, about 15 s), else native (the CasADi graph)")


def add_limit_range_arguments(group, defaults=None) -> None:
    """--qdot-max-range, --f-min-range, --f-max-range LO,HI (default: `defaults`, a LimitRanges;
    None: the problem's task's wide ranges, each task's listed in the help)."""
    from judgeopt.planners.limits import CONDITION_NAMES, wide_limits
    from judgeopt.tasks import get_task, task_names

    for name in CONDITION_NAMES:
        if defaults is not None:
            shown = "{:g},{:g}".format(*getattr(defaults, name))
        else:
            shown = "the task's: " + ", ".join("{} {:g},{:g}".format(t, *getattr(wide_limits(t), name))
                                                for t in task_names() if get_task(t).wide_limits)
        group.add_argument(f"--{name.replace('_', '-')}-range", dest=f"{name}_range", type=value_range, metavar="LO,HI",
                           help=f"range of {name} (default {shown})")


def limit_ranges_from_args(args: argparse.Namespace, defaults):
    """The LimitRanges the --*-range options give (the rest, and the task, from `defaults`)."""
    import dataclasses

    from judgeopt.planners.limits import CONDITION_NAMES

    given = {k: getattr(args, f"{k}_range") for k in CONDITION_NAMES if getattr(args, f"{k}_range") is not None}
    return dataclasses.replace(defaults, **given)


def cmd_fit_trust_region(args) -> int:
    from judgeopt.data.dataset import load
    from judgeopt.files import resolve, sha256_file
    from judgeopt.planners.trust_region import fit_trust_region, save_trust_region

    refuse_overwrite([Path(args.out).with_suffix(".json")], args.overwrite)
    ds = load(resolve(args.data))
    ok = ds.commands[ds.labels == 1]
    tr = fit_trust_region(ok, args.components)
    path = save_trust_region(tr, args.out, {"data": {"path": str(args.data), "sha256": sha256_file(resolve(args.data)),
                                                     "successful_demonstrations": int(len(ok))},
                                            "components_kept": args.components})
    q = ", ".join(f"{k[1:]} %: {v:.1f}" for k, v in tr.quantiles.items())
    print(f"wrote {path}: distance quantiles of the successful demonstrations: {q}")
    return 0


def add_trust_region_command(sub) -> None:
    t = sub.add_parser("fit-trust-region", help=HELP["fit-trust-region"],
                       parents=[out_option("STEM", "model path without suffix (writes STEM.json; the shipped one is "
                                           "models/trust_region_default)", default="out/trust_region"), OVERWRITE])
    t.add_argument("--data", default="data/train.h5", metavar="FILE", help="demonstrations (HDF5)")
    t.add_argument("--components", type=positive, default=8, help="principal components kept")
    t.set_defaults(func=cmd_fit_trust_region)
