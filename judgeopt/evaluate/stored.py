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

from judgeopt.errors import BadInput


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
