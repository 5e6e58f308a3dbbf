"""Problem files: `base` lookup, the paper's Table 8, and the simulated world's values the planners do not read."""

from __future__ import annotations

import shutil

import pytest

from judgeopt.files import REPO
from judgeopt.planners.problem import Problem, ProblemError, ProblemFileError, load_problem
from judgeopt.tasks import get_task

PROBLEMS = REPO / "judgeopt" / "tasks" / "scoop" / "problems"


def test_paper_real_is_table_8():
    real = load_problem(PROBLEMS / "paper_real.toml")
    assert (real.q0, real.qdot0, real.q_min, real.q_max, real.qdot_min, real.f_min, real.f_max) == \
        (-0.1, 0.0, -0.2, 0.4, -0.05, 1.0, 10.0)
    assert (real.q_end, real.qdot_end, real.environment) == ("y_obj", 0.0, {"y_obj": 0.246})


def test_the_simulated_world_has_what_the_judge_does_not_read():
    real = load_problem(PROBLEMS / "paper_real.toml")
    lab = get_task("scoop").env_defaults()["mu"]
    assert lab == 0.5  # the simulated lab's friction, measured (docs/physics.md)
    assert real.world_env({"y_obj": 0.246}) == {"y_obj": 0.246, "mu": lab}
    set_by_name = real.with_overrides(mu=2)
    assert set_by_name.environment == {"y_obj": 0.246} and set_by_name.world == {"mu": 2.0}
    assert set_by_name.world_env({"y_obj": 0.2}) == {"y_obj": 0.2, "mu": 2.0}
    assert set_by_name.limits_key() == real.limits_key()  # a generator for the limits still fits
    with pytest.raises(ProblemError, match="simulated world's one value"):
        real.with_overrides(mu="1,2")
    with pytest.raises(ProblemError, match="unknown problem field 'x_obj'"):
        real.with_overrides(x_obj=0.1)


def test_world_section_in_a_file(tmp_path):
    (tmp_path / "lab.toml").write_text('base = "problems/paper_real.toml"\n[world]\nmu = 1\n')
    lab = load_problem(tmp_path / "lab.toml")
    assert lab.world == {"mu": 1.0} and lab.world_env({"y_obj": 0.246})["mu"] == 1.0
    assert lab.to_dict()["world"] == {"mu": 1.0} and "world" not in load_problem(PROBLEMS / "paper_sim.toml").to_dict()
    (tmp_path / "planned.toml").write_text('base = "lab.toml"\n[environment]\ny_obj = 0.2\nmu = [1.0, 2.0]\n')
    assert load_problem(tmp_path / "planned.toml").world == {}  # planned for now: the base's world value gives way
    (tmp_path / "both.toml").write_text('base = "lab.toml"\n[environment]\ny_obj = 0.2\nmu = 2.0\n[world]\nmu = 1.0\n')
    with pytest.raises(ProblemFileError, match="both"):
        load_problem(tmp_path / "both.toml")


@pytest.mark.parametrize("base", ["problems/paper_real.toml", "paper_real.toml"])
def test_base_is_found_as_the_command_line_finds_a_name(tmp_path, base):
    (tmp_path / "mine.toml").write_text(f'base = "{base}"\n[limits]\nqdot_max = 0.4\n')
    mine = load_problem(tmp_path / "mine.toml")
    assert (mine.q0, mine.f_max, mine.qdot_max, mine.environment) == (-0.1, 10.0, 0.4, {"y_obj": 0.246})


def test_a_copied_shipped_file_keeps_its_base(tmp_path):
    shutil.copy(PROBLEMS / "paper_real.toml", tmp_path / "copy.toml")
    assert load_problem(tmp_path / "copy.toml").limits_key() == load_problem(PROBLEMS / "paper_real.toml").limits_key()


def test_a_base_next_to_the_file_comes_first(tmp_path):
    (tmp_path / "paper_sim.toml").write_text('[limits]\nqdot_max = 0.7\n[environment]\ny_obj = 0.2\nmu = 1.0\n')
    (tmp_path / "mine.toml").write_text('base = "paper_sim.toml"\n')
    assert load_problem(tmp_path / "mine.toml").qdot_max == 0.7
    (tmp_path / "lost.toml").write_text('base = "nowhere.toml"\n')
    with pytest.raises(ProblemFileError, match="base = 'nowhere.toml' not found"):
        load_problem(tmp_path / "lost.toml")


def test_the_problem_is_in_parts_and_every_field_is_read_and_set_by_name():
    from judgeopt.planners.problem import GeneratorWeights, Motion, ModelRefs, SolverOptions

    p = Problem(qdot_max=0.4, p_target=0.9, Q=10.0, judge="models/judge_demos_tcn")
    assert (type(p.motion), type(p.solver), type(p.generator), type(p.models)) == (Motion, SolverOptions,
                                                                                   GeneratorWeights, ModelRefs)
    assert (p.motion.qdot_max, p.solver.p_target, p.generator.Q, p.models.judge) == (0.4, 0.9, 10.0, "models/judge_demos_tcn")
    assert (p.qdot_max, p.p_target, p.Q, p.judge) == (0.4, 0.9, 10.0, "models/judge_demos_tcn")
    q = p.with_overrides(tol=1e-4, f_min=5.0)
    assert (q.solver.tol, q.motion.f_min, q.motion.qdot_max, p.solver.tol) == (1e-4, 5.0, 0.4, 1e-6)
    # the flat record plan files, generator files and setting ids have always held: same keys, same order
    assert list(Problem().to_dict()) == [
        "name", "description", "task", "steps", "dt", "q0", "qdot0", "q_min", "q_max", "qdot_min", "qdot_max", "f_min",
        "f_max", "q_end", "qdot_end", "environment", "P", "Q", "R", "acc_weight", "force_rate_weight", "objective",
        "p_target", "p_min", "max_iter", "tol", "replan_period", "replan_trigger", "judge", "ensemble", "pessimism",
        "trust_region", "trust_model", "calibration", "source"]
    assert Problem.from_dict(q.to_dict()) == q
    with pytest.raises(TypeError, match="unknown problem field"):
        Problem(qdotmax=0.4)


def test_a_field_in_its_old_section_still_reads_with_a_note_and_one_in_a_wrong_one_is_refused(tmp_path):
    from judgeopt.planners.problem import ProblemDeprecation

    old = tmp_path / "old.toml"
    old.write_text('base = "paper_sim.toml"\n[weights]\nQ = 500.0\nacc_weight = 2e-3\n')
    with pytest.warns(ProblemDeprecation, match=r"\[weights\] Q is read from its old place; move it to \[generator\]"):
        p = load_problem(old)
    assert (p.generator.Q, p.motion.acc_weight) == (500.0, 2e-3)
    wrong = tmp_path / "wrong.toml"
    wrong.write_text('base = "paper_sim.toml"\n[solver]\njudge = "models/judge_demos_tcn"\n')
    with pytest.raises(ProblemError, match=r"judge belongs in \[models\], not \[solver\]: move it there"):
        load_problem(wrong)
