"""What a judge architecture is: the seam between the judge (normalisation, checks, files,
training, CasADi) and the network that reads the normalised trajectory.

An architecture names itself, declares its fields as a typed dataclass (`Config`: the
defaults live there and only there, checked in its `__post_init__`), builds its torch layers
from a JudgeConfig, maps the normalised features to one logit, and says how it is exported to
CasADi. l4casadi takes any torch module, so `flat_module` has a generic default; the `native`
and `compiled` backends need the network as a CasADi MX graph, which only an architecture
that sets `casadi_graph = True` and writes `native_logit` offers.
"""

from __future__ import annotations

from dataclasses import fields
from typing import Any, ClassVar

import torch
from torch import nn

from judgeopt.judge.errors import JudgeError


class Arch:
    """One architecture of the judge's network. Subclass it in a module of its own under
    judgeopt/judge/archs/ and add it to ARCHS in judgeopt/judge/archs/__init__.py."""

    #: the name files and `judgeopt train-judge --arch` use
    name: ClassVar[str]
    #: a dataclass of the architecture's own fields with their defaults; validates in __post_init__
    #: (raise JudgeError). Its field names must differ from JudgeConfig's shared ones.
    Config: ClassVar[type]
    #: offers `native_logit`, so the CasADi backends "native" and "compiled"
    casadi_graph: ClassVar[bool] = False

    def layers(self, config: Any) -> dict[str, nn.Module]:
        """The torch layers for `config` (a JudgeConfig; its architecture fields are `config.net`,
        the input width `config.input_size`), in the order they are created (that order draws
        the initial weights from torch's generator). The judge registers them under these names,
        so they are the state_dict's keys."""
        raise NotImplementedError

    def logit(self, judge: nn.Module, u: torch.Tensor) -> torch.Tensor:
        """(B,) logits from the normalised features u (B, N+1, C+E) ([x_k, e] every step),
        reading the layers as attributes of `judge`."""
        raise NotImplementedError

    def describe(self, net: Any) -> str:
        """One line for `judgeopt inspect`, e.g. "LSTM 2 x 100, FC 2 x 102, dropout 0.3"."""
        return ", ".join(f"{f.name} {getattr(net, f.name)}" for f in fields(net))

    def flat_module(self, judge: nn.Module) -> nn.Module:
        """The judge as one flat row [x_0, ..., x_N (row-major), e] of raw values -> (1, 2)
        [logit, probability], normalising with buffers named x_mean, x_std, e_mean, e_std: what
        l4casadi traces. The default is the judge itself; override it where the torch layers do
        not trace (the LSTM's mkldnn kernel)."""
        return FlatJudge(judge)

    def flat_module32(self, judge: nn.Module) -> nn.Module:
        """The same flat row -> (1, 2) [logit, probability] in FLOAT32, for the l4casadi32 backend
        (only its value and its reverse-mode derivative are traced, with grad mode off in the
        backward). The default is flat_module in float32; override it where a faster form
        traces (the LSTM's fused oneDNN layer)."""
        return self.flat_module(judge).float()

    def native_logit(self, judge: nn.Module, u: Any) -> Any:
        """The logit (1 x 1 casadi.MX) from the normalised features u ((C+E) x (N+1) MX, one
        column per step). Only where casadi_graph is True."""
        raise JudgeError(f"the {self.name} architecture has no CasADi graph")


class FlatJudge(nn.Module):
    """Any judge as the flat row -> [logit, probability] l4casadi needs (one matrix in, one out)."""

    def __init__(self, judge: nn.Module) -> None:
        super().__init__()
        import copy

        cfg = judge.config
        self.judge = copy.deepcopy(judge)  # a copy: .double() on this must not touch the judge
        self.n_steps, self.n_ch, self.n_env = cfg.horizon + 1, cfg.n_channels, cfg.n_env

    def forward(self, inp: torch.Tensor) -> torch.Tensor:
        n = self.n_steps * self.n_ch
        logit = self.judge(inp[:, :n].reshape(-1, self.n_steps, self.n_ch), inp[:, n:n + self.n_env]).unsqueeze(-1)
        return torch.cat([logit, torch.sigmoid(logit)], dim=-1)


class Flat32(nn.Module):
    """What every float32 flat module (the l4casadi32 backend's) shares: the judge's sizes, its
    normalisation buffers and head in float32, the normalised (B, T, C + E) features of a
    (B, (N+1)*C + E) row of raw values, and the (B, 2) [logit, probability] output. casadi_fn
    sets the buffers to 0 and 1 and normalises in CasADi."""

    def __init__(self, judge: nn.Module) -> None:
        super().__init__()
        import copy

        cfg = judge.config
        self.n_steps, self.n_ch, self.n_env = cfg.horizon + 1, cfg.n_channels, cfg.n_env
        for name in ("x_mean", "x_std", "e_mean", "e_std"):
            self.register_buffer(name, getattr(judge, name).detach().float().clone())
        self.head = copy.deepcopy(judge.head).float()

    def features(self, inp: torch.Tensor) -> torch.Tensor:
        n, T, B = self.n_steps * self.n_ch, self.n_steps, inp.shape[0]
        x = (inp[:, :n].reshape(B, T, self.n_ch) - self.x_mean) / self.x_std
        e = ((inp[:, n:n + self.n_env] - self.e_mean) / self.e_std).unsqueeze(1).expand(B, T, self.n_env)
        return torch.cat([x, e], dim=-1)

    def output(self, features: torch.Tensor) -> torch.Tensor:
        logit = self.head(features)
        return torch.cat([logit, torch.sigmoid(logit)], dim=-1)


def fc_head(width: int, units: int, layers: int, dropout: float) -> nn.Sequential:
    """`layers` x (Linear to `units`, ReLU, Dropout), then Linear to one logit."""
    out: list[nn.Module] = []
    for _ in range(layers):
        out += [nn.Linear(width, units), nn.ReLU(), nn.Dropout(dropout)]
        width = units
    out.append(nn.Linear(width, 1))
    return nn.Sequential(*out)


def casadi_sigmoid(v: Any) -> Any:
    """sigmoid for CasADi graphs, via tanh: 1 / (1 + exp(-v)) has derivative inf / inf = NaN
    once exp(-v) overflows."""
    import casadi as cs

    return 0.5 + 0.5 * cs.tanh(0.5 * v)
