"""A planner of one's own in one file (toy_planner.py) and one registration line is a --method
choice, a row of every evaluation and a calibration setting, with nothing else changed: what the
built-ins are, each registered the same way."""

from __future__ import annotations

import json
import re

import pytest

from judgeopt.cli import main
from judgeopt.planners.base import (ENTRY_POINT_GROUP, REGISTRY, Planner, PlannerSpec, default_planners, group,
                                    register, register_installed, to_build, unregister, with_uses)
from judgeopt.planners.problem import ProblemError


@pytest.fixture
def toy():
    register(PlannerSpec("toy", "the min-jerk move", "toy_planner:Straight"))  # the one line
    yield
    unregister("toy")


def test_the_built_ins_are_registered_and_names_are_checked():
    assert list(REGISTRY)[:4] == ["amortized", "direct", "cem", "receding"]
    assert REGISTRY["receding"].closed_loop and REGISTRY["receding"].uses == ("direct",)
    assert with_uses(["receding", "cem"]) == ("direct", "receding", "cem")
    assert to_build(["direct"]) == ("amortized", "direct")  # the generator's plan warm-starts it
    assert default_planners() == group("default") == group("both") == ("amortized", "direct")
    assert "receding" in group("all") and "receding" not in group("all", simulate=False)
    for bad in ("direct", "both", "default", "all", "receding", "two words"):
        with pytest.raises(ProblemError, match="taken or not a plain name"):
            register(PlannerSpec(bad, "x", "toy_planner:Straight"))


@pytest.mark.parametrize("fields, message", [
    ({}, "give build="), ({"build": "toy_planner:Straight", "uses": ("nowhere",)}, "register it first"),
    ({"build": "toy_planner:Straight", "models": ("weights",)}, "choose from judge, generator"),
    ({"build": "toy_planner:Straight", "reads": ("tol",)}, "choose from objective")])
def test_an_entry_the_rest_could_not_use_is_refused(fields, message):
    with pytest.raises(ProblemError, match=message):
        register(PlannerSpec("toy", "x", **fields))
    assert "toy" not in REGISTRY


@pytest.mark.slow
def test_a_registered_planner_runs_through_solve_evaluate_and_calibrate(toy, tmp_path, capsys):
    assert main(["solve", "--method", "toy", "--no-simulate", "--json"]) in (0, 4)  # 4: unlikely
    out = json.loads(capsys.readouterr().out)
    (r,) = out["results"]
    assert r["method"] == "toy" and r["status"] == "solved" and r["verdict"] in ("likely", "unlikely")
    assert r["setting_description"].startswith("toy, judge ")
    quick = ["--n", "2", "--jobs", "1", "--quiet"]
    assert main(["evaluate", "planners", "--methods", "toy", "--n", "20", "--jobs", "1", "--quiet",  # the fewest
                 "--out", str(tmp_path / "planners")]) == 0  # outcomes a calibration is fitted on
    assert "| toy |" in (tmp_path / "planners" / "planners.md").read_text()
    assert main(["evaluate", "sweep", "--methods", "toy", "--limits", "f_max=20", "--no-baselines", *quick,
                 "--out", str(tmp_path / "sweep")]) == 0
    assert "| toy |" in (tmp_path / "sweep" / "sweep.md").read_text()
    assert main(["evaluate", "robustness", "--methods", "toy", "--qdot-max", "1.0", "--perturb", "y_obj_offset=0.04",
                 *quick, "--out", str(tmp_path / "robustness")]) == 0
    assert "toy" in (tmp_path / "robustness" / "robustness.md").read_text()
    assert main(["calibrate", str(tmp_path / "planners"), "--methods", "toy", "--min-n", "20",
                 "--out", str(tmp_path / "calibration.json")]) == 0
    assert "toy, judge " in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:  # an unregistered name is a usage error
        main(["solve", "--method", "nowhere"])
    assert exc.value.code == 2


