"""Calibrated confidence: what a planner's own replayed outcomes say its predictions are worth.

A planner that maximises a judge reports the judge's probability at the optimum, which is
exactly where the judge is most over-confident (docs/remedies.md: +18 to +48 points). Here,
per planner setting (method, models and solver options; over limits: with the limits as
inputs), a logistic map takes the judge's logit and the environment (and limits) to the
probability that the plan succeeds in simulation. The map never falls while the judge's p
rises at the same setting (its slope's weights are held >= 0), and it is applied only where
it *covers* a plan: inside every fitted range and near fitted outcomes in the joint space of
inputs and the judge's p (docs/remedies.md, "Calibration where outcomes flip"). Elsewhere the
planner reports the judge's own p, marked uncalibrated. Fitted by `judgeopt calibrate
FOLDER...` on outcomes replayed by `judgeopt evaluate` (densest where outcomes flip with
`judgeopt evaluate edge`).
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import asdict, dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np

from judgeopt.errors import BadInput
from judgeopt.files import atomic_write
from judgeopt.formats.header import check_header, header
from judgeopt.robots import DEFAULT_ROBOT
from judgeopt.verdict.risk import RANGE_MARGIN, Evidence  # a fitted range's margin, as the evidence's

FORMAT, VERSION = "judgeopt-calibration", 2
LOGIT_CLIP = 12.0  # a judge saturates; beyond this its logit says nothing more
L2_GRID = (0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0, 1000.0)
#: coverage in the joint space of inputs and judge logit: a request is covered when its
#: NEIGHBOURS-th nearest fitted outcome is no further than that of COVER_QUANTILE of the fitted ones
NEIGHBOURS = 5
COVER_QUANTILE = 0.95
#: at most this many fitted points are kept in the file to judge coverage by (seeded subsample)
MAX_POINTS = 3000
#: the folds of the cross-validation that chooses the penalty and measures the maps
FOLDS = 5


class CalibrationError(BadInput, ValueError):
    """A calibration file that is missing, malformed, from another format or for another judge."""


def env_fingerprint(env: Iterable[float]) -> str:
    """Which environment a plan was made for (to tell fitted-on from held-out environments)."""
    return hashlib.sha256(json.dumps([round(float(v), 9) for v in env]).encode()).hexdigest()[:12]


def _logit(p: np.ndarray) -> np.ndarray:
    p = np.clip(np.asarray(p, float), 1e-12, 1 - 1e-12)
    return np.clip(np.log(p) - np.log1p(-p), -LOGIT_CLIP, LOGIT_CLIP)


def _sigmoid(z: np.ndarray) -> np.ndarray:
    return np.exp(-np.logaddexp(0.0, -z))


@dataclass
class Calibrator:
    """P(success in simulation) = sigmoid(a(x) + s(x) z), with z the judge's logit and x the
    inputs (environment, and limits for a calibration over limits); a and s are sums of
    Gaussian bumps along each input, and every weight of s is >= 0, so the calibrated
    probability never falls while the judge's rises at the same x. It is trusted only near what
    it was fitted on, judged in the joint space of x and the judge's p (`covers`)."""

    setting: str
    method: str
    description: str
    env_names: list[str]  # the inputs x, by name
    env_low: list[float]
    env_high: list[float]
    bumps: int
    weights: list[float]  # [bias, slope, bumps of a..., bumps of s...]
    l2: float
    n: int
    successes: int
    cv_log_loss: float  # 5-fold, at the chosen l2
    base_log_loss: float  # the constant (overall success rate) predictor, same folds
    points: list[list[float]] = field(default_factory=list)  # fitted (x, judge's p), scaled (`_scaled`)
    cover_radius: float = 0.0
    judge_sha256: str | None = None
    alternatives: dict[str, float] = field(default_factory=dict)  # other maps' CV log loss on the same folds
    fitted_on: list[str] = field(default_factory=list)  # environment fingerprints
    sources: list[str] = field(default_factory=list)
    constant: bool = False  # the map lost to the plain success rate in cross-validation, so it is the rate

    def _varying(self) -> list[int]:
        return [j for j, (lo, hi) in enumerate(zip(self.env_low, self.env_high)) if hi > lo]

    def basis(self, env: np.ndarray) -> np.ndarray:
        """Gaussian bumps along each input that varied in the fitted outcomes (width: one spacing)."""
        env = np.atleast_2d(np.asarray(env, float))
        width = 1.0 / max(self.bumps - 1, 1)
        cols = []
        for j in self._varying():
            u = (env[:, j] - self.env_low[j]) / (self.env_high[j] - self.env_low[j])
            cols += [np.exp(-0.5 * ((u - c) / width) ** 2) for c in np.linspace(0, 1, self.bumps)]
        return np.stack(cols, axis=1) if cols else np.zeros((len(env), 0))

    def features(self, env: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        env = np.atleast_2d(np.asarray(env, float))
        z = (_logit(predicted) / LOGIT_CLIP)[:, None]
        b = self.basis(env)
        return np.hstack([np.ones((len(env), 1)), z, b, z * b])

    def predict(self, env: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        return _sigmoid(self.features(env, predicted) @ np.asarray(self.weights))

    def _scaled(self, env: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        """Each varying input on its fitted range's scale (0 to 1), and the judge's p (0 to 1: its
        saturated logits, 0.99 against 0.9999, are the same verdict; 0.002 against 0.99 are not)."""
        env = np.atleast_2d(np.asarray(env, float))
        lo, hi = np.asarray(self.env_low), np.asarray(self.env_high)
        j = self._varying()
        return np.hstack([(env[:, j] - lo[j]) / (hi[j] - lo[j]), np.asarray(predicted, float).reshape(-1, 1)])

    def covers(self, env: np.ndarray, predicted: np.ndarray) -> np.ndarray:
        """Inside every fitted range (RANGE_MARGIN beyond), equal on inputs that never varied, and
        near fitted outcomes in the joint space of inputs and judge logit."""
        env = np.atleast_2d(np.asarray(env, float))
        lo, hi = np.asarray(self.env_low), np.asarray(self.env_high)
        tol = 1e-9 + RANGE_MARGIN * (hi - lo)
        inside = np.all((env >= lo - tol) & (env <= hi + tol), axis=1)
        return inside & (kth_distance(self._scaled(env, predicted), self._points) <= self.cover_radius)

    @cached_property
    def _points(self) -> np.ndarray:
        """The fitted points as one array, made once per calibrator (not a field: never saved)."""
        return np.asarray(self.points, float)

    def annotate(self, env: dict[str, float], predicted: float) -> dict[str, Any]:
        """What a plan's result carries: the calibrated success, and whether the calibration covers it."""
        e = [[env[k] for k in self.env_names]]
        return {"calibrated_success": float(self.predict(e, [predicted])[0]),
                "calibration_covers": bool(self.covers(e, [predicted])[0])}


def kth_distance(query: np.ndarray, points: np.ndarray, k: int = NEIGHBOURS, chunk: int = 256) -> np.ndarray:
    """Each query's distance to its k-th nearest point, by brute force: a plan asks once against
    about a thousand fitted points (tens of microseconds), and scipy.spatial's k-d tree would
    cost half a second of import in every `solve` (benchmarks/bench_calibration.py)."""
    points = np.asarray(points, float)
    k = min(k, len(points))
    out = np.empty(len(query))
    for i in range(0, len(query), chunk):
        q = query[i:i + chunk]
        d2 = ((q[:, None, :] - points[None, :, :]) ** 2).sum(axis=2)
        out[i:i + chunk] = np.sqrt(np.partition(d2, k - 1, axis=1)[:, k - 1])
    return out


def _kth_distance_to_others(points: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Each point's distance to its NEIGHBOURS-th nearest point of *another* group (another planner
    setting: plans made under the same limits crowd together, and a new request is as far from
    them as one fitted setting is from the others)."""
    out = np.empty(len(points))
    for g in np.unique(groups):
        mine, others = groups == g, points[groups != g]
        out[mine] = kth_distance(points[mine], others) if len(others) else np.inf
    return out


def _fit_monotone(X: np.ndarray, y: np.ndarray, l2: float, n_basis: int) -> np.ndarray:
    """The L2-penalised logistic fit (bias not penalised) with the slope's weights >= 0, by
    scipy's L-BFGS-B: convex, so deterministic up to its tolerance."""
    from scipy.optimize import minimize

    pen = np.full(X.shape[1], l2)
    pen[0] = 0.0

    def loss(w: np.ndarray) -> tuple[float, np.ndarray]:
        z = X @ w
        p = _sigmoid(z)
        value = float(np.sum(np.logaddexp(0.0, z) - y * z) + 0.5 * np.sum(pen * w * w))
        return value, X.T @ (p - y) + pen * w

    bounds = [(None, None), (0.0, None)] + [(None, None)] * n_basis + [(0.0, None)] * n_basis
    res = minimize(loss, np.zeros(X.shape[1]), jac=True, method="L-BFGS-B", bounds=bounds,
                   options={"maxiter": 2000, "ftol": 1e-12, "gtol": 1e-8})
    return res.x


def _log_loss(p: np.ndarray, y: np.ndarray) -> float:
    p = np.clip(p, 1e-6, 1 - 1e-6)
    return float(-np.mean(y * np.log(p) + (1 - y) * np.log(1 - p)))


def _alternatives(X: np.ndarray, z: np.ndarray, y: np.ndarray, folds: np.ndarray, l2: float) -> dict[str, float]:
    """Scikit-learn's maps on the same folds, to measure the monotone map against: the same
    features without the sign constraint, and isotonic regression on the judge's logit alone."""
    from sklearn.isotonic import IsotonicRegression
    from sklearn.linear_model import LogisticRegression

    out = {}
    for name in ("logistic_unconstrained", "isotonic_judge_only"):
        p = np.empty(len(y))
        for k in range(FOLDS):
            tr, te = folds != k, folds == k
            if len(np.unique(y[tr])) < 2:
                p[te] = y[tr].mean()
            elif name == "isotonic_judge_only":
                p[te] = IsotonicRegression(y_min=1e-3, y_max=1 - 1e-3, out_of_bounds="clip").fit(z[tr], y[tr]).predict(z[te])
            else:
                m = LogisticRegression(C=1.0 / l2, max_iter=5000).fit(X[tr, 1:], y[tr])
                p[te] = m.predict_proba(X[te, 1:])[:, 1]
        out[name] = round(_log_loss(p, y), 5)
    return out


def fit(setting: str, method: str, description: str, env_names: list[str], envs: np.ndarray,
        predicted: np.ndarray, outcomes: np.ndarray, bumps: int = 9, seed: int = 0,
        sources: list[str] | None = None, judge_sha256: str | None = None,
        groups: Sequence[str] | None = None) -> Calibrator:
    """Choose the penalty by 5-fold cross-validated log loss, then fit on all outcomes; record
    the fitted points and the radius that judges coverage. `groups`: the planner setting of each
    outcome (default: each its own), so the radius is measured between settings."""
    envs, predicted = np.atleast_2d(np.asarray(envs, float)), np.asarray(predicted, float)
    y = np.asarray(outcomes, float)
    if len(y) < 20:
        raise CalibrationError(f"{description}: {len(y)} outcomes are too few to calibrate on (need at least 20)")
    cal = Calibrator(setting, method, description, list(env_names), envs.min(0).tolist(), envs.max(0).tolist(),
                     bumps, [], 0.0, len(y), int(y.sum()), 0.0, 0.0, judge_sha256=judge_sha256,
                     fitted_on=sorted({env_fingerprint(e) for e in envs}), sources=sorted(set(sources or [])))
    X = cal.features(envs, predicted)
    n_basis = (X.shape[1] - 2) // 2
    folds = np.random.default_rng(seed).permutation(len(y)) % FOLDS
    scores = {}
    for l2 in L2_GRID:
        p = np.empty(len(y))
        for k in range(FOLDS):
            p[folds == k] = _sigmoid(X[folds == k] @ _fit_monotone(X[folds != k], y[folds != k], l2, n_basis))
        scores[l2] = _log_loss(p, y)
    base = np.empty(len(y))
    for k in range(FOLDS):
        base[folds == k] = np.clip(y[folds != k].mean(), 1e-3, 1 - 1e-3)
    cal.l2 = min(scores, key=scores.get)
    cal.cv_log_loss, cal.base_log_loss = scores[cal.l2], _log_loss(base, y)
    cal.alternatives = _alternatives(X, X[:, 1], y, folds, cal.l2)
    cal.weights = _fit_monotone(X, y, cal.l2, n_basis).tolist()
    if cal.base_log_loss < cal.cv_log_loss:  # e.g. 1 failure in 100: nothing to map, report the rate
        r = float(np.clip(y.mean(), 1e-3, 1 - 1e-3))
        cal.weights = [float(np.log(r / (1 - r)))] + [0.0] * (X.shape[1] - 1)
        cal.constant = True
    pts = cal._scaled(envs, predicted)
    groups = np.asarray(groups) if groups is not None else np.arange(len(pts))
    cal.cover_radius = float(np.quantile(_kth_distance_to_others(pts, groups), COVER_QUANTILE))
    if len(pts) > MAX_POINTS:
        pts = pts[np.sort(np.random.default_rng(seed).choice(len(pts), MAX_POINTS, replace=False))]
    cal.points = np.round(pts, 6).tolist()
    return cal


def save_calibration(path: str | Path, calibrators: dict[str, Calibrator],
                     evidence: dict[str, Evidence] | None = None, plan_model: dict[str, Any] | None = None) -> Path:
    """The calibrators, the held-out evidence that sets the risk behind "likely" (judgeopt.verdict.risk),
    and a plan model (judgeopt.verdict.plan_model, as its to_dict) where there is one."""
    path = Path(path)
    doc = {**header(FORMAT, VERSION), "settings": {k: asdict(c) for k, c in sorted(calibrators.items())}}
    if evidence:
        doc["evidence"] = {k: e.to_dict() for k, e in sorted(evidence.items())}
    if plan_model:
        doc["plan_model"] = plan_model
    atomic_write(path, (json.dumps(doc, indent=1) + "\n").encode())
    return path


def load_calibration_file(path: str | Path) -> tuple[dict[str, Calibrator], dict[str, Evidence]]:
    """Every calibrator in the file and its held-out evidence per planner and judge
    (judgeopt.verdict.risk.evidence_key; empty where it has none: every verdict's risk is then
    unchecked), validated: a version-1 file (coverage judged axis by axis, no monotone map) is
    refused with the command that refits it."""
    return load_calibration_document(path)[:2]


def load_calibration_document(path: str | Path) -> tuple[dict[str, Calibrator], dict[str, Evidence], dict | None]:
    """load_calibration_file, and the file's plan model as stored (None: it has none; validated where it
    is read, by judgeopt.verdict.plan_model.PlanModel.from_dict)."""
    path = Path(path)
    if path.is_dir():
        raise CalibrationError(f"{path}: a folder, not a calibration file (give the .json that "
                               "`judgeopt calibrate --out FILE` wrote)")
    if not path.exists():
        raise CalibrationError(f"{path}: no such calibration file (make one with `judgeopt calibrate "
                               "out/evaluate/TABLE ... --out FILE`)")
    try:
        doc = json.loads(path.read_text())
        found = check_header(doc, str(path), FORMAT, VERSION, CalibrationError, "calibration file")
        if found < VERSION:
            raise CalibrationError(f"{path}: calibration format version {found} (coverage judged axis by axis, not "
                                   f"monotone in the judge) is no longer read; refit it with `judgeopt calibrate "
                                   f"FOLDER... --over-limits --out {path}`")
        out = {k: Calibrator(**v) for k, v in doc["settings"].items()}
    except (json.JSONDecodeError, KeyError, TypeError, AttributeError) as exc:
        raise CalibrationError(f"{path}: malformed calibration file ({exc}); refit it with `judgeopt calibrate`") from None
    for k, c in out.items():
        width = len(c._varying()) + 1
        if len(c.weights) != c.features(np.array([c.env_low]), np.array([0.5])).shape[1] or not c.points or any(
                len(p) != width for p in c.points):
            raise CalibrationError(f"{path}: setting {k} has weights or fitted points of the wrong size for its "
                                   "inputs; refit it with `judgeopt calibrate`")
    try:
        evidence = {k: Evidence.from_dict(v) for k, v in doc.get("evidence", {}).items()}
        for k, e in evidence.items():
            if not e.grid or any(set(g) != {"threshold", "n", "failures", "bound"} for g in e.grid):
                raise ValueError(f"evidence {k} has no threshold table")
    except (TypeError, ValueError, AttributeError) as exc:
        raise CalibrationError(f"{path}: malformed evidence ({exc}); recompute it with `judgeopt calibrate "
                               f"--evidence FOLDER... --out {path}`") from None
    plan_model = doc.get("plan_model")
    if plan_model is not None and not isinstance(plan_model, dict):
        raise CalibrationError(f"{path}: malformed plan model (not an object); refit it with `judgeopt calibrate "
                               f"--plan-model FOLDER... --out {path}`")
    return out, evidence, plan_model


#: resolved path -> ((modification time, size), (calibrators, evidence), plan model section) as read there
_READ: dict[str, tuple[tuple[int, int], tuple[dict[str, Calibrator], dict[str, Evidence]], dict | None]] = {}


def read_calibration_file(path: str | Path) -> tuple[dict[str, Calibrator], dict[str, Evidence]]:
    """load_calibration_file, read again only where the file changed (its modification time or
    size): a service's worker loads planners for every new environment or limits, and parsing the
    file cost each such request about 25 ms. The objects are shared by every caller: read them,
    never change them (load_calibration_file gives a copy of one's own)."""
    return _kept(path)[1]


def read_calibration_document(path: str | Path) -> tuple[dict[str, Calibrator], dict[str, Evidence], dict | None]:
    """read_calibration_file, and the file's plan model section (shared too)."""
    kept = _kept(path)
    return (*kept[1], kept[2])


def _kept(path: str | Path) -> tuple[Any, tuple[dict[str, Calibrator], dict[str, Evidence]], dict | None]:
    path = Path(path)
    try:
        st = path.stat()
    except OSError:
        calibrators, evidence, section = load_calibration_document(path)  # its own message for a missing file
        return None, (calibrators, evidence), section
    key, stamp = str(path.resolve()), (st.st_mtime_ns, st.st_size)
    kept = _READ.get(key)
    if kept is None or kept[0] != stamp:
        calibrators, evidence, section = load_calibration_document(path)
        _READ[key] = kept = (stamp, (calibrators, evidence), section)
    return kept


def load_calibration(path: str | Path) -> dict[str, Calibrator]:
    """Every calibrator in the file, validated (load_calibration_file)."""
    return load_calibration_file(path)[0]


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


def lookup(calibrators: dict[str, Calibrator], setting: str | None, family: str | None,
           constrained_family: str | None = None) -> Calibrator | None:
    """The calibrator for this exact setting, else one fitted over limits for its family, else (a plan
    under a constraint set) one fitted over limits and constraint sets."""
    return calibrators.get(setting or "") or calibrators.get(family or "") or calibrators.get(constrained_family or "")


def calibrate_rows(rows: list[dict], calibrators: dict[str, Calibrator], plan_model: Any = None) -> None:
    """Add `calibrated_success` (and whether the calibration covers the plan) to
    evaluation rows whose setting has a calibrator, or that `plan_model` (a
    judgeopt.verdict.plan_model.PlanModel) covers: its p then stands. What an earlier calibration wrote into a row
    (a chunk planned before this one was fitted) is dropped first: rows say what `calibrators` say."""
    seen = {k: set(c.fitted_on) for k, c in calibrators.items()}
    for r in rows:
        for key in ("calibrated_success", "calibration_covers", "calibration_fitted_on_env", "calibrated_by"):
            r.pop(key, None)
        if r.get("predicted_success") is None:
            continue
        if plan_model is not None:
            r.update(plan_model.annotate(r, r.get("robot", DEFAULT_ROBOT)))
            if r.get("calibrated_by"):
                continue
        cal = lookup(calibrators, r.get("setting"), r.get("family"), r.get("constrained_family"))
        if cal is None:
            continue
        values = inputs(r.get("limits", {}), r["environment"])
        r.update(cal.annotate(values, r["predicted_success"]))
        r["calibration_fitted_on_env"] = env_fingerprint([values[k] for k in cal.env_names]) in seen[cal.setting]


def for_judge(calibrators: dict[str, Calibrator], judge_sha256: str, path: str | Path) -> dict[str, Calibrator]:
    """The calibrators fitted for this judge (or that do not record which). A file whose every
    calibrator names another judge is refused: its numbers would describe another judge's plans."""
    mine = {k: c for k, c in calibrators.items() if c.judge_sha256 in (None, judge_sha256)}
    if calibrators and not mine:
        raise CalibrationError(f"{path}: fitted for another judge (weights {sorted({c.judge_sha256[:12] for c in calibrators.values()})}, "
                               f"this one {judge_sha256[:12]}); refit it with `judgeopt evaluate ... --judge JUDGE` and "
                               "`judgeopt calibrate FOLDER --out FILE`, or leave --calibration out")
    return mine


def fit_from_rows(rows: list[dict], descriptions: dict[str, str], env_names: list[str], min_n: int = 50,
                  sources: list[str] | None = None, over_limits: bool = False) -> dict[str, Calibrator]:
    """One calibrator per setting that has at least `min_n` replayed outcomes. `over_limits`:
    one per family of settings that differ only in their limits (rows of a sweep, or of
    evaluations under many limits), with the limits as inputs beside the environment; plans under a
    constraint set in one per family over limits and constraint sets (a band draws a set per setting)."""
    by: dict[str, list[dict]] = {}
    for r in rows:
        key = r.get("constrained_family") or r.get("family") if over_limits else r.get("setting")
        if key and r.get("predicted_success") is not None and r.get("simulated_success") is not None:
            by.setdefault(key, []).append(r)
    out = {}
    for setting, rs in by.items():
        if len(rs) < min_n:
            continue
        first = rs[0]  # a family's rows share their method and their limits' names
        names = list(env_names) + ([k for k in inputs(first.get("limits", {}), {})] if over_limits else [])
        values = np.array([[inputs(r.get("limits", {}), r["environment"])[k] for k in names] for r in rs])
        description = descriptions.get(first["setting"], first["method"])
        if over_limits:  # the family's description: without the first row's limits
            description = re.sub(r"[,;] q̇_max [^,]*, f in \[[^\]]*\]", "", description) + (
                ", over limits and constraint sets" if first.get("constrained_family") else ", over limits")
        judges = {r.get("judge_sha256") for r in rs}
        out[setting] = fit(setting, first["method"], description, names,
                           values, np.array([r["predicted_success"] for r in rs]),
                           np.array([float(r["simulated_success"]) for r in rs]), sources=sources,
                           judge_sha256=judges.pop() if len(judges) == 1 else None,
                           groups=[r["setting"] if over_limits else env_fingerprint(r["environment"].values())
                                   for r in rs])
    return out


def describe(c: Calibrator) -> dict[str, Any]:
    return {"setting": c.setting, "description": c.description, "n": c.n, "success_pct": 100 * c.successes / c.n,
            "ranges": {k: [round(lo, 3), round(hi, 3)] for k, lo, hi in zip(c.env_names, c.env_low, c.env_high)},
            "cv_log_loss": round(c.cv_log_loss, 4), "constant_log_loss": round(c.base_log_loss, 4), "l2": c.l2,
            **{f"{k}_log_loss": v for k, v in c.alternatives.items()}, "cover_radius": round(c.cover_radius, 4)}
