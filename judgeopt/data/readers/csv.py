"""CSV recordings: one file per demonstration, or one table with a `demo_id` column; a lab's own
files as recorded (mapped header, streams at their own rates, streams in files of their own).

Format (header row required, SI units; the scoop's names, each task its own channels):

    demo_id  optional; without it the file is one demonstration
    t        time stamps in s, strictly increasing, any rate and origin (UNIX time is fine)
    y        position along the scooping direction in m (each position channel of the task)
    ydot     optional velocity in m/s (derived from y when missing)
    f        pressing force in N, pressing positive (each force channel)
    label    success or failure (also 1/0, true/false), the same on every row of a demonstration
    <env>    each of the task's environment values (`--env-names`), constant within a demonstration

Options (`CsvOptions`): `--columns t=time,y=tool_y_m,f=fz_N` maps the header; `--streams
mocap,ft` merges NAME_mocap.csv and NAME_ft.csv, side by side on time, into the recording NAME.
A channel whose cells are empty on some rows was recorded at its own rate (motion capture at
120 Hz, force at 1 kHz on other rows): each keeps its own time stamps. A labels file and `--env`
stand in for the label and environment columns (`ImportSpec`). A file is imported whole or not at
all: one table is one recording session. Messages name the file, row (as a spreadsheet numbers
it, the header being row 1) and column.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from judgeopt.data.labels import FILE_COLUMNS, LABEL_COLUMNS
from judgeopt.data.readers.base import Flag, Reader, Source
from judgeopt.data.recording import LABELS, ImportError_, ImportSpec, RawDemo, env_fix, parse_keys
from judgeopt.formats.table_csv import TableError, read_table

#: rows of a table: (where the row is, for messages; its cells)
Rows = list[tuple[str, list[str]]]


@dataclass(frozen=True)
class CsvOptions:
    #: name -> header column (`--columns t=time,y=tool_y_m,f=fz_N`); unmapped names are their own column
    columns: Mapping[str, str] = field(default_factory=dict)
    #: a recording kept as one CSV file per stream, NAME_<stream>.csv (`--streams mocap,ft`), merged on time
    streams: tuple[str, ...] = ()

    def column(self, name: str) -> str:
        """The header a name is read from."""
        return self.columns.get(name, name)


def parse_columns(text: str | None, spec: ImportSpec) -> dict[str, str]:
    """`t=time,y=tool_y_m` -> {"t": "time", "y": "tool_y_m"}, checked against the task and environment."""
    return parse_keys(text, spec.env_names, spec.names("position", "velocity", "force"), flag="--columns",
                      scalars=("label", "demo_id"))


def parse_streams(text: str | None, spec: ImportSpec | None = None) -> tuple[str, ...]:
    """`mocap,ft` -> ("mocap", "ft"); a stream named twice is refused."""
    streams = tuple(s.strip() for s in (text or "").split(",") if s.strip())
    twice = sorted({s for s in streams if streams.count(s) > 1})
    if twice:
        raise ImportError_(f"--streams: {twice[0]!r} is named twice; name each stream once, e.g. --streams mocap,ft")
    return streams


def required(spec: ImportSpec) -> tuple[str, ...]:
    """The names every file must have a column for (before --columns renames them)."""
    return ("t", *spec.names("position", "force"), *(() if spec.labels is not None else ("label",)),
            *(n for n in spec.env_names if n not in spec.env_values))


def _read(path: Path) -> tuple[list[str], list[list[str]]]:
    try:
        return read_table(path)
    except TableError as exc:
        raise ImportError_(str(exc)) from None


#: what a column of each kind is often called instead (first word of its header, any case): the
#: column --columns is suggested to map (time, a force, a position, a velocity, the outcome)
SYNONYMS = {"t": ("time", "timestamp", "stamp", "times", "seconds", "sec"),
            "force": ("force", "fz", "fy", "fx", "wrench", "load"), "position": ("pos", "position"),
            "velocity": ("vel", "velocity", "speed"), "label": LABEL_COLUMNS}


def _looks_like_labels(header: list[str], spec: ImportSpec, options: CsvOptions) -> bool:
    """A labels file (recording, outcome) rather than a recording: a recording column and an outcome
    column, and neither time stamps nor any channel (a recording missing one column is no labels file)."""
    lower = {c.strip().lower() for c in header}
    samples = ("t", *spec.names("position", "velocity", "force"))
    return bool(lower & set(FILE_COLUMNS)) and bool(lower & set(LABEL_COLUMNS)) and not any(
        options.column(n) in header for n in samples)


def _similar(name: str, kind: str, header: list[str], taken: set[str]) -> str | None:
    """The one header column that is likely `name` under another name (`force` or `fz_N` for f,
    `time` for t, `F` for f), or None where there is none or more than one."""
    words = {c: [w for w in re.split(r"[^0-9a-z]+", c.strip().lower()) if w] for c in header if c not in taken}
    same = [c for c, w in words.items() if c.strip().lower() == name.lower()]
    if same:
        return same[0] if len(same) == 1 else None
    alike = [c for c, w in words.items() if w and (w[0] == name.lower() or w[0] in SYNONYMS.get(kind, ()))]
    return alike[0] if len(alike) == 1 else None


#: the placeholder a fix shows where no column of the header looks like the one missing
COLUMN = "COLUMN"


def _missing(path: Path, header: list[str], spec: ImportSpec, options: CsvOptions) -> None:
    """Refuse a file without a column it needs, with the fix: a labels file is passed with --labels;
    a channel is mapped with --columns (to the header's column of a similar name, where there is
    one); an environment value is left out, given or mapped."""
    missing = [c for c in required(spec) if options.column(c) not in header]
    if not missing:
        return
    if _looks_like_labels(header, spec, options):
        raise ImportError_(f"{path}: a labels file, not a recording; pass it with --labels {path}")
    named = [f"{c}={options.column(c)}" if c in options.columns else c for c in missing]
    env = [c for c in missing if c in spec.env_names]
    channels = [c for c in missing if c not in env]
    kinds = {"t": "t", "label": "label", **{c.name: c.kind for c in spec.channels}}
    known = ("demo_id", "label", "t", *spec.names("position", "velocity", "force"), *spec.env_names)
    taken = {options.column(n) for n in known if options.column(n) in header}
    suggested = {}
    for c in channels:
        col = _similar(c, kinds.get(c, ""), header, taken | set(suggested.values()))
        if col is not None:
            suggested[c] = col
    fixes = [f"map {'it' if len(channels) == 1 else 'them'} with --columns "
             f"{','.join(f'{c}={suggested.get(c, COLUMN)}' for c in channels)}"] if channels else []
    if env:
        fixes.append("for the environment: " * bool(channels) + env_fix(
            spec, env, f"map {'a column' if len(env) == 1 else 'columns'} with --columns "
                       f"{','.join(f'{c}=COLUMN' for c in env)}"))
    raise ImportError_(f"{path}: missing column(s) {named}; the header has {header}; {', and '.join(fixes)}")


def _table(source: Source, options: CsvOptions) -> tuple[list[str], Rows]:
    """The header and rows of one file, or of the stream files of one recording side by side
    (each file's rows blank in the others' columns); a recording missing one of its streams is refused."""
    if not source.parts:
        header, lines = _read(source.path)
        return header, [(f"{source.path}, row {r}", row) for r, row in enumerate(lines, start=2)]
    present = {_stream(p, options.streams) for p in source.parts}
    missing = [s for s in options.streams if s not in present]
    if missing:
        name = source.path.name
        raise ImportError_(f"{source.path}: no {', '.join(f'{name}_{s}.csv' for s in missing)} beside "
                           f"{', '.join(f.name for f in source.parts)} (--streams {','.join(options.streams)})")
    tables = [(f, *_read(f)) for f in source.parts]
    for f, head, lines in tables:
        short = next(((r, len(row)) for r, row in enumerate(lines, start=2) if len(row) != len(head)), None)
        if short:
            raise ImportError_(f"{f}, row {short[0]}: {short[1]} fields, the header has {len(head)}")
    header = list(dict.fromkeys(h for _, head, _ in tables for h in head))
    return header, [(f"{f}, row {r}", [row[head.index(h)] if h in head else "" for h in header])
                    for f, head, lines in tables for r, row in enumerate(lines, start=2)]


def read(source: Source, spec: ImportSpec, options: CsvOptions) -> tuple[list[RawDemo], list[str]]:
    """A CSV file (or the stream files of one recording) as raw demonstrations: numbers and
    labels parsed, nothing else checked. A channel with empty cells was recorded at its own rate:
    its rows with a value are its samples."""
    path = source.path
    header, rows = _table(source, options)
    _missing(path, header, spec, options)
    col = {name: header.index(options.column(name)) for name in
           ("demo_id", "label", "t", *spec.names("position", "force", "velocity"), *spec.env_names)
           if options.column(name) in header}
    numeric = ["t", *spec.names("position", "force"), *(c for c in spec.names("velocity") if c in col),
               *(c for c in spec.env_names if c in col and c not in spec.env_values)]
    groups: dict[str, Rows] = {}
    for r, row in rows:
        if not row:  # a blank line is no sample
            continue
        if len(row) != len(header):
            raise ImportError_(f"{r}: {len(row)} fields, the header has {len(header)}")
        key = row[col["demo_id"]].strip() if "demo_id" in col else path.stem
        groups.setdefault(key, []).append((r, row))
    if not groups:
        raise ImportError_(f"{path}: no rows below the header; a recording has a row per sample")
    return [_demo(path, spec, options, key, items, col, numeric) for key, items in groups.items()], []


def _demo(path: Path, spec: ImportSpec, options: CsvOptions, key: str, items: Rows, col: dict[str, int],
          numeric: list[str]) -> RawDemo:
    values: dict[str, np.ndarray] = {}
    rows_of: dict[str, np.ndarray] = {}  # per field: the item indices holding its values
    for c in numeric:
        v, at = [], []
        for k, (r, row) in enumerate(items):
            cell = row[col[c]].strip()
            if not cell and c != "t":
                continue
            try:
                v.append(float(cell))
            except ValueError:
                raise ImportError_(f"{r}, column {options.column(c)!r}: {row[col[c]]!r} is not a number") from None
            at.append(k)
        if not v:
            raise ImportError_(f"{path}: demonstration {key!r}: column {options.column(c)!r} is empty")
        values[c], rows_of[c] = np.array(v), np.array(at)
    label = None if spec.labels is not None else _label(path, options, key, items, col["label"])
    t = values["t"]
    times = {c: t[rows_of[c]] for c in values if c != "t" and len(rows_of[c]) != len(items)}

    def where(c: str, i: int) -> str:
        rows = rows_of.get(c, rows_of["t"])
        return f"{items[int(rows[i])][0]}, column {options.column(c)!r}"

    def shown(c: str, i: int) -> str:
        rows = rows_of.get(c, rows_of["t"])
        return repr(items[int(rows[i])][1][col[c]])

    channels = ("t", *spec.names("position", "force", "velocity"))
    return RawDemo(str(path), f"demonstration {key!r}", f"{path.name}:{key}",
                   {c: values[c] for c in channels if c in values},
                   {c: values[c] for c in spec.env_names if c in values}, label, where, shown, times=times)


def _label(path: Path, options: CsvOptions, key: str, items: Rows, at: int) -> int:
    """The one label of a demonstration's rows (blank cells skipped)."""
    labels = set()
    for r, row in items:
        lab = row[at].strip().lower()
        if not lab:
            continue
        if lab not in LABELS:
            raise ImportError_(f"{r}, column {options.column('label')!r}: {row[at]!r} is not success/failure")
        labels.add(LABELS[lab])
    if len(labels) != 1:
        raise ImportError_(f"{path}: demonstration {key!r} has " + ("both labels; a demonstration has one outcome"
                           if labels else "no label; fill the label column or give --labels FILE"))
    return labels.pop()


