"""The direct solve's formulation: the objective "target" and the derivatives handed to Ipopt."""

from __future__ import annotations

import casadi as cs
import numpy as np
import pytest

from judgeopt.files import REPO
from judgeopt.planners.cold_start import default_guess
from judgeopt.planners.direct import DirectOptions, DirectPlanner
from judgeopt.planners.problem import Problem, ProblemError, load_problem

PROBLEMS = REPO / "judgeopt" / "tasks" / "scoop" / "problems"
ENV = {"y_obj": 0.25, "mu": 3.0}
#: high friction, and a min-jerk guess pressing with 12.5 N: a guess the judge calls a failure
HARD = Problem(qdot_max=0.4, f_min=5.0, f_max=20.0, judge="models/judge_refined")


@pytest.fixture(scope="module")
def judge():
    from judgeopt.judge.store import load_judge

    # an LSTM judge: its CasADi graph ("native") has the exact Hessian the tests compare against
    return load_judge(REPO / "models" / "judge_refined")[0]


@pytest.fixture(scope="module")
def native(judge):
    """The judge as a CasADi graph: it has exact second derivatives, so CasADi's own Hessian can
    be compared with the one the solve hands to Ipopt."""
    from judgeopt.judge.casadi_fn import build_casadi_judge

    return build_casadi_judge(judge, "native")


def logit_of(p: float) -> float:
    return float(np.log(p / (1 - p)))


@pytest.mark.parametrize("p_target", [0.9, 0.98])
def test_a_cold_start_reaches_the_target_and_stops_there(judge, native, p_target):
    """From the min-jerk guess (which the judge calls a failure) the least change that reaches
    p_target ends on the target: the judge's constraint binds."""
    problem = HARD.with_overrides(p_target=p_target)
    guess = default_guess(problem, ENV)
    p_guess = float(judge.predict_proba(guess.as_array()[None], np.array([[0.25, 3.0]]))[0])
    assert p_guess < p_target
    planner = DirectPlanner(problem, judge, native)
    r = planner.solve(ENV, guess=guess)
    assert r.status == "solved", r.message
    assert r.predicted_success == pytest.approx(p_target, abs=2e-3)
    assert r.max_constraint_violation < 1e-6, r.residuals
    assert r.plan.ydot.max() <= 0.4 + 1e-9 and r.plan.y[-1] == pytest.approx(0.25, abs=1e-9)
    cold = planner.solve(ENV)  # from its own cold start (the task's commands): at least the target
    assert cold.status == "solved" and cold.predicted_success >= p_target - 2e-3


def test_a_start_that_meets_the_target_is_kept_and_converges_in_a_few_iterations(judge, native):
    """A warm start already above the target is a near-optimum: the plan changes little, in a few
    iterations (the paper's -log p took 58-139 from the same kind of start)."""
    problem = HARD.with_overrides(p_target=0.9)
    first = DirectPlanner(problem, judge, native).solve(ENV, guess=default_guess(problem, ENV))
    again = DirectPlanner(problem.with_overrides(p_target=0.8), judge, native).solve(ENV, guess=first.plan)
    assert again.status == "solved" and again.iterations <= 12, (again.iterations, again.message)
    assert again.predicted_success >= 0.8
    # each channel moves by at most 5 % of its allowed range
    span = np.array([problem.q_max - problem.q_min, problem.qdot_max - problem.qdot_min, problem.f_max - problem.f_min])
    assert np.all(np.abs(again.plan.as_array() - first.plan.as_array()).max(0) <= 0.05 * span)


def test_an_unreachable_target_gives_the_judges_best_within_a_bounded_effort(judge, native):
    """Where the limits make the target impossible (8 N at most against mu = 3), the solve stops
    at the round it cannot complete and says so: a plan the judge scores above its start, well
    under the target, in no more than the problem's max_iter; p_min is never relaxed."""
    problem = HARD.with_overrides(f_max=8.0, max_iter=120)
    start = float(judge.predict_proba(default_guess(problem, ENV).as_array()[None], np.array([[0.25, 3.0]]))[0])
    best = DirectPlanner(problem, judge, native).solve(ENV)
    assert start < best.predicted_success < 0.5
    assert best.iterations <= 120 and "p_target = 0.98 not reached" in best.message
    assert best.status != "infeasible" and best.max_constraint_violation < 1e-6
    hard = DirectPlanner(problem.with_overrides(p_min=0.9), judge, native).solve(ENV)
    assert hard.status in ("infeasible", "not_converged") and hard.residuals["p_min"] > 0


