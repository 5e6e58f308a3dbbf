"""The paper's network (Fig. 2, Table 2): an LSTM over the steps, its last hidden state through
feed-forward layers to one logit. nn.LSTM for training; for l4casadi in float64 the same weights
in an unrolled one-Linear cell; for l4casadi in float32 oneDNN's fused LSTM layer op, called
directly (FusedLSTMJudge32); for the native and compiled CasADi backends an MX graph."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import torch
from torch import nn

from judgeopt.judge.arch_configs import LSTMConfig
from judgeopt.judge.archs.base import Arch, Flat32, casadi_sigmoid, fc_head


class LSTM(Arch):
    name = "lstm"
    Config = LSTMConfig
    casadi_graph = True

    def layers(self, config: Any) -> dict[str, nn.Module]:
        net = config.net
        return {"lstm": nn.LSTM(config.input_size, net.lstm_units, num_layers=net.lstm_layers, batch_first=True,
                                dropout=net.lstm_dropout if net.lstm_layers > 1 else 0.0),
                "head": fc_head(net.lstm_units, net.fc_units, net.fc_layers, net.dropout)}

    def logit(self, judge: nn.Module, u: torch.Tensor) -> torch.Tensor:
        out, _ = judge.lstm(u)
        return judge.head(out[:, -1]).squeeze(-1)

    def describe(self, net: LSTMConfig) -> str:
        return f"LSTM {net.lstm_layers} x {net.lstm_units}, FC {net.fc_layers} x {net.fc_units}, dropout {net.dropout}"

    def flat_module(self, judge: nn.Module) -> nn.Module:
        return UnrolledJudge(judge)

    def flat_module32(self, judge: nn.Module) -> nn.Module:
        return FusedLSTMJudge32(judge)

    def native_logit(self, judge: nn.Module, u: Any) -> Any:
        """The input projection of each LSTM layer is one matrix product over all steps; only
        the recurrent product stays per step (fewer, larger ops are what CasADi's virtual
        machine runs fast)."""
        import casadi as cs

        H = judge.config.lstm_units
        n1 = u.size2()
        sig = casadi_sigmoid
        h = None
        for W, b in lstm_layer_weights(judge.lstm):
            n_in = W.shape[1] - H
            Z = cs.mtimes(cs.DM(W[:, :n_in]), u) + cs.repmat(cs.DM(b), 1, n1)
            W_hh = cs.DM(W[:, n_in:])
            hs = []
            for k in range(n1):
                z = Z[:, k] if k == 0 else Z[:, k] + cs.mtimes(W_hh, h)
                i, f, g, o = sig(z[:H]), sig(z[H:2 * H]), cs.tanh(z[2 * H:3 * H]), sig(z[3 * H:])
                c = i * g if k == 0 else f * c + i * g  # noqa: F821 (c defined at k = 0)
                h = o * cs.tanh(c)
                hs.append(h)
            u = cs.horzcat(*hs)
        a = h
        linears = [m for m in judge.head if isinstance(m, nn.Linear)]
        for j, lin in enumerate(linears):
            a = cs.mtimes(cs.DM(lin.weight.detach().double().numpy()), a) + cs.DM(lin.bias.detach().double().numpy())
            if j < len(linears) - 1:
                a = cs.fmax(a, 0)
        return a


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

    def __init__(self, judge: nn.Module) -> None:
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


#: nn.LSTM's mode number for aten::mkldnn_rnn_layer (RNN_RELU 0, RNN_TANH 1, LSTM 2, GRU 3)
_MKLDNN_LSTM = 2


class FusedLSTMJudge32(Flat32):
    """The judge in float32 with each LSTM layer ONE call of oneDNN's fused kernel
    (aten::mkldnn_rnn_layer, the kernel nn.LSTM itself runs on CPU in float32), for l4casadi.

    Why not nn.LSTM: under make_fx (how l4casadi traces) aten::lstm does not see plain CPU
    tensors, so it decomposes into an unrolled cell of ~10 ops per step and layer, which
    TorchScript then runs one by one (and torch.jit.freeze breaks that decomposition, see
    shared/notes/dependencies.md). The op called directly is recorded as one node, and its
    backward, traced with grad mode off (casadi_fn's adjoint trace), as one
    aten::mkldnn_rnn_layer_backward node. `train` (the workspace the backward needs) is
    requested only when grad mode is on, i.e. in the adjoint trace, not in the value's.

    Input: a (B, (N+1)*C + E) row [x_0, ..., x_N (row-major), e] of raw values normalised
    with the buffers x_mean, x_std, e_mean, e_std (casadi_fn sets them to 0 and 1 and
    normalises in CasADi); output (B, 2) [logit, probability].
    """

    def __init__(self, judge: nn.Module) -> None:
        super().__init__(judge)
        lstm = judge.lstm
        self.hidden, self.layers = lstm.hidden_size, lstm.num_layers
        for k in range(lstm.num_layers):  # buffers: constants of the trace, no gradient wanted
            for w in ("weight_ih", "weight_hh", "bias_ih", "bias_hh"):
                self.register_buffer(f"{w}_l{k}", getattr(lstm, f"{w}_l{k}").detach().float().clone())

    def forward(self, inp: torch.Tensor) -> torch.Tensor:
        u = self.features(inp).transpose(0, 1).contiguous()  # time-major (T, B, C + E)
        h0 = torch.zeros(inp.shape[0], self.hidden, dtype=u.dtype)
        train = torch.is_grad_enabled()
        for k in range(self.layers):
            w = [getattr(self, f"{name}_l{k}") for name in ("weight_ih", "weight_hh", "bias_ih", "bias_hh")]
            u = torch.ops.aten.mkldnn_rnn_layer(u, *w, h0, h0, False, [], _MKLDNN_LSTM, self.hidden, 1, True,
                                                False, False, train)[0]
        return self.output(u[-1])
