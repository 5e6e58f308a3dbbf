"""The trained judge as a CasADi Function: (trajectory, env) -> (logit, probability).

Inputs, raw physical values as the judge was trained on:
  traj  ((N+1)*C, 1)  the (N+1, C) response [y, ydot, f] flattened ROW-major
                      (numpy `x.ravel()`: y_0, ydot_0, f_0, y_1, ...)
  env   (E, 1)        the judge's environment variables, in `config.env_names` order
Outputs: logit (1x1) and prob = sigmoid(logit) (1x1). First derivatives are exact.

Backends (measured by benchmarks/bench_judge_casadi.py and bench_judge_ipopt.py, docs/judge.md):
  "l4casadi32" ("auto" for a noise-tolerant use, where l4casadi is installed and the architecture
               is in AUTO_L4CASADI32: the direct solve's judge as a constraint) l4casadi 2.0 on the
               architecture's FLOAT32 flat module (Arch.flat_module32: for the LSTM oneDNN's
               fused layer op, for the TCN its convolutions as matrix products), inputs
               normalised in CasADi (l4casadi's C++ side casts them to float32, which is what a
               float32 network reads anyway). Only the value and the reverse-mode derivative
               (adj1) are traced: what the solve calls. Value + gradient: LSTM 0.8-1.07x the
               torch32 callback's time, TCN 0.2-0.4x; value alone about half the callback's.
               2-5 s to build once per model, cached; ~1e-7 relative noise like torch32.
  "l4casadi"   ("auto" where installed and the use needs float64) l4casadi 2.0: TorchScript traces
               of the unrolled network (one-Linear LSTM cell, float64) compiled into a shared
               library, cached per model. Its C++ side casts inputs to float32, so inputs are sent
               as exact float32 hi/lo halves (see judge.compiled.split). The fastest float64 backend, but 2-4x
               slower than the float32 ones: the unrolled cell runs op by op in float64. About
               16 s (TCN 2-5 s) to build once per model.
  "torch"      a casadi.Callback around torch autograd (reverse mode: one backward pass; the
               forward graph of the last point is kept). No build; needs Python at solve
               time; precision="float32" is 4.5x faster but its ~1e-6 noise stalls Ipopt.
  "torch32"    the same callback in float32 (precision="float32"): the network as trained, its
               value and gradient 3-4x cheaper; the noise (~1e-7 relative) is harmless where the
               judge is a constraint (the direct solve's objective "target"), not where -log p
               is driven to a tight tolerance. "auto"'s choice for that use where l4casadi32 is
               not (l4casadi missing, an architecture not measured, or a build that failed).
  "native"     the network as a CasADi MX graph (0.1 s to build, no Python or libtorch at
               solve time, usable in code generation); about 1.7x torch autograd (float64).
  "compiled"   that graph generated as C and compiled with gcc -O2 (about 80 s, cached).
"native" and "compiled" exist only for architectures with a CasADi graph (Arch.casadi_graph:
the LSTM); l4casadi, l4casadi32 and the torch callbacks take any architecture (backends_for).
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import logging
import os
import shutil
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import casadi as cs
import numpy as np
import torch
from torch import nn

from judgeopt.cbuild import CompileError, compiled_library, source_digest
from judgeopt.errors import Missing
from judgeopt.files import CACHE_FIX, make_temp_dir, publish_dir
from judgeopt.judge.archs import casadi_sigmoid
from judgeopt.judge.backends import AUTO_L4CASADI32, BACKENDS, DEFAULT_BACKEND, GRAPH_BACKENDS, choose_backend  # noqa: F401
from judgeopt.judge.compiled import SPLIT_BITS, CasadiJudge, sigmoid, warm, wrap_library
from judgeopt.judge.model import Judge, JudgeConfig, JudgeError

log = logging.getLogger("judgeopt")


def backends_for(config: JudgeConfig) -> tuple[str, ...]:
    """The backends a judge of this architecture can be built with."""
    return tuple(b for b in BACKENDS if config.spec.casadi_graph or b not in GRAPH_BACKENDS)


class CasadiBuildError(Missing, JudgeError):
    """A backend that could not be built (compiler missing, l4casadi failure, ...)."""


def default_cache_dir() -> Path:
    """Where built libraries are kept: $JUDGEOPT_CACHE, else the platform's user cache folder."""
    from judgeopt.files import cache_dir

    return cache_dir()


