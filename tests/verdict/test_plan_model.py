"""The plan model (judgeopt.verdict.plan_model) against figures known by construction: scikit-learn's own
predictions, outcomes that depend on one sample of the plan only, folds whose outcomes are reversed."""

from __future__ import annotations

import base64
import json

import numpy as np
import pytest

from judgeopt.verdict.calibration import CalibrationError, load_calibration_document, save_calibration
from judgeopt.verdict.plan_model import (BOOSTING, PlanModel, constraints_of, fit_plan_model, out_of_fold,
                                         plan_model_of)
from judgeopt.verdict.risk import PLAN_MODEL, fit_evidence, kind_of

SAMPLES = 31
JUDGE = "c" * 64


def _band(n: int, seed: int, flip: bool = False, method_of=lambda i: ("direct", "held")[i % 2]) -> list[dict]:
    """Band rows whose outcome is the plan's force at knot 15 above 12 N (below, with `flip`); the judge
    says 0.9 to every plan, so only the plan's samples can tell them apart."""
    rng = np.random.default_rng(seed)
    rows = []
    for i in range(n):
        f = rng.uniform(8.0, 16.0, SAMPLES)
        rows.append({"method": method_of(i), "predicted_success": 0.9, "simulated_success": bool((f[15] > 12.0) != flip),
                     "max_constraint_violation": 0.0, "judge_sha256": JUDGE,
                     "environment": {"y_obj": float(rng.uniform(0.12, 0.27)), "mu": float(rng.uniform(1.0, 3.2))},
                     "limits": {"qdot_max": float(rng.uniform(0.3, 1.0)), "f_max": 16.0},
                     "band_constraints": {"fdot_max": 60.0} if i % 3 == 0 else {},
                     "channels": ["y", "ydot", "f"], "y": rng.uniform(0, 0.3, SAMPLES).tolist(),
                     "ydot": rng.uniform(-0.5, 0.5, SAMPLES).tolist(), "f": f.tolist()})
    return rows


@pytest.fixture(scope="module")
def fitted() -> tuple[PlanModel, list[dict]]:
    rows = _band(600, 1)
    return fit_plan_model(rows), rows


def test_the_trees_walked_with_numpy_give_scikit_learn_s_own_probabilities(fitted):
    """Missing rates (NaN: no constraint set) go where scikit-learn sends them."""
    from sklearn.ensemble import HistGradientBoostingClassifier

    model, rows = fitted
    X = model.features(rows)
    assert np.isnan(X[:, 1 + len(model.names) + 2]).any()  # fdot_max: not drawn in two of three settings
    X[:, np.isnan(X).all(axis=0)] = 0.0  # a_max and jerk_max, never drawn (as fit_plan_model fits them)
    clf = HistGradientBoostingClassifier(**BOOSTING, random_state=0).fit(X, [r["simulated_success"] for r in rows])
    others = model.features(_band(200, 7))
    assert np.abs(model.predict(others) - clf.predict_proba(others)[:, 1]).max() < 1e-12


def test_it_reads_the_plan_where_the_judge_says_the_same_to_every_plan(fitted):
    model, _ = fitted
    fresh = _band(300, 2)
    p = model.predict(model.features(fresh))
    y = np.array([r["simulated_success"] for r in fresh])
    clear = np.array([abs(r["f"][15] - 12.0) > 0.5 for r in fresh])  # not within half a newton of the edge
    assert ((p > 0.5) == y)[clear].all() and ((p > 0.5) == y).mean() > 0.95


def test_it_covers_only_what_it_was_fitted_on(fitted):
    model, rows = fitted
    row = dict(rows[0])
    assert model.covers(row) and model.annotate(row)["calibrated_by"] == PLAN_MODEL
    far = {**row, "limits": {**row["limits"], "qdot_max": 1.5}}
    under_scale = {**row, "band_constraints": {"joint_limit_scale": 0.8}}
    per_axis = {**row, "band_constraints": {"fdot_max": [60.0, 70.0]}}
    unknown = {k: v for k, v in row.items() if k != "band_constraints"}
    shorter = {**row, "f": row["f"][:-1]}
    for r in (far, under_scale, per_axis, unknown, shorter, {**row, "method": "cmaes"}, {**row, "judge_sha256": "d" * 64}):
        assert not model.covers(r) and model.annotate(r) == {}
    assert not model.covers(row, robot="panda")
    # a live problem's constraint set with nothing set is no constraint set
    live = {**unknown, "constraints": {"a_max": None, "jerk_max": None, "fdot_max": None, "bounds": [],
                                       "joint_limit_scale": None}}
    assert constraints_of(live) == live["constraints"] and model.covers(live)


