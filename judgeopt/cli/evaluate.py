"""`judgeopt evaluate table4|table5|compare`: the paper's tables and the planners side by side,
measured in simulation."""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path
from typing import Any

from judgeopt.cli.commands import HELP
from judgeopt.cli.common import (CLIError, QUIET, env_range, file_path, floats, jobs_option, name_values, out_option, positive,
                                 risk_rate, strictly_between_0_and_1,
                                 seed_option, threads_option, value_range)
from judgeopt.files import check_writable
from judgeopt.verdict.risk import CONFIDENCE, RISK


def _table_names() -> list[str]:
    """`planners`, `sweep`, `robustness` and every task's own tables (the scoop's table4, table5, compare)."""
    from judgeopt.tasks import get_task, task_names

    return ["planners", "sweep", "edge", "band", "robustness", "trials"] + sorted({name for t in task_names() for name in get_task(t).tables()})


def _default_problem(table: str) -> str:
    from judgeopt.tasks import get_task, task_names

    for t in task_names():
        if table in get_task(t).tables():
            return get_task(t).tables()[table].problem
    return "problems/paper_sim.toml"


def _env_text(problem) -> str:
    return ", ".join(f"{k} in {list(v) if isinstance(v, tuple) else v}" for k, v in problem.environment.items())


def cmd_evaluate(args: argparse.Namespace) -> int:
    from judgeopt.evaluate.report import markdown, summarise, write_report
    from judgeopt.evaluate.tables import run_table, table_planners, tables
    from judgeopt.verdict.rows import rescore
    from judgeopt.planners.problem import ProblemError

    if args.n < 1:
        raise ProblemError(f"--n {args.n}: need at least one environment per row")
    if args.perturb and args.table != "robustness":
        raise CLIError("--perturb: only for `judgeopt evaluate robustness`")
    if args.qdot_max and args.table not in ("robustness", "trials", "edge"):
        raise CLIError("--qdot-max: only for `judgeopt evaluate robustness`, `trials` and `edge`")
    given = [o for o, v in (("--edge-limit", args.edge_limit), ("--edge-span", args.edge_span),
                            ("--offsets", args.offsets)) if v is not None]
    if given and args.table != "edge":
        raise CLIError(f"{', '.join(given)}: only for `judgeopt evaluate edge`")
    if args.edge_span is not None and not args.edge_span[0] < args.edge_span[1]:
        raise CLIError(f"--edge-span {args.edge_span[0]:g},{args.edge_span[1]:g}: need LO < HI")
    if args.trials is not None and args.table != "trials":
        raise CLIError("--trials: only for `judgeopt evaluate trials`")
    given = [o for o, v in (("--band", args.band), ("--constrained", args.constrained), ("--ensemble", args.ensemble))
             if v is not None]
    if given and args.table != "band":
        raise CLIError(f"{', '.join(given)}: only for `judgeopt evaluate band`")
    check_writable([args.out or f"out/evaluate/{args.table}"])  # before any plan is made
    if args.table == "sweep":
        return cmd_sweep(args)
    if args.table == "edge":
        return cmd_edge(args)
    if args.table == "band":
        return cmd_band(args)
    if args.table == "robustness":
        return cmd_robustness(args)
    if args.table == "trials":
        return cmd_trials(args)
    problem = problem_of(args, _default_problem(args.table))
    if args.limits:
        from judgeopt.evaluate.sweep import parse_limit_set

        if len(args.limits) > 1:
            raise CLIError(f"--limits: `evaluate {args.table}` takes one set (a sweep takes several)")
        problem = problem.with_overrides(**dict(parse_limit_set(args.limits[0]).overrides))
    available = tables(problem.task)
    if args.table not in available:
        raise ProblemError(f"table {args.table!r} is not one of task {problem.task!r}'s ({', '.join(available)}); "
                           "choose another --problem or table")
    table = available[args.table]
    rows = table.rows(table_planners())
    if args.methods:
        rows = [r for r in rows if r.method in args.methods or r.method == "random"]
    if args.rows:
        rows = [r for r in rows if r.name in args.rows]
        if not rows:
            raise ProblemError(f"--rows {args.rows}: no such rows in {args.table} (names: "
                               f"{[r.name for r in table.rows(table_planners())]})")
    if args.judge:  # the same table against another judge (e.g. a refined one): every row that plans with one
        from judgeopt.planners.base import REGISTRY

        rows = [dataclasses.replace(r, name=f"{r.name}, {Path(args.judge).name}", judge=args.judge)
                if r.judge or r.method in REGISTRY else r for r in rows]
    out = Path(args.out or f"out/evaluate/{args.table}")
    calibrators, evidence, plan_model = _calibration(problem, args.calibration)  # a bad file fails here, before any planning
    results = run_table(problem, rows, args.n, args.seed, out, n_jobs=args.jobs, scheduler=args.scheduler,
                        chunk=args.chunk, models_dir=args.models, progress=not args.quiet)
    for rs in results.values():  # with the calibration and evidence there are now (cached plans may predate them)
        rescore(rs, calibrators, evidence, args.risk, plan_model)
    summary = summarise(rows, results)
    title = table.title.format(qdot_max=problem.qdot_max, name=problem.name, task=problem.task,
                               f_min=problem.f_min, f_max=problem.f_max, env=_env_text(problem))
    if problem.constraints.is_set():
        from judgeopt.planners.constraints import describe

        title += "; constraints " + ", ".join(f"{k} {', '.join(v) if k == 'bounds' else v}"
                                              for k, v in describe(problem.constraints).items())
    files = write_report(summary, out, args.table, title, results, rows)
    print(markdown(summary, title))
    print("command: judgeopt evaluate " + " ".join(f"{a}" for a in _argv(args)))
    for f in files:
        print(f"wrote {f}")
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    from judgeopt.evaluate.sweep import (DEFAULT_LIMIT_SETS, markdown_sweep, parse_limit_set, plot_sweep,
                                         random_constraint_sets, random_limit_sets, summarise_sweep, sweep_rows)
    from judgeopt.evaluate.tables import run_table
    from judgeopt.verdict.rows import rescore
    from judgeopt.planners.constraint_ranges import corners
    from judgeopt.cli.planners import limit_ranges_from_args
    from judgeopt.planners.limits import wide_limits

    problem = problem_of(args)
    if args.judge:  # every planner against this judge (its calibration applies only where it has one)
        problem = problem.with_overrides(judge=args.judge)
    vary = _vary(problem, args.vary) if args.vary else None
    if args.random_constraints is not None and (args.random_limits or args.limits):
        raise CLIError("--random-constraints: draws constraint sets at the problem's limits; leave out "
                       f"{'--random-limits' if args.random_limits else '--limits'} (or give constraints in --limits)")
    what = "limit"
    if args.random_constraints is not None:
        varied = problem if vary is None else problem.with_overrides(**{vary[0]: list(vary[1])})
        sets = random_constraint_sets(args.random_constraints, args.seed, problem, envs=corners(varied))
        what = "constraint"
    elif args.random_limits:
        ranges = limit_ranges_from_args(args, wide_limits(problem.task))
        ranges.check(problem)
        sets = random_limit_sets(args.random_limits, args.seed, ranges)
    else:
        sets = [parse_limit_set(t) for t in (args.limits or DEFAULT_LIMIT_SETS)]
    methods = tuple(args.methods) if args.methods else None
    rows, notes = sweep_rows(problem, sets, vary, args.models, methods, args.baselines)
    out = Path(args.out or "out/evaluate/sweep")
    calibrators, evidence, plan_model = _calibration(problem, args.calibration)  # a bad file fails here, before any planning
    results = run_table(problem, rows, args.n, args.seed, out, n_jobs=args.jobs, scheduler=args.scheduler,
                        chunk=args.chunk, models_dir=args.models, progress=not args.quiet)
    for rs in results.values():  # with the calibration and evidence there are now (cached plans may predate them)
        rescore(rs, calibrators, evidence, args.risk, plan_model)
    summary = summarise_sweep(sets, rows, results, methods)
    env = _env_text(problem) if vary is None else _env_text(problem.with_overrides(**{vary[0]: list(vary[1])}))
    at = f" at the limits of {problem.name}" if what == "constraint" else ""
    title = f"Held-out {what} sets{at} ({args.n} environments each, {env}, seed {args.seed}; judge {problem.judge})"
    md = markdown_sweep(summary, title)
    return _report(args, out / "sweep", md, summary, plot_sweep(summary, title), notes)


