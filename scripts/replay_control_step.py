"""Is the compiled control step the same plant? Replay shipped demonstrations with it (issue 34, part 4).

Every demonstration of each dataset is replayed, its recorded command in its recorded environment,
with each control step named (ControllerConfig.step: "compiled", the C step of
judgeopt/sim/compiled.py; "python", HybridController.step, the reference the files were made with).
Labels are the success test each file was recorded with (its meta's rollout.success_test; "rise"
for the files made before 2026-11-23). Rollouts are chaotic (docs/physics.md): a changed rounding
changes trajectories, so the measure is label agreement, against the recorded labels and between
the steps, and the shipped judge's accuracy on the replayed responses and labels against its
accuracy on the recorded ones (Wilson 95 % intervals).

    .venv/bin/python scripts/replay_control_step.py [--data data/test.h5 data/test_seed2.h5]
        [--steps compiled python] [--jobs 2] [--judge models/judge_refined] [--n N]

Chunks of 25 demonstrations are saved under out/replay_control_step/<stem>_<step>.partial/ as they
finish: a rerun resumes. Result: out/replay_control_step/result.json and a summary on stdout.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from judgeopt.evaluate.report import wilson  # noqa: E402
from judgeopt.threads import set_threads  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
CHUNK = 25


def recorded_test(meta: dict) -> str:
    return ((meta.get("simulator") or meta.get("settings") or {}).get("rollout") or {}).get("success_test", "rise")


def _simulator(task_name: str, step: str):
    from judgeopt.parallel import worker_cache
    from judgeopt.tasks import get_task

    def build():
        task = get_task(task_name)
        s = task.settings()
        return task.simulator(dataclasses.replace(s, controller=dataclasses.replace(s.controller, step=step)))

    return worker_cache(f"replay_control_step:{task_name}:{step}", build)


def run_chunk(data: str, step: str, rows: list[int]) -> dict:
    """Replay demonstrations `rows` of `data` with control step `step`: labels and responses."""
    from judgeopt.data.dataset import load
    from judgeopt.tasks import get_task

    ds = load(data)
    task, sim, test = get_task(ds.task), _simulator(ds.task, step), recorded_test(ds.meta)
    kind = type(sim.controller).__name__
    labels, responses = [], []
    for i in rows:
        env = dict(zip(ds.env_names, map(float, ds.env[i])))
        o = sim.simulate(task.plan(np.array(ds.commands[i], dtype=float)), env)
        labels.append(int(o.details[f"success_{test}_test"]))
        responses.append(o.response)
    return {"labels": np.array(labels), "responses": np.array(responses), "controller": kind}


def judge_scores(judge: str, ds, responses: np.ndarray, labels: np.ndarray) -> dict:
    """The judge's accuracy (Wilson 95 %) on these responses and labels."""
    from judgeopt.judge.model import select_env
    from judgeopt.judge.store import load_judge

    set_threads(1)
    model, _ = load_judge(REPO / judge if not Path(judge).exists() else judge)
    p = model.predict_proba(responses, select_env(ds.env[:len(labels)], ds.env_names, model.config.env_names))
    right = int(((p >= 0.5) == labels.astype(bool)).sum())
    return {"accuracy": right / len(labels), "ci95": wilson(right, len(labels)), "n": len(labels)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", nargs="+", default=["data/test.h5", "data/test_seed2.h5"])
    ap.add_argument("--steps", nargs="+", default=["compiled", "python"], choices=["compiled", "python"])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--judge", default="models/judge_refined", help="'' : no judge scores")
    ap.add_argument("--n", type=int, help="first N demonstrations of each file (default: all)")
    ap.add_argument("--out", default=str(REPO / "out" / "replay_control_step"))
    ap.add_argument("--quiet", action="store_true")
    a = ap.parse_args()

    from judgeopt.data.dataset import load
    from judgeopt.parallel import run_chunks

    out = Path(a.out)
    sets = {d: load(d) for d in a.data}
    work, folders = [], {}
    for d, ds in sets.items():
        n = min(a.n or ds.n, ds.n)
        for step in a.steps:
            folder = folders[d, step] = out / f"{Path(d).stem}_{step}{'' if n == ds.n else f'_n{n}'}.partial"
            folder.mkdir(parents=True, exist_ok=True)
            for k, s in enumerate(range(0, n, CHUNK)):
                if not (folder / f"chunk_{k:04d}.npz").exists():
                    work.append(((d, step, k), run_chunk, (d, step, list(range(s, min(s + CHUNK, n))))))

    def save(key, result) -> None:
        d, step, k = key
        tmp = folders[d, step] / f"chunk_{k:04d}.tmp.npz"
        np.savez(tmp, labels=result["labels"], responses=result["responses"], controller=result["controller"])
        tmp.replace(folders[d, step] / f"chunk_{k:04d}.npz")

    run_chunks(work, save, n_jobs=a.jobs, progress=not a.quiet, desc="replay", unit="chunk")

    result: dict = {"command": "python scripts/replay_control_step.py " + " ".join(sys.argv[1:]), "files": {}}
    for d, ds in sets.items():
        n = min(a.n or ds.n, ds.n)
        rec = ds.labels[:n].astype(int)
        r: dict = {"n": n, "success_test": recorded_test(ds.meta), "recorded_success_share": float(rec.mean())}
        replay = {}
        for step in a.steps:
            parts = [np.load(f) for f in sorted(folders[d, step].glob("chunk_[0-9]*.npz"))]
            labels = np.concatenate([z["labels"] for z in parts])
            responses = np.concatenate([z["responses"] for z in parts])
            replay[step] = labels, responses
            agree = int((labels == rec).sum())
            r[step] = {"controller": sorted({str(z["controller"]) for z in parts}),
                       "agreement_with_recorded": agree / n, "agreement_ci95": wilson(agree, n),
                       "flipped_to_success": int(((labels == 1) & (rec == 0)).sum()),
                       "flipped_to_failure": int(((labels == 0) & (rec == 1)).sum()),
                       "responses_bit_identical": int(np.all(responses == ds.responses[:n], axis=(1, 2)).sum()),
                       "largest_response_difference": float(np.abs(responses - ds.responses[:n]).max())}
            if a.judge:
                r[step]["judge_on_replay"] = judge_scores(a.judge, ds, responses, labels)
        if len(replay) == 2:
            (la, ra), (lb, rb) = replay["compiled"], replay["python"]
            r["compiled_vs_python_label_agreement"] = float((la == lb).mean())
            r["compiled_vs_python_largest_response_difference"] = float(np.abs(ra - rb).max())
        if a.judge:
            r["judge_on_recorded"] = judge_scores(a.judge, ds, ds.responses[:n], rec)
        result["files"][d] = r
    if a.judge:
        result["judge"] = a.judge
    tot = {s: sum(result["files"][d][s]["agreement_with_recorded"] * result["files"][d]["n"] for d in sets)
           for s in a.steps}
    n_all = sum(result["files"][d]["n"] for d in sets)
    result["all"] = {s: {"agreement_with_recorded": tot[s] / n_all, "ci95": wilson(round(tot[s]), n_all)} for s in a.steps}
    (out / "result.json").write_text(json.dumps(result, indent=1) + "\n")
    for d, r in result["files"].items():
        print(f"{d}: {r['n']} demonstrations, success test '{r['success_test']}'")
        for s in a.steps:
            x = r[s]
            line = (f"  {s:8s} ({', '.join(x['controller'])}): labels agree with the recorded "
                    f"{100 * x['agreement_with_recorded']:.2f} % (+{x['flipped_to_success']} / -{x['flipped_to_failure']}), "
                    f"responses bit-identical {x['responses_bit_identical']}")
            if a.judge:
                j = x["judge_on_replay"]
                line += f"; judge {100 * j['accuracy']:.2f} % ({100 * j['ci95'][0]:.1f}-{100 * j['ci95'][1]:.1f})"
            print(line)
        if a.judge:
            j = r["judge_on_recorded"]
            print(f"  judge on the recorded labels: {100 * j['accuracy']:.2f} % ({100 * j['ci95'][0]:.1f}-{100 * j['ci95'][1]:.1f})")
        if "compiled_vs_python_label_agreement" in r:
            print(f"  compiled vs python: labels agree {100 * r['compiled_vs_python_label_agreement']:.2f} %")
    for s, x in result["all"].items():
        print(f"all: {s} agrees with the recorded labels on {100 * x['agreement_with_recorded']:.2f} % "
              f"(95 % {100 * x['ci95'][0]:.2f}-{100 * x['ci95'][1]:.2f})")
    print(f"  -> {out / 'result.json'}")


if __name__ == "__main__":
    main()
