"""Readers by name, and which one reads a path: the one place formats are told apart (the importer
reads with it, `judgeopt import-demos` lists folders and builds its flags from it). Adding a format
is an entry here.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable, Sequence

from judgeopt.data.readers import csv, hdf5, lerobot, mcap
from judgeopt.data.readers.base import Flag, Reader

#: in the order a path is offered to them: folders by content first, then suffixes
READERS: dict[str, Reader] = {r.name: r for r in (lerobot.READER, mcap.READER, hdf5.READER, csv.READER)}


def _head(path: Path, n: int) -> bytes:
    try:
        with open(path, "rb") as fh:
            return fh.read(n)
    except OSError:
        return b""  # its reader says what is wrong with it


def reader_for(path: str | Path) -> Reader | None:
    """The reader of `path`: by a folder's content, else by suffix, else by the file's first bytes,
    else the fallback (CSV). None for a folder no reader claims (a folder of recordings)."""
    path = Path(path)
    readers = list(READERS.values())
    found = next((r for r in readers if r.claims(path)), None)
    if found is not None or path.is_dir():
        return found
    head = _head(path, max((len(r.magic) for r in readers), default=0))
    found = next((r for r in readers if r.magic and head.startswith(r.magic)), None)
    return found or next(r for r in readers if r.fallback)


def listed(folder: Path, skip: Iterable[Path] = ()) -> list[Path]:
    """The recordings in a folder: the entries a reader claims by suffix or content, sorted."""
    skip = {Path(p).resolve() for p in skip}
    return sorted(p for p in folder.iterdir() if p.resolve() not in skip and any(r.claims(p) for r in READERS.values()))


def inputs(readers: Sequence[Reader] | None = None) -> str:
    """"a or b or c": what the readers read, for messages."""
    names = [r.inputs for r in (READERS.values() if readers is None else readers)]
    return " or ".join(names) if len(names) < 3 else f"{', '.join(names[:-1])} or {names[-1]}"


def flags() -> dict[str, tuple[Flag, tuple[Reader, ...]]]:
    """Every reader's flags by spelling, with the readers that take each; a spelling two readers
    declare differently is refused (one flag, one meaning)."""
    out: dict[str, tuple[Flag, tuple[Reader, ...]]] = {}
    for r in READERS.values():
        for f in r.flags:
            if f.spelling in out and out[f.spelling][0] != f:
                raise ValueError(f"reader {r.name!r} declares {f.spelling} unlike reader "
                                 f"{out[f.spelling][1][0].name!r}; share one Flag (judgeopt.data.readers.base)")
            out[f.spelling] = (f, (*out.get(f.spelling, (f, ()))[1], r))
    return out