def model_hash(judge: Judge) -> str:
    """sha256 of the judge's architecture and every parameter/buffer value.

    Why the content and not the .pt file's bytes: the same weights give the same hash
    whether the model came from a file or from memory, and any retraining changes it.
    """
    config = judge.config.to_dict()
    if config["arch"] == "lstm":  # as before architectures had names: LSTM judges keep their built libraries
        del config["arch"]
    h = hashlib.sha256(json.dumps(config, sort_keys=True).encode())
    for name, t in sorted(judge.state_dict().items()):
        h.update(name.encode())
        h.update(t.detach().cpu().double().contiguous().numpy().tobytes())
    return h.hexdigest()


def build_casadi_judge(judge: Judge, backend: str = DEFAULT_BACKEND, cache_dir: str | Path | None = None,
                       name: str = "judge", precision: str = "float64", noise_tolerant: bool = False,
                       last_call: bool = True) -> CasadiJudge:
    """Build the judge's CasADi Function with `backend` (cached where building is slow).

    precision applies to the torch backend: "float64" (default) evaluates a float64 copy of
    the network, exact to rounding; "float32" runs the network as trained, several times
    faster on CPU (oneDNN's fused LSTM kernel) but with ~1e-7 relative noise in value and
    gradient, which can stall a line search at tight tolerances. l4casadi32 is float32 and the
    other backends float64, whatever `precision` says.
    `noise_tolerant`: what "auto" may choose (choose_backend). Where "auto" chose l4casadi32 and
    it cannot be built (l4casadi or a compiler missing, a trace that fails or disagrees with
    torch), the torch32 callback is returned and one warning line names the fallback; an
    explicitly requested backend raises CasadiBuildError instead.
    `last_call` (l4casadi's backends): a repeated call answered from memory (compiled.LastCall).
    """
    auto = backend == "auto"
    backend = choose_backend(backend, noise_tolerant, judge.config)
    if auto and backend == "l4casadi32":
        try:
            return build_casadi_judge(judge, "l4casadi32", cache_dir, name, last_call=last_call)
        except CasadiBuildError as exc:
            log.warning("judge backend: l4casadi32 could not be built (%s); falling back to torch32", exc)
            return build_casadi_judge(judge, "torch32", cache_dir, name)
    if backend not in BACKENDS:
        raise JudgeError(f"unknown CasADi backend {backend!r}; choose one of {['auto', *BACKENDS]}")
    if backend not in backends_for(judge.config):
        raise JudgeError(f"a {judge.config.arch} judge has no CasADi graph, so no {backend!r} backend; its backends: "
                         f"{', '.join(['auto', *backends_for(judge.config)])}")
    if precision not in ("float64", "float32"):
        raise JudgeError(f"precision must be 'float64' or 'float32', got {precision!r}")
    judge = judge.eval()
    t0 = time.perf_counter()
    if backend == "native":
        fn = _native_function(judge, name)
        return CasadiJudge(fn, backend, time.perf_counter() - t0, horizon=judge.config.horizon,
                           n_env=judge.config.n_env)
    if backend in ("torch", "torch32"):
        cb = _TorchJudgeCallback(name, judge, dtype=torch.float32 if backend == "torch32" else getattr(torch, precision))
        return CasadiJudge(cb, backend, time.perf_counter() - t0, horizon=judge.config.horizon,
                           n_env=judge.config.n_env, _keep=[cb])
    root = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    if backend == "compiled":
        fn, hit, where = _compiled_function(judge, root)
    elif backend == "l4casadi32":
        fn, hit, where = _l4casadi32_function(judge, root)
    else:
        fn, hit, where = _l4casadi_function(judge, root)
    keep: list[Any] = [fn]
    if backend == "compiled":
        x, e = cs.MX.sym("traj", _n_traj(judge)), cs.MX.sym("env", judge.config.n_env)
        logit, prob = fn(x, e)
        wrapped = cs.Function(name, [x, e], [logit, prob], ["traj", "env"], ["logit", "prob"])
    else:
        cfg = judge.config
        wrapped, last = wrap_library(fn, backend, judge.normalization(), cfg.horizon, cfg.n_channels, cfg.n_env, name,
                                     last_call)
        keep.append(last)
    out = CasadiJudge(wrapped, backend, 0.0, cache_hit=hit, cache_dir=where, horizon=judge.config.horizon,
                      n_env=judge.config.n_env, _keep=keep)
    if backend == "l4casadi32":
        try:
            warm(out, judge.normalization(), judge.config.horizon)
        except Exception as exc:  # the library loaded but does not evaluate: a build error, so "auto" falls back
            raise CasadiBuildError(f"the built library does not evaluate: {_one_line(exc)}") from None
    out.build_seconds = time.perf_counter() - t0
    return out


