"""Problems, both planners, and `judgeopt solve`."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from judgeopt.cli import main
from judgeopt.planners.direct import default_guess
from judgeopt.planners.dynamics import dynamics_residual, integrate
from judgeopt.planners.generator import AmortizedPlanner, Generator
from judgeopt.planners.generator_train import GeneratorTrainConfig, generator_loss, train_generator
from judgeopt.planners.problem import InfeasibleProblemError, Problem, ProblemError, load_problem
from judgeopt.planners.result import constraint_residuals
from judgeopt.planners.store import GeneratorFileError, find_generator, load_generator, save_generator
from judgeopt.trajectory import Plan

ROOT = Path(__file__).resolve().parents[1]
PROBLEMS = ROOT / "problems"


@pytest.fixture(scope="module")
def judge():
    from judgeopt.judge.store import load_judge

    return load_judge(ROOT / "models" / "judge_default")[0]


@pytest.fixture(scope="module")
def direct(judge):
    from judgeopt.judge.casadi_fn import build_casadi_judge
    from judgeopt.planners.direct import DirectPlanner

    cj = build_casadi_judge(judge)
    return {q: DirectPlanner(load_problem(PROBLEMS / "paper_sim.toml").with_overrides(qdot_max=q), judge, cj)
            for q in (1.0, 0.4)}


# -- problems ------------------------------------------------------------------------------------
def test_shipped_problems_are_the_papers_tables():
    sim = load_problem(PROBLEMS / "paper_sim.toml")
    assert (sim.q0, sim.qdot0, sim.q_min, sim.q_max, sim.qdot_min, sim.qdot_max, sim.f_min, sim.f_max) == \
        (-0.03, 0.0, -0.2, 0.4, -0.05, 1.0, 7.5, 22.5)
    assert sim.q_end == "y_obj" and sim.qdot_end == 0.0 and sim.env_names == ("y_obj", "mu")
    slow = load_problem(PROBLEMS / "paper_sim_slow.toml")
    assert slow.qdot_max == 0.4 and slow.limits_key() == {**sim.limits_key(), "qdot_max": 0.4}
    real = load_problem(PROBLEMS / "paper_real.toml")
    assert (real.q0, real.f_min, real.f_max, real.environment) == (-0.1, 1.0, 10.0, {"y_obj": 0.246})


def test_overrides_and_environment_values():
    p = load_problem(PROBLEMS / "paper_sim.toml").with_overrides(qdot_max=0.4, y_obj="0.2", mu="1,3")
    assert p.qdot_max == 0.4 and p.environment == {"y_obj": 0.2, "mu": (1.0, 3.0)}
    assert p.nominal_env() == {"y_obj": 0.2, "mu": 2.0}
    with pytest.raises(ProblemError, match="unknown problem field 'qdot_maximum'"):
        p.with_overrides(qdot_maximum=1.0)


@pytest.mark.parametrize("change, message", [
    ({"f_min": 30.0}, "f_min = 30.0 must be below f_max"),
    ({"q0": 0.5}, "start position q0 = 0.5 is outside"),
    ({"qdot0": 2.0}, "start velocity qdot0 = 2.0 is outside"),
    ({"steps": 0}, "steps = 0 .* positive whole number"),
    ({"dt": -0.1}, "dt = -0.1 .* positive"),
    ({"p_min": 1.5}, "p_min = 1.5"),
    ({"q_end": "end"}, "q_end = 'end'"),
    ({"qdot_max": float("nan")}, "qdot_max = nan .* finite"),
])
def test_invalid_values_are_named(change, message):
    with pytest.raises(ProblemError, match=message):
        Problem().with_overrides(**change)


def test_bad_files(tmp_path):
    (tmp_path / "a.toml").write_text("[limits]\nqdot_max = \n")
    with pytest.raises(ProblemError, match="not valid TOML"):
        load_problem(tmp_path / "a.toml")
    (tmp_path / "b.toml").write_text("[limits]\nspeed = 1\n")
    with pytest.raises(ProblemError, match="unknown key 'speed' in \\[limits\\]"):
        load_problem(tmp_path / "b.toml")
    (tmp_path / "c.toml").write_text('base = "d.toml"\n')
    (tmp_path / "d.toml").write_text('base = "c.toml"\n')
    with pytest.raises(ProblemError, match="cycle"):
        load_problem(tmp_path / "c.toml")
    (tmp_path / "e.toml").write_text('[environment]\ny_obj = [0.3, 0.1]\n')
    with pytest.raises(ProblemError, match="lo <= hi"):
        load_problem(tmp_path / "e.toml")


def test_reach_check_names_the_conflict():
    p = Problem(qdot_max=0.1)
    with pytest.raises(InfeasibleProblemError) as exc:
        p.check_feasible({"y_obj": 0.2, "mu": 2.0})
    assert "limits.qdot_max" in exc.value.conflict and "out of reach" in str(exc.value)
    lo, hi = p.reachable_range()
    p.check_feasible({"y_obj": hi, "mu": 2.0})  # exactly reachable is feasible
    with pytest.raises(InfeasibleProblemError, match="outside the position limits"):
        Problem().check_feasible({"y_obj": 0.5, "mu": 2.0})


# -- the shared model ---------------------------------------------------------------------------
def test_integration_is_consistent_with_the_controllers_interpolation():
    acc = np.random.default_rng(0).normal(0, 2, 30)
    q, v = integrate(0.0, 0.1, acc, 0.05)
    assert dynamics_residual(q, v, 0.05) < 1e-15
    t, y, ydot, _ = Plan(0.05, q, v, np.zeros(31)).resample(0.001)
    # constant acceleration per step: the Hermite pieces are the exact quadratics
    k = np.minimum((t / 0.05).astype(int), 29)
    tau = t - k * 0.05
    exact = q[k] + v[k] * tau + 0.5 * acc[k] * tau**2
    assert np.abs(y - exact).max() < 1e-12


# -- direct solve ------------------------------------------------------------------------------
@pytest.mark.parametrize("qdot_max", [1.0, 0.4])
def test_direct_holds_every_constraint_and_raises_the_judge(direct, judge, qdot_max):
    planner = direct[qdot_max]
    env = {"y_obj": 0.22, "mu": 2.5}
    r = planner.solve(env)
    assert r.status == "solved", r.message
    assert r.max_constraint_violation < 1e-6, r.residuals
    guess = default_guess(planner.problem, env)
    p_guess = float(judge.predict_proba(guess.as_array()[None], np.array([[0.22, 2.5]]))[0])
    assert r.predicted_success > max(0.9, p_guess)
    assert r.plan.ydot.max() <= qdot_max + 1e-9 and r.plan.y[-1] == pytest.approx(0.22, abs=1e-9)


def test_direct_reports_infeasible_without_a_traceback(direct, judge):
    from judgeopt.planners.direct import DirectPlanner

    planner = DirectPlanner(Problem(qdot_max=0.15), judge, direct[0.4].cjudge)
    r = planner.solve({"y_obj": 0.25, "mu": 2.0})  # 0.28 m in 1.5 s needs more than 0.15 m/s
    assert r.status == "infeasible" and r.plan is None and "limits.qdot_max" in r.info["conflict"]


def test_direct_p_min_constraint(judge):
    from judgeopt.judge.casadi_fn import build_casadi_judge
    from judgeopt.planners.direct import DirectPlanner

    # without the judge in the objective the smoothest plan is judged a failure; p_min lifts it
    cj = build_casadi_judge(judge)
    free = DirectPlanner(Problem(qdot_max=0.4, P=0.0), judge, cj).solve({"y_obj": 0.2, "mu": 2.0})
    held = DirectPlanner(Problem(qdot_max=0.4, P=0.0, p_min=0.9), judge, cj).solve({"y_obj": 0.2, "mu": 2.0})
    assert free.predicted_success < 0.5
    assert held.status == "solved" and held.predicted_success == pytest.approx(0.9, abs=0.01)
    assert held.max_constraint_violation < 1e-6


# -- generator ---------------------------------------------------------------------------------
def test_generator_numpy_plan_equals_torch_rollout():
    torch.manual_seed(0)
    g = Generator(Problem())
    ap = AmortizedPlanner(g, Problem())
    plan = ap.plan({"y_obj": 0.2, "mu": 2.0})
    with torch.no_grad():
        x = g.rollout(torch.tensor([[0.2, 2.0]]))[0].double().numpy()
    assert np.abs(plan.as_array() - x).max() < 1e-5
    assert dynamics_residual(plan.y, plan.ydot, plan.dt) < 1e-12


def test_generator_training_lowers_the_loss_and_is_seeded(judge, tmp_path):
    p = Problem(qdot_max=0.4)
    tc = GeneratorTrainConfig(epochs=40, batch=16, seed=3, threads=1, progress=False)
    g1, h1 = train_generator(p, judge, tc=tc)
    g2, _ = train_generator(p, judge, tc=tc)
    for a, b in zip(g1.state_dict().values(), g2.state_dict().values()):
        assert torch.equal(a, b)
    env = torch.tensor(p.sample_env(np.random.default_rng(9), 64), dtype=torch.float32)
    untrained = generator_loss(Generator(p), judge, env)[0].item()
    assert generator_loss(g1, judge, env)[0].item() < untrained
    assert h1[-1]["epoch"] == 40

    save_generator(g1, tmp_path / "g", {"judge": {"weights_sha256": "x"}})
    g3, meta = load_generator(tmp_path / "g")
    assert all(torch.equal(a, b) for a, b in zip(g1.state_dict().values(), g3.state_dict().values()))
    assert find_generator(tmp_path, p) == tmp_path / "g"
    assert find_generator(tmp_path, p.with_overrides(qdot_max=1.0)) is None
    assert find_generator(tmp_path, p, judge_sha="other") is None
    (tmp_path / "g.pt").write_bytes(b"garbage")
    with pytest.raises(GeneratorFileError, match="sha256"):
        load_generator(tmp_path / "g")


def test_residuals_measure_soft_violations():
    p = Problem(qdot_max=0.4)
    plan = default_guess(p, {"y_obj": 0.2, "mu": 2.0})
    assert max(constraint_residuals(p, plan, {"y_obj": 0.2, "mu": 2.0}).values()) < 1e-6  # the guess: q_end to 3e-7
    bad = Plan(plan.dt, plan.y, plan.ydot * 2, plan.f + 10)
    r = constraint_residuals(p, bad, {"y_obj": 0.2, "mu": 2.0})
    assert r["qdot_max"] > 0.01 and r["f_max"] == pytest.approx(plan.f.max() + 10 - 22.5) and r["dynamics"] > 0


# -- the command -------------------------------------------------------------------------------
def test_solve_json_schema_csv_and_plot(tmp_path, capsys):
    rc = main(["solve", "--qdot-max", "0.4", "--method", "direct", "--y-obj", "0.2", "--json", "--no-simulate",
               "--out", str(tmp_path / "plan.csv"), "--plot", str(tmp_path / "plan.png")])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and out["status"] == "ok"
    (r,) = out["results"]
    for key in ("method", "predicted_success", "simulated_success", "max_constraint_violation", "solve_time_s",
                "status", "t", "q", "qdot", "f"):
        assert key in r
    assert r["simulated_success"] is None and len(r["t"]) == 31 and max(r["qdot"]) <= 0.4 + 1e-9
    rows = (tmp_path / "plan.csv").read_text().splitlines()
    assert rows[0] == "t [s],q [m],qdot [m/s],f [N]" and len(rows) == 1 + 1501
    assert (tmp_path / "plan.png").stat().st_size > 10_000


def test_solve_infeasible_exit_code_and_message(capsys):
    rc = main(["solve", "--qdot-max", "0.1", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 3 and out["status"] == "infeasible" and "limits.qdot_max" in out["conflict"]
    assert "out of reach" in out["message"]


def test_solve_errors_are_one_line(capsys, tmp_path):
    assert main(["solve", "--f-min", "30"]) == 2
    assert "f_min = 30.0 must be below f_max" in capsys.readouterr().err
    assert main(["solve", "--method", "amortized", "--qdot-max", "0.77", "--models", str(tmp_path)]) == 2
    assert "train-generator" in capsys.readouterr().err


@pytest.mark.slow
def test_solve_both_methods_in_simulation(capsys):
    """The README's main command, end to end, on the shipped models."""
    rc = main(["solve", "--qdot-max", "0.4", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0 and [r["method"] for r in out["results"]] == ["amortized", "direct"]
    assert out["generator"] is not None
    for r in out["results"]:
        assert isinstance(r["simulated_success"], bool)
    direct = out["results"][1]
    assert direct["max_constraint_violation"] < 1e-6 and direct["warm_start"] == "generator"