def cmd_edge(args: argparse.Namespace) -> int:
    from judgeopt.evaluate.edge import EdgeConfig, markdown_edge, plot_edge, run_edge, summarise_edge
    from judgeopt.verdict.rows import rescore

    base = _problem(args)
    vary = _vary(base, args.vary) if args.vary else None
    cfg = EdgeConfig(**{k: v for k, v in (("limit", args.edge_limit), ("span", args.edge_span),
                                          ("offsets", args.offsets)) if v is not None})
    from judgeopt.planners.base import default_planners

    methods = tuple(args.methods or default_planners())
    out = Path(args.out or "out/evaluate/edge")
    calibrators, evidence, plan_model = _calibration(base, args.calibration)  # a bad file fails here, before any planning
    rows = []
    for q in args.qdot_max or (None,):
        problem = base if q is None else base.with_overrides(qdot_max=q)
        rows += run_edge(problem, cfg, methods, args.n, args.seed, out, vary, n_jobs=args.jobs,
                         scheduler=args.scheduler, chunk=args.chunk, models_dir=args.models, progress=not args.quiet)
    rescore(rows, calibrators, evidence, args.risk, plan_model)  # cached plans may predate the calibration
    summary = summarise_edge(rows, methods)
    speeds = ", ".join(f"{q:g}" for q in args.qdot_max) if args.qdot_max else f"{base.qdot_max:g}"
    env = _env_text(base) if vary is None else _env_text(base.with_overrides(**{vary[0]: list(vary[1])}))
    title = (f"Where outcomes flip: {base.name}, q̇_max {speeds}, {cfg.limit} around the edge found ({env}; seed "
             f"{args.seed}; judge {base.judge})")
    command = "judgeopt evaluate " + " ".join(_argv(args))
    stem = out / "edge"
    from judgeopt.files import atomic_write

    atomic_write(stem.with_suffix(".json"), json.dumps(summary, indent=1) + "\n")
    print(f"wrote {stem.with_suffix('.json')}")
    per = [{k: v for k, v in s.items() if k != "reliability"} for s in summary["planners"]]
    return _report(args, stem, markdown_edge(summary, title, command), per, plot_edge(summary, rows, title), [])


