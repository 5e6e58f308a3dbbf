"""Reading an evaluation's saved rows back: every chunk once, in order, and a damaged chunk named."""

import json

import pytest

from judgeopt.evaluate.stored import StoredRowsError, chunk_files, read_rows
from judgeopt.parallel import run_json_chunks


def _write(folder, name, rows):
    (folder / "partial").mkdir(parents=True, exist_ok=True)
    (folder / "partial" / name).write_text(json.dumps(rows))


def test_rows_of_several_folders_come_back_each_once_in_chunk_order(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    _write(a, "00010.json", [{"i": 2}])
    _write(a, "00000.json", [{"i": 0}, {"i": 1}])
    _write(b, "00000.json", [{"i": 3}])
    assert [r["i"] for r in read_rows([a, str(b)])] == [0, 1, 2, 3]
    assert [r["i"] for r in read_rows(a)] == [0, 1, 2]  # one folder, given alone


@pytest.mark.parametrize("text, words", [("[{\"i\": 0}", "unreadable"), ("{\"i\": 0}", "not a list of plan rows"),
                                         ("[1, 2]", "not a list of plan rows")])
def test_a_damaged_chunk_is_named_with_the_fix(tmp_path, text, words):
    _write(tmp_path, "00000.json", [{"i": 0}])
    (tmp_path / "partial" / "00005.json").write_text(text)
    with pytest.raises(StoredRowsError, match=words) as err:
        read_rows(tmp_path)
    assert "00005.json" in str(err.value) and "rerun the evaluation" in str(err.value)


def test_a_folder_without_rows_is_an_error_not_an_empty_list(tmp_path):
    (tmp_path / "partial").mkdir()
    with pytest.raises(StoredRowsError, match="no evaluated plans"):
        read_rows([tmp_path])
    assert chunk_files(tmp_path / "missing") == []


def _square(x):
    return [x * x]


def test_a_resumed_run_redoes_a_damaged_chunk_and_keeps_the_good_ones(tmp_path, capsys):
    paths = [tmp_path / f"{i}.json" for i in range(3)]
    paths[0].write_text(json.dumps(["kept"]))  # not what _square would give: proves it was read, not redone
    paths[1].write_text("[4")  # a damaged chunk
    out = run_json_chunks([(p, _square, (i,)) for i, p in enumerate(paths)], n_jobs=1, progress=False)
    assert out == [["kept"], [1], [4]]
    assert json.loads(paths[1].read_text()) == [1]
    assert "1.json is unreadable" in capsys.readouterr().out


def test_a_run_refuses_a_folder_holding_another_runs_chunks(tmp_path):
    from judgeopt.errors import OutputExists
    from judgeopt.evaluate.stored import refuse_other_runs

    ours = [tmp_path / "partial" / f"band__{k:05d}_c5_s1.json" for k in (0, 5)]
    _write(tmp_path, ours[0].name, [{"i": 0}])
    refuse_other_runs(ours)  # its own chunk: a resume
    _write(tmp_path, "band__00000_c10_s1.json", [{"i": 0}])  # the same settings, chunked otherwise
    with pytest.raises(OutputExists, match=r"1 chunks of another run \(band__00000_c10_s1.json\).*another --out"):
        refuse_other_runs(ours)
