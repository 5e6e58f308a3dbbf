"""CasADi functions generated as C and compiled with gcc into one shared library, once per cache
folder: the judge's `compiled` backend and the compiled control step both build this way.

Why one place: the build is written in a temporary folder beside the final one and renamed into
place (files.publish_dir), so a half-built library is never loaded by another process, and a
missing or failing compiler is one clear error, not a traceback.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Any, Sequence

import casadi as cs

from judgeopt.errors import Missing
from judgeopt.files import publish_dir

log = logging.getLogger("judgeopt")


class CompileError(Missing, RuntimeError):
    """gcc is missing or failed; the message says which (gcc's last lines)."""


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
    where.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{where.name}.", dir=where.parent))
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
