"""`judgeopt robots` and `--robot`: the arms as a user lists and picks them, and what picking one changes."""

from __future__ import annotations

import json

import pytest

from judgeopt.cli import main
from judgeopt.planners.base import setting_id
from judgeopt.planners.problem import ProblemError, load_problem
from judgeopt.robots import robot_names
from judgeopt.verdict.risk import Evidence


def test_robots_lists_every_arm_with_the_makers_corrections(capsys):
    assert main(["robots", "--json"]) == 0
    arms = {d["name"]: d for d in json.loads(capsys.readouterr().out)}
    assert set(arms) == set(robot_names())
    ur3 = arms["ur3"]
    assert ur3["effort_limit"] == [56.0, 56.0, 28.0, 12.0, 12.0, 12.0]  # the UR10's 330/.../54 in the file
    assert all("ur3/joint_limits.yaml" in c["source"] for c in ur3["corrections"])
    assert len(arms["panda"]["joints"]) == 7 and not arms["panda"]["corrections"]


def test_robots_text_names_the_correction_and_the_reach(capsys):
    assert main(["robots", "ur3", "--reach"]) == 0
    text = capsys.readouterr().out
    assert "corrected effort limit: shoulder_pan_joint 56.0" in text and "reach on the scooping line: y -0.25 to 0.45" in text


def test_an_unknown_arm_is_one_line(capsys):
    assert main(["robots", "ur6"]) == 5
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "known robots are" in err[0]
    with pytest.raises(ProblemError, match="unknown robot 'ur6'"):
        load_problem("paper_sim").with_overrides(robot="ur6")


def test_another_arm_holds_its_joint_limits_and_has_its_own_calibration_setting():
    """Planned for another arm, the problem holds that arm's joint limits (scale 1 unless set) and its
    calibration setting differs from the UR5's, whose records read as before (no robot key)."""
    ur5 = load_problem("paper_sim")
    kinova = ur5.with_overrides(robot="kinova")
    assert ur5.joint_limit_scale is None and "robot" not in ur5.to_dict()
    assert kinova.joint_limit_scale == 1.0 and kinova.to_dict()["robot"] == "kinova"
    assert ur5.with_overrides(robot="kinova", joint_limit_scale=0.5).joint_limit_scale == 0.5
    assert setting_id("direct", ur5, {"judge": "x"}) != setting_id("direct", kinova, {"judge": "x"})


def test_evidence_drawn_on_one_arm_says_nothing_of_another():
    ev = Evidence("direct", "abc", 0.95, [], {}, ranges={"qdot_max": [0.3, 1.0]})  # stored before arms: the UR5's
    assert ev.outside({"qdot_max": 0.5}) == [] and ev.outside({"qdot_max": 0.5, "robot": "ur5"}) == []
    assert ev.outside({"qdot_max": 0.5, "robot": "panda"}) == ["robot panda (ur5)"]


def test_collect_records_the_arm_and_a_dataset_knows_it(tmp_path, capsys):
    """Demonstrations collected on another arm say so (their settings' scene.robot, Dataset.robot, which
    render replays on); a file made before arms were chosen reads as the UR5's."""
    from judgeopt.data.dataset import Dataset, load

    out = tmp_path / "panda.h5"
    assert main(["collect", "--robot", "panda", "--n", "2", "--seed", "3", "--out", str(out), "--jobs", "1", "--quiet"]) == 0
    ds = load(out)
    assert ds.robot == "panda" and ds.meta["settings"]["scene"]["robot"] == "panda"
    old = Dataset(ds.commands, ds.responses, ds.labels, ds.env, ds.dt, ds.env_names,
                  meta={"settings": {"scene": {"x_home": 0.3}}})
    assert old.robot == "ur5"
    assert main(["collect", "--robot", "ur6", "--n", "2", "--out", str(tmp_path / "x.h5")]) == 5


def test_evidence_is_counted_per_arm_and_one_arms_never_states_anothers_risk():
    """Replayed rows of two arms make two evidences; a Kinova plan reads the Kinova's, and where only the
    UR5's exists, its risk is unchecked, naming the arm the plans were replayed on."""
    from judgeopt.verdict.risk import annotate, evidence_key, fit_evidence

    def rows(robot, failures):
        extra = {} if robot == "ur5" else {"robot": robot}
        return [{"method": "direct", "judge_sha256": "ab" * 32, "simulated_success": k >= failures, "predicted_success": 0.999,
                 "environment": {"y_obj": 0.2}, "limits": {"qdot_max": 1.0}, **extra} for k in range(300)]

    ev = fit_evidence(rows("ur5", 0) + rows("kinova", 30))
    assert set(ev) == {evidence_key("direct", "ab" * 32, arm, kind) for arm in ("ur5", "kinova")
                       for kind in ("calibrated", "judge")}
    assert ev[evidence_key("direct", "ab" * 32, "kinova", "judge")].grid[-1]["failures"] == 30
    assert ev[evidence_key("direct", "ab" * 32, kind="judge")].grid[-1]["failures"] == 0
    target: dict = {}
    annotate(target, ev, "direct", "ab" * 32, {"y_obj": 0.2, "qdot_max": 1.0, "robot": "kinova"})
    assert target["likely_at"] is None  # 30 of 300 failed on the Kinova: no threshold holds 2 %
    only_ur5 = {k: e for k, e in ev.items() if e.robots == ["ur5"]}
    target = {}
    annotate(target, only_ur5, "direct", "ab" * 32, {"y_obj": 0.2, "qdot_max": 1.0, "robot": "panda"})
    # unchecked on the Panda, and held to the threshold the UR5's plans set (never below where it was checked)
    assert target["likely_at"] == max(0.5, only_ur5[evidence_key("direct", "ab" * 32, kind="judge")].at()["threshold"])
    assert "unchecked here" in target["risk"]["evidence"] and "robot panda (ur5)" in target["risk"]["evidence"]
