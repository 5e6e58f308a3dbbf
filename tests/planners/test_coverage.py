"""A judge asked about forces its demonstrations never reached says so (coverage_notes)."""

from __future__ import annotations

from judgeopt.files import resolve
from judgeopt.planners.limits import coverage_notes
from judgeopt.planners.problem import load_problem


def _meta(lo: float, hi: float) -> dict:
    return {"train_data": {"ranges": {"y": [-0.1, 0.3], "ydot": [-0.1, 1.0], "f": [lo, hi]}}}


def test_limits_outside_the_recorded_forces_are_named_with_the_sign_fix():
    real = load_problem(resolve("problems/paper_real.toml"))  # Table 8: f in [1, 10] N
    (note,) = coverage_notes(real, _meta(-24.0, 0.3))  # recorded with the other sign
    assert "allow f in [1, 10] N, but the judge's training data has f in [-24, 0.3] N" in note
    assert note.endswith("re-import them with --scale f=-1")
    assert coverage_notes(real, _meta(-1.0, 2.0)) != []  # 1 N of 9 overlaps: under a fifth
    assert coverage_notes(real, _meta(0.0, 14.0)) == []
    assert coverage_notes(real, {"train_data": {}}) == []  # a judge saved before ranges were kept
    assert coverage_notes(real, {"train_data": "my file"}) == []  # or by other code