#: the name of an l4casadi library's function: this prefix and its cache key (the folder's name)
_LIBRARY_PREFIX = {"l4casadi": "judge_l4c_", "l4casadi32": "judge_l4c32_"}


def remember_library(judge: Judge, meta: dict[str, Any], cj: CasadiJudge) -> None:
    """Record the library `cj` was built from (or found as) for the judge file whose metadata is
    `meta`, so that the next solve loads it without torch (judge.compiled.recall); nothing for a
    backend that needs torch's Python package (the callbacks) or has no library."""
    from judgeopt.judge.compiled import RECALLED, LibraryRecord, file_digests, installed_versions, remember

    if cj.backend not in RECALLED or cj.cache_dir is None:
        return
    name = _LIBRARY_PREFIX[cj.backend] + cj.cache_dir.name
    lib = cj.cache_dir / f"lib{name}.so"
    if not lib.is_file():
        return
    record = LibraryRecord(meta["weights_sha256"], cj.backend, str(lib.resolve()), name, judge.normalization(),
                           judge.config.to_dict(), installed_versions(),
                           file_digests(generating_sources(judge, cj.backend)))
    remember(default_cache_dir(), record)


def generating_sources(judge: Judge, backend: str) -> list[Path]:
    """The source files of the code that generates and wraps `backend`'s library for `judge`
    (_generating_code's, this module and judge.compiled): a fast start's record (judge.compiled)
    holds their digests, so an edit to any of them sends the next solve through torch again."""
    import inspect

    from judgeopt.judge import compiled

    model = _flat_model(judge, backend) if backend in ("l4casadi", "l4casadi32") else None
    files = {Path(inspect.getsourcefile(obj)) for obj in _generating_code(judge, backend, model)}
    return sorted(files | {Path(__file__), Path(compiled.__file__)})


def _n_traj(judge: Judge) -> int:
    return (judge.config.horizon + 1) * judge.config.n_channels


# -- native MX graph -------------------------------------------------------------------------
def _native_function(judge: Judge, name: str) -> cs.Function:
    """The network as an MX graph: the normalisation here, the network from its architecture
    (Arch.native_logit)."""
    cfg = judge.config
    n1 = cfg.horizon + 1
    x, e = cs.MX.sym("traj", _n_traj(judge)), cs.MX.sym("env", cfg.n_env)
    xm, xs = (cs.DM(getattr(judge, k).detach().double().numpy()) for k in ("x_mean", "x_std"))
    em, es = (cs.DM(getattr(judge, k).detach().double().numpy()) for k in ("e_mean", "e_std"))
    X = (cs.reshape(x, cfg.n_channels, n1) - cs.repmat(xm, 1, n1)) / cs.repmat(xs, 1, n1)
    U = cs.vertcat(X, cs.repmat((e - em) / es, 1, n1)) if cfg.n_env else X
    a = cfg.spec.native_logit(judge, U)
    return cs.Function(name, [x, e], [a, casadi_sigmoid(a)], ["traj", "env"], ["logit", "prob"])


# -- compiled C of the native graph ---------------------------------------------------------
def _compiled_function(judge: Judge, root: Path) -> tuple[cs.Function, bool, Path]:
    """Generate C for the graph plus its reverse-mode and Jacobian functions (named so that
    casadi.external finds them: adj1_<name>, jac_<name>) and compile it once per model."""
    key = _cache_key(judge, "compiled")
    name = f"judge_c_{key}"
    where = root / "compiled" / key
    fn = _native_function(judge, name)
    try:
        lib, hit = compiled_library([fn, fn.reverse(1), fn.jacobian()], where, name, info={"backend": "compiled"},
                                    note=f"compiling the judge as C (once per judge, about 80 s; cached in {where})")
    except CompileError as exc:
        raise CasadiBuildError(f"the 'compiled' backend: {exc}") from None
    return cs.external(name, str(lib)), hit, where


