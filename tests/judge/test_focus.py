"""Active collection (`collect --focus`): demonstrations kept where a judge is unsure."""

import json

import numpy as np
import pytest

from judgeopt.data.collect import CollectionSpec, collect
from judgeopt.judge.errors import JudgeError
from judgeopt.judge.focus import JudgeFocus
from judgeopt.judge.store import IncompatibleJudgeError, load_judge

JUDGE = "models/judge_demos_tcn"
BAND = (0.3, 0.7)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("focus")
    plain = collect(CollectionSpec(seed=11, n=5), folder / "plain.h5", n_jobs=1, progress=False)
    focus = JudgeFocus.of(JUDGE, band=BAND, tries=30)
    focused = collect(CollectionSpec(seed=11, n=5, focus=focus), folder / "focused.h5", n_jobs=1, progress=False)
    return plain, focused


def _p(commands, env):
    judge = load_judge(JUDGE)[0]
    return judge.predict_proba(commands, env)


def test_kept_commands_are_the_ones_the_judge_is_unsure_about(files):
    plain, focused = files
    p = _p(focused.commands, focused.env)  # the judge, called here apart from the collection
    assert focused.meta["focus"]["misses"] == int((~((BAND[0] < p) & (p < BAND[1]))).sum())
    assert focused.meta["focus"]["misses"] == 0 and focused.n == 5
    # a demonstration whose unfocused draw was already unsure keeps it; the others were redrawn
    p_plain = _p(plain.commands, plain.env)
    unsure = (BAND[0] < p_plain) & (p_plain < BAND[1])
    assert not unsure.all()  # else this test would not see a redraw
    for i in range(5):
        same = np.array_equal(focused.commands[i], plain.commands[i])
        assert same == bool(unsure[i])
    assert "not a sample" in focused.meta["focus"]["note"]


def test_out_of_tries_keeps_the_last_candidate_and_counts_it(files, tmp_path):
    plain, _ = files
    never = JudgeFocus.of(JUDGE, band=(0.5, 0.5 + 1e-12), tries=1)  # one candidate: the unfocused draw
    ds = collect(CollectionSpec(seed=11, n=5, focus=never), tmp_path / "never.h5", n_jobs=1, progress=False)
    assert np.array_equal(ds.commands, plain.commands) and np.array_equal(ds.labels, plain.labels)
    assert ds.meta["focus"]["misses"] == 5


def test_an_unfocused_collection_keeps_its_resume_fingerprint():
    # unfinished collections started before --focus existed must still resume
    assert "focus" not in json.loads(CollectionSpec(seed=11, n=5).fingerprint())


def test_bad_focus_settings_are_one_line_errors(tmp_path):
    with pytest.raises(JudgeError, match="0 <= LO < HI <= 1"):
        JudgeFocus.of(JUDGE, band=(0.9, 0.1))
    with pytest.raises(IncompatibleJudgeError, match="horizon N = 20"):
        JudgeFocus.of(JUDGE, horizon=20)
    with pytest.raises(JudgeError, match="no such model"):
        JudgeFocus.of(str(tmp_path / "nosuch"))


def test_scoring_a_judge_on_focused_data_says_it_is_not_the_task_accuracy(files, tmp_path, capsys):
    from judgeopt.cli import main
    from judgeopt.data.dataset import save

    save(files[1], tmp_path / "focused.h5")
    assert main(["test-judge", "--judge", JUDGE, "--data", str(tmp_path / "focused.h5")]) == 0
    assert "not the judge's accuracy on the task" in capsys.readouterr().err


def test_a_focused_collection_is_the_same_in_worker_processes(files, tmp_path):
    # workers load the judge themselves (the focus pickles as its path and weights hash)
    focus = JudgeFocus.of(JUDGE, band=BAND, tries=30)
    par = collect(CollectionSpec(seed=11, n=5, focus=focus), tmp_path / "par.h5", n_jobs=2, chunk_size=2,
                  progress=False)
    assert np.array_equal(par.commands, files[1].commands) and np.array_equal(par.labels, files[1].labels)
