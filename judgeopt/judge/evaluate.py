"""Metrics of a judge on any dataset: accuracy alone hides what the planner cares about.

The planner pushes trajectories toward high judged success probability, so false positives
(failures judged successful) and calibration matter as much as accuracy.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from judgeopt.data.dataset import Dataset
from judgeopt.judge.model import Judge, select_env
from judgeopt.judge.store import check_compatible
from judgeopt.judge.views import VIEWS


def classification_metrics(labels: np.ndarray, prob: np.ndarray, threshold: float = 0.5,
                           n_bins: int = 10) -> dict[str, Any]:
    """n, accuracy, precision, recall, F1, expected calibration error (equal-width bins),
    Brier score, and the confusion matrix [[TN, FP], [FN, TP]] (rows: true 0/1)."""
    y = np.asarray(labels).astype(int).ravel()
    p = np.asarray(prob, dtype=float).ravel()
    pred = (p >= threshold).astype(int)
    tp = int(((pred == 1) & (y == 1)).sum())
    tn = int(((pred == 0) & (y == 0)).sum())
    fp = int(((pred == 1) & (y == 0)).sum())
    fn = int(((pred == 0) & (y == 1)).sum())
    n = len(y)
    precision = tp / (tp + fp) if tp + fp else float("nan")
    recall = tp / (tp + fn) if tp + fn else float("nan")
    f1 = 2 * precision * recall / (precision + recall) if tp else 0.0
    return {
        "n": n,
        "accuracy": (tp + tn) / n if n else float("nan"),
        "precision": precision,
        "recall": recall,
        "f1": f1,
        "ece": expected_calibration_error(y, p, n_bins),
        "brier": float(np.mean((p - y) ** 2)) if n else float("nan"),
        "positive_ratio": float(y.mean()) if n else float("nan"),
        "confusion": [[tn, fp], [fn, tp]],
        "threshold": threshold,
    }


def expected_calibration_error(labels: np.ndarray, prob: np.ndarray, n_bins: int = 10) -> float:
    """sum_b (n_b / n) |mean label_b - mean prob_b| over equal-width probability bins."""
    y, p = np.asarray(labels, float).ravel(), np.asarray(prob, float).ravel()
    if not len(y):
        return float("nan")
    bins = np.minimum((p * n_bins).astype(int), n_bins - 1)
    ece = 0.0
    for b in range(n_bins):
        m = bins == b
        if m.any():
            ece += m.mean() * abs(y[m].mean() - p[m].mean())
    return float(ece)


def judge_inputs(model: Judge, ds: Dataset, view: str = "response") -> tuple[np.ndarray, np.ndarray]:
    """(responses or commands, the judge's env columns) after checking the dataset fits the judge."""
    check_compatible(model.config, horizon=ds.horizon, dt=ds.dt, channels=ds.channels, env_names=ds.env_names)
    if view not in VIEWS:
        raise ValueError(f"view {view!r}: one of {', '.join(VIEWS)}")
    return ds.responses if view == "response" else ds.commands, select_env(ds.env, ds.env_names, model.config.env_names)


def evaluate_judge(model: Judge, ds: Dataset, invert_labels: bool = False, view: str = "response") -> dict[str, Any]:
    """Metrics of `model` on `ds` (read as `view`) against the dataset's labels (or 1 - labels when asked)."""
    x, e = judge_inputs(model, ds, view)
    prob = model.predict_proba(x, e)
    labels = 1 - ds.labels if invert_labels else ds.labels
    return classification_metrics(labels, prob)


def format_metrics(m: dict[str, Any]) -> str:
    (tn, fp), (fn, tp) = m["confusion"]
    return "\n".join([
        f"  demonstrations   : {m['n']}  (successes {m['positive_ratio']:.3f})",
        f"  accuracy         : {m['accuracy']:.4f}",
        f"  precision        : " + (f"{m['precision']:.4f}" if m["precision"] == m["precision"]
                                    else "n/a (the judge never says success)"),
        f"  recall           : " + (f"{m['recall']:.4f}" if m["recall"] == m["recall"]
                                    else "n/a (no successes in the data)"),
        f"  calibration (ECE): {m['ece']:.4f}  (10 bins; Brier {m['brier']:.4f})",
        "  confusion matrix : rows true, columns judged",
        "                     failure  success",
        f"    true failure   : {tn:7d}  {fp:7d}",
        f"    true success   : {fn:7d}  {tp:7d}",
    ])
