"""`judgeopt refine`: plan, replay, aggregate the outcomes, fine-tune the judge; per round."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from judgeopt.cli.commands import HELP

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def cmd_refine(args: argparse.Namespace) -> int:
    from judgeopt.files import atomic_write, check_writable, save_figure
    from judgeopt.formats.table_csv import write_records
    from judgeopt.cli.planners import limit_ranges_from_args, problem_from_args
    from judgeopt.planners.limits import wide_limits
    from judgeopt.files import resolve
    from judgeopt.refine.loop import RefineConfig, install, refine

    check_writable([args.out])  # before the first round, not at its end
    if args.install:
        check_writable([resolve("models") / args.install], "--install NAME")
    problem = problem_from_args(args)
    ranges = limit_ranges_from_args(args, wide_limits(problem.task)) if args.sample_limits else None
    if ranges is not None:
        ranges.check(problem)
    chosen = {"methods": tuple(args.methods)} if args.methods else {}  # default: RefineConfig's
    if args.sample_constraints:
        from judgeopt.planners.constraint_ranges import ConstraintRanges

        chosen["constraint_ranges"] = ConstraintRanges()
    cfg = RefineConfig(rounds=args.rounds, n=args.n, **chosen, seed=args.seed,
                       judge_epochs=args.judge_epochs, weight=args.weight, generator_epochs=args.generator_epochs,
                       chunk=args.chunk, limit_ranges=ranges)
    out = Path(args.out)
    generator = resolve(args.generator, (".json",)) if args.generator else None
    if generator is not None:  # a bad one is one line before the first round starts
        from judgeopt.planners.store import load_generator_meta

        load_generator_meta(generator)
    figures = refine(problem, resolve(args.train), resolve(problem.judge, (".json",)), generator,
                     out, cfg, test_data=resolve(args.test) if args.test else None, n_jobs=args.jobs,
                     scheduler=args.scheduler, progress=not args.quiet, plans_only=args.plans_only,
                     outcomes=args.outcomes, on_error=lambda e: print(f"judgeopt refine: left out: {e}", file=sys.stderr))
    if args.plans_only or args.outcomes:
        from judgeopt.refine.robot import pending

        waiting = pending(out)
        if waiting is not None:
            print(f"round {waiting.parent.parent.name.split('_')[1]}: plans to execute listed in {waiting}; record "
                  "each as DIR/<id>.csv (the importer's columns and label), then run this command again with "
                  "--outcomes DIR")
        if not figures:
            return 0
    md = markdown(figures)
    atomic_write(out / "refine.md", md.encode())
    write_records(out / "refine.csv", figures, fieldnames=sorted({k for f in figures for k in f}))
    save_figure(plot(figures), out / "refine.png")
    print(md)
    print(f"wrote {out / 'refine.md'}, {out / 'refine.csv'}, {out / 'refine.png'}")
    if args.install:
        for p in install(out, args.install, resolve("models"), last=args.rounds, overwrite=args.overwrite):
            print(f"installed {p}")
    return 0


def markdown(figures: list[dict]) -> str:
    lines = ["| round | planner | simulated success | mean predicted | predicted - simulated | failures called "
             "unlikely | successes called unlikely | worst violation | judge after: val acc | test acc |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for f in figures:
        test = f.get("judge_after_test_accuracy")
        failures = f["n"] - f["successes"]
        caught, alarms = f.get("failures_called_unlikely"), f.get("successes_called_unlikely")
        caught = "-" if caught is None else f"{caught}/{failures}"
        alarms = "-" if alarms is None else f"{alarms}/{f['successes']}"
        lines.append(f"| {f['round']} | {f['method']} | {f['successes']}/{f['n']} ({f['success_pct']:.0f} %) "
                     f"| {f['predicted_mean']:.3f} | {f['calibration_gap_pct']:+.0f} pts | {caught} | {alarms} "
                     f"| {f['violation_max']:.1e} "
                     f"| {f['judge_after_val_accuracy']:.3f} | {'-' if test is None else f'{test:.3f}'} |")
    return ("Round k's plans are made with the models of round k - 1 (round 1: the starting models) on "
            "environments none of them has seen.\n\n" + "\n".join(lines) + "\n")


def plot(figures: list[dict]) -> Figure:
    """Simulated and predicted success per round and planner: does refining close the gap?"""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5, 3.5))
    ax = fig.subplots()
    for m in sorted({f["method"] for f in figures}):
        fs = [f for f in figures if f["method"] == m]
        ax.plot([f["round"] for f in fs], [f["success_pct"] for f in fs], marker="o", label=f"{m}: simulated")
        ax.plot([f["round"] for f in fs], [100 * f["predicted_mean"] for f in fs], ls="--", marker="x",
                label=f"{m}: predicted")
    ax.set_xlabel("round (plans by the models of the round before)")
    ax.set_ylabel("success [%]")
    ax.set_ylim(0, 102)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def add_refine_commands(sub: argparse._SubParsersAction) -> None:
    from judgeopt.cli.common import OVERWRITE, QUIET, jobs_option, out_option, positive, seed_option, threads_option
    from judgeopt.cli.planners import add_limit_range_arguments, add_problem_arguments

    r = sub.add_parser("refine", help=HELP["refine"],
                       description="Each round plans for --n fresh environments with the current judge, replays "
                       "every plan in PyBullet, adds the labelled outcomes to the training data and fine-tunes the "
                       "judge (and with --generator-epochs the generator). Parallel like collection; a rerun "
                       "resumes. Models go to --out; models/ changes only with --install NAME.",
                       parents=[out_option("DIR", "folder for every round's plans, outcomes and models (a rerun "
                                           "resumes it)", default="out/refine"), OVERWRITE, seed_option(), jobs_option(), threads_option(), QUIET])
    add_problem_arguments(r)
    r.add_argument("--rounds", type=positive, default=3, help="rounds of plan, replay, fine-tune")
    r.add_argument("--n", type=int, default=150, help="environments per round")
    from judgeopt.cli.common import PlannerChoices, add_plugin_option
    from judgeopt.refine.loop import judge_only_planners

    r.add_argument("--methods", nargs="+", choices=PlannerChoices(open_loop=True),
                   help="planners whose plans are replayed and added (default: "
                   f"{' and '.join(judge_only_planners())}, the default ones that need no generator)")
    add_plugin_option(r)
    r.add_argument("--train", default="data/train.h5", metavar="FILE", help="the demonstrations the judge was trained on")
    r.add_argument("--test", default="data/test.h5", metavar="FILE", help="held-out demonstrations to score each new judge")
    r.add_argument("--generator", metavar="STEM", help="generator to warm-start the direct solve and to fine-tune")
    r.add_argument("--judge-epochs", type=positive, default=8, help="fine-tuning epochs of the judge per round")
    r.add_argument("--weight", type=int, default=3, help="copies of the planners' outcomes in the training set")
    r.add_argument("--generator-epochs", type=int, default=0, help="fine-tuning steps of the generator per round")
    r.add_argument("--chunk", type=positive, default=5, help="environments per work unit (and per resume step)")
    r.add_argument("--install", metavar="NAME", help="copy round --rounds' models to models/judge_NAME (and "
                   "generator_NAME; NAME may name a subfolder: scrape/refined is models/scrape/judge_refined); an "
                   "installed model is replaced only with --overwrite")
    robot = r.add_argument_group("with a robot", "run the rounds on a robot instead of the simulator "
                                 "(docs/remedies.md): the same environments, limits, models and training")
    robot.add_argument("--plans-only", action="store_true", help="write the next round's plans for execution "
                       "(OUT/round_K/plans/: plan JSON and 1 kHz CSV per plan id, manifest.json with environment and "
                       "limits) and stop instead of replaying them")
    robot.add_argument("--outcomes", metavar="DIR", help="the labelled executions of the written round's plans "
                       "(DIR/<id>.csv in the importer's format with label): finish that round with them, then "
                       "write the next round's plans")
    g = r.add_argument_group("limit sampling", "plan each environment under its own q̇_max, f_min, f_max drawn "
                             "from ranges (uniform), so the judge learns which limits make the task impossible; "
                             "the generator (with --generator-epochs) becomes a conditioned one over these ranges")
    g.add_argument("--sample-limits", action="store_true", help="sample the limits per environment")
    add_limit_range_arguments(g)
    c = r.add_argument_group("constraint sampling", "plan each environment under its own [constraints] set: "
                             "a_max, jerk_max, fdot_max and an early force cap F:0:HI@0:T1, drawn uniformly from "
                             "judgeopt.planners.constraint_ranges.ConstraintRanges (the ranges `judgeopt evaluate "
                             "sweep --random-constraints` draws held-out sets from) and feasible for that environment, "
                             "so the judge learns from plans made under constraints it was never trained on")
    c.add_argument("--sample-constraints", action="store_true", help="sample a constraint set per environment "
                   "(with --sample-limits: feasible at that environment's sampled limits)")
    r.set_defaults(func=cmd_refine)
