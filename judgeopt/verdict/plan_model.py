"""A success model of the plan itself, fitted on replayed band plans of every planner at once.

A calibrator (judgeopt.verdict.calibration) maps the judge's p, the limits and the environment to
a calibrated p; it never sees the plan. At the edge of the scoop the confident failures are near
misses (the object 3.5-6 cm off the blade's centre, where 3.5 cm is a success) that the judge's p
and the inputs do not tell apart (docs/verdict.md, "Where the confident failures lie"). This model
also reads the plan's samples, the constraint set and the planner: a gradient-boosted classifier
(scikit-learn's HistGradientBoostingClassifier), its trees kept as flat arrays of numbers in the calibration
file and walked here with numpy, so a file from someone else is data, never code.

It covers a plan only inside what it was fitted on: the same judge, arm, planners, channels and
horizon, every limit and variable inside its fitted range, a constraint set of the kinds the bands
drew, and a plan whose constraint set is known. Its threshold for "likely" is set, per planner, on
out-of-fold p (each band folder scored by a model of the others; `out_of_fold`).
"""

from __future__ import annotations

import base64
from dataclasses import asdict, dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from judgeopt.robots import DEFAULT_ROBOT
from judgeopt.verdict.calibration import CalibrationError, inputs
from judgeopt.verdict.risk import PLAN_MODEL, RANGE_MARGIN

#: a constraint set's rate limits, as the model reads them (NaN: not set)
RATES = ("a_max", "jerk_max", "fdot_max")
#: the boosting's settings (scikit-learn's names); deterministic: no early stopping, no subsampling
BOOSTING = {"max_iter": 300, "learning_rate": 0.05, "max_leaf_nodes": 31, "early_stopping": False}
#: each node's fields and how they are stored (children are indices inside their own tree)
FIELDS = {"feature": "<i4", "threshold": "<f8", "nan_left": "u1", "left": "<i4", "right": "<i4", "leaf": "u1",
          "value": "<f8"}


def constraints_of(row: Mapping[str, Any]) -> Mapping[str, Any] | None:
    """A plan's constraint set as a row states it (a band's drawn set, or the problem's); None: unknown."""
    found = row.get("constraints", row.get("band_constraints"))
    return found if isinstance(found, Mapping) else None