# -- l4casadi -------------------------------------------------------------------------------
def _l4casadi_function(judge: Judge, root: Path) -> tuple[cs.Function, bool, Path]:
    """l4casadi of the architecture's flat module (Arch.flat_module; for the LSTM the unrolled
    concat-Linear cell model), float64, built once per model.

    Built in a temporary folder with model_search_path pointing at the final folder, then
    renamed into place, so a half-built cache entry is never seen by another process."""
    try:
        import l4casadi
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise CasadiBuildError(f"the 'l4casadi' backend needs l4casadi (pip install 'judgeopt[l4casadi]', or "
                               f"scripts/setup.sh); or choose --casadi-backend native ({exc})") from exc
    version = _version("l4casadi")
    model = _flat_model(judge, "l4casadi")
    key = _cache_key(judge, "l4casadi", model)
    name = f"judge_l4c_{key}"
    where = root / "l4casadi" / key
    lib = where / f"lib{name}.so"
    if (where / "complete.json").exists() and lib.exists():
        return cs.external(name, str(lib)), True, where
    log.info("building the judge library (once per judge, about 15 s; cached in %s)", where)
    tmp = make_temp_dir(where, CACHE_FIX)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", (DeprecationWarning, UserWarning))  # torch.jit deprecations, TF32 notes
            with torch.backends.mkldnn.flags(enabled=False):
                l4c = l4casadi.L4CasADi(model, name=name, build_dir=str(tmp), model_search_path=str(where.absolute()),
                                        generate_jac=True, generate_adj1=True, generate_jac_adj1=False,
                                        generate_jac_jac=False)
                l4c.build(cs.MX.sym("inp", 1, 2 * (_n_traj(judge) + judge.config.n_env)))
        missing = [f for f in (f"{name}.pt", f"jac_{name}.pt", f"adj1_{name}.pt", lib.name) if not (tmp / f).exists()]
        if missing:
            raise CasadiBuildError(f"l4casadi did not produce {missing} (derivative traces failed)")
        (tmp / "complete.json").write_text(json.dumps({"backend": "l4casadi", "l4casadi": version,
                                                       "torch": torch.__version__}))
        publish_dir(tmp, where)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return cs.external(name, str(lib)), False, where


# -- l4casadi, float32 ------------------------------------------------------------------------
def _l4casadi32_function(judge: Judge, root: Path) -> tuple[cs.Function, bool, Path]:
    """l4casadi of the architecture's float32 flat module (Arch.flat_module32; for the LSTM
    oneDNN's fused layer op) on inputs normalised in CasADi, value and adj1 traces only,
    built once per model and cached. The build is checked before it is published: the
    frozen traces (what libl4casadi runs) must load and agree with eager torch."""
    try:
        import l4casadi
    except ImportError as exc:
        raise CasadiBuildError(f"l4casadi is not installed ({exc})") from None
    version = _version("l4casadi")
    try:
        model = _flat_model(judge, "l4casadi32")
    except Exception as exc:
        raise CasadiBuildError(f"no float32 module for l4casadi: {_one_line(exc)}") from None
    module = f"{type(model).__module__}.{type(model).__qualname__}"
    key = _cache_key(judge, "l4casadi32", model)
    name = f"judge_l4c32_{key}"
    where = root / "l4casadi32" / key
    lib = where / f"lib{name}.so"
    if not ((where / "complete.json").exists() and lib.exists()):
        if shutil.which("gcc") is None:
            raise CasadiBuildError("no C compiler: gcc is not on PATH")
        log.info("building the judge library in float32 (once per judge, a few seconds; cached in %s)", where)
        tmp = make_temp_dir(where, CACHE_FIX)
        try:
            _build_l4casadi32(l4casadi, model, name, tmp, where, _n_traj(judge) + judge.config.n_env)
            (tmp / "complete.json").write_text(json.dumps({"backend": "l4casadi32", "l4casadi": version,
                                                           "torch": torch.__version__, "traces": "value+adj1",
                                                           "module": module}))
            publish_dir(tmp, where)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        hit = False
    else:
        hit = True
    try:
        return cs.external(name, str(lib)), hit, where
    except RuntimeError as exc:
        raise CasadiBuildError(f"could not load {lib}: {_one_line(exc)}") from None


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text[:200]}"


