"""How much of a judge's error is the simulated scoop's own chaos (issue 23, part 1).

Every demonstration of a dataset is replayed: once exactly as recorded (its command in its
recorded environment), then R times with a perturbation far below anything physical, each
repeat drawn from its own generator seeded by (--seed, demonstration index, repeat):

  command  every command value (y, ydot, f at each of the 31 samples) multiplied by
           (1 + eps * z), z ~ N(0, 1) per value, eps = --eps (default 1e-9): at most a few
           1e-10 m, 1e-9 m/s and 1e-8 N; zeros (rest at both ends) stay zero
  object   the object's start position y_obj moved by eps * z metres, z ~ N(0, 1),
           eps = --eps (default 1e-7 m); the command is untouched

Each rollout's label is the success test the dataset was recorded with (its meta's
rollout.success_test; "rise" where it names none: the files made before 2026-11-23).

The exact replay is itself a rounding-level perturbation wherever the code's floating-point
operations changed since the file was made (the shipped scoop files of 2026-11-22 no longer
replay bit for bit: their responses differ from the first samples at 1e-15 and grow), so it
counts as one more run: each demonstration has the recorded label plus R + 1 replayed ones.

From the labels:
  - the share of demonstrations whose label flips in at least one repeat (Wilson 95 %),
    and the agreement of each repeat with the recorded label;
  - p_i = share of successes among the R + 1 labels; the best accuracy any judge of the
    command and environment could reach on recorded labels is 1 - E[min(p, 1 - p)]. With
    m = min(p, 1 - p) <= 1/2, p(1 - p) = m(1 - m) lies in [m / 2, m], so the Bayes accuracy lies in
    [1 - 2 E[p(1 - p)], 1 - E[p(1 - p)]], and k(n - k) / (n(n - 1)) (k successes of n labels)
    estimates p(1 - p) without bias. Where few or no labels flip the bootstrap says little; then
    the conservative bound: with >= 3 labels a demonstration of minority share m shows a flip
    with probability >= 2m(1 - m) >= m, so the Bayes error is at most the flip share's upper
    Wilson limit. Also the plug-in mean(max(p_i, 1 - p_i)) (biased upward
    with few repeats). 95 % intervals by a seeded bootstrap over demonstrations.
  - with --judge: the judge on every replayed response (does it follow a flipped label?),
    and how many of its errors on the recorded labels fall on demonstrations that flip.

    .venv/bin/python scripts/noise_floor.py --data data/test.h5 --repeats 3 --perturb command
    .venv/bin/python scripts/noise_floor.py --data data/test.h5 --repeats 2 --perturb object
    .venv/bin/python scripts/noise_floor.py --data data/test.h5 --combine \
        out/noise_floor/test_command_r3.npz out/noise_floor/test_object_r2.npz

--combine pools the runs of earlier results on the same file (the exact replay once, every
perturbed repeat) into one analysis: <data stem>_combined.json.

Results: JSON under out/noise_floor/ (default name <data stem>_<perturb>_r<R>[_n<N>].json) and
the replayed labels and responses beside it (.npz). Progress is saved every 25 demonstrations
to <out>.partial.npz; a rerun of the same command resumes from it. One process, one thread.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from judgeopt.evaluate.report import wilson  # noqa: E402

DEFAULT_EPS = {"command": 1e-9, "object": 1e-7}
REPO = Path(__file__).resolve().parents[1]


def bootstrap(values: np.ndarray, seed: int, n_boot: int = 10000) -> tuple[float, float]:
    """95 % percentile interval of the mean of `values` (one per demonstration)."""
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, len(values), size=(n_boot, len(values)))
    means = values[idx].mean(axis=1)
    return float(np.quantile(means, 0.025)), float(np.quantile(means, 0.975))


def perturbed(kind: str, eps: float, seed: int, i: int, r: int, command: np.ndarray,
              env: dict[str, float]) -> tuple[np.ndarray, dict[str, float]]:
    rng = np.random.default_rng([seed, int(i), r])
    if kind == "command":
        return command * (1.0 + eps * rng.standard_normal(command.shape)), dict(env)
    if kind == "object":
        return command.copy(), {**env, "y_obj": env["y_obj"] + eps * float(rng.standard_normal())}
    raise ValueError(kind)


def recorded_test(meta: dict) -> str:
    return ((meta.get("simulator") or meta.get("settings") or {}).get("rollout") or {}).get("success_test", "rise")


def analyse(labels: np.ndarray, recorded: np.ndarray, seed: int) -> dict:
    """labels: (n, R) the replayed runs' labels; recorded: (n,) the file's labels."""
    n, R = labels.shape
    all_labels = np.concatenate([recorded[:, None], labels], axis=1).astype(float)
    flips = (labels != recorded[:, None]).any(axis=1)
    k = all_labels.sum(axis=1)
    m = R + 1
    p = k / m
    pq = k * (m - k) / (m * (m - 1))  # unbiased estimate of p(1 - p)
    plug = np.maximum(p, 1 - p)
    # a judge that predicts the majority of the replayed runs, scored on the recorded label
    # (ties: half right): what a predictor of the command alone reaches with R samples to learn from
    maj = labels.mean(axis=1)
    loo = np.where(maj == 0.5, 0.5, ((maj > 0.5) == recorded.astype(bool)).astype(float))
    out = {
        "n": int(n), "runs": int(R),
        "flipped": int(flips.sum()), "flip_share": float(flips.mean()), "flip_share_ci95": wilson(int(flips.sum()), n),
        "agreement_per_run": [float((labels[:, r] == recorded).mean()) for r in range(R)],
        "agreement_mean": float((labels == recorded[:, None]).mean()),
        "p_of_flipped": sorted(np.round(p[flips], 3).tolist()),
        "successes_recorded": int(recorded.sum()),
        "flipped_recorded_success": int((flips & (recorded == 1)).sum()),
        "bayes_accuracy_lower": float(1 - 2 * pq.mean()), "bayes_accuracy_lower_ci95": None,
        "bayes_accuracy_upper": float(1 - pq.mean()), "bayes_accuracy_upper_ci95": None,
        # P(a flip among >= 2 runs | m) >= 2m(1 - m) >= m: the Bayes error is at most the flip share
        "bayes_accuracy_conservative_lower": 1 - wilson(int(flips.sum()), n)[1],
        "bayes_accuracy_plugin": float(plug.mean()), "bayes_accuracy_plugin_ci95": bootstrap(plug, seed),
        "majority_of_repeats_accuracy": float(loo.mean()), "majority_of_repeats_accuracy_ci95": bootstrap(loo, seed),
    }
    lo, hi = bootstrap(pq, seed)
    out["bayes_accuracy_lower_ci95"] = (float(1 - 2 * hi), float(1 - 2 * lo))
    out["bayes_accuracy_upper_ci95"] = (float(1 - hi), float(1 - lo))
    return out


def judge_report(judge_path: str, ds, responses: np.ndarray, labels: np.ndarray, flips: np.ndarray) -> dict:
    import torch

    from judgeopt.judge.model import select_env
    from judgeopt.judge.store import load_judge

    torch.set_num_threads(1)
    model, _ = load_judge(REPO / judge_path if not Path(judge_path).exists() else judge_path)
    e = select_env(ds.env[:len(labels)], ds.env_names, model.config.env_names)
    n, R = labels.shape
    p_rec = model.predict_proba(ds.responses[:n], e)
    p_rep = np.stack([model.predict_proba(responses[:, r], e) for r in range(R)], axis=1)
    rec = ds.labels[:n]
    wrong = (p_rec >= 0.5) != rec.astype(bool)
    pred_rep = p_rep >= 0.5
    out = {
        "judge": judge_path,
        "accuracy_recorded": float(1 - wrong.mean()), "errors_recorded": int(wrong.sum()),
        "errors_on_flipped": int((wrong & flips).sum()),
        "accuracy_on_replays": float((pred_rep == labels.astype(bool)).mean()),
        "accuracy_recorded_without_flipped": float(1 - wrong[~flips].mean()) if (~flips).any() else None,
    }
    if flips.any():
        f = np.flatnonzero(flips)
        # on the flipped demonstrations: does the judge's answer move with the label?
        all_p = np.concatenate([p_rec[f, None], p_rep[f]], axis=1)
        all_y = np.concatenate([rec[f, None], labels[f]], axis=1).astype(bool)
        out["flipped_accuracy_all_runs"] = float(((all_p >= 0.5) == all_y).mean())
        out["flipped_judge_prediction_changes"] = int(((all_p >= 0.5) != (all_p[:, :1] >= 0.5)).any(axis=1).sum())
        out["flipped_mean_p_success_runs"] = float(all_p[all_y].mean()) if all_y.any() else None
        out["flipped_mean_p_failure_runs"] = float(all_p[~all_y].mean()) if (~all_y).any() else None
        out["flipped_p_spread_median"] = float(np.median(all_p.max(axis=1) - all_p.min(axis=1)))
    return out


def combine(args) -> None:
    from judgeopt.data.dataset import load

    ds = load(args.data)
    parts = [np.load(f) for f in args.combine]
    n = len(parts[0]["recorded"])
    recorded = ds.labels[:n].astype(int)
    for f, z in zip(args.combine, parts):
        if not (np.array_equal(z["recorded"], recorded) and np.array_equal(z["replay_label"], parts[0]["replay_label"])):
            raise SystemExit(f"{f}: not a result on the first {n} demonstrations of {args.data}")
    runs = np.concatenate([parts[0]["replay_label"][:, None]] + [z["labels"] for z in parts], axis=1)
    result = {"command": "python scripts/noise_floor.py " + " ".join(sys.argv[1:]), "data": str(args.data), "n": n,
              "combined": list(args.combine), "labels": analyse(runs, recorded, args.seed)}
    out = Path(args.out or REPO / "out" / "noise_floor" / f"{Path(args.data).stem}_combined.json")
    out.write_text(json.dumps(result, indent=1) + "\n")
    L = result["labels"]
    print(f"{args.data}: {n} demonstrations, recorded label + {runs.shape[1]} runs each")
    print(f"  labels flipped in >= 1 run: {L['flipped']}/{n} = {100 * L['flip_share']:.1f} % "
          f"(95 % {100 * L['flip_share_ci95'][0]:.1f}-{100 * L['flip_share_ci95'][1]:.1f}); p of those {L['p_of_flipped']}")
    print(f"  Bayes accuracy in [{100 * L['bayes_accuracy_lower']:.2f}, {100 * L['bayes_accuracy_upper']:.2f}] % "
          f"(95 % CI of the ends: {100 * L['bayes_accuracy_lower_ci95'][0]:.2f}-{100 * L['bayes_accuracy_upper_ci95'][1]:.2f}); "
          f"plug-in {100 * L['bayes_accuracy_plugin']:.2f} %")
    print(f"  -> {out}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", required=True, help="dataset (HDF5) to replay")
    ap.add_argument("--repeats", type=int, default=3, help="perturbed replays per demonstration (default 3)")
    ap.add_argument("--perturb", choices=sorted(DEFAULT_EPS), default="command")
    ap.add_argument("--eps", type=float, help="perturbation size (default: 1e-9 relative for command, 1e-7 m for object)")
    ap.add_argument("--n", type=int, help="first N demonstrations (default: all)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the perturbations and the bootstrap (default 0)")
    ap.add_argument("--judge", default="models/judge_demos_tcn", help="judge to score on the replays ('' : none)")
    ap.add_argument("--out", help="result JSON (default out/noise_floor/<stem>_<perturb>_r<R>[_n<N>].json)")
    ap.add_argument("--quiet", action="store_true")
    ap.add_argument("--combine", nargs="+", metavar="NPZ", help="pool these earlier results on --data (no replays)")
    args = ap.parse_args()
    if args.combine:
        return combine(args)

    from tqdm import tqdm

    from judgeopt.data.dataset import load
    from judgeopt.tasks import get_task

    eps = DEFAULT_EPS[args.perturb] if args.eps is None else args.eps
    ds = load(args.data)
    n = min(args.n or ds.n, ds.n)
    R = args.repeats
    stem = Path(args.data).stem
    out = Path(args.out or REPO / "out" / "noise_floor" / f"{stem}_{args.perturb}_r{R}{'' if n == ds.n else f'_n{n}'}.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    partial = out.with_name(out.stem + ".partial.npz")
    test = recorded_test(ds.meta)
    task = get_task(ds.task)
    sim = task.simulator()
    key = json.dumps({"data": hashlib.sha256(Path(args.data).read_bytes()).hexdigest(), "n": n, "R": R,
                      "perturb": args.perturb, "eps": eps, "seed": args.seed})

    orig_resp = np.full((n, *ds.responses.shape[1:]), np.nan)
    orig_label = np.full(n, -1)
    resp = np.full((n, R, *ds.responses.shape[1:]), np.nan)
    lab = np.full((n, R), -1)
    clear = np.full((n, R + 1), -1)  # the "clear" and "rise" tests' labels, both, for the record
    rise = np.full((n, R + 1), -1)
    done = 0
    if partial.exists():
        with np.load(partial) as z:
            if str(z["key"]) == key:
                done = int(z["done"])
                orig_resp, orig_label, resp, lab, clear, rise = (z[k].copy() for k in
                                                                 ("orig_resp", "orig_label", "resp", "lab", "clear", "rise"))

    def save_partial(k: int) -> None:
        tmp = partial.with_name(partial.name + ".tmp.npz")
        np.savez(tmp, key=key, done=k, orig_resp=orig_resp, orig_label=orig_label, resp=resp, lab=lab, clear=clear, rise=rise)
        tmp.replace(partial)

    t0 = time.perf_counter()
    bar = tqdm(total=n, initial=done, desc=f"replay {stem} ({args.perturb} x{R})", unit="demo", disable=args.quiet)
    for i in range(done, n):
        env = dict(zip(ds.env_names, map(float, ds.env[i])))
        c = np.array(ds.commands[i], dtype=float)
        o = sim.simulate(task.plan(c), env)
        orig_resp[i], orig_label[i] = o.response, int(o.details[f"success_{test}_test"])
        clear[i, 0], rise[i, 0] = o.details["success_clear_test"], o.details["success_rise_test"]
        for r in range(R):
            cp, ep = perturbed(args.perturb, eps, args.seed, ds.index[i] if ds.index is not None else i, r, c, env)
            o = sim.simulate(task.plan(cp), ep)
            resp[i, r], lab[i, r] = o.response, int(o.details[f"success_{test}_test"])
            clear[i, r + 1], rise[i, r + 1] = o.details["success_clear_test"], o.details["success_rise_test"]
        bar.update(1)
        if (i + 1) % 25 == 0 or i + 1 == n:
            save_partial(i + 1)
    bar.close()
    seconds = time.perf_counter() - t0

    recorded = ds.labels[:n].astype(int)
    same_resp = np.all(orig_resp == ds.responses[:n], axis=(1, 2))
    diff = np.abs(resp - orig_resp[:, None]).max(axis=(2, 3))  # (n, R): largest response change of each repeat
    runs = np.concatenate([orig_label[:, None], lab], axis=1)  # the exact replay is one more run
    runs_resp = np.concatenate([orig_resp[:, None], resp], axis=1)
    flips = (runs != recorded[:, None]).any(axis=1)
    result = {
        "command": "python scripts/noise_floor.py " + " ".join(sys.argv[1:]),
        "data": str(args.data), "n": n, "repeats": R, "perturb": args.perturb, "eps": eps, "seed": args.seed,
        "success_test": test, "seconds_this_run": round(seconds, 1),
        "replay": {
            "responses_bit_identical": int(same_resp.sum()),
            "labels_reproduced": int((orig_label == recorded).sum()),
            "largest_response_difference": float(np.abs(orig_resp - ds.responses[:n]).max()),
        },
        "response_change": {
            "median_of_largest": float(np.median(diff)), "share_changed_over_1e-6": float((diff > 1e-6).mean()),
            "share_changed_over_0.1": float((diff > 0.1).mean()), "max": float(diff.max()),
        },
        "clear_vs_rise_test_disagree": int((clear != rise).sum()),
        "labels_perturbed_only": analyse(lab, recorded, args.seed),
        "labels": analyse(runs, recorded, args.seed),
    }
    if args.judge:
        result["judge"] = judge_report(args.judge, ds, runs_resp, runs, flips)
    np.savez_compressed(out.with_suffix(".npz"), recorded=recorded, replay_label=orig_label, labels=lab,
                        replay_response=orig_resp.astype(np.float32),
                        responses=resp.astype(np.float32), clear=clear, rise=rise, index=ds.index[:n])
    out.write_text(json.dumps(result, indent=1) + "\n")
    partial.unlink(missing_ok=True)
    L = result["labels"]
    print(f"{args.data}: {n} demonstrations, {R} x {args.perturb} perturbation (eps {eps:g}), {seconds:.0f} s")
    print(f"  exact replay: responses bit-identical {result['replay']['responses_bit_identical']}/{n}, "
          f"labels reproduced {result['replay']['labels_reproduced']}/{n}")
    P = result["labels_perturbed_only"]
    print(f"  perturbed repeats alone: {P['flipped']}/{n} flipped, agreement per repeat {100 * P['agreement_mean']:.2f} %")
    print(f"  labels flipped in >= 1 of {R + 1} runs: {L['flipped']}/{n} = {100 * L['flip_share']:.1f} % "
          f"(95 % {100 * L['flip_share_ci95'][0]:.1f}-{100 * L['flip_share_ci95'][1]:.1f}); "
          f"agreement per run {100 * L['agreement_mean']:.2f} %")
    print(f"  Bayes accuracy in [{100 * L['bayes_accuracy_lower']:.2f}, {100 * L['bayes_accuracy_upper']:.2f}] % "
          f"(95 % CI of the ends: {100 * L['bayes_accuracy_lower_ci95'][0]:.2f}-{100 * L['bayes_accuracy_upper_ci95'][1]:.2f}); "
          f"plug-in {100 * L['bayes_accuracy_plugin']:.2f} %")
    if args.judge:
        J = result["judge"]
        print(f"  {args.judge}: {J['errors_recorded']} errors on recorded labels, {J['errors_on_flipped']} of them on "
              f"flipped demonstrations; accuracy on the replays {100 * J['accuracy_on_replays']:.2f} %")
    print(f"  -> {out}")


if __name__ == "__main__":
    main()
