"""A training set too small for its validation split is refused in one line saying how many
demonstrations a class needs (it trained, and reported "validation accuracy nan"); the fix it names
works; and a recording given where a dataset belongs points to `judgeopt import-demos`."""

from __future__ import annotations

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.data.dataset import Dataset, DatasetError, load, save
from judgeopt.files import REPO
from judgeopt.judge.model import JudgeError
from judgeopt.judge.train import check_split, split_minimum, stratified_split

SMALL = ["--lstm-units", "4", "--fc-units", "4", "--epochs", "1", "--threads", "1", "--quiet"]


def _dataset(labels: list[int], horizon: int = 8, seed: int = 0) -> Dataset:
    """Scoop-shaped ramps (y, ydot, f) with the given labels."""
    rng = np.random.default_rng(seed)
    n, t = len(labels), np.linspace(0, 1, horizon + 1)
    y = -0.03 + rng.uniform(0.05, 0.35, n)[:, None] * (3 * t**2 - 2 * t**3)[None]
    x = np.stack([y, np.gradient(y, 0.05, axis=1), 12 + rng.standard_normal((n, horizon + 1))], axis=2)
    env = np.stack([rng.uniform(0.10, 0.28, n), rng.uniform(1, 3, n)], axis=1)
    return Dataset(x.copy(), x, np.array(labels, dtype=np.int64), env, 0.05, ("y_obj", "mu"))


@pytest.mark.parametrize("fraction", [0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.45, 0.49])
def test_the_minimum_per_class_is_where_the_split_itself_first_gives_both_sides(fraction):
    """Against stratified_split, the split training uses: the fewest of a class with at least one
    demonstration to validate on and one to train on."""
    first = next(n for n in range(1, 100) if all(
        len(part) >= 1 for part in stratified_split(np.zeros(n, dtype=int), fraction, seed=0)))
    assert split_minimum(fraction) == first
    check_split(np.array([0] * first + [1] * first), fraction)  # enough: nothing raised
    with pytest.raises(JudgeError, match=f"each class needs at least {first} demonstrations"):
        check_split(np.array([0] * first + [1] * (first - 1)), fraction)


def test_four_demonstrations_are_refused_in_one_line_and_nothing_is_written(tmp_path, capsys):
    data, out = tmp_path / "four.h5", tmp_path / "j"
    save(_dataset([1, 1, 0, 0]), data)
    assert main(["train-judge", "--train", str(data), "--out", str(out), *SMALL]) == 5
    captured = capsys.readouterr()
    assert captured.err.splitlines() == [
        f"judgeopt train-judge: error: --train {data}: 4 demonstrations (2 successes, 2 failures) are too few for a "
        "validation split of 0.1: each class needs at least 6 demonstrations (one or more to validate on, one or "
        "more to train on); add demonstrations or raise --val-fraction to 0.3"]
    assert "nan" not in captured.out and sorted(p.name for p in tmp_path.iterdir()) == ["four.h5"]


def test_the_fix_it_names_trains_with_a_real_validation_accuracy(tmp_path, capsys):
    import json

    data, out = tmp_path / "four.h5", tmp_path / "j"
    save(_dataset([1, 1, 0, 0]), data)
    assert main(["train-judge", "--train", str(data), "--out", str(out), "--val-fraction", "0.3", *SMALL]) == 0
    assert "validation accuracy nan" not in capsys.readouterr().out
    metrics = json.loads(out.with_suffix(".json").read_text())["metrics"]
    assert metrics["n_val"] == 2 and metrics["val_accuracy"] in (0.0, 0.5, 1.0)


def test_one_of_a_class_cannot_be_split_at_any_fraction(tmp_path):
    with pytest.raises(JudgeError, match=r"\(1 success, 4 failures\).* add demonstrations \(at least 2 per class at "
                                         r"any --val-fraction\)$"):
        check_split(np.array([1, 0, 0, 0, 0]), 0.1)


def test_a_csv_given_as_training_data_points_to_import_demos(tmp_path, capsys):
    csv = tmp_path / "demos.csv"
    csv.write_text((REPO / "data" / "example_demos.csv").read_text())
    assert main(["train-judge", "--train", str(csv), "--out", str(tmp_path / "j"), *SMALL]) == 5
    err = capsys.readouterr().err.strip()
    h5 = tmp_path / "demos.h5"
    assert err == (f"judgeopt train-judge: error: {csv}: a CSV recording, not a dataset; import it first with "
                   f"`judgeopt import-demos {csv} --out {h5}` and give {h5} instead")
    assert main(["import-demos", str(csv), "--out", str(h5)]) == 0  # the command it names works
    assert load(h5).n > 0
    (tmp_path / "other.h5").write_text("not HDF5 either\n")  # a dataset's suffix: the reader's own message
    with pytest.raises(DatasetError, match="not a readable HDF5 file"):
        load(tmp_path / "other.h5")