def _build_l4casadi32(l4casadi: Any, model: nn.Module, name: str, tmp: Path, where: Path, n_in: int) -> None:
    """Trace, check and compile into `tmp` (the library will look for its traces in `where`).

    Only the value and the reverse-mode derivative (adj1) are traced. The direct solve
    differentiates the judge by cs.gradient (one reverse sweep per judge row), and counted over its
    solves CasADi asks the judge's function for reverse(1) and never for its Jacobian
    (docs/judge.md); no Hessian traces (Ipopt's judge curvature is left out or approximated).
    cs.jacobian of the function still works, from adj1 sweeps."""
    from torch.fx.experimental.proxy_tensor import make_fx

    class _L4C32(l4casadi.L4CasADi):
        def _trace_adj1_model(self) -> Any:
            """The adjoint traced with plain autograd and grad mode OFF in the backward
            (create_graph=False): each op then records its own backward kernel (for the LSTM one
            aten::mkldnn_rnn_layer_backward per layer), where l4casadi's torch.func.vjp keeps
            grad mode on and functionalises, which unrolls the fused LSTM (or fails: oneDNN's
            workspace is lost under functorch's wrappers)."""
            m = self.model

            def adj1(p, seed):  # type: ignore[no-untyped-def]  (no annotations: FX copies them into the trace)
                with torch.enable_grad():
                    p = p.detach().requires_grad_(True)
                    return torch.autograd.grad(m(p), p, seed)[0]

            return make_fx(adj1)(torch.zeros(self._input_shape), torch.zeros(self._output_shape))

        def model_compile(self, model: Any, file_path: str, dummy_inp: Any) -> bool:
            """The adjoint's TorchScript wrapped in grad mode ON (_GradOn): libl4casadi calls
            it with grad mode off, and oneDNN's LSTM keeps the workspace its backward needs
            only in grad mode (it returns none otherwise, whatever `train` says)."""
            ok = super().model_compile(model, file_path, dummy_inp)
            if ok and Path(file_path).name.startswith("adj1_"):
                torch.jit.script(_GradOn(torch.jit.load(file_path))).save(file_path)
            return ok

    if not hasattr(l4casadi.L4CasADi, "_trace_adj1_model"):
        raise CasadiBuildError(f"l4casadi {_version('l4casadi')} has no adjoint trace hook "
                               "(_trace_adj1_model); l4casadi32 was written for l4casadi 2.0")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # torch.jit deprecations, l4casadi's notes on traces not asked for
            with torch.no_grad():  # the value's trace: inference kernels (no oneDNN workspace)
                l4c = _L4C32(model, name=name, build_dir=str(tmp), model_search_path=str(where.absolute()),
                             generate_jac=False, generate_adj1=True, generate_jac_adj1=False, generate_jac_jac=False)
                l4c.generate(cs.MX.sym("inp", 1, n_in))
    except Exception as exc:
        raise CasadiBuildError(f"tracing failed: {_one_line(exc)}") from None
    missing = [f for f in (f"{name}.pt", f"adj1_{name}.pt") if not (tmp / f).exists()]
    if missing:
        raise CasadiBuildError(f"l4casadi did not produce {missing} (the trace failed)")
    _check_traces(model, tmp / f"{name}.pt", tmp / f"adj1_{name}.pt", n_in)
    try:
        with open(os.devnull, "w") as null, _redirect_fd(2, null):  # gcc's own messages: the exception says it
            l4c.compile()
    except Exception:
        raise CasadiBuildError(f"compiling lib{name}.so failed (gcc with libl4casadi)") from None
    if not (tmp / f"lib{name}.so").exists():
        raise CasadiBuildError(f"l4casadi did not produce lib{name}.so")


class _GradOn(nn.Module):
    """A traced adjoint (p, seed) -> gradient run with grad mode on (see _L4C32.model_compile)."""

    def __init__(self, inner: Any) -> None:
        super().__init__()
        self.inner = inner

    def forward(self, p: torch.Tensor, seed: torch.Tensor) -> torch.Tensor:
        prev = torch.is_grad_enabled()  # TorchScript has no `with torch.enable_grad()`
        torch.set_grad_enabled(True)
        out = self.inner(p, seed)
        torch.set_grad_enabled(prev)
        return out