@dataclass
class PlanModel:
    """P(success in simulation) from the judge's logit, the limits and environment (`names`), the
    constraint set, the planner and the plan's samples; its trees' nodes as flat arrays (`nodes`)."""

    names: list[str]
    low: list[float]
    high: list[float]
    planners: list[str]
    channels: list[str]
    samples: int  # knots per channel
    baseline: float  # the boosting's starting logit
    sizes: list[int]  # nodes per tree; the trees' nodes one after the other in `nodes`
    depth: int  # the deepest leaf's depth + 1: walks enough to reach every leaf
    nodes: dict[str, str]  # per field (FIELDS), the nodes' values as little-endian bytes in base64
    judge_sha256: str | None = None
    robot: str = DEFAULT_ROBOT
    n: int = 0
    successes: int = 0
    sources: list[str] = field(default_factory=list)

    def features(self, rows: Sequence[Mapping[str, Any]]) -> np.ndarray:
        out = []
        for r in rows:
            p = float(np.clip(r["predicted_success"], 1e-6, 1 - 1e-6))
            values = inputs(r.get("limits", {}), r["environment"])
            drawn = constraints_of(r) or {}
            rates = [np.nan if drawn.get(k) is None else float(drawn[k]) for k in RATES]
            out.append([np.log(p / (1 - p)), *(values[k] for k in self.names), *rates, float(bool(drawn.get("bounds"))),
                        *(float(r["method"] == m) for m in self.planners),
                        *(v for c in self.channels for v in np.asarray(r[c], float).ravel())])
        return np.array(out, float)

    def predict(self, X: np.ndarray) -> np.ndarray:
        """P(success) of each row of features: every tree walked at once (one plan's p with its features: 0.4 ms)."""
        X = np.atleast_2d(np.asarray(X, float))
        arrays = self._arrays
        node = np.tile(arrays["root"], (len(X), 1))  # (plans, trees): each plan's node in each tree
        rows = np.arange(len(X))[:, None]
        for _ in range(arrays["depth"]):
            x = X[rows, arrays["feature"][node]]
            left = np.where(np.isnan(x), arrays["nan_left"][node], x <= arrays["threshold"][node])
            node = np.where(arrays["leaf"][node], node, np.where(left, arrays["left"][node], arrays["right"][node]))
        z = self.baseline + arrays["value"][node].sum(axis=1)
        return np.exp(-np.logaddexp(0.0, -z))

    @property
    def _arrays(self) -> dict[str, Any]:
        """The nodes as arrays, children offset to the whole (made once per model)."""
        cached = self.__dict__.get("_flat")
        if cached is not None:
            return cached
        flat = {k: np.frombuffer(base64.b64decode(self.nodes[k]), dtype=t) for k, t in FIELDS.items()}
        roots = np.cumsum([0] + self.sizes[:-1])
        offset = np.repeat(roots, self.sizes)
        flat = {**{k: v.astype(bool) for k, v in flat.items() if k in ("leaf", "nan_left")},
                "feature": flat["feature"].astype(np.intp), "threshold": flat["threshold"], "value": flat["value"],
                "left": flat["left"] + offset, "right": flat["right"] + offset, "root": roots, "depth": self.depth}
        self.__dict__["_flat"] = flat
        return flat

    def covers(self, row: Mapping[str, Any], robot: str = DEFAULT_ROBOT) -> bool:
        """Inside what it was fitted on (the module's docstring)."""
        drawn = constraints_of(row)
        if (drawn is None or robot != self.robot or row.get("method") not in self.planners
                or any(isinstance(drawn.get(k), (list, tuple)) for k in RATES)  # per-axis rates: never drawn
                or row.get("judge_sha256", self.judge_sha256) != self.judge_sha256
                or any(drawn.get(k) not in (None, [], 0) for k in drawn if k not in (*RATES, "bounds"))
                or list(row.get("channels") or []) != self.channels
                or any(len(row[c]) != self.samples for c in self.channels)):
            return False
        values = inputs(row.get("limits", {}), row["environment"])
        for k, lo, hi in zip(self.names, self.low, self.high):
            tol = 1e-9 + RANGE_MARGIN * (hi - lo)
            if k not in values or not lo - tol <= values[k] <= hi + tol:
                return False
        return True

    def annotate(self, row: Mapping[str, Any], robot: str = DEFAULT_ROBOT) -> dict[str, Any]:
        """What a covered plan's result carries (as a calibrator's annotate, marked `calibrated_by`);
        nothing where the model does not cover it."""
        if not self.covers(row, robot):
            return {}
        return {"calibrated_success": float(self.predict(self.features([row]))[0]), "calibration_covers": True,
                "calibrated_by": PLAN_MODEL}

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str) -> "PlanModel":
        """The model as `to_dict` wrote it, checked: every field of every node there, children inside their tree."""
        try:
            m = cls(**{k: d[k] for k in cls.__dataclass_fields__ if k in d})
            total = sum(m.sizes)
            if not m.sizes or min(m.sizes) < 1 or len(m.low) != len(m.names) or len(m.high) != len(m.names):
                raise ValueError("no trees, or ranges of the wrong size")
            raw = {k: np.frombuffer(base64.b64decode(m.nodes[k], validate=True), dtype=t) for k, t in FIELDS.items()}
            if any(len(v) != total for v in raw.values()):
                raise ValueError(f"the nodes' fields are not {total} long each")
            width = 1 + len(m.names) + len(RATES) + 1 + len(m.planners) + len(m.channels) * m.samples
            size = np.repeat(m.sizes, m.sizes)
            inner = raw["leaf"] == 0
            if any(np.any((raw[k][inner] < 0) | (raw[k][inner] >= size[inner])) for k in ("left", "right")) or np.any(
                    (raw["feature"][inner] < 0) | (raw["feature"][inner] >= width)):
                raise ValueError("a tree points outside itself or its features")
        except (KeyError, TypeError, ValueError) as exc:  # binascii.Error is a ValueError
            raise CalibrationError(f"{where}: malformed plan model ({exc}); refit it with `judgeopt calibrate "
                                   "--plan-model FOLDER...`") from None
        return m


