"""`judgeopt evaluate robustness`: the worlds replayed, the summary's counts, resuming, bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.evaluate.robustness import (NOMINAL, Case, markdown_robustness, robustness_cases, robustness_rows,
                                          summarise_robustness)
from judgeopt.files import resolve
from judgeopt.planners.problem import load_problem
from judgeopt.tasks import TaskError, get_task

SCOOP = get_task("scoop")
PROBLEM = load_problem(resolve("problems/paper_sim.toml"))


def test_cases_are_the_nominal_world_then_each_perturbation_at_its_values():
    cases = robustness_cases(SCOOP)
    assert cases[0] == NOMINAL
    assert len(cases) == 1 + sum(len(p.values) for p in SCOOP.perturbations)
    assert [c.label for c in robustness_cases(SCOOP, [("mass_factor", None), ("y_obj_offset", (0.04,))])] == [
        "nominal", "mass_factor x0.5", "mass_factor x2", "y_obj_offset +0.04 m"]
    with pytest.raises(TaskError, match="'mass' is not a perturbation of task 'scoop' \\(known: mu_factor, y_obj_offset"):
        robustness_cases(SCOOP, [("mass", None)])
    with pytest.raises(TaskError, match="y_obj_offset \\+0.1 m is outside"):
        robustness_cases(SCOOP, [("y_obj_offset", (0.1,))])


def test_rows_are_one_per_velocity_limit_and_planner():
    rows, notes = robustness_rows(PROBLEM, (1.0, 0.4), ("amortized", "direct"))
    assert [(r.method, dict(r.overrides)["qdot_max"]) for r in rows] == [
        ("amortized", 1.0), ("direct", 1.0), ("amortized", 0.4), ("direct", 0.4)]
    assert notes == []
    assert len({r.key for r in rows}) == 4


def test_the_summary_counts_what_each_world_lost_and_gained_and_where_the_object_ended():
    rows, _ = robustness_rows(PROBLEM, (1.0,), ("direct",))
    row = rows[0]
    far = Case("y_obj_offset", 0.03, "y_obj_offset +0.03 m")
    sticky = Case("mu_factor", 2.0, "mu_factor x2")

    def r(i, ok, ahead, y=0.2, mu=2.0, world=None):
        env = {"y_obj": y, "mu": mu}
        return {"env_index": i, "method": "direct", "environment": env, "world": world or env, "success": ok,
                "details": {"object_ahead": ahead, "object_bottom": 0.03}}

    results = {(row.key, NOMINAL.slug): [r(0, True, 0.01), r(1, True, -0.01), r(2, False, 0.05)],
               (row.key, far.slug): [r(0, False, 0.04, world={"y_obj": 0.23, "mu": 2.0}),
                                     r(1, True, 0.02, world={"y_obj": 0.23, "mu": 2.0}),
                                     r(2, True, 0.0, world={"y_obj": 0.23, "mu": 2.0})],
               # mu 3 x 2 = 6 is clipped to the scene's 5; mu 1 x 2 = 2 is not
               (row.key, sticky.slug): [r(0, True, 0.0, mu=3.0, world={"y_obj": 0.2, "mu": 5.0}),
                                        r(1, True, 0.0, mu=1.0, world={"y_obj": 0.2, "mu": 2.0}),
                                        {**r(2, None, 0.0), "details": {}}]}  # no plan: left out
    s = {x["world"]: x for x in summarise_robustness(SCOOP, rows, [NOMINAL, far, sticky], results)}
    assert (s["nominal"]["successes"], s["nominal"]["n"]) == (2, 3)
    assert (s[far.label]["successes"], s[far.label]["lost"], s[far.label]["gained"]) == (2, 1, 1)
    assert s[far.label]["object_ahead_mean_cm"] == pytest.approx(2.0)
    assert (s[far.label]["object_ahead_min_cm"], s[far.label]["object_ahead_max_cm"]) == pytest.approx((0.0, 4.0))
    assert (s[sticky.label]["n"], s[sticky.label]["true_env_clipped"], s[sticky.label]["true_env_differs"]) == (2, 1, 2)
    md = markdown_robustness(SCOOP, list(s.values()), "t")
    assert "| y_obj_offset +0.03 m | 2/3 (67 %, 21-94; -1 / +1) |" in md
    assert "| nominal | 1.67 (-1.00 to 5.00) |" in md
    assert "In mu_factor x2 the true value was clipped" in md


@pytest.mark.slow
def test_plans_are_replayed_unchanged_in_each_world_and_a_rerun_resumes(tmp_path, sim):
    out = tmp_path / "rob"
    argv = ["evaluate", "robustness", "--n", "2", "--methods", "amortized", "--qdot-max", "1.0,0.4",
            "--perturb", "y_obj_offset=0.04", "mass_factor=1", "--jobs", "1", "--chunk", "1", "--out", str(out),
            "--quiet"]
    assert main(argv) == 0
    csv = (out / "robustness.csv").read_text().splitlines()
    assert len(csv) == 1 + 3 * 2  # header, then (nominal, 2 perturbations) x 2 velocity limits
    assert (out / "robustness.png").exists() and "| y_obj_offset +0.04 m |" in (out / "robustness.md").read_text()
    plans = {p.name: json.loads(p.read_text()) for p in (out / "partial").glob("*.json")}
    replays = {p.name: json.loads(p.read_text()) for p in (out / "replays").glob("*.json")}
    assert len(plans) == 4 and len(replays) == 8  # 2 limits x 2 environments, each in 2 worlds
    planned = {(k.rsplit("__", 1)[0], r["env_index"]): r for k, rs in plans.items() for r in rs}
    for name, rows in replays.items():
        (row,) = rows
        (plan,) = [p for (key, i), p in planned.items() if name.startswith(key + "__") and i == row["env_index"]]
        values = np.stack([plan[c] for c in plan["channels"]], axis=1)
        if "mass_factor" in name:  # a perturbation at its nominal value is the nominal world
            assert row["success"] == plan["simulated_success"]
            assert row["details"]["object_ahead"] == plan["sim_object_ahead"]
        else:  # 4 cm further than told: the plan replayed by the plain scene with the object there
            env = {"y_obj": plan["environment"]["y_obj"] + 0.04, "mu": plan["environment"]["mu"]}
            assert row["world"] == env
            expected = sim.simulate(SCOOP.plan(values), env)
            assert row["success"] == expected.success
            assert row["details"]["object_ahead"] == expected.details["object_ahead"]
    # a rerun replays nothing again: a stored chunk comes back as it is
    first = sorted(replays)[0]
    tampered = [dict(replays[first][0], success=not replays[first][0]["success"])]
    (out / "replays" / first).write_text(json.dumps(tampered))
    assert main(argv) == 0
    assert json.loads((out / "replays" / first).read_text()) == tampered
    assert len(list((out / "replays").glob("*.json"))) == 8


def test_bad_input_is_one_line_with_exit_code_2(capsys):
    assert main(["evaluate", "robustness", "--perturb", "weight", "--n", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "'weight' is not a perturbation of task 'scoop' (known: mu_factor" in err and "\n" not in err
    assert main(["evaluate", "planners", "--perturb", "mass_factor", "--n", "1"]) == 2
    assert "--perturb: only for `judgeopt evaluate robustness`" in capsys.readouterr().err


@pytest.mark.slow
def test_a_closed_loop_planner_executes_again_in_each_world(tmp_path):
    """The receding planner's row is not its nominal plan replayed: it runs again in each world.
    In a world perturbed to its nominal value it ends as it did in the nominal run (the same
    execution, re-planned the same way); only its own rows are kept, not the direct ones it is built on."""
    out = tmp_path / "rob"
    assert main(["evaluate", "robustness", "--n", "1", "--methods", "receding", "--qdot-max", "1.0", "--perturb",
                 "mass_factor=1", "--jobs", "1", "--out", str(out), "--quiet"]) == 0
    (plans,) = [json.loads(p.read_text()) for p in (out / "partial").glob("*.json")]
    (replay,) = [json.loads(p.read_text()) for p in (out / "replays").glob("*.json")]
    assert [r["method"] for r in plans] == ["receding"] and plans[0]["closed_loop"]["replans"] > 0
    assert replay[0]["success"] == plans[0]["simulated_success"]
    assert replay[0]["details"]["object_ahead"] == plans[0]["sim_object_ahead"]
