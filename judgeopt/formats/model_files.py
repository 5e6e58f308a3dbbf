"""A saved model: `<name>.pt` (a plain torch state_dict, loaded with weights_only=True: no
pickled code) next to `<name>.json` (format, format_version, everything else, and the sha256 of
the .pt, so a weights file swapped or damaged after saving is caught on load). One writer and one
reader for every kind: judges (judgeopt.judge.store), generators (judgeopt.planners.store).

The same weights as numpy arrays are kept in the cache (`weights/<sha256 of the .pt>.npz`, written
atomically when a model is saved or first read through torch): a one-shot solve reads them with
`read_arrays` and needs no torch (judgeopt.judge.compiled says why). The .pt stays the model; the
copy is checked against the .pt's recorded sha256 on every read and is rebuilt from it where missing.
"""

from __future__ import annotations

import hashlib
import io
import json
import logging
from pathlib import Path
from typing import Any, Sequence

from judgeopt.errors import BadInput, JudgeoptError
from judgeopt.files import atomic_write, cache_dir
from judgeopt.formats.header import check_header

log = logging.getLogger("judgeopt")
#: the entry of a weights copy that names the .pt it was made from (its sha256)
SOURCE_KEY = "__weights_sha256__"


class ModelFileError(BadInput, ValueError):
    """A model file that is missing, unreadable, corrupt or inconsistent with its metadata."""


def model_paths(path: str | Path) -> tuple[Path, Path]:
    """`models/x`, `models/x.pt` or `models/x.json` -> (models/x.pt, models/x.json)."""
    p = Path(path)
    if p.suffix in (".pt", ".json"):
        p = p.with_suffix("")
    return p.with_name(p.name + ".pt"), p.with_name(p.name + ".json")


def write_model(model: Any, path: str | Path, record: dict[str, Any]) -> tuple[Path, Path]:
    """The weights to `<path>.pt`, then `record` plus the weights' name and sha256 to
    `<path>.json`, each atomically (shared by every saved model: judges and generators)."""
    import torch

    pt, js = model_paths(path)
    buf = io.BytesIO()
    torch.save({k: v.detach().cpu() for k, v in model.state_dict().items()}, buf)
    data = buf.getvalue()
    atomic_write(pt, data)
    record = {**record, "weights_file": pt.name, "weights_sha256": hashlib.sha256(data).hexdigest()}
    atomic_write(js, (json.dumps(record, indent=2, sort_keys=False) + "\n").encode())
    remember_arrays(record["weights_sha256"], {k: v.detach().cpu().numpy() for k, v in model.state_dict().items()})
    return pt, js


def read_meta(path: str | Path, fmt: str, version: int, required: Sequence[str] = ("config", "weights_sha256"),
              error: type[Exception] = ModelFileError, hint: str = "", kind: str = "model") -> dict[str, Any]:
    """A model's JSON metadata, validated for format, version and the keys loading needs
    (`error`: the model kind's file error; `hint`: how to make one)."""
    _, js = model_paths(path)
    if not js.exists():
        raise error(f"{js}: no such {kind} metadata file" + (f" ({hint})" if hint else ""))
    try:
        meta = json.loads(js.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise error(f"{js}: corrupt {kind} metadata, not valid JSON ({exc})") from exc
    check_header(meta, str(js), fmt, version, error, f"{fmt.removeprefix('judgeopt-')} metadata file")
    missing = [k for k in required if k not in meta]
    if missing:
        raise error(f"{js}: metadata lacks {missing}")
    return meta


def read_weights(path: str | Path, meta: dict[str, Any], error: type[Exception] = ModelFileError,
                 check_hash: bool = True) -> dict[str, Any]:
    """The state_dict next to the metadata, checked against its recorded sha256."""
    import torch

    pt, js = model_paths(path)
    if not pt.exists():
        raise error(f"{pt}: no such weights file (its metadata {js.name} exists)")
    data = pt.read_bytes()
    if check_hash and hashlib.sha256(data).hexdigest() != meta["weights_sha256"]:
        raise error(f"{pt}: weights file does not match the sha256 recorded in {js.name} "
                    "(damaged, or replaced after saving)")
    try:
        state = torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises several types for corrupt files
        raise error(f"{pt}: corrupt weights file, torch cannot read it ({type(exc).__name__}: {exc})") from exc
    if check_hash and isinstance(state, dict):
        remember_arrays(meta["weights_sha256"], {k: v.detach().cpu().numpy() for k, v in state.items()
                                                 if isinstance(v, torch.Tensor)})
    return state


def arrays_path(weights_sha256: str) -> Path:
    """Where the numpy copy of the weights whose .pt has this sha256 is kept."""
    return cache_dir() / "weights" / f"{weights_sha256}.npz"


def remember_arrays(weights_sha256: str, state: dict[str, Any]) -> None:
    """Keep a numpy copy of a state_dict (numpy arrays) for `read_arrays`, written atomically, unless
    one is there; a cache that cannot be written only costs the next run its fast start."""
    import numpy as np

    path = arrays_path(weights_sha256)
    if path.is_file():
        return
    buf = io.BytesIO()
    np.savez(buf, **{SOURCE_KEY: np.array(weights_sha256)}, **state)
    try:
        atomic_write(path, buf.getvalue())
    except (OSError, JudgeoptError) as exc:  # judgeopt.files raises its own one-line error for an unwritable cache
        log.debug("weights copy not written (%s): the next solve reads the .pt with torch", exc)


def read_arrays(path: str | Path, meta: dict[str, Any]) -> dict[str, Any] | None:
    """The weights of the model at `path` as numpy arrays, without torch: the cache's copy, where
    the .pt still has its recorded sha256 and the copy names that sha256 and holds only numbers;
    None otherwise (read the .pt with `read_weights`, which makes the copy)."""
    import numpy as np

    pt, _ = model_paths(path)
    copy = arrays_path(meta["weights_sha256"])
    try:
        if not copy.is_file() or hashlib.sha256(pt.read_bytes()).hexdigest() != meta["weights_sha256"]:
            return None
        with np.load(copy, allow_pickle=False) as npz:
            state = {k: npz[k] for k in npz.files}
    except (OSError, ValueError, EOFError) as exc:  # unreadable or not an npz: the .pt is read instead
        log.debug("ignoring the weights copy %s (%s)", copy, exc)
        return None
    if str(state.pop(SOURCE_KEY, "")) != meta["weights_sha256"] or \
            not all(np.issubdtype(a.dtype, np.number) for a in state.values()):
        log.debug("ignoring the weights copy %s: not of %s", copy, pt)
        return None
    return state


