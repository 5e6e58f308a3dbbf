"""File formats: one header check for every file, one CSV writer the importer reads back, an
exporter registry the command line reads."""

from __future__ import annotations

import json

import numpy as np
import pytest

from judgeopt.cli import main
from judgeopt.formats.exporters import EXPORTERS, exporter_for
from judgeopt.formats.header import check_header, header
from judgeopt.formats.table_csv import read_table, write_plan_csv, write_records
from judgeopt.tasks import get_task
from judgeopt.trajectory import PlanError


def test_one_header_check_for_every_file():
    assert check_header(header("judgeopt-x", 2), "f", "judgeopt-x", 2) == 2
    assert check_header({"format": "judgeopt-x", "version": 1}, "f", "judgeopt-x", 2) == 1  # the old key
    assert check_header({"format": "judgeopt-x", "format_version": np.int64(1)}, "f", "judgeopt-x", 1) == 1  # HDF5
    with pytest.raises(ValueError, match=r"f: x file format version 3 is newer than this judgeopt reads \(2\); update"):
        check_header(header("judgeopt-x", 3), "f", "judgeopt-x", 2, what="x file")
    with pytest.raises(ValueError, match="not a judgeopt file .format is 'judgeopt-y'"):
        check_header(header("judgeopt-y", 1), "f", "judgeopt-x", 2)
    with pytest.raises(ValueError, match="is not an integer"):
        check_header({"format": "judgeopt-x", "format_version": "2"}, "f", "judgeopt-x", 2)


@pytest.mark.parametrize("path, kind", [("models/calibration_default.json", "calibration"),
                                        ("models/trust_region_default.json", "trust")])
def test_a_newer_file_is_refused_in_one_line(tmp_path, path, kind):
    from judgeopt.files import resolve
    from judgeopt.verdict.calibration import CalibrationError, load_calibration
    from judgeopt.planners.trust_region import TrustRegionError, load_trust_region

    doc = json.loads(resolve(path).read_text())
    doc.pop("version", None)
    doc["format_version"] = 99
    out = tmp_path / "newer.json"
    out.write_text(json.dumps(doc))
    load, error = (load_calibration, CalibrationError) if kind == "calibration" else (load_trust_region, TrustRegionError)
    with pytest.raises(error, match="format version 99 is newer than this judgeopt reads"):
        load(out)
    load(resolve(path))  # the shipped one still loads


def test_a_plan_csv_reads_back_as_the_importer_reads_it(tmp_path):
    task = get_task("scoop")
    rng = np.random.default_rng(0)
    plan = task.plan(task.random_command(rng, {"y_obj": 0.2, "mu": 2.0}))
    path = write_plan_csv(plan, tmp_path / "plan.csv", step=0.01, env={"y_obj": 0.2, "mu": 2.0})
    names, rows = read_table(path)
    assert names == ["t", *task.channel_names, "y_obj", "mu"]
    table = np.array(rows, dtype=float)
    assert len(table) == int(round(plan.horizon * plan.dt / 0.01)) + 1
    np.testing.assert_allclose(table[:: 5, 1:4], plan.values, rtol=1e-8, atol=1e-9)  # the samples, every 5th row
    assert np.all(table[:, 4] == 0.2) and np.all(table[:, 5] == 2.0)


def test_the_exporter_registry_is_what_the_command_line_offers(capsys):
    assert [exporter_for(f"x{e.suffix}").name for e in EXPORTERS.values()] == list(EXPORTERS)
    with pytest.raises(PlanError, match=r"cannot tell the format from the suffix '.txt': name the file .csv or .mcap"):
        exporter_for("plan.txt")
    with pytest.raises(SystemExit):
        main(["export", "--help"])
    assert f"{{{','.join(EXPORTERS)}}}" in capsys.readouterr().out


def test_records_keep_every_column_in_the_order_it_first_appears(tmp_path):
    import csv
    rows = [{"epoch": 1, "val": 0.5}, {"epoch": 2, "val": 0.6, "test": 0.7}]  # a column added later (as --test is)
    write_records(tmp_path / "h.csv", rows)
    with open(tmp_path / "h.csv", newline="") as fh:
        back = list(csv.DictReader(fh))
    assert list(back[0]) == ["epoch", "val", "test"]
    assert back == [{"epoch": "1", "val": "0.5", "test": ""}, {"epoch": "2", "val": "0.6", "test": "0.7"}]
