"""The judge's network architectures, by name (JudgeConfig.arch, `judgeopt train-judge --arch`).

base.py  what an architecture says about itself (Arch): its fields, its torch layers, its
         logit, its CasADi export (l4casadi generic; an MX graph where it offers one)
lstm.py  the paper's LSTM (the default; judge files without an `arch` key are LSTMs)
tcn.py   a small temporal convolution network

A new architecture is one module here, its Config dataclass in judgeopt/judge/arch_configs.py (which
imports nothing heavy: the command line lists the fields at start-up) and its entry in ARCHS below.
"""

from __future__ import annotations

from dataclasses import fields

from judgeopt.judge.arch_configs import ARCH_CONFIGS, DEFAULT_ARCH
from judgeopt.judge.archs.base import Arch, FlatJudge, casadi_sigmoid, fc_head
from judgeopt.judge.archs.lstm import LSTM
from judgeopt.judge.archs.tcn import TCN
from judgeopt.judge.errors import JudgeError

#: what every architecture shares in JudgeConfig (its field names must differ from these)
SHARED_FIELDS = ("arch", "net", "env_names", "channels", "units", "horizon", "dt")

ARCHS: dict[str, Arch] = {a.name: a for a in (LSTM(), TCN())}

if {n: a.Config for n, a in ARCHS.items()} != ARCH_CONFIGS:  # the light list the command line reads must agree
    raise TypeError(f"judgeopt/judge/arch_configs.py's ARCH_CONFIGS {sorted(ARCH_CONFIGS)} does not match ARCHS "
                    f"{sorted(ARCHS)} (each architecture's Config lives there)")

for _a in ARCHS.values():  # a clash would make a judge file ambiguous: caught on import
    _clash = {f.name for f in fields(_a.Config)} & set(SHARED_FIELDS)
    if _clash:
        raise TypeError(f"architecture {_a.name!r}: fields {sorted(_clash)} clash with JudgeConfig's shared ones")


def arch_names() -> list[str]:
    return list(ARCHS)


def get_arch(name: str) -> Arch:
    """The architecture called `name`; a one-line JudgeError listing the known ones otherwise."""
    try:
        return ARCHS[name]
    except (KeyError, TypeError):
        raise JudgeError(f"unknown judge architecture {name!r}; known: {', '.join(ARCHS)}") from None


def arch_fields(name: str) -> list[str]:
    return [f.name for f in fields(get_arch(name).Config)]


__all__ = ["ARCHS", "DEFAULT_ARCH", "SHARED_FIELDS", "Arch", "FlatJudge", "arch_fields", "arch_names", "casadi_sigmoid",
           "fc_head", "get_arch"]