def _check_traces(model: nn.Module, value_pt: Path, adj1_pt: Path, n_in: int) -> None:
    """Load the traces as libl4casadi does (torch.jit.freeze, optimize_for_inference) and compare
    value and adjoint with eager torch at a random point: a trace that breaks there (as the
    two-Linear LSTM cell did, shared/notes/dependencies.md) fails the build, not the solve."""
    z = torch.randn(1, n_in, generator=torch.Generator().manual_seed(0))
    seed = torch.tensor([[1.0, 0.5]])
    zg = z.clone().requires_grad_(True)
    want = model(zg)
    want_g = torch.autograd.grad(want, zg, seed)[0]
    want = want.detach()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            value = torch.jit.optimize_for_inference(torch.jit.freeze(torch.jit.load(str(value_pt)).eval()))
            adj1 = torch.jit.optimize_for_inference(torch.jit.freeze(torch.jit.load(str(adj1_pt)).eval()))
            with torch.inference_mode():  # as libl4casadi calls them
                got, got_g = value(z), adj1(z, seed)
    except Exception as exc:
        raise CasadiBuildError(f"the frozen trace does not run: {_one_line(exc)}") from None
    for what, a, b in (("value", got, want), ("gradient", got_g, want_g)):
        err = float((a - b).abs().max() / b.abs().max().clamp_min(1e-12))
        if not err <= 1e-4:
            raise CasadiBuildError(f"the traced {what} differs from torch's by {err:.1e} (relative)")


class _redirect_fd:
    """Point file descriptor `fd` at `target` for the block (os.system's children write there)."""

    def __init__(self, fd: int, target: Any) -> None:
        self.fd, self.target = fd, target

    def __enter__(self) -> None:
        self.saved = os.dup(self.fd)
        os.dup2(self.target.fileno(), self.fd)

    def __exit__(self, *exc: Any) -> None:
        os.dup2(self.saved, self.fd)
        os.close(self.saved)


#: l4casadi's C++ side hands the model FLOAT32 inputs (measured: a relative input change of
#: 1e-9 leaves the output unchanged), which makes the function piecewise constant at ~6e-8
#: relative resolution and stalls Ipopt near an optimum. So each normalised input z is sent
#: as z_hi = floor(z 2^b) / 2^b (exactly representable in float32 while |z| < 2^(24-b)) plus
#: z_lo = z - z_hi (in [0, 2^-b), its float32 rounding ~1e-11), and the model adds them in
#: float64. floor has zero derivative, so the gradient flows through z_lo unchanged.
_SPLIT_BITS = SPLIT_BITS  # judge.compiled.split sends them


class _SplitInput(nn.Module):
    """The judge's flat module (float64) on normalised inputs sent as (z_hi, z_lo) halves."""

    def __init__(self, judge: Judge) -> None:
        super().__init__()
        self.model = _identity_normalization(judge.config.spec.flat_module(judge).double())

    def forward(self, inp: torch.Tensor) -> torch.Tensor:
        n = inp.shape[1] // 2
        inp = inp.to(torch.float64)
        return self.model(inp[:, :n] + inp[:, n:])


def _identity_normalization(model: nn.Module) -> nn.Module:
    """`model` with its normalisation buffers set to mean 0, std 1: CasADi normalises (_normalized)."""
    for module in model.modules():
        for name, buf in module.named_buffers(recurse=False):
            if name in ("x_mean", "e_mean"):
                buf.zero_()
            elif name in ("x_std", "e_std"):
                buf.fill_(1.0)
    return model


def _flat_model(judge: Judge, backend: str) -> nn.Module:
    """The torch module l4casadi traces for `backend` ("l4casadi" or "l4casadi32"): the float64 flat
    module on split inputs, or the architecture's float32 one; CasADi normalises for both."""
    if backend == "l4casadi32":
        return _identity_normalization(judge.config.spec.flat_module32(judge)).eval()
    return _SplitInput(judge)


def _version(dist: str) -> str:
    """An installed distribution's version, "?" where it is not installed (l4casadi 2.0 has no
    __version__ attribute, so the attribute alone keyed every l4casadi version alike)."""
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return "?"


