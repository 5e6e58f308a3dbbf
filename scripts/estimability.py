"""How much a motion's measured response says about its environment: a linear (ridge) estimator
of each environment variable from the first k measured samples (and their tracking error),
fitted on one dataset and scored on another. Why: a receding planner can only re-estimate what
the measurements carry (docs/planners.md).

    python scripts/estimability.py --train data/train_random.h5 --test data/test.h5
"""

from __future__ import annotations

import argparse

import numpy as np

from judgeopt.data.dataset import load


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--train", default="data/train_random.h5")
    ap.add_argument("--test", default="data/test.h5")
    ap.add_argument("--k", default="6,10,14,18,22", help="measured samples")
    args = ap.parse_args()
    tr, te = load(args.train), load(args.test)

    def features(ds, k):
        x, c = ds.responses[:, :k].reshape(ds.n, -1), ds.commands[:, :k].reshape(ds.n, -1)
        return np.hstack([x, x - c, np.ones((ds.n, 1))])

    print("| measured samples | variable | RMSE of the estimate | spread (std) in the test set |")
    print("|---|---|---|---|")
    for k in map(int, args.k.split(",")):
        f, ft = features(tr, k), features(te, k)
        for j, name in enumerate(tr.env_names):
            w = np.linalg.solve(f.T @ f + 1e-3 * np.eye(f.shape[1]), f.T @ tr.env[:, j])
            rmse = float(np.sqrt(np.mean((ft @ w - te.env[:, j]) ** 2)))
            print(f"| {k} | {name} | {rmse:.4f} | {te.env[:, j].std():.4f} |")


if __name__ == "__main__":
    main()
