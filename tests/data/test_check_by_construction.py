"""The shared checks (`recording.check`) and the CSV reader's table handling, against recordings
written here whose answer is known by construction: which samples the window holds (a bad value
just inside it refused, just outside it ignored), where a message says it is, the sign rule at
its boundaries, the kept window of each --fit, and positions resampled exactly where the recorded
curve is a polynomial the spline reproduces."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from judgeopt.data.importer import ImportSpec, import_demos
from judgeopt.data.readers.base import Source
from judgeopt.data.readers.csv import CsvOptions, gather
from judgeopt.data.recording import ImportError_, RawDemo, check

T = np.arange(141) * 0.01
_S = np.clip((T - 0.5) / 0.5, 0, 1)
Y = 0.1 + 0.1 * (10 * _S**3 - 15 * _S**4 + 6 * _S**5)  # at rest to 0.5 s, a 10 cm move to 1.0 s, at rest
F = np.where(T < 0.5, 0.5, 5.0)


def _raw(**series) -> RawDemo:
    return RawDemo("rec", "demo", "rec:d", series, {}, 1, lambda c, i: f"{c}[{i}]")


def _check(spec: ImportSpec | None = None, **series):
    return check(_raw(**{"t": T, "y": Y, "f": F, **series}), spec or ImportSpec(()))


# -- the window's samples -------------------------------------------------------------------------------
@pytest.mark.parametrize("field", ["f", "ydot"])
def test_a_bad_value_is_refused_inside_the_window_and_named_by_its_sample(field):
    spec = ImportSpec((), start=0.3, end=1.0)  # samples 30 .. 100
    ok = {"ydot": np.gradient(Y, T)} if field == "ydot" else {}
    for i, seen in ((29, False), (30, True), (60, True), (100, True), (101, False)):
        a = (ok.get(field, F)).copy()
        a[i] = np.nan
        if seen:
            with pytest.raises(ImportError_, match=rf"^{field}\[{i}\]: nan is not finite$"):
                _check(spec, **{**ok, field: a})
        else:
            _check(spec, **{**ok, field: a})


def test_a_velocity_beyond_its_limit_names_mm_per_s_and_counts_from_unix_time():
    t0 = 1.7e9  # UNIX time: the window is measured from the first time stamp
    v = np.gradient(Y, T)
    v[60] = 50.0
    with pytest.raises(ImportError_, match=r"^ydot\[60\]: 50 is beyond 10; expected SI units \(m, m/s, N\); in mm/s\? "
                                           r"pass --scale ydot=mm/s$"):
        _check(ImportSpec((), start=0.3), t=t0 + T, ydot=v)


@pytest.mark.parametrize("low, high, force, refused", [
    (-10.0, 3.0, 1.0, False),  # pressing beyond contact as well: not a flipped sign
    (-1.0, 0.2, 1.0, False),  # not beyond contact
    (-0.5, 0.1, 1.0, False),
    (-10.0, 1.0, 1.0, False),  # reaches contact pressing
    (-4.0, 2.0, 3.0, False),  # exactly twice: not more negative than twice the positive
    (-5.0, 2.0, 3.0, True),
    (-1.5, -0.5, 1.0, True),  # never positive
])
def test_a_force_that_only_goes_negative_beyond_contact_is_refused(low, high, force, refused):
    f = np.full_like(T, (low + high) / 2)
    f[40], f[90] = low, high
    spec = ImportSpec((), contact_force=force)
    if refused:
        with pytest.raises(ImportError_, match=rf"^rec: demo: force 'f' runs from {low:.3g} to {high:.3g} N: .*"
                                               r"pass --scale f=-1$"):
            _check(spec, f=f)
    else:
        _check(spec, f=f)


@pytest.mark.parametrize("i, refused", [(100, True), (101, False)])
def test_the_sign_is_judged_on_the_window_alone(i, refused):
    f = np.full_like(T, 0.5)
    f[i] = -5.0
    spec = ImportSpec((), end=1.0)
    if refused:
        with pytest.raises(ImportError_, match="pass --scale f=-1"):
            _check(spec, f=f)
    else:
        _check(spec, f=f)


# -- what is kept -----------------------------------------------------------------------------------------
def test_the_fit_keeps_the_motion_and_its_lead_and_crop_keeps_a_motion_ending_at_the_horizon():
    info = _check().info
    assert info["noise"] == info["velocity_noise"] == 0.0 and 0 < info["window"] <= 0.25  # a noiseless recording
    end = info["end"]
    info = _check(ImportSpec((), fit="resample", lead=0.1)).info
    assert info["kept"] == pytest.approx(end + 0.1) and info["time_scale"] == pytest.approx((end + 0.1) / 1.5)
    horizon = round(end / 0.05)
    assert horizon * 0.05 == end  # the motion ends on the last planner step of the crop
    info = _check(ImportSpec((), fit="crop", horizon=horizon)).info
    assert info["kept"] == pytest.approx(end)


def _polynomial(t: np.ndarray) -> np.ndarray:
    return 0.1 + 0.2 * t - 0.3 * t**2 + 0.4 * t**3  # a cubic: the spline through its samples is itself


def test_given_velocities_are_resampled_through_a_spline_of_the_samples_in_the_window():
    t = np.arange(0, 1.21, 0.02)
    spec = ImportSpec((), dt=0.03, horizon=40, end=1.0)  # planner steps between samples
    c = check(_raw(t=t, y=_polynomial(t), ydot=np.full_like(t, 0.2), f=np.full_like(t, 0.5)), spec)
    tk = np.arange(41) * 0.03
    assert np.allclose(c.x[:, 0], _polynomial(np.minimum(tk, 1.0)), atol=1e-12)
    assert np.allclose(c.x[tk <= 1.0, 1], 0.2) and np.all(c.x[tk > 1.0, 1] == 0.0)


@pytest.mark.parametrize("n", [2, 3])
def test_a_window_of_two_or_three_samples_is_interpolated_exactly(n):
    """Three samples: the quadratic through them; two: the line."""
    t = np.arange(n) * 0.05
    y = 0.1 + 0.2 * t + (0.3 * t**2 if n == 3 else 0.0)
    spec = ImportSpec((), dt=0.03, horizon=4)
    c = check(_raw(t=t, y=y, ydot=np.full_like(t, 0.2), f=np.full_like(t, 0.5)), spec)
    tk = np.minimum(np.arange(5) * 0.03, t[-1])
    assert np.allclose(c.x[:, 0], 0.1 + 0.2 * tk + (0.3 * tk**2 if n == 3 else 0.0), atol=1e-12)


def test_channels_at_their_own_rates_are_resampled_from_their_own_time_stamps(tmp_path):
    """y on even rows, ydot on odd rows, f on every row of a 100 Hz table."""
    rows = ["t,y,ydot,f,label"]
    for k in range(121):
        t = k * 0.01
        y, v = (f"{_polynomial(t):.12f}", "") if k % 2 == 0 else ("", f"{0.2 + 0.1 * t:.12f}")
        rows.append(f"{t:.2f},{y},{v},0.5,success")
    (tmp_path / "rec.csv").write_text("\n".join(rows) + "\n")
    ds, errors = import_demos([tmp_path / "rec.csv"], ImportSpec((), dt=0.03, horizon=40, end=1.0))
    assert errors == []
    tk = np.arange(41) * 0.03
    x = ds.commands[0]
    assert np.allclose(x[:, 0], _polynomial(np.minimum(tk, 1.0)), atol=1e-9)
    inside = tk <= 1.0
    v_at = np.maximum(tk[inside], 0.01)  # its first sample at 0.01 s: held before it
    assert np.allclose(x[inside, 1], 0.2 + 0.1 * v_at, atol=1e-9)


# -- CSV: the columns a file lacks ---------------------------------------------------------------------------
def _csv(path: Path, header: str, rows: int = 3) -> Path:
    cells = {"t": "{t}", "y": "0.1", "f": "0.5", "label": "success", "a": "1", "b": "2", "mu": "high", "fz": "0.5"}
    lines = [header] + [",".join(cells.get(h, "0").format(t=k * 0.01) for h in header.split(",")) for k in range(rows)]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("header, env, columns, message", [
    ("t,label", ("a",), {}, "missing column(s) ['y', 'f', 'a']; the header has ['t', 'label']; map them with "
                            "--columns y=COLUMN,f=COLUMN, and for the environment: give it with --env a=VALUE or map "
                            "a column with --columns a=COLUMN"),
    ("t,y,label", ("a", "b"), {"f": "fz_N"}, "missing column(s) ['f=fz_N', 'a', 'b']; the header has ['t', 'y', "
                                             "'label']; map it with --columns f=COLUMN, and for the environment: give "
                                             "them with --env a=VALUE,b=VALUE or map columns with --columns "
                                             "a=COLUMN,b=COLUMN"),
    ("demo,t,y", (), {}, "missing column(s) ['f', 'label']; the header has ['demo', 't', 'y']; map them with "
                         "--columns f=COLUMN,label=COLUMN"),
    ("File,Outcome", (), {}, "a labels file, not a recording; pass it with --labels {path}"),
])
def test_a_missing_column_is_named_with_its_fix(tmp_path, header, env, columns, message):
    path = _csv(tmp_path / "rec.csv", header)
    _, errors = import_demos([path], ImportSpec(env), {"csv": CsvOptions(columns)})
    assert errors == [f"{path}: {message.format(path=path)}"]


def test_a_recording_without_a_label_says_how_to_give_one(tmp_path):
    path = tmp_path / "rec.csv"
    path.write_text("t,y,f,label\n0,0.1,0.5,\n0.01,0.1,0.5, \n")
    _, errors = import_demos([path], ImportSpec(()))
    assert errors == [f"{path}: demonstration 'rec' has no label; fill the label column or give --labels FILE"]


def test_an_environment_value_given_by_hand_replaces_its_column_unread(tmp_path):
    path = _csv(tmp_path / "rec.csv", "t,y,f,label,mu", rows=20)  # mu is "high": not a number, and not read
    ds, errors = import_demos([path], ImportSpec(("mu",), env_values={"mu": 0.4}))
    assert errors == [] and ds.env.tolist() == [[0.4]]


# -- CSV: streams -------------------------------------------------------------------------------------------
def test_stream_files_are_named_name_underscore_stream_with_a_name():
    paths = [Path("a_ft.csv"), Path("_ft.csv"), Path("ab_ft.csv"), Path("b_mocap.csv")]
    assert gather(paths, CsvOptions(streams=("ft",))) == [
        Source(Path("a"), (Path("a_ft.csv"),)), Source(Path("_ft.csv")), Source(Path("ab"), (Path("ab_ft.csv"),)),
        Source(Path("b_mocap.csv"))]


def test_a_recording_missing_streams_or_with_a_short_row_is_named(tmp_path):
    for s in ("a", "b"):
        (tmp_path / f"rec_{s}.csv").write_text("t,y\n0,0.1\n0.01,0.1\n")
    opts = {"csv": CsvOptions(streams=("a", "b", "c", "d"))}
    _, errors = import_demos([tmp_path / "rec_a.csv", tmp_path / "rec_b.csv"], ImportSpec(()), opts)
    assert errors == [f"{tmp_path / 'rec'}: no rec_c.csv, rec_d.csv beside rec_a.csv, rec_b.csv (--streams a,b,c,d)"]
    (tmp_path / "rec_b.csv").write_text("t,f,label\n0,0.5,success\n0.01,0.5\n")
    opts = {"csv": CsvOptions(streams=("a", "b"))}
    _, errors = import_demos([tmp_path / "rec_a.csv", tmp_path / "rec_b.csv"], ImportSpec(()), opts)
    assert errors == [f"{tmp_path / 'rec_b.csv'}, row 3: 2 fields, the header has 3"]
    (tmp_path / "rec_b.csv").write_text("t,f,label\n0,0.5,success\n0.01,x,success\n")
    _, errors = import_demos([tmp_path / "rec_a.csv", tmp_path / "rec_b.csv"], ImportSpec(()), opts)
    assert errors == [f"{tmp_path / 'rec_b.csv'}, row 3, column 'f': 'x' is not a number"]


# -- time stamps, environment values, the crop ------------------------------------------------------------
def test_bad_time_stamps_are_named_by_the_field_whose_clock_they_are():
    t = T.copy()
    t[5] = np.nan
    with pytest.raises(ImportError_, match=r"^t\[5\]: nan is not finite$"):
        _check(t=t)
    own = T[::2].copy()  # f at its own rate, its 4th time stamp earlier than its 3rd
    own[3] = own[1]
    raw = RawDemo("rec", "demo", "rec:d", {"t": T, "y": Y, "f": F[::2]}, {}, 1, lambda c, i: f"{c}[{i}]",
                  times={"f": own})
    with pytest.raises(ImportError_, match=r"^f\[3\]: earlier time stamp 0\.02 \(time stamps must increase\)$"):
        check(raw, ImportSpec(()))
    raw = RawDemo("rec", "demo", "rec:d", {"t": T, "y": Y[::2], "f": F}, {}, 1, lambda c, i: f"{c}[{i}]",
                  times={"y": own})
    with pytest.raises(ImportError_, match=r"^y\[3\]: earlier time stamp"):
        check(raw, ImportSpec(()))


def test_nothing_left_after_the_start_is_refused():
    with pytest.raises(ImportError_, match=r"^rec: demo lasts 1\.4 s: nothing left after --start 1\.4 s$"):
        _check(ImportSpec((), start=float(T[-1])))


@pytest.mark.parametrize("values, kept", [
    ([0.4, 0.4, 0.4], 0.4), ([1e6, 1e6 + 1e-5, 1e6], 1e6),  # within 1e-9 of its size: constant
    ([0.4, 0.6, 0.4], None), ([2.0, 2.0 + 1e-8, 2.0], None), ([0.4, 0.4 + 1.5e-9, 0.4], None)])
def test_an_environment_value_must_be_constant_within_a_recording(values, kept):
    raw = RawDemo("rec", "demo", "rec:d", {"t": T, "y": Y, "f": F}, {"mu": np.array(values)}, 1,
                  lambda c, i: f"{c}[{i}]")
    if kept is None:
        with pytest.raises(ImportError_, match="^rec: environment value 'mu' changes within demo$"):
            check(raw, ImportSpec(("mu",)))
    else:
        assert check(raw, ImportSpec(("mu",))).env.tolist() == [kept]


def test_a_time_scale_converts_the_own_rate_channels_time_stamps_too(tmp_path):
    """t in ms; f on every other row, linear in time: resampled on the planner's grid in s."""
    rows = ["t,y,f,label"] + [f"{k * 10},0.1,{'' if k % 2 else f'{1 + 2 * k * 0.01:.6f}'},success" for k in range(121)]
    (tmp_path / "rec.csv").write_text("\n".join(rows) + "\n")
    ds, errors = import_demos([tmp_path / "rec.csv"], ImportSpec((), scale={"t": 1e-3}, end=1.0, horizon=20))
    assert errors == []
    tk = np.arange(21) * 0.05
    assert np.allclose(ds.commands[0][:, 2], 1 + 2 * np.minimum(tk, 1.0), atol=1e-9)


