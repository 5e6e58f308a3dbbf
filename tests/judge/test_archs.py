"""Judge architectures (judgeopt.judge.archs): the seam, the TCN beside the LSTM, old files."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import torch
from torch import nn

from judgeopt.data.dataset import load, save
from judgeopt.judge import archs
from judgeopt.judge.archs import ARCHS, Arch, fc_head
from judgeopt.judge.casadi_fn import (BACKENDS, backends_for, build_casadi_judge, choose_backend, model_hash,
                                      torch_logit_and_grad)
from judgeopt.judge.evaluate import evaluate_judge, judge_inputs
from judgeopt.judge.model import Judge, JudgeConfig, JudgeError
from judgeopt.judge.store import JudgeFileError, load_judge, save_judge
from judgeopt.judge.train import TrainConfig, train_judge

torch.set_num_threads(1)
REPO = Path(__file__).resolve().parents[2]
OLD_FILES = ["models/judge_refined", "models/judge_lab", "models/judge_ensemble/member_0"]


@pytest.fixture(scope="module")
def scoop_slice():
    """600 + 300 real demonstrations of data/train.h5 (N = 30, the 3 x 3 grid)."""
    ds = load(REPO / "data" / "train.h5")
    pick = np.random.default_rng(0).permutation(ds.n)
    return ds.subset(np.sort(pick[:600])), ds.subset(np.sort(pick[600:900]))


@pytest.fixture(scope="module")
def tcn_trained(scoop_slice):
    train, test = scoop_slice
    cfg = JudgeConfig(arch="tcn", tcn_channels=16, fc_units=16, horizon=train.horizon, env_names=train.env_names)
    tc = TrainConfig(epochs=8, batch_size=32, lr=1e-2, seed=0, progress=False)
    return train_judge(train, test, cfg, tc)


# -- the TCN ---------------------------------------------------------------------------------
def test_tcn_trains_on_a_small_slice(tcn_trained, scoop_slice):
    model, result = tcn_trained
    _, test = scoop_slice
    assert model.config.arch == "tcn" and [k for k in model.state_dict() if k.startswith("lift")]
    assert result.history[-1]["train_loss"] < result.history[0]["train_loss_running"]
    majority = max(test.success_ratio(), 1 - test.success_ratio())
    assert evaluate_judge(model, test)["accuracy"] > majority + 0.05


def test_tcn_l4casadi_matches_torch_autograd(tcn_trained, scoop_slice, tmp_path):
    """Value and gradient of the l4casadi function against torch autograd (float64) at real
    demonstrations; l4casadi hands back float32 gradients, hence 1e-5 relative."""
    import casadi as cs

    model, _ = tcn_trained
    _, test = scoop_slice
    cj = build_casadi_judge(model, "l4casadi", cache_dir=tmp_path)
    x_all, e_all = judge_inputs(model, test)
    X, E = cs.MX.sym("x", x_all[0].size), cs.MX.sym("e", e_all.shape[1])
    jac_p = cs.Function("jp", [X, E], [cs.jacobian(cj.fn(X, E)[1], cs.vertcat(X, E))])
    for i in (0, 7, 123):
        x, e = x_all[i], e_all[i]
        v, gx, ge = cj.value_and_gradient(x, e)
        tv, tgx, tge = torch_logit_and_grad(model, x, e)
        g, tg = np.concatenate([gx, ge]), np.concatenate([tgx, tge])
        assert abs(tg).max() > 1e-6
        assert v == pytest.approx(tv, rel=1e-5, abs=1e-6)
        np.testing.assert_allclose(g, tg, rtol=1e-5, atol=1e-5 * abs(tg).max())
        p = 1 / (1 + np.exp(-tv))
        np.testing.assert_allclose(np.asarray(jac_p(x.ravel(), e)).ravel(), p * (1 - p) * tg, rtol=1e-5,
                                   atol=1e-5 * abs(tg).max() * p * (1 - p))
        # and the float32 network as trained agrees to float32 rounding
        assert float(model.predict_logit(x, e)[0]) == pytest.approx(tv, rel=1e-4, abs=1e-5)


def test_tcn_has_no_casadi_graph_backends(tcn_trained, monkeypatch):
    model, _ = tcn_trained
    assert backends_for(model.config) == tuple(b for b in BACKENDS if b not in ("native", "compiled"))
    for backend in ("native", "compiled"):
        with pytest.raises(JudgeError) as exc:
            build_casadi_judge(model, backend)
        msg = str(exc.value)
        assert "\n" not in msg and f"no '{backend}' backend" in msg and "torch, torch32, l4casadi" in msg
    # without l4casadi, "auto" falls back to the torch callback, not to the graph it lacks
    import judgeopt.judge.casadi_fn as cf
    monkeypatch.setattr(cf.importlib.util, "find_spec", lambda name: None)
    assert choose_backend("auto", config=model.config) == "torch"
    assert choose_backend("auto", config=JudgeConfig()) == "native"


def test_tcn_torch_backend_and_round_trip(tcn_trained, tmp_path):
    model, _ = tcn_trained
    save_judge(model, tmp_path / "t")
    assert json.loads((tmp_path / "t.json").read_text())["config"]["arch"] == "tcn"
    back, _ = load_judge(tmp_path / "t")
    x, e = torch.randn(3, 31, 3), torch.randn(3, 2)
    assert back.config == model.config and torch.equal(back(x, e), model(x, e))
    assert model_hash(back) == model_hash(model)
    cj = build_casadi_judge(model, "torch")
    xx, ee = np.random.default_rng(1).normal([0.1, 0.5, 12], [0.1, 0.5, 4], (31, 3)), np.array([0.2, 2.0])
    assert cj.value_and_gradient(xx, ee)[0] == pytest.approx(torch_logit_and_grad(model, xx, ee)[0], rel=1e-9)


# -- old files -------------------------------------------------------------------------------
def _reference_logits(stem: str, x: np.ndarray, e: np.ndarray) -> np.ndarray:
    """The paper's network built from torch modules directly from the file (no Judge class)."""
    meta = json.loads((REPO / f"{stem}.json").read_text())
    c, norm = meta["config"], meta["normalization"]
    state = torch.load(REPO / f"{stem}.pt", weights_only=True)
    lstm = nn.LSTM(len(c["channels"]) + len(c["env_names"]), c["lstm_units"], num_layers=c["lstm_layers"],
                   batch_first=True)
    lstm.load_state_dict({k[5:]: v for k, v in state.items() if k.startswith("lstm.")})
    head = fc_head(c["lstm_units"], c["fc_units"], c["fc_layers"], c["dropout"])
    head.load_state_dict({k[5:]: v for k, v in state.items() if k.startswith("head.")})
    lstm.eval(), head.eval()
    xt, et = torch.as_tensor(x, dtype=torch.float32), torch.as_tensor(e, dtype=torch.float32)
    xn = (xt - state["x_mean"]) / state["x_std"]
    en = ((et - state["e_mean"]) / state["e_std"]).unsqueeze(1).expand(-1, xt.shape[1], -1)
    assert state["x_mean"].tolist() == pytest.approx(norm["x_mean"])
    with torch.no_grad():
        out, _ = lstm(torch.cat([xn, en], dim=-1))
        return head(out[:, -1]).squeeze(-1).double().numpy()


