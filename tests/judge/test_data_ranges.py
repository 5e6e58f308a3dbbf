"""What a judge learnt from (judgeopt.judge.data_ranges): the ranges its file records, the
phrase for a value outside them, what train-judge records, and every shipped judge's ranges."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from judgeopt.data.dataset import Dataset, save
from judgeopt.files import resolve, shipped_models
from judgeopt.judge.data_ranges import (TOLERANCE, TOLERANCE_ABS, data_ranges, env_ranges_of, outside_data,
                                        tolerance)

PLAIN = {"task": "scoop", "train_data": {"env_ranges": {"y_obj": [0.10, 0.28], "mu": [1.0, 3.0]},
                                         "ranges": {"f": [0.0, 30.0]}}}
REFINED = {"refine_config": {"limit_ranges": {"qdot_max": [0.22, 1.2], "f_min": [0.0, 10.0], "f_max": [10.5, 16.0]}},
           "train_data": {"path": "data/train.h5", "planner_outcomes": 1400,
                          "env_ranges": {"y_obj": [0.10, 0.28], "mu": [0.05, 4.0]}}}


def test_the_tolerance_is_one_percent_of_the_width_plus_1e_9():
    assert (TOLERANCE, TOLERANCE_ABS) == (0.01, 1e-9)
    assert tolerance(0.10, 0.28) == pytest.approx(1e-9 + 0.0018, abs=1e-15)
    assert tolerance(0.246, 0.246) == 1e-9


@pytest.mark.parametrize("name, lo, hi", [("y_obj", 0.10, 0.28), ("mu", 1.0, 3.0)])
def test_each_end_is_inside_at_the_tolerance_and_outside_just_beyond(name, lo, hi):
    tol = tolerance(lo, hi)
    other = {"y_obj": 0.2, "mu": 2.0}
    for value in (lo, hi, lo - tol * (1 - 1e-6), hi + tol * (1 - 1e-6), (lo + hi) / 2):
        assert outside_data(PLAIN, {**other, name: value}, {}) == [], value
    for value in (lo - tol * (1 + 1e-6), hi + tol * (1 + 1e-6), lo - 1.0, hi + 1.0):
        notes = outside_data(PLAIN, {**other, name: value}, {})
        assert len(notes) == 1 and notes[0].startswith(f"{name} = {value:g}"), (value, notes)


def test_the_phrase_names_value_unit_and_range():
    assert outside_data(PLAIN, {"y_obj": 0.35, "mu": 2.0}, {}) == [
        "y_obj = 0.35 m is outside the judge's data (0.10-0.28)"]
    assert outside_data(PLAIN, {"y_obj": 0.05, "mu": 3.5}, {}) == [
        "y_obj = 0.05 m is outside the judge's data (0.10-0.28)", "mu = 3.5 is outside the judge's data (1.0-3.0)"]
    one = {"task": "scoop", "train_data": {"env_ranges": {"y_obj": [0.246, 0.246]}}}  # a lab's one object position
    assert outside_data(one, {"y_obj": 0.246}, {}) == []
    assert outside_data(one, {"y_obj": 0.25}, {}) == ["y_obj = 0.25 m is outside the judge's data (only 0.246)"]


def test_variables_without_a_recorded_range_are_not_mentioned():
    assert outside_data(PLAIN, {"y_obj": 0.2, "zeta": 99.0}, {}) == []


def test_limit_ranges_only_for_refined_judges():
    limits = {"qdot_max": 1.0, "f_min": 7.5, "f_max": 22.5}
    assert outside_data(PLAIN, {"y_obj": 0.2}, limits) == []  # a judge of demonstrations records no limits
    assert set(data_ranges(PLAIN)) == {"y_obj", "mu"}
    assert data_ranges(REFINED) == {"y_obj": (0.10, 0.28), "mu": (0.05, 4.0), "qdot_max": (0.22, 1.2),
                                    "f_min": (0.0, 10.0), "f_max": (10.5, 16.0)}
    assert outside_data(REFINED, {"y_obj": 0.2, "mu": 0.5}, limits) == [
        "f_max = 22.5 N is outside the judge's data (10.5-16.0)"]
    assert outside_data(REFINED, {}, {"qdot_max": 0.1, "q_max": 5.0}) == [
        "qdot_max = 0.1 m/s is outside the judge's data (0.22-1.20)"]  # q_max: no range recorded, not mentioned
    # the union over every round (train_data.limit_ranges) is read before the last run's refine_config
    wider = {**REFINED, "train_data": {**REFINED["train_data"], "limit_ranges": {"f_max": [10.5, 30.0]}}}
    assert outside_data(wider, {}, limits) == []


def test_a_per_axis_limit_is_checked_per_element():
    meta = {"task": "scrape", "refine_config": {"limit_ranges": {"qdot_max": [0.2, 0.6], "f_min": [0.0, 2.0],
                                                                 "f_max": [3.0, 30.0], "task": "scrape"}}}
    assert outside_data(meta, {}, {"qdot_max": [0.3, 0.6]}) == []
    assert outside_data(meta, {}, {"qdot_max": [0.3, 0.9]}) == [
        "qdot_max[1] = 0.9 m/s is outside the judge's data (0.20-0.60)"]
    assert outside_data(REFINED, {}, {"qdot_max": [1.5]}) == [  # one axis: named as the scalar limit
        "qdot_max = 1.5 m/s is outside the judge's data (0.22-1.20)"]
    assert outside_data(meta, {}, {"qdot_max": np.array([0.1, 0.9])}) == [
        "qdot_max[0] = 0.1 m/s is outside the judge's data (0.20-0.60)",
        "qdot_max[1] = 0.9 m/s is outside the judge's data (0.20-0.60)"]


def test_an_old_file_without_ranges_gives_no_phrase():
    old = json.loads(resolve("models/judge_demos_tcn.json").read_text())
    del old["train_data"]["env_ranges"], old["train_data"]["env_ranges_source"]  # as it was before
    for meta in (old, {"train_data": "data/train.h5"}, {}, {"refine_config": {"limit_ranges": None}}):
        assert data_ranges(meta) == {}
        assert outside_data(meta, {"y_obj": 9.0, "mu": -1.0}, {"f_max": 1e6}) == []


def _dataset(n: int, y_obj: tuple[float, float], mu: tuple[float, float], seed: int) -> Dataset:
    rng = np.random.default_rng(seed)
    horizon = 6
    t = np.linspace(0, 1, horizon + 1)
    y_end = rng.uniform(0.0, 0.38, n)
    y = -0.03 + (y_end + 0.03)[:, None] * (3 * t**2 - 2 * t**3)[None]
    resp = np.stack([y, np.gradient(y, 0.05, axis=1), 12 + rng.standard_normal((n, horizon + 1))], axis=2)
    env = np.stack([rng.uniform(*y_obj, n), rng.uniform(*mu, n)], axis=1)
    return Dataset(resp.copy(), resp, (y_end > env[:, 0]).astype(np.int64), env, 0.05, ("y_obj", "mu"))


def test_env_ranges_of_a_dataset():
    ds = _dataset(40, (0.12, 0.2), (1.5, 2.5), seed=0)
    r = env_ranges_of(ds)
    assert r == {"y_obj": [ds.env[:, 0].min(), ds.env[:, 0].max()], "mu": [ds.env[:, 1].min(), ds.env[:, 1].max()]}
    assert all(type(v) is float for lo_hi in r.values() for v in lo_hi)  # JSON-ready
    assert env_ranges_of(ds.subset(np.zeros(ds.n, bool))) == {}


def test_train_judge_records_the_env_ranges_of_all_its_training_files(tmp_path):
    from judgeopt.cli import main

    a, b = _dataset(60, (0.12, 0.2), (1.5, 2.0), seed=1), _dataset(60, (0.15, 0.26), (1.2, 1.8), seed=2)
    save(a, tmp_path / "a.h5")
    save(b, tmp_path / "b.h5")
    out = tmp_path / "j"
    assert main(["train-judge", "--train", str(tmp_path / "a.h5"), str(tmp_path / "b.h5"), "--out", str(out),
                 "--epochs", "1", "--lstm-units", "4", "--fc-units", "4", "--batch-size", "32", "--threads", "1",
                 "--quiet"]) == 0
    meta = json.loads(out.with_suffix(".json").read_text())
    env = np.concatenate([a.env, b.env])
    assert meta["train_data"]["env_ranges"] == {"y_obj": [env[:, 0].min(), env[:, 0].max()],
                                                "mu": [env[:, 1].min(), env[:, 1].max()]}
    assert outside_data(meta, {"y_obj": float(env[:, 0].max()), "mu": 1.5}, {}) == []
    assert outside_data(meta, {"y_obj": 0.35, "mu": 1.5}, {})[0].startswith("y_obj = 0.35 m is outside")


def _shipped_judges():
    for js in sorted(shipped_models().rglob("*.json")):
        meta = json.loads(js.read_text())
        if isinstance(meta, dict) and meta.get("format") == "judgeopt-judge":
            yield js, meta


def test_every_shipped_judge_records_the_env_ranges_it_learnt_from():
    judges = list(_shipped_judges())
    assert len(judges) >= 13  # 6 scoop judges, 5 ensemble members, 2 scrape judges
    for js, meta in judges:
        td = meta["train_data"]
        ranges = td.get("env_ranges")
        assert ranges and td.get("env_ranges_source"), js
        assert set(meta["config"]["env_names"]) <= set(ranges), js
        assert all(lo <= hi for lo, hi in ranges.values()), js
        if meta.get("refine_config", {}).get("limit_ranges"):  # refined: the limits of every round
            assert set(td["limit_ranges"]) == {"qdot_max", "f_min", "f_max"}, js


def test_no_shipped_problem_is_outside_its_own_judges_data():
    """A phrase on every plan of a default problem would be a false alarm people learn to ignore."""
    from judgeopt.judge.store import load_meta
    from judgeopt.planners.limits import CONDITION_NAMES
    from judgeopt.planners.problem import load_problem

    import judgeopt

    problems = sorted((Path(judgeopt.__file__).parent / "tasks").glob("*/problems/*.toml"))
    assert len(problems) >= 6
    for path in problems:
        problem = load_problem(path)
        judges = [resolve(problem.judge, (".json",))]
        if getattr(problem, "ensemble", None):
            judges += sorted(resolve(problem.ensemble).glob("member_*.pt"))
        limits = {k: problem.vec(k).tolist() for k in CONDITION_NAMES}
        for judge in judges:
            meta = load_meta(judge)
            assert data_ranges(meta), judge
            for end in (0, 1):
                env = {k: problem.env_range(k)[end] for k in problem.env_names}
                assert outside_data(meta, env, limits) == [], (path.name, judge, env)


def test_inspect_shows_what_a_judge_learnt_from(capsys):
    from judgeopt.cli import main

    assert main(["inspect", "models/judge_demos_tcn"]) == 0
    assert "learnt from    : y_obj 0.10-0.28 m, mu 1.0-3.0\n" in capsys.readouterr().out
    assert main(["inspect", "models/judge_refined"]) == 0
    text = capsys.readouterr().out
    assert "learnt from    : y_obj 0.10-0.28 m, mu 0.05-4.0; limits qdot_max 0.22-1.20 m/s, f_min 0-10 N, " \
           "f_max 10.5-30 N" in text and "ranges from    : data/train.h5 measured;" in text
