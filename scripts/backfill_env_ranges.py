"""Record in each shipped judge's JSON the environment (and limit) ranges it learnt from.

Judges made before `train_data.env_ranges` existed (judgeopt.judge.data_ranges) do not say which
worlds their data covered, so a planner cannot warn when asked about one outside them. This adds
to every judge file under judgeopt/models (ensemble members included) `train_data.env_ranges`
and `train_data.env_ranges_source`, and changes nothing else in the file (same keys in the same
order, same indent, same bytes apart from the two keys):

- a training file named in `train_data.path` that is in this repo with the recorded sha256 is
  measured (min, max of its environments; an ensemble member's bootstrap sample, redrawn from its
  `bootstrap_seed` as judgeopt.judge.ensemble draws it). One that was remade since is taken from
  the git commit whose version has the recorded sha256.
- a file that is not shipped (out/...) counts with the ranges its environments were drawn from,
  as the commands that made it say (NOT_SHIPPED: docs/judge.md, docs/remedies.md, Makefile);
  every `collect` draws from the task's sampled ranges (EnvVar.sampled).
- a refined judge's replayed plans (`planner_outcomes`, not shipped) count with the ranges the
  refinement rounds drew their environments from (REFINE_DRAWS).
- a refined judge also gets `train_data.limit_ranges` (and `limit_ranges_source`): the union of
  `refine_config.limit_ranges` (its last run's) and the ranges of the runs before it
  (EARLIER_LIMITS), which refine_config does not record.

The ranges recorded are the union of these, and `env_ranges_source` says which parts were
measured and which were drawn. Every measured range is checked against the task's sampled ranges
(printed), every judge is loaded afterwards (weights hash checked). A rerun writes the same bytes.

    .venv/bin/python scripts/backfill_env_ranges.py           # write
    .venv/bin/python scripts/backfill_env_ranges.py --check   # exit 1 where a file would change
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from judgeopt.data.dataset import load
from judgeopt.files import REPO, sha256_file
from judgeopt.judge.data_ranges import env_ranges_of, format_range, limit_ranges_in, union
from judgeopt.judge.store import load_judge
from judgeopt.tasks import DEFAULT_TASK, get_task

MODELS = REPO / "judgeopt" / "models"
_TMP = tempfile.TemporaryDirectory()  # old versions of data files, from git; removed at exit

#: `collect`: drawn from the task's sampled ranges (no --range in the commands that made them)
COLLECT = "collect"
#: training files shipped judges name that are not in this repo: how they were made
NOT_SHIPPED: dict[str, object] = {
    # docs/judge.md: `judgeopt collect --out out/j23/train_more_s21.h5 --seed 21 --n 20000`
    "out/j23/train_more_s21.h5": COLLECT,
    # docs/judge.md: `judgeopt collect ... --focus JUDGE`: every candidate environment is drawn from the same ranges
    "out/j24/focus_s31.h5": COLLECT,
    "out/j24/focus2_s41.h5": COLLECT,
    "out/j25/focus_both_s71.h5": COLLECT,
    "out/j26/focus_s91.h5": COLLECT,
    # docs/remedies.md: "one file, out/j27/train123k.h5, the eight training files concatenated"
    "out/j27/train123k.h5": ["data/train.h5", "data/train_random.h5", "data/train_constant.h5",
                             "out/j23/train_more_s21.h5", "out/j24/focus_s31.h5", "out/j24/focus2_s41.h5",
                             "out/j25/focus_both_s71.h5", "out/j26/focus_s91.h5"],
    # Makefile `section5`: lab recordings imported with --env-names y_obj --env y_obj=0.246 (data/lab/test.h5, the
    # same import of the held-out recordings, the judge's test_data by its sha256, holds y_obj = 0.246 only)
    "out/section5/train.h5": ({"y_obj": (0.246, 0.246)}, "every recording imported with --env y_obj=0.246 "
                              "(Makefile section5; data/lab/test.h5, the same import, holds y_obj = 0.246 only)"),
}
#: refined judges' replayed plans: the problem whose environment ranges the rounds drew from, the
#: command-line overrides of those ranges (each run's), and where that is written
REFINE_DRAWS = {
    "judge_refined": ("problems/paper_sim.toml", {"mu": [(0.05, 4.0), (1.0, 4.0)]},
                      "docs/remedies.md: problems/paper_sim.toml, --mu 0.05,4 in rounds 1-4 and --mu 1,4 in 5-7"),
    "experiments/judge_refined_tcn": ("problems/paper_sim.toml", {"mu": [(0.05, 4.0), (1.0, 4.0)]},
                          "docs/remedies.md: problems/paper_sim.toml, --mu 0.05,4 in rounds 1-4 and --mu 1,4 in 5-7"),
    "scrape/judge_refined": ("problems/scrape.toml", {}, "Makefile scrape-trust: problems/scrape.toml's ranges"),
}
#: the limit ranges of the refinement runs before the one refine_config records (a resumed refinement
#: records only its last run's): (ranges, where that is written). Every round's judge learnt from them.
EARLIER_LIMITS = {
    # rounds 1-4: --sample-limits with the scoop's wide ranges (then and now); rounds 5-7: --f-max-range 10.5,16
    "judge_refined": ({"qdot_max": (0.22, 1.2), "f_min": (0.0, 10.0), "f_max": (11.0, 30.0)},
                      "rounds 1-4 drew from the wide ranges qdot_max 0.22-1.2, f_min 0-10, f_max 11-30 "
                      "(docs/remedies.md), rounds 5-7 from refine_config's"),
    "experiments/judge_refined_tcn": ({"qdot_max": (0.22, 1.2), "f_min": (0.0, 10.0), "f_max": (11.0, 30.0)},
                          "rounds 1-4 drew from the wide ranges qdot_max 0.22-1.2, f_min 0-10, f_max 11-30 "
                          "(docs/remedies.md), rounds 5-7 from refine_config's"),
    # Makefile scrape-trust: rounds 1-4 and 5-6 both with the scrape's wide ranges, which refine_config records
    "scrape/judge_refined": ({}, "every round drew from refine_config's (Makefile scrape-trust)"),
}


def git_version(path: str, sha: str) -> tuple[Path, str] | None:
    """(a temporary copy, the commit) of the version of `path` in git history with sha256 `sha`."""
    commits = subprocess.run(["git", "log", "--format=%H", "--", path], cwd=REPO, capture_output=True, text=True,
                             check=True).stdout.split()
    for c in commits:
        blob = subprocess.run(["git", "show", f"{c}:{path}"], cwd=REPO, capture_output=True, check=False).stdout
        tmp = Path(_TMP.name) / f"{c}_{Path(path).name}"
        tmp.write_bytes(blob)
        if sha256_file(tmp) == sha:
            return tmp, c
        tmp.unlink()
    return None


def widen(into: dict[str, list[float]], ranges: dict) -> None:
    into.update(union(into, ranges))


def describe(ranges: dict) -> str:
    return ", ".join(f"{k} {format_range(*v)}" for k, v in ranges.items())


def ranges_for(name: str, meta: dict) -> tuple[dict[str, list[float]], str, list[str]]:
    """(env_ranges, env_ranges_source, check lines) for the judge `name` (path under models/, no suffix)."""
    td = meta["train_data"]
    paths, shas = td["path"].split(" + "), td["sha256"].split(" + ")
    assert len(paths) == len(shas), name
    boot = td.get("bootstrap_seed")
    out: dict[str, list[float]] = {}
    measured, collected, other, checks = [], [], [], []
    task_name = meta.get("task") or (meta.get("refine_config") or {}).get("limit_ranges", {}).get("task")

    def part(path: str, sha: str | None) -> None:
        nonlocal task_name
        file = REPO / path
        version = None
        if file.exists() and sha is not None and sha256_file(file) != sha:
            found = git_version(path, sha)
            if found is None:
                raise SystemExit(f"{name}: {path} has another sha256 than recorded and no version in git has it")
            file, version = found
        if file.exists():
            ds = load(file)
            task_name = task_name or ds.task
            if boot is not None:  # judgeopt.judge.ensemble: the member's own bootstrap sample
                ds = ds.subset(np.random.default_rng(boot).integers(0, ds.n, ds.n))
            r = env_ranges_of(ds)
            widen(out, r)
            label = path + (f" as of commit {version[:7]} (sha256 {sha[:12]}..., the version trained on; the file "
                            "was remade since)" if version else " (as shipped)" if sha is None else "")
            measured.append(label + (f", bootstrap sample {boot}" if boot is not None else ""))
            sampled = get_task(ds.task).env_ranges()
            inside = all(sampled[k][0] - 1e-12 <= lo and hi <= sampled[k][1] + 1e-12 for k, (lo, hi) in r.items())
            checks.append(f"  {path}: {describe(r)} ({'within' if inside else 'NOT within'} the task's sampled "
                          f"{describe(sampled)})")
            return
        how = NOT_SHIPPED.get(path)
        if how is None:
            raise SystemExit(f"{name}: {path} is not in this repo and NOT_SHIPPED does not say how it was made")
        if how == COLLECT:
            collected.append(path)
            widen(out, get_task(task_name or DEFAULT_TASK).env_ranges())
        elif isinstance(how, list):
            other.append(f"{path} not shipped: the concatenation of {' + '.join(how)} (docs/remedies.md)")
            for p in how:
                part(p, None)
        else:
            ranges, why = how
            if path == "out/section5/train.h5":  # the evidence the note cites
                lab = REPO / "data/lab/test.h5"
                assert sha256_file(lab) == meta["test_data"]["sha256"] and env_ranges_of(load(lab)) == {
                    k: list(v) for k, v in ranges.items()}, "data/lab/test.h5 no longer backs the section5 note"
            other.append(f"{path} not shipped: {why}")
            widen(out, ranges)

    for p, s in zip(paths, shas):
        part(p, s)
    task = get_task(task_name or DEFAULT_TASK)
    source = []
    if measured:
        source.append(" + ".join(dict.fromkeys(measured)) + " measured")
    if collected:
        source.append(f"{', '.join(dict.fromkeys(collected))} not shipped: the task's collection ranges "
                      f"({describe(task.env_ranges())}), which every collect draws from (docs/judge.md)")
    source += other
    if td.get("planner_outcomes"):
        from judgeopt.planners.problem import load_problem
        from judgeopt.files import resolve

        problem_file, overrides, why = REFINE_DRAWS[name]
        problem = load_problem(resolve(problem_file))
        drawn = {k: problem.env_range(k) for k in problem.env_names}
        for k, rs in overrides.items():
            drawn[k] = (min(r[0] for r in rs), max(r[1] for r in rs))
        widen(out, drawn)
        source.append(f"the {td['planner_outcomes']} replayed plans of refinement (not shipped): the ranges their "
                      f"environments were drawn from, {describe(drawn)} ({why})")
    out = {k: out[k] for k in (td.get("env_names") or list(out)) if k in out} | out  # the data's order
    sampled = task.env_ranges()
    beyond = [k for k, (lo, hi) in out.items() if k in sampled and (lo < sampled[k][0] or hi > sampled[k][1])]
    checks.append(f"  recorded: {describe(out)}" + (f"  (beyond the task's sampled ranges in {', '.join(beyond)})"
                                                     if beyond else "  (the task's sampled ranges, or within them)"))
    return out, "; ".join(source), checks


def judge_files() -> list[Path]:
    found = []
    for js in sorted(MODELS.rglob("*.json")):
        try:
            meta = json.loads(js.read_text())
        except ValueError:
            continue
        if isinstance(meta, dict) and meta.get("format") == "judgeopt-judge":
            found.append(js)
    return found


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 where a file would change")
    args = ap.parse_args()
    changed = []
    for js in judge_files():
        name = str(js.relative_to(MODELS).with_suffix(""))
        text = js.read_text()
        meta = json.loads(text)
        if json.dumps(meta, indent=2) + "\n" != text:
            raise SystemExit(f"{js}: not in the format json.dumps(indent=2) writes; refusing to rewrite it")
        ranges, source, checks = ranges_for(name, meta)
        print(f"{name}:\n" + "\n".join(checks) + f"\n  source: {source}")
        td = meta["train_data"]
        td["env_ranges"], td["env_ranges_source"] = ranges, source  # new keys go last; existing ones keep their place
        if meta.get("refine_config", {}).get("limit_ranges"):
            for key in ("limit_ranges", "limit_ranges_source"):  # recomputed below (a rerun writes the same)
                td.pop(key, None)
            earlier, why = EARLIER_LIMITS[name]
            td["limit_ranges"] = union(limit_ranges_in(meta), earlier)
            td["limit_ranges_source"] = why
            print(f"  limits: {describe(td['limit_ranges'])} ({why})")
        new = json.dumps(meta, indent=2) + "\n"
        if new != text:
            changed.append(js)
            if not args.check:
                js.write_text(new)
        load_judge(js.with_suffix(""))  # still loads, weights hash still matches
    print(f"{len(changed)} file(s) {'would change' if args.check else 'written'}: "
          + (", ".join(str(c.relative_to(REPO)) for c in changed) or "none"))
    return 1 if args.check and changed else 0


if __name__ == "__main__":
    sys.exit(main())