def test_each_fold_is_scored_by_a_model_that_never_saw_it():
    """Two folds whose outcomes are the reverse of each other: a model of the other fold gets every plan
    wrong. A model that had seen the fold itself would get most of them right."""
    folds = {"a": _band(300, 3), "b": _band(300, 4, flip=True)}
    out_of_fold(folds)
    for rows in folds.values():
        p = np.array([r["calibrated_success"] for r in rows])
        y = np.array([r["simulated_success"] for r in rows])
        assert all(kind_of(r) == "plans" for r in rows)
        assert (p[y] < 0.5).mean() > 0.9 and (p[~y] > 0.5).mean() > 0.9
    with pytest.raises(CalibrationError, match="at least two band folders"):
        out_of_fold({"a": folds["a"]})


def test_the_evidence_of_a_plan_model_s_p_is_kept_apart_and_made_only_where_it_stood(fitted):
    model, rows = fitted
    scored = [{**r, **model.annotate(r)} for r in rows[:100]]
    plain = [{**r, "method": "amortized"} for r in rows[100:150]]
    evidence = fit_evidence(scored + plain)
    kinds = {(e.method, e.kind) for e in evidence.values()}
    assert ("direct", "plans") in kinds and ("held", "plans") in kinds and ("amortized", "plans") not in kinds
    assert ("amortized", "judge") in kinds and ("amortized", "calibrated") in kinds


def test_a_calibration_file_keeps_the_model_and_refuses_a_broken_one(tmp_path, fitted):
    model, rows = fitted
    path = save_calibration(tmp_path / "cal.json", {}, None, model.to_dict())
    _, _, section = load_calibration_document(path)
    again = plan_model_of(section, str(path))
    assert again.predict(again.features(rows[:20])).tolist() == model.predict(model.features(rows[:20])).tolist()
    broken = json.loads(path.read_text())
    left = np.frombuffer(base64.b64decode(broken["plan_model"]["nodes"]["left"]), "<i4").copy()
    left[0] = model.sizes[0]  # the first tree's root's left child: one past its last node
    broken["plan_model"]["nodes"]["left"] = base64.b64encode(left.tobytes()).decode()
    path.write_text(json.dumps(broken))
    with pytest.raises(CalibrationError, match="malformed plan model .*points outside.*--plan-model"):
        plan_model_of(load_calibration_document(path)[2], str(path))
    broken["plan_model"] = [1, 2]
    path.write_text(json.dumps(broken))
    with pytest.raises(CalibrationError, match="malformed plan model"):
        load_calibration_document(path)


def test_too_few_plans_or_two_judges_are_refused():
    with pytest.raises(CalibrationError, match="too few for a plan model"):
        fit_plan_model(_band(50, 5))
    mixed = _band(200, 5)
    mixed[0]["judge_sha256"] = "d" * 64
    with pytest.raises(CalibrationError, match="2 judges"):
        fit_plan_model(mixed)
    mixed = _band(200, 5)
    mixed[0]["f"] = mixed[0]["f"][:-1]
    with pytest.raises(CalibrationError, match="2 different sets of channels or horizons"):
        fit_plan_model(mixed)
    mixed = _band(200, 5)
    mixed[0]["robot"] = "panda"
    with pytest.raises(CalibrationError, match=r"2 arms \(panda, ur5\)"):
        fit_plan_model(mixed)


