"""One generator for any limits (issue 6): the generator conditioned on q̇_max, f_min, f_max."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from judgeopt.files import REPO, resolve
from judgeopt.cli import main
from judgeopt.planners.generator import AmortizedPlanner, Generator
from judgeopt.planners.limits import CONDITION_NAMES, LimitRanges
from judgeopt.planners.generator_train import GeneratorTrainConfig, generator_loss, train_generator
from judgeopt.planners.problem import Problem, ProblemError, load_problem
from judgeopt.planners.result import constraint_residuals
from judgeopt.planners.store import (
    GeneratorFileError, find_generator, load_generator, load_generator_meta, matches, save_generator,
)

ROOT = REPO  # the source checkout
SHIPPED = ROOT / "models" / "generator_conditioned"
#: the soft violation of q̇_max, f_min, f_max the shipped conditioned generator stays within
#: (m/s or N) on limits drawn from its ranges; measured at most 5.8e-3 (q̇_max) and 7.8e-3 m (q_end)
#: on the 200 draws below (docs/planners.md): the penalty Q = 1000 lets a few mm through
SOFT_LIMIT_TOL = 1e-2


@pytest.fixture(scope="module")
def judge():
    from judgeopt.judge.store import load_judge

    return load_judge(ROOT / "models" / "judge_demos_tcn")[0]


@pytest.fixture(scope="module")
def tiny(judge):
    """A conditioned generator after a few epochs (not a good planner, a real file)."""
    tc = GeneratorTrainConfig(epochs=6, batch=8, seed=1, threads=1, progress=False)
    return train_generator(Problem(), judge, tc=tc, conditioned=LimitRanges())


def test_ranges_are_checked():
    with pytest.raises(ProblemError, match="f_min range"):
        LimitRanges(f_min=(5.0, 16.0), f_max=(15.0, 25.0))
    with pytest.raises(ProblemError, match="lo <= hi"):
        LimitRanges(qdot_max=(1.0, 0.5))
    with pytest.raises(ProblemError, match="cannot reach"):
        LimitRanges(qdot_max=(0.2, 1.0)).check(Problem())  # y_obj = 0.28 m needs 0.214 m/s
    LimitRanges().check(Problem())
    r = LimitRanges().sample(np.random.default_rng(0), 1000)
    assert r.shape == (1000, 3) and (r[:, 1] < r[:, 2]).all()
    assert LimitRanges().contains(Problem()) and not LimitRanges().contains(Problem(qdot_max=1.2))


def test_outputs_scale_with_each_samples_limits():
    """With the last layer's weights zeroed, the force is the middle of each plan's own force
    range and the acceleration a fixed fraction of each plan's own q̇_max - q̇_min."""
    torch.manual_seed(0)
    g = Generator(Problem(), conditioned=LimitRanges())
    last = g.net[-1]
    with torch.no_grad():
        last.weight.zero_()
        last.bias.copy_(torch.tensor([0.0, 0.5]))
    lim = torch.tensor([[0.3, 5.0, 15.0], [1.0, 10.0, 25.0]])
    with torch.no_grad():
        x = g.rollout(torch.tensor([[0.2, 2.0], [0.2, 2.0]]), lim)
    assert torch.allclose(x[0, :, 2], torch.tensor(10.0)) and torch.allclose(x[1, :, 2], torch.tensor(17.5))
    acc = torch.diff(x[..., 1], dim=1) / 0.05
    assert torch.allclose(acc[0], torch.tensor(0.5 * (0.3 + 0.05) / 0.2)) and torch.allclose(
        acc[1], torch.tensor(0.5 * (1.0 + 0.05) / 0.2))
    with pytest.raises(ValueError, match="fixed limits"):
        Generator(Problem()).rollout(torch.tensor([[0.2, 2.0]]), lim[:1])


def test_loss_penalises_each_sample_against_its_own_limits(judge):
    """Plans that overshoot their own q̇_max and f_max (constant outputs): the penalty of eq. (4)
    is each plan's violation of its own limits, not of the problem's."""
    torch.manual_seed(0)
    g = Generator(Problem(), conditioned=LimitRanges())
    with torch.no_grad():
        g.net[-1].weight.zero_()
        g.net[-1].bias.copy_(torch.tensor([1.5, 0.5]))  # f = f_max + f_half / 2; q̇ ramps past q̇_max
    env = torch.tensor([[0.2, 2.0], [0.25, 1.5]])
    lim = torch.tensor([[0.3, 9.0, 16.0], [1.0, 5.0, 25.0]])
    with torch.no_grad():
        x = g.rollout(env, lim)
        _, parts = generator_loss(g, judge, env, lim)
    q, v, f = x[..., 0], x[..., 1], x[..., 2]
    per = [(torch.relu(v[i, 1:] - lim[i, 0]) ** 2).sum() + (torch.relu(f[i] - lim[i, 2]) ** 2).sum()
           + (torch.relu(lim[i, 1] - f[i]) ** 2).sum() + (torch.relu(q[i, 1:] - 0.4) ** 2).sum() for i in range(2)]
    assert per[0] > 0 and per[1] > 0
    assert parts["limits"] == pytest.approx(float(sum(per)) / 2, rel=1e-5)
    assert (f[0] - 16.0).abs().max() < 1e-4 + 0.5 * 3.5 and torch.allclose(f[1], torch.tensor(30.0))


