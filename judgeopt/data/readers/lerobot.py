"""LeRobot v3 datasets (what `lerobot-record` writes) read as recordings, frame by frame.

Read with pyarrow alone (the optional extra `judgeopt[lerobot]`), not with `lerobot`: only the
numeric frames are needed, not torch, video decoding or the Hub. Layout of a local folder:

    meta/info.json  "codebase_version": "v3.0" (any v3.x is read), "fps" and "data_path", the
                    data files' template (default data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet)
    data/chunk-000/file-000.parquet, ...  one row per frame, many episodes per file: episode_index,
                    frame_index, timestamp (s from the episode's start), observation.state, action,
                    next.reward, next.done, maybe next.success; a vector is a list of numbers per row

Each episode (its rows in every data file, grouped by `episode_index`) becomes one `RawDemo`, so
the checks, windows and resampling are the other formats'. Where each name is read
(`LeRobotOptions.keys`, the command's `--keys NAME=COLUMN[:INDEX]`, INDEX picking one element
of a vector column), by default:

    t        `timestamp`; else `frame_index` / fps; else the row's place in its episode / fps
    channels the column of the same name (y, f, ...): map them, e.g. y=observation.state:1
    success  `next.success`, else `next.reward`, else `next.done` (last value 1 or 0; with
             --success-threshold X: the largest `next.reward` >= X); labels that all come from
             `next.done` and are all 1 are refused (it is 1 at the end of every episode)
    <env>    the column of that name, else a number under that key in meta/info.json

Messages name the data file, the episode, the row in that file (0-based, as pyarrow and pandas
count) and the field; a bad episode is reported and the others are imported.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from judgeopt.data.readers.base import SUCCESS_THRESHOLD, Flag, Reader, Source
from judgeopt.data.recording import ImportError_, ImportSpec, RawDemo, env_fix, parse_keys, series_label, split_key

INFO = Path("meta") / "info.json"
DEFAULT_DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
#: where a label is looked for without --keys success=COLUMN, in this order
SUCCESS_COLUMNS = ("next.success", "next.reward", "next.done")
DONE_COLUMN = "next.done"
#: what to pass instead when every label comes from next.done
LABEL_HINT = ("map a success column with --keys success=COLUMN, or label from next.reward with "
                      "--success-threshold X")


@dataclass(frozen=True)
class LeRobotOptions:
    #: name -> "COLUMN" or "COLUMN:INDEX" (`--keys`); unmapped names are read where the docstring says
    keys: Mapping[str, str] = field(default_factory=dict)
    #: dense rewards: label 1 when the episode's largest next.reward is >= this
    success_threshold: float | None = None


def parse_lerobot_keys(text: str | None, spec: ImportSpec) -> dict[str, str]:
    """`y=observation.state:1,success=next.success` -> {"y": "observation.state:1", ...}, checked:
    t, the task's channels, success and the environment names, each with an optional INDEX."""
    return parse_keys(text, spec.env_names, [c.name for c in spec.channels], flag="--keys", scalars=("success",),
                      columns_everywhere=True)


def is_lerobot(path: Path) -> bool:
    """A folder with meta/info.json: a LeRobot dataset."""
    return path.is_dir() and (path / INFO).is_file()


def _pyarrow() -> tuple[Any, Any, Any]:
    """pyarrow, its compute and parquet modules, imported only when a LeRobot dataset is read."""
    try:
        import pyarrow as pa
        import pyarrow.compute as pc
        import pyarrow.parquet as pq
    except ImportError:
        raise ImportError_("reading a LeRobot dataset needs pyarrow: pip install 'judgeopt[lerobot]' "
                           "(or pip install pyarrow)") from None
    return pa, pc, pq


def read_info(root: Path) -> dict[str, Any]:
    """meta/info.json, checked to be a v3 dataset."""
    path = root / INFO
    try:
        info = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ImportError_(f"{path}: not readable JSON ({exc})") from None
    if not isinstance(info, dict):
        raise ImportError_(f"{path}: not a JSON object")
    version = str(info.get("codebase_version", ""))
    if not re.fullmatch(r"v3(\.\d+)*", version):
        raise ImportError_(f"{path}: codebase_version {version or 'missing'!r} is not supported; judgeopt reads "
                           "LeRobot v3.x datasets (convert older ones with lerobot's convert_dataset_v21_to_v30)")
    return info


def data_files(root: Path, info: dict[str, Any]) -> list[Path]:
    """The data files that info.json's `data_path` template names, in chunk and file order."""
    template = str(info.get("data_path") or DEFAULT_DATA_PATH)
    files = sorted(root.glob(re.sub(r"\{[^}]*\}", "*", template)))
    if not files:
        raise ImportError_(f"{root}: no data files matching {template!r} (meta/info.json's data_path)")
    return files


