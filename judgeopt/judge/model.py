"""NN_judge (paper Fig. 2): an LSTM over the measured response, then feed-forward layers.

Per step the network reads x_k = [y, ydot, f] of the RESPONSE concatenated with the
environment e (repeated every step, as in Fig. 2), normalised by a mean/std fitted on the
training set. The normalisation lives in the module as buffers, so a saved judge and the
CasADi functions built from it take raw physical values and cannot drift from training.
"""

from __future__ import annotations

import copy
from dataclasses import asdict, dataclass, field
from typing import Any, Sequence

import numpy as np
import torch
from torch import nn

from judgeopt.trajectory import CHANNELS, DEFAULT_DT, DEFAULT_HORIZON, UNITS


class JudgeError(ValueError):
    """Base class of every judge error (a ValueError, so generic handlers catch it)."""


class TrajectoryError(JudgeError):
    """A trajectory or environment the judge cannot score: wrong shape or horizon, NaN."""


@dataclass
class JudgeConfig:
    """Architecture and the trajectory format the judge was trained on (paper Table 2)."""

    lstm_units: int = 100
    lstm_layers: int = 2
    fc_units: int = 102
    fc_layers: int = 2
    dropout: float = 0.3
    #: dropout between the two LSTM layers (training only). The paper does not say where its
    #: dropout 0.3 sits; applying it here too gained ~0.5 % validation accuracy (docs/judge.md)
    lstm_dropout: float = 0.3
    env_names: tuple[str, ...] = ("y_obj", "mu")
    channels: tuple[str, ...] = CHANNELS
    units: dict[str, str] = field(default_factory=lambda: dict(UNITS))
    horizon: int = DEFAULT_HORIZON
    dt: float = DEFAULT_DT

    def __post_init__(self) -> None:
        self.env_names = tuple(self.env_names)
        self.channels = tuple(self.channels)
        if self.lstm_units < 1 or self.lstm_layers < 1 or self.fc_units < 1 or self.fc_layers < 0:
            raise JudgeError(f"layer sizes must be positive: {self}")
        if not (0.0 <= self.dropout < 1.0 and 0.0 <= self.lstm_dropout < 1.0):
            raise JudgeError(f"dropout {self.dropout} and lstm_dropout {self.lstm_dropout} must be in [0, 1)")
        if self.horizon < 1 or not self.dt > 0:
            raise JudgeError(f"horizon {self.horizon} must be >= 1 and dt {self.dt} > 0")
        if len(set(self.env_names)) != len(self.env_names):
            raise JudgeError(f"env_names {self.env_names} repeat a name")

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
        d = asdict(self)
        d["env_names"], d["channels"] = list(self.env_names), list(self.channels)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "JudgeConfig":
        known = set(cls.__dataclass_fields__)
        unknown = set(d) - known
        if unknown:
            raise JudgeError(f"unknown judge config keys {sorted(unknown)}")
        return cls(**d)


