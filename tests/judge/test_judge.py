"""The success judge: model, storage, training, metrics, CasADi backends, command line."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
import torch

from judgeopt.data.dataset import Dataset, save
from judgeopt.judge.casadi_fn import build_casadi_judge, model_hash, torch_logit_and_grad
from judgeopt.judge.evaluate import classification_metrics, evaluate_judge, expected_calibration_error
from judgeopt.judge.model import Judge, JudgeConfig, JudgeError, TrajectoryError, UnrolledJudge
from judgeopt.judge.store import (IncompatibleJudgeError, JudgeFileError, check_compatible, load_judge, model_paths,
                                  save_judge)
from judgeopt.judge.train import TrainConfig, stratified_split, train_judge

torch.set_num_threads(1)

SMALL = dict(lstm_units=8, fc_units=16)


def synthetic(n: int, horizon: int = 8, seed: int = 0, env_names=("y_obj", "mu")) -> Dataset:
    """Scoop-like ramps; success when the response ends past the object (y_N > y_obj):
    separable, but only by comparing the LAST sample with the environment."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, horizon + 1)
    y_end = rng.uniform(0.0, 0.38, n)
    y = -0.03 + (y_end + 0.03)[:, None] * (3 * t**2 - 2 * t**3)[None]
    ydot = np.gradient(y, 0.05, axis=1)
    f = 12 + 3 * rng.standard_normal((n, horizon + 1))
    resp = np.stack([y, ydot, f], axis=2)
    env = np.stack([rng.uniform(0.10, 0.28, n), rng.uniform(1, 3, n)], axis=1)
    labels = (y_end > env[:, 0]).astype(np.int64)
    cols = {"y_obj": env[:, 0], "mu": env[:, 1]}
    env = np.stack([cols[k] for k in env_names], axis=1)
    return Dataset(resp.copy(), resp, labels, env, 0.05, tuple(env_names), meta={"source": "synthetic", "seed": seed})


def small_judge(horizon: int = 6, seed: int = 3, env_names=("y_obj", "mu"), **kw) -> Judge:
    torch.manual_seed(seed)
    m = Judge(JudgeConfig(horizon=horizon, env_names=env_names, **{**SMALL, **kw}))
    ds = synthetic(50, horizon, seed)
    from judgeopt.judge.model import select_env
    m.fit_normalization(ds.responses, select_env(ds.env, ds.env_names, env_names))
    return m.eval()


# -- model -----------------------------------------------------------------------------------
def test_shapes_and_probability():
    m = small_judge()
    x, e = torch.randn(5, 7, 3), torch.randn(5, 2)
    assert m(x, e).shape == (5,)
    p = m.prob(x, e)
    assert torch.all((p > 0) & (p < 1))
    assert torch.allclose(p, torch.sigmoid(m.logit(x, e)))
    assert m.predict_proba(np.zeros((7, 3)), np.array([0.2, 2.0])).shape == (1,)


def test_unrolled_concat_cell_equals_nn_lstm():
    m = small_judge().double()
    u = UnrolledJudge(m)
    x, e = torch.randn(4, 7, 3, dtype=torch.float64), torch.randn(4, 2, dtype=torch.float64)
    out = u(torch.cat([x.reshape(4, -1), e], 1))
    assert torch.allclose(out[:, 0], m(x, e), atol=1e-12)
    assert torch.allclose(out[:, 1], m.prob(x, e), atol=1e-12)


def test_horizon_mismatch_and_nan_are_clear_errors():
    m = small_judge(horizon=6)
    with pytest.raises(TrajectoryError, match=r"horizon N = 9 .* N = 6"):
        m.predict_proba(np.zeros((10, 3)), np.array([0.2, 2.0]))
    x = np.zeros((7, 3))
    x[4, 2] = np.nan
    with pytest.raises(TrajectoryError, match=r"non-finite .* index \(0, 4, 2\)"):
        m.predict_proba(x, np.array([0.2, 2.0]))
    with pytest.raises(TrajectoryError, match="environment"):
        m.predict_proba(np.zeros((7, 3)), np.array([0.2]))
    assert issubclass(TrajectoryError, ValueError)


