"""Writing files so that nothing already written is lost, hashing them, and finding shipped ones.

Every file judgeopt writes goes through `atomic_write` (bytes or text) or `atomic_path` (a
writer that needs a file name): a reader (or a crash) sees the old file
or the new one, never half of one. A path that cannot be written (no permission, a read-only or
full disk, a file where a folder belongs) is one `OutputWriteError` (exit 5) naming it, raised
before any work by `refuse_overwrite`/`check_writable` and, should the disk change meanwhile, by
the writers themselves.
"""

from __future__ import annotations

import errno
import hashlib
import os
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterable, Iterator, Sequence

from judgeopt.errors import BadInput, JudgeoptError, OutputExists

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


def refuse_overwrite(paths, overwrite: bool, flag: str = "--out", writable: bool = True) -> None:
    """Nothing already written is replaced unless the user says so: one line naming the file. With
    `writable` (the default), an output that could not be written is refused here too, before any
    work is done, so that hours of training never end in a failed write."""
    paths = [Path(p) for p in paths]
    if not overwrite:
        for p in paths:
            if p.exists():
                raise OverwriteError(f"{p} exists: pass --overwrite to replace it, or choose another {flag}")
    if writable:
        check_writable(paths, flag)


class OutputWriteError(BadInput, OSError):
    """5: an output that cannot be written (no permission, a read-only or full disk, a file where a
    folder belongs): one line naming the path and the fix, never a traceback; what a command printed
    before stays printed. Made by `cannot_write`, which records `path`, `reason` and `flag`."""

    path: Path | None = None
    reason: str = ""
    flag: str | None = None

    def with_flag(self, flag: str | None) -> "OutputWriteError":
        """The same error naming the option that chose the path (known to the command, not the writer)."""
        return cannot_write(self.path, self.reason, flag) if self.path is not None else self


#: errno -> why a path cannot be written, as the message says it
_WHY = {errno.EACCES: "permission denied", errno.EPERM: "permission denied",
        errno.EROFS: "the file system is read-only", errno.ENOSPC: "no space left on the device",
        errno.EDQUOT: "the disk quota is exceeded", errno.EFBIG: "the file is too large for the file system",
        errno.EISDIR: "it is a folder", errno.ENAMETOOLONG: "the name is too long"}
#: failures of the disk itself (any file would fail): the fix is space, not another name
_FULL = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG}


def _blocking_file(path: Path) -> Path | None:
    """The first of `path`'s folders that exists as a file (so nothing can be made inside it)."""
    for p in reversed(path.parents):
        if p.exists() and not p.is_dir():
            return p
    return None


def cannot_write(path: str | Path, why: OSError | str, flag: str | None = None) -> OutputWriteError:
    """The one-line error for an output that cannot be written at `path`; `why` is the OSError (its
    errno says why) or the reason itself; `flag`, the option that chose the path, goes in the fix."""
    path = Path(path)
    if isinstance(why, OSError):
        blocker = _blocking_file(path)
        if why.errno in (errno.ENOTDIR, errno.EEXIST) and blocker is not None:
            reason = f"{blocker} is a file, not a folder"
        elif why.errno == errno.ENOENT:
            reason = f"its folder {path.parent} does not exist and could not be made"
        else:
            reason = _WHY.get(why.errno) or why.strerror or type(why).__name__
        full = why.errno in _FULL
    else:
        reason, full = why, any(_WHY[e] == why for e in _FULL)
    fix = "free some space or choose another folder" if full else "choose a writable folder"
    exc = OutputWriteError(f"cannot write {path}: {reason}; {fix}{f' with {flag}' if flag else ''}")
    exc.path, exc.reason, exc.flag = path, reason, flag
    return exc


def _unwritable(path: Path) -> str | None:
    """Why nothing could be written at `path` (a file to write or a folder to fill), or None: its
    nearest existing folder must be a folder this process may write in, on a writable file system.
    Nothing is created; as root only a read-only file system or a file in the way refuses."""
    p = path if path.is_dir() else path.parent
    while not p.exists() and p != p.parent:
        p = p.parent
    if not p.is_dir():
        return f"{p} is a file, not a folder"
    try:
        if os.statvfs(p).f_flag & os.ST_RDONLY:
            return _WHY[errno.EROFS]
    except (OSError, AttributeError):  # no statvfs (Windows): access() below still answers
        pass
    if not os.access(p, os.W_OK | os.X_OK):
        return _WHY[errno.EACCES] + ("" if p == path.parent or p == path else f" in {p}")
    return None


def check_writable(paths: Iterable[str | Path], flag: str | None = "--out") -> None:
    """Refuse, before any work, an output that could not be written (OutputWriteError, exit 5)."""
    for p in map(Path, paths):
        reason = _unwritable(p)
        if reason is not None:
            raise cannot_write(p, reason, flag)


def _write_failure(exc: BaseException, *paths: Path) -> bool:
    """Is `exc` a failure to write one of `paths` (not, say, a bad value, or a file read meanwhile)?"""
    if not isinstance(exc, OSError) or isinstance(exc, JudgeoptError):
        return False
    if exc.errno in _FULL:
        return True
    return exc.errno in _WHY and (exc.filename is None or Path(exc.filename) in paths)


def make_temp_dir(path: str | Path, flag: str | None = None) -> Path:
    """A temporary folder beside `path` (for a writer that writes a folder, e.g. a ROS bag or a built
    library), made with `path`'s folder; a path that cannot be written is an OutputWriteError naming
    `path` (and `flag`, what chose it, in the fix)."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        return Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp"))
    except OSError as exc:
        raise cannot_write(path, exc, flag) from None


#: what a cache folder that cannot be written tells the user to change
CACHE_FIX = f"${CACHE_ENV}"


def make_cache_dir(path: str | Path) -> Path:
    """`path`, a folder of the build cache, made where missing: one that cannot be made is one line
    saying to point $JUDGEOPT_CACHE elsewhere (OutputWriteError, exit 5), not a PermissionError."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise cannot_write(path, exc, CACHE_FIX) from None
    return path


def shipped(path: str | Path) -> bool:
    """Is `path` inside the shipped models folder (written only when the user names it)?"""
    try:
        Path(path).resolve().relative_to(shipped_models().resolve())
        return True
    except ValueError:
        return False


#: every file this process has written whole (by `atomic_path`), in order: what Ctrl-C's line names
WRITTEN: list[Path] = []


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary file beside `path` for a writer that needs a file name (HDF5, GIF, npz):
    it becomes `path` by a rename when the block ends, and is removed if the block raises.
    Its mode follows the umask like an ordinary new file (mkstemp alone makes it 0600)."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    except OSError as exc:  # a read-only folder, a file where a folder belongs: one line, not a traceback
        raise cannot_write(path, exc) from None
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_current_umask())
        os.replace(tmp, path)
        WRITTEN.append(path)
    except BaseException as exc:
        tmp.unlink(missing_ok=True)
        if _write_failure(exc, tmp, path):  # a full disk while writing, a folder named `path`
            raise cannot_write(path, exc) from None
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
