"""The judge's input normalisation against a separate numpy computation, on data whose channels
differ in scale by three orders of magnitude (position in m, velocity in m/s, force in N): one
mean and one std per channel and per environment variable, never one for all."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from judgeopt.data.dataset import Dataset
from judgeopt.judge.model import Judge, JudgeConfig
from judgeopt.judge.train import TrainConfig, train_judge

torch.set_num_threads(1)

H = 6


def scaled_data(n: int = 400, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(responses (n, H+1, 3), env (n, 2), labels): channel means 0.1 / -0.5 / 15 and stds about
    0.01 / 0.3 / 4; environment means 0.2 / 30 and stds 0.05 / 8."""
    rng = np.random.default_rng(seed)
    x = np.stack([0.1 + 0.01 * rng.standard_normal((n, H + 1)), -0.5 + 0.3 * rng.standard_normal((n, H + 1)),
                  15 + 4 * rng.standard_normal((n, H + 1))], axis=2)
    e = np.stack([0.2 + 0.05 * rng.standard_normal(n), 30 + 8 * rng.standard_normal(n)], axis=1)
    return x, e, (x[:, -1, 2] > 15).astype(np.int64)


def numpy_stats(x: np.ndarray, e: np.ndarray):
    """Per channel over every demonstration and sample; per environment variable over demonstrations."""
    flat = x.reshape(-1, x.shape[-1])
    return flat.mean(0), flat.std(0), e.mean(0), e.std(0)


def test_fit_normalization_is_per_channel():
    x, e, _ = scaled_data()
    m = Judge(JudgeConfig(horizon=H, lstm_units=4, fc_units=4))
    m.fit_normalization(x, e)
    xm, xs, em, es = numpy_stats(x, e)
    assert np.allclose(m.x_mean.numpy(), xm, rtol=1e-5) and np.allclose(m.x_std.numpy(), xs, rtol=1e-5)
    assert np.allclose(m.e_mean.numpy(), em, rtol=1e-5) and np.allclose(m.e_std.numpy(), es, rtol=1e-5)
    assert xs.max() / xs.min() > 100  # the check means something: one std for all would be far off


def test_the_lstm_sees_every_channel_at_zero_mean_and_unit_std():
    x, e, _ = scaled_data()
    m = Judge(JudgeConfig(horizon=H, lstm_units=4, fc_units=4))
    m.fit_normalization(x, e)
    with torch.no_grad():
        z = m.features(torch.as_tensor(x, dtype=torch.float32), torch.as_tensor(e, dtype=torch.float32)).numpy()
    flat = z.reshape(-1, z.shape[-1])  # [y, ydot, f, y_obj, mu] per step
    assert np.allclose(flat.mean(0), 0, atol=1e-4) and np.allclose(flat.std(0), 1, atol=1e-4)
    # and by hand for one sample: (value - channel mean) / channel std
    xm, xs, em, es = numpy_stats(x, e)
    assert np.allclose(z[7, 3], np.concatenate([(x[7, 3] - xm) / xs, (e[7] - em) / es]), atol=1e-4)


def test_a_constant_channel_is_centred_not_divided_by_zero():
    x, e, _ = scaled_data()
    e[:, 1] = 2.0  # a fixed mu
    m = Judge(JudgeConfig(horizon=H, lstm_units=4, fc_units=4))
    m.fit_normalization(x, e)
    assert m.e_mean[1].item() == pytest.approx(2.0) and m.e_std[1].item() == 1.0
    assert m.e_std[0].item() == pytest.approx(e[:, 0].std(), rel=1e-5)


def test_training_normalises_on_its_own_training_part_per_channel():
    """train_judge fits the normalisation on the demonstrations it trains on: within a few % of
    the whole set's per-channel figures (it holds out a validation part), never one std for all."""
    x, e, labels = scaled_data(300, seed=1)
    ds = Dataset(x.copy(), x, labels, e, 0.05, ("y_obj", "mu"), meta={"source": "test"})
    m, _ = train_judge(ds, None, JudgeConfig(horizon=H, lstm_units=4, fc_units=4),
                       TrainConfig(epochs=1, batch_size=64, seed=0, threads=1))
    xm, xs, em, es = numpy_stats(x, e)
    assert np.allclose(m.x_std.numpy(), xs, rtol=0.1) and np.allclose(m.e_std.numpy(), es, rtol=0.1)
    assert np.allclose(m.x_mean.numpy(), xm, rtol=0.05, atol=0.01 * xs)
    assert np.allclose(m.e_mean.numpy(), em, rtol=0.05, atol=0.05 * es)
