"""The shared parsers and validators of the import (key maps, columns, streams, assignments, labels
files, the contact onset, the force tare, the messages' fixes), each against input whose meaning is
known by construction: generated where a generated case beats a hand-picked one (a key map of any
task's names, a force trace with its onset at a drawn sample), hand-picked where one exact message
or one boundary is the point."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from judgeopt.data.importer import ImportSpec, import_demos
from judgeopt.data.labels import UNITS, parse_assignments, read_labels

from judgeopt.data.readers.csv import parse_columns, parse_streams
from judgeopt.data.readers.hdf5 import parse_hdf5_keys
from judgeopt.data.readers.registry import READERS, inputs
from judgeopt.data.recording import ImportError_, RawDemo, check, contact_onset, env_fix, parse_keys, split_key

checked = settings(database=None, deadline=None, max_examples=50)
names_ = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,8}", fullmatch=True)
paths = st.from_regex(r"[A-Za-z0-9_.]([A-Za-z0-9_./:-]{0,10}[A-Za-z0-9_.])?", fullmatch=True)

# -- key maps ------------------------------------------------------------------------------------------
@checked
@given(paths, st.integers(-10**9 + 1, 10**9 - 1))
def test_split_key_takes_the_last_colon_number_as_the_column(path, column):
    assert split_key(f"{path}:{column}") == (path, column)  # "a:b:2" -> ("a:b", 2): a path may hold colons
    if not re.search(r":-?\d+$", path):
        assert split_key(path) == (path, None)

@checked
@given(st.sampled_from(["scoop", "scrape"]), st.data())
def test_csv_columns_map_any_name_of_the_task_its_environment_label_and_demo_id(task, data):
    env = data.draw(st.lists(names_.filter(lambda n: n not in ("t", "x", "y", "f", "xdot", "ydot", "label", "demo_id")),
                             unique=True, max_size=3))
    spec = ImportSpec(tuple(env), task=task)
    allowed = ("t", *spec.names("position", "velocity", "force"), "label", "demo_id", *env)
    picked = data.draw(st.lists(st.sampled_from(allowed), unique=True, min_size=1))
    meant = {n: data.draw(names_) for n in picked}
    assert parse_columns(",".join(f"{n}={c}" for n, c in meant.items()), spec) == meant
    with pytest.raises(ImportError_, match=r"^--columns: unknown name 'speed'; map one of \["):
        parse_columns("speed=v", spec)
    with pytest.raises(ImportError_, match="^--columns: a column selector is only for per-step arrays"):
        parse_columns("label=outcome:1", spec)

def test_a_task_s_own_channels_are_mapped_in_hdf5_keys():
    assert parse_hdf5_keys("x=obs/pos:0,xdot=obs/vel:0,mu=friction", ("mu",), ("x", "xdot", "f")) == {
        "x": "obs/pos:0", "xdot": "obs/vel:0", "mu": "friction"}
    with pytest.raises(ImportError_, match=r"^--hdf5-keys: unknown name 'y'; map one of \['t', 'x', 'xdot', 'f', "
                                           r"'success', 'dt', 'mu'\]$"):
        parse_hdf5_keys("y=obs/pos", ("mu",), ("x", "xdot", "f"))

def test_a_key_map_s_messages_name_its_flag_and_the_per_step_names():
    with pytest.raises(ImportError_, match=r"^--hdf5-keys: 'y' is not NAME=PATH or NAME=PATH:COLUMN$"):
        parse_keys("y")  # the default flag
    with pytest.raises(ImportError_, match=r"^--hdf5-keys: a column selector is only for per-step arrays "
                                           r"\(t, y, ydot, f\), not 'success'$"):
        parse_keys("success=is_success:1")

@checked
@given(st.lists(st.from_regex(r"[a-z][a-z0-9]{0,4}", fullmatch=True), min_size=1, max_size=5), st.data())
def test_a_stream_named_twice_is_refused_naming_the_first_such(streams, data):
    twice = data.draw(st.lists(st.sampled_from(streams), min_size=1, max_size=3))
    names = data.draw(st.permutations([*streams, *twice]))
    dup = sorted({s for s in names if names.count(s) > 1})
    if not dup:
        return
    with pytest.raises(ImportError_, match=f"^--streams: '{dup[0]}' is named twice"):
        parse_streams(",".join(names))

# -- assignments (--env, --offset, --scale) --------------------------------------------------------------
def test_assignments_without_units_take_zero_and_name_no_unit():
    assert parse_assignments("mu=0,,y_obj=-0.25", "--env", ["mu", "y_obj"]) == {"mu": 0.0, "y_obj": -0.25}
    assert parse_assignments("f=kN,y=-mm", "--scale", ["f", "y"], units=True) == {"f": 1000.0, "y": -0.001}
    for text, message in [
        ("y=1=2", "--offset: y='1=2': not a number"), ("=5", "--offset: '=5' is not NAME=VALUE"),
        ("y=", "--offset: 'y=' is not NAME=VALUE"), ("y5", "--offset: 'y5' is not NAME=VALUE"),
        ("y=abc", "--offset: y='abc': not a number")]:
        with pytest.raises(ImportError_, match=f"^{re.escape(message)}$"):
            parse_assignments(text, "--offset", ["y"])
    units = re.escape(", ".join(UNITS))
    with pytest.raises(ImportError_, match=f"^--scale: y='abc': not a number or a unit \\({units}\\)$"):
        parse_assignments("y=abc", "--scale", ["y"], units=True)

# -- labels files ----------------------------------------------------------------------------------------
def test_a_labels_file_keeps_a_quoted_line_break_and_names_the_columns_it_needs(tmp_path):
    path = tmp_path / "labels.csv"
    path.write_bytes(b'file,success\r\n"two\r\nlines.csv",1\r\nb.csv,failure\r\n')
    assert read_labels(path).labels == {"two\r\nlines.csv": 1, "b.csv": 0}  # csv's newline="" rule
    path.write_text("id,ok\nb.csv,1\n")
    with pytest.raises(ImportError_, match=re.escape(
            "needs a recording column (one of file, recording, name, demo, demo_id, path, filename) and an "
            "outcome column (one of success, label, outcome, result)")):
        read_labels(path)

# -- messages' fixes and the readers' inputs --------------------------------------------------------------
def test_environment_fixes_name_what_is_kept_and_what_is_missing():
    spec = ImportSpec(("a", "b", "c", "d"))
    assert env_fix(spec, ["a", "b"], "map them") == ("leave them out with --env-names c,d, give them with --env "
                                                     "a=VALUE,b=VALUE or map them")
    assert env_fix(spec, ["a"], "map it") == "leave it out with --env-names b,c,d, give it with --env a=VALUE or map it"
    assert env_fix(ImportSpec(("a",)), ["a"], "map it") == "give it with --env a=VALUE or map it"

def test_the_readers_inputs_are_listed_with_or_before_the_last():
    every = [r.inputs for r in READERS.values()]
    assert inputs() == f"{', '.join(every[:-1])} or {every[-1]}" and len(every) == 4
    r = list(READERS.values())
    assert inputs(r[:1]) == r[0].inputs and inputs(r[:2]) == f"{r[0].inputs} or {r[1].inputs}"
    assert inputs(r[:3]) == f"{r[0].inputs}, {r[1].inputs} or {r[2].inputs}"

def test_label_keys_split_the_demo_id_at_its_last_colon():
    raw = RawDemo("in/run:1.csv", "x", "run:1.csv:d0", {}, {}, 1, lambda c, i: "")
    assert raw.label_keys() == ("run:1.csv:d0", "run:1.csv", "run:1", "d0")

# -- CSV tables: empty cells, labels -----------------------------------------------------------------------
def test_a_csv_with_an_empty_time_cell_or_two_labels_is_named(tmp_path):
    spec = ImportSpec(())
    path = tmp_path / "rec.csv"
    path.write_text("t,y,f,label\n0,0.1,0,success\n,0.1,0,success\n0.02,0.1,0,success\n")
    _, errors = import_demos([path], spec)
    assert errors == [f"{path}, row 3, column 't': '' is not a number"]
    path.write_text("demo_id,t,y,f,label\nd,0,0.1,0,success\nd,0.01,0.1,0,failure\n")
    _, errors = import_demos([path], spec)
    assert errors == [f"{path}: demonstration 'd' has both labels; a demonstration has one outcome"]

def test_a_channel_at_its_own_rate_is_named_by_its_own_row(tmp_path):
    """f on every other row (its own rate): its 3rd sample is on spreadsheet row 6, not row 4."""
    path = tmp_path / "rec.csv"
    rows = ["t,y,f,label"]
    for k in range(40):
        f = "" if k % 2 else ("nan" if k == 4 else "1.0")
        rows.append(f"{k * 0.01:.2f},0.1,{f},success")
    path.write_text("\n".join(rows) + "\n")
    _, errors = import_demos([path], ImportSpec(()))
    assert errors == [f"{path}, row 6, column 'f': 'nan' is not finite"]

# -- the contact onset -------------------------------------------------------------------------------------
def _raw(**series) -> RawDemo:
    return RawDemo("rec", "demo", "rec:d", series, {}, 1, lambda c, i: f"{c}[{i}]")

@checked
@given(st.integers(5, 60), st.data())
def test_the_contact_onset_is_lead_before_the_first_sample_above_the_threshold_in_the_window(n, data):
    dt = 0.01
    t = np.arange(n) * dt
    lo_i = data.draw(st.integers(0, n - 3))
    hi_i = data.draw(st.integers(lo_i + 1, n - 1))
    k = data.draw(st.integers(lo_i, hi_i))  # the onset, anywhere in the window, its ends included
    threshold = data.draw(st.floats(0.5, 5.0))
    lead = data.draw(st.sampled_from([0.0, 0.005, 0.02, 0.3]))
    below = st.floats(0.0, 1.0).map(lambda u: u * threshold)  # at most the threshold: not touching
    f = np.array([data.draw(below) * data.draw(st.sampled_from([1, -1])) for _ in range(n)])
    f[k] = data.draw(st.floats(1.0001, 3.0)) * threshold * data.draw(st.sampled_from([1, -1]))
    if data.draw(st.booleans()):
        f[k] = -abs(f[k])  # a magnitude: pulling counts too
    outside = [i for i in range(n) if i < lo_i or i > hi_i]
    for i in data.draw(st.lists(st.sampled_from(outside), max_size=3)) if outside else ():
        f[i] = 10 * threshold  # contact outside the window does not count
    if k < hi_i and data.draw(st.booleans()):
        f[k + 1:hi_i + 1] = 2 * threshold  # later contact does not move it
    spec = ImportSpec((), contact_force=threshold, lead=lead)
    lo, hi = t[lo_i], t[hi_i]
    assert contact_onset(_raw(), spec, {"f": (t, f)}, lo, hi) == max(lo, t[k] - lead)

def test_no_contact_names_the_largest_force_channel_and_sample():
    t = np.arange(10) * 0.01
    spec = ImportSpec((), contact_force=1.0, lead=0.0)
    forces = {"f": (t, np.r_[0.2, 0.8, 0.5, np.zeros(7)]), "g": (t, np.r_[0.3, 0.4, 0.0, -0.6, np.zeros(6)])}
    with pytest.raises(ImportError_, match=r"^f\[1\]: no contact onset .* the largest force between 0 s and 0\.09 s "
                                           r"is 0\.8 N, not above --contact-force 1 N$"):
        contact_onset(_raw(), spec, forces, 0.0, 0.09)
    forces["g"] = (t, np.r_[0.0, 0.0, 0.0, -0.8, np.zeros(6)])  # as large, later: the first keeps it
    with pytest.raises(ImportError_, match=r"^f\[1\]: .* is 0\.8 N"):
        contact_onset(_raw(), spec, forces, 0.0, 0.09)
    forces["g"] = (t, np.r_[0.0, 0.0, 0.0, -0.9, np.zeros(6)])  # larger: the second channel, by its name
    with pytest.raises(ImportError_, match=r"^g\[3\]: .* is 0\.9 N"):
        contact_onset(_raw(), spec, forces, 0.0, 0.09)
    spec = ImportSpec((), contact_force=2.0, lead=0.0)  # below 1 N too: still the largest
    with pytest.raises(ImportError_, match=r"^g\[3\]: .* is 0\.9 N, not above --contact-force 2 N$"):
        contact_onset(_raw(), spec, forces, 0.0, 0.09)
    at = {"f": (t, np.full(10, 2.0))}  # at the threshold, not above it: no contact
    with pytest.raises(ImportError_, match=r"^f\[0\]: .* is 2 N, not above --contact-force 2 N$"):
        contact_onset(_raw(), spec, at, 0.0, 0.09)
    zero = {"f": (t, np.zeros(10))}  # no force at all: the task's first force channel, its first sample
    with pytest.raises(ImportError_, match=r"^f\[0\]: .* is 0 N"):
        contact_onset(_raw(), spec, zero, 0.0, 0.09)
    scrape = ImportSpec((), task="scrape")
    with pytest.raises(ImportError_, match=rf"^{scrape.names('force')[0]}\[0\]: "):
        contact_onset(_raw(), scrape, {"f": (t, np.full(10, np.nan))}, 0.0, 0.09)

# -- the tare ----------------------------------------------------------------------------------------------
T = np.arange(141) * 0.01
_S = np.clip((T - 0.5) / 0.5, 0, 1)
Y = 0.1 + 0.1 * (10 * _S**3 - 15 * _S**4 + 6 * _S**5)  # at rest to 0.5 s, a 10 cm move to 1.0 s, at rest

def _pressing(**changes) -> np.ndarray:
    f = np.where(T < 0.5, 0.5, 5.0)
    for i, v in changes.items():
        f[int(i[1:])] = v
    return f

def test_the_tare_is_the_mean_force_over_the_rest_its_ends_included():
    onset = check(_raw(t=T, y=Y, f=_pressing()), ImportSpec(())).info["onset"]
    k = int(round(onset / 0.01))
    assert T[k] == onset and 10 < k < 50  # the fit puts the onset on a sample
    f = _pressing(i0=1.1, **{f"i{k}": 2.0})  # the first sample kept, and the one at the onset (lead 0)
    info = check(_raw(t=T, y=Y, f=f), ImportSpec((), tare=True, lead=0.0)).info
    assert info["bias_f"] == pytest.approx((1.1 + 2.0 + 0.5 * (k - 1)) / (k + 1), rel=1e-12)
    info = check(_raw(t=T, y=Y, f=f), ImportSpec((), tare=True, lead=0.105)).info  # to 0.105 s before the onset:
    n = k - 10  # samples 0 .. k - 11
    assert info["bias_f"] == pytest.approx((1.1 + 0.5 * (n - 1)) / n, rel=1e-12)

def test_the_tare_needs_a_rest_of_0_05_s_before_the_motion_less_the_lead():
    onset = check(_raw(t=T, y=Y, f=_pressing()), ImportSpec(())).info["onset"]
    lo = round(onset - 0.1 - 0.03, 2)  # 0.03 s of rest kept before lead and motion
    with pytest.raises(ImportError_, match=r"^rec: demo: --tare needs at least 0\.05 s at rest before the motion, and "
                                           r"the tool starts moving 0\.1\d* s into the kept part"):
        check(_raw(t=T, y=Y, f=_pressing()), ImportSpec((), tare=True, lead=0.1, start=lo))
    with pytest.raises(ImportError_, match=r"^rec: demo: --tare needs .* the tool never moves"):
        check(_raw(t=T, y=np.full_like(T, 0.1), f=_pressing()), ImportSpec((), tare=True))


@checked
@given(st.lists(st.integers(1, 50), min_size=2, max_size=30), st.data())
def test_span_is_the_last_sample_at_or_before_lo_to_the_first_at_or_after_hi(steps, data):
    from judgeopt.data.recording import span

    t = np.cumsum(steps) * 0.01 - 0.01 * steps[0]  # strictly increasing from 0
    lo = data.draw(st.floats(-0.1, float(t[-1]) + 0.1))
    hi = data.draw(st.floats(lo, float(t[-1]) + 0.2).filter(lambda h: h > lo))
    i0, i1 = span(t, lo, hi)
    at_or_before = [i for i in range(len(t)) if t[i] <= lo]
    at_or_after = [i for i in range(len(t)) if t[i] >= hi]
    assert i0 == (at_or_before[-1] if at_or_before else 0)
    assert i1 == max(at_or_after[0] if at_or_after else len(t) - 1, i0 + 1)
