"""Writing files so that nothing already written is lost, hashing them, and finding shipped ones.

Every file judgeopt writes goes through `atomic_write`: a reader (or a crash) sees the old file
or the new one, never half of one.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path
from typing import Sequence

#: the source checkout, where the shipped problems and models live
REPO = Path(__file__).resolve().parents[1]


class OverwriteError(FileExistsError):
    """A command would replace a file the user has not said it may replace."""


def refuse_overwrite(paths, overwrite: bool, flag: str = "--out") -> None:
    """Nothing already written is replaced unless the user says so: one line naming the file."""
    if overwrite:
        return
    for p in map(Path, paths):
        if p.exists():
            raise OverwriteError(f"{p} exists: pass --overwrite to replace it, or choose another {flag}")


def shipped(path: str | Path) -> bool:
    """Is `path` inside the shipped models folder (written only when the user names it)?"""
    try:
        Path(path).resolve().relative_to((REPO / "models").resolve())
        return True
    except ValueError:
        return False


def atomic_write(path: str | Path, data: bytes | str) -> None:
    """Write `data` (text is UTF-8 encoded) to `path` through a temporary file and a rename."""
    path = Path(path)
    if isinstance(data, str):
        data = data.encode()
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; a shipped model should be readable
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def save_figure(fig, path: str | Path, dpi: int = 120) -> Path:
    """A matplotlib figure to `path` (format from its suffix), atomically; the figure is closed."""
    import io

    import matplotlib.pyplot as plt

    path = Path(path)
    buf = io.BytesIO()
    try:
        fig.savefig(buf, dpi=dpi, format=(path.suffix.lstrip(".") or "png"))
    finally:
        plt.close(fig)
    atomic_write(path, buf.getvalue())
    return path


def sha256_file(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def resolve(path: str | Path, suffixes: Sequence[str] = ("",)) -> Path:
    """A path as given if it exists, else a shipped file: relative to the source checkout, or in
    a task's own folder (`problems/paper_sim.toml` is judgeopt/tasks/scoop/problems/paper_sim.toml)."""
    p = Path(path)
    if p.is_absolute() or any(p.with_name(p.name + s).exists() for s in suffixes):
        return p
    for candidate in [REPO / p, *sorted((REPO / "judgeopt" / "tasks").glob(f"*/{p.as_posix()}"))]:
        if any(candidate.with_name(candidate.name + s).exists() for s in suffixes):
            return candidate
    return p