def test_an_installed_package_planner_is_registered_from_its_entry_point():
    from importlib.metadata import EntryPoint

    good = EntryPoint("toy_installed", "toy_planner:SPEC", ENTRY_POINT_GROUP)
    try:
        assert register_installed([good]) == ["toy_installed"] and list(REGISTRY)[-1] == "toy_installed"
        assert register_installed([good]) == []  # registered once
    finally:
        unregister("toy_installed")
    with pytest.raises(ProblemError, match="does not load .*fix or uninstall"):
        register_installed([EntryPoint("gone", "no_such_module:SPEC", ENTRY_POINT_GROUP)])
    with pytest.raises(ProblemError, match="must name a PlannerSpec called 'other'"):
        register_installed([EntryPoint("other", "toy_planner:SPEC", ENTRY_POINT_GROUP)])
    assert "other" not in REGISTRY and "toy_installed" not in REGISTRY


class Holder:
    """A planner class nested in another: "module:Holder.Inner" finds it attribute by attribute."""

    class Inner(Planner):
        method = "inner"

        def solve(self, env, guess=None):
            raise NotImplementedError


def test_an_entry_is_stored_as_given_and_its_class_found_through_dots():
    try:
        spec = register(PlannerSpec("toy_nested", "x", f"{__name__}:Holder.Inner"))
        assert REGISTRY["toy_nested"] is spec and spec.planner_class() is Holder.Inner
        assert Holder.Inner(None, None).warm_up() == 0.0 and Holder.Inner(None, None).warm_up(cold=True) == 0.0
        assert register(PlannerSpec("toy_class", "x", Holder.Inner)).planner_class() is Holder.Inner
    finally:
        unregister("toy_nested")
        unregister("toy_class")


def test_what_is_built_includes_every_method_asked_for_and_unknown_names_pass_through():
    assert to_build(["cem", "receding"]) == ("amortized", "direct", "cem", "receding")
    assert with_uses(["nowhere", "receding"]) == ("nowhere", "direct", "receding")


@pytest.mark.parametrize("build", [int, Holder, "x"])
def test_a_build_that_is_no_planner_class_is_refused_and_a_string_is_taken_as_given(build):
    if build == "x":  # where a string points is looked up when first built, not when registered
        try:
            assert register(PlannerSpec("toy_str", "x", build)).build == "x"
        finally:
            unregister("toy_str")
        return
    with pytest.raises(ProblemError, match="give build=YourPlanner"):
        register(PlannerSpec("toy_bad", "x", build))
    assert "toy_bad" not in REGISTRY


def test_refusals_name_every_unknown_planner_and_every_taken_name():
    with pytest.raises(ProblemError, match=r"^planner 'toy' is built on a, b: register them first$"):
        register(PlannerSpec("toy", "x", "toy_planner:Straight", uses=("a",), warm_start="b"))
    taken = ", ".join((*REGISTRY, "default", "all", "both"))
    with pytest.raises(ProblemError, match=re.escape(f"(taken: {taken})")):
        register(PlannerSpec("direct", "x", "toy_planner:Straight"))


def test_unregistering_a_name_never_registered_is_no_error():
    unregister("never_registered")
    assert "never_registered" not in REGISTRY


def test_installed_planners_skip_registered_names_and_name_the_import_error():
    from importlib.metadata import EntryPoint

    assert isinstance(register_installed(), list)  # the installed packages' own group: none is no error
    taken = EntryPoint("direct", "toy_planner:SPEC", ENTRY_POINT_GROUP)  # registered already: skipped, not the end
    good = EntryPoint("toy_installed", "toy_planner:SPEC", ENTRY_POINT_GROUP)
    try:
        assert register_installed([taken, good]) == ["toy_installed"]
    finally:
        unregister("toy_installed")
    with pytest.raises(ProblemError, match=r"^planner entry point gone = 'no_such_module:SPEC' does not load "
                                           r"\(ModuleNotFoundError: "):
        register_installed([EntryPoint("gone", "no_such_module:SPEC", ENTRY_POINT_GROUP)])
