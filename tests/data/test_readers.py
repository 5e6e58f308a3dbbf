"""The readers' registry: which reader reads a path (folder content, suffix, first bytes, else CSV),
what a folder of recordings lists, and that every reader's flags and options agree."""

from __future__ import annotations

import dataclasses
import shutil

import pytest

from judgeopt.data.importer import ImportSpec, import_demos
from judgeopt.data.readers.base import Flag, Reader
from judgeopt.data.readers.hdf5 import MAGIC
from judgeopt.data.readers.registry import READERS, flags, listed, reader_for
from judgeopt.data.recording import ImportError_
from judgeopt.files import REPO

EXAMPLE_H5 = REPO / "data" / "example_demos_robomimic.hdf5"


def _folders(tmp_path):
    lerobot = tmp_path / "scoops"
    (lerobot / "meta").mkdir(parents=True)
    (lerobot / "meta" / "info.json").write_text("{}")
    bag = tmp_path / "take_1"
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    return lerobot, bag


def test_a_path_goes_to_its_reader_by_content_suffix_or_first_bytes(tmp_path):
    lerobot, bag = _folders(tmp_path)
    (tmp_path / "a.H5").write_bytes(b"")  # by suffix, whatever the case and content
    (tmp_path / "robot.dat").write_bytes(MAGIC + b"\0" * 8)
    (tmp_path / "log.txt").write_text("t,y,f\n")
    expected = {lerobot: "lerobot", bag: "mcap", tmp_path / "a.H5": "hdf5", tmp_path / "b.hdf5": "hdf5",
                tmp_path / "c.mcap": "mcap", tmp_path / "d.csv": "csv", tmp_path / "robot.dat": "hdf5",
                tmp_path / "log.txt": "csv", tmp_path / "missing.dat": "csv"}
    assert {p: reader_for(p).name for p in expected} == expected
    assert reader_for(tmp_path) is None  # a folder of recordings: listed, not read


def test_a_folder_lists_what_a_reader_claims_and_skips_the_rest(tmp_path):
    lerobot, bag = _folders(tmp_path)
    for name in ("a.csv", "b.h5", "c.mcap", "notes.txt", "labels.csv"):
        (tmp_path / name).write_text("")
    (tmp_path / "plain").mkdir()
    assert listed(tmp_path, skip=[tmp_path / "labels.csv"]) == sorted(
        [tmp_path / "a.csv", tmp_path / "b.h5", tmp_path / "c.mcap", lerobot, bag])


def test_an_hdf5_file_without_its_suffix_imports_as_with_it(tmp_path):
    other = shutil.copy(EXAMPLE_H5, tmp_path / "recorded.bin")
    spec = ImportSpec(("y_obj", "mu"))
    a, errors = import_demos([EXAMPLE_H5], spec)
    b, more = import_demos([other], spec)
    assert errors == more == [] and (a.responses == b.responses).all() and a.labels.tolist() == b.labels.tolist()


def test_every_reader_declares_options_its_flags_set_and_each_help_says_its_default():
    spec = ImportSpec(("y_obj", "mu"))
    for r in READERS.values():
        fields = {f.name for f in dataclasses.fields(r.options)}
        assert r.options() == r.configure({}, spec), r.name  # no flag given: the defaults, defined once
        for f in r.flags:
            assert f.option in fields, f"{r.name} {f.spelling} sets {f.option!r}, not a field of {r.options.__name__}"
            assert "default" in f.help.lower(), f"{r.name} {f.spelling}: help gives no default"
    shared = flags()["--success-threshold"]
    assert sorted(r.name for r in shared[1]) == ["hdf5", "lerobot"]


def test_two_readers_may_not_give_one_flag_two_meanings(monkeypatch):
    csv = READERS["csv"]
    clash = Reader("clash", "clash", ".clash file", csv.read, csv.options, suffixes=(".clash",),
                   flags=(Flag("--columns", "columns", help="something else (default: none)", does="differs"),))
    monkeypatch.setitem(READERS, "clash", clash)
    with pytest.raises(ValueError, match="declares --columns unlike reader 'csv'"):
        flags()


def test_options_for_no_reader_or_of_the_wrong_kind_are_refused():
    spec = ImportSpec(("y_obj", "mu"))
    with pytest.raises(ImportError_, match="options for 'parquet': no such reader; the readers are lerobot, mcap"):
        import_demos([EXAMPLE_H5], spec, {"parquet": object()})
    with pytest.raises(ImportError_, match="options for 'hdf5': CsvOptions, not Hdf5Options"):
        import_demos([EXAMPLE_H5], spec, {"hdf5": READERS["csv"].options()})
