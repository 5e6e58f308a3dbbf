"""Levers on a trained judge that need no retraining (issue 23, part 1.3), each chosen on the
judge's own VALIDATION split, never on a test set:

  threshold  the decision threshold that maximises validation accuracy (grid 0.05..0.95 in
             steps of 0.01; ties: the one nearest 0.5)
  noise      test-time augmentation: the mean probability over K = 16 copies of the input with
             the training augmentation's Gaussian noise (0.05 of the normalisation std, on the
             response and the environment; seeded)
  dropout    the mean probability over K = 16 passes with the network's dropout left on (MC dropout; seeded)
  shift      the mean probability over the response shifted by -1, 0 and +1 samples (50 ms; the
             end sample repeated)
  ensemble   the mean probability of the members of --ensemble (a different model, for comparison)

The validation split is the one `judgeopt train-judge` made: the training files concatenated in
the order the judge's JSON names them, `stratified_split(labels, val_fraction, seed)` of
judgeopt.judge.train with the judge's recorded seed and fraction (checked: the validation
accuracy at threshold 0.5 must equal the recorded one).

Every variant is scored on every --data file with a Wilson 95 % interval; "adopted" says
whether validation accuracy improved on the plain judge at 0.5, which is the only rule by which
a lever is chosen. Paired changes against the plain judge are given as discordant counts.

    .venv/bin/python scripts/judge_levers.py --data data/test.h5 data/test_seed2.h5 out/fresh_seed13.h5
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))
from noise_floor import wilson  # noqa: E402

K = 16
NOISE = 0.05
GRID = np.round(np.arange(0.05, 0.951, 0.01), 2)


def choose_threshold(p: np.ndarray, y: np.ndarray) -> float:
    acc = np.array([((p >= t) == y).mean() for t in GRID])
    best = np.flatnonzero(acc == acc.max())
    return float(GRID[best[np.argmin(np.abs(GRID[best] - 0.5))]])


def variants(model, ensemble, x: np.ndarray, e: np.ndarray, seed: int) -> dict[str, np.ndarray]:
    import torch

    out = {"plain": model.predict_proba(x, e)}
    xt, et = torch.as_tensor(x, dtype=torch.float32), torch.as_tensor(e, dtype=torch.float32)
    with torch.no_grad():
        model.eval()
        g = torch.Generator().manual_seed(seed)
        acc = torch.zeros(len(x), dtype=torch.float64)
        for _ in range(K):
            xn = xt + NOISE * model.x_std * torch.randn(xt.shape, generator=g)
            en = et + NOISE * model.e_std * torch.randn(et.shape, generator=g)
            acc += torch.sigmoid(model(xn, en)).double()
        out["noise"] = (acc / K).numpy()
        torch.manual_seed(seed)
        model.train()
        acc = torch.zeros(len(x), dtype=torch.float64)
        for _ in range(K):
            acc += torch.sigmoid(model(xt, et)).double()
        model.eval()
        out["dropout"] = (acc / K).numpy()
    shifted = [np.concatenate([x[:, :1], x[:, :-1]], axis=1), x, np.concatenate([x[:, 1:], x[:, -1:]], axis=1)]
    out["shift"] = np.mean([model.predict_proba(s, e) for s in shifted], axis=0)
    if ensemble:
        out["ensemble"] = np.mean([m.predict_proba(x, e) for m in ensemble], axis=0)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--judge", default="models/judge_demos_tcn")
    ap.add_argument("--ensemble", default="models/judge_ensemble", help="'' : none")
    ap.add_argument("--data", nargs="+", required=True)
    ap.add_argument("--seed", type=int, default=0, help="seed of the noise and dropout draws (default 0)")
    ap.add_argument("--out", default=str(REPO / "out" / "noise_floor" / "levers.json"))
    args = ap.parse_args()

    import torch

    from judgeopt.data.dataset import concatenate, load
    from judgeopt.judge.ensemble import load_ensemble
    from judgeopt.judge.model import select_env
    from judgeopt.judge.store import load_judge
    from judgeopt.judge.train import stratified_split

    torch.set_num_threads(1)
    model, meta = load_judge(args.judge)
    ensemble = load_ensemble(args.ensemble)[0] if args.ensemble else []
    tc = meta["train_config"]
    train = concatenate([load(REPO / p) for p in meta["train_data"]["path"].split(" + ")])
    _, va = stratified_split(train.labels, tc["val_fraction"], tc["seed"])
    val = train.subset(va)
    names = model.config.env_names

    def scores(ds):
        return variants(model, ensemble, ds.responses, select_env(ds.env, ds.env_names, names), args.seed)

    pv, yv = scores(val), val.labels.astype(bool)
    recorded_val = meta["metrics"]["val_accuracy"]
    base_val = float(((pv["plain"] >= 0.5) == yv).mean())
    chosen = {}
    for name, p in pv.items():
        t = choose_threshold(p, yv)
        chosen[name] = {"threshold": t, "val_accuracy_at_0.5": float(((p >= 0.5) == yv).mean()),
                        "val_accuracy_at_threshold": float(((p >= t) == yv).mean())}
    result = {"command": "python scripts/judge_levers.py " + " ".join(sys.argv[1:]), "judge": args.judge,
              "ensemble": args.ensemble, "k": K, "noise": NOISE, "seed": args.seed,
              "validation": {"n": int(len(va)), "recorded_val_accuracy": recorded_val, "val_accuracy_plain": base_val,
                             "split_reproduced": abs(base_val - recorded_val) < 1e-6, "variants": chosen},
              "data": {}}
    for name, c in chosen.items():
        c["adopted_at_0.5"] = name != "plain" and c["val_accuracy_at_0.5"] > base_val
        c["adopted_with_threshold"] = c["val_accuracy_at_threshold"] > base_val
    for path in args.data:
        ds = load(path)
        p, y = scores(ds), ds.labels.astype(bool)
        right0 = (p["plain"] >= 0.5) == y
        rows = {}
        for name in p:
            for label, t in (("0.5", 0.5), ("val threshold", chosen[name]["threshold"])):
                right = (p[name] >= t) == y
                k = int(right.sum())
                rows[f"{name} @ {label}"] = {"threshold": t, "accuracy": k / ds.n, "ci95": wilson(k, ds.n),
                                            "gained": int((right & ~right0).sum()), "lost": int((~right & right0).sum())}
        result["data"][path] = {"n": ds.n, "success_ratio": float(y.mean()), "rows": rows}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
    print(f"validation split: {len(va)} demonstrations, plain accuracy {base_val:.4f} (recorded {recorded_val:.4f})")
    for name, c in chosen.items():
        print(f"  {name:9s} val acc @0.5 {c['val_accuracy_at_0.5']:.4f}, threshold {c['threshold']:.2f} -> "
              f"{c['val_accuracy_at_threshold']:.4f}")
    for path, d in result["data"].items():
        print(f"{path} ({d['n']}, successes {d['success_ratio']:.3f})")
        for name, r in d["rows"].items():
            print(f"  {name:26s} t={r['threshold']:.2f} acc {r['accuracy']:.4f} "
                  f"[{r['ci95'][0]:.4f}, {r['ci95'][1]:.4f}]  +{r['gained']} -{r['lost']}")
    print(f"-> {args.out}")


if __name__ == "__main__":
    main()
