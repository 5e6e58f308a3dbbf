"""The names of the ways the judge is evaluated inside CasADi (judge.casadi_fn builds them), in a
module that imports nothing heavy: the command line lists them in its options at start-up (and
the fast start, judge.compiled, chooses one without torch)."""

from __future__ import annotations

import importlib.util
from typing import Any

BACKENDS = ("native", "compiled", "torch", "torch32", "l4casadi", "l4casadi32")
#: the backends that need the network as a CasADi MX graph (Arch.native_logit)
GRAPH_BACKENDS = ("native", "compiled")
#: "auto" is a rule, not one backend (choose_backend below): for a noise-tolerant use (the direct solve's
#: judge as a constraint) l4casadi32 where l4casadi is installed and the architecture is in
#: AUTO_L4CASADI32, else the torch32 callback; otherwise l4casadi (float64) where installed, else native
DEFAULT_BACKEND = "auto"


#: architectures whose l4casadi32 measured <= 1.1x the torch32 callback's time for value + gradient
#: (benchmarks/bench_judge_casadi.py, docs/judge.md "l4casadi in float32"); "auto" gives the
#: others torch32. An architecture is added here by measurement, not by default.
AUTO_L4CASADI32 = frozenset({"lstm", "tcn"})


def choose_backend(backend: str = DEFAULT_BACKEND, noise_tolerant: bool = False,
                   config: Any = None) -> str:
    """`backend` itself, or for "auto" the fastest one for the use. Where ~1e-7 relative noise
    is harmless (`noise_tolerant`: the judge as a constraint): l4casadi32 (the network in float32
    inside l4casadi) where l4casadi is installed and the architecture (`config`, a JudgeConfig or
    judge.compiled.TrajectoryFormat; None counts as the LSTM) is in AUTO_L4CASADI32, else the
    torch32 callback; both are 3-4x faster than any float64 backend. Otherwise l4casadi (float64) where it is installed, else native (torch for
    an architecture without a CasADi graph). build_casadi_judge falls back from an "auto"
    l4casadi32 that fails to build to torch32, with one warning line."""
    if backend != "auto":
        return backend
    installed = importlib.util.find_spec("l4casadi") is not None
    if noise_tolerant:
        arch = config.arch if config is not None else "lstm"
        return "l4casadi32" if installed and arch in AUTO_L4CASADI32 else "torch32"
    if installed:
        return "l4casadi"
    return "native" if config is None or config.spec.casadi_graph else "torch"
