"""NN_judge (paper Fig. 2): a network over the measured response (by default the paper's LSTM
then feed-forward layers; the architectures are in judgeopt.judge.archs), one logit.

Per step the network reads x_k = [y, ydot, f] of the RESPONSE concatenated with the
environment e (repeated every step, as in Fig. 2), normalised by a mean/std fitted on the
training set. The normalisation lives in the module as buffers, so a saved judge and the
CasADi functions built from it take raw physical values and cannot drift from training.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Any, Sequence

import numpy as np
import torch
from torch import nn

from judgeopt.judge.archs import DEFAULT_ARCH, SHARED_FIELDS, Arch, get_arch
# the LSTM's export forms lived here before the architectures had modules of their own
from judgeopt.judge.archs.lstm import ConcatLSTMCell, UnrolledJudge, lstm_layer_weights  # noqa: F401
from judgeopt.judge.compiled import sigmoid  # noqa: F401  (judge p's, here before the fast start had a module)
from judgeopt.judge.errors import JudgeError, TrajectoryError
from judgeopt.trajectory import CHANNELS, DEFAULT_DT, DEFAULT_HORIZON, UNITS


@dataclass(init=False)
class JudgeConfig:
    """The network (`arch` and its own fields, `net`) and the trajectory format the judge was
    trained on (paper Table 2).

    The architecture's fields are given as keywords and read as attributes
    (`JudgeConfig(lstm_units=8).lstm_units`); `to_dict` writes them flat beside `arch`, and a
    dict without `arch` (every judge file written before architectures had names) is an LSTM.
    """

    arch: str
    #: the architecture's fields: an instance of get_arch(arch).Config
    net: Any
    env_names: tuple[str, ...]
    channels: tuple[str, ...]
    units: dict[str, str]
    horizon: int
    dt: float

    def __init__(self, *, arch: str = DEFAULT_ARCH, net: Any = None, env_names: Sequence[str] | None = None,
                 channels: Sequence[str] = CHANNELS, units: dict[str, str] | None = None,
                 horizon: int = DEFAULT_HORIZON, dt: float = DEFAULT_DT, **net_fields: Any) -> None:
        spec = get_arch(arch)
        if isinstance(net, dict):
            net_fields, net = {**net, **net_fields}, None
        if net is None:
            unknown = set(net_fields) - {f.name for f in fields(spec.Config)}
            if unknown:
                raise JudgeError(f"the {arch} architecture has no field {', '.join(sorted(unknown))} (its fields: "
                                 f"{', '.join(f.name for f in fields(spec.Config))})")
            net = spec.Config(**net_fields)
        elif net_fields or not isinstance(net, spec.Config):
            raise JudgeError(f"net must be a {spec.Config.__name__} (the {arch} architecture's fields), given alone")
        self.arch, self.net = arch, net
        if env_names is None:  # the default task's, as the channels are
            from judgeopt.tasks import DEFAULT_TASK, get_task

            env_names = get_task(DEFAULT_TASK).env_names
        self.env_names, self.channels = tuple(env_names), tuple(channels)
        self.units = dict(UNITS) if units is None else dict(units)
        self.horizon, self.dt = horizon, dt
        if self.horizon < 1 or not self.dt > 0:
            raise JudgeError(f"horizon {self.horizon} must be >= 1 and dt {self.dt} > 0")
        if len(set(self.env_names)) != len(self.env_names):
            raise JudgeError(f"env_names {self.env_names} repeat a name")

    def __getattr__(self, name: str) -> Any:
        """The architecture's fields as attributes (config.lstm_units)."""
        net = self.__dict__.get("net")  # not self.net: copy and pickle call this before __dict__ is filled
        if net is not None and name in net.__dataclass_fields__:
            return getattr(net, name)
        raise AttributeError(f"{type(self).__name__} ({self.__dict__.get('arch')}) has no attribute {name!r}")

    @property
    def spec(self) -> Arch:
        """The architecture (judgeopt.judge.archs)."""
        return get_arch(self.arch)

    @property
    def n_channels(self) -> int:
        return len(self.channels)

    @property
    def n_env(self) -> int:
        return len(self.env_names)

    @property
    def input_size(self) -> int:
        return self.n_channels + self.n_env

    def to_dict(self) -> dict[str, Any]:
        """Flat: arch, the architecture's fields, then the trajectory format (what a judge file holds)."""
        return {"arch": self.arch, **asdict(self.net), "env_names": list(self.env_names),
                "channels": list(self.channels), "units": dict(self.units), "horizon": self.horizon, "dt": self.dt}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "JudgeConfig":
        d = dict(d)
        arch = d.pop("arch", DEFAULT_ARCH)  # files from before architectures had names: the LSTM
        own = {f.name for f in fields(get_arch(arch).Config)}
        unknown = set(d) - own - set(SHARED_FIELDS)
        if unknown:
            raise JudgeError(f"unknown judge config keys {sorted(unknown)} (the {arch} architecture's fields: "
                             f"{', '.join(sorted(own))})")
        return cls(arch=arch, **d)


def select_env(env: np.ndarray, available: Sequence[str], wanted: Sequence[str]) -> np.ndarray:
    """The columns `wanted` (by name) of an env array whose columns are named `available`.

    Why by name: a judge trained on every environment variable and one that sees only some of
    them (the paper's Table 4) must both read the same dataset files without relying on column order.
    """
    available = list(available)
    missing = [n for n in wanted if n not in available]
    if missing:
        raise TrajectoryError(f"the judge needs environment variables {missing}, the data has only {available}")
    return np.asarray(env)[..., [available.index(n) for n in wanted]]


