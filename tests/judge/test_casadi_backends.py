"""The l4casadi32 backend (the judge in float32 inside l4casadi, value and adj1 traces only), what
"auto" chooses, and the fallback to the torch32 callback when it cannot be built."""

from __future__ import annotations

import logging

import numpy as np
import pytest
import torch

import judgeopt.judge.casadi_fn as cf
from judgeopt.judge.archs import ARCHS, Arch
from judgeopt.judge.casadi_fn import (AUTO_L4CASADI32, CasadiBuildError, build_casadi_judge, choose_backend,
                                      torch_logit_and_grad)
from judgeopt.judge.model import Judge, JudgeConfig

l4casadi = pytest.importorskip("l4casadi")
torch.set_num_threads(1)
HORIZON = 6  # short: the LSTM's traces grow with the steps; a few seconds to build


def _small(arch: str, seed: int = 0) -> Judge:
    """A small random judge with a normalisation that is not the identity (CasADi applies it)."""
    torch.manual_seed(seed)
    net = {"lstm": dict(lstm_units=12, fc_units=10), "tcn": dict(tcn_channels=8, levels=2, fc_units=10)}[arch]
    m = Judge(JudgeConfig(arch=arch, horizon=HORIZON, **net))
    with torch.no_grad():
        m.x_mean.copy_(torch.tensor([0.1, 0.2, 12.0]))
        m.x_std.copy_(torch.tensor([0.08, 0.4, 4.0]))
        m.e_mean.copy_(torch.tensor([0.19, 2.0]))
        m.e_std.copy_(torch.tensor([0.05, 0.6]))
        for p in m.parameters():  # larger weights than the default init: a logit far from 0, gates that move
            p.mul_(2.0)
    return m.eval()


def _points(n: int, seed: int = 1) -> list[tuple[np.ndarray, np.ndarray]]:
    rng = np.random.default_rng(seed)
    return [(rng.normal([0.1, 0.2, 12.0], [0.08, 0.4, 4.0], (HORIZON + 1, 3)), rng.normal([0.19, 2.0], [0.05, 0.6]))
            for _ in range(n)]


@pytest.mark.parametrize("arch", ["lstm", "tcn"])
def test_l4casadi32_matches_torch_float64(arch, tmp_path):
    """Value and gradient (trajectory and environment) within 1e-5 relative of torch autograd in
    float64, and a second build is a cache hit with no Jacobian trace generated."""
    m = _small(arch)
    cj = build_casadi_judge(m, "l4casadi32", cache_dir=tmp_path)
    assert cj.backend == "l4casadi32" and not cj.cache_hit
    for x, e in _points(3):
        v, gx, ge = cj.value_and_gradient(x, e)
        tv, tgx, tge = torch_logit_and_grad(m, x, e)
        g, tg = np.concatenate([gx, ge]), np.concatenate([tgx, tge])
        assert abs(tg).max() > 1e-3
        assert abs(v - tv) <= 1e-5 * max(1.0, abs(tv))
        assert np.abs(g - tg).max() <= 1e-5 * np.abs(tg).max()
        p = float(cj.fn(x.ravel(), e)[1])
        assert p == pytest.approx(1 / (1 + np.exp(-tv)), rel=1e-5)
    names = [f.name for f in cj.cache_dir.iterdir()]
    # only what the solve calls: the value and adj1, no Jacobian
    assert any(n.startswith("adj1_") for n in names) and not any(n.startswith("jac") for n in names)
    again = build_casadi_judge(m, "l4casadi32", cache_dir=tmp_path)
    assert again.cache_hit and again.cache_dir == cj.cache_dir
    # the float64 l4casadi backend of the same judge has its own cache entry
    assert cj.cache_dir.parent.name == "l4casadi32"


def test_l4casadi32_jacobian_from_adjoints(tmp_path):
    """No Jacobian trace, yet CasADi's Jacobian of the function (built from adj1) is right."""
    import casadi as cs

    m = _small("tcn", seed=3)
    cj = build_casadi_judge(m, "l4casadi32", cache_dir=tmp_path)
    X, E = cs.MX.sym("x", 3 * (HORIZON + 1)), cs.MX.sym("e", 2)
    jac = cs.Function("j", [X, E], [cs.jacobian(cj.fn(X, E)[0], cs.vertcat(X, E))])
    x, e = _points(1, seed=4)[0]
    _, tgx, tge = torch_logit_and_grad(m, x, e)
    tg = np.concatenate([tgx, tge])
    assert np.abs(np.asarray(jac(x.ravel(), e)).ravel() - tg).max() <= 1e-5 * np.abs(tg).max()