def test_numpy_plan_equals_torch_rollout_and_training_is_seeded(judge, tiny):
    g, hist = tiny
    assert hist[-1]["epoch"] == 6
    g2, _ = train_generator(Problem(), judge, tc=GeneratorTrainConfig(epochs=6, batch=8, seed=1, threads=1,
                                                                      progress=False), conditioned=LimitRanges())
    assert all(torch.equal(a, b) for a, b in zip(g.state_dict().values(), g2.state_dict().values()))
    p = Problem(qdot_max=0.55, f_min=6.0, f_max=20.0)
    plan = AmortizedPlanner(g, p).plan({"y_obj": 0.2, "mu": 2.0})
    with torch.no_grad():
        x = g.rollout(torch.tensor([[0.2, 2.0]]), torch.tensor([[0.55, 6.0, 20.0]]))[0].double().numpy()
    assert np.abs(plan.as_array() - x).max() < 1e-5


def test_metadata_round_trip_and_old_files_still_load(tiny, tmp_path):
    g, _ = tiny
    save_generator(g, tmp_path / "c", {"judge": {"weights_sha256": "x"}})
    meta = load_generator_meta(tmp_path / "c")
    assert meta["format_version"] == 2 and meta["conditioned"] == {
        "names": list(CONDITION_NAMES), "ranges": {"qdot_max": [0.25, 1.0], "f_min": [5.0, 10.0], "f_max": [15.0, 25.0]}}
    g2, meta2 = load_generator(tmp_path / "c")
    assert g2.conditioned == LimitRanges() and meta2 == meta
    assert all(torch.equal(a, b) for a, b in zip(g.state_dict().values(), g2.state_dict().values()))
    # per-limit generators are written as before (version 1, no `conditioned`); shipped ones load
    save_generator(Generator(Problem()), tmp_path / "p", {})
    assert load_generator_meta(tmp_path / "p")["format_version"] == 1
    assert "conditioned" not in load_generator_meta(tmp_path / "p")
    old, old_meta = load_generator(ROOT / "models" / "generator_paper_sim")
    assert old.conditioned is None and old_meta["format_version"] == 1
    # a damaged `conditioned` entry is named
    js = tmp_path / "c.json"
    js.write_text(json.dumps({**meta, "conditioned": {"names": ["qdot_max"], "ranges": {}}}))
    with pytest.raises(GeneratorFileError, match="conditioned"):
        load_generator(tmp_path / "c")


def test_find_generator_prefers_exact_then_covering_ranges(tiny, tmp_path):
    g, _ = tiny
    # the conditioned one sorts first by name: an exact per-limit generator still wins
    save_generator(g, tmp_path / "a_conditioned", {"judge": {"weights_sha256": "x"}})
    save_generator(Generator(Problem(qdot_max=0.4)), tmp_path / "b_slow", {"judge": {"weights_sha256": "x"}})
    p = Problem()
    assert find_generator(tmp_path, p.with_overrides(qdot_max=0.4), "x") == tmp_path / "b_slow"
    assert find_generator(tmp_path, p.with_overrides(qdot_max=0.55), "x") == tmp_path / "a_conditioned"
    assert find_generator(tmp_path, p.with_overrides(qdot_max=1.0, f_min=5.0, f_max=25.0)) == tmp_path / "a_conditioned"
    assert find_generator(tmp_path, p.with_overrides(qdot_max=0.55), "other judge") is None
    assert find_generator(tmp_path, p.with_overrides(qdot_max=1.2), "x") is None  # outside the ranges
    assert find_generator(tmp_path, p.with_overrides(f_min=4.0), "x") is None
    assert find_generator(tmp_path, p.with_overrides(f_max=12.0), "x") is None
    assert find_generator(tmp_path, p.with_overrides(qdot_max=0.55, q_max=0.35), "x") is None  # not conditioned on q
    assert matches(load_generator_meta(tmp_path / "a_conditioned"), p.with_overrides(qdot_max=0.3))


