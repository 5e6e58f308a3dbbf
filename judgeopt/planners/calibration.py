"""Calibrated confidence: what a planner's own replayed outcomes say its predictions are worth.

A planner that maximises a judge reports the judge's probability at the optimum, which is
exactly where the judge is most over-confident (docs/remedies.md: +18 to +48 points). Here,
per planner *setting* (method, judge, generator and every limit and solver option, but not
the environment), a small logistic model maps the judge's logit and the environment to the
probability that the plan succeeds in simulation. It is fitted on outcomes replayed by
`judgeopt evaluate` (`judgeopt calibrate FOLDER...`) and applied to new plans by every
planner. It knows only the settings and the environment ranges it was fitted on: another
setting gets no calibrated value, and environments outside the fitted ranges are flagged.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from judgeopt.files import atomic_write
from judgeopt.formats.header import check_header, header
from judgeopt.planners.problem import LIMIT_NAMES, SECTIONS, Problem, ProblemError

FORMAT, VERSION = "judgeopt-calibration", 1
LOGIT_CLIP = 12.0  # a judge saturates; beyond this its logit says nothing more
L2_GRID = (0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0, 1000.0)


class CalibrationError(ProblemError):
    """A calibration file that is missing, malformed or from another format."""


def setting_id(method: str, problem: Problem, shas: dict[str, str], over_limits: bool = False) -> str:
    """What a planner's outcomes depend on besides the environment: the method, the models'
    weights (by hash, not by path) and every limit and solver option. `over_limits`: the same
    without the limits, the key of a calibrator that takes the limits as inputs."""
    # the task is left out: the judge's hash already tells tasks apart (and ids fitted before tasks stay valid)
    skip = {"name", "description", "source", "task", "environment", *SECTIONS["models"]}
    skip |= set(LIMIT_NAMES) if over_limits else set()
    skip |= set() if method == "direct" else {"objective", "p_target"}  # the direct solve's alone
    skip |= set() if method == "receding" else {"replan_period", "replan_trigger"}
    p = {k: v for k, v in problem.to_dict().items() if k not in skip}
    blob = json.dumps({"method": method, "problem": p, "models": shas, "over_limits": over_limits or None},
                      sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def env_fingerprint(env: Iterable[float]) -> str:
    """Which environment a plan was made for (to tell fitted-on from held-out environments)."""
    return hashlib.sha256(json.dumps([round(float(v), 9) for v in env]).encode()).hexdigest()[:12]


def _logit(p: np.ndarray) -> np.ndarray:
    p = np.clip(np.asarray(p, float), 1e-12, 1 - 1e-12)
    return np.clip(np.log(p) - np.log1p(-p), -LOGIT_CLIP, LOGIT_CLIP)


@dataclass
class Calibrator:
    """Logistic regression on [1, judge logit, Gaussian bumps along each environment variable]."""

    setting: str
    method: str
    description: str
    env_names: list[str]
    env_low: list[float]
    env_high: list[float]
    bumps: int
    weights: list[float]
    l2: float
    n: int
    successes: int
    cv_log_loss: float  # 5-fold, at the chosen l2
    base_log_loss: float  # the constant (overall success rate) predictor, same folds
    fitted_on: list[str] = field(default_factory=list)  # environment fingerprints
    sources: list[str] = field(default_factory=list)
    constant: bool = False  # the map lost to the plain success rate in cross-validation, so it is the rate

    def features(self, env: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        env = np.atleast_2d(np.asarray(env, float))
        cols = [np.ones(len(env)), _logit(predicted) / LOGIT_CLIP]
        width = 1.0 / max(self.bumps - 1, 1)
        for j, (lo, hi) in enumerate(zip(self.env_low, self.env_high)):
            if hi <= lo:  # a fixed value: nothing to learn along it
                continue
            u = (env[:, j] - lo) / (hi - lo)
            cols += [np.exp(-0.5 * ((u - c) / width) ** 2) for c in np.linspace(0, 1, self.bumps)]
        return np.stack(cols, axis=1)

    def predict(self, env: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        z = self.features(env, predicted) @ np.asarray(self.weights)
        return 1.0 / (1.0 + np.exp(-z))

    def annotate(self, env: dict[str, float], predicted: float) -> dict[str, Any]:
        """What a plan's result carries: the calibrated success, and whether `env` is in the fitted ranges."""
        e = [[env[k] for k in self.env_names]]
        return {"calibrated_success": float(self.predict(e, [predicted])[0]), "calibration_covers": bool(self.covers(e)[0])}

    def covers(self, env: np.ndarray) -> np.ndarray:
        env = np.atleast_2d(np.asarray(env, float))
        tol = 1e-9 + 0.02 * (np.asarray(self.env_high) - np.asarray(self.env_low))
        return np.all((env >= np.asarray(self.env_low) - tol) & (env <= np.asarray(self.env_high) + tol), axis=1)


