"""The judge's built CasADi library loaded without torch's Python package: a one-shot solve's fast start.

Why: importing torch's Python package costs about 2 s of a one-shot `judgeopt solve`, and the
direct solve never needs it once its judge library is built: an l4casadi library links libtorch
itself (the C++ runtime, about 0.3 s to load), and its normalisation is a CasADi expression.

So when the torch path builds (or finds) such a library for a judge file, `remember` writes a record
beside the cache: `fast/<weights sha256>.<backend>.json` with the library and its function's name, the
judge's normalisation and trajectory format, the installed versions of l4casadi, torch and casadi,
and the sha256 of every source file that generated the library. `recall` loads the library from
that record (libtorch and libl4casadi by ctypes, then casadi.external), only where every one of
those still matches; otherwise it returns None and the caller takes the torch path, which builds
the library where needed and writes the record again. First run builds, the second is fast.

Light on purpose: numpy and casadi only (tests/judge/test_compiled.py runs a solve with torch's
import made to fail).
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import hashlib
import importlib.metadata
import json
import logging
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

import casadi as cs
import numpy as np

from judgeopt.errors import JudgeoptError
from judgeopt.judge.errors import TrajectoryError

log = logging.getLogger("judgeopt")

#: the backends whose library `recall` can load without torch's Python package (l4casadi's)
RECALLED = ("l4casadi", "l4casadi32")
#: the distributions whose versions key a library (casadi_fn._cache_key); a record names them
VERSIONED = ("l4casadi", "torch", "casadi")
RECORD_FORMAT = "judgeopt-judge-library"
#: l4casadi's C++ side hands the model FLOAT32 inputs, so the float64 backend sends each normalised
#: input z as exact float32 halves z_hi + z_lo (judge.casadi_fn explains it)
SPLIT_BITS = 12


def sigmoid(z: Any) -> Any:
    """A judge's logit as a probability: exp(-log(1 + exp(-z))), with no overflow warning for a
    confident logit (z < -709). A float for a number, an array for an array."""
    p = np.exp(-np.logaddexp(0.0, -np.asarray(z, dtype=float)))
    return float(p) if p.ndim == 0 else p


@dataclass(frozen=True)
class TrajectoryFormat:
    """What a judge reads, from its file's config alone (no network): the planners need no more
    to call a built judge, and checking a problem against it needs no torch."""

    arch: str
    env_names: tuple[str, ...]
    channels: tuple[str, ...]
    horizon: int
    dt: float

    @classmethod
    def of(cls, config: Mapping[str, Any]) -> "TrajectoryFormat":
        """From a judge file's `config` (an LSTM where `arch` is missing, as JudgeConfig reads it)."""
        try:
            return cls(str(config.get("arch", "lstm")), tuple(config["env_names"]), tuple(config["channels"]),
                       int(config["horizon"]), float(config["dt"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise TrajectoryError(f"judge config lacks its trajectory format ({exc})") from None

    @property
    def n_env(self) -> int:
        return len(self.env_names)

    @property
    def n_channels(self) -> int:
        return len(self.channels)

    @property
    def input_size(self) -> int:
        return self.n_channels + self.n_env


@dataclass
class CasadiJudge:
    """A built judge function and how it came to be. Keep this object alive while the
    Function is used: the torch backend's callbacks and an l4casadi library's LastCall live in Python."""

    fn: cs.Function
    backend: str
    build_seconds: float
    cache_hit: bool = False
    cache_dir: Path | None = None
    horizon: int = 0
    n_env: int = 0
    _keep: list[Any] = field(default_factory=list, repr=False)

    def __call__(self, *args: Any) -> Any:
        return self.fn(*args)

    def value_and_gradient(self, traj: np.ndarray, env: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """logit and its gradient w.r.t. the flattened trajectory and env (convenience, numeric)."""
        grad = self._grad_fn()
        out = grad(np.asarray(traj, float).ravel(), np.asarray(env, float).ravel())
        return float(out[0]), np.asarray(out[1]).ravel(), np.asarray(out[2]).ravel()

    def _grad_fn(self) -> cs.Function:
        if not hasattr(self, "_grad"):
            x, e = cs.MX.sym("traj", self.fn.size1_in(0)), cs.MX.sym("env", self.fn.size1_in(1))
            logit = self.fn(x, e)[0]
            g = cs.gradient(logit, cs.vertcat(x, e))  # one reverse sweep for both inputs
            n = x.size1()
            self._grad = cs.Function("judge_value_grad", [x, e], [logit, g[:n], g[n:]])
        return self._grad


def normalization_vectors(norm: Mapping[str, Sequence[float]], horizon: int) -> tuple[np.ndarray, np.ndarray]:
    """The mean and std of the flattened inputs [traj; env] (traj row-major, (N+1) x C), in float64,
    from a judge's normalisation (Judge.normalization(): x_mean, x_std, e_mean, e_std)."""
    n1 = horizon + 1
    arr = {k: np.asarray(norm[k], dtype=np.float64) for k in ("x_mean", "x_std", "e_mean", "e_std")}
    return (np.concatenate([np.tile(arr["x_mean"], n1), arr["e_mean"]]),
            np.concatenate([np.tile(arr["x_std"], n1), arr["e_std"]]))


def split(z: cs.MX) -> cs.MX:
    """[z_hi; z_lo] of the normalised inputs z, each exactly a float32 (see SPLIT_BITS)."""
    z_hi = cs.floor(z * 2.0**SPLIT_BITS) / 2.0**SPLIT_BITS
    return cs.vertcat(z_hi, z - z_hi)


class LastCall(cs.Callback):
    """`fn` that answers a call with the same inputs as its last one from memory, and so does its
    reverse sweep. Why: Ipopt asks for the constraints at a point, then for their Jacobian at the
    same point, and CasADi's Jacobian runs the judge's forward pass again before its reverse sweep
    (the direct solve: 8 value calls and 9 Jacobians, of which 8 at a point just evaluated). The
    same library on the same bytes gives the same bytes, so answers are unchanged. Keep it alive
    while a Function that calls it is used (CasadiJudge._keep)."""

    def __init__(self, fn: cs.Function, reversible: bool = True) -> None:
        cs.Callback.__init__(self)
        self.fn, self.reversible = fn, reversible
        self.last: tuple[bytes, list] | None = None  # (the inputs' bytes, the outputs): one tuple, swapped whole
        self.reverses: list[LastCall] = []
        self.construct(f"{fn.name()}_last", {})

    def get_n_in(self) -> int:
        return self.fn.n_in()

    def get_n_out(self) -> int:
        return self.fn.n_out()

    def get_sparsity_in(self, i: int) -> cs.Sparsity:
        return self.fn.sparsity_in(i)

    def get_sparsity_out(self, i: int) -> cs.Sparsity:
        return self.fn.sparsity_out(i)

    def eval(self, args: list) -> list:
        key = b"".join(np.asarray(a).tobytes() for a in args)
        last = self.last
        if last is not None and last[0] == key:
            return last[1]
        out = self.fn.call(args)
        self.last = (key, out)
        return out

    def has_reverse(self, nadj: int) -> bool:
        return self.reversible  # a reverse sweep's own derivatives: none (no judge curvature is asked for)

    def get_reverse(self, nadj: int, name: str, inames: list, onames: list, opts: dict) -> cs.Function:
        reverse = LastCall(self.fn.reverse(nadj), reversible=False)
        self.reverses.append(reverse)
        return reverse


def wrap_library(fn: cs.Function, backend: str, norm: Mapping[str, Sequence[float]], horizon: int, n_channels: int,
                 n_env: int, name: str = "judge", last_call: bool = True) -> tuple[cs.Function, LastCall | None]:
    """(traj, env) -> (logit, prob) around an l4casadi library `fn` of the normalised inputs: the
    normalisation in float64 here, split in halves for the float64 backend; and the LastCall the
    function calls `fn` through, to keep alive beside it (`last_call` False: none, every call
    evaluated, what benchmarks/bench_direct.py's lever last_call=off measures)."""
    x, e = cs.MX.sym("traj", (horizon + 1) * n_channels), cs.MX.sym("env", n_env)
    mean, std = normalization_vectors(norm, horizon)
    z = (cs.vertcat(x, e) - cs.DM(mean)) / cs.DM(std)
    last = LastCall(fn) if last_call else None
    out = (last or fn)((z if backend == "l4casadi32" else split(z)).T)
    return cs.Function(name, [x, e], [out[0, 0], out[0, 1]], ["traj", "env"], ["logit", "prob"]), last


def warm(cj: CasadiJudge, norm: Mapping[str, Sequence[float]], horizon: int) -> None:
    """Two value + gradient calls at the normalisation's means: TorchScript's profiling executor
    profiles the traces on their first call and optimises them on the second (measured on the
    first six calls in a fresh process: LSTM 78, 13, 3.0, 2.6 ms; TCN 27, 37, 2.8, 2.3 ms), so
    without this the first solve would pay 40-90 ms that no later one pays. Raises what the call
    raises (the caller names it a build error)."""
    traj = np.tile(np.asarray(norm["x_mean"], dtype=np.float64), horizon + 1)
    env = np.asarray(norm["e_mean"], dtype=np.float64)
    for shift in (0.0, 1e-3):
        cj.value_and_gradient(traj + shift, env)


#: whether this process loads models for a fast start where it can (enable_fast_start)
_FAST_START = False


def enable_fast_start(on: bool = True) -> None:
    """Let this process plan from a judge's built library and a generator's numpy weights where a
    torch run has left them (planners.loaded.fast_models): `judgeopt solve` and the service's workers,
    whose start is the cost. Off by default: a library user, a test or a long evaluation keeps the
    torch Judge, which serves every planner, and its judge p as it always was."""
    global _FAST_START
    _FAST_START = on


@contextlib.contextmanager
def fast_start(on: bool = True) -> Iterator[None]:
    """The fast start on (or off) inside the block, as it was after it: for one command in a
    process that goes on (judgeopt.cli.main may be called from Python, whose later API calls plan
    with the torch Judge as before)."""
    before = _FAST_START
    enable_fast_start(on)
    try:
        yield
    finally:
        enable_fast_start(before)


def fast_start_enabled() -> bool:
    return _FAST_START


# -- the record of a built library ---------------------------------------------------------------
def installed_versions() -> dict[str, str]:
    """The installed versions of what keys a library (VERSIONED), "?" for one not installed."""
    return dict(_versions_here())


@functools.lru_cache(maxsize=1)
def _versions_here() -> tuple[tuple[str, str], ...]:
    """installed_versions, read once per process: what this process runs is what it imported, and
    reading the packages' metadata cost each load of the planners (a service's request under new
    limits or a new environment) about 3 ms."""
    out = []
    for dist in VERSIONED:
        try:
            out.append((dist, importlib.metadata.version(dist)))
        except importlib.metadata.PackageNotFoundError:
            out.append((dist, "?"))
    return tuple(out)


def file_digests(paths: Sequence[str | Path]) -> dict[str, str]:
    """path -> sha256 of the file's bytes (the source files that generated a library)."""
    return {str(Path(p).resolve()): hashlib.sha256(Path(p).read_bytes()).hexdigest() for p in paths}


def record_path(root: Path, weights_sha256: str, backend: str) -> Path:
    """Where the record of a judge file's library for `backend` lies in the cache `root`."""
    return root / "fast" / f"{weights_sha256}.{backend}.json"


@dataclass(frozen=True)
class LibraryRecord:
    """What loading a judge's built library needs, and what must still hold for it to be the one
    the torch path would load (versions, generating sources)."""

    weights_sha256: str
    backend: str
    library: str  # the shared library's path
    function: str  # its function's name
    normalization: dict[str, list[float]]
    config: dict[str, Any]  # the judge file's config (TrajectoryFormat.of reads it)
    versions: dict[str, str]
    sources: dict[str, str]  # file -> sha256

    def to_json(self) -> dict[str, Any]:
        return {"format": RECORD_FORMAT, **asdict(self)}

    @classmethod
    def from_json(cls, d: Mapping[str, Any]) -> "LibraryRecord":
        if d.get("format") != RECORD_FORMAT:
            raise ValueError(f"not a {RECORD_FORMAT} record")
        return cls(**{k: d[k] for k in cls.__dataclass_fields__})

    def stale(self) -> str | None:
        """Why this record no longer names the library the torch path would load; None if it does."""
        lib = Path(self.library)
        if not lib.is_file() or not (lib.parent / "complete.json").is_file():
            return f"{lib} is gone"
        if self.versions != installed_versions():
            return f"versions changed ({self.versions} -> {installed_versions()})"
        try:
            now = file_digests(list(self.sources))
        except OSError as exc:
            return f"a generating source is unreadable ({exc})"
        changed = [p for p, sha in self.sources.items() if now.get(str(Path(p).resolve())) != sha]
        return f"{', '.join(changed)} changed" if changed else None


def remember(root: Path, record: LibraryRecord) -> None:
    """Write `record` atomically where `recall` looks (unless the same is there): a cache that cannot
    be written only costs the next run its fast start, so that is one debug line, not an error."""
    from judgeopt.files import atomic_write

    path = record_path(root, record.weights_sha256, record.backend)
    text = json.dumps(record.to_json(), indent=1, sort_keys=True) + "\n"
    try:
        if path.is_file() and path.read_text() == text:
            return
        atomic_write(path, text)
    except (OSError, JudgeoptError) as exc:  # judgeopt.files raises its own one-line error for an unwritable cache
        log.debug("judge library record not written (%s): the next solve imports torch", exc)


def read_record(root: Path, weights_sha256: str, backend: str) -> LibraryRecord | None:
    """The record of this judge file's library for `backend`, where one is there, valid and not stale."""
    path = record_path(root, weights_sha256, backend)
    if not path.is_file():
        return None
    try:
        record = LibraryRecord.from_json(json.loads(path.read_text()))
    except (OSError, ValueError, TypeError, KeyError) as exc:
        log.debug("ignoring %s (%s)", path, exc)
        return None
    if record.weights_sha256 != weights_sha256 or record.backend != backend:
        return None
    why = record.stale()
    if why is not None:
        log.debug("judge library record %s is stale: %s", path, why)
        return None
    return record


# -- loading libtorch and libl4casadi without torch's Python package -----------------------------
_RUNTIME: dict[str, ctypes.CDLL] = {}


def _package_dir(name: str) -> Path | None:
    """An installed distribution's package folder, found from its metadata: neither imported nor
    looked up through the import system (which a test blocks torch in)."""
    try:
        where = Path(str(importlib.metadata.distribution(name).locate_file(name)))
    except importlib.metadata.PackageNotFoundError:
        return None
    return where if where.is_dir() else None


def load_runtime() -> bool:
    """libtorch and libl4casadi loaded with their symbols global (what `import l4casadi` does after
    `import torch`), so that casadi.external can load an l4casadi library; False where either is
    missing. Once per process."""
    if "l4casadi" in _RUNTIME:
        return True
    torch_dir, l4c_dir = _package_dir("torch"), _package_dir("l4casadi")
    if torch_dir is None or l4c_dir is None:
        return False
    libs = [torch_dir / "lib" / "libtorch_cpu.so", torch_dir / "lib" / "libtorch.so", l4c_dir / "lib" / "libl4casadi.so"]
    if not all(p.is_file() for p in libs):
        return False
    try:
        for key, path in zip(("torch_cpu", "torch", "l4casadi"), libs):
            _RUNTIME[key] = ctypes.CDLL(str(path), mode=ctypes.RTLD_GLOBAL)
    except OSError as exc:
        log.debug("libtorch not loadable without torch (%s)", exc)
        return False
    return True


def set_runtime_threads(n: int) -> None:
    """libtorch's intra-op threads (at::set_num_threads, what torch.set_num_threads calls) where
    libtorch was loaded by `load_runtime`: the judge library runs on them."""
    lib = _RUNTIME.get("torch_cpu")
    if lib is not None:
        lib._ZN2at15set_num_threadsEi(ctypes.c_int(n))


def recall(root: Path, weights_sha256: str, backend: str, threads: int) -> tuple[CasadiJudge, LibraryRecord] | None:
    """The built library of this judge file for `backend`, loaded and warmed without torch's Python
    package, with its record; None where there is none to load (the caller takes the torch path)."""
    import time

    if backend not in RECALLED:
        return None
    record = read_record(root, weights_sha256, backend)
    if record is None or not load_runtime():
        return None
    t0 = time.perf_counter()
    fmt = TrajectoryFormat.of(record.config)
    set_runtime_threads(threads)
    try:
        fn = cs.external(record.function, record.library)
        wrapped, last = wrap_library(fn, backend, record.normalization, fmt.horizon, fmt.n_channels, fmt.n_env)
        cj = CasadiJudge(wrapped, backend, 0.0, cache_hit=True, cache_dir=Path(record.library).parent,
                         horizon=fmt.horizon, n_env=fmt.n_env, _keep=[fn, last])
        if backend == "l4casadi32":
            warm(cj, record.normalization, fmt.horizon)
    except Exception as exc:  # a library that no longer loads or runs: the torch path builds it again
        log.debug("judge library %s not usable without torch (%s)", record.library, exc)
        return None
    cj.build_seconds = time.perf_counter() - t0
    return cj, record


class CompiledJudge:
    """A judge file's built library standing in for the torch Judge where a planner only calls it:
    `config` (its trajectory format) and predict_logit / predict_proba, evaluated by the same CasADi
    function the direct solve constrains (so the generator's plan is judged as the solve judges)."""

    def __init__(self, cjudge: CasadiJudge, config: TrajectoryFormat) -> None:
        self.cjudge, self.config = cjudge, config

    def predict_logit(self, x: np.ndarray, e: np.ndarray) -> np.ndarray:
        """Logits of (N+1, C) or (B, N+1, C) trajectories in (E,) or (B, E) environments."""
        cfg = self.config
        x, e = np.asarray(x, dtype=np.float64), np.asarray(e, dtype=np.float64)
        x, e = (x[None] if x.ndim == 2 else x), (e[None] if e.ndim == 1 else e)
        if x.ndim != 3 or x.shape[1:] != (cfg.horizon + 1, cfg.n_channels) or e.shape != (x.shape[0], cfg.n_env):
            raise TrajectoryError(f"trajectories must have shape (B, {cfg.horizon + 1}, {cfg.n_channels}) and the "
                                  f"environment (B, {cfg.n_env}), got {x.shape} and {e.shape}")
        return np.array([float(self.cjudge.fn(xi.ravel(), ei)[0]) for xi, ei in zip(x, e)])

    def predict_proba(self, x: np.ndarray, e: np.ndarray) -> np.ndarray:
        return sigmoid(self.predict_logit(x, e))
