"""The end margin (issue 36, part 5): a plan ends `end_margin` past the environment variable its
end names, within q_max. The problem's terminal position and the generator's terminal term by
hand (as test_generator_loss.py does), and the one-line errors."""

from __future__ import annotations

import pytest
import torch

from conftest import min_jerk_plan
from judgeopt.planners.generator import Generator
from judgeopt.planners.generator_train import generator_loss
from judgeopt.planners.problem import Problem, ProblemError
from test_generator_loss import ConstantJudge

PROBLEM = Problem(Q=1000.0, R=250.0, acc_weight=0.0, force_rate_weight=0.0)


def terminal(end: float, y_obj: float, end_margin: float) -> float:
    """generator_loss's terminal part for a min-jerk plan at rest at `end` (within every limit)."""
    gen = Generator(PROBLEM.with_overrides(end_margin=end_margin))
    x = torch.tensor(min_jerk_plan(-0.03, end, 1.2, 12.0).as_array()[None], dtype=torch.float64)
    gen.rollout = lambda env, lim=None: x  # noqa: E731
    with torch.no_grad():
        _, parts = generator_loss(gen, ConstantJudge(), torch.tensor([[y_obj, 2.0]], dtype=torch.float64))
    return parts["terminal"]


def test_without_a_margin_the_end_is_the_object():
    assert terminal(0.25, 0.25, 0.0) == pytest.approx(0.0, abs=1e-20)
    assert terminal(0.30, 0.25, 0.0) == pytest.approx(0.05 ** 2)


def test_a_margin_moves_the_end_past_the_object():
    assert terminal(0.30, 0.25, 0.05) == pytest.approx(0.0, abs=1e-20)
    assert terminal(0.25, 0.25, 0.05) == pytest.approx(0.05 ** 2)


def test_the_margined_end_stays_within_q_max():
    """y_obj 0.38 + 0.05 would be 0.43, past q_max = 0.4: the end asked for is 0.4."""
    assert terminal(0.40, 0.38, 0.05) == pytest.approx(0.0, abs=1e-20)


def test_the_problem_ends_past_the_object_within_q_max():
    p = PROBLEM.with_overrides(end_margin=0.1)
    assert p.terminal_positions({"y_obj": 0.2, "mu": 2.0})[0] == pytest.approx(0.3)
    assert p.terminal_positions({"y_obj": 0.35, "mu": 2.0})[0] == pytest.approx(0.4)  # q_max
    assert PROBLEM.terminal_positions({"y_obj": 0.2, "mu": 2.0})[0] == pytest.approx(0.2)


def test_a_margin_is_part_of_what_a_generator_is_trained_for_and_absent_otherwise():
    """Records and setting ids of problems without a margin read as before; a generator trained
    without one is not chosen for a problem with one (limits_key differs)."""
    assert "end_margin" not in PROBLEM.to_dict() and "end_margin" not in PROBLEM.limits_key()
    p = PROBLEM.with_overrides(end_margin=0.1)
    assert p.to_dict()["end_margin"] == 0.1 and p.limits_key()["end_margin"] == 0.1


@pytest.mark.parametrize("overrides, words", [
    ({"end_margin": -0.01}, ">= 0"),
    ({"end_margin": 0.1, "q_end": 0.3}, "numeric q_end"),
    ({"end_margin": 0.1, "q_end": "free"}, "numeric q_end"),
])
def test_a_margin_without_an_environment_end_or_below_zero_is_refused_in_one_line(overrides, words):
    with pytest.raises(ProblemError, match=words) as exc:
        PROBLEM.with_overrides(**overrides)
    assert "\n" not in str(exc.value)


class LinearJudge(torch.nn.Module):
    """A judge with a gradient and no parameters to train: logit 40 - |y_N - 0.3| (any plan is fine)."""

    config = ConstantJudge().config

    def forward(self, x: torch.Tensor, env: torch.Tensor) -> torch.Tensor:
        return 40.0 - (x[:, -1, 0] - 0.3).abs()


def test_fine_tuning_takes_the_new_problems_end_margin():
    """A generator trained without a margin, fine-tuned for a problem with one, plans (and is
    saved) for the margin: its problem's end is 0.1 past y_obj, its loss's terminal target too."""
    from judgeopt.planners.generator_train import GeneratorTrainConfig, train_generator

    init = Generator(PROBLEM)
    gen, _ = train_generator(PROBLEM.with_overrides(end_margin=0.1), LinearJudge(),
                             tc=GeneratorTrainConfig(epochs=1, batch=2, progress=False, threads=1), init=init)
    assert gen.problem.end_margin == 0.1 and init.problem.end_margin == 0.0
    assert gen.problem.terminal_positions({"y_obj": 0.2, "mu": 2.0})[0] == pytest.approx(0.3)


def test_the_margin_never_hides_an_end_beyond_q_max():
    """An object told beyond q_max stays beyond it (feasible.check reports it); the margin only
    stops at q_max."""
    p = PROBLEM.with_overrides(end_margin=0.1)
    assert p.terminal_positions({"y_obj": 0.5, "mu": 2.0})[0] == pytest.approx(0.5)
    assert terminal(0.40, 0.5, 0.1) == pytest.approx(0.1 ** 2)  # the generator's target is y_obj itself