@pytest.mark.parametrize("stem", OLD_FILES)
def test_old_judge_files_load_unchanged(stem):
    meta = json.loads((REPO / f"{stem}.json").read_text())
    assert "arch" not in meta["config"]  # written before architectures had names
    model, _ = load_judge(REPO / stem)
    assert model.config.arch == "lstm" and model.config.to_dict()["arch"] == "lstm"
    ds = load(REPO / "data" / "test.h5").subset(np.arange(40))
    x, e = judge_inputs(model, ds)
    np.testing.assert_array_equal(model.predict_logit(x, e), _reference_logits(stem, x, e))
    # the CasADi cache key is what it was: built libraries of LSTM judges stay valid
    import hashlib
    h = hashlib.sha256(json.dumps(meta["config"], sort_keys=True).encode())
    for name, t in sorted(model.state_dict().items()):
        h.update(name.encode())
        h.update(t.detach().cpu().double().contiguous().numpy().tobytes())
    assert model_hash(model) == h.hexdigest()


# -- the config and its errors ---------------------------------------------------------------
def test_config_fields_per_architecture():
    cfg = JudgeConfig(lstm_units=8, fc_units=16)
    assert cfg.arch == "lstm" and cfg.lstm_units == 8 and cfg.fc_units == 16 and cfg.lstm_layers == 2
    d = cfg.to_dict()
    assert list(d)[:2] == ["arch", "lstm_units"] and JudgeConfig.from_dict(d) == cfg
    tcn = JudgeConfig(arch="tcn", tcn_channels=8)
    assert tcn.tcn_channels == 8 and JudgeConfig.from_dict(tcn.to_dict()) == tcn
    assert JudgeConfig(arch="tcn", net={"tcn_channels": 8}) == tcn
    with pytest.raises(AttributeError):
        tcn.lstm_units
    with pytest.raises(JudgeError, match=r"the tcn architecture has no field lstm_units \(its fields: tcn_channels"):
        JudgeConfig(arch="tcn", lstm_units=8)
    with pytest.raises(JudgeError, match="unknown judge config keys"):
        JudgeConfig.from_dict({**tcn.to_dict(), "lstm_units": 8})
    with pytest.raises(JudgeError, match="layer sizes must be positive"):
        JudgeConfig(arch="tcn", levels=-1)
    for name in ARCHS:  # defaults come from the architecture's dataclass
        assert JudgeConfig(arch=name).net == ARCHS[name].Config()


