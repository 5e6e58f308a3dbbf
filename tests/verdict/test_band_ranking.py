"""scripts/band_ranking.py counts, by construction, the successes a threshold could call likely before it
admits a failure."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from judgeopt.files import REPO


def _script():
    spec = importlib.util.spec_from_file_location("band_ranking", REPO / "scripts" / "band_ranking.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_successes_are_counted_above_each_failure_and_a_tie_counts_against_the_score():
    ranked = _script().ranked_successes
    y = np.array([True, True, False, True, False])
    assert ranked(np.array([0.9, 0.8, 0.7, 0.6, 0.5]), y) == [2, 3, 3]
    assert ranked(np.array([0.5, 0.6, 0.7, 0.8, 0.9]), y) == [0, 1, 3]
    assert ranked(np.array([0.9, 0.9, 0.9, 0.1, 0.1]), y) == [0, 2, 3]  # the failure tied at 0.9 comes first


def test_a_cross_fitted_calibrator_ranks_what_the_judge_cannot(tmp_path, monkeypatch, capsys):
    """The judge says 0.99 to every plan; the plans fail exactly where mu lies in [1.8, 2.2], and no plan
    lies within 0.2 of that band. Ranked by the judge's own p, every failure ties with the successes and
    comes first: 0 above each. A calibrator fitted on another band of the same shape learns the band of
    mu: every success of the scored band ranks above its first failure."""
    import json
    import sys

    def band(folder, seed):
        rng = np.random.default_rng(seed)
        rows = []
        for i in range(300):
            mu = float(rng.choice([rng.uniform(1.0, 1.6), rng.uniform(1.8, 2.2), rng.uniform(2.4, 3.2)]))
            rows.append({"method": "held", "predicted_success": 0.99, "simulated_success": not 1.8 <= mu <= 2.2,
                         "max_constraint_violation": 0.0, "environment": {"y_obj": float(rng.uniform(0.12, 0.27)), "mu": mu},
                         "limits": {"qdot_max": 0.5, "f_max": 13.0}, **({"band_constraints": {"fdot_max": 60.0}} if i % 2 else {})})
        (folder / "partial").mkdir(parents=True)
        (folder / "partial" / "rows.json").write_text(json.dumps(rows))
        return rows

    scored = band(tmp_path / "scored", 1)
    band(tmp_path / "fitted", 2)
    monkeypatch.chdir(REPO)
    monkeypatch.setattr(sys, "argv", ["band_ranking", str(tmp_path / "scored"), "--method", "held", "--constraint-sets",
                                      "with", "--fit", str(tmp_path / "fitted")])
    _script().main()
    out = capsys.readouterr().out
    successes = sum(r["simulated_success"] for r in scored if r.get("band_constraints"))
    assert f"150 held plans that hold their limits, drawn with a constraint set, {successes} succeeded" in out
    assert "| judge's own p | 0 / 0 / 0 |" in out
    assert f"| calibrated, fitted on 150 plans of {tmp_path / 'fitted'} | {successes} / {successes} / {successes} |" in out
    monkeypatch.setattr(sys, "argv", ["band_ranking", str(tmp_path / "scored"), "--method", "held", "--fit",
                                      str(tmp_path / "none")])
    with pytest.raises(SystemExit, match="none: no evaluated plans"):  # one line, not a traceback
        _script().main()
