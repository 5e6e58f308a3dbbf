"""A saved model: `<name>.pt` (a plain torch state_dict, loaded with weights_only=True: no
pickled code) next to `<name>.json` (format, format_version, everything else, and the sha256 of
the .pt, so a weights file swapped or damaged after saving is caught on load). One writer and one
reader for every kind: judges (judgeopt.judge.store), generators (judgeopt.planners.store).
"""

from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path
from typing import Any, Sequence

from judgeopt.errors import BadInput
from judgeopt.files import atomic_write
from judgeopt.formats.header import check_header


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
        return torch.load(io.BytesIO(data), map_location="cpu", weights_only=True)
    except Exception as exc:  # torch raises several types for corrupt files
        raise error(f"{pt}: corrupt weights file, torch cannot read it ({type(exc).__name__}: {exc})") from exc