# -- span --------------------------------------------------------------------------------------------------
def test_span_covers_the_window_with_the_samples_at_or_beyond_its_ends():
    from judgeopt.data.recording import span

    t = np.array([0.0, 0.1, 0.2, 0.3, 0.4])
    assert span(t, 0.1, 0.3) == (1, 3) and span(t, 0.15, 0.25) == (1, 3) and span(t, -1.0, 9.0) == (0, 4)
    assert span(t, 0.0, 0.05) == (0, 1) and span(t, 0.2, 0.2 + 1e-13) == (2, 3) and span(t, 0.35, 0.4) == (3, 4)


def test_a_value_at_its_limit_is_kept_and_one_beyond_is_named_without_a_unit_hint_for_forces():
    f = F.copy()
    f[70] = 1000.0  # at the limit: plausible
    _check(f=f)
    f[70] = 2000.0
    with pytest.raises(ImportError_, match=r"^f\[70\]: 2000 is beyond 1000; expected SI units \(m, m/s, N\)$"):
        _check(f=f)


def test_a_velocity_at_its_own_rate_is_checked_over_its_own_samples_in_the_window():
    own = T[::2]
    v = np.full_like(own, 0.1)
    v[20] = np.nan  # at 0.4 s: inside the window from 0.3 s
    raw = RawDemo("rec", "demo", "rec:d", {"t": T, "y": Y, "ydot": v, "f": F}, {}, 1, lambda c, i: f"{c}[{i}]",
                  times={"ydot": own})
    with pytest.raises(ImportError_, match=r"^ydot\[20\]: nan is not finite$"):
        check(raw, ImportSpec((), start=0.3))


@pytest.mark.parametrize("kw, message", [
    ({"start": 0.5, "end": 0.5}, "--end 0.5 s must be after --start 0.5 s"),
    ({"env_values": {"nu": 1.0}}, "--env nu: not one of the environment names ['mu']; choose them with --env-names A,B"),
])
def test_a_window_ending_at_its_start_or_a_value_for_no_environment_name_is_refused(kw, message):
    with pytest.raises(ImportError_, match=f"^{re.escape(message)}$"):
        ImportSpec(("mu",), **kw)


def test_a_csv_row_of_the_wrong_length_or_no_rows_at_all_is_named(tmp_path):
    path = tmp_path / "rec.csv"
    path.write_text("t,y,f,label\n0,0.1,0.5,success\n0.01,0.1\n")
    _, errors = import_demos([path], ImportSpec(()))
    assert errors == [f"{path}, row 3: 2 fields, the header has 4"]
    path.write_text("t,y,f,label\n")
    _, errors = import_demos([path], ImportSpec(()))
    assert errors == [f"{path}: no rows below the header; a recording has a row per sample"]
