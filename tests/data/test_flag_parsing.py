"""The import flags' parsers and a reader's guard rails, against generated input: what is written
the documented way parses back to what was meant (key maps, topics, scales and units, offsets,
streams), and anything else is the module's one-line error (ImportError_), never another
exception."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from judgeopt.data.importer import ImportSpec, import_demos
from judgeopt.data.labels import UNITS, parse_assignments, read_labels
from judgeopt.data.readers.csv import parse_columns, parse_streams
from judgeopt.data.readers.mcap import AXES, parse_topics
from judgeopt.data.recording import ImportError_, parse_keys

ENV = ("y_obj", "mu")
CHANNELS = ("y", "ydot", "f")
KINDS = {"t": "t", "y": "position", "ydot": "velocity", "f": "force"}
#: no example database in the checkout, no deadline on a shared machine
checked = settings(database=None, deadline=None, max_examples=150,
                   suppress_health_check=[HealthCheck.function_scoped_fixture])

paths = st.from_regex(r"[A-Za-z0-9_.]([A-Za-z0-9_./ -]{0,10}[A-Za-z0-9_.])?", fullmatch=True)
topics = st.from_regex(r"/[A-Za-z_][A-Za-z0-9_]{0,6}(/[A-Za-z_][A-Za-z0-9_]{0,6}){0,2}", fullmatch=True)
garbage = (st.text(alphabet=st.characters(codec="utf-8"), max_size=40)
           | st.text(alphabet="=,:/ -.yftmu0123_a", max_size=30))


@st.composite
def key_maps(draw, per_step=("t", *CHANNELS), scalars=("success", "dt")) -> tuple[str, dict[str, str]]:
    """A key map as a user types it (spaces and slashes around paths allowed) and what it means."""
    names = draw(st.lists(st.sampled_from((*per_step, *scalars, *ENV)), unique=True, max_size=6))
    items, meant = [], {}
    for name in names:
        path = draw(paths)
        column = draw(st.none() | st.integers(-99, 99)) if name in per_step else None
        meant[name] = path + ("" if column is None else f":{column}")
        pad = draw(st.sampled_from(["", " ", "/", " /"]))
        items.append(f"{draw(st.sampled_from(['', ' ']))}{name} ={pad}{path}{pad[::-1]}"
                     + ("" if column is None else f": {column}"))
    return ",".join(items), meant


@checked
@given(key_maps())
def test_a_key_map_parses_to_what_was_meant(case):
    text, meant = case
    assert parse_keys(text, ENV, CHANNELS) == meant


@checked
@given(garbage)
def test_any_key_map_text_parses_or_is_the_one_line_error(text):
    for flag, kw in (("--hdf5-keys", {}), ("--keys", {"scalars": ("success",), "columns_everywhere": True}),
                     ("--columns", {"scalars": ("label", "demo_id")})):
        try:
            out = parse_keys(text, ENV, CHANNELS, flag=flag, **kw)
        except ImportError_ as exc:
            assert str(exc).startswith(f"{flag}: ") and "\n" not in str(exc)
            continue
        for name, ref in out.items():  # what a map holds: a known name, a non-empty path, no separator
            assert name in ("t", *CHANNELS, *ENV, *kw.get("scalars", ("success", "dt")))
            assert ref and "," not in ref and not ref.startswith("/") and ref == ref.strip()


@checked
@given(garbage)
def test_columns_and_streams_parse_or_are_the_one_line_error(text):
    spec = ImportSpec(ENV)
    for parse in (parse_columns, parse_streams):
        try:
            parse(text, spec)
        except ImportError_ as exc:
            assert "\n" not in str(exc)


@checked
@given(st.lists(st.from_regex(r"[a-z][a-z0-9]{0,5}", fullmatch=True), unique=True, max_size=4))
def test_streams_parse_back(names):
    assert parse_streams(" , ".join(names)) == tuple(names)


@checked
@given(st.lists(st.tuples(st.sampled_from(("y", "f", "episode", "label", *ENV)), topics, st.sampled_from(AXES)),
                unique_by=lambda item: item[0], max_size=6))
def test_topics_parse_back_absolute(items):
    text = ",".join(f"{n}={t.lstrip('/') if k % 2 else t}" + (f":{a}" if n in ("y", "f") else "")
                    for k, (n, t, a) in enumerate(items))
    assert parse_topics(text, ENV, ("y", "f")) == {n: t + (f":{a}" if n in ("y", "f") else "") for n, t, a in items}


@checked
@given(garbage)
def test_any_topics_text_parses_or_is_the_one_line_error(text):
    try:
        out = parse_topics(text, ENV, ("y", "f"))
    except ImportError_ as exc:
        assert str(exc).startswith("--topics: ") and "\n" not in str(exc)
        return
    assert all(ref.startswith("/") for ref in out.values())


finite = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e12, max_value=1e12).filter(lambda v: v != 0)


@checked
@given(st.dictionaries(st.sampled_from(tuple(KINDS)), finite, max_size=4))
def test_scales_parse_back_exactly(factors):
    text = ",".join(f"{n}={v!r}" for n, v in factors.items())
    assert parse_assignments(text, "--scale", list(KINDS), units=True, kinds=KINDS) == factors


@checked
@given(st.sampled_from(tuple(KINDS)), st.sampled_from(tuple(UNITS)), st.booleans())
def test_a_unit_is_its_factor_to_si_signed_and_only_for_what_it_measures(name, unit, negative):
    text = f"{name}={'-' if negative else ''}{unit}"
    factor, kind = UNITS[unit]
    if kind != KINDS[name]:
        with pytest.raises(ImportError_, match=f"^--scale: {name}=-?{unit}: '{unit}' measures {kind}"):
            parse_assignments(text, "--scale", list(KINDS), units=True, kinds=KINDS)
    else:
        assert parse_assignments(text, "--scale", list(KINDS), units=True, kinds=KINDS) == {
            name: -factor if negative else factor}


@checked
@given(garbage, st.booleans())
def test_any_scale_offset_or_env_text_is_finite_numbers_or_the_one_line_error(text, units):
    flag = "--scale" if units else "--offset"
    try:
        out = parse_assignments([text, text[::-1]], flag, list(KINDS), units=units, kinds=KINDS)
    except ImportError_ as exc:
        assert str(exc).startswith(f"{flag}: ") and "\n" not in str(exc)
        return
    assert all(math.isfinite(v) and (v != 0 or not units) for v in out.values())


@checked
@given(st.text(max_size=200) | st.lists(st.sampled_from(["file,success", "a.csv,1", "b,failure", "a.csv,0", ",",
                                                          "name", "x,maybe", "\ufeff"]), max_size=6).map("\n".join))
def test_any_labels_file_reads_or_is_the_one_line_error(text):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "labels.csv"
        path.write_text(text, errors="surrogatepass")
        try:
            labels = read_labels(path)
        except ImportError_ as exc:
            assert str(exc).startswith(f"--labels {path}") and "\n" not in str(exc)
            return
        assert set(labels.labels.values()) <= {0, 1}


CELLS = ["", "0", "0.05", "0.1", "1", "-1", "1e9", "nan", "inf", "x", "success", "failure", "d1", " "]
HEADERS = ["t", "y", "f", "label", "y_obj", "mu", "demo_id", "ydot", "time"]


@checked
@given(st.lists(st.sampled_from(HEADERS), min_size=1, max_size=8, unique=True),
       st.lists(st.lists(st.sampled_from(CELLS), min_size=0, max_size=9), max_size=12))
def test_any_csv_table_imports_or_names_what_is_wrong_in_one_line(header, rows):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "rec.csv"
        path.write_text("\n".join([",".join(header), *(",".join(r) for r in rows)]) + "\n")
        ds, errors = import_demos([path], ImportSpec(ENV))
    assert (ds is None) == bool(errors) and all("\n" not in e for e in errors)
    assert ds is None or ds.n >= 1
