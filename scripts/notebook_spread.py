"""Measure how much a notebook's printed figures move when its in-notebook training is perturbed.

Why: a judge trained on a few hundred demonstrations is a chaotic computation. Two torch kernel sets
(another CPU, or ATEN_CPU_CAPABILITY) round differently in the last bit, Adam amplifies that about
tenfold per epoch, and after ~15 epochs the two trainings are as unlike as two seeds
(docs/testing.md, "Notebooks on any CPU"). So the spread over training seeds bounds what another CPU
can do to a figure, and tests/test_notebooks.py compares such figures within that spread.

Each run executes the notebook with every `TrainConfig(..., seed=SEED ...)` given `seed=SEED + k`
(the data the notebook makes are unchanged) and stores its masked outputs, one JSON per run under a
digest of the notebook's code (resumable: a run of the same code already stored is not repeated).
Then the figures declared in tests/test_notebooks.py are summarised per notebook: min, median, max
and standard deviation.

    .venv/bin/python scripts/notebook_spread.py notebooks/03_your_own_task.ipynb --runs 10
"""

from __future__ import annotations

import argparse
import hashlib
import json
import re
import statistics
import sys
import tempfile
from pathlib import Path

import nbformat

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
from tests.test_notebooks import FIGURES, execute_nb, outputs  # noqa: E402

TRAIN_SEED = re.compile(r"(TrainConfig\([^)]*?seed=)SEED\b")


def perturbed(path: Path, k: int) -> nbformat.NotebookNode:
    """The notebook with its trainings' seeds moved by k (k = 0: as committed)."""
    nb = nbformat.read(path, as_version=4)
    found = 0
    for cell in nb.cells:
        if cell.cell_type == "code":
            cell.source, n = TRAIN_SEED.subn(rf"\g<1>SEED + {k}", cell.source)
            found += n
    if not found:
        raise SystemExit(f"{path.name}: no TrainConfig(..., seed=SEED) to perturb")
    return nb


def code_digest(path: Path) -> str:
    """Of the notebook's code as committed: a stored run of other code is never reused."""
    nb = nbformat.read(path, as_version=4)
    return hashlib.sha256("\0".join(c.source for c in nb.cells if c.cell_type == "code").encode()).hexdigest()[:12]


def run(path: Path, k: int, store: Path) -> list:
    """The masked outputs of the notebook run with its trainings seeded SEED + k (stored, or made and stored)."""
    target = store / f"seed_{k}.json"
    if target.exists():
        return json.loads(target.read_text())
    with tempfile.TemporaryDirectory() as tmp:
        shown = outputs(execute_nb(perturbed(path, k), path, Path(tmp)), Path(tmp))
    tmp_target = target.with_suffix(".tmp")
    tmp_target.write_text(json.dumps(shown))
    tmp_target.replace(target)
    return shown


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("notebooks", nargs="+", type=Path)
    ap.add_argument("--runs", type=int, default=10, help="training seeds SEED + 0 .. SEED + runs - 1")
    ap.add_argument("--out", type=Path, default=REPO / "out" / "notebook_spread")
    args = ap.parse_args()
    for path in args.notebooks:
        path = path.resolve()
        store = args.out / path.stem / code_digest(path)
        store.mkdir(parents=True, exist_ok=True)
        runs = []
        for k in range(args.runs):
            runs.append(run(path, k, store))
            print(f"{path.stem}: run {k + 1}/{args.runs} stored in {store}", flush=True)
        for fig in FIGURES.get(path.stem, ()):
            per_run = [fig.values(shown) for shown in runs]
            for i, values in enumerate(zip(*per_run)):
                sd = statistics.stdev(values)
                print(f"  {fig.name} #{i + 1}: min {min(values):.4g}, median {statistics.median(values):.4g}, "
                      f"max {max(values):.4g}, sd {sd:.3g}; declared {fig.between[0]:g}-{fig.between[1]:g}")


if __name__ == "__main__":
    main()
