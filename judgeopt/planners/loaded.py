"""One problem, its judge and its planners, loaded once and used for many environments.

`Planners.load` reads the registry (judgeopt.planners.base): it loads the judge, and the generator
for these limits where a planner's outcomes depend on one (found once, shared), then builds each
planner asked for, with the planners it is built on and the one that warm-starts it, each by its
entry. `Planners.solve(env)` runs them in registry order: the amortised generator, the direct
solve warm-started from the generator's plan (or from the documented min-jerk guess when no
generator fits the limits), the CEM sampling baseline if asked, any registered planner, and
optionally replays each plan in the simulator. The CLI, the benchmarks and the evaluation all go
through here, so they measure the same thing.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from judgeopt.files import resolve
from judgeopt.judge.compiled import CompiledJudge
from judgeopt.planners.base import (WARM_STARTS, BuildContext, Planner, default_planners, planner_names, spec_of,
                                    to_build, unknown, with_uses)
from judgeopt.planners.problem import LIMIT_NAMES, Problem, ProblemError, ProblemFileError
from judgeopt.planners.result import PlanResult, infeasible_result
from judgeopt.verdict.rules import assess
from judgeopt.robots import DEFAULT_ROBOT
from judgeopt.trajectory import PlanError
from judgeopt.verdict.risk import RISK, annotate as annotate_risk

if TYPE_CHECKING:
    from judgeopt.judge.model import Judge

#: the planners a fast start serves (fast_models): they only call the judge (no batched torch
#: forward passes) and take the generator's numpy rollout
FAST_PLANNERS = frozenset({"amortized", "direct", "held"})

@dataclass(frozen=True)
class ChosenModels:
    """The model files a problem's planners use and their weights hashes; cheap to find (no
    weights are read), so a cached result can be checked against the models there are now."""
    problem: Problem
    judge: Path
    generator: Path | None
    shas: dict[str, str]

    def settings(self, methods: Sequence[str], over_limits: bool = False,
                 over_constraints: bool = False) -> dict[str, str]:
        """method -> calibration.setting_id over the models its entry names (over_limits: the id
        of the settings that differ from it only in their limits; over_constraints: in their limits
        and constraint sets)."""
        from judgeopt.planners.base import setting_id

        return {m: setting_id(m, self.problem, {k: v for k, v in self.shas.items() if k in spec_of(m).models},
                              over_limits, over_constraints) for m in methods}

    def description(self, method: str) -> str:
        """The setting in words: the planner, the models it depends on, the limits."""
        p, models = self.problem, spec_of(method).models
        extra = (f", generator {self.generator.name}" if "generator" in models and self.generator else "") + (
            f", ensemble {p.ensemble} - {p.pessimism:g} std" if "ensemble" in models and p.ensemble else "") + (
            f", trust region {p.trust_region:g}" if "trust_model" in models and p.trust_region is not None else "")
        return f"{method}{on_arm(p.robot)}, judge {self.judge.name}{extra}; q̇_max {p.qdot_max:g}, f in [{p.f_min:g}, {p.f_max:g}]"


def on_arm(robot: str | None) -> str:
    """A setting's description names an arm other than the default (the default's read as before arms)."""
    return f" on {robot}" if robot and robot != DEFAULT_ROBOT else ""


def choose_models(problem: Problem, methods: Sequence[str], judge: str | Path | None = None,
                  generator: str | Path | None = None, models_dir: str | Path = "models") -> ChosenModels:
    """The judge (given or the problem's) and the other models these planners' outcomes depend
    on (PlannerSpec.models): the generator (given, or the best match in models_dir for these limits
    and this judge), the problem's ensemble and trust model."""
    from judgeopt.files import sha256_file
    from judgeopt.judge.store import load_meta
    from judgeopt.planners.store import find_generator, load_generator_meta

    wanted = {k for m in methods for k in spec_of(m).models}
    jpath = resolve(judge or problem.judge, (".json",))
    shas = {"judge": load_meta(jpath)["weights_sha256"]}
    gpath = None
    if "generator" in wanted:
        gpath = resolve(generator, (".json",)) if generator else find_generator(resolve(models_dir), problem,
                                                                                  shas["judge"])
        if gpath is not None:
            shas["generator"] = load_generator_meta(gpath)["weights_sha256"]
    if "ensemble" in wanted and problem.ensemble:
        manifest = resolve(problem.ensemble) / "ensemble.json"
        if not manifest.is_file():
            raise ProblemFileError(f"ensemble {problem.ensemble}: not a judge ensemble (a folder with ensemble.json); "
                                   "make one with `judgeopt train-ensemble --out DIR` or leave [models] ensemble out")
        shas["ensemble"] = sha256_file(manifest)
    if "trust_model" in wanted and problem.trust_region is not None:
        trust = resolve(problem.trust_model, (".json",)).with_suffix(".json")
        if not trust.is_file():
            raise ProblemFileError(f"trust model {problem.trust_model}: no such trust-region model; fit one with "
                                   "`judgeopt fit-trust-region` or leave [solver] trust_region out")
        shas["trust_model"] = sha256_file(trust)
    return ChosenModels(problem, jpath, gpath, shas)


def without_generator() -> str:
    """The default planners that need no generator, as the options that ask for them."""
    return " or ".join(f"--method {m}" for m in default_planners() if "generator" not in spec_of(m).needs)


#: (cache folder, judge file, weights sha256, backend, threads) -> its CasadiJudge, loaded once per process
_RECALLED_HERE: dict[tuple, Any] = {}


def fast_models(chosen: ChosenModels, methods: Sequence[str], casadi_backend: str | None = None
                ) -> tuple[CompiledJudge, dict] | None:
    """The judge of a fast start (judge.compiled), as (judge, its metadata): its built library, read
    without torch's Python package where a run has left the library's record, else built with torch,
    which leaves it (the generator as numpy arrays: Planners._generator, by the same rule). Either way the planners get the same models, so the first run
    and the next ones answer alike (the amortised plan's judge p included), and one process answers a
    request the same way before and after another request made it import torch.
    None where the process has not enabled it (judge.compiled.enable_fast_start: solve and the
    service's workers do), where a planner asked for is not in FAST_PLANNERS, for an ensemble, or where
    the judge's backend has no library to load (l4casadi missing, a build that fell back to the torch
    callback): the caller loads the torch models."""
    import importlib.util

    from judgeopt.files import cache_dir, sha256_file
    from judgeopt.formats.model_files import model_paths
    from judgeopt.judge.backends import DEFAULT_BACKEND, choose_backend
    from judgeopt.judge.compiled import RECALLED, TrajectoryFormat, fast_start_enabled, recall
    from judgeopt.judge.store import load_meta
    from judgeopt.threads import wanted_threads

    problem = chosen.problem
    if not fast_start_enabled() or not set(methods) <= FAST_PLANNERS or problem.ensemble \
            or importlib.util.find_spec("l4casadi") is None:
        return None
    jmeta = load_meta(chosen.judge)
    try:
        fmt = TrajectoryFormat.of(jmeta["config"])
    except ValueError:
        return None
    backend = choose_backend(casadi_backend or DEFAULT_BACKEND, problem.objective == "target", fmt)
    if backend not in RECALLED:
        return None
    cj = None
    key = (str(cache_dir()), str(Path(chosen.judge).resolve()), jmeta["weights_sha256"], backend, wanted_threads())
    try:
        if sha256_file(model_paths(chosen.judge)[0]) == jmeta["weights_sha256"]:  # else load_judge says what is wrong
            # the library loaded once per process: a service's worker loads planners for every new environment
            # or limits, and loading and warming it again cost each such request about 14 ms (its answers are the
            # same bit for bit from a fresh and a reused library)
            if key not in _RECALLED_HERE and (found := recall(cache_dir(), jmeta["weights_sha256"], backend,
                                                              wanted_threads())) is not None:
                _RECALLED_HERE[key] = found[0]
            cj = _RECALLED_HERE.get(key)
    except OSError:
        pass
    cj = cj if cj is not None else _build_library(chosen.judge, jmeta, casadi_backend, problem)
    return None if cj is None else (CompiledJudge(cj, fmt), jmeta)


def _torch_generator(path: Path) -> tuple[Any, dict]:
    """The generator at `path` read with torch (which leaves the weights' copy), as numpy arrays."""
    from judgeopt.planners.store import load_generator
    from judgeopt.threads import import_torch

    import_torch()
    gen, meta = load_generator(path)
    return gen.arrays(), meta


def _build_library(path: Path, jmeta: dict, casadi_backend: str | None, problem: Problem) -> Any:
    """The judge at `path` built (or found) as its library with torch, as the direct solve builds it,
    and its record left for the next run; None where the build fell back to a torch callback."""
    from judgeopt.judge.backends import DEFAULT_BACKEND
    from judgeopt.judge.casadi_fn import build_casadi_judge, remember_library
    from judgeopt.judge.compiled import RECALLED
    from judgeopt.judge.store import load_judge
    from judgeopt.threads import import_torch

    import_torch()  # on the threads the command line asked for
    judge, _ = load_judge(path)
    cj = build_casadi_judge(judge, backend=casadi_backend or DEFAULT_BACKEND, noise_tolerant=problem.objective == "target")
    if cj.backend not in RECALLED:
        return None
    remember_library(judge, jmeta, cj)
    return cj


@dataclass(frozen=True)
class ModelRequest:
    """What the user asked for: a judge and a generator (None: the problem's judge, the generator
    in `models_dir` that best covers the limits; one named is never swapped), and how the direct
    solve evaluates the judge (None: judge.casadi_fn's default)."""
    judge: str | Path | None = None
    generator: str | Path | None = None
    models_dir: str | Path = "models"
    casadi_backend: str | None = None


@dataclass
class Planners:
    """Every planner asked for, built once for one problem and judge, run for many environments."""

    problem: Problem
    judge: "Judge | CompiledJudge"  # CompiledJudge: a fast start (fast_models)
    judge_meta: dict
    chosen: ChosenModels
    request: ModelRequest
    methods: tuple[str, ...]  # the planners whose results `solve` returns, in registry order
    built: dict[str, Planner] = field(default_factory=dict)  # those and their helpers, in the order they run
    notes: list[str] = field(default_factory=list)
    settings: dict[str, str] = field(default_factory=dict)  # method -> calibration.setting_id
    families: dict[str, str] = field(default_factory=dict)  # method -> the same without the limits
    constrained_families: dict[str, str] = field(default_factory=dict)  # ... and the constraint set (if one is set)
    descriptions: dict[str, str] = field(default_factory=dict)
    calibrators: dict = field(default_factory=dict)  # method -> calibration.Calibrator
    calibration_file: dict = field(default_factory=dict)  # every calibrator in the problem's file
    evidence: dict = field(default_factory=dict)  # the file's held-out evidence (verdict.risk.evidence_key -> Evidence)
    plan_model: Any = None  # the file's plan model (verdict.plan_model.PlanModel), where it has one
    risk: float = RISK  # the failure rate a "likely" may carry (its upper confidence bound on the evidence)
    #: generator path -> (Generator or GeneratorArrays, meta), shared by with_limits copies
    generators: dict = field(default_factory=dict)
    for_sets: dict = field(default_factory=dict)  # (method, samples, case) -> its planner for environment sets

    @classmethod
    def load(cls, problem: Problem, methods: Sequence[str] | None = None, judge: str | Path | None = None,
             generator: str | Path | None = None, models_dir: str | Path = "models",
             casadi_backend: str | None = None) -> "Planners":
        """Load the judge and the generator, and build the planners in `methods` (default: the
        default ones) with those each is built on and the one that warm-starts it."""
        from judgeopt.judge.store import check_compatible, load_judge
        from judgeopt.planners.limits import coverage_notes

        methods = tuple(default_planners() if methods is None else methods)
        bad = unknown(methods)  # a plugin's planner imported where named
        if bad or not methods:
            raise ProblemError(f"unknown method(s) {bad}; choose from {list(planner_names())}")
        methods = with_uses(methods)
        chosen = choose_models(problem, to_build(methods), judge, generator, models_dir)
        fast = fast_models(chosen, to_build(methods), casadi_backend)
        if fast is not None:
            jmodel, jmeta = fast
        else:
            from judgeopt.threads import import_torch

            import_torch()  # on the threads the command line asked for
            jmodel, jmeta = load_judge(chosen.judge)
        check_compatible(jmeta, horizon=problem.steps, dt=problem.dt, channels=problem.channels, env_names=problem.env_names)
        out = cls(problem, jmodel, jmeta, chosen, ModelRequest(judge, generator, models_dir, casadi_backend),
                  tuple(m for m in planner_names() if m in methods), notes=coverage_notes(problem, jmeta))
        out._load_generator()
        out.built = out._build()
        out._settings()
        return out

    @property
    def judge_path(self) -> Path:
        return self.chosen.judge

    @property
    def generator_path(self) -> Path | None:
        return self.chosen.generator

    def __getitem__(self, method: str) -> Planner:
        """The planner called `method` (one asked for, or one it is built on or warm-started by)."""
        return self.built[method]

    def _load_generator(self) -> None:
        """The generator chosen, loaded once, with what the user should know about it; none where a
        planner asked for needs one is an error naming what to do."""
        from judgeopt.planners.store import matches

        gpath, models_dir = self.generator_path, self.request.models_dir
        if gpath is None:
            needy = [m for m in self.methods if "generator" in spec_of(m).needs]
            if needy:
                p = self.problem
                raise ProblemError(
                    f"no generator in {models_dir}/ was trained for these limits (q̇_max = {p.qdot_max}, "
                    f"f in [{p.f_min}, {p.f_max}], ...), or conditioned on ranges that contain them, "
                    f"and this judge; train one with `judgeopt train-generator --problem "
                    f"{p.source or 'PROBLEM'} [--conditioned] ... --out models/NAME`, "
                    f"pass one with --generator, or use {without_generator()}")
            return
        _, gmeta = self._generator(gpath)
        if not matches(gmeta, self.problem):
            self.notes.append(f"generator {gpath} was trained for other limits; its plan may violate these "
                              "(reported below)")
        if gmeta.get("judge", {}).get("weights_sha256") != self.judge_meta["weights_sha256"]:
            self.notes.append(f"generator {gpath} was trained against another judge")

    def _generator(self, gpath: Path) -> tuple[Any, dict]:
        """(generator, metadata) at `gpath`, loaded once. In a fast start (the judge a CompiledJudge)
        always its numpy arrays, from the cache or read with torch (which leaves them there), so a
        first run and the next plan alike, under the first limits or others; else the torch Generator."""
        from judgeopt.planners.store import load_generator, load_generator_arrays
        from judgeopt.threads import import_torch

        if gpath not in self.generators:
            if isinstance(self.judge, CompiledJudge):
                self.generators[gpath] = load_generator_arrays(gpath) or _torch_generator(gpath)
            else:
                import_torch()  # on the threads the command line asked for
                self.generators[gpath] = load_generator(gpath)
        return self.generators[gpath]

    def _build(self, previous: dict[str, Planner] | None = None) -> dict[str, Planner]:
        """Every planner to run, each after what it needs. One built before, for other limits, is
        carried over by its own with_limits where it can; one that needs a generator where none
        covers the limits is left out (one built before, only warm-starting others, stays)."""
        previous = previous or {}
        gpath = self.generator_path
        context = BuildContext(self.problem, self.judge, self.judge_meta,
                               self._generator(gpath)[0] if gpath is not None else None,
                               self.request.casadi_backend, self.notes)
        built: dict[str, Planner] = {}
        for m in to_build(self.methods):
            spec, old = spec_of(m), previous.get(m)
            if "generator" in spec.needs and context.generator is None:
                if old is not None and m not in self.methods:
                    built[m] = old  # under the old limits: its plan still warm-starts (the direct solve clips it)
                continue
            context.uses = {u: built[u] for u in spec.uses}
            renewed = old.with_limits(self.problem) if old is not None and not spec.uses else None
            built[m] = renewed or spec.make(context)
        return built

    def _settings(self) -> None:
        """Each method's setting (what its outcomes depend on) and its calibrator, if fitted."""
        from judgeopt.verdict.calibration import lookup, read_calibration_document
        from judgeopt.verdict.plan_model import plan_model_of

        self.settings = self.chosen.settings(self.methods)
        self.families = self.chosen.settings(self.methods, over_limits=True)
        # under a constraint set: also the family over every constraint set (a set alone is too few plans)
        self.constrained_families = (self.chosen.settings(self.methods, over_constraints=True)
                                     if self.problem.constraints.is_set() else {})
        self.descriptions = {m: self.chosen.description(m) for m in self.methods}
        if not self.calibration_file:
            path = resolve(self.problem.calibration) if self.problem.calibration else None
            if path is None:
                return
            if not path.exists():
                self.notes.append(f"calibration {self.problem.calibration}: no such file, so the probabilities are the "
                                  "judge's own, uncalibrated (fit one with `judgeopt calibrate`)")
                return
            # a setting without one reports the judge's probability (fit one with `judgeopt calibrate`)
            self.calibration_file, self.evidence, section = read_calibration_document(path)  # shared: never changed
            self.plan_model = plan_model_of(section, str(path))
        found = {m: lookup(self.calibration_file, self.settings[m], self.families[m], self.constrained_families.get(m))
                 for m in self.methods}
        self.calibrators = {m: c for m, c in found.items() if c is not None}

    def with_limits(self, **limits: Any) -> "Planners":
        """The same judge under other position, velocity or force limits: each planner carried
        over by its own with_limits where it can (the direct solve swaps its bounds, no rebuild),
        built again where it cannot. The generator is chosen as `load` chooses it (the one given,
        else one in models_dir that covers the new limits; each loaded once); where none covers
        them, the planners that need one drop out and the old generator's plan only warm-starts
        the direct solve. Each method's setting, and so its calibration, is new."""
        problem = self.problem.with_overrides(**limits)
        chosen = choose_models(problem, to_build(self.methods), self.judge_path, self.request.generator,
                               self.request.models_dir)
        out = dataclasses.replace(self, problem=problem, chosen=chosen, notes=list(self.notes), settings={},
                                  families={}, constrained_families={}, descriptions={}, calibrators={},
                                  for_sets={})
        if chosen.generator is None:
            out.methods = tuple(m for m in self.methods if "generator" not in spec_of(m).needs)
            if not out.methods:
                raise ProblemError(f"no generator in {self.request.models_dir}/ covers {limits}; plan with "
                                   f"{without_generator()}")
        out.built = out._build(self.built)
        out._settings()
        return out

    def in_environment(self, problem: Problem) -> "Planners":
        """The same planners for `problem`, which may differ from theirs in its environment alone
        (a new object position: no planner is built for one, each plans for the environment it is
        given, and setting ids and generators leave it out); a copy with notes of its own."""
        if problem is not self.problem and problem.without_environment() != self.problem.without_environment():
            raise ProblemError("in_environment: the problems differ in more than their environment; load the "
                               "planners for it (Planners.load) or change limits with with_limits")
        return dataclasses.replace(self, problem=problem, notes=list(self.notes))

    def only(self, method: str) -> "Planners":
        """The same planners reporting `method` alone (run with what it is built on and its warm start)."""
        methods = with_uses((method,))
        needed = to_build(methods)
        return dataclasses.replace(self, methods=tuple(m for m in self.methods if m in methods),
                                   built={m: p for m, p in self.built.items() if m in needed})

    def over_env_sets(self) -> list[str]:
        """The planners that plan one plan over a set of environments (the direct solve)."""
        return [m for m, p in self.built.items() if p.plans_env_sets]

    def warm_up(self, cold: bool = False) -> None:
        """What each planner's first solve would pay on its own, paid before any plan is timed."""
        for p in self.built.values():
            p.warm_up(cold=cold)

    def solve(self, env: dict[str, float], simulator=None, guess=None, warm_start: str = "generator",
              env_set: list[dict[str, float]] | None = None, case: str = "worst",
              world: dict[str, float] | None = None) -> list[PlanResult]:
        """Every requested method for one environment (infeasible limits: one result saying so).
        `guess`: the warm start of the planners that take one (the direct solve) instead of their
        warm-start planner's plan (the generator's); `warm_start` "none": they start cold (the
        direct solve from its min-jerk guess), as with a new task or limits no generator covers.
        `env_set` (session.env_grid): the planners that plan over sets (the direct solve) plan for
        all of them at once, in their worst `case` or on average; the others plan for `env`."""
        if warm_start not in WARM_STARTS:
            raise ProblemError(f"warm start {warm_start!r}: choose one of {', '.join(WARM_STARTS)}")
        env = self.problem.env_dict(env)
        infeasible = [infeasible_result(m, self.problem, env) for m in self.methods]
        if infeasible[0] is not None:
            return infeasible
        closed = [m for m in self.methods if spec_of(m).closed_loop]
        if closed and simulator is None:
            raise ProblemError(f"{', '.join(closed)} plans while its plan is executed in simulation: give a simulator "
                               "(drop --no-simulate)")
        starts = guess is None and warm_start != "none"  # the warm-start planners' plans are used
        plans: dict[str, object] = {}
        results: list[PlanResult] = []
        for m, planner in self.built.items():
            if m in closed or (m not in self.methods and not starts):
                continue
            source = spec_of(m).warm_start
            start = None if source is None else guess if guess is not None else plans.get(source) if starts else None
            if env_set is not None and len(env_set) > 1 and planner.plans_env_sets:
                key = (m, len(env_set), case)
                if key not in self.for_sets:  # built once per size and case
                    self.for_sets[key] = planner.for_env_set(len(env_set), case)
                r = answer(m, self.for_sets[key], self.for_sets[key].solve(env, guess=start, env_set=env_set))
            else:
                if m not in self.methods and (plan := planner.warm_start_plan(env, guess=start)) is not None:
                    plans[m] = plan  # it only warm-starts the others: no result to report
                    continue
                r = answer(m, planner, planner.solve(env, guess=start))
            plans[m] = r.plan
            if m in self.methods:
                results.append(self._annotate(r, env))
        if simulator is not None:
            # with the task's variables the planners do not read; `world`: where it differs from what was said
            world = {**self.problem.world_env(env), **(world or {})}
            for r in results:
                if r.plan is not None:
                    try:
                        out = simulator.simulate(r.plan, world)
                    except PlanError as exc:  # a plan the arm cannot be commanded to follow fails
                        r.simulated_success, r.info["sim_refused"] = False, str(exc)
                        continue
                    r.simulated_success, r.response = bool(out.success), np.asarray(out.response, dtype=float)
                    r.info.update({f"sim_{k}": v for k, v in out.details.items() if isinstance(v, (bool, int, float))})
            for m in closed:  # planning while executing, from the open-loop results
                planner = self.built[m]
                results.append(self._annotate(answer(m, planner, planner.run(simulator, results, env, world), "run"), env))
        return results

    def _annotate(self, r: PlanResult, env: dict[str, float]) -> PlanResult:
        """The result's setting (what its outcomes depend on), limits and calibrated success."""
        from judgeopt.judge.data_ranges import outside_data
        from judgeopt.verdict.calibration import inputs as calibration_inputs

        limits = {k: getattr(self.problem, k) for k in LIMIT_NAMES}
        r.info.update(setting=self.settings[r.method], family=self.families[r.method], limits=limits,
                      setting_description=self.descriptions[r.method], judge_sha256=self.judge_meta["weights_sha256"])
        if r.method in self.constrained_families:
            r.info["constrained_family"] = self.constrained_families[r.method]
        cal = self.calibrators.get(r.method)
        if cal is not None and r.predicted_success is not None:
            r.info.update(cal.annotate(calibration_inputs(limits, env), r.predicted_success))
        if self.plan_model is not None and r.plan is not None and r.predicted_success is not None:
            # the plan as a stored row reads (its limits and judge in its info, above), with its constraint set
            row = {**r.to_json(), "constraints": dataclasses.asdict(self.problem.constraints)}
            r.info.update(self.plan_model.annotate(row, self.problem.robot))
        outside = outside_data(self.judge_meta, env, limits)
        if outside:
            r.info["outside_judge_data"] = outside
        if self.problem.robot != DEFAULT_ROBOT:  # results of the default arm read as before
            r.info["robot"] = self.problem.robot
        annotate_risk(r.info, self.evidence, r.method, self.judge_meta["weights_sha256"],
                      {**limits, **env, "robot": self.problem.robot}, self.risk)
        return assess(r)


def answer(name: str, planner: Planner, result: Any, call: str = "solve") -> PlanResult:
    """`result`, what the planner registered as `name` returned, where it is a PlanResult of that
    name; else a one-line error saying what `solve` must return (a planner of one's own that
    returned None would fail later, far from its cause)."""
    where = f"planner {name!r}: {type(planner).__name__}.{call}"
    if not isinstance(result, PlanResult):
        raise ProblemError(f"{where} returned {type(result).__name__}; it must return a PlanResult, e.g. "
                           "judgeopt.planners.toolkit.plan_result(self, env, plan, started)")
    if result.method != name:
        raise ProblemError(f"{where} returned a result of method {result.method!r}; its method must be the registered "
                           f"name {name!r} (set the class's `method = {name!r}`)")
    return result