def cmd_band(args: argparse.Namespace) -> int:
    from judgeopt.evaluate.band import BandConfig, default_band, markdown_band, plot_band, run_band, summarise_band
    from judgeopt.verdict.rows import rescore
    from judgeopt.files import atomic_write
    from judgeopt.planners.base import default_planners

    problem = _problem(args)
    band = default_band(problem.task) if not args.band else BandConfig(tuple((k, lo, hi) for k, (lo, hi) in args.band))
    cfg = dataclasses.replace(band, constrained=0.3 if args.constrained is None else args.constrained)
    methods = tuple(args.methods or default_planners())
    out = Path(args.out or "out/evaluate/band")
    calibrators, evidence, plan_model = _calibration(problem, args.calibration)  # a bad file fails here, before any planning
    rows = run_band(problem, cfg, methods, args.n, args.seed, out, n_jobs=args.jobs, scheduler=args.scheduler,
                    chunk=args.chunk, models_dir=args.models, ensemble=args.ensemble, progress=not args.quiet)
    rescore(rows, calibrators, evidence, args.risk, plan_model)
    summary = summarise_band(rows, methods)
    ranges = ", ".join(f"{k} {lo:g}-{hi:g}" for k, lo, hi in cfg.ranges)
    title = (f"The verdict across the edge band: {problem.name}, {ranges}, {100 * cfg.constrained:g} % constrained; "
             f"risk {100 * args.risk:g} %; seed {args.seed}; judge {problem.judge}")
    stem = out / "band"
    atomic_write(stem.with_suffix(".json"), json.dumps(summary, indent=1) + "\n")
    print(f"wrote {stem.with_suffix('.json')}")
    per = [{k: v for k, v in s.items() if k != "reliability"} for s in summary["planners"]]
    command = "judgeopt evaluate " + " ".join(_argv(args))
    return _report(args, stem, markdown_band(summary, title, command), per, plot_band(summary, title), [])


def _report(args: argparse.Namespace, stem: Path, md: str, summary: list[dict], figure, notes: list[str]) -> int:
    """An evaluation's Markdown, CSV (one row per summary entry) and figure at STEM.md/.csv/.png,
    printed with its notes and the command that made it."""
    from judgeopt.files import atomic_write, save_figure
    from judgeopt.formats.table_csv import write_records

    atomic_write(stem.with_suffix(".md"), md)
    write_records(stem.with_suffix(".csv"), summary)
    png = save_figure(figure, stem.with_suffix(".png"))
    for note in notes:
        print(f"note: {note}")
    print(md)
    print("command: judgeopt evaluate " + " ".join(_argv(args)))
    for f in (stem.with_suffix(".md"), stem.with_suffix(".csv"), png):
        print(f"wrote {f}")
    return 0


def problem_of(args: argparse.Namespace, default: str = "problems/paper_sim.toml") -> Any:
    """--problem (or `default`) on the arm --robot names (default: the problem's)."""
    from judgeopt.files import resolve
    from judgeopt.planners.problem import load_problem

    problem = load_problem(resolve(args.problem or default))
    return problem.with_overrides(robot=args.robot) if args.robot else problem


def _problem(args: argparse.Namespace) -> Any:
    """--problem with --judge, each --qdot-max checked against it before any planning."""

    problem = problem_of(args)
    if args.judge:
        problem = problem.with_overrides(judge=args.judge)
    for q in args.qdot_max or ():
        problem.with_overrides(qdot_max=q)  # a limit that contradicts the problem: one line, before planning
    return problem


def _planned(args: argparse.Namespace, problem: Any, default_out: str) -> tuple[list, list[str], Path, dict]:
    """One row per --qdot-max and planner (default: the default planners), each planned for --n
    environments (resumable in OUT/partial/): rows, notes, the output folder and the plans."""
    from judgeopt.evaluate.robustness import robustness_rows
    from judgeopt.evaluate.tables import run_table
    from judgeopt.planners.base import default_planners

    qdots = tuple(args.qdot_max or (problem.qdot_max,))
    rows, notes = robustness_rows(problem, qdots, tuple(args.methods or default_planners()), args.models)
    if not rows:
        raise CLIError(f"no planner to evaluate: {'; '.join(notes)}")
    out = Path(args.out or default_out)
    plans = run_table(problem, rows, args.n, args.seed, out, n_jobs=args.jobs, scheduler=args.scheduler,
                      chunk=args.chunk, models_dir=args.models, progress=not args.quiet)
    return rows, notes, out, plans