def _generating_code(judge: Judge, backend: str, model: nn.Module | None = None) -> list[object]:
    """What generates `backend`'s library for `judge`: this module's functions and classes that
    build or trace it; the modules of the judge's architecture class and its bases (flat_module,
    flat_module32, native_logit and what they call); for l4casadi the modules of the traced
    `model`'s own classes (the Judge that a generic flat module wraps; torch's own classes are
    keyed by torch's version). Looked up at each call, so the names here are the ones in use."""
    own: list[object] = {
        "compiled": [_compiled_function, _native_function, compiled_library],
        "l4casadi": [_l4casadi_function, _SplitInput, _identity_normalization],
        "l4casadi32": [_l4casadi32_function, _build_l4casadi32, _GradOn, _check_traces, _identity_normalization],
    }[backend]
    arch = [sys.modules[c.__module__] for c in type(judge.config.spec).__mro__ if c is not object]
    traced = [] if model is None else [
        sys.modules[type(m).__module__] for m in model.modules()
        if type(m) not in own and type(m).__module__ != __name__ and type(m).__module__.split(".")[0] != "torch"]
    return own + arch + traced


def _cache_key(judge: Judge, backend: str, model: nn.Module | None = None) -> str:
    """The name of `backend`'s cached library for `judge`, computed without building: the model's
    numbers (model_hash), the versions of what builds it and the source of the code that generates
    it (_generating_code), so an edit to that code builds a new library instead of loading the old
    one. `model`: for l4casadi, the module it traces (_flat_model)."""
    ver = f"l4casadi {_version('l4casadi')}|torch {torch.__version__}|casadi {cs.__version__}"
    versions = {"compiled": cs.__version__, "l4casadi": f"{ver}|split{_SPLIT_BITS}", "l4casadi32": f"{ver}|float32"}
    code = source_digest(*_generating_code(judge, backend, model))
    return hashlib.sha256(f"{model_hash(judge)}|{backend}|{versions[backend]}|{code}".encode()).hexdigest()[:20]


# -- casadi.Callback around torch autograd --------------------------------------------------
class _TorchJudgeCallback(cs.Callback):
    """(traj, env) -> (logit, prob) evaluated by torch in float64.

    Derivatives: reverse mode (one torch backward per adjoint direction) and a Jacobian
    (one backward gives d logit; d prob = p (1 - p) d logit)."""

    def __init__(self, name: str, judge: Judge, dtype: torch.dtype = torch.float64, opts: dict | None = None) -> None:
        cs.Callback.__init__(self)
        self.dtype = dtype
        self.model = _copy(judge, dtype)
        self.nx, self.ne = _n_traj(judge), judge.config.n_env
        self.shape = (judge.config.horizon + 1, judge.config.n_channels)
        self._children: list[cs.Callback] = []
        self._last: tuple[bytes, tuple[torch.Tensor, torch.Tensor, torch.Tensor]] | None = None
        self.construct(name, {"enable_fd": False, **(opts or {})})

    def get_n_in(self) -> int:
        return 2

    def get_n_out(self) -> int:
        return 2

    def get_name_in(self, i: int) -> str:
        return ("traj", "env")[i]

    def get_name_out(self, i: int) -> str:
        return ("logit", "prob")[i]

    def get_sparsity_in(self, i: int) -> cs.Sparsity:
        return cs.Sparsity.dense(self.nx if i == 0 else self.ne, 1)

    def get_sparsity_out(self, i: int) -> cs.Sparsity:
        return cs.Sparsity.dense(1, 1)

    def eval(self, args: list) -> list:
        logit = self._forward(args[0], args[1])[0].item()
        return [logit, sigmoid(logit)]

    def _forward(self, traj: Any, env: Any) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """Forward with the autograd graph kept for the last point: solvers ask for the value
        and then the gradient at the same point, so the gradient costs one backward only."""
        key = np.asarray(traj, dtype=np.float64).tobytes() + np.asarray(env, dtype=np.float64).tobytes()
        if self._last is None or self._last[0] != key:
            x, e = _tensors(traj, env, self.shape, grad=True, dtype=self.dtype)
            self._last = (key, (self.model(x, e), x, e))
        return self._last[1]

    def has_reverse(self, nadj: int) -> bool:
        return True

    def get_reverse(self, nadj: int, name: str, inames: list, onames: list, opts: dict) -> cs.Function:
        cb = _TorchReverse(name, self, nadj, opts)
        self._children.append(cb)
        return cb

    def has_jacobian(self) -> bool:
        return True

    def get_jacobian(self, name: str, inames: list, onames: list, opts: dict) -> cs.Function:
        cb = _TorchJacobian(name, self, opts)
        self._children.append(cb)
        return cb

    def logit_and_grad(self, traj: Any, env: Any) -> tuple[float, np.ndarray, np.ndarray]:
        logit, x, e = self._forward(traj, env)
        gx, ge = torch.autograd.grad(logit, (x, e), retain_graph=True)
        return logit.item(), gx.double().numpy().ravel(), ge.double().numpy().ravel()


