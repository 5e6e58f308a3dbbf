"""What would make an unlikely plan likely: the suggestion search, on a planner whose answer is a
known function of the limits."""

from __future__ import annotations

import dataclasses

import numpy as np

from conftest import direct_result
from judgeopt.files import resolve
from judgeopt.planners.problem import load_problem
from judgeopt.session.suggest import relaxations, suggest
from judgeopt.tasks import get_task
from judgeopt.verdict import rules as rules_module
from judgeopt.verdict.rules import LIKELY, assess

RELAXATIONS = relaxations(get_task("scoop"))


@dataclasses.dataclass
class FakePlanners:
    """Stands in for Planners: success probability rises with f_max (0.5 at 20 N), not with q̇_max."""

    problem: object
    methods: tuple = ("direct",)
    calls: list = dataclasses.field(default_factory=list)

    def with_limits(self, **limits):
        return dataclasses.replace(self, problem=self.problem.with_overrides(**limits))

    def only(self, method):
        return dataclasses.replace(self, methods=(method,))

    def solve(self, env, simulator=None, guess=None):
        self.calls.append(self.problem.f_max)
        p = 1.0 / (1.0 + np.exp(-(self.problem.f_max - 20.0)))
        return [assess(direct_result(float(p)))]


def test_suggest_finds_the_smallest_relaxation_that_makes_a_plan_likely():
    problem = load_problem(resolve("problems/paper_sim.toml")).with_overrides(f_max=12.0)
    planners = FakePlanners(problem)
    found = suggest(planners, {"y_obj": 0.2, "mu": 2.0}, planners.solve({}))
    assert [s.limit for s in found] == ["f_max"]  # q̇_max and f_min change nothing here
    f_max = next(r for r in RELAXATIONS if r.name == "f_max")
    assert 20.0 <= found[0].value <= 20.0 + f_max.resolution  # the first value with p >= 0.5
    assert found[0].result.success_probability >= LIKELY and found[0].p_at_bound > 0.99
    assert "likely with f_max >= " in found[0].text() and found[0].to_json()["limit"] == "f_max"


def test_a_suggestion_quotes_the_p_planned_at_the_value_it_prints():
    """A threshold off the printed grid (20.0137 N, printed to 3 digits): rounding it to the nearest
    printable value (20.0) would quote a p planned at 20.0137+ for a limit where p is 0.34."""
    threshold = 20.0137

    class Steep(FakePlanners):
        def solve(self, env, simulator=None, guess=None):
            self.calls.append(self.problem.f_max)
            return [assess(direct_result(float(1.0 / (1.0 + np.exp(-50.0 * (self.problem.f_max - threshold))))))]

    problem = load_problem(resolve("problems/paper_sim.toml")).with_overrides(f_max=12.0)
    planners = Steep(problem)
    found = suggest(planners, {"y_obj": 0.2, "mu": 2.0}, planners.solve({}))
    s = next(x for x in found if x.limit == "f_max")
    assert f">= {s.value:g} N" in s.text() and s.value == float(f"{s.value:.3g}")  # printed as planned
    assert s.value >= threshold
    again = planners.with_limits(f_max=s.value).solve({})[0]
    assert s.result.success_probability == again.success_probability >= LIKELY
    assert f"p = {again.success_probability:.2f}" in s.text()


def test_printable_values_round_the_way_the_limit_relaxes_and_stay_within_reach():
    from judgeopt.session.suggest import printable

    assert printable(20.0137, +1, 40.0) == 20.1 and printable(20.0137, -1, 0.0) == 20.0
    assert printable(0.45301, +1, 1.0) == 0.454 and printable(0.453, +1, 1.0) == 0.453  # exact stays
    assert printable(7.4349, -1, 5.0) == 7.43 and printable(0.99953, +1, 0.9996) == 0.9996  # not past reach


def test_suggest_says_nothing_when_no_relaxation_helps(monkeypatch):
    problem = load_problem(resolve("problems/paper_sim.toml")).with_overrides(f_max=12.0)
    monkeypatch.setattr(rules_module, "LIKELY", 1.01)  # nothing is ever likely
    planners = FakePlanners(problem)
    assert suggest(planners, {"y_obj": 0.2, "mu": 2.0}, []) == []
    assert len(planners.calls) == len(RELAXATIONS)  # one screen at each bound, no bisection