def cmd_robustness(args: argparse.Namespace) -> int:
    from judgeopt.evaluate.robustness import (markdown_robustness, plot_robustness, robustness_cases, run_replays,
                                              summarise_robustness)
    from judgeopt.tasks import get_task

    problem = _problem(args)
    task = get_task(problem.task)
    cases = robustness_cases(task, args.perturb)  # an unknown name fails here, before any planning
    rows, notes, out, plans = _planned(args, problem, "out/evaluate/robustness")
    results = run_replays(problem, rows, plans, cases, args.n, args.seed, out, chunk=args.chunk, n_jobs=args.jobs,
                          scheduler=args.scheduler, progress=not args.quiet, models_dir=args.models)
    summary = summarise_robustness(task, rows, cases, results)
    title = (f"Plans for the nominal world replayed in perturbed ones: {problem.name} (task {task.name}), "
             f"{args.n} environments ({_env_text(problem)}), seed {args.seed}, judge {problem.judge}")
    md = markdown_robustness(task, summary, title)
    return _report(args, out / "robustness", md, summary, plot_robustness(task, summary, title), notes)


def cmd_trials(args: argparse.Namespace) -> int:
    from matplotlib.figure import Figure

    from judgeopt.evaluate.trials import TrialSpread, markdown_trials, run_trials

    problem = _problem(args)
    rows, notes, out, plans = _planned(args, problem, "out/evaluate/trials")
    k = args.trials or 10
    spread = TrialSpread.of(problem.task)
    summary = run_trials(problem, {r.key: plans[r.key] for r in rows}, k, args.seed, spread, progress=not args.quiet)
    names = {r.key: r.name for r in rows}
    for s in summary:
        s["row"] = names[s["row"]]
    title = (f"Repeated trials: {problem.name} (task {problem.task}), {args.n} environment(s) ({_env_text(problem)}), "
             f"{k} trials per plan, seed {args.seed}, judge {problem.judge}")
    fig = Figure(figsize=(7, 3.2))
    ax = fig.subplots()
    ax.bar(range(len(summary)), [s["successes"] or 0 for s in summary])
    ax.set_xticks(range(len(summary)), [f"{s['row']}\n(env {s['env_index']})" for s in summary], fontsize=7)
    ax.axhline(0.9 * k, color="0.5", ls="--", lw=0.8)
    ax.set_ylabel(f"successful trials of {k}")
    ax.set_title(title, fontsize=8, wrap=True)
    table = [{k_: v for k_, v in s.items() if k_ not in ("draws", "outcomes")} for s in summary]
    return _report(args, out / "trials", markdown_trials(summary, title, spread), table, fig, notes)


def _vary(problem, item: tuple[str, tuple[float, float]]) -> tuple[str, tuple[float, float]]:
    """--vary NAME=LO,HI checked against the task's physical range."""
    from judgeopt.planners.problem import ProblemError
    from judgeopt.tasks import get_task

    name, (lo, hi) = item
    physical = get_task(problem.task).env_ranges("physical")
    if name not in problem.environment:
        raise ProblemError(f"--vary {name}: not an environment variable of the problem ({', '.join(problem.environment)})")
    plo, phi = physical[name]
    if not (plo <= lo <= hi <= phi):
        raise ProblemError(f"--vary {name}={lo:g},{hi:g}: need {plo:g} <= LO <= HI <= {phi:g} (the scene's physical "
                           "range, lower bound first)")
    return name, (lo, hi)


def _calibration(problem, path: str | None) -> tuple[dict, dict, object]:
    """The calibrators, held-out evidence and plan model (None: none) of --calibration, or of the
    problem's file where it exists (none: no calibrated column, every risk unchecked), read once."""
    from judgeopt.files import resolve
    from judgeopt.verdict.calibration import load_calibration_document
    from judgeopt.verdict.plan_model import plan_model_of

    if path is None and not (problem.calibration and resolve(problem.calibration).exists()):
        return {}, {}, None
    file = resolve(path or problem.calibration)
    calibrators, evidence, section = load_calibration_document(file)
    return calibrators, evidence, plan_model_of(section, str(file))


