"""Do the tests catch the bugs they were written against? Apply each single-line mutation below,
one at a time, in a temporary git worktree of HEAD (the working tree is never touched), run the
tests named for it, and print caught / MISSED. A mutation whose text is no longer in its file
(the code moved on) is reported as "not applied", so the list is kept up to date by hand.

    .venv/bin/python scripts/mutations.py                 # all (about 2 min on 2 cores)
    .venv/bin/python scripts/mutations.py --only f_min    # those whose name contains f_min
    .venv/bin/python scripts/mutations.py --tests-from .  # test files from the working tree (before committing them)

Exit status 1 when a mutation is missed, or when the named tests fail without any mutation.
docs/testing.md lists the mutations and what catches each.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class Mutation:
    name: str
    path: str  # file in the repository
    old: str  # text replaced (must occur exactly once)
    new: str
    tests: tuple[str, ...]  # pytest node ids or files that must fail


SUCCESS = "tests/tasks/scoop/test_success_criterion.py"
OVERWRITE = "tests/cli/test_overwrite_every_output.py"
NORMALISATION = "tests/judge/test_normalisation.py"
LIMITS = "tests/planners/test_binding_limits.py"
RESIDUALS = "tests/planners/test_residuals_by_hand.py"
MAIN = "tests/planners/test_planners.py::test_solve_both_methods_in_simulation"

MUTATIONS = [
    Mutation("success rise 2.5 -> 1.5 cm", "judgeopt/tasks/scoop/rollout.py",
             "success_rise: float = 0.025", "success_rise: float = 0.015", (SUCCESS,)),
    Mutation("success rise 2.5 -> 3.5 cm", "judgeopt/tasks/scoop/rollout.py",
             "success_rise: float = 0.025", "success_rise: float = 0.035", (SUCCESS,)),
    Mutation("overhang 3.5 cm -> 3.5 mm", "judgeopt/tasks/scoop/rollout.py",
             "max_overhang: float = 0.035", "max_overhang: float = 0.0035", (SUCCESS,)),
    Mutation("success ignores where the object is", "judgeopt/tasks/scoop/rollout.py",
             "success = held and passed[cfg.success_test]", "success = passed[cfg.success_test]", (SUCCESS,)),
    Mutation("solve refuses the bare --out, not the per-method files", "judgeopt/cli/planners.py",
             "targets = [_with_method(path, m, several) for path in", "targets = [Path(path) for path in",
             (OVERWRITE,)),
    Mutation("solve does not refuse an existing --plot", "judgeopt/cli/planners.py",
             "refuse_overwrite(targets + ([args.plot] if args.plot else []), args.overwrite)",
             "refuse_overwrite(targets, args.overwrite)", (OVERWRITE,)),
    Mutation("solve does not refuse an existing --export", "judgeopt/cli/planners.py",
             "for path in (args.out, args.save_json, args.export) if path",
             "for path in (args.out, args.save_json) if path", (OVERWRITE,)),
    Mutation("export does not refuse an existing --out", "judgeopt/cli/export.py",
             "refuse_overwrite([args.out], args.overwrite)", "refuse_overwrite([], args.overwrite)", (OVERWRITE,)),
    Mutation("judge normalisation: one std for all channels", "judgeopt/judge/model.py",
             "std = a.std(0) if len(a) else", "std = np.full(a.shape[1], a.std()) if len(a) else", (NORMALISATION,)),
    Mutation("judge normalisation: one mean for all channels", "judgeopt/judge/model.py",
             "mean = a.mean(0) if len(a) else", "mean = np.full(a.shape[1], a.mean()) if len(a) else",
             (NORMALISATION,)),
    Mutation("direct: f_min bound with its sign flipped", "judgeopt/planners/direct.py",
             'column(pr.vec("f_min"), n + 1, SCALE_F)', 'column(-pr.vec("f_min"), n + 1, SCALE_F)', (LIMITS,)),
    Mutation("direct: q_min bound scaled as a velocity", "judgeopt/planners/direct.py",
             'column(pr.vec("q_min"), n, SCALE_Q)', 'column(pr.vec("q_min"), n, SCALE_V)', (LIMITS,)),
    Mutation("direct: terminal velocity from qdot0, not qdot_end", "judgeopt/planners/direct.py",
             'qd_end = pr.vec("qdot_end")', 'qd_end = pr.vec("qdot0")', (LIMITS,)),
    Mutation("reach: N steps of velocity instead of N - 1 (dt off by one)", "judgeopt/planners/problem.py",
             "inner = self.dt * (self.steps - 1)", "inner = self.dt * self.steps", (LIMITS,)),
    Mutation("residual q̇_end measured against q̇0", "judgeopt/planners/result.py",
             'np.abs(v[-1] - problem.vec("qdot_end"))', 'np.abs(v[-1] - problem.vec("qdot0"))', (RESIDUALS,)),
    Mutation("simulator range check strict (< lo becomes <= lo)", "judgeopt/tasks/scoop/rollout.py",
             "bad = np.flatnonzero((values < lo) | (values > hi))",
             "bad = np.flatnonzero((values <= lo) | (values > hi))", (RESIDUALS,)),
    Mutation("$JUDGEOPT_MODELS looked up after the shipped models", "judgeopt/files.py",
             "candidates = [models_dir() / rest, shipped_models() / rest, *candidates]",
             "candidates = [shipped_models() / rest, models_dir() / rest, *candidates]",
             ("tests/test_models_folder.py",)),
    Mutation("conditioned generator reads its training limits, not the problem's", "judgeopt/planners/generator.py",
             "            lim = limits_of(problem)", "            lim = limits_of(g.problem)", (MAIN,)),
]

TEST_FILES = sorted({t.split("::")[0] for m in MUTATIONS for t in m.tests})


def pytest(tree: Path, tests: tuple[str, ...]) -> int:
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", *tests], cwd=tree,
                       env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return r.returncode


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--only", help="run the mutations whose name contains this")
    ap.add_argument("--tests-from", metavar="DIR", help="copy the named test files from this checkout first")
    ap.add_argument("--keep", action="store_true", help="keep the worktree (its path is printed)")
    args = ap.parse_args()
    chosen = [m for m in MUTATIONS if not args.only or args.only in m.name]
    tree = Path(tempfile.mkdtemp(prefix="judgeopt-mutations-")) / "tree"
    subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(tree), "HEAD"], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    missed = 0
    try:
        if args.tests_from:
            for f in TEST_FILES:
                shutil.copy(Path(args.tests_from) / f, tree / f)
        tests = sorted({t for m in chosen for t in m.tests})
        if pytest(tree, tuple(tests)) != 0:
            print(f"the named tests fail without any mutation: {' '.join(tests)}")
            return 1
        for m in chosen:
            f = tree / m.path
            text = f.read_text()
            if text.count(m.old) != 1:
                print(f"not applied  {m.name}: {m.path} holds {m.old!r} {text.count(m.old)} times")
                continue
            line = text[:text.index(m.old)].count("\n") + 1
            f.write_text(text.replace(m.old, m.new))
            try:
                rc = pytest(tree, m.tests)
            finally:
                f.write_text(text)
            caught = rc == 1  # tests ran and failed (2-5: interrupted, usage, collection errors)
            missed += not caught
            print(f"{'caught' if caught else f'MISSED (pytest exit {rc})':<12} {m.path}:{line} {m.name} -> "
                  f"{', '.join(m.tests)}", flush=True)
    finally:
        if args.keep:
            print(f"worktree kept: {tree}")
        else:
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(tree)], check=False)
            shutil.rmtree(tree.parent, ignore_errors=True)
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