def test_calibrate_fits_a_plan_model_on_band_folders_and_keeps_the_rest_of_the_file(tmp_path, capsys):
    from judgeopt.cli.main import main
    from judgeopt.files import REPO

    for name, seed in (("a", 11), ("b", 12)):
        (tmp_path / name / "partial").mkdir(parents=True)
        (tmp_path / name / "partial" / "rows.json").write_text(json.dumps(_band(300, seed)))
    out = tmp_path / "cal.json"
    out.write_bytes((REPO / "models" / "calibration_default.json").read_bytes())
    before, before_evidence, _ = load_calibration_document(out)
    assert main(["calibrate", "--plan-model", str(tmp_path / "a"), str(tmp_path / "b"), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "direct: likely at p >= " in text and "a plan model fitted on 600 replayed plans of 2 folders" in text
    calibrators, evidence, section = load_calibration_document(out)
    # the calibrators and every other kind's evidence kept; the old model's evidence goes with it
    assert set(calibrators) == set(before)
    assert all(evidence[k].to_dict() == e.to_dict() for k, e in before_evidence.items() if e.kind != "plans")
    assert {e.kind for e in evidence.values() if e.judge_sha256 == JUDGE} == {"plans"}
    assert not any(e.kind == "plans" and e.judge_sha256 != JUDGE for e in evidence.values())
    assert plan_model_of(section, str(out)).n == 600
    assert main(["calibrate", "--plan-model", str(tmp_path / "a"), "--out", str(out)]) != 0
    assert "at least two band folders" in capsys.readouterr().err


@pytest.mark.slow
def test_a_solve_reads_the_plan_model_of_its_calibration_file_where_it_covers_the_plan(tmp_path):
    """A model fitted on band rows of the shipped judge: a direct plan inside its ranges gets its p (printed as
    calibrated, judged by its own evidence's kind); the same plan beyond them keeps the calibrators' p."""
    from judgeopt.files import resolve
    from judgeopt.planners.loaded import Planners
    from judgeopt.planners.problem import LIMIT_NAMES, load_problem

    problem = load_problem(resolve("problems/paper_sim.toml")).with_overrides(qdot_max=0.5, f_max=13.0)
    sha = Planners.load(problem, ("direct",)).judge_meta["weights_sha256"]
    rows = _band(300, 21, method_of=lambda i: "direct")
    for r, f_max in zip(rows, np.random.default_rng(22).uniform(11.0, 15.5, len(rows))):
        r["judge_sha256"] = sha
        r["limits"] = {**{k: getattr(problem, k) for k in LIMIT_NAMES}, "qdot_max": r["limits"]["qdot_max"],
                       "f_max": float(f_max)}
    model = fit_plan_model(rows)
    path = save_calibration(tmp_path / "cal.json", *load_calibration_document(resolve("models/calibration_default.json"))[:2],
                            model.to_dict())
    env = {"y_obj": 0.2, "mu": 2.0}
    (inside,) = Planners.load(problem.with_overrides(calibration=str(path)), ("direct",)).solve(env)
    assert inside.info["calibrated_by"] == PLAN_MODEL and inside.probability_source == "calibrated"
    f = inside.plan.values[:, [c.name for c in inside.plan.channels].index("f")]
    assert inside.info["calibrated_success"] == pytest.approx(float(f[15] > 12.0), abs=0.1)
    assert kind_of(inside.info) == "plans"
    (beyond,) = Planners.load(problem.with_overrides(calibration=str(path), f_max=20.0), ("direct",)).solve(env)
    assert "calibrated_by" not in beyond.info


def test_the_suggestion_search_screens_the_plan_model_s_range_ends_nearest_first(fitted):
    """Across an end of the model's range a plan's p changes kind, so "likely" need not grow there: the
    ends between the current value and the bound are screened, nearest first, in the relaxing direction."""
    from types import SimpleNamespace

    from judgeopt.session.suggest import Relaxation, kind_edges

    model, _ = fitted
    planners = SimpleNamespace(plan_model=model)
    i = model.names.index("qdot_max")
    lo, hi = model.low[i], model.high[i]
    up = Relaxation("qdot_max", +1, 0.05, 1.5, "m/s")
    assert kind_edges(planners, up, lo - 0.2) == [lo, hi]
    assert kind_edges(planners, up, lo + 0.01) == [hi]  # lo lies behind the current value
    assert kind_edges(planners, up, hi - 0.01) == []  # within the resolution
    down = Relaxation("qdot_max", -1, 0.05, 0.0, "m/s")
    assert kind_edges(planners, down, hi + 0.2) == [hi, lo]
    assert kind_edges(planners, Relaxation("f_min", -1, 1.0, 0.0, "N"), 7.5) == []  # not an input of the model
    assert kind_edges(SimpleNamespace(plan_model=None), up, 0.1) == []


def test_features_are_the_judge_s_logit_the_inputs_the_set_the_planner_and_the_samples_in_that_order(fitted):
    """Against a vector written out by hand: a judge's p of 0 or 1 is clipped to 1e-6 from the end."""
    model, rows = fitted
    row = {**rows[3], "method": "held", "predicted_success": 1.0,
           "band_constraints": {"fdot_max": 60.0, "a_max": 2.5, "bounds": ["f:0:15.9@0:0.55"]}}
    x = model.features([row])[0]
    values = {"qdot_max": row["limits"]["qdot_max"], "f_max": 16.0, **row["environment"]}
    expected = [np.log((1 - 1e-6) / 1e-6), *(values[k] for k in model.names), 2.5, np.nan, 60.0, 1.0,
                *(float(m == "held") for m in model.planners), *row["y"], *row["ydot"], *row["f"]]
    assert model.names == sorted(values) and model.planners == ["direct", "held"]
    np.testing.assert_allclose(x, np.array(expected), rtol=1e-9)  # NaN where NaN
    low = model.features([{**rows[3], "predicted_success": 0.0, "band_constraints": {}}])[0]
    assert low[0] == pytest.approx(-np.log((1 - 1e-6) / 1e-6)) and np.isnan(low[5:8]).all() and low[8] == 0.0
    assert model.features([{**rows[3], "predicted_success": 0.9}])[0][0] == pytest.approx(np.log(9.0))


def test_a_fitted_model_records_what_it_was_fitted_on(fitted):
    model, rows = fitted
    assert (model.n, model.successes) == (600, sum(r["simulated_success"] for r in rows))
    assert model.judge_sha256 == JUDGE and model.robot == "ur5" and model.samples == SAMPLES
    assert model.channels == ["y", "ydot", "f"] and len(model.sizes) == BOOSTING["max_iter"]
    i = model.names.index("qdot_max")
    assert (model.low[i], model.high[i]) == (min(r["limits"]["qdot_max"] for r in rows),
                                             max(r["limits"]["qdot_max"] for r in rows))
    on_arm = fit_plan_model([{**r, "robot": "panda"} for r in _band(120, 8)], sources=["b", "a", "b"])
    assert on_arm.robot == "panda" and on_arm.sources == ["a", "b"] and on_arm.n == 120
    # rows without an outcome, a p, a plan or a stated constraint set are not fitted on
    unusable = [{**r, "simulated_success": None} for r in rows[:5]] + [{**r, "predicted_success": None} for r in rows[5:10]]
    unusable += [{k: v for k, v in r.items() if k != "band_constraints"} for r in rows[10:15]]
    unusable += [{**r, "channels": []} for r in rows[15:20]]
    assert fit_plan_model(unusable + rows[20:120]).n == 100
    with pytest.raises(CalibrationError, match="99 replayed band plans are too few"):
        fit_plan_model(unusable + rows[20:119])


def test_coverage_ends_at_the_range_s_margin_and_at_any_other_constraint(fitted):
    from judgeopt.verdict.plan_model import RANGE_MARGIN

    model, rows = fitted
    i = model.names.index("qdot_max")
    lo, hi = model.low[i], model.high[i]
    tol = 1e-9 + RANGE_MARGIN * (hi - lo)
    at = lambda v: {**rows[0], "limits": {**rows[0]["limits"], "qdot_max": v}}  # noqa: E731
    assert model.covers(at(lo - tol)) and model.covers(at(hi + tol))
    assert not model.covers(at(lo - 1.001 * tol)) and not model.covers(at(hi + 1.001 * tol))
    assert model.covers({k: v for k, v in rows[0].items() if k != "judge_sha256"})  # a row without its judge: the model's
    assert not model.covers({**rows[0], "band_constraints": {"joint_limit_scale": 1}})
    assert model.covers({**rows[0], "band_constraints": {"bounds": ["f:0:15.9@0:0.55"], "joint_limit_scale": 0}})
    assert not model.covers({**rows[0], "limits": {"qdot_max": 0.5}})  # f_max, an input, not stated


def test_out_of_fold_drops_what_an_earlier_model_wrote():
    folds = {"a": _band(200, 3), "b": _band(200, 4)}
    stale = {"calibrated_success": 0.5, "calibration_covers": True, "calibrated_by": "old"}
    folds["a"][0].update(stale)
    # beyond the range of the folder it is scored by a model of: not covered
    folds["b"][0].update({**stale, "limits": {**folds["b"][0]["limits"], "qdot_max": 5.0}})
    out_of_fold(folds)
    assert folds["a"][0]["calibrated_by"] == PLAN_MODEL and folds["a"][0]["calibrated_success"] != 0.5
    assert not {"calibrated_success", "calibration_covers", "calibrated_by"} & set(folds["b"][0])


def test_a_stored_model_is_read_once_per_section_and_every_broken_field_is_refused(fitted, tmp_path):
    model, rows = fitted
    section = model.to_dict()
    first = plan_model_of(section, "here")
    assert plan_model_of(section, "here") is first and plan_model_of(dict(section), "here") is not first
    assert plan_model_of(None, "here") is None

    def broken(**change):
        with pytest.raises(CalibrationError, match=r"^here: malformed plan model .*--plan-model FOLDER\.\.\.`$"):
            PlanModel.from_dict({**section, **change}, "here")

    nodes = section["nodes"]

    def field(name, index, value):
        a = np.frombuffer(base64.b64decode(nodes[name]), FIELDS[name]).copy()
        a[index] = value
        return {**nodes, name: base64.b64encode(a.tobytes()).decode()}

    from judgeopt.verdict.plan_model import FIELDS

    broken(sizes=[])
    broken(sizes=[0, *section["sizes"][1:]])
    broken(low=section["low"][:-1])
    broken(high=section["high"][:-1])
    broken(nodes={**nodes, "left": nodes["left"][:-8]})
    broken(nodes={**nodes, "value": "not base64!"})
    broken(nodes=field("left", 0, -1))
    broken(nodes=field("right", 0, section["sizes"][0]))
    broken(nodes=field("feature", 0, -1))
    width = 1 + len(model.names) + 3 + 1 + len(model.planners) + 3 * SAMPLES
    broken(nodes=field("feature", 0, width))
    PlanModel.from_dict({**section, "nodes": field("feature", 0, width - 1)}, "here")  # the last feature is one
    PlanModel.from_dict({**section, "nodes": field("left", 0, section["sizes"][0] - 1)}, "here")  # the last node too
    broken(names=None)


def test_a_missing_rate_goes_where_scikit_learn_sends_it():
    """Outcomes that depend only on whether a force-rate limit was drawn: the trees split on a value that is
    missing (NaN) in half the plans, and the walk must route those plans as scikit-learn does."""
    from sklearn.ensemble import HistGradientBoostingClassifier

    rows = _band(400, 9)
    for i, r in enumerate(rows):
        r["band_constraints"] = {"fdot_max": 40.0 + i % 7} if i % 2 else {}
        r["simulated_success"] = bool(i % 2)
    model = fit_plan_model(rows)
    X = model.features(rows)
    X[:, np.isnan(X).all(axis=0)] = 0.0
    clf = HistGradientBoostingClassifier(**BOOSTING, random_state=0).fit(X, [r["simulated_success"] for r in rows])
    assert np.abs(model.predict(X) - clf.predict_proba(X)[:, 1]).max() < 1e-12
    assert ((model.predict(model.features(rows)) > 0.5) == np.array([r["simulated_success"] for r in rows])).all()


def test_a_live_plan_is_read_as_its_stored_row_would_be(fitted):
    """A result's row (PlanResult.to_json: its judge and limits in its info) with its problem's constraint
    set, as Planners annotates it: another judge's plan or another arm is not covered."""
    from judgeopt.planners.result import PlanResult
    from judgeopt.tasks import get_task
    from judgeopt.trajectory import Plan

    model, rows = fitted
    row = rows[0]
    channels = {c.name: c for c in get_task("scoop").channels}
    plan = Plan.from_columns(0.05, tuple(channels[c] for c in row["channels"]), *(row[c] for c in row["channels"]))

    def live(judge):
        result = PlanResult(row["method"], row["environment"], plan, row["predicted_success"], "solved", 0.0,
                            info={"limits": row["limits"], "judge_sha256": judge})
        return {**result.to_json(), "constraints": {"fdot_max": None, "bounds": []}}

    assert model.annotate(live(JUDGE))["calibrated_success"] == pytest.approx(
        float(model.predict(model.features([{**row, "band_constraints": {}}]))[0]), abs=1e-12)
    assert model.annotate(live("d" * 64)) == {} and model.annotate(live(JUDGE), robot="panda") == {}
