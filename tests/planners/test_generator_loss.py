"""The generator's training loss, eq. (4): P (-log y_judge) + Q (limit violations²) + R (terminal
errors²), each term against a hand computation on a plan that violates exactly one limit by a
known amount (and 0 where every limit holds). `generator_loss` is the smallest public function
that computes it; the generator's rollout is replaced by the hand-made plan and the judge by a
constant logit, so every figure below is arithmetic on the plan's own numbers.

Issue 36: a planted bug dropped the penalty below f_min and passed every earlier test (they
checked that the loss falls, and the margin term, never the limit penalties one by one)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
import torch

from conftest import min_jerk_plan
from judgeopt.planners.generator import Generator
from judgeopt.planners.generator_train import generator_loss
from judgeopt.planners.limits import LimitRanges
from judgeopt.planners.problem import Problem

Q, R = 1000.0, 250.0
#: the paper's limits: q in [-0.2, 0.4] m, q̇ in [-0.05, 1] m/s, f in [7.5, 22.5] N; q_end = y_obj, q̇_end = 0.
#: No smoothing, so the loss is L1 + Q limits + R terminal alone
PROBLEM = Problem(Q=Q, R=R, acc_weight=0.0, force_rate_weight=0.0)
ENV = torch.tensor([[0.25, 2.0]])  # y_obj = 0.25 m: where the plan below ends


class ConstantJudge:
    """A judge that reads nothing: logit `z` for every plan (z = 40: -log y = 4e-18)."""

    def __init__(self, z: float = 40.0):
        self.z = z
        self.config = SimpleNamespace(env_names=("y_obj", "mu"))

    def __call__(self, x: torch.Tensor, env: torch.Tensor) -> torch.Tensor:
        return torch.full((x.shape[0],), self.z, dtype=x.dtype)


def held() -> np.ndarray:
    """A min-jerk scoop -0.03 -> 0.25 m in 1.2 s at 12 N, (31, [y, ydot, f]): peak 0.44 m/s, every
    limit held, at rest at y_obj at the end."""
    return min_jerk_plan(-0.03, 0.25, 1.2, 12.0).as_array()


def loss_of(plans: list[np.ndarray], problem: Problem = PROBLEM, judge=None, limits=None, gen=None):
    """generator_loss on these plans (one per environment row), its rollout replaced by them."""
    gen = gen or Generator(problem)
    x = torch.tensor(np.stack(plans), dtype=torch.float64)
    gen.rollout = lambda env, lim=None: x  # noqa: E731 (the instance's own: only this test's generator)
    env = ENV.double().expand(len(plans), -1)
    with torch.no_grad():
        loss, parts = generator_loss(gen, judge or ConstantJudge(), env, limits)
    return loss.item(), parts


def test_a_plan_holding_every_limit_costs_nothing_but_its_judge_term():
    """Every limit held, end met: the limit and terminal terms are 0 and the loss is P softplus(-40)."""
    loss, parts = loss_of([held()])
    assert parts["limits"] == 0.0 and parts["terminal"] == 0.0
    assert loss == pytest.approx(math.log1p(math.exp(-40.0)), abs=1e-20)


#: (case, sample, column, value, squared violation by hand): one sample moved beyond one limit
VIOLATIONS = [
    ("q_max", 10, 0, 0.45, 0.05 ** 2),  # 0.05 m over 0.4
    ("q_min", 5, 0, -0.23, 0.03 ** 2),  # 0.03 m under -0.2
    ("qdot_max", 7, 1, 1.2, 0.2 ** 2),  # 0.2 m/s over 1
    ("qdot_min", 3, 1, -0.15, 0.1 ** 2),  # 0.1 m/s under -0.05
    ("f_min", 12, 2, 7.0, 0.5 ** 2),  # 0.5 N under 7.5
    ("f_max", 20, 2, 25.5, 3.0 ** 2),  # 3 N over 22.5
    ("f_min at sample 0", 0, 2, 5.5, 2.0 ** 2),  # the first force is planned too: 2 N under
    ("f_max at the last sample", 30, 2, 23.5, 1.0 ** 2),
]


@pytest.mark.parametrize("case, k, col, value, expected", VIOLATIONS, ids=[v[0] for v in VIOLATIONS])
def test_each_limit_penalty_is_the_squared_violation_times_Q(case, k, col, value, expected):
    """One sample moved beyond one limit by a known amount: the limits term is that amount
    squared, the loss Q times it (the judge's term is 4e-18), the terminal term 0."""
    x = held()
    x[k, col] = value
    loss, parts = loss_of([x])
    assert parts["limits"] == pytest.approx(expected, rel=1e-9)
    assert parts["terminal"] == 0.0
    assert loss == pytest.approx(Q * expected, rel=1e-9)


def test_two_violations_add_and_the_batch_is_averaged():
    """f 0.5 N under f_min at two samples and q̇ 0.2 m/s over: 0.25 + 0.25 + 0.04 = 0.54 in one plan;
    beside a plan that holds everything, the batch mean is 0.27."""
    x = held()
    x[12, 2] = x[13, 2] = 7.0
    x[7, 1] = 1.2
    assert loss_of([x])[1]["limits"] == pytest.approx(0.54, rel=1e-9)
    loss, parts = loss_of([x, held()])
    assert parts["limits"] == pytest.approx(0.27, rel=1e-9) and loss == pytest.approx(Q * 0.27, rel=1e-9)


def test_the_start_sample_of_position_and_velocity_is_not_penalised():
    """Sample 0 of q and q̇ is the given start, not the generator's to choose: a q_0 beyond q_max or
    a q̇_0 beyond q̇_max costs nothing (the force at sample 0 does: above)."""
    x = held()
    x[0, 0], x[0, 1] = 0.5, 1.5
    assert loss_of([x])[1]["limits"] == 0.0


@pytest.mark.parametrize("dy, dv, expected", [(0.02, 0.0, 0.02 ** 2), (0.0, 0.1, 0.1 ** 2),
                                               (-0.01, -0.03, 0.01 ** 2 + 0.03 ** 2)])
def test_the_terminal_penalty_is_the_squared_end_error_times_R(dy, dv, expected):
    """The end 2 cm past y_obj: 4e-4; at 0.1 m/s instead of rest: 0.01; both (1 cm short, -0.03 m/s):
    their sum. The loss is R times it; no limit is crossed."""
    x = held()
    x[-1, 0] += dy
    x[-1, 1] += dv
    loss, parts = loss_of([x])
    assert parts["limits"] == 0.0
    assert parts["terminal"] == pytest.approx(expected, rel=1e-9)
    assert loss == pytest.approx(R * expected, rel=1e-9)


def test_the_terminal_position_is_the_environments_or_the_problems_number():
    """q_end = y_obj reads each row's environment (0.25 and 0.2: the second plan 5 cm past); q_end =
    0.3 (a number) puts both 5 cm short; q_end free costs nothing for the position."""
    x = held()
    env_rows = torch.tensor([[0.25, 2.0], [0.2, 2.0]], dtype=torch.float64)
    gen = Generator(PROBLEM)
    gen.rollout = lambda env, lim=None: torch.tensor(np.stack([x, x]))  # noqa: E731
    with torch.no_grad():
        _, parts = generator_loss(gen, ConstantJudge(), env_rows)
    assert parts["terminal"] == pytest.approx(0.05 ** 2 / 2, rel=1e-9)
    assert loss_of([x], PROBLEM.with_overrides(q_end=0.3))[1]["terminal"] == pytest.approx(0.05 ** 2, rel=1e-9)
    moved = x.copy()
    moved[-1, 0] = 0.1
    assert loss_of([moved], PROBLEM.with_overrides(q_end="free"))[1]["terminal"] == 0.0


def test_the_judge_term_is_P_times_minus_log_p():
    """A judge at logit 0 (p = 1/2): L1 = P log 2, with P = 3; at logit -2: P log(1 + e²)."""
    pr = PROBLEM.with_overrides(P=3.0)
    loss, parts = loss_of([held()], pr, ConstantJudge(0.0))
    assert parts["L1"] == pytest.approx(3 * math.log(2), rel=1e-12) and loss == pytest.approx(3 * math.log(2))
    assert parts["p_mean"] == pytest.approx(0.5)
    assert loss_of([held()], pr, ConstantJudge(-2.0))[0] == pytest.approx(3 * math.log1p(math.exp(2.0)), rel=1e-12)


def test_the_smoothing_terms_by_hand():
    """acc_weight dt Σ a² + force_rate_weight Σ Δf² / dt on a plan whose q̇ steps 0 -> 0.1 once (a = 2
    m/s²) and whose f steps 12 -> 13 N once: 0.5 * 0.05 * 4 + 0.2 * 1 / 0.05 = 0.1 + 4."""
    x = np.zeros((31, 3))
    x[:, 0] = 0.25
    x[:, 2] = 12.0
    x[1:, 1] = 0.0
    x[5, 1] = 0.1  # up at sample 5 and down at sample 6: a = +2 and -2 m/s²
    x[20:, 2] = 13.0
    pr = PROBLEM.with_overrides(acc_weight=0.5, force_rate_weight=0.2)
    # q̇_5 = 0.1 is inside the limits, the end is at rest at y_obj: only smoothing
    loss, parts = loss_of([x], pr)
    assert parts["limits"] == 0.0 and parts["terminal"] == 0.0
    assert loss == pytest.approx(0.5 * 0.05 * (4 + 4) + 0.2 * 1.0 / 0.05, rel=1e-9)


@pytest.mark.parametrize("which, col, value, expected", [
    ("qdot_max", 1, 0.5, (0.5 - 0.3) ** 2),  # first plan's q̇_max 0.3
    ("f_min", 2, 8.0, (9.0 - 8.0) ** 2),  # first plan's f_min 9: 8 N is 1 under (and 0.5 over the problem's 7.5)
    ("f_max", 2, 17.0, (17.0 - 16.0) ** 2),  # first plan's f_max 16
])
def test_a_conditioned_generator_penalises_each_plan_against_its_own_limits(which, col, value, expected):
    """Per-plan limits [q̇_max, f_min, f_max] = [0.3, 9, 16] and [1, 5, 25]: the same violation in both
    plans costs its amount against the first plan's limits and nothing against the second's; the
    held plan's 12 N and peak 0.44 m/s: the first plan's 0.44 > 0.3 is part of its cost too, so
    the base plan is flattened to 0.25 m/s here."""
    x = held()
    # q̇ under both plans' q̇_max (the positions are not re-integrated: no term reads the model)
    x[:, 1] = np.minimum(x[:, 1], 0.25)
    x[10, col] = value
    lim = torch.tensor([[0.3, 9.0, 16.0], [1.0, 5.0, 25.0]], dtype=torch.float64)
    gen = Generator(PROBLEM, conditioned=LimitRanges())
    _, parts = loss_of([x, x], limits=lim, gen=gen)
    assert parts["limits"] == pytest.approx(expected / 2, rel=1e-6)  # the limits are held in float32


@pytest.mark.parametrize("y_obj, end_margin, expected", [
    (0.25, 0.03, 0.03 ** 2),  # the plan ends at y_obj: 3 cm short of y_obj + 3 cm
    (0.25, 0.0, 0.0),
    (0.39, 0.03, (0.4 - 0.25) ** 2),  # y_obj + 3 cm = 0.42 is past q_max: the target is q_max, 0.15 m away
])
def test_the_end_margin_moves_the_terminal_target_past_the_environments_end(y_obj, end_margin, expected):
    """The problem's end_margin m past y_obj (capped at q_max = 0.4): the terminal term is the squared
    distance of the plan's end (0.25 m, at rest) to that target, by hand."""
    gen = Generator(PROBLEM.with_overrides(end_margin=end_margin))
    x = torch.tensor(held()[None])
    gen.rollout = lambda env, lim=None: x  # noqa: E731
    with torch.no_grad():
        _, parts = generator_loss(gen, ConstantJudge(), torch.tensor([[y_obj, 2.0]], dtype=torch.float64))
    assert parts["terminal"] == pytest.approx(expected, rel=1e-9, abs=1e-15)
    assert parts["limits"] == 0.0