def select_env(env: np.ndarray, available: Sequence[str], wanted: Sequence[str]) -> np.ndarray:
    """The columns `wanted` (by name) of an env array whose columns are named `available`.

    Why by name: a judge trained on (y_obj, mu) and one that sees only y_obj (paper Table 4)
    must both read the same dataset files without relying on column order.
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
        self.lstm = nn.LSTM(config.input_size, config.lstm_units, num_layers=config.lstm_layers, batch_first=True,
                            dropout=config.lstm_dropout if config.lstm_layers > 1 else 0.0)
        layers: list[nn.Module] = []
        width = config.lstm_units
        for _ in range(config.fc_layers):
            layers += [nn.Linear(width, config.fc_units), nn.ReLU(), nn.Dropout(config.dropout)]
            width = config.fc_units
        layers.append(nn.Linear(width, 1))
        self.head = nn.Sequential(*layers)

    # -- normalisation ------------------------------------------------------------------
    def fit_normalization(self, x: np.ndarray, e: np.ndarray) -> None:
        """Per-channel mean/std over all demonstrations and samples; std floored so a
        constant channel (e.g. a fixed mu) does not divide by zero."""
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
        """The LSTM input: normalised [x_k, e] at every step, (B, N+1, C+E)."""
        xn = (x - self.x_mean) / self.x_std
        en = ((e - self.e_mean) / self.e_std).unsqueeze(1).expand(-1, x.shape[1], -1)
        return torch.cat([xn, en], dim=-1)

    def forward(self, x: torch.Tensor, e: torch.Tensor) -> torch.Tensor:
        out, _ = self.lstm(self.features(x, e))
        return self.head(out[:, -1]).squeeze(-1)

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
        return 1.0 / (1.0 + np.exp(-self.predict_logit(x, e)))


class ConcatLSTMCell(nn.Module):
    """One LSTM layer step with the gates from ONE Linear over cat([x, h]).

    Why: l4casadi's TorchScript export breaks on nn.LSTM's mkldnn kernel and on a cell with
    two Linear layers after torch.jit.freeze (shared/notes/dependencies.md); this form
    exports cleanly. Gate order i, f, g, o as in nn.LSTM.
    """

    def __init__(self, input_size: int, hidden: int) -> None:
        super().__init__()
        self.hidden = hidden
        self.lin = nn.Linear(input_size + hidden, 4 * hidden)

    def forward(self, x: torch.Tensor, h: torch.Tensor, c: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        z = self.lin(torch.cat([x, h], dim=-1))
        H = self.hidden
        i, f, g, o = torch.sigmoid(z[..., :H]), torch.sigmoid(z[..., H:2 * H]), torch.tanh(z[..., 2 * H:3 * H]), \
            torch.sigmoid(z[..., 3 * H:])
        c = f * c + i * g
        return o * torch.tanh(c), c


def lstm_layer_weights(lstm: nn.LSTM) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per layer (W, b) with W = [W_ih | W_hh] (4H x (in + H)) and b = b_ih + b_hh, float64."""
    out = []
    for k in range(lstm.num_layers):
        w_ih, w_hh = getattr(lstm, f"weight_ih_l{k}"), getattr(lstm, f"weight_hh_l{k}")
        b_ih, b_hh = getattr(lstm, f"bias_ih_l{k}"), getattr(lstm, f"bias_hh_l{k}")
        W = torch.cat([w_ih, w_hh], dim=1).detach().double().numpy()
        b = (b_ih + b_hh).detach().double().numpy()
        out.append((W, b))
    return out


class UnrolledJudge(nn.Module):
    """The same judge as one flat input -> logit, the LSTM unrolled with ConcatLSTMCell.

    Input: a (1, (N+1)*C + E) row [x_0, ..., x_N (row-major), e] of raw values; output (1, 2)
    [logit, probability]. This is the form l4casadi (one matrix in, one out) needs.
    """

    def __init__(self, judge: Judge) -> None:
        super().__init__()
        cfg = judge.config
        self.n_steps, self.n_ch, self.n_env = cfg.horizon + 1, cfg.n_channels, cfg.n_env
        for name in ("x_mean", "x_std", "e_mean", "e_std"):
            self.register_buffer(name, getattr(judge, name).detach().clone())
        self.cells = nn.ModuleList()
        for k, (W, b) in enumerate(lstm_layer_weights(judge.lstm)):
            cell = ConcatLSTMCell(W.shape[1] - cfg.lstm_units, cfg.lstm_units)
            with torch.no_grad():
                cell.lin.weight.copy_(torch.as_tensor(W))
                cell.lin.bias.copy_(torch.as_tensor(b))
            self.cells.append(cell)
        self.head = copy.deepcopy(judge.head)  # a copy: .double() here must not touch the judge
        self.hidden = cfg.lstm_units
        self.to(next(judge.parameters()).dtype)

    def forward(self, inp: torch.Tensor) -> torch.Tensor:
        n = self.n_steps * self.n_ch
        x = (inp[:, :n].reshape(-1, self.n_steps, self.n_ch) - self.x_mean) / self.x_std
        e = (inp[:, n:n + self.n_env] - self.e_mean) / self.e_std
        B = inp.shape[0]
        hs = [torch.zeros(B, self.hidden, dtype=inp.dtype) for _ in self.cells]
        cs = [torch.zeros(B, self.hidden, dtype=inp.dtype) for _ in self.cells]
        for k in range(self.n_steps):
            u = torch.cat([x[:, k], e], dim=-1)
            for j, cell in enumerate(self.cells):
                hs[j], cs[j] = cell(u, hs[j], cs[j])
                u = hs[j]
        logit = self.head(u)
        return torch.cat([logit, torch.sigmoid(logit)], dim=-1)