def _fit_logistic(X: np.ndarray, y: np.ndarray, l2: float, iters: int = 50) -> np.ndarray:
    """Newton's method on the L2-penalised log-likelihood (bias not penalised): convex, deterministic."""
    w = np.zeros(X.shape[1])
    pen = np.full(X.shape[1], l2)
    pen[0] = 0.0
    for _ in range(iters):
        p = 1.0 / (1.0 + np.exp(-(X @ w)))
        g = X.T @ (p - y) + pen * w
        H = (X * (p * (1 - p))[:, None]).T @ X + np.diag(pen + 1e-9)
        step = np.linalg.solve(H, g)
        w -= step
        if np.max(np.abs(step)) < 1e-8:
            break
    return w


def _log_loss(p: np.ndarray, y: np.ndarray) -> float:
    p = np.clip(p, 1e-6, 1 - 1e-6)
    return float(-np.mean(y * np.log(p) + (1 - y) * np.log(1 - p)))


def fit(setting: str, method: str, description: str, env_names: list[str], envs: np.ndarray,
        predicted: np.ndarray, outcomes: np.ndarray, bumps: int = 9, seed: int = 0,
        sources: list[str] | None = None) -> Calibrator:
    """Choose the penalty by 5-fold cross-validated log loss, then fit on all outcomes."""
    envs, predicted = np.asarray(envs, float), np.asarray(predicted, float)
    y = np.asarray(outcomes, float)
    if len(y) < 20:
        raise CalibrationError(f"{description}: {len(y)} outcomes are too few to calibrate on (need at least 20)")
    cal = Calibrator(setting, method, description, list(env_names), envs.min(0).tolist(), envs.max(0).tolist(),
                     bumps, [], 0.0, len(y), int(y.sum()), 0.0, 0.0,
                     sorted({env_fingerprint(e) for e in envs}), sorted(set(sources or [])))
    X = cal.features(envs, predicted)
    folds = np.random.default_rng(seed).permutation(len(y)) % 5
    scores = {}
    for l2 in L2_GRID:
        p = np.empty(len(y))
        for k in range(5):
            w = _fit_logistic(X[folds != k], y[folds != k], l2)
            p[folds == k] = 1.0 / (1.0 + np.exp(-(X[folds == k] @ w)))
        scores[l2] = _log_loss(p, y)
    base = np.empty(len(y))
    for k in range(5):
        base[folds == k] = np.clip(y[folds != k].mean(), 1e-3, 1 - 1e-3)
    cal.l2 = min(scores, key=scores.get)
    cal.cv_log_loss, cal.base_log_loss = scores[cal.l2], _log_loss(base, y)
    cal.weights = _fit_logistic(X, y, cal.l2).tolist()
    if cal.base_log_loss < cal.cv_log_loss:  # e.g. 1 failure in 100: nothing to map, report the rate
        r = float(np.clip(y.mean(), 1e-3, 1 - 1e-3))
        cal.weights = [float(np.log(r / (1 - r)))] + [0.0] * (X.shape[1] - 1)
        cal.constant = True
    return cal


def save_calibration(path: str | Path, calibrators: dict[str, Calibrator]) -> Path:
    path = Path(path)
    doc = {**header(FORMAT, VERSION), "settings": {k: asdict(c) for k, c in sorted(calibrators.items())}}
    atomic_write(path, (json.dumps(doc, indent=1) + "\n").encode())
    return path


