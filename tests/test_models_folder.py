"""$JUDGEOPT_MODELS: a folder of your own models looked up before the shipped ones (files.resolve):
the same name there wins, a name only there is found, a name only shipped still is, and without
the variable the shipped models answer. Run from another folder, where the checkout's models/
link is not in reach."""

from __future__ import annotations

import json
import shutil

import pytest

from judgeopt.cli import main
from judgeopt.files import MODELS_ENV, resolve, shipped_models


@pytest.fixture
def mine(tmp_path, monkeypatch):
    own = tmp_path / "my_models"
    own.mkdir()
    for suffix in (".json", ".pt"):
        shutil.copy(shipped_models() / f"judge_default{suffix}", own / f"judge_default{suffix}")
        shutil.copy(shipped_models() / f"judge_default{suffix}", own / f"only_mine{suffix}")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    return own


def test_own_models_come_before_the_shipped_ones(mine, monkeypatch):
    monkeypatch.setenv(MODELS_ENV, str(mine))
    assert resolve("models/judge_default", (".json",)) == mine / "judge_default"
    assert resolve("models/only_mine", (".json",)) == mine / "only_mine"
    assert resolve("models/judge_refined", (".json",)) == shipped_models() / "judge_refined"


def test_without_the_variable_the_shipped_models_answer(mine, monkeypatch):
    monkeypatch.delenv(MODELS_ENV, raising=False)
    assert resolve("models/judge_default", (".json",)) == shipped_models() / "judge_default"
    assert resolve("models/only_mine", (".json",)) != mine / "only_mine"


def test_solve_plans_with_a_judge_found_there(mine, monkeypatch, capsys):
    monkeypatch.setenv(MODELS_ENV, str(mine))
    assert main(["solve", "--judge", "models/only_mine", "--method", "direct", "--no-simulate", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["judge"] == str(mine / "only_mine")