@pytest.mark.parametrize("objective", ["target", "log_p"])
def test_derivatives_given_to_ipopt_are_casadis_own_but_the_judges_curvature(judge, native, objective):
    """grad_f and jac_g (chain rule through one reverse sweep of the judge) equal CasADi's own
    derivatives; hess_lag equals CasADi's exact Hessian of the Lagrangian once the judge's
    curvature is taken out (its multiplier set to 0 under "target"; under log_p the judge's
    Hessian replaced by its Gauss-Newton term, checked at a point where p (1 - p) is not 0)."""
    problem = load_problem(PROBLEMS / "paper_sim.toml").with_overrides(judge="models/judge_refined",
                                                                         objective=objective)
    planner = DirectPlanner(problem, judge, native)
    solver = planner.solver
    guess = default_guess(problem, ENV)
    x = planner._pack(guess)
    p = [np.array([0.25, 3.0]), [0.25]]
    if objective == "target":
        p.append(x)
        x = np.append(x, 0.3)
    x, p = np.asarray(x, float), np.concatenate(p)
    nlp = solver.get_function("nlp_jac_g")
    # CasADi's own derivatives of the same functions (nlp_f and nlp_g: the graph, exact)
    xs, ps = cs.MX.sym("x", x.size), cs.MX.sym("p", p.size)
    f = solver.get_function("nlp_f")(xs, ps)
    g = solver.get_function("nlp_g")(xs, ps)
    exact_grad = cs.Function("gf", [xs, ps], [cs.gradient(f, xs)])(x, p)
    exact_jac = cs.Function("jg", [xs, ps], [cs.jacobian(g, xs)])(x, p)
    assert np.allclose(solver.get_function("nlp_grad_f")(x, p)[1], exact_grad, atol=1e-9, rtol=1e-7)
    assert np.allclose(nlp(x, p)[1], exact_jac, atol=1e-9, rtol=1e-7)
    lam_g = np.random.default_rng(0).normal(size=g.size1())
    hess = solver.get_function("nlp_hess_l")
    if objective == "target":
        lam_g[planner._judge_rows] = 0.0  # the judge's row
        lf, lg = cs.MX.sym("lf"), cs.MX.sym("lg", g.size1())
        lag = cs.Function("H", [xs, ps, lf, lg], [cs.triu(cs.hessian(lf * f + cs.dot(lg, g), xs)[0])])
        assert np.allclose(cs.DM(hess(x, p, 1.0, lam_g)).full(), cs.DM(lag(x, p, 1.0, lam_g)).full(), atol=1e-9)
    else:
        # Gauss-Newton: P s (1 - s) (∇logit)(∇logit)^T, plus the smoothing terms' exact Hessian
        logit, gl, _ = native.value_and_gradient(guess.as_array().ravel(), [0.25, 3.0])
        s = 1 / (1 + np.exp(-logit))
        h = cs.DM(hess(x, p, 1.0, np.zeros(g.size1()))).full()
        smooth = DirectPlanner(problem.with_overrides(P=0.0), judge, native).solver.get_function("nlp_hess_l")
        h0 = cs.DM(smooth(x, p, 1.0, np.zeros(g.size1()))).full()
        jac_traj = exact_jac_traj(planner, x, p)
        gn = problem.P * s * (1 - s) * np.outer(jac_traj.T @ gl, jac_traj.T @ gl)
        assert np.allclose(h - h0, np.triu(gn), atol=1e-9 * max(1.0, np.abs(gn).max()))


