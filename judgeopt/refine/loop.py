"""Closing the loop in simulation (DAgger-style data aggregation for the judge).

A planner that maximises a learned judge finds the plans the judge is most wrong about, and
those are exactly the plans the demonstrations never showed it. Each round here plans for
fresh environments with the current judge (and generator), replays every plan in the
simulator, adds the labelled outcomes to the training data and fine-tunes the judge (and,
if asked, the generator) on the aggregate. The success rate of round k's plans is the
honest measure of the models of round k - 1: they never saw those environments.

Layout of OUT (every file written atomically; a rerun resumes where it stopped):

    round_1/partial/*.json   planned-and-simulated chunks of round 1 (resume unit)
    round_1/outcomes.h5      round 1's plans as demonstrations (commands, responses, labels)
    round_1/judge.{pt,json}  the judge fine-tuned after round 1
    round_1/generator.*      the generator fine-tuned against it (when generator_epochs > 0)
    round_1/summary.json     round 1 finished (its figures)
    round_1/plans/           with a robot instead of the simulator (--plans-only, then --outcomes
                             DIR): round 1's plans for execution and their manifest
                             (judgeopt.refine.robot); outcomes.h5 then holds the recordings
    refine.md / .csv / .png  success per round

Nothing under models/ is touched; `install` copies the last round's models there, on request.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

from judgeopt.evaluate.stored import chunk_files, read_chunk
from judgeopt.files import atomic_write, refuse_overwrite
from judgeopt.parallel import run_chunks
from judgeopt.planners.constraint_ranges import ConstraintRanges
from judgeopt.planners.limits import CONDITION_NAMES, LimitRanges
from judgeopt.planners.problem import Problem


def judge_only_planners() -> tuple[str, ...]:
    """The default planners that need no generator (the direct solve): a generator is only as good
    as the judge it was trained against, and refinement changes the judge every round."""
    from judgeopt.planners.base import REGISTRY

    return tuple(n for n, s in REGISTRY.items() if s.default and "generator" not in s.needs)


@dataclass(frozen=True)
class RefineConfig:
    rounds: int = 3
    n: int = 150  # environments per round
    methods: tuple[str, ...] = field(default_factory=judge_only_planners)
    seed: int = 0
    judge_epochs: int = 8  # fine-tuning epochs per round (from the previous round's judge)
    judge_lr: float = 1e-3
    weight: int = 3  # copies of the planners' outcomes in the training set: they are few, and they matter
    generator_epochs: int = 0  # > 0: fine-tune the generator against each new judge
    chunk: int = 5
    # sample q̇_max, f_min, f_max per environment from these ranges (None: the problem's own
    # limits), so the judge sees outcomes of plans made under many limits, failures included;
    # the generator is then fine-tuned as a conditioned one over the same ranges
    limit_ranges: LimitRanges | None = None
    # draw a [constraints] set (a_max, jerk_max, fdot_max, an early force cap) per environment
    # from these ranges (None: the problem's own constraints), each feasible for its environment
    # (at its sampled limits), so the judge sees outcomes of plans made under constraints too
    constraint_ranges: ConstraintRanges | None = None

    def __post_init__(self) -> None:
        from judgeopt.planners.problem import ProblemError

        if self.rounds < 1 or self.n < 1 or self.judge_epochs < 1 or self.weight < 1 or self.chunk < 1:
            raise ProblemError(f"rounds, n, judge_epochs, weight and chunk must be at least 1: {self}")
        if self.limit_ranges is not None and not isinstance(self.limit_ranges, LimitRanges):
            object.__setattr__(self, "limit_ranges", LimitRanges.from_dict(self.limit_ranges))
        if self.constraint_ranges is not None and not isinstance(self.constraint_ranges, ConstraintRanges):
            object.__setattr__(self, "constraint_ranges", ConstraintRanges.from_dict(self.constraint_ranges))
        from judgeopt.planners.base import planner_names, spec_of

        closed = [m for m in self.methods if spec_of(m).closed_loop]
        if closed:
            raise ProblemError(f"{', '.join(closed)} plans while executing; refinement replays finished plans: choose "
                               f"from {', '.join(planner_names(open_loop=True))}")
        needy = [m for m in self.methods if "generator" in spec_of(m).needs]
        if needy and self.generator_epochs < 1:
            raise ProblemError(f"planning with {', '.join(needy)} in refinement needs generator_epochs > 0 "
                               "(a generator is only as good as the judge it was trained against)")


def _solved(problem: Problem, methods: tuple[str, ...], judge: str, generator: str | None, envs: np.ndarray,
            limits: np.ndarray | None, constraints: list[dict[str, Any]] | None = None
            ) -> Iterator[tuple[int, dict[str, float], dict[str, float], dict[str, Any], Any]]:
    """(i, environment, limits, constraints, PlanResult) for each planned environment and method;
    `limits`: (n, 3) q̇_max, f_min, f_max per environment (None: the problem's); `constraints`:
    a [constraints] override set per environment (None: the problem's)."""
    import torch

    from judgeopt.evaluate.batch import planners as load_planners

    torch.set_num_threads(1)
    planners = load_planners(problem, methods, judge, generator=generator)
    for i, e in enumerate(envs):
        env = dict(zip(problem.env_names, map(float, e)))
        lim = {} if limits is None else dict(zip(CONDITION_NAMES, map(float, limits[i])))
        con = {} if constraints is None else _as_overrides(constraints[i])
        over = {**lim, **con}
        for r in (planners.with_limits(**over) if over else planners).solve(env):
            if r.plan is not None:  # None: limits infeasible for this environment, nothing to run
                yield i, env, lim, con, r


def _as_overrides(constraints: dict[str, Any]) -> dict[str, Any]:
    """A constraint set as problem overrides (bounds a tuple: JSON gives a list)."""
    return {k: tuple(v) if k == "bounds" else v for k, v in constraints.items()}


def _plan_chunk(problem: Problem, methods: tuple[str, ...], judge: str, generator: str | None,
                envs: np.ndarray, first: int, limits: np.ndarray | None = None,
                constraints: list[dict[str, Any]] | None = None) -> list[dict[str, Any]]:
    """Plan, replay, and keep what the dataset needs: the command, the measured response, the
    label."""
    from judgeopt.evaluate.batch import simulator

    sim = simulator(problem.task, problem.robot)
    rows = []
    for i, env, lim, con, r in _solved(problem, methods, judge, generator, envs, limits, constraints):
        out = sim.simulate(r.plan, problem.world_env(env))
        rows.append({"env_index": first + i, "method": r.method, "env": [env[k] for k in problem.env_names],
                     "limits": lim, **({"constraints": con} if con else {}), "command": r.plan.as_array().tolist(), "response": out.response.tolist(),
                     "success": bool(out.success), "predicted": r.predicted_success,
                     "violation": r.max_constraint_violation})
    return rows


def _record_chunk(problem: Problem, methods: tuple[str, ...], judge: str, generator: str | None, envs: np.ndarray,
                  first: int, limits: np.ndarray | None, provenance: dict[str, Any],
                  constraints: list[dict[str, Any]] | None = None) -> list[dict[str, Any]]:
    """Plan without replaying: each plan's JSON record (under its own limits and constraints), for a robot."""
    from judgeopt.formats.plan import plan_record

    return [{"env_index": first + i, "method": r.method, "limits": lim, **({"constraints": con} if con else {}),
             "record": plan_record(r, problem.with_overrides(**lim, **con), provenance)}
            for i, env, lim, con, r in _solved(problem, methods, judge, generator, envs, limits, constraints)]


def _round_envs(problem: Problem, seed: int, k: int, n: int) -> np.ndarray:
    return problem.sample_env(np.random.default_rng([seed, 7919, k]), n)


def _round_limits(cfg: RefineConfig, k: int) -> np.ndarray | None:
    """Round k's limits per environment (their own stream: the environments stay those of a
    refinement without limit sampling)."""
    if cfg.limit_ranges is None:
        return None
    return cfg.limit_ranges.sample(np.random.default_rng([cfg.seed, 7927, k]), cfg.n)


def round_constraints(problem: Problem, cfg: RefineConfig, k: int, envs: np.ndarray | None = None,
                      limits: np.ndarray | None = None) -> list[dict[str, Any]] | None:
    """Round k's constraint set per environment (None without cfg.constraint_ranges): drawn in
    environment order from a stream of their own (the environments and limits stay those of a
    refinement without constraint sampling), each feasible for its environment at its limits
    (judgeopt.planners.constraint_ranges.draw_constraints)."""
    from judgeopt.planners.constraint_ranges import draw_constraints

    if cfg.constraint_ranges is None:
        return None
    envs = _round_envs(problem, cfg.seed, k, cfg.n) if envs is None else envs
    limits = _round_limits(cfg, k) if limits is None else limits
    rng = np.random.default_rng([cfg.seed, 7933, k])
    out = []
    for i, e in enumerate(envs):
        at = problem if limits is None else problem.with_overrides(**dict(zip(CONDITION_NAMES, map(float, limits[i]))))
        out.append(draw_constraints(rng, at, cfg.constraint_ranges, [dict(zip(problem.env_names, map(float, e)))]))
    return out


def _plan_round(problem: Problem, cfg: RefineConfig, k: int, judge: str, generator: str | None, folder: Path,
                n_jobs: int, scheduler: str | None, progress: bool) -> list[dict]:
    envs = _round_envs(problem, cfg.seed, k, cfg.n)
    limits = _round_limits(cfg, k)
    constraints = round_constraints(problem, cfg, k, envs, limits)
    partial = folder / "partial"
    done, todo = [], []
    for first in range(0, cfg.n, cfg.chunk):
        path = partial / f"{first:05d}.json"
        if path.exists():
            done += read_chunk(path)
        else:
            todo.append((path, first))
    work = [(path, _plan_chunk, (problem, cfg.methods, judge, generator, envs[f:f + cfg.chunk], f,
                                 None if limits is None else limits[f:f + cfg.chunk],
                                 None if constraints is None else constraints[f:f + cfg.chunk])) for path, f in todo]
    new = run_chunks(work, lambda path, rows: atomic_write(path, json.dumps(rows)), n_jobs=n_jobs,
                     scheduler=scheduler, progress=progress, desc=f"round {k}: plan and replay")
    done += [r for rows in new.values() for r in rows]
    return sorted(done, key=lambda r: (r["env_index"], r["method"]))


def _write_round(problem: Problem, cfg: RefineConfig, k: int, judge: str, generator: str | None, folder: Path,
                 n_jobs: int, scheduler: str | None, progress: bool) -> Path:
    """Round k's plans for a robot (judgeopt.refine.robot): the same environments and limits the
    simulator path would plan for, planned by the same models, written instead of replayed."""
    from judgeopt.formats.plan import plan_provenance
    from judgeopt.refine.robot import write_plans

    envs, limits = _round_envs(problem, cfg.seed, k, cfg.n), _round_limits(cfg, k)
    constraints = round_constraints(problem, cfg, k, envs, limits)
    from judgeopt.files import sha256_file
    from judgeopt.judge.store import model_paths

    prov = plan_provenance(judge, sha256_file(model_paths(judge)[0]), generator, f"judgeopt refine round {k}")
    work = [(f, _record_chunk, (problem, cfg.methods, judge, generator, envs[f:f + cfg.chunk], f,
                                None if limits is None else limits[f:f + cfg.chunk], prov,
                                None if constraints is None else constraints[f:f + cfg.chunk]))
            for f in range(0, cfg.n, cfg.chunk)]
    done = run_chunks(work, lambda key, rows: None, n_jobs=n_jobs, scheduler=scheduler, progress=progress,
                      desc=f"round {k}: plan for the robot")
    rows = sorted((r for rows in done.values() for r in rows), key=lambda r: (r["env_index"], r["method"]))
    return write_plans(folder / "plans", rows, k, problem, {"judge": judge, "generator": generator})


def _outcomes(rows: list[dict], problem: Problem, k: int, where: str = "in simulation"):
    from judgeopt.data.dataset import Dataset

    return Dataset(np.array([r["command"] for r in rows]), np.array([r["response"] for r in rows]),
                   np.array([int(r["success"]) for r in rows]), np.array([r["env"] for r in rows]), problem.dt,
                   problem.env_names, np.array([r["env_index"] for r in rows]),
                   meta={"source": f"judgeopt refine round {k}: planners' outcomes {where}"}, task=problem.task,
                   channels=problem.channels, units={c.name: c.unit for c in problem.channel_spec})


def _pairs_of(ranges: LimitRanges | None) -> dict[str, tuple[float, float]]:
    return {} if ranges is None else {k: getattr(ranges, k) for k in CONDITION_NAMES}


def _round_figures(rows: list[dict], k: int) -> list[dict]:
    """Per method: success, prediction, and how the verdict (p >= LIKELY) did on the outcomes."""
    from judgeopt.verdict.rules import LIKELY

    out = []
    for m in sorted({r["method"] for r in rows}):
        rs = [r for r in rows if r["method"] == m]
        sim = np.mean([r["success"] for r in rs])
        pred = np.mean([r["predicted"] for r in rs])
        out.append({"round": k, "method": m, "n": len(rs), "successes": int(sum(r["success"] for r in rs)),
                    "success_pct": 100 * float(sim), "predicted_mean": float(pred),
                    "calibration_gap_pct": 100 * float(pred - sim),
                    "violation_max": float(max(r["violation"] for r in rs)),
                    "failures_called_unlikely": sum(not r["success"] and r["predicted"] < LIKELY for r in rs),
                    "successes_called_unlikely": sum(r["success"] and r["predicted"] < LIKELY for r in rs)})
    return out


def refine(problem: Problem, train_data: str | Path, judge: str | Path, generator: str | Path | None,
           out: str | Path, cfg: RefineConfig, test_data: str | Path | None = None, n_jobs: int = -1,
           scheduler: str | None = None, progress: bool = True, plans_only: bool = False,
           outcomes: str | Path | None = None, on_error: Callable[[str], None] | None = None) -> list[dict]:
    """Run (or resume) the rounds; returns one figure row per round and method.

    With a robot instead of the simulator (judgeopt.refine.robot): `plans_only` writes the first
    unfinished round's plans to OUT/round_k/plans/ and stops there; `outcomes` (a folder of the
    labelled executions of those plans) finishes that round with them instead of replaying, then
    writes the next round's plans and stops. `on_error` hears of each recording left out."""
    from judgeopt.planners.problem import ProblemError
    from judgeopt.refine.robot import MANIFEST, read_outcomes

    from judgeopt.data.dataset import concatenate, load, save
    from judgeopt.judge.data_ranges import env_ranges_in, env_ranges_of, limit_ranges_in, union
    from judgeopt.judge.evaluate import evaluate_judge
    from judgeopt.files import sha256_file
    from judgeopt.judge.store import load_judge, save_judge
    from judgeopt.judge.train import TrainConfig, train_judge

    out = Path(out)
    base = load(train_data)
    test = load(test_data) if test_data else None
    judge, generator = str(judge), (str(generator) if generator else None)
    figures: list[dict] = []
    aggregated = []
    for k in range(1, cfg.rounds + 1):
        folder = out / f"round_{k}"
        summary_path = folder / "summary.json"
        if summary_path.exists():  # finished earlier: reuse its models and data
            summary = json.loads(summary_path.read_text())
            aggregated.append(load(folder / "outcomes.h5"))
            rows = [r for f in chunk_files(folder) for r in read_chunk(f)]
            now = {f["method"]: f for f in _round_figures(rows, k)} if rows else {}  # columns added since
            figures += [{**now.get(f["method"], {}), **f} for f in summary["figures"]]
            # a generator given now joins rounds that ran without one (e.g. more rounds, with --methods amortized)
            judge, generator = summary["judge"], summary["generator"] or generator
            continue
        manifest = folder / "plans" / MANIFEST
        skipped: list[str] = []
        if plans_only or outcomes is not None:  # a robot runs the plans
            if not manifest.exists():
                if outcomes is not None:
                    raise ProblemError(f"{outcomes}: round {k} has no plans written to execute ({manifest} is "
                                       "missing): write them with --plans-only first")
                _write_round(problem, cfg, k, judge, generator, folder, n_jobs, scheduler, progress)
                return figures
            if outcomes is None:  # written earlier, not executed yet
                return figures
            rows, skipped = read_outcomes(manifest, outcomes, problem)
            for e in skipped:
                (on_error or (lambda m: None))(e)
            outcomes, plans_only = None, True  # these recordings are this round's; the next one's plans wait
            done = _outcomes(rows, problem, k, "executed on the robot")
        else:
            if manifest.exists():
                raise ProblemError(f"{out}: round {k}'s plans were written for a robot ({manifest}): finish the round "
                                   "with --outcomes DIR, or refine into another --out")
            rows = _plan_round(problem, cfg, k, judge, generator, folder, n_jobs, scheduler, progress)
            done = _outcomes(rows, problem, k)
        save(done, folder / "outcomes.h5")
        aggregated.append(done)
        figs = _round_figures(rows, k)
        # fine-tune the judge on the demonstrations plus every round's outcomes so far
        data = concatenate([base] + [a for a in aggregated for _ in range(cfg.weight)])
        init, init_meta = load_judge(judge)
        # one torch thread: the planning workers may still hold the other cores, and two threads
        # fighting over one core made an epoch 8x slower here
        tc = TrainConfig(epochs=cfg.judge_epochs, lr=cfg.judge_lr, seed=cfg.seed + k, threads=1, progress=progress)
        model, result = train_judge(data, test, tc=tc, init=init)
        new_judge = folder / "judge"
        limits = union(limit_ranges_in(init_meta), _pairs_of(cfg.limit_ranges))
        metrics = {"val_accuracy": result.best["val_accuracy"], "best_epoch": result.best_epoch}
        if test is not None:
            metrics["test_accuracy"] = evaluate_judge(model, test)["accuracy"]
        save_judge(model, new_judge, {"source": f"judgeopt refine round {k}", "fine_tuned_from": judge,
                                      "refine_config": asdict(cfg), "metrics": metrics,
                                      "train_data": {"path": str(train_data), "sha256": sha256_file(train_data),
                                                     "planner_outcomes": int(sum(a.n for a in aggregated)),
                                                     "weight": cfg.weight,
                                                     # the demonstrations' and every round's environments (and
                                                     # limits) so far, and those of the judge it continues
                                                     "env_ranges": union(env_ranges_of(data), env_ranges_in(init_meta)),
                                                     **({"limit_ranges": limits} if limits else {}),
                                                     # the [constraints] sets were drawn from (per environment)
                                                     **({"constraint_ranges": cfg.constraint_ranges.to_dict()}
                                                        if cfg.constraint_ranges is not None else {})}})
        judge = str(new_judge)
        if cfg.generator_epochs > 0:
            generator = str(_fine_tune_generator(problem, judge, generator, folder / "generator", cfg, k, progress))
        for f in figs:
            f.update({f"judge_after_{m}": v for m, v in metrics.items()})
        summary = {"round": k, "figures": figs, "judge": judge, "generator": generator,
                   **({"outcomes_left_out": skipped} if skipped else {})}
        atomic_write(summary_path, json.dumps(summary, indent=2).encode())
        figures += figs
    return figures


def _fine_tune_generator(problem: Problem, judge: str, generator: str | None, out: Path, cfg: RefineConfig,
                         k: int, progress: bool) -> Path:
    from judgeopt.judge.store import load_judge
    from judgeopt.planners.generator_train import GeneratorTrainConfig, train_config_dict, train_generator
    from judgeopt.planners.store import load_generator, save_generator

    jmodel, jmeta = load_judge(judge)
    init = load_generator(generator)[0] if generator else None
    tc = GeneratorTrainConfig(epochs=cfg.generator_epochs, seed=cfg.seed + k, progress=progress)
    gen, _ = train_generator(problem, jmodel, tc=tc, init=init, conditioned=cfg.limit_ranges)
    save_generator(gen, out, {"source": f"judgeopt refine round {k}", "fine_tuned_from": generator,
                              "train_config": train_config_dict(tc), "problem": problem.to_dict(),
                              "judge": {"path": judge, "weights_sha256": jmeta["weights_sha256"]}})
    return out


def install(out: str | Path, name: str, models_dir: str | Path = "models", last: int | None = None,
            overwrite: bool = False) -> list[Path]:
    """Copy the last finished round's (or round `last`'s) judge and generator into models/ as
    judge_NAME and generator_NAME (NAME may name a subfolder: scrape/refined is
    models/scrape/judge_refined): the only way refinement changes shipped models, and an
    installed model is replaced only with `overwrite`."""
    rounds = sorted(Path(out).glob("round_*/summary.json"), key=lambda p: int(p.parent.name.split("_")[1]))
    rounds = [r for r in rounds if last is None or int(r.parent.name.split("_")[1]) <= last]
    if not rounds:
        from judgeopt.planners.problem import ProblemError

        raise ProblemError(f"{out}: no finished refinement round to install (run judgeopt refine first)")
    summary = json.loads(rounds[-1].read_text())
    copied = []
    for kind, src in (("judge", summary["judge"]), ("generator", summary["generator"])):
        if not src or Path(src).parent != rounds[-1].parent:  # only what refinement made (not a starting model)
            continue
        stem = Path(models_dir) / Path(name).parent / f"{kind}_{Path(name).name}"
        pt, js = stem.with_suffix(".pt"), stem.with_suffix(".json")
        refuse_overwrite([pt, js], overwrite, flag="--install NAME")
        meta = json.loads(Path(src + ".json").read_text())
        meta.update(weights_file=pt.name, installed_from=src)
        atomic_write(pt, Path(src + ".pt").read_bytes())
        atomic_write(js, (json.dumps(meta, indent=2) + "\n").encode())
        copied += [pt, js]
    return copied
