"""One problem, its judge and its planners, loaded once and used for many environments.

`Planners.solve(env)` runs the amortised generator, then the direct solve warm-started from
the generator's plan (or from the documented min-jerk guess when no generator fits the
limits), then the CEM sampling baseline if asked, and optionally replays each plan in the
simulator. The CLI, the benchmarks and the
evaluation all go through here, so they measure the same thing.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from judgeopt.files import resolve
from judgeopt.judge.model import Judge
from judgeopt.planners.base import REGISTRY, Planner, planner_names, with_uses
from judgeopt.planners.cem import CEMPlanner
from judgeopt.planners.direct import DirectPlanner
from judgeopt.planners.generator import AmortizedPlanner
from judgeopt.planners.problem import LIMIT_NAMES, Problem, ProblemError
from judgeopt.planners.result import PlanResult, assess, infeasible_result
from judgeopt.trajectory import PlanError

#: the built-in planners (`judgeopt.planners.base.REGISTRY` holds them and any added one)
METHODS = ("amortized", "direct", "cem")
#: samples per environment variable given as a range "somewhere in here" (env_grid): its ends and
#: middle, or five points where only one variable is uncertain
GRID_POINTS = {1: 5}
GRID_POINTS_DEFAULT = 3
#: where the direct solve starts: the generator's plan where one covers the limits, or cold
WARM_STARTS = ("generator", "none")
def env_grid(nominal: dict[str, float], ranges: dict[str, tuple[float, float]], judge_reads: Sequence[str]) -> list[dict[str, float]]:
    """The environments one plan is judged in when some variables are only known to lie in a
    range: a grid over the ranges (ends included: a worst case over a box is usually at a corner),
    the other variables at their nominal value. A range for a variable the judge does not read is
    refused: it could not change the plan."""
    unread = [k for k in ranges if k not in judge_reads]
    if unread:
        raise ProblemError(f"{', '.join(unread)} given as a range, but the judge does not read "
                           f"{'it' if len(unread) == 1 else 'them'} (it reads {', '.join(judge_reads)}): give one value")
    k = GRID_POINTS.get(len(ranges), GRID_POINTS_DEFAULT)
    axes = {name: np.linspace(lo, hi, k) for name, (lo, hi) in ranges.items()}
    grid = np.meshgrid(*axes.values(), indexing="ij")
    return [{**nominal, **{name: float(g.flat[i]) for name, g in zip(axes, grid)}} for i in range(grid[0].size)] \
        if ranges else [dict(nominal)]


@dataclass(frozen=True)
class ChosenModels:
    """The model files a problem's planners use and their weights hashes; cheap to find (no
    weights are read), so a cached result can be checked against the models there are now."""
    problem: Problem
    judge: Path
    generator: Path | None
    shas: dict[str, str]

    def settings(self, methods: Sequence[str], over_limits: bool = False) -> dict[str, str]:
        """method -> calibration.setting_id (over_limits: the id of the settings that differ
        from it only in their limits); the CEM baseline uses the judge only."""
        from judgeopt.planners.calibration import setting_id

        return {m: setting_id(m, self.problem, {k: v for k, v in self.shas.items() if m != "cem" or k == "judge"},
                              over_limits) for m in methods}


def choose_models(problem: Problem, methods: Sequence[str], judge: str | Path | None = None,
                  generator: str | Path | None = None, models_dir: str | Path = "models") -> ChosenModels:
    """The judge (given or the problem's), the generator (given, or the best match in
    models_dir for these limits and this judge), and the ensemble and trust model the direct
    solve would use."""
    from judgeopt.files import sha256_file
    from judgeopt.judge.store import load_meta
    from judgeopt.planners.store import find_generator, load_generator_meta

    jpath = resolve(judge or problem.judge, (".json",))
    shas = {"judge": load_meta(jpath)["weights_sha256"]}
    gpath = None
    if "amortized" in methods or "direct" in methods:
        gpath = resolve(generator, (".json",)) if generator else find_generator(resolve(models_dir), problem,
                                                                                  shas["judge"])
        if gpath is not None:
            shas["generator"] = load_generator_meta(gpath)["weights_sha256"]
    if "direct" in methods:
        if problem.ensemble:
            shas["ensemble"] = sha256_file(resolve(problem.ensemble) / "ensemble.json")
        if problem.trust_region is not None:
            shas["trust_model"] = sha256_file(resolve(problem.trust_model, (".json",)).with_suffix(".json"))
    return ChosenModels(problem, jpath, gpath, shas)


@dataclass
class Planners:
    problem: Problem
    judge: Judge
    judge_meta: dict
    judge_path: Path | None = None
    generator_path: Path | None = None
    amortized: AmortizedPlanner | None = None
    direct: DirectPlanner | None = None
    cem: CEMPlanner | None = None
    notes: list[str] = field(default_factory=list)
    methods: tuple[str, ...] = METHODS
    settings: dict[str, str] = field(default_factory=dict)  # method -> calibration.setting_id
    families: dict[str, str] = field(default_factory=dict)  # method -> the same without the limits
    descriptions: dict[str, str] = field(default_factory=dict)
    calibrators: dict = field(default_factory=dict)  # method -> calibration.Calibrator
    calibration_file: dict = field(default_factory=dict)  # every calibrator in the problem's file
    models_dir: str | Path = "models"
    generator_given: str | Path | None = None  # a generator named by the user is never swapped
    loaded: dict = field(default_factory=dict)  # generator path -> (Generator, meta), shared by with_limits copies
    for_sets: dict = field(default_factory=dict)  # (samples, case) -> the direct solve for environment sets
    added: dict[str, Planner] = field(default_factory=dict)  # registered planners besides the built-ins, by name

    @classmethod
    def load(cls, problem: Problem, methods: Sequence[str] = ("amortized", "direct"), judge: str | Path | None = None,
             generator: str | Path | None = None, models_dir: str | Path = "models",
             casadi_backend: str | None = None) -> "Planners":
        """Load the judge, find or load the generator, build the direct solver (its judge through
        l4casadi32 where l4casadi is installed, else the torch32 callback: judge.casadi_fn.choose_backend;
        the library is built once per judge, a few seconds, and loaded from the cache after)."""
        from judgeopt.judge.casadi_fn import DEFAULT_BACKEND, build_casadi_judge
        from judgeopt.judge.store import check_compatible, load_judge
        from judgeopt.planners.limits import coverage_notes
        from judgeopt.planners.store import load_generator, matches

        bad = [m for m in methods if m not in REGISTRY]
        if bad or not methods:
            raise ProblemError(f"unknown method(s) {bad}; choose from {list(planner_names())}")
        methods = with_uses(methods)
        chosen = choose_models(problem, methods, judge, generator, models_dir)
        jmodel, jmeta = load_judge(chosen.judge)
        check_compatible(jmeta, horizon=problem.steps, dt=problem.dt, channels=problem.channels, env_names=problem.env_names)
        out = cls(problem, jmodel, jmeta, judge_path=chosen.judge, models_dir=models_dir, generator_given=generator)
        out.notes += coverage_notes(problem, jmeta)
        metrics = jmeta.get("metrics")
        ceiling = metrics.get("p_max_train") if isinstance(metrics, dict) else None
        if "direct" in methods and problem.objective == "target" and ceiling is not None and ceiling < problem.p_target:
            out.notes.append(f"the judge never gives a training demonstration more than p = {ceiling:.3f} (some labels "
                             f"wrong?), so the direct solve's p_target = {problem.p_target:g} is out of reach and it "
                             f"spends its iterations on the slack; set --p-target below {ceiling:.3f}")
        if "amortized" in methods or "direct" in methods:
            gpath = chosen.generator
            if gpath is not None:
                gen, gmeta = out.loaded[gpath] = load_generator(gpath)
                if not matches(gmeta, problem):
                    out.notes.append(f"generator {gpath} was trained for other limits; its plan may violate these "
                                     "(reported below)")
                if gmeta.get("judge", {}).get("weights_sha256") != jmeta["weights_sha256"]:
                    out.notes.append(f"generator {gpath} was trained against another judge")
                out.generator_path = Path(gpath)
                out.amortized = AmortizedPlanner(gen, problem, jmodel)
            elif "amortized" in methods:
                raise ProblemError(
                    f"no generator in {models_dir}/ was trained for these limits (q̇_max = {problem.qdot_max}, "
                    f"f in [{problem.f_min}, {problem.f_max}], ...), or conditioned on ranges that contain them, "
                    f"and this judge; train one with `judgeopt train-generator --problem "
                    f"{problem.source or 'PROBLEM'} [--conditioned] ... --out models/NAME`, "
                    "pass one with --generator, or use --method direct")
            else:
                out.notes.append("no generator trained for these limits: the direct solve starts from the min-jerk guess")
        if "direct" in methods:
            backend = casadi_backend or DEFAULT_BACKEND
            # the judge as a constraint (objective "target") tolerates float32's noise; -log p does not
            tolerant = problem.objective == "target"
            cj = build_casadi_judge(jmodel, backend=backend, noise_tolerant=tolerant)
            members, trust = None, None
            if problem.ensemble:
                from judgeopt.judge.ensemble import load_ensemble

                judges, _ = load_ensemble(resolve(problem.ensemble))
                for m in judges:
                    check_compatible(m.config, horizon=problem.steps, dt=problem.dt, channels=problem.channels, env_names=problem.env_names)
                members = [build_casadi_judge(m, backend=backend, noise_tolerant=tolerant) for m in judges]
                out.notes.append(f"direct: maximises mean - {problem.pessimism:g} std of the logits of "
                                 f"{len(members)} judges ({problem.ensemble})")
            if problem.trust_region is not None:
                from judgeopt.planners.trust_region import load_trust_region

                trust = load_trust_region(resolve(problem.trust_model, (".json",)), 3 * (problem.steps + 1))
                out.notes.append(f"direct: trust region, distance to the demonstrations <= {problem.trust_region:g} "
                                 f"(demonstrations' median {trust.quantiles['q50']:.1f}, 95 % "
                                 f"{trust.quantiles['q95']:.1f})")
            out.direct = DirectPlanner(problem, jmodel, cj, members=members, trust=trust)
        if "cem" in methods:
            out.cem = CEMPlanner(problem, jmodel)
        out.methods = tuple(m for m in planner_names() if m in methods)
        out.added = out._build_added(problem)
        out._settings(chosen)
        return out

    def _settings(self, chosen: ChosenModels) -> None:
        """Each method's setting (what its outcomes depend on) and its calibrator, if fitted."""
        from judgeopt.planners.calibration import load_calibration, lookup

        p, jpath = self.problem, chosen.judge
        self.settings = chosen.settings(self.methods)
        self.families = chosen.settings(self.methods, over_limits=True)
        for m in self.methods:
            extra = (f", generator {self.generator_path.name}" if m != "cem" and self.generator_path else "") + (
                f", ensemble {p.ensemble} - {p.pessimism:g} std" if m == "direct" and p.ensemble else "") + (
                f", trust region {p.trust_region:g}" if m == "direct" and p.trust_region is not None else "")
            self.descriptions[m] = f"{m}, judge {jpath.name}{extra}; q̇_max {p.qdot_max:g}, f in [{p.f_min:g}, {p.f_max:g}]"
        if not self.calibration_file:
            path = resolve(p.calibration) if p.calibration else None
            if path is None or not path.exists():
                return
            # a setting without one reports the judge's probability (fit one with `judgeopt calibrate`)
            self.calibration_file = load_calibration(path)
        found = {m: lookup(self.calibration_file, self.settings[m], self.families[m]) for m in self.methods}
        self.calibrators = {m: c for m, c in found.items() if c is not None}

    def _build_added(self, problem: Problem, built: dict[str, Planner] | None = None) -> dict[str, Planner]:
        """The registered planners besides the built-ins (those in `built` kept), each given the
        planners its entry `uses`."""
        out = dict(built or {})
        for m in self.methods:
            spec = REGISTRY[m]
            if m in METHODS or m in out:
                continue
            out[m] = spec.builder()(problem, self.judge, **{u: getattr(self, u) for u in spec.uses})
        return dict(sorted(out.items(), key=lambda kv: self.methods.index(kv[0])))

    def _direct_for(self, samples: int, case: str) -> DirectPlanner:
        """The direct solve for `samples` environments at once (built once per size and case)."""
        key = (samples, case)
        if key not in self.for_sets:
            d = self.direct
            self.for_sets[key] = DirectPlanner(d.problem, d.judge, d.cjudge, d.options, d.members, d.trust, samples, case)
        return self.for_sets[key]

    def with_limits(self, **limits: float) -> "Planners":
        """The same judge under other position, velocity or force limits, without rebuilding the
        direct solver (it swaps its bounds). The generator is chosen as `load` chooses it (the
        one given, else one in models_dir that covers the new limits; each loaded once); where
        none covers them, the amortised method drops out and the old generator's plan only
        warm-starts the direct solve. Each method's setting, and so its calibration, is new."""
        from judgeopt.planners.store import load_generator

        problem = self.problem.with_overrides(**limits)
        chosen = choose_models(problem, self.methods, self.judge_path, self.generator_given, self.models_dir)
        out = dataclasses.replace(self, problem=problem, notes=list(self.notes), settings={}, families={},
                                  descriptions={}, calibrators={}, for_sets={})
        gpath = chosen.generator
        if gpath is not None:
            if gpath not in self.loaded:
                self.loaded[gpath] = load_generator(gpath)
            gen, _ = self.loaded[gpath]
            out.generator_path, out.amortized = Path(gpath), AmortizedPlanner(gen, problem, self.judge)
        elif "amortized" in self.methods or self.amortized is not None:
            out.methods = tuple(m for m in self.methods if m != "amortized")
            if not out.methods:
                raise ProblemError(f"no generator in {self.models_dir}/ covers {limits}; plan with --method direct")
            out.generator_path = None
        if self.direct is not None:
            out.direct = self.direct.with_limits(problem)
        if self.cem is not None:
            out.cem = CEMPlanner(problem, self.judge, self.cem.config)
        out.added = {m: p.with_limits(problem) for m, p in self.added.items() if not REGISTRY[m].uses}
        out.added = out._build_added(problem, out.added)
        out._settings(chosen)
        return out

    def solve(self, env: dict[str, float], simulator=None, guess=None, warm_start: str = "generator",
              env_set: list[dict[str, float]] | None = None, case: str = "worst",
              world: dict[str, float] | None = None) -> list[PlanResult]:
        """Every requested method for one environment (infeasible limits: one result saying so).
        `guess`: the direct solve's warm start instead of the generator's plan; `warm_start`
        "none": the direct solve starts cold, from its min-jerk guess, as with a new task or
        limits no generator covers. `env_set` (env_grid): the direct solve plans for all of
        them at once, in their worst `case` or on average; the others plan for `env`."""
        if warm_start not in WARM_STARTS:
            raise ProblemError(f"warm start {warm_start!r}: choose one of {', '.join(WARM_STARTS)}")
        env = self.problem.env_dict(env)
        infeasible = [infeasible_result(m, self.problem, env) for m in self.methods]
        if infeasible[0] is not None:
            return infeasible
        results: list[PlanResult] = []
        if self.amortized is not None:
            r = self.amortized.solve(env)
            # under other limits (a generator that does not cover them): the direct solve clips it
            guess = guess if guess is not None or warm_start == "none" else r.plan
            if "amortized" in self.methods:
                results.append(r)
        if self.direct is not None:
            if env_set is not None and len(env_set) > 1:
                results.append(self._direct_for(len(env_set), case).solve(env, guess=guess, env_set=env_set))
            else:
                results.append(self.direct.solve(env, guess=guess))
        if self.cem is not None:
            results.append(self.cem.solve(env))
        closed = {m: p for m, p in self.added.items() if REGISTRY[m].closed_loop}
        if closed and simulator is None:
            raise ProblemError(f"{', '.join(closed)} plans while its plan is executed in simulation: give a simulator "
                               "(drop --no-simulate)")
        results += [p.solve(env) for m, p in self.added.items() if m not in closed]
        for r in results:
            self._annotate(r, env)
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
            for p in closed.values():  # planning while executing, from the open-loop results
                results.append(self._annotate(p.run(simulator, results, env, world), env))
        return results

    def _annotate(self, r: PlanResult, env: dict[str, float]) -> PlanResult:
        """The result's setting (what its outcomes depend on), limits and calibrated success."""
        from judgeopt.judge.data_ranges import outside_data
        from judgeopt.planners.calibration import inputs as calibration_inputs

        limits = {k: getattr(self.problem, k) for k in LIMIT_NAMES}
        r.info.update(setting=self.settings[r.method], family=self.families[r.method], limits=limits,
                      setting_description=self.descriptions[r.method], judge_sha256=self.judge_meta["weights_sha256"])
        cal = self.calibrators.get(r.method)
        if cal is not None and r.predicted_success is not None:
            r.info.update(cal.annotate(calibration_inputs(limits, env), r.predicted_success))
        outside = outside_data(self.judge_meta, env, limits)
        if outside:
            r.info["outside_judge_data"] = outside
        return assess(r)
