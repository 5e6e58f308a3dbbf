"""Writing files so that nothing already written is lost, hashing them, and finding shipped ones.

Every file judgeopt writes goes through `atomic_write` (bytes or text) or `atomic_path` (a
writer that needs a file name): a reader (or a crash) sees the old file
or the new one, never half of one.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, Sequence

from judgeopt.errors import OutputExists

#: the installed package: shipped models in models/, each task's problems in tasks/NAME/problems/
PACKAGE = Path(__file__).resolve().parent
#: the source checkout (in an installed wheel, site-packages): git provenance, data/, docs/
REPO = PACKAGE.parent
#: where `models/NAME` is looked up first (your own models folder), before the shipped one
MODELS_ENV = "JUDGEOPT_MODELS"
#: where built judge libraries and generated robot descriptions are kept
CACHE_ENV = "JUDGEOPT_CACHE"


def shipped_models() -> Path:
    """The models shipped inside the package (the checkout's `models/` links here)."""
    return PACKAGE / "models"


def models_dir() -> Path:
    """$JUDGEOPT_MODELS if set, else the shipped models."""
    env = os.environ.get(MODELS_ENV)
    return Path(env) if env else shipped_models()


def cache_dir() -> Path:
    """$JUDGEOPT_CACHE if set, else the platform's user cache folder (~/.cache/judgeopt on Linux)."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env)
    from platformdirs import user_cache_dir

    return Path(user_cache_dir("judgeopt", appauthor=False))


class OverwriteError(OutputExists, FileExistsError):
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
        Path(path).resolve().relative_to(shipped_models().resolve())
        return True
    except ValueError:
        return False


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary file beside `path` for a writer that needs a file name (HDF5, GIF, npz):
    it becomes `path` by a rename when the block ends, and is removed if the block raises.
    Its mode follows the umask like an ordinary new file (mkstemp alone makes it 0600)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_current_umask())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _current_umask() -> int:
    """The process's umask, read where the system shows it (Linux: /proc/self/status), so that
    no other thread ever sees it changed; elsewhere set and restored at once."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    umask = os.umask(0)
    os.umask(umask)
    return umask


def atomic_write(path: str | Path, data: bytes | str) -> None:
    """Write `data` (text is UTF-8 encoded) to `path` through a temporary file and a rename."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data.encode() if isinstance(data, str) else data)


def save_figure(fig, path: str | Path, dpi: int = 120) -> Path:
    """A matplotlib figure to `path` (format from its suffix), atomically. judgeopt's plot
    functions return `matplotlib.figure.Figure`s that pyplot does not hold; a pyplot figure is
    closed here so a loop of saves frees them. Neither chooses nor changes the backend."""
    import io
    import sys

    path = Path(path)
    buf = io.BytesIO()
    try:
        fig.savefig(buf, dpi=dpi, format=(path.suffix.lstrip(".") or "png"))
    finally:
        pyplot = sys.modules.get("matplotlib.pyplot")  # a figure pyplot holds exists only once it is imported
        if pyplot is not None:
            pyplot.close(fig)
    atomic_write(path, buf.getvalue())
    return path


def publish_dir(tmp: str | Path, where: str | Path, marker: str = "complete.json") -> None:
    """Move a finished build folder `tmp` into place at `where` by a rename, so a reader sees a
    whole build or none; if another process won the race (its `marker` is there), keep its copy."""
    import shutil

    tmp, where = Path(tmp), Path(where)
    try:
        os.replace(tmp, where)
    except OSError:
        if not (where / marker).exists():
            shutil.rmtree(where, ignore_errors=True)
            os.replace(tmp, where)


def sha256_file(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def resolve(path: str | Path, suffixes: Sequence[str] = ("",)) -> Path:
    """A path as given if it exists, else a shipped file, so the same names work from any folder
    and from an installed wheel: `models/NAME` in $JUDGEOPT_MODELS, then in the shipped models;
    `problems/NAME.toml` in a task's own folder (judgeopt/tasks/scoop/problems/paper_sim.toml);
    anything else relative to the source checkout."""
    p = Path(path)
    if p.is_absolute() or any(p.with_name(p.name + s).exists() for s in suffixes):
        return p
    candidates = [REPO / p, *sorted((PACKAGE / "tasks").glob(f"*/{p.as_posix()}"))]
    if p.parts and p.parts[0] == "models":
        rest = Path(*p.parts[1:]) if len(p.parts) > 1 else Path()
        candidates = [models_dir() / rest, shipped_models() / rest, *candidates]
    for candidate in candidates:
        if any(candidate.with_name(candidate.name + s).exists() for s in suffixes):
            return candidate
    return p