def _argv(args: argparse.Namespace) -> list[str]:
    extra = (["--problem", args.problem] if args.problem else []) + (["--robot", args.robot] if args.robot else [])
    extra += ["--methods", *args.methods] if args.methods else []
    extra += (["--rows", *map(repr, args.rows)] if args.rows else []) + (
        ["--judge", args.judge] if args.judge else [])
    extra += (["--limits", *map(repr, args.limits)] if args.limits else []) + (["--vary", f"{args.vary[0]}={args.vary[1][0]:g},{args.vary[1][1]:g}"] if args.vary else [])
    extra += (["--random-constraints", str(args.random_constraints)] if getattr(args, "random_constraints", None)
              else [])
    extra += (["--random-limits", str(args.random_limits)] if args.random_limits else []) + (
        [] if args.baselines else ["--no-baselines"])
    extra += [f"--{k.replace('_', '-')} {v[0]:g},{v[1]:g}" for k, v in vars(args).items()
              if k.endswith("_range") and v is not None]
    extra += (["--perturb", *(n if v is None else f"{n}={','.join(f'{x:g}' for x in v)}" for n, v in args.perturb)]
              if args.perturb else []) + (["--qdot-max", ",".join(f"{q:g}" for q in args.qdot_max)] if args.qdot_max else [])
    extra += (["--trials", str(args.trials)] if args.trials else []) + (
        ["--calibration", args.calibration] if args.calibration else [])
    extra += (["--edge-limit", args.edge_limit] if args.edge_limit else []) + (
        [f"--edge-span {args.edge_span[0]:g},{args.edge_span[1]:g}"] if args.edge_span else []) + (
        ["--offsets " + ",".join(f"{x:g}" for x in args.offsets)] if args.offsets else [])
    extra += (["--band", *(f"{k}={lo:g},{hi:g}" for k, (lo, hi) in args.band)] if args.band else []) + (
        [f"--constrained {args.constrained:g}"] if args.constrained is not None else []) + (
        ["--ensemble", args.ensemble] if args.ensemble else []) + (
        [f"--risk {args.risk:g}"] if args.risk != RISK else [])
    return [args.table, "--n", str(args.n), "--seed", str(args.seed)] + extra


def cmd_calibrate(args: argparse.Namespace) -> int:
    from judgeopt.verdict.calibration import CalibrationError, load_calibration_document, save_calibration
    from judgeopt.verdict.risk import whose

    check_writable([args.out])
    if args.plan_model:
        return _calibrate_plan_model(args)
    if not args.folders and not args.evidence:
        raise CLIError("give evaluation folders to fit on, or --evidence FOLDER... to set the risk behind 'likely' "
                       "for the calibration already in --out")
    out = Path(args.out)
    if not args.folders and not out.exists():
        raise CalibrationError(f"--evidence: {out} holds no calibration to add it to; fit one first with "
                               f"`judgeopt calibrate FOLDER... --out {out}`")
    kept, old_evidence, plan_model = load_calibration_document(out) if out.exists() else ({}, {}, None)
    kept, old_evidence = ({}, {}) if args.replace else (kept, old_evidence)
    fitted, refitted = _fit_calibration(args) if args.folders else ({}, set())
    calibrators = {**{k: v for k, v in kept.items() if k not in fitted}, **fitted}
    # evidence describes the p of its planner, judge and arm: that of the ones refitted here is stale, and
    # new evidence replaces all the old of its planner, judge and arm (every kind of p)
    new = _risk_evidence(args, calibrators) if args.evidence else {}
    renewed = {whose(k) for k in new}
    # a plan model's evidence is its own (--plan-model), kept beside what is renewed here
    evidence = {**{k: v for k, v in old_evidence.items() if whose(k) not in refitted | renewed or v.kind == "plans"},
                **new}
    dropped = sorted(k for k in old_evidence if whose(k) in refitted - renewed)
    if dropped:
        print(f"note: the held-out evidence in {out} for {', '.join(dropped)} described the calibration being "
              "replaced and is dropped; recompute it with --evidence FOLDER (`judgeopt evaluate band` on another seed)")
    save_calibration(out, calibrators, evidence, plan_model)
    print(f"wrote {out} ({len(fitted)} settings fitted, {len(calibrators) - len(fitted)} kept from before"
          f"{f', evidence for {len(evidence)} planners' if evidence else ''})")
    return 0


def _calibrate_plan_model(args: argparse.Namespace) -> int:
    """Fit a plan model (judgeopt.verdict.plan_model) on band folders and set its threshold of "likely"
    on out-of-fold p (each folder scored by a model of the others); the rest of --out is kept."""
    from judgeopt.evaluate.stored import read_rows
    from judgeopt.verdict.calibration import load_calibration_document, save_calibration
    from judgeopt.verdict.plan_model import fit_plan_model, out_of_fold
    from judgeopt.verdict.risk import RISK, fit_evidence

    if args.folders or args.evidence:
        raise CLIError("--plan-model fits on its own folders (each is held out from the others' model): give the "
                       "other folders in a call of their own")
    out = Path(args.out)
    calibrators, old_evidence, _ = load_calibration_document(out) if out.exists() else ({}, {}, None)
    folds = {f: [r for r in read_rows([f]) if not args.methods or r.get("method") in args.methods]
             for f in args.plan_model}
    if len(folds) < 2:
        raise CLIError("--plan-model needs at least two band folders (each is scored by a model fitted on the others)")
    out_of_fold(folds)
    rows = [r for rs in folds.values() for r in rs]
    new = {k: e for k, e in fit_evidence(rows, args.confidence).items() if e.kind == "plans"}
    for e in new.values():
        e.sources = sorted(folds)
    model = fit_plan_model(rows, sources=list(folds))
    evidence = {**{k: v for k, v in old_evidence.items() if v.kind != "plans"}, **new}
    save_calibration(out, calibrators, evidence, model.to_dict())
    for e in new.values():
        print(f"{e.method}: {e.describe(RISK)}")
    print(f"wrote {out} (a plan model fitted on {model.n} replayed plans of {len(folds)} folders, "
          f"{model.successes} succeeded; its evidence counted out of fold; the other {len(calibrators)} settings kept)")
    return 0