def exact_jac_traj(planner: DirectPlanner, x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """d(trajectory fed to the judge) / d(decision variables): linear, so finite differences are exact."""
    base = planner._unpack(x).as_array().ravel()
    cols = []
    for i in range(x.size):
        e = np.zeros(x.size)
        e[i] = 1.0
        cols.append(planner._unpack(x + e).as_array().ravel() - base)
    return np.stack(cols, axis=1)


def test_a_bad_objective_or_target_is_one_clear_error():
    with pytest.raises(ProblemError, match="objective = 'max'.*choose one of target, log_p"):
        Problem(objective="max")
    with pytest.raises(ProblemError, match="p_target = 1.0 must lie strictly between 0 and 1"):
        Problem(p_target=1.0)
    with pytest.raises(ProblemError, match="hessian 'bfgs'"):
        DirectPlanner(Problem(), None, type("J", (), {"horizon": 30, "n_env": 2})(), DirectOptions(hessian="bfgs"))


# -- one plan for a set of environments ("somewhere in here") -------------------------------------
def test_env_grid_spans_the_ranges_ends_included_and_refuses_what_the_judge_cannot_read():
    from judgeopt.session.solve import env_grid

    one = env_grid({"y_obj": 0.2, "mu": 2.0}, {"mu": (1.5, 2.5)}, ("y_obj", "mu"))
    assert [e["mu"] for e in one] == pytest.approx([1.5, 1.75, 2.0, 2.25, 2.5]) and {e["y_obj"] for e in one} == {0.2}
    two = env_grid({"y_obj": 0.2, "mu": 2.0}, {"mu": (1.5, 2.5), "y_obj": (0.18, 0.22)}, ("y_obj", "mu"))
    corners = {(y, m) for y in (0.18, 0.22) for m in (1.5, 2.5)}
    assert len(two) == 9 and corners <= {(round(e["y_obj"], 9), round(e["mu"], 9)) for e in two}
    with pytest.raises(ProblemError, match=r"^mu given as a range, but the judge does not read it \(it reads y_obj\)"):
        env_grid({"y_obj": 0.2, "mu": 2.0}, {"mu": (1.5, 2.5)}, ("y_obj",))


@pytest.mark.parametrize("case", ["worst", "expected"])
def test_a_plan_for_a_set_meets_the_target_in_the_worst_case_or_on_average(judge, native, case):
    """The constraint holds per environment (worst) or for the mean probability (expected): the
    plan's probabilities over the set, each scored by the judge afterwards, say it did."""
    from judgeopt.planners.direct import judge_env
    from judgeopt.session.solve import env_grid

    problem = HARD.with_overrides(f_max=22.5, p_target=0.9)
    sets = env_grid(ENV, {"mu": (2.0, 3.0), "y_obj": (0.24, 0.26)}, ("y_obj", "mu"))
    r = DirectPlanner(problem, judge, native, samples=len(sets), case=case).solve(ENV, env_set=sets)
    each = [float(judge.predict_proba(r.plan.as_array()[None], judge_env(judge, e)[None])[0]) for e in sets]
    assert r.status == "solved" and r.max_constraint_violation < 1e-6 and r.plan.y[-1] == pytest.approx(0.25, abs=1e-9)
    assert r.info["env_case"] == case and r.info["env_set_success"] == pytest.approx(each, abs=1e-6)
    held = min(each) if case == "worst" else np.mean(each)
    assert held >= 0.9 - 2e-3 and r.predicted_success == pytest.approx(held, abs=1e-6)


def test_solve_plans_for_a_range_given_on_the_command_line(capsys):
    import json

    from judgeopt.cli import main

    rc = main(["solve", "--method", "direct", "--mu", "1.5,2.5", "--y-obj", "0.2", "--no-simulate", "--json"])
    out = json.loads(capsys.readouterr().out)
    (r,) = out["results"]
    assert rc == 0 and r["env_case"] == "worst" and [e["mu"] for e in r["env_set"]] == \
        pytest.approx([1.5, 1.75, 2.0, 2.25, 2.5])
    assert any("worst case over 5 environments (mu in [1.5, 2.5])" in n for n in out["notes"])
    assert main(["solve", "--method", "direct", "--judge", "models/experiments/judge_yobj_only", "--mu", "1,2",
                 "--no-simulate"]) == 2
    assert "mu given as a range, but the judge does not read it" in capsys.readouterr().err


def test_the_objective_is_chosen_on_the_command_line(capsys):
    import json

    from judgeopt.cli import main

    rc = main(["solve", "--method", "direct", "--objective", "log_p", "--y-obj", "0.2", "--no-simulate", "--json"])
    (r,) = json.loads(capsys.readouterr().out)["results"]
    assert rc == 0 and r["rounds"] == 1 and r["predicted_success"] > 0.99  # -log p drives the judge up
    assert main(["solve", "--objective", "max", "--no-simulate"]) == 2
    err = capsys.readouterr().err
    assert "objective = 'max'" in err and err.strip().endswith("choose one of target, log_p, min_time")


@pytest.mark.parametrize("backend", ["native", "torch32"])
def test_warming_up_changes_no_plan(judge, backend):
    """warm_up pays the first solve's one-off costs; the judge callback keeps the last point it
    saw, so a warm-up that left it stale would change the next solve's gradients."""
    from judgeopt.judge.casadi_fn import build_casadi_judge

    problem = HARD.with_overrides(qdot_max=0.5)
    plans = []
    for warm in (False, True):
        planner = DirectPlanner(problem, judge, build_casadi_judge(judge, backend))
        if warm:
            assert planner.warm_up() > 0 and planner.warm_up() == 0.0  # paid once, not per request
            assert planner.warm_up(cold=True) > 0 and planner.warm_up(cold=True) == planner.warm_up() == 0.0
        r = planner.solve(ENV)
        plans.append((r.plan.as_array(), r.iterations, r.status))
    np.testing.assert_array_equal(plans[0][0], plans[1][0])
    assert plans[0][1:] == plans[1][1:]