class Judge(nn.Module):
    """P(success | response trajectory, environment); forward returns the logit.

    Inputs are raw physical values: x (B, N+1, channels) and e (B, E).
    """

    def __init__(self, config: JudgeConfig | None = None) -> None:
        super().__init__()
        self.config = config = config or JudgeConfig()
        c, e = config.n_channels, config.n_env
        # normalisation (identity until fit_normalization); buffers so they travel with state_dict
        self.register_buffer("x_mean", torch.zeros(c))
        self.register_buffer("x_std", torch.ones(c))
        self.register_buffer("e_mean", torch.zeros(e))
        self.register_buffer("e_std", torch.ones(e))
        # the architecture's layers, registered on the judge itself: a state_dict reads lstm.*, head.*
        # as it did before architectures had modules of their own
        for name, layer in config.spec.layers(config).items():
            if hasattr(self, name):
                raise TypeError(f"architecture {config.arch!r}: layer name {name!r} is taken by the Judge")
            self.add_module(name, layer)

    # -- normalisation ------------------------------------------------------------------
    def fit_normalization(self, x: np.ndarray, e: np.ndarray) -> None:
        """Per-channel mean/std over all demonstrations and samples; std floored so a
        constant channel (e.g. an environment variable held fixed) does not divide by zero."""
        x = np.asarray(x, dtype=np.float64).reshape(-1, self.config.n_channels)
        e = np.asarray(e, dtype=np.float64).reshape(-1, self.config.n_env)
        for name, a in (("x", x), ("e", e)):
            mean = a.mean(0) if len(a) else np.zeros(a.shape[1])
            std = a.std(0) if len(a) else np.ones(a.shape[1])
            std = np.where(std > 1e-6 * np.maximum(1.0, np.abs(mean)), std, 1.0)
            getattr(self, f"{name}_mean").copy_(torch.as_tensor(mean))
            getattr(self, f"{name}_std").copy_(torch.as_tensor(std))

    def normalization(self) -> dict[str, list[float]]:
        return {k: getattr(self, k).tolist() for k in ("x_mean", "x_std", "e_mean", "e_std")}

    # -- network ------------------------------------------------------------------------
    def features(self, x: torch.Tensor, e: torch.Tensor) -> torch.Tensor:
        """The network's input: normalised [x_k, e] at every step, (B, N+1, C+E)."""
        xn = (x - self.x_mean) / self.x_std
        en = ((e - self.e_mean) / self.e_std).unsqueeze(1).expand(-1, x.shape[1], -1)
        return torch.cat([xn, en], dim=-1)

    @property
    def arch(self) -> Arch:
        return self.config.spec

    def forward(self, x: torch.Tensor, e: torch.Tensor) -> torch.Tensor:
        return self.config.spec.logit(self, self.features(x, e))

    def logit(self, x: torch.Tensor, e: torch.Tensor) -> torch.Tensor:
        return self(x, e)

    def prob(self, x: torch.Tensor, e: torch.Tensor) -> torch.Tensor:
        return torch.sigmoid(self(x, e))

    # -- checked numpy entry points -------------------------------------------------------
    def check_inputs(self, x: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Validate and batch: (N+1, C) or (B, N+1, C) trajectories, (E,) or (B, E) env."""
        cfg = self.config
        x = np.asarray(x, dtype=np.float64)
        e = np.asarray(e, dtype=np.float64)
        if x.ndim == 2:
            x = x[None]
        if e.ndim == 1:
            e = e[None]
        if x.ndim != 3 or x.shape[2] != cfg.n_channels:
            raise TrajectoryError(f"trajectories must have shape (B, N+1, {cfg.n_channels}) for "
                                  f"{list(cfg.channels)}, got {x.shape}")
        if x.shape[1] != cfg.horizon + 1:
            raise TrajectoryError(f"trajectory horizon N = {x.shape[1] - 1} ({x.shape[1]} samples) differs from the "
                                  f"judge's N = {cfg.horizon} ({cfg.horizon + 1} samples at dt = {cfg.dt} s)")
        if e.shape != (x.shape[0], cfg.n_env):
            raise TrajectoryError(f"environment must have shape ({x.shape[0]}, {cfg.n_env}) for "
                                  f"{list(cfg.env_names)}, got {e.shape}")
        for name, a in (("trajectory", x), ("environment", e)):
            bad = ~np.isfinite(a)
            if bad.any():
                idx = tuple(int(i) for i in np.argwhere(bad)[0])
                raise TrajectoryError(f"{name} holds a non-finite value ({a[idx]!r}) at index {idx}")
        return x, e

    @torch.no_grad()
    def predict_logit(self, x: np.ndarray, e: np.ndarray, batch_size: int = 2048) -> np.ndarray:
        x, e = self.check_inputs(x, e)
        was_training = self.training
        self.eval()
        try:
            dtype = next(self.parameters()).dtype
            out = [self(torch.as_tensor(x[i:i + batch_size], dtype=dtype), torch.as_tensor(e[i:i + batch_size], dtype=dtype))
                   for i in range(0, len(x), batch_size)]
        finally:
            self.train(was_training)
        return torch.cat(out).double().numpy() if out else np.zeros(0)

    def predict_proba(self, x: np.ndarray, e: np.ndarray) -> np.ndarray:
        return sigmoid(self.predict_logit(x, e))

