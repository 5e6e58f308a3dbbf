"""Plans out to a robot: the task frame of a problem file, the CSV the importer reads back, and the
ROS 2 MCAP file read back with rosbags itself, sample by sample."""

from __future__ import annotations

import dataclasses
import json
import sys

import numpy as np
import pytest

from judgeopt.files import resolve
from judgeopt.formats.plan import PlanFileError, plan_provenance, plan_record, record_frame
from judgeopt.formats.exporters import export_record
from judgeopt.formats.frame import TaskFrame
from judgeopt.planners.problem import ProblemError, load_problem
from judgeopt.planners.result import PlanResult
from judgeopt.tasks import get_task

ENV = {"y_obj": 0.2, "mu": 2.0}
#: a frame that moves, turns and flips every axis, so a wrong transform cannot pass
FRAME = {"frame_id": "ur5_base", "origin": [0.45, -0.1, 0.02], "orientation": [0.0, 0.0, 0.38268343, 0.92387953],
         "axes": {"y": "-x", "f": "z"}}


def record(problem=None, env=ENV, seed=0):
    """A plan record as `solve --save-json` writes it, for a random demonstration command."""
    problem = problem or load_problem(resolve("problems/paper_sim.toml"))
    task = get_task(problem.task)
    plan = task.plan(task.random_command(np.random.default_rng(seed), env))
    result = PlanResult("direct", dict(env), plan, 0.9, "solved", 0.1, success_probability=0.9,
                        probability_source="judge")
    return plan, plan_record(result, problem, plan_provenance(None, None, command="test"))


def write_problem(tmp_path, frame_lines: str, base: str = "paper_sim.toml"):
    path = tmp_path / "p.toml"
    path.write_text(f'base = "{resolve("problems/" + base)}"\n[frame]\n{frame_lines}\n')
    return path


# -- the task frame ---------------------------------------------------------------------------
def test_default_frames_come_from_the_task():
    scoop = load_problem(resolve("problems/paper_sim.toml")).task_frame()
    scrape = load_problem(resolve("problems/scrape.toml")).task_frame()
    assert scoop == TaskFrame("base_link", (0, 0, 0), (0, 0, 0, 1), {"y": "y", "f": "-z"})
    assert scrape.axes == {"x": "x", "y": "y", "f": "-z"}


def test_a_problem_file_declares_its_frame(tmp_path):
    p = load_problem(write_problem(tmp_path, 'frame_id = "ur5_base"\norigin = [0.45, -0.1, 0.02]\n'
                                            'orientation = [0, 0, 0.7071068, 0.7071068]\naxes = { y = "-x" }'))
    f = p.task_frame()
    assert f.frame_id == "ur5_base" and f.origin == (0.45, -0.1, 0.02) and f.axes == {"y": "-x", "f": "-z"}
    assert np.linalg.norm(f.orientation) == pytest.approx(1, abs=1e-12)  # normalised
    assert "frame" not in p.to_dict()  # where a plan goes is not what is planned: no id or cache changes


@pytest.mark.parametrize("lines, field", [
    ('origin = [0, 0]', "origin"),
    ('orientation = [0, 0, 0, 2]', "orientation"),
    ('frame_id = "base link"', "frame_id"),
    ('axes = { f = "down" }', "axes.f"),
    ('axes = { ydot = "y" }', "axes.ydot"),
    ('colour = "red"', "colour"),
])
def test_a_bad_frame_is_one_line_naming_the_file_and_field(tmp_path, lines, field):
    path = write_problem(tmp_path, lines)
    with pytest.raises(ProblemError) as err:
        load_problem(path)
    assert str(path) in str(err.value) and field in str(err.value) and "\n" not in str(err.value)


def test_two_positions_on_one_axis_are_refused(tmp_path):
    with pytest.raises(ProblemError, match=r"axes\.y = '-x' lies along the axis of 'x'"):
        load_problem(write_problem(tmp_path, 'axes = { y = "-x" }', base="scrape.toml"))


def test_the_plan_record_keeps_the_frame_and_an_older_one_gets_the_default():
    problem = dataclasses.replace(load_problem(resolve("problems/paper_sim.toml")), frame=FRAME)
    _, rec = record(problem)
    assert record_frame(rec, "p.json") == problem.task_frame()
    del rec["frame"]
    assert record_frame(rec, "p.json") == load_problem(resolve("problems/paper_sim.toml")).task_frame()
    rec["frame"] = {**FRAME, "axes": {"q": "x"}}
    with pytest.raises(PlanFileError, match=r"p\.json: field 'frame': \[frame\] axes\.q"):
        record_frame(rec, "p.json")


