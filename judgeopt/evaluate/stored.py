"""The plan rows an evaluation wrote, read back.

Every evaluation (`judgeopt evaluate tables|sweep|edge|band`, the refinement rounds) saves its rows in
chunks, FOLDER/partial/*.json, so a killed run resumes. Calibration, inspection, the refinement loop
and the analysis scripts all read them back here, so a damaged chunk is reported the same way
everywhere.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path

from judgeopt.errors import BadInput, OutputExists


class StoredRowsError(BadInput, ValueError):
    """An evaluation folder with no rows, or a damaged chunk."""


def chunk_files(folder: str | Path) -> list[Path]:
    """The folder's saved chunks, in the order they were numbered."""
    return sorted((Path(folder) / "partial").glob("*.json"))


def read_chunk(path: Path) -> list[dict]:
    """One chunk's rows; a chunk a killed run left half-written says how to redo it."""
    try:
        rows = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise StoredRowsError(f"{path}: unreadable ({type(exc).__name__}): a damaged chunk: delete it and rerun the "
                              "evaluation to redo it") from None
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise StoredRowsError(f"{path}: not a list of plan rows: delete it and rerun the evaluation to redo it")
    return rows


def read_rows(folders: str | Path | Iterable[str | Path]) -> list[dict]:
    """Every row of one or more evaluation folders; a folder without any is an error, not an empty list."""
    rows: list[dict] = []
    for folder in [folders] if isinstance(folders, (str, Path)) else folders:
        files = chunk_files(folder)
        if not files:
            raise StoredRowsError(f"{folder}: no evaluated plans (expected {Path(folder) / 'partial'}/*.json from "
                                  "`judgeopt evaluate ... --out FOLDER`)")
        for f in files:
            rows += read_chunk(f)
    return rows


def refuse_other_runs(paths: Iterable[Path]) -> None:
    """Stop before a run writes its chunks (`paths`) beside another run's: read back together, the
    two would count each setting twice. A rerun of the same command resumes; other options (--n,
    --seed, --chunk, the band, the models) need another --out."""
    paths = list(paths)
    ours = set(paths)
    for folder in dict.fromkeys(p.parent.parent for p in paths):
        others = [f for f in chunk_files(folder) if f not in ours]
        if others:
            raise OutputExists(f"{folder} holds {len(others)} chunks of another run ({others[0].name}): rerun that "
                               "command to resume it (the same --n, --seed, --chunk and models), or give another --out")