def fps(root: Path, info: dict[str, Any]) -> float:
    value = info.get("fps")
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
        raise ImportError_(f"{root / INFO}: 'fps' is {value!r}, not a positive number of frames per second")
    return float(value)


def _sources(spec: ImportSpec, options: LeRobotOptions, columns: list[str], info: dict[str, Any], file: Path
             ) -> dict[str, str]:
    """Where each name is read in one data file: NAME -> "COLUMN[:INDEX]" (see the module docstring)."""
    keys = options.keys
    out: dict[str, str] = {}

    def need(name: str, ref: str) -> None:
        if split_key(ref)[0] not in columns:
            raise ImportError_(f"{file}, field {name!r}: no column {split_key(ref)[0]!r} (the file has {columns}); "
                               f"map one with --keys {name}=COLUMN[:INDEX]")
        out[name] = ref

    for name in spec.names("position", "force"):
        need(name, keys.get(name, name))
    for name in (*spec.names("velocity"), *spec.env_names):
        if name in keys:
            need(name, keys[name])
        elif name in columns:
            out[name] = name
    for name in spec.env_names:
        if name not in out and name not in spec.env_values and not isinstance(info.get(name), (int, float)):
            raise ImportError_(f"{file}, field {name!r}: no column {name!r} and no number {name!r} in {INFO}; "
                               + env_fix(spec, [name], f"map a column with --keys {name}=COLUMN[:INDEX]"))
    if "t" in keys:
        need("t", keys["t"])
    elif "timestamp" in columns or "frame_index" in columns:
        out["t"] = "timestamp" if "timestamp" in columns else "frame_index"
    order = ("next.reward",) if options.success_threshold is not None else SUCCESS_COLUMNS
    found = [c for c in order if c in columns]
    if "success" in keys:
        need("success", keys["success"])
    elif found:
        out["success"] = found[0]
    elif spec.labels is None:
        raise ImportError_(f"{file}, field 'success': no column {' or '.join(map(repr, order))}; map one with "
                           "--keys success=COLUMN")
    need("episode_index", "episode_index")
    return out


def _column(pa: Any, pc: Any, table: Any, file: Path, name: str, ref: str) -> np.ndarray:
    """One column (or one element of a vector column) of a table as float64, one value per row."""
    col, index = split_key(ref)
    arr = table.column(col).combine_chunks()
    where = f"{file}, field {name!r} ({ref})"
    if arr.null_count:
        row = int(np.flatnonzero(arr.is_null().to_numpy(zero_copy_only=False))[0])
        raise ImportError_(f"{file}, row {row}, field {name!r} ({ref}): empty (null) value")
    kind = arr.type
    if pa.types.is_list(kind) or pa.types.is_large_list(kind) or pa.types.is_fixed_size_list(kind):
        lengths = pc.list_value_length(arr).to_numpy(zero_copy_only=False)
        if len(lengths) and (lengths != lengths[0]).any():
            row = int(np.flatnonzero(lengths != lengths[0])[0])
            raise ImportError_(f"{file}, row {row}, field {name!r} ({ref}): {lengths[row]} values, row 0 has "
                               f"{lengths[0]}")
        k = int(lengths[0]) if len(lengths) else 1
        flat = arr.flatten()
        if not (pa.types.is_integer(flat.type) or pa.types.is_floating(flat.type) or pa.types.is_boolean(flat.type)):
            raise ImportError_(f"{where}: column {col!r} holds lists of {flat.type}, not numbers")
        values = flat.to_numpy(zero_copy_only=False).astype(np.float64).reshape(-1, k)
        if index is None and k != 1:
            raise ImportError_(f"{where}: column {col!r} holds {k} values per row: choose one with "
                               f"--keys {name}={col}:INDEX")
        index = 0 if index is None else index
        if not -k <= index < k:
            raise ImportError_(f"{where}: index {index} is out of range for column {col!r} of {k} values per row")
        return values[:, index]
    if not (pa.types.is_integer(kind) or pa.types.is_floating(kind) or pa.types.is_boolean(kind)):
        raise ImportError_(f"{where}: column {col!r} holds {kind}, not numbers")
    if index is not None:
        raise ImportError_(f"{where}: column {col!r} holds one value per row; drop the :{index}")
    return arr.to_numpy(zero_copy_only=False).astype(np.float64)


@dataclass
class _Episode:
    """One episode's rows, gathered from every data file that holds some."""

    index: int
    files: list[Path] = field(default_factory=list)
    parts: list[tuple[int, np.ndarray, dict[str, np.ndarray]]] = field(default_factory=list)  # (file, rows, values)


