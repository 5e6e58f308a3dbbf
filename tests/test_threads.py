"""Torch threads: one count for every command (judgeopt.threads), refused in one line when it is not one."""

from __future__ import annotations

import pytest
import torch

from judgeopt.threads import DEFAULT_THREADS, check_threads, torch_threads


@pytest.mark.parametrize("bad", [0, -2, 1.5, "2", True, None])
def test_a_thread_count_is_a_whole_number_of_at_least_one(bad):
    with pytest.raises(ValueError, match="whole number >= 1"):
        check_threads(bad)


def test_the_block_runs_on_its_count_and_the_callers_setting_comes_back():
    before = torch.get_num_threads()
    other = 2 if before == 1 else 1
    with torch_threads(other):
        assert torch.get_num_threads() == other
    assert torch.get_num_threads() == before
    with pytest.raises(RuntimeError):
        with torch_threads(other):
            raise RuntimeError("inside")
    assert torch.get_num_threads() == before  # restored on the way out of an error too
    with torch_threads(None):
        assert torch.get_num_threads() == before


@pytest.mark.parametrize("value", ["0", "-1", "1.5", "x"])
@pytest.mark.parametrize("command", ["solve", "evaluate", "collect", "refine", "train-judge", "train-generator"])
def test_a_bad_threads_option_is_one_line_on_every_command_that_runs_torch(command, value, capsys):
    from judgeopt.cli.main import main

    with pytest.raises(SystemExit) as exc:
        main([command, "--threads", value])
    assert exc.value.code == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "--threads" in lines[0] and "positive integer" in lines[0], lines


def test_every_command_that_runs_torch_takes_threads_and_defaults_to_one():
    from judgeopt.cli.main import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    for name in ("solve", "evaluate", "collect", "refine", "train-judge", "test-judge", "train-generator",
                 "train-ensemble"):
        opts = {o: a for a in sub.choices[name]._actions for o in a.option_strings}
        assert "--threads" in opts, name
        assert opts["--threads"].default == DEFAULT_THREADS == 1, name