def load_calibration(path: str | Path) -> dict[str, Calibrator]:
    path = Path(path)
    if not path.exists():
        raise CalibrationError(f"{path}: no such calibration file (make one with `judgeopt calibrate "
                               "out/evaluate/TABLE ... --out FILE`)")
    try:
        doc = json.loads(path.read_text())
        check_header(doc, str(path), FORMAT, VERSION, CalibrationError, "calibration file")
        out = {k: Calibrator(**v) for k, v in doc["settings"].items()}
    except (json.JSONDecodeError, KeyError, TypeError, AttributeError) as exc:
        raise CalibrationError(f"{path}: malformed calibration file ({exc}); refit it with `judgeopt calibrate`") from None
    for k, c in out.items():
        if len(c.weights) != c.features(np.array([c.env_low]), np.array([0.5])).shape[1]:
            raise CalibrationError(f"{path}: setting {k} has {len(c.weights)} weights, its features need a different "
                                   "number; refit it with `judgeopt calibrate`")
    return out


def inputs(limits: dict[str, Any], env: dict[str, float]) -> dict[str, float]:
    """A plan's limits and environment as a calibrator reads them: a per-axis limit (a task with
    several position axes) becomes one input per axis, `q_min[0]`, `q_min[1]`."""
    out: dict[str, float] = {}
    for k, v in limits.items():
        if isinstance(v, (list, tuple, np.ndarray)):
            out.update({f"{k}[{i}]": float(x) for i, x in enumerate(v)})
        else:
            out[k] = float(v)
    return {**out, **env}


def lookup(calibrators: dict[str, Calibrator], setting: str | None, family: str | None) -> Calibrator | None:
    """The calibrator for this exact setting, else one fitted over limits for its family."""
    return calibrators.get(setting or "") or calibrators.get(family or "")


def calibrate_rows(rows: list[dict], calibrators: dict[str, Calibrator], env_names: Iterable[str]) -> None:
    """Add `calibrated_success` (and whether the environment was in the fitted ranges) to
    evaluation rows whose setting has a calibrator; other rows are left as they are."""
    seen = {k: set(c.fitted_on) for k, c in calibrators.items()}
    for r in rows:
        cal = lookup(calibrators, r.get("setting"), r.get("family"))
        if cal is None or r.get("predicted_success") is None:
            continue
        values = inputs(r.get("limits", {}), r["environment"])
        r.update(cal.annotate(values, r["predicted_success"]))
        r["calibration_fitted_on_env"] = env_fingerprint([values[k] for k in cal.env_names]) in seen[cal.setting]


def fit_from_rows(rows: list[dict], descriptions: dict[str, str], env_names: list[str], min_n: int = 50,
                  sources: list[str] | None = None, over_limits: bool = False) -> dict[str, Calibrator]:
    """One calibrator per setting that has at least `min_n` replayed outcomes. `over_limits`:
    one per family of settings that differ only in their limits (rows of a sweep, or of
    evaluations under many limits), with the limits as inputs beside the environment."""
    key = "family" if over_limits else "setting"
    by: dict[str, list[dict]] = {}
    for r in rows:
        if r.get(key) and r.get("predicted_success") is not None and r.get("simulated_success") is not None:
            by.setdefault(r[key], []).append(r)
    out = {}
    for setting, rs in by.items():
        if len(rs) < min_n:
            continue
        names = list(env_names) + ([k for k in inputs(rs[0].get("limits", {}), {})] if over_limits else [])
        values = np.array([[inputs(r.get("limits", {}), r["environment"])[k] for k in names] for r in rs])
        description = descriptions.get(rs[0]["setting"], rs[0]["method"])
        if over_limits:  # the family's description: without the first row's limits
            description = re.sub(r"[,;] q̇_max [^,]*, f in \[[^\]]*\]", "", description) + ", over limits"
        out[setting] = fit(setting, rs[0]["method"], description, names,
                           values, np.array([r["predicted_success"] for r in rs]),
                           np.array([float(r["simulated_success"]) for r in rs]), sources=sources)
    return out


def describe(c: Calibrator) -> dict[str, Any]:
    return {"setting": c.setting, "description": c.description, "n": c.n, "success_pct": 100 * c.successes / c.n,
            "ranges": {k: [round(lo, 3), round(hi, 3)] for k, lo, hi in zip(c.env_names, c.env_low, c.env_high)},
            "cv_log_loss": round(c.cv_log_loss, 4), "constant_log_loss": round(c.base_log_loss, 4), "l2": c.l2}
