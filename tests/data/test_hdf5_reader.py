"""The HDF5 reader's own output (`hdf5.read`: RawDemos before any check), against small files whose
content is written here: the order of demo groups, where each value is looked up (and where it is
not), which time base a demo gets, which label, and the exact message naming the demo group and
field when something is wrong. Each expectation is worked out by hand from what was written."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from judgeopt.data.importer import ImportSpec
from judgeopt.data.labels import LabelFile
from judgeopt.data.readers import hdf5
from judgeopt.data.readers.base import Source
from judgeopt.data.readers.hdf5 import Hdf5Options, parse_hdf5_keys

ENV = ("mu",)
SPEC = ImportSpec(ENV)
T = np.arange(5) * 0.02  # five samples at 50 Hz
Y = np.array([0.10, 0.11, 0.13, 0.16, 0.20])
F = np.array([0.0, 2.0, 4.0, 6.0, 8.0])


def _file(path: Path, demos: dict[str, dict], data_attrs: dict | None = None, masks: dict | None = None) -> Path:
    """data/<name> per demo: its datasets (name -> array, "attrs" -> attributes)."""
    with h5py.File(path, "w") as h:
        data = h.create_group("data")
        for k, v in (data_attrs or {}).items():
            data.attrs[k] = v
        for name, content in demos.items():
            g = data.create_group(name)
            for k, v in content.items():
                if k == "attrs":
                    for a, av in v.items():
                        if av is not None:
                            g.attrs[a] = av
                else:
                    g[k] = v
        for k, v in (masks or {}).items():
            h[f"mask/{k}"] = v
    return path


def _demo(**extra) -> dict:
    """t, y, f, a success attribute and mu: everything one demo needs, `extra` replacing or adding."""
    out = {"t": T, "y": Y, "f": F, "attrs": {"success": 1, "mu": 0.4}}
    attrs = extra.pop("attrs", None)
    out.update(extra)
    if attrs is not None:
        out["attrs"] = {**out["attrs"], **attrs}
    return {k: v for k, v in out.items() if v is not None}


def _read(path: Path, spec: ImportSpec = SPEC, **options):
    return hdf5.read(Source(path), spec, Hdf5Options(**options))


def _error(path: Path, spec: ImportSpec = SPEC, **options) -> str:
    raws, errors = _read(path, spec, **options)
    assert raws == [] and len(errors) == 1, errors
    return errors[0]


# -- demo groups: order, filter keys ------------------------------------------------------------------
def test_demo_groups_are_read_in_the_order_of_their_trailing_number(tmp_path):
    names = ["demo_10", "demo_2", "extra", "demo_0", "demo_1"]  # a name without a number comes first
    path = _file(tmp_path / "d.hdf5", {n: _demo() for n in names})
    raws, errors = _read(path)
    assert errors == [] and [r.demo_id for r in raws] == ["d.hdf5:extra", "d.hdf5:demo_0", "d.hdf5:demo_1",
                                                          "d.hdf5:demo_2", "d.hdf5:demo_10"]
    assert [hdf5._demo_order(n) for n in ("demo_10", "x", "a7b")] == [(10, "demo_10"), (-1, "x"), (-1, "a7b")]


def test_a_filter_key_takes_names_with_or_without_data_prefix_and_names_what_is_not_there(tmp_path):
    demos = {f"demo_{k}": _demo() for k in range(3)}
    masks = {"train": np.array([b"data/demo_2", b"demo_0"]), "odd": np.array([7, 1])}
    path = _file(tmp_path / "d.hdf5", demos, masks=masks)
    raws, errors = _read(path, filter_key="train")
    assert errors == [] and [r.demo_id for r in raws] == ["d.hdf5:demo_0", "d.hdf5:demo_2"]  # in file order
    raws, errors = _read(path, filter_key="odd")  # numbers, not names: each named as listed
    assert raws == [] and errors == [f"{path}, mask/odd: lists demo group '7', which is not in 'data'",
                                     f"{path}, mask/odd: lists demo group '1', which is not in 'data'"]


# -- what a RawDemo says about itself -----------------------------------------------------------------
def test_a_raw_demo_names_its_file_group_and_each_sample(tmp_path):
    path = _file(tmp_path / "d.hdf5", {"demo_0": _demo()})
    (raw,), errors = _read(path)
    assert errors == [] and raw.origin == str(path) and raw.name == "demo group 'data/demo_0'"
    assert raw.demo_id == "d.hdf5:demo_0" and raw.label == 1 and raw.label_from_done == ""
    for c, a in (("t", T), ("y", Y), ("f", F)):
        assert raw.series[c].dtype == np.float64 and np.array_equal(raw.series[c], a)
    assert raw.env == {"mu": pytest.approx(np.array([0.4]))}
    ctx = f"{path}, demo group 'data/demo_0'"
    assert raw.where("y", 3) == f"{ctx}, field 'y' (y), sample 3"
    assert raw.where("mu", 0) == f"{ctx}, field 'mu' (attribute 'mu')"  # one value: no sample


def test_integer_and_boolean_datasets_read_as_floats(tmp_path):
    path = _file(tmp_path / "d.hdf5", {"demo_0": _demo(y=np.array([1, 2, 3, 4, 5], dtype=np.int16),
                                                       f=np.array([0, 1, 1, 0, 1], dtype=bool))})
    (raw,), _ = _read(path)
    assert raw.series["y"].dtype == raw.series["f"].dtype == np.float64
    assert raw.series["y"].tolist() == [1.0, 2.0, 3.0, 4.0, 5.0] and raw.series["f"].tolist() == [0, 1, 1, 0, 1]


def test_two_samples_are_still_numbered_in_messages(tmp_path):
    path = _file(tmp_path / "d.hdf5", {"demo_0": _demo(t=T[:2], y=Y[:2], f=F[:2])})
    (raw,), _ = _read(path)
    assert raw.where("y", 1).endswith("field 'y' (y), sample 1")


# -- channels: columns and shapes ---------------------------------------------------------------------
def test_a_single_column_array_needs_no_column_and_negative_columns_count_from_the_end(tmp_path):
    eef = np.stack([Y, 2 * Y, 3 * Y], axis=1)
    path = _file(tmp_path / "d.hdf5", {"demo_0": _demo(y=None, f=F[:, None], **{"obs/eef": eef})})
    (raw,), errors = _read(path, keys=parse_hdf5_keys("y=obs/eef:-3"))
    assert errors == [] and np.array_equal(raw.series["y"], Y) and np.array_equal(raw.series["f"], F)
    assert raw.where("y", 0).endswith("field 'y' (obs/eef:-3), sample 0")
    (raw,), _ = _read(path, keys=parse_hdf5_keys("y=obs/eef:2"))
    assert np.array_equal(raw.series["y"], 3 * Y)


def _with(tmp_path: Path, **datasets) -> Path:
    return _file(tmp_path / "d.hdf5", {"demo_0": _demo(**datasets)})


@pytest.mark.parametrize("datasets, keys, message", [
    ({"y": np.stack([Y, Y], axis=1)}, "",
     "field 'y': dataset 'y' has shape (5, 2): choose a column with --hdf5-keys y=y:COLUMN"),
    ({"y": np.stack([Y, Y, Y], axis=1)}, "y=y:3",
     "field 'y': column 3 is out of range for dataset 'y' of shape (5, 3)"),
    ({"y": np.stack([Y, Y, Y], axis=1)}, "y=y:-4",
     "field 'y': column -4 is out of range for dataset 'y' of shape (5, 3)"),
    ({}, "y=y:0", "field 'y': dataset 'y' has shape (5,); expected (T,) and (T, k) for a column selector"),
    ({"y": np.zeros((5, 1, 1))}, "",
     "field 'y': dataset 'y' has shape (5, 1, 1); expected (T,) or (T, k) with a column"),
    ({"y": np.array([b"a", b"b", b"c", b"d", b"e"])}, "", "field 'y': dataset 'y' holds |S1 values, not numbers"),
    ({}, "y=obs/pos:1", "field 'y': no dataset 'obs/pos:1' in the demo group (it has ['f', 't', 'y']); map another "
                        "with --hdf5-keys y=PATH[:COLUMN]"),
    ({"y": None, "obs": None}, "", "field 'y': no dataset 'y' or 'obs/y' in the demo group (it has ['f', 't']); map "
                                   "another with --hdf5-keys y=PATH[:COLUMN]"),
])
def test_a_bad_channel_names_demo_group_field_and_fix(tmp_path, datasets, keys, message):
    path = _with(tmp_path, **{k: v for k, v in datasets.items() if k != "obs"})
    if "obs" in datasets:  # a group that is not a dataset is not listed; nested datasets are
        with h5py.File(path, "a") as h:
            h["data/demo_0"].create_group("obs")
    assert _error(path, keys=parse_hdf5_keys(keys)) == f"{path}, demo group 'data/demo_0', {message}"


def test_the_listing_includes_nested_datasets_and_says_when_there_are_none(tmp_path):
    path = _file(tmp_path / "d.hdf5", {"demo_0": {"obs/ft": F, "attrs": {"success": 1}}, "demo_1": {}})
    raws, errors = _read(path)
    assert raws == [] and errors == [
        f"{path}, demo group 'data/demo_0', field 'y': no dataset 'y' or 'obs/y' in the demo group (it has "
        "['obs/ft']); map another with --hdf5-keys y=PATH[:COLUMN]",
        f"{path}, demo group 'data/demo_1', field 'y': no dataset 'y' or 'obs/y' in the demo group (it has no "
        "datasets); map another with --hdf5-keys y=PATH[:COLUMN]"]


# -- time base ----------------------------------------------------------------------------------------
def test_without_time_stamps_dt_then_control_freq_as_attributes_never_as_datasets(tmp_path):
    ctx = "field 't' ({}), sample 2"
    # a dataset called dt or control_freq is not a period: the attribute (or env_args key) is
    path = _file(tmp_path / "a.hdf5", {"demo_0": _demo(t=None, dt=np.full(5, 0.5), control_freq=np.full(5, 1.0),
                                                       attrs={"control_freq": 25})})
    (raw,), errors = _read(path)
    assert errors == [] and np.allclose(raw.series["t"], np.arange(5) * 0.04)
    assert raw.where("t", 2).endswith(ctx.format("evenly spaced at 25 Hz from attribute 'control_freq'"))
    path = _file(tmp_path / "b.hdf5", {"demo_0": _demo(t=None, control_freq=np.full(5, 1.0))},
                 data_attrs={"env_args": json.dumps({"env_kwargs": {"control_freq": 0.5}}), "dt": b"0.25"})
    (raw,), errors = _read(path)  # dt (bytes, on 'data') first
    assert errors == [] and np.allclose(raw.series["t"], np.arange(5) * 0.25)
    assert raw.where("t", 2).endswith(ctx.format("evenly spaced by dt = 0.25 s from attribute 'dt' of 'data'"))
    path = _file(tmp_path / "c.hdf5", {"demo_0": _demo(t=None, control_freq=np.full(5, 1.0))},
                 data_attrs={"env_args": np.bytes_(json.dumps({"env_kwargs": {"control_freq": 0.5}}))})
    (raw,), errors = _read(path)  # below 1 Hz is still a rate; env_args as bytes is JSON too
    assert errors == [] and np.allclose(raw.series["t"], np.arange(5) * 2.0)
    assert raw.where("t", 2).endswith(ctx.format("evenly spaced at 0.5 Hz from env_args['env_kwargs']['control_freq']"))


@pytest.mark.parametrize("attrs, message", [
    ({"control_freq": 0}, "field 't': control frequency attribute 'control_freq' = 0 Hz is not a positive number"),
    ({"control_freq": -5}, "field 't': control frequency attribute 'control_freq' = -5 Hz is not a positive number"),
    ({"control_freq": np.inf},
     "field 't': control frequency attribute 'control_freq' = inf Hz is not a positive number"),
    ({"control_freq": "fast"}, "field 't': attribute 'control_freq' is 'fast', not a number"),
    ({"dt": "short"}, "field 'dt': attribute 'dt' is 'short', not a number"),
    ({"dt": np.zeros(0)}, "field 'dt': attribute 'dt' is empty"),
    ({"dt": -0.1}, "field 't': sample period attribute 'dt' = -0.1 s is not a positive number"),
])
def test_a_bad_period_or_rate_is_named(tmp_path, attrs, message):
    path = _file(tmp_path / "d.hdf5", {"demo_0": _demo(t=None, attrs=attrs)})
    assert _error(path) == f"{path}, demo group 'data/demo_0', {message}"


# -- environment values -------------------------------------------------------------------------------
def test_an_environment_value_from_a_dataset_a_string_or_a_mapped_name(tmp_path):
    path = _file(tmp_path / "d.hdf5", {"demo_0": _demo(mu=np.full(5, 0.7), attrs={"mu": None}),
                                       "demo_1": _demo(attrs={"mu": "0.25"}),
                                       "demo_2": _demo(attrs={"friction": b"0.5"})})
    raws, errors = _read(path, keys={"mu": "friction"})
    assert [r.demo_id for r in raws] == ["d.hdf5:demo_2"] and raws[0].env["mu"].tolist() == [0.5]
    assert errors == [
        f"{path}, demo group 'data/demo_0', field 'mu': no environment value 'friction': not an attribute of the "
        "demo group, a dataset, a key of env_args or an attribute of 'data'; give it with --env mu=VALUE or map "
        "one with --hdf5-keys mu=NAME",
        f"{path}, demo group 'data/demo_1', field 'mu': no environment value 'friction': not an attribute of the "
        "demo group, a dataset, a key of env_args or an attribute of 'data'; give it with --env mu=VALUE or map "
        "one with --hdf5-keys mu=NAME"]
    raws, errors = _read(path)
    assert errors == [] and [r.env["mu"].tolist() for r in raws[:2]] == [[0.7] * 5, [0.25]]
    assert raws[0].where("mu", 1).endswith("field 'mu' (dataset 'mu'), sample 1")


def test_an_environment_value_that_is_no_number_is_named(tmp_path):
    path = _file(tmp_path / "d.hdf5", {"demo_0": _demo(attrs={"mu": "slippery"})})
    assert _error(path) == f"{path}, demo group 'data/demo_0', field 'mu': attribute 'mu' is 'slippery', not a number"
    path = _file(tmp_path / "e.hdf5", {"demo_0": _demo(mu=np.array([b"icy"] * 5), attrs={"mu": None})})
    assert _error(path) == f"{path}, demo group 'data/demo_0', field 'mu': dataset 'mu' holds |S3 values, not numbers"


# -- labels -------------------------------------------------------------------------------------------
def _labelled(tmp_path: Path, **content) -> Path:
    attrs = content.pop("attrs", {})
    return _file(tmp_path / "d.hdf5", {"demo_0": {"t": T, "y": Y, "f": F, **content, "attrs": {"mu": 0.4, **attrs}}})


@pytest.mark.parametrize("content, options, label, done", [
    ({"attrs": {"success": "Success"}}, {}, 1, ""),
    ({"attrs": {"success": b" FAILURE "}}, {}, 0, ""),
    ({"success": np.array([0, 0, 1]), "rewards": np.array([0.0, 0.0, 0.0])}, {}, 1, ""),  # success before rewards
    ({"rewards": np.array([0.0, 1.0, 0.0]), "dones": np.array([0, 0, 1])}, {}, 0, ""),  # rewards before dones
    ({"dones": np.array([0, 0, 1])}, {}, 1, "dones"),
    ({"attrs": {"ok": 0, "success": 1}}, {"keys": {"success": "ok"}}, 0, ""),  # mapped: the attribute it names
    ({"ok": np.array([0, 1]), "attrs": {"success": 0}}, {"keys": {"success": "ok"}}, 1, ""),
    ({"dones": np.array([0, 1])}, {"keys": {"success": "dones"}}, 1, ""),  # mapped to dones: a success flag
    ({"rewards": np.array([0.0, 0.6, 0.2]), "attrs": {"success": 0}}, {"success_threshold": 0.6}, 1, ""),
    ({"rewards": np.array([0.0, 0.6, 0.2])}, {"success_threshold": 0.61}, 0, ""),
])
def test_the_label_comes_from_the_first_source_in_the_documented_order(tmp_path, content, options, label, done):
    (raw,), errors = _read(_labelled(tmp_path, **content), **options)
    assert errors == [] and (raw.label, raw.label_from_done) == (label, done)


@pytest.mark.parametrize("content, options, message", [
    ({"attrs": {"success": "maybe"}}, {}, "attribute 'success' is 'maybe', not success/failure"),
    ({"success": np.zeros(0)}, {}, "dataset 'success' is empty"),
    ({"success": np.array([b"yes"])}, {}, "dataset 'success' holds |S3 values, not numbers"),
    ({"success": np.array([0.0, 0.5])}, {}, "dataset 'success': last value 0.5 is neither 1 (success) nor 0 (failure); "
                                            "for dense rewards pass --success-threshold X"),
    ({"attrs": {"success": 1}}, {"keys": {"success": "ok"}},
     "no success flag: found no attribute or dataset 'ok'; map one with --hdf5-keys success=NAME"),
    ({}, {}, "no success flag: found no attribute 'success', dataset 'success', 'rewards' or 'dones' (also under "
             "obs/); map one with --hdf5-keys success=NAME"),
])
def test_a_missing_or_bad_label_is_named(tmp_path, content, options, message):
    path = _labelled(tmp_path, **content)
    assert _error(path, **options) == f"{path}, demo group 'data/demo_0', field 'success': {message}"


def test_with_a_labels_file_the_file_needs_no_label(tmp_path):
    spec = ImportSpec(ENV, labels=LabelFile("labels.csv", {"d.hdf5": 1}))
    (raw,), errors = _read(_labelled(tmp_path), spec)
    assert errors == [] and raw.label is None and raw.label_from_done == ""
