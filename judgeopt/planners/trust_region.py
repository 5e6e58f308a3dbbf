"""A trust region around the demonstrations: how far a plan is from what the judge has seen.

Why: the judge is only trustworthy near its data. This models the successful demonstrations'
commands (all N + 1 samples of [q, q̇, f], each feature standardised) with probabilistic PCA:
d principal directions with their variances, and one isotropic variance for the rest. The
distance of a plan is the Mahalanobis distance under that Gaussian,

    D(x)^2 = sum_i (w_i . z)^2 / lambda_i + (|z|^2 - sum_i (w_i . z)^2) / sigma^2,

a full-space distance (a plan cannot hide in the directions PCA dropped), smooth and cheap, so
the direct solve can hold D(x) <= bound as a hard constraint. Typical demonstrations sit near
sqrt(F) (F = 3 (N + 1) features); the fitted model records the demonstrations' quantiles of D
so a bound can be chosen in those terms.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from judgeopt.errors import BadInput
from judgeopt.files import atomic_write
from judgeopt.formats.header import check_header, header
from judgeopt.planners.problem import ProblemError

FORMAT = "judgeopt-trust-region"
VERSION = 1


class TrustRegionError(BadInput, ProblemError):
    """A trust-region model file that is missing or malformed."""


@dataclass
class TrustRegion:
    mean: np.ndarray  # (F,)
    scale: np.ndarray  # (F,)
    components: np.ndarray  # (d, F), orthonormal rows
    variances: np.ndarray  # (d,)
    sigma2: float
    quantiles: dict[str, float]

    def distance(self, x: np.ndarray) -> np.ndarray:
        """D for (F,) or (B, F) flattened plans (row-major [q, q̇, f] per sample)."""
        z = (np.atleast_2d(x) - self.mean) / self.scale
        p = z @ self.components.T
        d2 = (p ** 2 / self.variances).sum(1) + ((z ** 2).sum(1) - (p ** 2).sum(1)) / self.sigma2
        return np.sqrt(np.maximum(d2, 0.0))

    def casadi_distance2(self, x):
        """D(x)^2 as a CasADi expression of the flattened plan x (a column)."""
        import casadi as cs

        z = (x - cs.DM(self.mean)) / cs.DM(self.scale)
        p = cs.mtimes(cs.DM(self.components), z)
        return cs.sum1(p ** 2 / cs.DM(self.variances)) + (cs.sumsqr(z) - cs.sumsqr(p)) / self.sigma2


def fit_trust_region(commands: np.ndarray, components: int = 8) -> TrustRegion:
    """PPCA of (n, N + 1, 3) commands (the successful demonstrations')."""
    x = np.asarray(commands, float).reshape(len(commands), -1)
    if len(x) <= components:
        raise TrustRegionError(f"{len(x)} demonstrations cannot fit {components} components")
    mean = x.mean(0)
    scale = np.maximum(x.std(0), 1e-3 * max(x.std(0).max(), 1e-12))  # constant features (the start) stay finite
    z = (x - mean) / scale
    _, s, vt = np.linalg.svd(z, full_matrices=False)
    eig = s ** 2 / (len(z) - 1)
    rest = eig[components:]
    sigma2 = float(max(rest.mean() if rest.size else eig[-1], 1e-6))
    tr = TrustRegion(mean, scale, vt[:components], eig[:components], sigma2, {})
    d = tr.distance(x)
    tr.quantiles = {f"q{int(q * 100)}": float(np.quantile(d, q)) for q in (0.5, 0.9, 0.95, 0.99)}
    return tr


def save_trust_region(tr: TrustRegion, path: str | Path, meta: dict) -> Path:
    path = Path(path).with_suffix(".json")
    record = {**header(FORMAT, VERSION), **meta, "mean": tr.mean.tolist(), "scale": tr.scale.tolist(),
              "components": tr.components.tolist(), "variances": tr.variances.tolist(), "sigma2": tr.sigma2,
              "quantiles": tr.quantiles}
    atomic_write(path, (json.dumps(record) + "\n").encode())
    return path


def load_trust_region(path: str | Path, features: int | None = None) -> TrustRegion:
    path = Path(path).with_suffix(".json")
    if not path.exists():
        raise TrustRegionError(f"{path}: no such trust-region model (fit one with `judgeopt fit-trust-region`)")
    try:
        r = json.loads(path.read_text())
        check_header(r, str(path), FORMAT, VERSION, TrustRegionError, "trust-region model")
        tr = TrustRegion(np.array(r["mean"]), np.array(r["scale"]), np.array(r["components"]),
                         np.array(r["variances"]), float(r["sigma2"]), dict(r["quantiles"]))
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, TrustRegionError):
            raise
        raise TrustRegionError(f"{path}: corrupt trust-region model ({type(exc).__name__}: {exc})") from None
    if features is not None and tr.mean.size != features:
        raise TrustRegionError(f"{path}: fitted on {tr.mean.size} features, the problem's plans have {features} "
                               "(another horizon): refit it on matching demonstrations")
    return tr
