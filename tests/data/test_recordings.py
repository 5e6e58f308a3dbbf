"""Long recordings cropped and aligned, robomimic filter keys, dense-reward and done-flag labels,
and a dataset exported to CSV and imported back unchanged."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from judgeopt.data.export import export_csv
from judgeopt.data.importer import ImportError_, ImportSpec, import_demos
from judgeopt.data.readers.hdf5 import Hdf5Options
from judgeopt.files import REPO

ENV = ("y_obj", "mu")
EXAMPLE_CSV = REPO / "data" / "example_demos.csv"
EXAMPLE_H5 = REPO / "data" / "example_demos_robomimic.hdf5"
TK = np.arange(31) * 0.05


def _y(t: np.ndarray) -> np.ndarray:
    return 0.05 * np.sin(t) + 0.01 * t


def _long(path: Path, seconds: float = 3.0, contact_at: float = 1.3, nan_at: float | None = None,
          stop: float | None = None) -> Path:
    """A 100 Hz recording longer than N·dt: no force before `contact_at`, 10 N after; the tool
    moves throughout, or until `stop` s and then rests."""
    t = np.round(np.arange(0, seconds + 1e-9, 0.01), 6)
    f = np.where(t >= contact_at, 10.0, 0.2)
    rows = ["t,y,f,label,y_obj,mu"]
    for ti, yi, fi in zip(t, _y(t if stop is None else np.minimum(t, stop)), f):
        y = "nan" if nan_at is not None and abs(ti - nan_at) < 1e-9 else repr(float(yi))
        rows.append(f"{float(ti)!r},{y},{float(fi)!r},success,0.2,1.5")
    path.write_text("\n".join(rows) + "\n")
    return path


def test_a_long_recording_is_refused_with_the_flags_that_fix_it(tmp_path):
    path = _long(tmp_path / "long.csv")
    ds, errors = import_demos([path], ImportSpec(ENV))
    assert ds is None and errors == [
        f"{path}: demonstration 'long' lasts 3 s, longer than the horizon N·dt = 1.5 s; crop it with --start/--end S, "
        "start at the motion with --align onset (or contact), keep the first 1.5 s with --fit crop, or fit the motion "
        "to it with --fit resample"]


def test_start_and_end_crop_and_resample_from_the_window(tmp_path):
    path = _long(tmp_path / "long.csv", nan_at=2.5)  # a NaN outside the window does not matter
    ds, errors = import_demos([path], ImportSpec(ENV, start=1.0, end=2.2))
    assert errors == []
    x = ds.responses[0]
    inside = TK <= 1.2 + 1e-9
    np.testing.assert_allclose(x[inside, 0], _y(1.0 + TK[inside]), atol=1e-7)
    np.testing.assert_allclose(x[inside, 1], 0.05 * np.cos(1.0 + TK[inside]) + 0.01, atol=1e-4)
    np.testing.assert_allclose(x[~inside, 0], _y(2.2), atol=1e-7)  # held at rest after --end
    assert (x[~inside, 1] == 0).all()
    _, errors = import_demos([path], ImportSpec(ENV, start=1.2, end=2.6))  # a NaN inside does
    assert errors[0].startswith(f"{path}, row 252, column 'y': 'nan' is not finite")
    _, errors = import_demos([path], ImportSpec(ENV, start=4.0))
    assert errors == [f"{path}: demonstration 'long' lasts 3 s: nothing left after --start 4 s"]


def test_contact_alignment_with_pre_roll_and_crop_to_horizon(tmp_path):
    path = _long(tmp_path / "long.csv", stop=2.5)
    spec = ImportSpec(ENV, align="contact", contact_force=1.0, lead=0.1)
    _, errors = import_demos([path], spec)  # 1.2 s .. 3 s is still 1.8 s
    assert "(1.8 s kept from 1.2 s to 3 s), longer than the horizon" in errors[0]
    ds, errors = import_demos([path], ImportSpec(ENV, align="contact", lead=0.1, fit="crop"))
    assert errors == []
    x = ds.responses[0]
    early = TK <= 1.2  # before the tool stops at 2.5 s
    np.testing.assert_allclose(x[early, 0], _y(1.2 + TK[early]), atol=1e-7)  # from 0.1 s before the force rises
    assert x[1, 2] == pytest.approx(0.2) and (x[2:, 2] == 10.0).all()
    ds, _ = import_demos([path], ImportSpec(ENV, align="contact", lead=5.0, start=0.5, end=1.8))
    np.testing.assert_allclose(ds.responses[0, 0, 0], _y(0.5), atol=1e-9)  # the pre-roll stops at --start
    _, errors = import_demos([path], ImportSpec(ENV, align="contact", contact_force=20.0, fit="crop"))
    assert errors == [f"{path}, row 132, column 'f': no contact onset for --align contact: the largest force between "
                      "0 s and 3 s is 10 N, not above --contact-force 20 N"]


@pytest.mark.parametrize("kw, message", [
    ({"align": "motion"}, "--align 'motion': choose one of start, contact, onset"),
    ({"fit": "stretch"}, "--fit 'stretch': choose one of refuse, crop, resample"),
    ({"start": 1.0, "end": 0.5}, "--end 0.5 s must be after --start 1 s"),
    ({"start": -1.0}, "--start -1 s: must be 0 or later"),
    ({"contact_force": 0.0}, "--contact-force 0 N must be positive"),
])
def test_bad_windows_are_refused(kw, message):
    with pytest.raises(ImportError_, match=message):
        ImportSpec(ENV, **kw)


def _example(tmp_path: Path) -> Path:
    return Path(shutil.copy(EXAMPLE_H5, tmp_path / "demos.hdf5"))


def test_filter_keys_pick_demo_groups(tmp_path):
    path = _example(tmp_path)
    with h5py.File(path, "a") as h:
        h["mask/train"] = np.array([b"demo_0", b"demo_2"])
        h["mask/valid"] = np.array([b"demo_1", b"demo_9"])
    ds, errors = import_demos([path], ImportSpec(ENV), {"hdf5": Hdf5Options(filter_key="train")})
    assert errors == [] and ds.meta["demo_ids"] == ["demos.hdf5:demo_0", "demos.hdf5:demo_2"]
    ds, errors = import_demos([path], ImportSpec(ENV), {"hdf5": Hdf5Options(filter_key="valid")})
    assert ds.meta["demo_ids"] == ["demos.hdf5:demo_1"]
    assert errors == [f"{path}, mask/valid: lists demo group 'demo_9', which is not in 'data'"]
    ds, errors = import_demos([path], ImportSpec(ENV), {"hdf5": Hdf5Options(filter_key="test")})
    assert ds is None and errors == [f"{path}: no filter key 'test' (mask/test); the file has ['train', 'valid']"]
    _, errors = import_demos([EXAMPLE_H5], ImportSpec(ENV), {"hdf5": Hdf5Options(filter_key="train")})
    assert errors == [f"{EXAMPLE_H5}: no filter key 'train' (mask/train); the file has no 'mask' group"]


def test_dense_rewards_with_a_threshold(tmp_path):
    path = _example(tmp_path)
    with h5py.File(path, "a") as h:
        for k, peak in enumerate((0.8, 0.3, 0.95)):
            g = h[f"data/demo_{k}"]
            del g["rewards"]
            g["rewards"] = np.r_[np.linspace(0, peak, 100), np.full(51, peak * 0.5)]  # the largest, not the last
    # the success attribute is not asked
    ds, errors = import_demos([path], ImportSpec(ENV), {"hdf5": Hdf5Options(success_threshold=0.5)})
    assert errors == [] and ds.labels.tolist() == [1, 0, 1]
    ds, _ = import_demos([path], ImportSpec(ENV), {"hdf5": Hdf5Options(success_threshold=0.9)})
    assert ds.labels.tolist() == [0, 0, 1]
    with h5py.File(path, "a") as h:
        del h["data/demo_1/rewards"]
    _, errors = import_demos([path], ImportSpec(ENV), {"hdf5": Hdf5Options(success_threshold=0.5)})
    assert errors == [f"{path}, demo group 'data/demo_1', field 'success': no success flag: found no dataset "
                      "'rewards' (also under obs/) for --success-threshold; map one with --hdf5-keys success=NAME"]


def test_labels_that_are_all_done_flags_are_refused(tmp_path):
    path = _example(tmp_path)
    with h5py.File(path, "a") as h:
        for k in range(3):
            del h[f"data/demo_{k}"].attrs["success"], h[f"data/demo_{k}/rewards"]
    ds, errors = import_demos([path, EXAMPLE_CSV], ImportSpec(ENV))
    assert ds.n == 3 and ds.meta["files_imported"] == 1  # the CSV is still imported
    assert errors == [
        f"{path}: every label comes from 'dones' and all 3 are 1: 'dones' marks the end of every demonstration "
        "(robomimic's done_mode 2, LeRobot's next.done), success or not; give each demo group a 'success' attribute, "
        "map a success flag with --hdf5-keys success=NAME, or label from dense rewards with --success-threshold X"]
    with h5py.File(path, "a") as h:
        h["data/demo_1/dones"][-1] = 0  # a failure among them: the flags mean something
    ds, errors = import_demos([path], ImportSpec(ENV))
    assert errors == [] and ds.labels.tolist() == [1, 0, 1]


@pytest.mark.parametrize("task, env, make", [
    ("scoop", ENV, lambda tmp: EXAMPLE_CSV),
    ("scrape", ("x_obj", "y_obj", "mu"), lambda tmp: _scrape(tmp / "s.csv")),
])
def test_export_then_import_gives_the_same_dataset(tmp_path, task, env, make):
    spec = ImportSpec(env, task=task)
    ds, errors = import_demos([make(tmp_path)], spec)
    assert errors == []
    out = export_csv(ds, tmp_path / "out.csv")
    back, errors = import_demos([out], spec)
    assert errors == [] and back.n == ds.n and back.channels == ds.channels
    assert back.labels.tolist() == ds.labels.tolist()
    np.testing.assert_allclose(back.responses, ds.responses, rtol=0, atol=1e-12)
    np.testing.assert_allclose(back.commands, ds.commands, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(back.env, ds.env)
    assert [i.split(":", 1)[1] for i in back.meta["demo_ids"]] == ds.meta["demo_ids"]  # out.csv:<the old id>


def _scrape(path: Path) -> Path:
    t = np.linspace(0, 1.2, 61)
    rows = ["demo_id,t,x,y,f,label,x_obj,y_obj,mu"]
    for d, label in enumerate(("success", "failure")):
        rows += [f"d{d},{ti:.3f},{0.3 - 0.02 * ti:.5f},{0.15 * ti * (d + 1):.5f},{20 + d},{label},0.28,0.12,0.4"
                 for ti in t]
    path.write_text("\n".join(rows) + "\n")
    return path