# -- CSV: what the importer reads ---------------------------------------------------------------
def test_an_executed_csv_plan_with_a_label_re_imports_as_the_plan(tmp_path):
    from judgeopt.data.importer import ImportSpec, import_demos

    plan, rec = record()
    path = export_record(rec, tmp_path / "plan.csv", "csv")
    lines = path.read_text().splitlines()
    assert lines[0] == "t,y,ydot,f,y_obj,mu" and len(lines) == 1 + 1501
    # what a robot's logger adds after executing the plan: the outcome on every row
    recorded = tmp_path / "run_1.csv"
    recorded.write_text("\n".join([lines[0] + ",label"] + [row + ",success" for row in lines[1:]]) + "\n")
    ds, errors = import_demos([recorded], ImportSpec(("y_obj", "mu")))
    assert errors == [] and ds.n == 1 and ds.labels.tolist() == [1]
    assert ds.env[0].tolist() == [0.2, 2.0]
    np.testing.assert_allclose(ds.commands[0], plan.values, atol=1e-7)  # every sample of every channel


# -- MCAP: what a ROS 2 user plays ----------------------------------------------------------------
def test_mcap_reads_back_with_rosbags_sample_by_sample(tmp_path):
    pytest.importorskip("rosbags")
    from rosbags.highlevel import AnyReader

    problem = dataclasses.replace(load_problem(resolve("problems/paper_sim.toml")), frame=FRAME)
    plan, rec = record(problem)
    path = export_record(rec, tmp_path / "plan.mcap", "mcap", start_ns=1_700_000_000 * 10**9)
    assert path.is_file() and not [p for p in tmp_path.iterdir() if p != path]  # one file, no temporary left
    topics: dict[str, list] = {}
    with AnyReader([path]) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        for conn, ns, raw in reader.messages():
            topics.setdefault(conn.topic, []).append((ns, reader.deserialize(raw, conn.msgtype)))
    assert types == {"/judgeopt/pose": "geometry_msgs/msg/PoseStamped",
                     "/judgeopt/twist": "geometry_msgs/msg/TwistStamped",
                     "/judgeopt/wrench": "geometry_msgs/msg/WrenchStamped",
                     "/judgeopt/plan_info": "std_msgs/msg/String"}
    (_, info), = topics["/judgeopt/plan_info"]
    info = json.loads(info.data)
    assert info["method"] == "direct" and info["environment"] == ENV and info["frame"]["frame_id"] == "ur5_base"
    assert info["provenance"]["command"] == "test"

    t, want = plan.resample(1e-3)
    frame = problem.task_frame()
    R, origin = frame.rotation(), np.array(FRAME["origin"])
    for topic in ("/judgeopt/pose", "/judgeopt/twist", "/judgeopt/wrench"):
        msgs = topics[topic]
        assert len(msgs) == len(t)
        stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for _, m in msgs])
        np.testing.assert_array_equal(stamps, [ns for ns, _ in msgs])  # header stamp = log time
        np.testing.assert_array_equal(stamps - 1_700_000_000 * 10**9, np.round(t * 1e9).astype(np.int64))
        assert {m.header.frame_id for _, m in msgs} == {"ur5_base"}
    pos = np.array([[m.pose.position.x, m.pose.position.y, m.pose.position.z] for _, m in topics["/judgeopt/pose"]])
    vel = np.array([[m.twist.linear.x, m.twist.linear.y, m.twist.linear.z] for _, m in topics["/judgeopt/twist"]])
    force = np.array([[m.wrench.force.x, m.wrench.force.y, m.wrench.force.z] for _, m in topics["/judgeopt/wrench"]])
    # back into the task frame: y lies along -x, the force along +z (FRAME["axes"])
    local_pos, local_vel, local_force = (pos - origin) @ R, vel @ R, force @ R
    np.testing.assert_allclose(-local_pos[:, 0], want[:, 0], atol=1e-12)
    np.testing.assert_allclose(local_pos[:, 1:], 0, atol=1e-12)
    np.testing.assert_allclose(-local_vel[:, 0], want[:, 1], atol=1e-12)
    np.testing.assert_allclose(local_force[:, 2], want[:, 2], atol=1e-9)
    np.testing.assert_allclose(local_force[:, :2], 0, atol=1e-9)
    q = topics["/judgeopt/pose"][0][1].pose.orientation
    np.testing.assert_allclose([q.x, q.y, q.z, q.w], frame.orientation, atol=1e-15)


def test_mcap_without_rosbags_names_the_extra(tmp_path, monkeypatch):
    _, rec = record()
    monkeypatch.setitem(sys.modules, "rosbags.typesys", None)  # as if not installed
    with pytest.raises(ModuleNotFoundError, match=r"pip install 'judgeopt\[ros\]'") as err:
        export_record(rec, tmp_path / "plan.mcap", "mcap")
    assert err.value.name == "rosbags" and not (tmp_path / "plan.mcap").exists()
