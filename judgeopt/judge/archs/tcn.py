"""A small temporal convolution network: a 1 x 1 convolution lifts [x_k, e] to `tcn_channels`,
then `levels` residual causal convolutions with dilations 1, 2, 4, ... (kernel 3, 4 levels: the
last step sees all 31 samples of N = 30); the last step and the mean over the steps through
feed-forward layers to one logit.

Why this one beside the LSTM: no recurrence, so the l4casadi trace is a handful of
convolutions instead of N + 1 unrolled cells (cheap to build and to call), and every step is
computed at once. It offers no CasADi MX graph: l4casadi and the torch callbacks only. For
l4casadi in float32 the convolutions are written as matrix products (MatmulTCN32).
"""

from __future__ import annotations

from typing import Any

import torch
from torch import nn

from judgeopt.judge.arch_configs import TCNConfig
from judgeopt.judge.archs.base import Arch, Flat32, fc_head


class TCN(Arch):
    name = "tcn"
    Config = TCNConfig

    def layers(self, config: Any) -> dict[str, nn.Module]:
        net = config.net
        ch = net.tcn_channels
        return {"lift": nn.Conv1d(config.input_size, ch, 1),
                "convs": nn.ModuleList(nn.Conv1d(ch, ch, net.kernel, dilation=2 ** i) for i in range(net.levels)),
                "conv_dropout": nn.Dropout(net.conv_dropout),
                "head": fc_head(2 * ch, net.fc_units, net.fc_layers, net.dropout)}

    def logit(self, judge: nn.Module, u: torch.Tensor) -> torch.Tensor:
        h = judge.lift(u.transpose(1, 2))  # (B, channels, N + 1)
        for conv in judge.convs:
            pad = (conv.kernel_size[0] - 1) * conv.dilation[0]  # on the left only: causal
            h = h + judge.conv_dropout(torch.relu(conv(nn.functional.pad(h, (pad, 0)))))
        return judge.head(torch.cat([h[:, :, -1], h.mean(dim=2)], dim=1)).squeeze(-1)

    def describe(self, net: TCNConfig) -> str:
        seen = 1 + (net.kernel - 1) * (2 ** net.levels - 1)
        return (f"TCN {net.levels} x {net.tcn_channels} (kernel {net.kernel}, the last step sees {seen} samples, "
                f"dropout {net.conv_dropout}), FC {net.fc_layers} x {net.fc_units}, dropout {net.dropout}")

    def flat_module32(self, judge: nn.Module) -> nn.Module:
        return MatmulTCN32(judge)


class MatmulTCN32(Flat32):
    """The TCN judge in float32 with each causal convolution as ONE matrix product over all steps:
    the kernel's taps (h shifted by 0, d, 2d, ... steps, zero-padded on the left) side by side,
    (T, K * channels) @ (K * channels, channels). For l4casadi32 (its value and adjoint traces).

    Why: on one thread a dilated Conv1d of 31 steps costs far more in dispatch and weight
    reordering than in arithmetic; measured on judge_demos_tcn (one thread, eager float32) value
    0.70 ms against 1.64 ms for the convolutions, value + gradient 2.4 against 4.0 ms.
    Same input and output as FlatJudge: a (B, (N+1)*C + E) row of raw values normalised with the
    buffers x_mean, x_std, e_mean, e_std -> (B, 2) [logit, probability].
    """

    def __init__(self, judge: nn.Module) -> None:
        super().__init__(judge)
        self.register_buffer("lift_w", judge.lift.weight.detach().float()[:, :, 0].T.contiguous())  # (C + E, ch)
        self.register_buffer("lift_b", judge.lift.bias.detach().float().clone())
        self.taps: list[tuple[int, int]] = []  # (kernel, dilation) per level
        for i, conv in enumerate(judge.convs):
            # weight (out, in, K) -> (K * in, out): tap j multiplies h[t - (K - 1 - j) d]
            w = conv.weight.detach().float().permute(2, 1, 0).reshape(-1, conv.out_channels)
            self.register_buffer(f"conv_w{i}", w.contiguous())
            self.register_buffer(f"conv_b{i}", conv.bias.detach().float().clone())
            self.taps.append((conv.kernel_size[0], conv.dilation[0]))

    def forward(self, inp: torch.Tensor) -> torch.Tensor:
        T = self.n_steps
        h = torch.matmul(self.features(inp), self.lift_w) + self.lift_b  # (B, T, channels)
        for i, (K, d) in enumerate(self.taps):
            hp = nn.functional.pad(h, (0, 0, (K - 1) * d, 0))  # causal: zeros before the first step
            taps = torch.cat([hp[:, j * d:j * d + T] for j in range(K)], dim=-1)
            h = h + torch.relu(torch.matmul(taps, getattr(self, f"conv_w{i}")) + getattr(self, f"conv_b{i}"))
        return self.output(torch.cat([h[:, -1], h.mean(dim=1)], dim=1))