def test_check_compatible_says_what_differs():
    cfg = JudgeConfig(horizon=30, dt=0.05, env_names=("y_obj", "mu"))
    check_compatible(cfg, horizon=30, dt=0.05, channels=("y", "ydot", "f"), env_names=("mu", "y_obj", "x"))
    with pytest.raises(IncompatibleJudgeError) as exc:
        check_compatible(cfg, horizon=20, dt=0.01, channels=("y", "f"), env_names=("y_obj",))
    msg = str(exc.value)
    for part in ("N = 20", "N = 30", "dt = 0.01", "channels", "['mu'] are missing"):
        assert part in msg


# -- storage ---------------------------------------------------------------------------------
def test_save_load_round_trip_identical(tmp_path):
    m = small_judge()
    pt, js = save_judge(m, tmp_path / "j", {"metrics": {"test_accuracy": 0.5}, "seed": 7})
    assert pt.name == "j.pt" and js.name == "j.json"
    m2, meta = load_judge(tmp_path / "j")
    x, e = torch.randn(3, 7, 3), torch.randn(3, 2)
    assert torch.equal(m(x, e), m2(x, e))
    for k in ("x_mean", "x_std", "e_mean", "e_std"):  # normalisation stored and reloaded
        assert torch.equal(getattr(m, k), getattr(m2, k))
        assert not torch.all(getattr(m2, k) == (0 if "mean" in k else 1))
    assert meta["seed"] == 7 and meta["config"]["horizon"] == 6 and meta["package_version"]
    assert meta["normalization"]["x_std"] == m.x_std.tolist()
    assert model_hash(m) == model_hash(m2)
    assert not list(tmp_path.glob("*.tmp"))  # atomic writes leave nothing behind
    load_judge(tmp_path / "j.pt")  # either name works