def _fit_calibration(args: argparse.Namespace) -> tuple[dict, set[str]]:
    """Fit a calibrator per setting in the folders and print the table of them; with the evidence keys
    (verdict.risk.evidence_key) of the plans fitted on."""
    from judgeopt.evaluate.stored import read_rows
    from judgeopt.robots import DEFAULT_ROBOT
    from judgeopt.verdict.calibration import CalibrationError, describe, fit_from_rows
    from judgeopt.verdict.risk import evidence_key

    rows = read_rows(args.folders)
    with_setting = [r for r in rows if r.get("setting") and (not args.methods or r.get("method") in args.methods)]
    if not with_setting and args.methods:
        raise CalibrationError(f"{args.folders}: no evaluated plans of {', '.join(args.methods)}")
    if not with_setting:
        raise CalibrationError(f"{args.folders}: these plans carry no planner setting (made before calibration "
                               "existed); rerun the evaluation")
    env_names = list(with_setting[0]["environment"])
    descriptions = {r["setting"]: _named_arm(r) for r in with_setting}
    if args.over_limits and not all("family" in r and "limits" in r for r in with_setting):
        raise CalibrationError(f"{args.folders}: these plans do not record their limits (made before --over-limits "
                               "existed); rerun the evaluation")
    fitted = fit_from_rows(with_setting, descriptions, env_names, min_n=args.min_n, sources=list(args.folders),
                           over_limits=args.over_limits)
    if not fitted:
        raise CalibrationError(f"no setting has {args.min_n} replayed outcomes in {args.folders}; evaluate more "
                               "environments or lower --min-n")
    print("| setting | planner | outcomes | simulated success | fitted ranges | CV log loss: monotone map "
          "(unconstrained logistic / isotonic on the judge / constant rate) |")
    print("|---|---|---|---|---|---|")
    for c in fitted.values():
        d = describe(c)
        ranges = ", ".join(f"{k} [{lo:g}, {hi:g}]" for k, (lo, hi) in d["ranges"].items())
        others = " / ".join(f"{c.alternatives[k]:.3f}" for k in ("logistic_unconstrained", "isotonic_judge_only")
                            if k in c.alternatives)
        print(f"| {c.setting} | {d['description']} | {c.n} | {d['success_pct']:.0f} % | {ranges} "
              f"| {d['cv_log_loss']:.3f} ({others} / {d['constant_log_loss']:.3f}){' -> the rate' if c.constant else ''} |")
    by = "family" if args.over_limits else "setting"
    return fitted, {evidence_key(r["method"], r.get("judge_sha256"), r.get("robot", DEFAULT_ROBOT))
                    for r in with_setting if r[by] in fitted}


def _named_arm(row: dict) -> str:
    """The row's setting in words, its arm named (rows recorded before descriptions named it carry it beside)."""
    from judgeopt.planners.loaded import on_arm

    text = row.get("setting_description", row["method"])
    return text if " on " in text else text.replace(row["method"], row["method"] + on_arm(row.get("robot")), 1)