def test_solve_with_a_freshly_trained_conditioned_generator(tmp_path, capsys):
    models = tmp_path / "models"
    assert main(["solve", "--qdot-max", "0.55", "--method", "amortized", "--models", str(models)]) == 2
    err = capsys.readouterr().err
    assert "no generator" in err and "--conditioned" in err
    out = models / "generator_c"
    assert main(["train-generator", "--conditioned", "--qdot-max-range", "0.3,0.9", "--epochs", "3", "--batch", "8",
                 "--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    meta = load_generator_meta(out)
    assert meta["conditioned"]["ranges"]["qdot_max"] == [0.3, 0.9] and meta["metrics"]["limits_sampled_from_ranges"]
    assert (models / "generator_c.history.csv").exists()
    rc = main(["solve", "--qdot-max", "0.55", "--method", "amortized", "--models", str(models), "--json",
               "--no-simulate"])
    res = json.loads(capsys.readouterr().out)
    # a 3-epoch generator may break a limit (its verdict then says so, exit 4): the generator is what is tested
    assert res["generator"] == str(out) and res["notes"] == [] and rc == (0 if res["verdict"] == "likely" else 4)
    (r,) = res["results"]
    assert r["method"] == "amortized" and len(r["y"]) == 31 and 0 <= r["predicted_success"] <= 1
    # outside the ranges: no generator (the shipped per-limit ones live in another folder)
    assert main(["solve", "--qdot-max", "0.95", "--method", "amortized", "--models", str(models)]) == 2
    assert main(["train-generator", "--f-min-range", "5,9", "--epochs", "1", "--out", str(tmp_path / "x")]) == 2
    assert "needs --conditioned" in capsys.readouterr().err


@pytest.mark.parametrize("name, judge_name", [("generator_conditioned", "judge_demos_tcn"),
                                              ("generator_conditioned_refined", "judge_refined"),
                                              ("experiments/generator_conditioned_refined_tcn", "experiments/judge_refined_tcn")])
def test_shipped_conditioned_generator_obeys_each_plans_limits(name, judge_name):
    """On 200 environments with limits drawn from its ranges, every plan holds its own q̇_max,
    f_min, f_max to the soft tolerance, and ends at the object."""
    g, meta = load_generator(ROOT / "models" / name)
    base = load_problem(resolve("problems/paper_sim.toml"))
    rng = np.random.default_rng(7)
    envs, lims = base.sample_env(rng, 200), g.conditioned.sample(rng, 200)
    worst = {k: 0.0 for k in (*CONDITION_NAMES, "q_end", "qdot_end")}
    for e, lim in zip(envs, lims):
        p = base.with_overrides(**dict(zip(CONDITION_NAMES, map(float, lim))))
        env = dict(zip(p.env_names, map(float, e)))
        res = constraint_residuals(p, AmortizedPlanner(g, p).plan(env), env)
        worst = {k: max(v, res[k]) for k, v in worst.items()}
    assert max(worst[k] for k in CONDITION_NAMES) < SOFT_LIMIT_TOL, worst
    assert max(worst["q_end"], worst["qdot_end"]) < SOFT_LIMIT_TOL, worst
    assert meta["judge"]["weights_sha256"] == json.loads((ROOT / "models" / f"{judge_name}.json").read_text())[
        "weights_sha256"]


@pytest.mark.skipif(not SHIPPED.with_suffix(".json").exists(), reason="no shipped conditioned generator")
def test_solve_qdot_max_055_amortized_with_the_shipped_models(capsys):
    rc = main(["solve", "--qdot-max", "0.55", "--method", "amortized", "--json", "--no-simulate"])
    res = json.loads(capsys.readouterr().out)
    # the default judge (problems/paper_sim.toml) is the refined one: its generator is picked; exit 4: the
    # amortised plan is never called likely at 2 % (its held-out evidence holds no threshold)
    assert rc in (0, 4) and res["generator"].endswith("generator_conditioned_refined")
    (r,) = res["results"]
    assert max(r["ydot"]) <= 0.55 + SOFT_LIMIT_TOL and r["predicted_success"] > 0.9


@pytest.mark.parametrize("robot, slow", [("kinova", True), ("panda", False)])
def test_on_an_arm_the_generator_is_asked_at_the_speed_its_joints_allow(robot, slow):
    """The Kinova's joint 1 caps the tool near 0.35 m/s on the scooping line: the conditioned generator's
    plan for 1 m/s (the UR5's, whose problem holds no joint limits) breaks it by far; its plan for the
    Kinova holds every joint's speed and names the joint. On the Panda no joint binds at 1 m/s: its plan
    is the UR5's, bit for bit."""
    from judgeopt.planners.joint_limits import joint_map

    generator, _ = load_generator(ROOT / "models" / "generator_conditioned_refined")
    ur5 = load_problem("paper_sim")  # q̇_max 1 m/s
    arm = ur5.with_overrides(robot=robot)  # its joint limits held
    env = {"y_obj": 0.21, "mu": 2.9}
    free, _ = AmortizedPlanner(generator, ur5).asked(env)
    held, asked = AmortizedPlanner(generator, arm).asked(env)
    joints = joint_map(arm)
    if slow:
        assert joints.binding(free, 1.0)[2] > 1.5
        assert joints.binding(held, 1.0)[2] <= 1.0 and joints.residuals(held, 1.0)["joint_velocity"] == 0.0
        assert asked.startswith("the generator was asked for q̇_max 0.3")
        assert joints.binding(free, 1.0)[0] in asked
        planner = AmortizedPlanner(generator, arm)
        line = planner.details(planner.solve(env))[0]  # what `judgeopt solve` prints below its table
        assert line.startswith("amortized, joints: j2s6s200_joint_1's velocity is the nearest") and line.endswith(asked)
        assert constraint_residuals(arm, held, env)["q_end"] < SOFT_LIMIT_TOL  # still ends under the object
    else:
        assert asked == "" and joints.binding(free, 1.0)[2] <= 1.0
        np.testing.assert_array_equal(held.as_array(), free.as_array())