def _exported(clf: Any) -> tuple[float, list[int], int, dict[str, str]]:
    """A fitted HistGradientBoostingClassifier's starting logit and trees (binary classes), as stored."""
    trees = [predictor.nodes for (predictor,) in clf._predictors]
    names = {"feature": "feature_idx", "threshold": "num_threshold", "nan_left": "missing_go_to_left",
             "left": "left", "right": "right", "leaf": "is_leaf", "value": "value"}
    nodes = {k: base64.b64encode(np.concatenate([t[names[k]] for t in trees]).astype(FIELDS[k]).tobytes()).decode()
             for k in FIELDS}
    depth = max(int(t["depth"].max()) for t in trees) + 1
    return float(np.ravel(clf._baseline_prediction)[0]), [len(t) for t in trees], depth, nodes


def fit_plan_model(rows: Sequence[Mapping[str, Any]], sources: Sequence[str] = (), seed: int = 0) -> PlanModel:
    """One model over every replayed plan in `rows` (band rows: each states its constraint set)."""
    from sklearn.ensemble import HistGradientBoostingClassifier

    rows = [r for r in rows if r.get("predicted_success") is not None and r.get("simulated_success") is not None
            and r.get("channels") and constraints_of(r) is not None]
    if len(rows) < 100:
        raise CalibrationError(f"{len(rows)} replayed band plans are too few for a plan model (need at least 100; "
                               "`judgeopt evaluate band` makes them)")
    first = rows[0]
    names = sorted(inputs(first.get("limits", {}), first["environment"]))
    values = np.array([[inputs(r.get("limits", {}), r["environment"])[k] for k in names] for r in rows])
    judges = {r.get("judge_sha256") for r in rows}
    if len(judges) > 1:
        raise CalibrationError(f"the plans were judged by {len(judges)} judges; fit a plan model on one judge's")
    arms = {r.get("robot", DEFAULT_ROBOT) for r in rows}
    if len(arms) > 1:
        raise CalibrationError(f"the plans were replayed on {len(arms)} arms ({', '.join(sorted(arms))}); fit a plan "
                               "model on one arm's")
    channels = list(first["channels"])
    shapes = {(tuple(r["channels"]), *(len(r[c]) for c in r["channels"])) for r in rows}
    if len(shapes) > 1:
        raise CalibrationError(f"the plans have {len(shapes)} different sets of channels or horizons; fit a plan "
                               "model on plans of one task and horizon")
    model = PlanModel(names, values.min(0).tolist(), values.max(0).tolist(), sorted({r["method"] for r in rows}),
                      channels, len(first[channels[0]]), 0.0, [], 0, {}, judges.pop(), arms.pop(),
                      len(rows), sum(bool(r["simulated_success"]) for r in rows), sorted(set(sources)))
    y = np.array([bool(r["simulated_success"]) for r in rows])
    X = model.features(rows)
    X[:, np.isnan(X).all(axis=0)] = 0.0  # a rate no band drew: constant, so no tree splits on it
    clf = HistGradientBoostingClassifier(**BOOSTING, random_state=seed).fit(X, y)
    model.baseline, model.sizes, model.depth, model.nodes = _exported(clf)
    return model


def out_of_fold(folds: Mapping[str, Sequence[dict]], seed: int = 0) -> None:
    """Annotate each fold's rows with the p of a model fitted on the other folds (held out from it):
    what the evidence for "likely" is counted on. Rows the fold's model does not cover get nothing."""
    if len(folds) < 2:
        raise CalibrationError("a plan model's evidence needs at least two band folders (each is scored by a "
                               "model of the others)")
    for name, rows in folds.items():
        model = fit_plan_model([r for other, rs in folds.items() if other != name for r in rs], seed=seed)
        for r in rows:
            for key in ("calibrated_success", "calibration_covers", "calibrated_by"):
                r.pop(key, None)
            r.update(model.annotate(r, r.get("robot", DEFAULT_ROBOT)))


#: id of a stored section (shared by calibration.read_calibration_document's cache) -> (it, its model)
_MODELS: dict[int, tuple[dict, PlanModel]] = {}


def plan_model_of(section: dict | None, where: str) -> PlanModel | None:
    """The model a calibration file's stored section holds (None: none), made once per section read."""
    if section is None:
        return None
    kept = _MODELS.get(id(section))
    if kept is None or kept[0] is not section:
        _MODELS[id(section)] = kept = (section, PlanModel.from_dict(section, where))
    return kept[1]