def _risk_evidence(args: argparse.Namespace, calibrators: dict) -> dict:
    """The held-out evidence per planner and judge (judgeopt.verdict.risk), from plans the
    calibration was not fitted on, their p recomputed by that calibration; printed at the default risk."""
    from judgeopt.evaluate.stored import read_rows
    from judgeopt.robots import DEFAULT_ROBOT
    from judgeopt.verdict.calibration import CalibrationError, calibrate_rows
    from judgeopt.verdict.risk import RISK, evidence_key, fit_evidence, kind_of

    rows, folders = [], []  # each plan, and the folder it came from
    for folder in args.evidence:
        for r in read_rows([folder]):
            if r.get("method") and r.get("environment"):
                rows.append(r)
                folders.append(folder)
    if not rows:
        raise CalibrationError(f"--evidence {' '.join(args.evidence)}: no replayed plans in these folders")
    calibrate_rows(rows, calibrators)
    seen = sum(bool(r.get("calibration_fitted_on_env")) for r in rows)
    if seen:
        raise CalibrationError(f"--evidence: {seen} of its {len(rows)} plans are at environments and limits the "
                               "calibration was fitted on; the evidence must be held out (evaluate on another --seed)")
    came: dict[str, list[str]] = {}  # the folders each planner, judge, arm and kind of p's plans came from
    for r, folder in zip(rows, folders):
        sources = came.setdefault(evidence_key(r["method"], r.get("judge_sha256"), r.get("robot", DEFAULT_ROBOT),
                                               kind_of(r)), [])
        if folder not in sources:
            sources.append(folder)
    evidence = fit_evidence(rows, confidence=args.confidence)
    for key, e in evidence.items():
        e.sources = came.get(key, [])  # none: no plan of this kind in any folder
        arm = "" if e.robots == [DEFAULT_ROBOT] else f" on {', '.join(e.robots)}"
        lifted = (f"; judge p raised above 0.5 by the calibration: {e.raised['successes']} of {e.raised['n']} succeeded"
                  if e.kind != "judge" else "")
        print(f"evidence, {e.subject}{arm} ({e.plans} plans{lifted}): {e.describe(RISK)}")
    return evidence


