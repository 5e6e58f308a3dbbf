"""The cached judge libraries (l4casadi, l4casadi32, compiled) are keyed by the source of the code
that generates them: an edit to that code, here made for real in a copy of its module, gives a new
key; an unchanged copy gives the same key (the key is the code's, not the module's name or chance).
No library is built: the keys are computed as the builders compute them."""

from __future__ import annotations

import pytest
import torch

import judgeopt.judge.archs.lstm as lstm_mod
import judgeopt.judge.archs.tcn as tcn_mod
import judgeopt.judge.casadi_fn as cf
import judgeopt.judge.model as model_mod
from judgeopt import cbuild
from judgeopt.judge.archs import ARCHS
from judgeopt.judge.model import JudgeConfig

NETS = {"lstm": dict(lstm_units=12, fc_units=10), "tcn": dict(tcn_channels=8, levels=2, fc_units=10)}
ARCH_MODULES = {"lstm": lstm_mod, "tcn": tcn_mod}

#: (backend, arch, module edited, old text, new text): one planted bug in each piece of generating code
EDITS = [
    ("l4casadi", "lstm", cf, "self.model(inp[:, :n] + inp[:, n:])", "self.model(inp[:, :n] - inp[:, n:])"),
    ("l4casadi", "lstm", lstm_mod, "u = torch.cat([x[:, k], e], dim=-1)", "u = torch.cat([e, x[:, k]], dim=-1)"),
    ("l4casadi", "tcn", model_mod, "xn = (x - self.x_mean) / self.x_std", "xn = (x - self.x_mean) * self.x_std"),
    ("l4casadi32", "lstm", lstm_mod, "_MKLDNN_LSTM = 2", "_MKLDNN_LSTM = 3"),
    ("l4casadi32", "tcn", tcn_mod, "h.mean(dim=1)], dim=1))", "h.sum(dim=1)], dim=1))"),
    ("l4casadi32", "lstm", cf, "generate_jac=False, generate_adj1=True", "generate_jac=True, generate_adj1=True"),
    ("compiled", "lstm", lstm_mod, "a = cs.fmax(a, 0)", "a = cs.fmax(a, 0.01 * a)"),
    ("compiled", "lstm", cf, "cs.repmat((e - em) / es, 1, n1)", "cs.repmat((e + em) / es, 1, n1)"),
    ("compiled", "lstm", cbuild, '"-O2"', '"-O3"'),
]


def _judge(arch: str, judge_class: type = model_mod.Judge) -> model_mod.Judge:
    torch.manual_seed(0)
    return judge_class(JudgeConfig(arch=arch, horizon=4, **NETS[arch])).eval()


def _key(fn_module, judge, backend: str) -> str:
    """The key as the builder computes it (`fn_module`: casadi_fn or a copy of it)."""
    model = None if backend == "compiled" else fn_module._flat_model(judge, backend)
    return fn_module._cache_key(judge, backend, model)


def _key_with(copy, module, backend: str, arch: str, monkeypatch) -> str:
    """The key with `copy` in use in place of `module` (casadi_fn, the architecture's module, the
    Judge's or cbuild), undone by monkeypatch at the test's end."""
    if module is cf:
        return _key(copy, _judge(arch), backend)
    if module is model_mod:
        return _key(cf, _judge(arch, copy.Judge), backend)
    if module is cbuild:
        monkeypatch.setattr(cf, "compiled_library", copy.compiled_library)
    else:
        monkeypatch.setitem(ARCHS, arch, getattr(copy, type(ARCHS[arch]).__name__)())
    return _key(cf, _judge(arch), backend)


@pytest.mark.parametrize("backend, arch, module, old, new", EDITS,
                         ids=[f"{b}-{a}-{m.__name__.rsplit('.', 1)[-1]}" for b, a, m, *_ in EDITS])
def test_an_edit_to_the_generating_code_gives_a_new_key(module_copy, monkeypatch, backend, arch, module, old, new):
    before = _key(cf, _judge(arch), backend)
    assert _key(cf, _judge(arch), backend) == before  # deterministic
    assert _key_with(module_copy(module), module, backend, arch, monkeypatch) == before
    assert _key_with(module_copy(module, old, new), module, backend, arch, monkeypatch) != before


def test_keys_differ_by_backend_and_model_and_hold_the_l4casadi_version(monkeypatch):
    """The parts that were there before stay: the backend, the weights, l4casadi's version (read
    from the installed distribution: l4casadi 2.0 has no __version__, which keyed every version alike)."""
    m = _judge("lstm")
    keys = {_key(cf, m, b) for b in ("l4casadi", "l4casadi32", "compiled")}
    assert len(keys) == 3
    other = _judge("lstm")
    with torch.no_grad():
        other.head[0].bias[0] += 1e-3
    assert _key(cf, other, "l4casadi") != _key(cf, m, "l4casadi")
    before = _key(cf, m, "l4casadi32")
    monkeypatch.setattr(cf, "_version", lambda dist: "0.0-other")
    assert _key(cf, m, "l4casadi32") != before
