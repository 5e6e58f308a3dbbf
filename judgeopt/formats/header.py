"""Every file judgeopt writes starts with the same two keys, checked by one function: `format`
(what the file is) and `format_version` (raised when its layout changes, so an older judgeopt
refuses a newer file by name instead of misreading it). Calibration files written before this
used `version`; it is still read.
"""

from __future__ import annotations

from typing import Any, Mapping

VERSION_KEY = "format_version"
#: the version key some older files used
OLD_VERSION_KEYS = ("version",)


def header(fmt: str, version: int) -> dict[str, Any]:
    """The keys a file of `fmt` starts with."""
    return {"format": fmt, VERSION_KEY: version}


def check_header(doc: Mapping[str, Any] | Any, where: str, fmt: str, version: int,
                 error: type[Exception] = ValueError, what: str = "file") -> int:
    """The file's version, after checking its format is `fmt` and its version an integer no newer
    than `version` (`where`: the path, for the one-line error)."""
    if not isinstance(doc, Mapping) or doc.get("format") != fmt:
        got = doc.get("format") if isinstance(doc, Mapping) else type(doc).__name__
        raise error(f"{where}: not a judgeopt {what} (format is {got!r}, expected {fmt!r})")
    key = next((k for k in (VERSION_KEY, *OLD_VERSION_KEYS) if k in doc), None)
    if key is None:
        raise error(f"{where}: no {VERSION_KEY} in the {what}")
    found = doc[key]
    try:
        found = int(found)  # HDF5 attributes come back as numpy integers
    except (TypeError, ValueError):
        raise error(f"{where}: {VERSION_KEY} {doc[key]!r} is not an integer") from None
    if isinstance(doc[key], (bool, float, str)):
        raise error(f"{where}: {VERSION_KEY} {doc[key]!r} is not an integer")
    if found > version:
        raise error(f"{where}: {what} format version {found} is newer than this judgeopt reads ({version}); "
                    "update judgeopt")
    return found
