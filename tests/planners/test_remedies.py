"""Remedies against exploiting the judge: an ensemble's pessimistic score and a trust region."""

from __future__ import annotations

import json

import numpy as np
import pytest

from judgeopt.files import REPO, resolve
from judgeopt.data.dataset import load, save
from judgeopt.judge.casadi_fn import build_casadi_judge
from judgeopt.judge.ensemble import EnsembleConfig, load_ensemble, pessimistic, train_ensemble
from judgeopt.judge.model import JudgeError
from judgeopt.judge.store import load_judge
from judgeopt.planners.direct import DirectPlanner
from judgeopt.planners.problem import ProblemError, load_problem
from judgeopt.planners.trust_region import (TrustRegionError, fit_trust_region, load_trust_region,
                                            save_trust_region)

ROOT = REPO  # the source checkout
ENV = {"y_obj": 0.2, "mu": 2.0}


@pytest.fixture(scope="module")
def judge():
    return load_judge(ROOT / "models" / "judge_refined")[0]  # an LSTM: the native graph below


@pytest.fixture(scope="module")
def problem():
    return load_problem(resolve("problems/paper_sim_slow.toml"))


def test_pessimistic_score():
    z = np.array([[1.0, 2.0], [3.0, 2.0]])
    assert pessimistic(z, 0.0).tolist() == [2.0, 2.0]
    assert pessimistic(z, 1.0).tolist() == [1.0, 2.0]
    assert pessimistic(z, np.inf).tolist() == [1.0, 2.0]


def test_ensemble_trains_resumes_and_checks_its_members(tmp_path):
    ds = load(ROOT / "data" / "train.h5")
    small = save(ds.subset(np.random.default_rng(0).choice(ds.n, 300, replace=False)), tmp_path / "small.h5")
    out = train_ensemble(small, None, tmp_path / "ens", EnsembleConfig(k=2, epochs=1), progress=False)
    members, meta = load_ensemble(out)
    assert len(members) == 2 and meta["members"][0]["weights_sha256"] != meta["members"][1]["weights_sha256"]
    from judgeopt.judge.data_ranges import env_ranges_of

    for i in (0, 1):  # each member records the environments of its own bootstrap sample
        sample = load(small).subset(np.random.default_rng([0, i]).integers(0, 300, 300))
        assert json.loads((out / f"member_{i}.json").read_text())["train_data"]["env_ranges"] == env_ranges_of(sample)
    stamp = (out / "member_0.pt").stat().st_mtime_ns
    train_ensemble(small, None, out, EnsembleConfig(k=2, epochs=1), progress=False)  # resumes: nothing retrained
    assert (out / "member_0.pt").stat().st_mtime_ns == stamp
    manifest = json.loads((out / "ensemble.json").read_text())
    manifest["members"][1]["weights_sha256"] = "0" * 64
    (out / "ensemble.json").write_text(json.dumps(manifest))
    with pytest.raises(JudgeError, match="replaced after the ensemble was assembled"):
        load_ensemble(out)
    with pytest.raises(JudgeError, match="not a judge ensemble"):
        load_ensemble(tmp_path)


def test_direct_with_an_ensemble_of_identical_members_is_the_plain_solve(judge, problem):
    cj = build_casadi_judge(judge, backend="native")
    plain = DirectPlanner(problem, judge, cj).solve(ENV)
    ens = DirectPlanner(problem, judge, cj, members=[cj, cj]).solve(ENV)
    assert ens.status == "solved" and ens.max_constraint_violation < 1e-6
    assert ens.predicted_success == pytest.approx(plain.predicted_success, abs=2e-3)
    assert ens.info["member_success"][0] == pytest.approx(ens.info["member_success"][1])


def test_trust_region_model_and_constraint(tmp_path, judge, problem):
    ds = load(ROOT / "data" / "train.h5")
    ok = ds.commands[ds.labels == 1][:2000]
    tr = fit_trust_region(ok, components=6)
    d = tr.distance(ok.reshape(len(ok), -1))
    assert np.median(d) == pytest.approx(tr.quantiles["q50"], rel=0.05)
    odd = ok[0].copy()
    odd[:, 1] += 0.2 * (-1.0) ** np.arange(len(odd))  # a velocity chattering by 0.4 m/s every step: no demo does
    assert tr.distance(odd.ravel())[0] > 2 * tr.quantiles["q99"]
    path = save_trust_region(tr, tmp_path / "tr", {})
    assert np.allclose(load_trust_region(path).distance(ok[:5].reshape(5, -1)), d[:5])
    with pytest.raises(TrustRegionError, match="another horizon"):
        load_trust_region(path, features=12)
    path.write_text("{")
    with pytest.raises(TrustRegionError, match="corrupt"):
        load_trust_region(path)

    cj = build_casadi_judge(judge, backend="native")
    free = DirectPlanner(problem, judge, cj).solve(ENV)
    bound = 0.8 * float(tr.distance(free.plan.as_array().ravel())[0])
    held = DirectPlanner(problem.with_overrides(trust_region=bound), judge, cj, trust=tr).solve(ENV)
    assert held.status == "solved" and held.max_constraint_violation < 1e-6, held.residuals
    assert held.info["trust_distance"] <= bound + 1e-6
    with pytest.raises(ProblemError, match="no trust-region model"):
        DirectPlanner(problem.with_overrides(trust_region=bound), judge, cj)


def test_generator_trains_against_the_pessimistic_score_and_is_only_found_for_its_ensemble(tmp_path, problem):
    import torch

    from judgeopt.cli import main
    from judgeopt.judge.ensemble import PessimisticJudge
    from judgeopt.planners.store import find_generator, load_generator_meta

    members, _ = load_ensemble(ROOT / "models" / "judge_ensemble")
    x = torch.randn(4, problem.steps + 1, 3)
    env = torch.tensor([[0.2, 1.5]] * 4)
    with torch.no_grad():
        logits = np.stack([m(x, env).numpy() for m in members])
        np.testing.assert_allclose(PessimisticJudge(members, 1.0)(x, env).numpy(), pessimistic(logits, 1.0), rtol=1e-5)
        np.testing.assert_allclose(PessimisticJudge(members, np.inf)(x, env).numpy(), logits.min(0), rtol=1e-6)

    folder = tmp_path / "models"
    args = ["train-generator", "--problem", "problems/paper_sim_slow.toml", "--epochs", "3", "--quiet"]
    assert main(args + ["--out", str(folder / "generator_plain")]) == 0
    assert main(args + ["--ensemble", "models/judge_ensemble", "--pessimism", "1",
                        "--out", str(folder / "generator_pessimistic")]) == 0
    assert load_generator_meta(folder / "generator_pessimistic")["loss_judge"]["pessimism"] == 1.0
    plain = find_generator(folder, problem)
    assert plain is not None and plain.name == "generator_plain"
    with_ensemble = problem.with_overrides(ensemble="models/judge_ensemble", pessimism=1.0)
    assert find_generator(folder, with_ensemble).name == "generator_pessimistic"
    assert find_generator(folder, with_ensemble.with_overrides(pessimism=2.0)).name == "generator_plain"