def add_evaluate_commands(sub: argparse._SubParsersAction) -> None:
    from judgeopt.cli.common import PlannerChoices, add_plugin_option
    from judgeopt.cli.planners import add_limit_range_arguments
    from judgeopt.planners.base import default_planners

    e = sub.add_parser("evaluate", help=HELP["evaluate"],
                       description="Success rates measured by replaying every plan in the PyBullet scene, over --n "
                       "seeded environments per row (rows with the same ranges share them). Parallel processes "
                       "or a Dask cluster (--scheduler); finished chunks are kept in OUT/partial/, so an "
                       "interrupted run resumes.",
                       parents=[out_option("DIR", "output folder, default out/evaluate/TABLE (an unfinished one "
                                           "resumes)"), seed_option(), jobs_option(), threads_option(), QUIET])
    e.add_argument("table", choices=_table_names(),
                   help="planners: every registered planner and the no-judge baseline (any task); sweep: held-out "
                   "limit sets, with the no-judge baseline and a feasibility search in simulation; robustness: each "
                   f"planner's plans (default {' and '.join(default_planners())}) for the nominal world replayed "
                   "unchanged under the "
                   "task's perturbations, one at a time; trials: each planner's plan tried --trials times, the world "
                   "drawn anew each time (a lab's repeated trials); the scoop's table4, "
                   "table5 (the paper's tables) and compare (planners and remedies side by side)")
    e.add_argument("--limits", nargs="+", metavar="SET", help="sweep: limit and constraint sets, each NAME=VALUE,... "
                   "(e.g. qdot_max=0.6,f_max=18 or a_max=2,fdot_max=60,bound=f:0:12@0:0.4; bound repeatable) or a "
                   "problem .toml (default: six held-out sets); other tables: one such set, applied to the problem")
    e.add_argument("--vary", type=env_range, metavar="NAME=LO,HI", help="sweep: draw this environment variable from "
                   "LO,HI instead of the problem's range (seeded by the range)")
    e.add_argument("--random-limits", type=int, metavar="K", help="sweep: K limit sets drawn (by --seed) from the "
                   "--*-range ranges instead of --limits (e.g. to fit `judgeopt calibrate --over-limits`)")
    e.add_argument("--random-constraints", type=int, metavar="K", help="sweep: K constraint sets (a_max, jerk_max, "
                   "fdot_max and an early force cap) drawn by --seed at the problem's limits from ranges that bind on "
                   "the generator's plans, each feasible for the problem's environments (judgeopt.evaluate.sweep."
                   "ConstraintRanges); instead of --limits")
    add_limit_range_arguments(e.add_argument_group("sweep --random-limits ranges"))
    e.add_argument("--baselines", action=argparse.BooleanOptionalAction, default=True,
                   help="sweep: also the no-judge baseline and the feasibility search (default: on)")
    e.add_argument("--edge-limit", metavar="NAME", help="edge: the limit bisected to find where outcomes flip "
                   "(default f_max; q̇_max and f_min too)")
    e.add_argument("--edge-span", type=value_range, metavar="LO,HI", help="edge: where to look for the edge (default: "
                   "the task's wide range of the limit)")
    e.add_argument("--offsets", type=floats, metavar="D1,D2,...", help="edge: settings planned at the edge plus each "
                   "offset towards the easier side, in the limit's units (default -2,-1,-0.5,0,0.5,1,2)")
    e.add_argument("--perturb", nargs="+", type=name_values, metavar="NAME[=V1,V2]",
                   help="robustness: the perturbations to replay under, each at the task's values or the ones given "
                   "(default: every one the task declares; `judgeopt tasks --json` lists them)")
    e.add_argument("--qdot-max", type=floats, metavar="V1,V2", help="robustness, trials: the velocity limits to plan under, "
                   "one evaluation each (e.g. 1.0,0.4; default: the problem's)")
    e.add_argument("--trials", type=positive, metavar="K", help="trials: times each plan is tried, each in a world "
                   "drawn anew around the planned one (the object placed by hand, friction, mass, sensor noise; "
                   "default 10)")
    e.add_argument("--band", nargs="+", type=env_range, metavar="NAME=LO,HI", help="band: draw each setting's limit or "
                   "environment variable NAME uniformly from LO-HI (default: the task's edge band)")
    e.add_argument("--constrained", type=float, metavar="SHARE", help="band: the share of settings that also draw a "
                   "constraint set (a_max, jerk_max, fdot_max, an early force cap; default 0.3)")
    e.add_argument("--ensemble", metavar="DIR", help="band: a judge ensemble whose members' p each plan records")
    e.add_argument("--risk", type=risk_rate, default=RISK, metavar="R", help="the risk behind 'likely' in the verdicts counted (as solve --risk)")
    e.add_argument("--n", type=positive, default=100, help="environments per row (band: settings)")
    e.add_argument("--problem", metavar="FILE", help="problem file (default problems/paper_sim.toml; compare: paper_sim_slow.toml, "
                   "q̇_max = 0.4)")
    e.add_argument("--robot", metavar="NAME", help="plan for and replay on this arm (`judgeopt robots`; default: the "
                   "problem's, ur5)")
    e.add_argument("--methods", nargs="+", choices=PlannerChoices(),
                   help="planners to include (default all of the table's)")
    add_plugin_option(e)
    e.add_argument("--rows", nargs="+", metavar="NAME", help="only these rows (by name)")
    e.add_argument("--judge", metavar="STEM", help="run every planner row against this judge instead (rows renamed)")
    e.add_argument("--judge-model", dest="judge", help=argparse.SUPPRESS)  # the name older scripts use
    e.add_argument("--calibration", metavar="FILE", help="calibration file for the calibrated predictions (default: the problem's "
                   "[models] calibration, where it exists)")
    e.add_argument("--models", default="models", metavar="DIR", help="folder searched for generators")
    e.add_argument("--chunk", type=positive, default=10, help="environments per work unit (and per resume step)")
    e.set_defaults(func=cmd_evaluate)

    c = sub.add_parser("calibrate", help=HELP["calibrate"],
                       description="For every planner setting (method, models, limits) with at least --min-n "
                       "replayed outcomes in the given `judgeopt evaluate` folders (an edge sweep's too), fit a "
                       "logistic map from the judge's logit and the environment to the simulated success, never "
                       "falling while the judge's p rises; planners report it as calibrated_success where it covers "
                       "the plan (near fitted outcomes in limits, environment and judge's p). Evaluate on another "
                       "--seed to test it.")
    c.add_argument("folders", nargs="*", metavar="DIR", help="evaluation output folders (with partial/*.json) to fit "
                   "on; none: keep the calibration in --out and only set its evidence")
    c.add_argument("--evidence", nargs="+", metavar="DIR", help="evaluation folders the calibration was NOT fitted on "
                   "(`judgeopt evaluate band` on another seed): per planner, the threshold of 'likely' at each risk "
                   "(solve --risk) and the raise a calibrated p may make over a judge's p below 0.5, stored in --out")
    c.add_argument("--confidence", type=strictly_between_0_and_1("a confidence between 0 and 1 (0.95 is 95 %)"),
                   default=CONFIDENCE, help="confidence of the evidence's Clopper-Pearson "
                   "bounds")
    c.add_argument("--out", default="out/calibration.json", metavar="FILE", type=file_path,
                   help="calibration file: its other settings "
                   "are kept unless --replace (the shipped one is models/calibration_default.json)")
    c.add_argument("--min-n", type=positive, default=50, help="fewest outcomes a setting needs")
    c.add_argument("--replace", action="store_true", help="drop settings already in --out instead of keeping them")
    c.add_argument("--methods", nargs="+", choices=PlannerChoices(),
                   help="fit only these planners' settings (default: every planner in the folders); a planner left "
                   "out reports the judge's own probability")
    add_plugin_option(c)
    c.add_argument("--over-limits", action="store_true", help="one calibrator per planner and models for all the "
                   "limits in the folders (a sweep's), with q̇ and force limits as inputs beside the environment: it "
                   "then also covers limits between those it saw; plans under constraint sets (a band's) get one of their "
                   "own over limits and constraint sets")
    c.add_argument("--plan-model", nargs="+", metavar="DIR", help="band folders (`judgeopt evaluate band`, two or "
                   "more seeds) to fit a plan model on: one boosted classifier over every planner's plans that reads "
                   "the plan's samples, the constraint set, the limits, the environment and the judge's p; its p stands "
                   "where it covers a plan, and its threshold of 'likely' is set on out-of-fold p (each folder scored "
                   "by a model of the others). Kept in --out beside the calibrators")
    c.set_defaults(func=cmd_calibrate)