class _TorchReverse(cs.Callback):
    """Inputs traj, env, logit, prob (nominal), adj_logit, adj_prob (nadj columns each);
    outputs adj_traj (nx x nadj), adj_env (ne x nadj)."""

    def __init__(self, name: str, parent: _TorchJudgeCallback, nadj: int, opts: dict) -> None:
        cs.Callback.__init__(self)
        self.parent, self.nadj = parent, nadj
        self.construct(name, {"enable_fd": False})

    def get_n_in(self) -> int:
        return 6

    def get_n_out(self) -> int:
        return 2

    def get_sparsity_in(self, i: int) -> cs.Sparsity:
        p = self.parent
        return [cs.Sparsity.dense(p.nx, 1), cs.Sparsity.dense(p.ne, 1), cs.Sparsity.dense(1, 1),
                cs.Sparsity.dense(1, 1), cs.Sparsity.dense(1, self.nadj), cs.Sparsity.dense(1, self.nadj)][i]

    def get_sparsity_out(self, i: int) -> cs.Sparsity:
        p = self.parent
        return cs.Sparsity.dense(p.nx if i == 0 else p.ne, self.nadj)

    def eval(self, args: list) -> list:
        _, gx, ge = self.parent.logit_and_grad(args[0], args[1])
        p = float(args[3])
        seed = np.asarray(args[4]).ravel() + np.asarray(args[5]).ravel() * p * (1 - p)
        return [np.outer(gx, seed), np.outer(ge, seed)]


class _TorchJacobian(cs.Callback):
    """Inputs traj, env, logit, prob; outputs d(logit, prob)/d(traj, env), four blocks."""

    def __init__(self, name: str, parent: _TorchJudgeCallback, opts: dict) -> None:
        cs.Callback.__init__(self)
        self.parent = parent
        self.construct(name, {"enable_fd": False})

    def get_n_in(self) -> int:
        return 4

    def get_n_out(self) -> int:
        return 4

    def get_sparsity_in(self, i: int) -> cs.Sparsity:
        p = self.parent
        return [cs.Sparsity.dense(p.nx, 1), cs.Sparsity.dense(p.ne, 1), cs.Sparsity.dense(1, 1),
                cs.Sparsity.dense(1, 1)][i]

    def get_sparsity_out(self, i: int) -> cs.Sparsity:
        p = self.parent
        return cs.Sparsity.dense(1, p.nx if i % 2 == 0 else p.ne)

    def eval(self, args: list) -> list:
        _, gx, ge = self.parent.logit_and_grad(args[0], args[1])
        p = float(args[3])
        s = p * (1 - p)
        return [gx[None], ge[None], s * gx[None], s * ge[None]]


def torch_logit_and_grad(judge: Judge, traj: Any, env: Any) -> tuple[float, np.ndarray, np.ndarray]:
    """The float64 torch reference every CasADi backend is checked against: logit and its
    gradients with respect to the (N + 1) x 3 trajectory (flattened) and the environment."""
    x, e = _tensors(traj, env, (judge.config.horizon + 1, judge.config.n_channels), grad=True)
    logit = _copy(judge, torch.float64)(x, e)
    gx, ge = torch.autograd.grad(logit, (x, e))
    return logit.item(), gx.numpy().ravel(), ge.numpy().ravel()


def _copy(judge: Judge, dtype: torch.dtype) -> Judge:
    model = Judge(judge.config)
    model.load_state_dict(judge.state_dict())
    for p in model.parameters():
        p.requires_grad_(False)  # gradients w.r.t. the inputs only
    return model.to(dtype).eval()


def _tensors(traj: Any, env: Any, shape: tuple[int, int], grad: bool = False,
             dtype: torch.dtype = torch.float64) -> tuple[torch.Tensor, torch.Tensor]:
    x = torch.tensor(np.asarray(traj, dtype=np.float64).reshape(1, *shape), dtype=dtype, requires_grad=grad)
    e = torch.tensor(np.asarray(env, dtype=np.float64).reshape(1, -1), dtype=dtype, requires_grad=grad)
    return x, e