def test_missing_and_corrupt_model_files(tmp_path):
    with pytest.raises(JudgeFileError, match="nope.json: no such"):
        load_judge(tmp_path / "nope")
    m = small_judge()
    pt, js = save_judge(m, tmp_path / "j")
    good = js.read_text()
    js.write_text(good[:40])
    with pytest.raises(JudgeFileError, match="j.json: corrupt model metadata"):
        load_judge(tmp_path / "j")
    js.write_text(json.dumps({"format": "something else"}))
    with pytest.raises(JudgeFileError, match="not a judgeopt judge"):
        load_judge(tmp_path / "j")
    js.write_text(good)
    data = pt.read_bytes()
    pt.write_bytes(data[: len(data) // 2])
    with pytest.raises(JudgeFileError, match="j.pt: weights file does not match the sha256"):
        load_judge(tmp_path / "j")
    with pytest.raises(JudgeFileError, match="j.pt: corrupt weights file"):
        load_judge(tmp_path / "j", check_hash=False)
    pt.unlink()
    with pytest.raises(JudgeFileError, match="j.pt: no such weights file"):
        load_judge(tmp_path / "j")
    assert model_paths("a/b.json") == model_paths("a/b")


# -- metrics ---------------------------------------------------------------------------------
def test_metrics_by_hand():
    y = np.array([1, 1, 0, 0, 0])
    p = np.array([0.9, 0.2, 0.6, 0.1, 0.1])
    m = classification_metrics(y, p)
    assert m["n"] == 5 and m["accuracy"] == pytest.approx(0.6)
    assert m["precision"] == pytest.approx(0.5) and m["recall"] == pytest.approx(0.5)
    assert m["confusion"] == [[2, 1], [1, 1]]
    # bins: 0.9 -> [1], 0.2 -> [0], 0.6 -> [0], 0.1, 0.1 -> [0]
    expect = (1 / 5) * abs(1 - 0.9) + (1 / 5) * abs(1 - 0.2) + (1 / 5) * abs(0 - 0.6) + (2 / 5) * abs(0 - 0.1)
    assert m["ece"] == pytest.approx(expect)
    assert expected_calibration_error(np.ones(4), np.ones(4)) == 0.0


# -- training --------------------------------------------------------------------------------
def _train(ds, test, **kw):
    cfg = JudgeConfig(horizon=ds.horizon, env_names=kw.pop("env_names", ("y_obj", "mu")), lstm_units=16, fc_units=16,
                      dropout=0.1)
    tc = TrainConfig(**{"epochs": 40, "batch_size": 32, "lr": 1e-2, "seed": 0, "progress": False, **kw})
    return train_judge(ds, test, cfg, tc)


@pytest.fixture(scope="module")
def trained():
    ds, test = synthetic(600, seed=1), synthetic(300, seed=2)
    model, result = _train(ds, test)
    return ds, test, model, result


def test_training_learns_a_separable_rule(trained):
    _, test, model, result = trained
    acc = evaluate_judge(model, test)["accuracy"]
    assert acc >= 0.93, f"held-out accuracy {acc:.3f}"
    assert result.best == result.history[result.best_epoch - 1]
    assert result.best["val_accuracy"] == max(r["val_accuracy"] for r in result.history)
    assert result.n_val == 60 and result.n_train == 540 and result.n_test == 300
    assert {"train_accuracy", "val_accuracy", "test_accuracy", "seconds"} <= set(result.history[0])


def test_training_is_deterministic():
    ds = synthetic(120, seed=4)
    m1, r1 = _train(ds, None, epochs=2)
    m2, r2 = _train(ds, None, epochs=2)
    for k, v in m1.state_dict().items():
        assert torch.equal(v, m2.state_dict()[k])
    assert [r["val_loss"] for r in r1.history] == [r["val_loss"] for r in r2.history]


def test_validation_split_is_stratified_and_seeded():
    y = np.array([0] * 90 + [1] * 10)
    t, v = stratified_split(y, 0.1, 0)
    assert len(v) == 10 and y[v].sum() == 1 and len(np.intersect1d(t, v)) == 0 and len(t) + len(v) == 100
    assert np.array_equal(v, stratified_split(y, 0.1, 0)[1])
    assert not np.array_equal(v, stratified_split(y, 0.1, 1)[1])


def test_inverted_labels_learn_the_opposite(trained):
    ds, test, _, _ = trained
    model, result = _train(ds, test, invert_labels=True)
    assert evaluate_judge(model, test, invert_labels=True)["accuracy"] >= 0.9
    assert evaluate_judge(model, test)["accuracy"] <= 0.1
    assert "test_accuracy_true_labels" in result.history[0]


def test_env_subset_selects_columns_by_name(trained):
    ds, test, _, _ = trained
    model, _ = _train(ds, test, env_names=("y_obj",), epochs=25)
    assert model.config.env_names == ("y_obj",)
    assert evaluate_judge(model, test)["accuracy"] >= 0.9  # the rule needs only y_obj
    # column order in the file does not matter: selection is by name
    swapped = Dataset(test.commands, test.responses, test.labels, test.env[:, ::-1].copy(), test.dt, ("mu", "y_obj"))
    assert evaluate_judge(model, swapped)["accuracy"] == evaluate_judge(model, test)["accuracy"]
    no_y = Dataset(test.commands, test.responses, test.labels, test.env[:, 1:], test.dt, ("mu",))
    with pytest.raises(IncompatibleJudgeError, match=r"\['y_obj'\] are missing"):
        evaluate_judge(model, no_y)


# -- CasADi ----------------------------------------------------------------------------------

def _check_backend(cj, m: Judge, n_points: int = 3, seed: int = 0):
    import casadi as cs
    rng = np.random.default_rng(seed)
    n1 = m.config.horizon + 1
    X, E = cs.MX.sym("x", n1 * 3), cs.MX.sym("e", 2)
    logit, prob = cj.fn(X, E)
    jac_p = cs.Function("jp", [X, E], [cs.jacobian(prob, cs.vertcat(X, E))])
    for _ in range(n_points):
        x = rng.normal([0.1, 0.5, 12], [0.1, 0.5, 4], size=(n1, 3))
        e = rng.uniform([0.1, 1], [0.28, 3])
        v, gx, ge = cj.value_and_gradient(x, e)
        tv, tgx, tge = torch_logit_and_grad(m, x, e)
        g, tg = np.concatenate([gx, ge]), np.concatenate([tgx, tge])
        assert abs(tg).max() > 1e-8, "degenerate judge: zero gradient"
        assert v == pytest.approx(tv, rel=1e-5, abs=1e-9)
        np.testing.assert_allclose(g, tg, rtol=1e-5, atol=1e-5 * abs(tg).max())
        p = 1 / (1 + np.exp(-tv))
        assert float(cj.fn(x.ravel(), e)[1]) == pytest.approx(p, rel=1e-5)
        np.testing.assert_allclose(np.asarray(jac_p(x.ravel(), e)).ravel(), p * (1 - p) * tg, rtol=1e-5,
                                   atol=1e-5 * abs(tg).max() * p * (1 - p))


@pytest.mark.parametrize("backend", ["native", "torch"])
def test_casadi_backend_matches_torch(backend, tmp_path):
    m = small_judge(horizon=6)
    _check_backend(build_casadi_judge(m, backend, cache_dir=tmp_path), m)


@pytest.mark.parametrize("backend", ["l4casadi", "compiled"])
def test_cached_backend_matches_torch_and_second_build_hits_cache(backend, tmp_path, monkeypatch):
    m = small_judge(horizon=5)
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    monkeypatch.setenv("JUDGEOPT_CACHE", str(tmp_path / "cache"))
    cj = build_casadi_judge(m, backend)  # cache from $JUDGEOPT_CACHE
    assert not cj.cache_hit and cj.cache_dir.parent.parent == tmp_path / "cache"
    assert not list(cwd.iterdir()), "the build wrote into the working folder (_l4c_generated?)"
    tmp_path = tmp_path / "cache"
    _check_backend(cj, m)
    t = time.perf_counter()
    cj2 = build_casadi_judge(m, backend, cache_dir=tmp_path)
    assert cj2.cache_hit and cj2.cache_dir == cj.cache_dir
    assert time.perf_counter() - t < 0.2 * cj.build_seconds
    _check_backend(cj2, m, n_points=1, seed=5)
    # a different model gets a different cache key
    other = small_judge(horizon=5, seed=4)
    assert model_hash(other) != model_hash(m)
    assert not list(tmp_path.glob(f"{backend}/.*"))  # no half-built folders left


@pytest.mark.parametrize("backend", ["native", "torch"])
def test_casadi_gradient_finite_when_gates_saturate(backend):
    """Far outside the training range the gates saturate: value and gradient stay finite."""
    m = small_judge(horizon=6)
    cj = build_casadi_judge(m, backend)
    x = np.tile([5.0, -40.0, 1e5], (7, 1))
    v, gx, ge = cj.value_and_gradient(x, np.array([-50.0, 400.0]))
    assert np.isfinite(v) and np.isfinite(gx).all() and np.isfinite(ge).all()
    tv, tgx, _ = torch_logit_and_grad(m, x, np.array([-50.0, 400.0]))
    assert v == pytest.approx(tv, rel=1e-6, abs=1e-9)
    np.testing.assert_allclose(gx, tgx, atol=1e-9)


def test_l4casadi_resolves_float64_input_changes(tmp_path):
    """l4casadi's C++ side hands the model float32 inputs; the hi/lo split must keep the
    function responsive to input changes far below float32 resolution."""
    m = small_judge(horizon=5)
    cj = build_casadi_judge(m, "l4casadi", cache_dir=tmp_path)
    ref = build_casadi_judge(m, "torch")
    rng = np.random.default_rng(0)
    x = rng.normal([0.1, 0.5, 12], [0.1, 0.5, 4], size=(6, 3)).ravel()
    e = np.array([0.2, 2.0])
    for d in (1e-10, 1e-9):
        dx = x * (1 + d)
        got = float(cj.fn(dx, e)[0]) - float(cj.fn(x, e)[0])
        want = float(ref.fn(dx, e)[0]) - float(ref.fn(x, e)[0])
        assert want != 0 and got == pytest.approx(want, rel=1e-3)


def test_casadi_judge_in_an_nlp(tmp_path):
    """The function works inside an Ipopt problem (limited-memory Hessian)."""
    import casadi as cs
    m = small_judge(horizon=6)
    for backend in ("native", "torch", "l4casadi"):
        cj = build_casadi_judge(m, backend, cache_dir=tmp_path)
        x = cs.MX.sym("x", 21)
        x0 = np.tile([0.1, 0.5, 12.0], 7)
        nlp = {"x": x, "f": -cj.fn(x, cs.DM([0.2, 2.0]))[0] + 0.5 * cs.sumsqr(x - x0)}
        solver = cs.nlpsol("s", "ipopt", nlp, {"ipopt.print_level": 0, "print_time": False,
                                               "ipopt.hessian_approximation": "limited-memory"})
        sol = solver(x0=x0)
        assert solver.stats()["success"]
        _, gx, _ = cj.value_and_gradient(np.asarray(sol["x"]).reshape(7, 3), np.array([0.2, 2.0]))
        np.testing.assert_allclose(np.asarray(sol["x"]).ravel() - x0, gx, atol=1e-6)  # stationarity


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["native", "torch", "l4casadi"])
def test_default_size_judge_at_horizon_30(backend, tmp_path):
    torch.manual_seed(0)
    m = Judge(JudgeConfig())
    ds = synthetic(50, 30)
    m.fit_normalization(ds.responses, ds.env)
    m.eval()
    _check_backend(build_casadi_judge(m, backend, cache_dir=tmp_path), m, n_points=2)


# -- command line ----------------------------------------------------------------------------
def test_cli_train_test_inspect(tmp_path, capsys):
    from judgeopt.cli import main
    from judgeopt.cli.inspect import kind_of
    from judgeopt.cli.judge import inspect_model
    train, test = tmp_path / "train.h5", tmp_path / "test.h5"
    save(synthetic(200, seed=1), train)
    save(synthetic(100, seed=2), test)
    out = tmp_path / "models" / "j"
    rc = main(["train-judge", "--train", str(train), "--test", str(test), "--out", str(out), "--epochs", "2",
               "--lstm-units", "8", "--fc-units", "8", "--batch-size", "32", "--threads", "1", "--quiet"])
    assert rc == 0
    for suffix in (".pt", ".json", ".history.csv", ".history.json", ".accuracy.png"):
        assert out.with_name("j" + suffix).exists(), suffix
    meta = json.loads(out.with_name("j.json").read_text())
    assert meta["command"].startswith("judgeopt ") and meta["seed"] == 0
    assert len(meta["train_data"]["sha256"]) == 64 and meta["metrics"]["n_val"] == 20
    assert 0 <= meta["metrics"]["test_accuracy"] <= 1
    capsys.readouterr()
    assert main(["test-judge", "--judge", str(out), "--data", str(test), "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["n"] == 100 and res["accuracy"] == pytest.approx(meta["metrics"]["test_accuracy"])
    assert main(["test-judge", "--judge", str(out), "--data", str(test)]) == 0
    assert "confusion matrix" in capsys.readouterr().out
    info = inspect_model(out)
    assert info["config"]["lstm_units"] == 8 and info["parameters"] > 0
    assert [kind_of(p)[0] for p in (out, str(out) + ".json", str(out) + ".pt", train)] == ["judge"] * 3 + ["dataset"]


def test_cli_errors_are_clear(tmp_path, capsys):
    from judgeopt.cli import main
    m = small_judge(horizon=6)
    save_judge(m, tmp_path / "j")
    data = tmp_path / "d.h5"
    save(synthetic(10, horizon=9), data)
    assert main(["test-judge", "--judge", str(tmp_path / "j"), "--data", str(data)]) == 5
    assert "horizon N = 9" in capsys.readouterr().err
    assert main(["test-judge", "--judge", str(tmp_path / "missing"), "--data", str(data)]) == 5
    assert "missing.json: no such" in capsys.readouterr().err
    (tmp_path / "bad.json").write_text("{not json")
    assert main(["test-judge", "--judge", str(tmp_path / "bad"), "--data", str(data)]) == 5
    assert "corrupt model metadata" in capsys.readouterr().err
    not_h5 = tmp_path / "x.h5"
    not_h5.write_text("hello")
    assert main(["test-judge", "--judge", str(tmp_path / "j"), "--data", str(not_h5)]) == 5
    assert "not a readable HDF5 file" in capsys.readouterr().err
    assert main(["train-judge", "--train", str(data), "--out", str(tmp_path / "k"), "--env-names", "zeta",
                 "--quiet"]) == 2
    assert "--env-names zeta" in capsys.readouterr().err


# -- commands as a second view ------------------------------------------------------------------
def command_only_signal(n: int, seed: int) -> Dataset:
    """The label is in the command alone: the commands are synthetic()'s ramps, while every
    response is the same flat trajectory plus noise (a controller that tracked nothing)."""
    ds = synthetic(n, seed=seed)
    rng = np.random.default_rng(seed + 100)
    flat = np.broadcast_to(ds.responses.mean(axis=0), ds.responses.shape)
    resp = flat + 0.01 * ds.responses.std(axis=0) * rng.standard_normal(ds.responses.shape)
    return Dataset(ds.responses.copy(), resp, ds.labels, ds.env, ds.dt, ds.env_names)


def test_command_views_follow_their_demonstrations():
    from judgeopt.judge.train import with_command_views
    ds = command_only_signal(10, seed=0)
    ds.responses[:4] = ds.commands[:4]  # four demonstrations tracked perfectly: no second view
    both = with_command_views(ds)
    assert both.n == 16
    assert np.array_equal(both.responses[10:], ds.commands[4:]) and np.array_equal(both.labels[10:], ds.labels[4:])
    assert np.array_equal(both.env[10:], ds.env[4:])
    with pytest.raises(JudgeError, match="without --with-commands"):
        with_command_views(synthetic(10))  # commands equal responses, as in imported recordings


def test_with_commands_learns_what_only_the_command_shows(tmp_path, capsys):
    from judgeopt.cli import main
    ds, test = command_only_signal(600, seed=1), command_only_signal(300, seed=2)
    plain, _ = _train(ds, test)
    both, result = _train(ds, test, with_commands=True)
    assert evaluate_judge(both, test, view="command")["accuracy"] >= 0.9
    assert evaluate_judge(plain, test, view="command")["accuracy"] <= 0.8  # the responses taught it nothing
    assert result.n_train == 540 and "test_command_accuracy" in result.history[0]
    save_judge(both, tmp_path / "j")
    save(test, tmp_path / "t.h5")
    capsys.readouterr()
    assert main(["test-judge", "--judge", str(tmp_path / "j"), "--data", str(tmp_path / "t.h5"), "--view", "command",
                 "--json"]) == 0
    res = json.loads(capsys.readouterr().out)
    assert res["view"] == "command" and res["accuracy"] >= 0.9


def test_with_commands_on_recordings_is_one_line(tmp_path, capsys):
    from judgeopt.cli import main
    save(synthetic(60, seed=1), tmp_path / "rec.h5")
    assert main(["train-judge", "--train", str(tmp_path / "rec.h5"), "--with-commands", "--epochs", "1",
                 "--out", str(tmp_path / "k"), "--quiet"]) == 5
    err = capsys.readouterr().err.strip()
    assert "without --with-commands" in err and len(err.splitlines()) == 1


def test_cli_init_continues_a_judge_and_keeps_what_it_was_trained_with(tmp_path, capsys):
    from judgeopt.cli import main
    first, more = tmp_path / "a.h5", tmp_path / "b.h5"
    save(synthetic(120, seed=1), first)
    b = synthetic(120, seed=7)
    b.responses[:] = 3.0 * b.responses + 1.0  # other statistics: a refitted normalisation would differ
    save(b, more)
    common = ["--epochs", "1", "--batch-size", "32", "--threads", "1", "--quiet"]
    assert main(["train-judge", "--train", str(first), "--out", str(tmp_path / "j"), "--arch", "tcn",
                 "--set", "tcn_channels=4", *common]) == 0
    assert main(["train-judge", "--train", str(more), "--out", str(tmp_path / "k"), "--init", str(tmp_path / "j"),
                 "--lr", "1e-4", *common]) == 0  # no --arch: the default (lstm) must not replace the judge's own
    a, b_meta = (json.loads((tmp_path / f"{n}.json").read_text()) for n in "jk")
    assert b_meta["config"]["arch"] == "tcn" and b_meta["config"]["tcn_channels"] == 4
    assert b_meta["normalization"] == a["normalization"]
    assert b_meta["init"]["weights_sha256"] == a["weights_sha256"] != b_meta["weights_sha256"]
    capsys.readouterr()
    # "--arch lstm" alone: the default's own name, once silently ignored
    for extra in (["--set", "tcn_channels=8"], ["--arch", "lstm"], ["--arch", "lstm", "--lstm-units", "4"],
                  ["--env-names", "mu"]):
        assert main(["train-judge", "--train", str(more), "--out", str(tmp_path / "m"), "--init", str(tmp_path / "j"),
                     *extra, *common]) != 0
        err = capsys.readouterr().err.strip()
        assert "drop --arch, --set and --env-names" in err and len(err.splitlines()) == 1, extra
    assert main(["train-judge", "--train", str(more), "--out", str(tmp_path / "m"), "--init",
                 str(tmp_path / "none"), *common]) != 0
    assert "--init" in capsys.readouterr().err and not (tmp_path / "m.json").exists()