def test_auto_chooses_l4casadi32_for_the_noise_tolerant_use(monkeypatch):
    lstm, tcn = JudgeConfig(), JudgeConfig(arch="tcn")
    assert AUTO_L4CASADI32 == {"lstm", "tcn"}
    assert choose_backend("auto", noise_tolerant=True, config=lstm) == "l4casadi32"
    assert choose_backend("auto", noise_tolerant=True, config=tcn) == "l4casadi32"
    assert choose_backend("auto", noise_tolerant=True) == "l4casadi32"
    assert choose_backend("auto", config=lstm) == "l4casadi"  # float64 where noise matters
    assert choose_backend("torch32", noise_tolerant=True, config=lstm) == "torch32"  # explicit stays
    import judgeopt.judge.backends as jb  # where the rule lives (casadi_fn re-exports it)

    monkeypatch.setattr(jb, "AUTO_L4CASADI32", frozenset({"lstm"}))  # an architecture not measured
    assert choose_backend("auto", noise_tolerant=True, config=tcn) == "torch32"
    monkeypatch.setattr(cf.importlib.util, "find_spec", lambda name: None)  # no l4casadi
    assert choose_backend("auto", noise_tolerant=True, config=lstm) == "torch32"


def _one_warning(caplog) -> str:
    records = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(records) == 1, [r.getMessage() for r in records]
    msg = records[0].getMessage()
    assert "\n" not in msg and "Traceback" not in msg
    assert records[0].exc_info is None
    return msg


@pytest.mark.parametrize("how", ["build_fails", "no_compiler", "no_module", "trace_fails", "no_l4casadi"])
def test_auto_falls_back_to_torch32_with_one_line(how, tmp_path, monkeypatch, caplog):
    m = _small("tcn", seed=5)
    if how == "build_fails":
        def fail(*args):
            raise CasadiBuildError("compiling failed (test)")
        monkeypatch.setattr(cf, "_l4casadi32_function", fail)
    elif how == "no_compiler":
        monkeypatch.setattr(cf.shutil, "which", lambda name: None)
    elif how == "trace_fails":
        def no_trace(*args, **kwargs):
            raise RuntimeError("make_fx failed\non two lines")
        monkeypatch.setattr(l4casadi.l4casadi, "make_fx", no_trace)
    elif how == "no_module":
        def broken(self, judge):
            raise RuntimeError("this module does not trace\nsecond line")
        monkeypatch.setattr(Arch, "flat_module32", broken)
        monkeypatch.setattr(type(ARCHS["tcn"]), "flat_module32", broken, raising=False)
    else:
        import builtins

        real_import = builtins.__import__

        def no_l4casadi(name, *args, **kwargs):
            if name == "l4casadi":
                raise ImportError("No module named 'l4casadi'")
            return real_import(name, *args, **kwargs)
        monkeypatch.setattr(builtins, "__import__", no_l4casadi)
    caplog.set_level(logging.INFO, logger="judgeopt")
    cj = build_casadi_judge(m, "auto", cache_dir=tmp_path, noise_tolerant=True)
    assert cj.backend == "torch32"
    msg = _one_warning(caplog)
    assert "l4casadi32" in msg and "falling back to torch32" in msg
    x, e = _points(1)[0]
    v, *_ = cj.value_and_gradient(x, e)
    assert v == pytest.approx(torch_logit_and_grad(m, x, e)[0], rel=1e-4)
    # asked for by name, the same failure is a one-line CasadiBuildError
    with pytest.raises(CasadiBuildError) as exc:
        build_casadi_judge(m, "l4casadi32", cache_dir=tmp_path)
    assert "\n" not in str(exc.value)
    assert not list(tmp_path.glob("l4casadi32/*")) and not list(tmp_path.glob("l4casadi32/.*"))  # nothing half-built


def test_direct_solve_with_l4casadi32_matches_torch32(tmp_path):
    """The direct solve (the judge as a constraint) with the shipped TCN judge: l4casadi32 and the
    torch32 callback reach the same plan quality, in the same number of iterations."""
    from judgeopt.files import resolve
    from judgeopt.judge.store import load_judge
    from judgeopt.planners.direct import DirectPlanner
    from judgeopt.planners.problem import load_problem

    judge = load_judge(resolve("models/judge_demos_tcn"))[0]
    problem = load_problem(resolve("problems/paper_sim.toml"))
    env = {"y_obj": 0.22, "mu": 2.5}
    out = {}
    for backend in ("torch32", "l4casadi32"):
        cj = build_casadi_judge(judge, backend, cache_dir=tmp_path)
        assert cj.backend == backend
        out[backend] = DirectPlanner(problem, judge, cj).solve(env)
    a, b = out["torch32"], out["l4casadi32"]
    assert a.status == b.status == "solved"
    assert b.predicted_success >= problem.p_target - 2e-3
    assert b.iterations == a.iterations
    assert b.predicted_success == pytest.approx(a.predicted_success, abs=1e-5)


def test_a_library_that_does_not_evaluate_falls_back_too(tmp_path, monkeypatch, caplog):
    m = _small("lstm", seed=7)
    build_casadi_judge(m, "l4casadi32", cache_dir=tmp_path)  # a good build in the cache

    def broken(self, traj, env):
        raise RuntimeError("Error in Function::call for 'judge' [MXFunction]\nat .../function.cpp:1234")
    monkeypatch.setattr(cf.CasadiJudge, "value_and_gradient", broken)
    caplog.set_level(logging.INFO, logger="judgeopt")
    cj = build_casadi_judge(m, "auto", cache_dir=tmp_path, noise_tolerant=True)
    assert cj.backend == "torch32" and "does not evaluate" in _one_warning(caplog)
