"""A recording lacking a column is told which one, whatever other columns it has (a `demo_id` and a
`label` do not make it a labels file), and where the header has the column under a similar name
(`force`, `fz_N`, `time`, `F`), the fix maps it; following that fix imports the file. Only a file
that looks like a labels file (a recording and an outcome column, no time stamps, no channel) is
called one."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.data.dataset import load
from judgeopt.data.importer import ImportSpec, import_demos
from judgeopt.data.readers.csv import CsvOptions
from judgeopt.files import REPO

EXAMPLE_CSV = REPO / "data" / "example_demos.csv"  # demo_id,t,y,ydot,f,label,y_obj,mu
LABELS_FILE = "a labels file, not a recording; pass it with --labels {path}"


def _csv(path: Path, header: str) -> Path:
    path.write_text(header + "\n" + ",".join("1" for _ in header.split(",")) + "\n")
    return path


@pytest.mark.parametrize("header, fix", [
    # the case: demo_id and label beside the samples, f missing
    ("demo_id,t,y,label", "missing column(s) ['f']; the header has ['demo_id', 't', 'y', 'label']; map it with "
                          "--columns f=COLUMN"),
    ("demo_id,t,y,force,label", "missing column(s) ['f']; the header has ['demo_id', 't', 'y', 'force', 'label']; "
                                "map it with --columns f=force"),
    ("demo_id,time,y,fz_N,outcome", "missing column(s) ['t', 'f', 'label']; the header has ['demo_id', 'time', 'y', "
                                    "'fz_N', 'outcome']; map them with --columns t=time,f=fz_N,label=outcome"),
    ("demo_id,t,y,F,label", "missing column(s) ['f']; the header has ['demo_id', 't', 'y', 'F', 'label']; map it "
                            "with --columns f=F"),
    ("demo_id,y,f,label", "missing column(s) ['t']; the header has ['demo_id', 'y', 'f', 'label']; map it with "
                          "--columns t=COLUMN"),
    # two columns alike: no guess
    ("t,y,fx,fz,label", "missing column(s) ['f']; the header has ['t', 'y', 'fx', 'fz', 'label']; map it with "
                        "--columns f=COLUMN"),
    # what is a labels file
    ("demo_id,label", LABELS_FILE),
    ("File,Outcome,notes", LABELS_FILE),
])
def test_the_missing_column_is_named_whatever_else_the_header_has(tmp_path, header, fix):
    path = _csv(tmp_path / "rec.csv", header)
    _, errors = import_demos([path], ImportSpec(()))
    assert errors == [f"{path}: {fix.format(path=path)}"]


def test_a_column_already_mapped_is_not_suggested_again(tmp_path):
    path = _csv(tmp_path / "rec.csv", "demo_id,time,y,force,label")
    _, errors = import_demos([path], ImportSpec(()), {"csv": CsvOptions({"t": "time"})})
    assert errors == [f"{path}: missing column(s) ['f']; the header has ['demo_id', 'time', 'y', 'force', 'label']; "
                      "map it with --columns f=force"]


def test_the_fix_suggested_on_the_command_line_imports_the_file(tmp_path, capsys):
    """The example recordings with their force column named `force`: one line naming f and the fix;
    running the fix gives the dataset the original gives."""
    lines = EXAMPLE_CSV.read_text().splitlines()
    assert lines[0] == "demo_id,t,y,ydot,f,label,y_obj,mu"
    renamed = tmp_path / "renamed.csv"
    renamed.write_text("\n".join(["demo_id,t,y,ydot,force,label,y_obj,mu", *lines[1:]]) + "\n")
    assert main(["import-demos", str(renamed), "--out", str(tmp_path / "x.h5")]) == 5
    err = capsys.readouterr().err.strip()
    assert err == (f"judgeopt import-demos: error: nothing imported: {renamed}: missing column(s) ['f']; the header "
                   "has ['demo_id', 't', 'y', 'ydot', 'force', 'label', 'y_obj', 'mu']; map it with --columns f=force")
    assert "labels file" not in err and not (tmp_path / "x.h5").exists()
    assert main(["import-demos", str(renamed), "--columns", "f=force", "--out", str(tmp_path / "fixed.h5")]) == 0
    assert main(["import-demos", str(EXAMPLE_CSV), "--out", str(tmp_path / "original.h5")]) == 0
    fixed, original = load(tmp_path / "fixed.h5"), load(tmp_path / "original.h5")
    assert fixed.n == original.n > 0
    np.testing.assert_array_equal(fixed.responses, original.responses)
    np.testing.assert_array_equal(fixed.labels, original.labels)
