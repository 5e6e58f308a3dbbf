"""CasADi functions generated as C and compiled with gcc into one shared library, once per cache
folder: the judge's `compiled` backend and the compiled control step both build this way.

Why one place: the build is written in a temporary folder beside the final one and renamed into
place (files.publish_dir), so a half-built library is never loaded by another process, and a
missing or failing compiler is one clear error, not a traceback. source_digest is what every
built library's cache key holds of the code that generates it (here and in judgeopt.judge.casadi_fn).
"""

from __future__ import annotations

import hashlib
import inspect
import json
import logging
import os
import shutil
import subprocess
from pathlib import Path
from typing import Any, Sequence

import casadi as cs

from judgeopt.errors import Missing
from judgeopt.files import CACHE_FIX, make_temp_dir, publish_dir

log = logging.getLogger("judgeopt")


class CompileError(Missing, RuntimeError):
    """gcc is missing or failed; the message says which (gcc's last lines)."""


def source_digest(*parts: object) -> str:
    """sha256 (hex) of the source text of `parts` (modules, classes, functions; a str as it is).

    Why: a cached library is keyed by what it is built from, and the code that generates it is
    part of that; without it an edit to the generating code would load the old library with no
    word. The digest is of the set of texts (order and repeats do not matter), so the same code
    reached by two routes, or moved to another module unchanged, gives the same key. Where the
    source cannot be read (an install without .py files) the part's name and judgeopt's version
    stand in for it."""
    texts = set()
    for part in parts:
        if isinstance(part, str):
            texts.add(part)
            continue
        try:
            texts.add(inspect.getsource(part))  # type: ignore[arg-type]
        except (OSError, TypeError):
            import judgeopt

            name = getattr(part, "__qualname__", getattr(part, "__name__", repr(part)))
            texts.add(f"{getattr(part, '__module__', '')}.{name} (no source) judgeopt {judgeopt.__version__}")
    h = hashlib.sha256()
    for text in sorted(texts):
        data = text.encode()
        h.update(len(data).to_bytes(8, "little"))
        h.update(data)
    return h.hexdigest()


def compiled_library(functions: Sequence[cs.Function], where: Path, name: str, extra_c: str = "",
                     info: dict[str, Any] | None = None, note: str = "") -> tuple[Path, bool]:
    """`where`/lib`name`.so holding `functions` (and `extra_c` appended to their C), built now
    unless it is there already; returns the library and whether it was there. `note` is logged
    when a build starts (what is built, how long it takes)."""
    lib = where / f"lib{name}.so"
    if (where / "complete.json").exists() and lib.exists():
        return lib, True
    if shutil.which("gcc") is None:
        raise CompileError("gcc is not on PATH")
    if note:
        log.info(note)
    tmp = make_temp_dir(where, CACHE_FIX)  # a cache that cannot be written: one line naming $JUDGEOPT_CACHE
    try:
        cg = cs.CodeGenerator(f"{name}.c", {"with_header": False})
        for f in functions:
            cg.add(f)
        cg.generate(str(tmp) + os.sep)
        src = tmp / f"{name}.c"
        if extra_c:
            with src.open("a") as out:
                out.write(extra_c)
        res = subprocess.run(["gcc", "-O2", "-fPIC", "-shared", str(src), "-o", str(tmp / lib.name), "-lm"],
                             capture_output=True, text=True)
        if res.returncode != 0:
            raise CompileError(f"gcc failed building {name}: {res.stderr.strip()[-500:]}")
        (tmp / "complete.json").write_text(json.dumps({"casadi": cs.__version__, **(info or {})}))
        publish_dir(tmp, where)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return lib, False