def _read(file: Path, spec: ImportSpec, options: LeRobotOptions, info: dict[str, Any],
          episodes: dict[int, _Episode]) -> dict[str, str]:
    """Add one data file's rows to `episodes`; where each name was read."""
    pa, pc, pq = _pyarrow()
    try:
        columns = list(pq.read_schema(file).names)
        sources = _sources(spec, options, columns, info, file)
        table = pq.read_table(file, columns=sorted({split_key(r)[0] for r in sources.values()}))
    except (OSError, pa.ArrowException) as exc:
        raise ImportError_(f"{file}: not a readable parquet file ({exc})") from None
    values = {name: _column(pa, pc, table, file, name, ref) for name, ref in sources.items()}
    episode = values.pop("episode_index")
    if not (np.isfinite(episode).all() and (episode == np.round(episode)).all()):
        row = int(np.flatnonzero(~np.isfinite(episode) | (episode != np.round(episode)))[0])
        raise ImportError_(f"{file}, row {row}, field 'episode_index': {episode[row]:g} is not an episode number")
    for e in dict.fromkeys(episode.astype(np.int64).tolist()):  # in order of first appearance
        rows = np.flatnonzero(episode == e)
        ep = episodes.setdefault(e, _Episode(e))
        if file not in ep.files:
            ep.files.append(file)
        ep.parts.append((ep.files.index(file), rows, {n: v[rows] for n, v in values.items()}))
    return sources


def _raw(ep: _Episode, spec: ImportSpec, options: LeRobotOptions, info: dict[str, Any], sources: dict[str, str],
         root: Path) -> RawDemo:
    """One episode as a RawDemo: its rows concatenated, time and label worked out."""
    if any(set(p) != set(ep.parts[0][2]) for _, _, p in ep.parts):
        raise ImportError_(f"{ep.files[0]}: episode {ep.index} continues in {ep.files[1:]}, whose columns differ")
    which = np.concatenate([np.full(len(rows), f) for f, rows, _ in ep.parts])
    rows = np.concatenate([rows for _, rows, _ in ep.parts])
    v = {n: np.concatenate([p[n] for _, _, p in ep.parts]) for n in ep.parts[0][2]}
    desc = dict(sources)
    if sources.get("t") == "frame_index" and "t" not in options.keys:
        v["t"] = v["t"] / fps(root, info)
        desc["t"] = f"frame_index / fps {fps(root, info):g}"
    elif "t" not in v:
        v["t"] = np.arange(len(rows)) / fps(root, info)
        desc["t"] = f"row in the episode / fps {fps(root, info):g}"
    env = {n: v.pop(n) if n in sources else np.array([float(info[n])]) for n in spec.env_names
           if n not in spec.env_values}
    for n in spec.env_names:
        desc.setdefault(n, f"{INFO} key {n!r}")
    origin = ep.files[0]

    def where(c: str, i: int) -> str:
        if c in spec.env_names and c not in sources:
            return f"{root / INFO}, field {c!r} (key {c!r}), episode {ep.index}"
        return f"{ep.files[which[i]]}, episode {ep.index}, row {rows[i]}, field {c!r} ({desc[c]})"

    label = None if "success" not in sources else series_label(
        v.pop("success"), f"{origin}, episode {ep.index}, field 'success' ({sources['success']})",
        options.success_threshold)
    done = sources.get("success") == DONE_COLUMN and "success" not in options.keys
    return RawDemo(str(origin), f"episode {ep.index}", f"{root.name}:episode_{ep.index}", v, env, label, where,
                   label_from_done=DONE_COLUMN if done else "")


def read(source: Source, spec: ImportSpec, options: LeRobotOptions) -> tuple[list[RawDemo], list[str]]:
    """Every episode of a LeRobot v3 dataset folder as a RawDemo (values not yet checked), and
    one message per data file or episode that could not be read. Raises ImportError_ when the
    dataset as a whole cannot be read (no pyarrow, info.json, version, no data files)."""
    root = source.path
    _pyarrow()
    info = read_info(root)
    episodes: dict[int, _Episode] = {}
    sources: dict[Path, dict[str, str]] = {}
    errors = []
    for file in data_files(root, info):
        try:
            sources[file] = _read(file, spec, options, info, episodes)
        except ImportError_ as exc:
            errors.append(str(exc))
    raws = []
    for e in sorted(episodes):
        try:
            raws.append(_raw(episodes[e], spec, options, info, sources[episodes[e].files[0]], root))
        except ImportError_ as exc:
            errors.append(str(exc))
    return raws, errors


READER = Reader(
    "lerobot", "LeRobot v3", "LeRobot dataset folder (with meta/info.json)", read, LeRobotOptions, folder=is_lerobot,
    done_hint=LABEL_HINT, flags=(
        Flag("--keys", "keys", parse=parse_lerobot_keys, metavar="NAME=COLUMN[:INDEX],...", kind="map",
             does="maps LeRobot columns",
             help="where a LeRobot dataset keeps t, a channel, success or an environment value, e.g. "
             "'y=observation.state:1,f=observation.force:2,success=next.success' (:INDEX picks one element of a "
             "vector column; default: t from timestamp, success from next.success/next.reward/next.done, the rest "
             "from columns of their own name)"),
        SUCCESS_THRESHOLD,
    ))