def _stream(p: Path, streams: Sequence[str]) -> str | None:
    """Which of `streams` a CSV file NAME_<stream>.csv holds, or None."""
    return next((s for s in streams if p.suffix.lower() == ".csv" and p.stem.endswith(f"_{s}")
                 and len(p.stem) > len(s) + 1), None)


def gather(paths: Sequence[Path], options: CsvOptions) -> list[Source]:
    """With --streams A,B: the files NAME_A.csv, NAME_B.csv, ... of one recording as one source
    NAME (at the place of its first file; `read` refuses it when a stream is missing); every
    other path as it is."""
    out: list[Source | Path] = []
    groups: dict[Path, dict[str, Path]] = {}
    for p in paths:
        stream = _stream(p, options.streams)
        if stream is None:
            out.append(Source(p))
            continue
        name = p.with_name(p.stem[:-len(stream) - 1])
        if name not in groups:
            out.append(name)
        groups.setdefault(name, {})[stream] = p
    return [item if isinstance(item, Source) else
            Source(item, tuple(groups[item][s] for s in options.streams if s in groups[item])) for item in out]


READER = Reader(
    "csv", "CSV", ".csv file", read, CsvOptions, suffixes=(".csv",), fallback=True, whole=True, gather=gather,
    flags=(
        Flag("--columns", "columns", parse=parse_columns, metavar="NAME=COLUMN,...", kind="map",
             does="maps CSV header columns",
             help="where a CSV file keeps t, a channel (the scoop's y, ydot, f), label, demo_id or an environment "
             "value, e.g. 't=time,y=tool_y_m,f=fz_N' (default: columns of those names). A channel whose cells are "
             "empty on some rows was recorded at its own rate"),
        Flag("--streams", "streams", parse=parse_streams, metavar="A,B", does="merges the CSV files of one recording",
             help="a recording kept as one CSV per stream, NAME_A.csv and NAME_B.csv (e.g. --streams mocap,ft: "
             "demo_01_mocap.csv with t,y and demo_01_ft.csv with t,f), merged on time (default: one file per "
             "recording)"),
    ))