def test_unknown_architecture_is_a_one_line_error(tmp_path):
    with pytest.raises(JudgeError, match=r"^unknown judge architecture 'nosuch'; known: lstm, tcn$"):
        JudgeConfig(arch="nosuch")
    torch.manual_seed(0)
    save_judge(Judge(JudgeConfig(horizon=4, lstm_units=4, fc_units=4)), tmp_path / "j")
    js = tmp_path / "j.json"
    meta = json.loads(js.read_text())
    meta["config"]["arch"] = "nosuch"
    js.write_text(json.dumps(meta))
    with pytest.raises(JudgeFileError) as exc:
        load_judge(tmp_path / "j")
    msg = str(exc.value)
    assert "\n" not in msg and "j.json" in msg and "unknown judge architecture 'nosuch'; known: lstm, tcn" in msg


# -- the seam: an architecture is one class and its registry entry -----------------------------
@dataclass
class _MLPConfig:
    mlp_units: int = 8


class _MLP(Arch):
    """A feed-forward network over the whole flattened trajectory: nothing but this class."""

    name = "mlp_test"
    Config = _MLPConfig

    def layers(self, config):
        return {"mlp": nn.Sequential(nn.Flatten(), nn.Linear((config.horizon + 1) * config.input_size,
                                                             config.net.mlp_units), nn.Tanh()),
                "head": fc_head(config.net.mlp_units, 4, 1, 0.0)}

    def logit(self, judge, u):
        return judge.head(judge.mlp(u)).squeeze(-1)


def test_a_new_architecture_needs_only_its_registry_entry(monkeypatch, tmp_path):
    monkeypatch.setitem(archs.ARCHS, "mlp_test", _MLP())
    torch.manual_seed(0)
    m = Judge(JudgeConfig(arch="mlp_test", horizon=5, mlp_units=6))
    m.fit_normalization(np.random.default_rng(0).normal(size=(20, 6, 3)), np.random.default_rng(1).normal(size=(20, 2)))
    m.eval()
    save_judge(m, tmp_path / "m")
    back, _ = load_judge(tmp_path / "m")
    x, e = torch.randn(2, 6, 3), torch.randn(2, 2)
    assert torch.equal(back(x, e), m(x, e))
    flat = m.arch.flat_module(m)  # the generic l4casadi module
    out = flat(torch.cat([x.reshape(2, -1), e], 1))
    assert torch.equal(out[:, 0], m(x, e)) and torch.allclose(out[:, 1], m.prob(x, e))
    cj = build_casadi_judge(m, "torch")
    xx, ee = np.random.default_rng(2).normal(size=(6, 3)), np.array([0.3, -0.2])
    v, gx, _ = cj.value_and_gradient(xx, ee)
    tv, tgx, _ = torch_logit_and_grad(m, xx, ee)
    assert v == pytest.approx(tv, rel=1e-12) and np.allclose(gx, tgx, rtol=1e-10)
    with pytest.raises(JudgeError, match="no 'native' backend"):
        build_casadi_judge(m, "native")


# -- command line ----------------------------------------------------------------------------
def test_cli_train_tcn_and_inspect(scoop_slice, tmp_path, capsys):
    from judgeopt.cli import main
    from judgeopt.cli.inspect import inspect

    train, test = scoop_slice
    save(train.subset(np.arange(200)), tmp_path / "train.h5")
    save(test, tmp_path / "test.h5")
    out = tmp_path / "tcn"
    rc = main(["train-judge", "--train", str(tmp_path / "train.h5"), "--out", str(out), "--arch", "tcn",
               "--set", "tcn_channels=8", "--set", "levels=2", "--fc-units", "8", "--epochs", "1", "--threads", "1",
               "--quiet"])
    assert rc == 0
    cfg = json.loads(out.with_suffix(".json").read_text())["config"]
    assert (cfg["arch"], cfg["tcn_channels"], cfg["levels"], cfg["fc_units"], cfg["kernel"]) == ("tcn", 8, 2, 8, 3)
    capsys.readouterr()
    assert main(["test-judge", "--judge", str(out), "--data", str(tmp_path / "test.h5"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["arch"] == "tcn"
    assert main(["inspect", str(out)]) == 0
    text = capsys.readouterr().out
    assert "network        : tcn: TCN 2 x 8" in text and "backends torch, torch32, l4casadi" in text
    old = inspect(REPO / "models" / "judge_refined")  # written before architectures had names
    assert old["arch"] == "lstm" and old["config"]["arch"] == "lstm" and old["network"].startswith("LSTM 2 x 100")


@pytest.mark.parametrize("argv, message", [
    (["--arch", "nosuch"], "--arch nosuch: unknown judge architecture 'nosuch'; known: lstm, tcn"),
    (["--arch", "tcn", "--lstm-units", "8"], "--lstm-units: the tcn architecture has no field 'lstm_units'"),
    (["--set", "levels=2"], "--set levels=2: the lstm architecture has no field 'levels'"),
    (["--arch", "tcn", "--set", "levels=two"], "--set levels=two: levels is a number (int)"),
    (["--arch", "tcn", "--set", "levels=-1"], "--arch tcn: layer sizes must be positive"),
])
def test_cli_architecture_errors(argv, message, tmp_path, capsys):
    from judgeopt.cli import main

    rc = main(["train-judge", "--train", str(tmp_path / "never_read.h5"), "--out", str(tmp_path / "j"), *argv])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and message in err and len(err.splitlines()) == 1
