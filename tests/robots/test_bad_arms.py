"""An arm that cannot do what is asked says so in one line, with the fix: a description the installed
example-robot-data lacks, an arm placed out of reach of the plan's start, positions beyond the segment
of the line it reaches (`judgeopt robots NAME --reach`)."""

from __future__ import annotations

import dataclasses

import pytest

from judgeopt.cli import main
from judgeopt.errors import ExitCode
from judgeopt.robots import get_robot, register_robot, unregister_robot

SOLVE = ["solve", "--qdot-max", "0.4", "--no-simulate", "--method", "direct"]


@pytest.fixture
def arm():
    """Registers a changed Kinova under a new name for one test."""
    names = []

    def register(name: str, **changes):
        register_robot(dataclasses.replace(get_robot("kinova"), name=name, **changes))
        names.append(name)
        return name

    yield register
    for name in names:
        unregister_robot(name)


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def test_a_description_the_installed_package_lacks_names_it_and_the_upgrade(arm, capsys):
    name = arm("ghost", description="ghost_description/urdf/ghost.urdf")
    assert main([*SOLVE, "--robot", name]) == ExitCode.MISSING
    line = _one_line(capsys)
    assert "ghost_description/urdf/ghost.urdf" in line and "pip install -U example-robot-data" in line


def test_an_arm_placed_out_of_reach_of_the_start_is_infeasible_naming_the_fix(arm, capsys):
    name = arm("far", base_xyz=(-1.5, 0.0, 0.0))  # 1.25 m further from the line than the Kinova's 0.9 m reach
    assert main([*SOLVE, "--robot", name]) == ExitCode.INFEASIBLE
    line = _one_line(capsys)
    assert "robot 'far' cannot hold the tool at the start q0 = -0.03 m" in line
    assert "judgeopt robots far --reach" in line and "base_xyz" in line


def test_positions_beyond_the_reached_segment_are_infeasible(capsys):
    """The Kinova reaches y up to about 0.45 m (`judgeopt robots kinova --reach`); 0.7 m it cannot."""
    assert main([*SOLVE, "--robot", "kinova", "--q-max", "0.7"]) == ExitCode.INFEASIBLE
    line = _one_line(capsys)
    assert "robot 'kinova' cannot hold the tool at position" in line and "[q_min, q_max] = [-0.2, 0.7] m" in line
    y = float(line.split("at position ")[1].split(" m")[0])
    assert 0.4 < y <= 0.7  # the first position past its reach, inside the limits asked for


def test_a_mass_correction_for_a_link_the_file_lacks_names_it(arm, capsys):
    from judgeopt.robots.spec import Correction

    name = arm("ghostmass", masses={"ghost_link": Correction(1.0, "test")})
    assert main([*SOLVE, "--robot", name]) == ExitCode.MISSING
    assert _one_line(capsys).endswith("the installed description has no mass for ghost_link")
