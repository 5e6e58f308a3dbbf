"""The hybrid controller's step compiled: one native call per simulated millisecond.

Why: the Python step (judgeopt/sim/controller.py) costs some 20 us of Python-level calls next to
a 40 us physics step (docs/physics.md, "The control step's cost"). Here the whole step, filters,
kinematics, Jacobian, orientation error, force terms, the J^-1 xdd solve, RNEA and the torque
clamp, is one CasADi SX graph (judgeopt/sim/chain.py, read from the Pinocchio model), generated
as C, compiled once with gcc and cached per model, and called through ctypes on one buffer that
holds the inputs, the filter states and the outputs. The arithmetic is the same plant, not the
same rounding: docs/physics.md, "The compiled control step", shows what that changes.
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import logging
import operator
import struct
import sys
from pathlib import Path

import casadi as cs
import numpy as np

from judgeopt.cbuild import CompileError, compiled_library, source_digest
from judgeopt.files import cache_dir
from judgeopt.interrupts import sigint_recorded
from judgeopt.sim import chain
from judgeopt.sim.controller import IDENTITY, ControllerConfig, HybridController, TaskCommand

log = logging.getLogger("judgeopt")

#: where each quantity lives in the shared buffer (doubles; sizes in "nv" are the model's), in
#: this order: first what changes every step (the joint states' part packed with one struct call),
#: then the command, the filter states and the parameters; the outputs follow the inputs
_IN = (("q", "nv"), ("sensor_joint", 1), ("force", 3), ("has_force", 1), ("force_terms", 1), ("force_z", 1),
       ("position_cmd", 3), ("velocity_cmd", 6), ("rotation_cmd", 9), ("selection", 6), ("sensor_rotation", 9),
       ("q_prev", "nv"), ("qd_est", "nv"), ("f_est", 3),
       ("kp", 6), ("kv", 6), ("kf", 6), ("tau_max", "nv"), ("alpha", 1), ("gain", 1), ("one_minus_alpha", 1),
       ("payload_weight", 1), ("q_rest", "nv"), ("null_gains", 2))
_OUT = (("tau", "nv"), ("qd_new", "nv"), ("f_new", 3), ("position", 3), ("velocity", 6), ("rotation", 9))
_SYMBOL = "judgeopt_control_step"
_first = operator.itemgetter(0)


def layout(nv: int) -> tuple[dict[str, slice], dict[str, slice], int]:
    """Slices of the inputs and of the outputs in the buffer (outputs after the inputs), its size."""
    out: list[dict[str, slice]] = []
    start = 0
    for fields in (_IN, _OUT):
        d = {}
        for name, size in fields:
            n = nv if size == "nv" else size
            d[name] = slice(start, start + n)
            start += n
        out.append(d)
    return out[0], out[1], start


def step_functions(model_data: dict) -> tuple[cs.Function, cs.Function]:
    """The step without and with the force terms, each from the input vector to the output vector
    (the layout's order), the same arithmetic as HybridController.step."""
    nv = len(model_data["axes"])
    ins, outs, _ = layout(nv)
    n_in = max(s.stop for s in ins.values())
    x = cs.SX.sym("x", n_in)
    g = {k: x[s] for k, s in ins.items()}
    v = g["alpha"] * g["qd_est"] + g["gain"] * (g["q"] - g["q_prev"])
    kin = chain.kinematics(model_data, g["q"])
    J = chain.frame_jacobian(model_data, kin)
    R, p = kin.frame_R, kin.frame_p
    sensor_R = cs.reshape(g["sensor_rotation"], 3, 3).T  # row-major in the buffer, as the command's rotation
    contact = -cs.mtimes(R, cs.mtimes(sensor_R, g["force"]))
    contact[2] = contact[2] + g["payload_weight"]
    f_new = cs.if_else(g["has_force"] > 0.5, g["alpha"] * g["f_est"] + g["one_minus_alpha"] * contact, g["f_est"])
    velocity = cs.mtimes(J, v)
    target = cs.reshape(g["rotation_cmd"], 3, 3).T  # row-major in the buffer
    err = cs.vertcat(g["position_cmd"] - p, chain.log3(cs.mtimes(target, R.T)))
    S = g["selection"]
    xdd0 = S * (g["kp"] * err + g["kv"] * (g["velocity_cmd"] - velocity))
    fns = []
    for force_terms in (False, True):
        xdd = xdd0
        if force_terms:  # Lambda^-1 F_cmd = J M^-1 J^T F_cmd, F_cmd = (0, 0, -f_z)
            fz = g["force_z"]
            lam_inv_z = cs.mtimes(J, _cholesky_solve(chain.mass_matrix(model_data, kin), J[2, :].T))
            xdd = cs.vertcat(xdd[:2], xdd[2] + (1.0 - S[2]) * g["kf"][2] * (f_new[2] - fz), xdd[3:])
            xdd = xdd - lam_inv_z * fz
        qdd = (cs.solve(J, xdd) if nv == 6 else cs.solve(cs.mtimes(J.T, J), cs.mtimes(J.T, xdd)) if nv < 6
               else _redundant(J, xdd, g, v, chain.mass_matrix(model_data, kin)))
        tau = chain.rnea(model_data, kin, v, qdd)
        tau = cs.fmin(cs.fmax(tau, -g["tau_max"]), g["tau_max"])
        name = "step_force" if force_terms else "step_free"
        # cse: the mass matrix and RNEA share the bodies' world inertias (15 % fewer operations)
        fns.append(cs.Function(name, [x], [cs.vertcat(tau, v, f_new, p, velocity, cs.reshape(R.T, 9, 1))],
                               {"cse": True}))
    return fns[0], fns[1]


def _redundant(J: cs.SX, xdd: cs.SX, g: dict, v: cs.SX, M: cs.SX) -> cs.SX:
    """HybridController._redundant: the dynamically consistent J# = M^-1 J^T Lambda times xdd, plus the
    null space's posture regulation."""
    Minv_Jt = _cholesky_solve(M, J.T)
    posture = -g["null_gains"][0] * (g["q"] - g["q_rest"]) - g["null_gains"][1] * v
    return posture + cs.mtimes(Minv_Jt, cs.solve(cs.mtimes(J, Minv_Jt), xdd - cs.mtimes(J, posture)))


def _cholesky_solve(M: cs.SX, b: cs.SX) -> cs.SX:
    """M^-1 b for a symmetric positive definite M and one or more columns b, by M's Cholesky factor
    (M = L L^T), factored once."""
    n = M.size1()
    L = [[None] * n for _ in range(n)]
    for j in range(n):
        d = M[j, j] - sum((L[j][k] * L[j][k] for k in range(j)), cs.SX(0))
        L[j][j] = cs.sqrt(d)
        for i in range(j + 1, n):
            L[i][j] = (M[i, j] - sum((L[i][k] * L[j][k] for k in range(j)), cs.SX(0))) / L[j][j]
    columns = []
    for c in range(b.size2()):
        y = [None] * n
        for i in range(n):
            y[i] = (b[i, c] - sum((L[i][k] * y[k] for k in range(i)), cs.SX(0))) / L[i][i]
        x = [None] * n
        for i in reversed(range(n)):
            x[i] = (y[i] - sum((L[k][i] * x[k] for k in range(i + 1, n)), cs.SX(0))) / L[i][i]
        columns.append(cs.vertcat(*x))
    return cs.horzcat(*columns)


def _wrapper(free: cs.Function, force: cs.Function, nv: int) -> str:
    """C of the one exported call (one pointer argument: ctypes converts more arguments at a cost
    of about 0.4 us): run a step on the buffer, then move the new filter states into
    the inputs (q_prev <- q, qd_est, f_est) and the outputs after the inputs."""
    ins, outs, size = layout(nv)
    n_in = max(s.stop for s in ins.values())
    n_out = size - n_in
    sz = {k: max(getattr(f, k)() for f in (free, force)) for k in ("sz_arg", "sz_res", "sz_iw", "sz_w")}
    o = {k: s.start - n_in for k, s in outs.items()}
    return f"""
int {_SYMBOL}(double* io) {{
  const casadi_real* arg[{sz['sz_arg'] + 1}];
  casadi_real* res[{sz['sz_res'] + 1}];
  casadi_int iw[{sz['sz_iw'] + 1}];
  casadi_real w[{sz['sz_w'] + 1}];
  double out[{n_out}];
  int i, rc;
  arg[0] = io;
  res[0] = out;
  rc = io[{ins['force_terms'].start}] > 0.5 ? step_force(arg, res, iw, w, 0) : step_free(arg, res, iw, w, 0);
  for (i = 0; i < {nv}; ++i) io[{ins['q_prev'].start} + i] = io[{ins['q'].start} + i];
  for (i = 0; i < {nv}; ++i) io[{ins['qd_est'].start} + i] = out[{o['qd_new']} + i];
  for (i = 0; i < 3; ++i) io[{ins['f_est'].start} + i] = out[{o['f_new']} + i];
  for (i = 0; i < {n_out}; ++i) io[{n_in} + i] = out[i];
  return rc;
}}
"""


def cache_key(model_data: dict) -> str:
    """sha256 of the model's numbers, CasADi's version and the source of the code that generates
    the library (chain.py, this module, cbuild.compiled_library), so an edit to any of them
    builds it again."""
    h = hashlib.sha256(json.dumps(model_data, sort_keys=True).encode())
    h.update(cs.__version__.encode())
    h.update(source_digest(chain, sys.modules[__name__], compiled_library).encode())
    return h.hexdigest()[:20]


def build_library(model_data: dict, root: Path | None = None) -> Path:
    """The compiled step's shared library for this model, built once (a few seconds) and kept in
    the cache folder (judgeopt.cbuild)."""
    key = cache_key(model_data)
    with sigint_recorded() as seen:  # CasADi would drop a Ctrl-C's KeyboardInterrupt (judgeopt.interrupts)
        free, force = step_functions(model_data)
    if seen:
        raise KeyboardInterrupt
    lib, _ = compiled_library([free, force], Path(root or cache_dir()) / "control_step" / key, "control_step",
                              extra_c=_wrapper(free, force, len(model_data["axes"])), info={"key": key})
    return lib


class CompiledController(HybridController):
    """HybridController with its step in C (same interface, same state attributes).

    The filter states, parameters and last outputs live in one buffer the C step reads and
    writes; the state attributes (`q_prev`, `qd_est`, `f_est`, `position`, `velocity`,
    `rotation`) give copies, as the Python step's new arrays each step do; the gains (`kp`,
    `kv`, `kf`, `tau_max`, `payload_weight`) write through when a perturbation sets them."""

    def __init__(self, urdf_path: str, payload_weight: float, tcp_frame: str = "tcp",
                 config: ControllerConfig | None = None, library: Path | None = None):
        self._v: dict[str, np.ndarray] | None = None
        self._params: dict[str, np.ndarray] = {}
        super().__init__(urdf_path, payload_weight, tcp_frame, config)
        lib = ctypes.CDLL(str(library or build_library(chain.model_data(self.model, self.tcp))))
        self._call = getattr(lib, _SYMBOL)
        self._call.argtypes, self._call.restype = (ctypes.c_void_p,), ctypes.c_int
        self._lib = lib  # keeps the library loaded as long as the controller
        nv = self.model.nv
        ins, outs, size = layout(nv)
        self._io = io = np.zeros(size)
        self._ptr = io.ctypes.data
        v = {k: io[sl] for k, sl in {**ins, **outs}.items()}
        v["alpha"][0], v["gain"][0], v["one_minus_alpha"][0] = self._alpha, self._gain, self._one_minus_alpha
        v["null_gains"][:] = self.config.null_kp, self.config.null_kv
        self._rot, self._sensor_R = v["rotation_cmd"].reshape(3, 3), v["sensor_rotation"].reshape(3, 3)
        self._tau = v["tau"]
        self._rot_src: np.ndarray | None = None  # the read-only rotation last copied in (IDENTITY), else None
        self._sel_src: np.ndarray | None = None  # the configured selection once copied in, else None
        self._sensor_src: np.ndarray | None = None  # the sensor rotation in the buffer: IDENTITY (step) or the driver's
        #: the rotation from the sensor's reading to the spatula frame, applied by step_joint_states
        self.sensor_rotation = IDENTITY
        self._pack = struct.Struct(f"{ins['force_z'].stop}d").pack_into  # q, force, has_force, force_terms, force_z
        self._v = v
        for k, value in self._params.items():
            v[k][:] = value
        self.S = np.array(self.S)
        self.S.flags.writeable = False  # copied in only when a command brings its own
        self.reset(self._pending_q)

    def reset(self, q: np.ndarray) -> None:
        v = self._v
        if v is None:  # HybridController.__init__ resets before the buffer exists
            self._pending_q = np.array(q, dtype=float)
            return
        v["q_prev"][:] = q
        v["q_rest"][:] = q
        for k in ("qd_est", "f_est", "position", "velocity"):
            v[k][:] = 0.0
        v["rotation"][:] = IDENTITY.ravel()

    def step(self, q: np.ndarray, sensor_force: np.ndarray | None, cmd: TaskCommand) -> np.ndarray:
        """HybridController.step in one native call; `sensor_force` in the spatula frame."""
        v = self._v
        if self._sensor_src is not IDENTITY:
            self._sensor_R[:] = self._sensor_src = IDENTITY
        v["q"][:] = q
        if sensor_force is None:
            v["has_force"][0] = 0.0
        else:
            v["force"][:] = sensor_force
            v["has_force"][0] = 1.0
        self._command(cmd)
        self._call(self._ptr)
        return v["tau"].copy()

    def step_joint_states(self, states: tuple, sensor_valid: bool, cmd: TaskCommand) -> list[float]:
        """The step from PyBullet's getJointStates of the arm's joints and, last, the sensor joint
        (its reaction force rotated by `sensor_rotation` in C), torques as a list: the driver's
        1 kHz path, with the fewest Python-level calls."""
        if self._sensor_src is not self.sensor_rotation:
            self._sensor_R[:] = self._sensor_src = self.sensor_rotation
        S = self.S if cmd.selection is None else cmd.selection
        # every joint's angle (the sensor joint's lands in a slot of its own, unread), its reaction
        self._pack(self._io, 0, *map(_first, states), *states[-1][2][:3], 1.0 if sensor_valid else 0.0,
                   1.0 if S[2] < 1.0 else 0.0, cmd.force_z)
        self._command(cmd, S)
        self._call(self._ptr)
        return self._tau.tolist()

    def _command(self, cmd: TaskCommand, S: np.ndarray | None = None) -> None:
        """The command into the buffer. The rotation is copied unless it is IDENTITY again (read-only,
        so unchanged), the selection unless it is the configured one (read-only here)."""
        v = self._v
        if S is None:
            S = self.S if cmd.selection is None else cmd.selection
            v["force_terms"][0] = 1.0 if S[2] < 1.0 else 0.0
            v["force_z"][0] = cmd.force_z
        v["position_cmd"][:] = cmd.position
        v["velocity_cmd"][:] = cmd.velocity
        rot = cmd.rotation
        if rot is not IDENTITY or self._rot_src is not IDENTITY:
            self._rot[:] = rot
            self._rot_src = rot if rot is IDENTITY else None
        if S is not self.S or self._sel_src is not S:
            v["selection"][:] = S
            self._sel_src = S if S is self.S else None

    # the states, as copies (the Python step rebinds new arrays every step)
    q_prev = property(lambda self: self._v["q_prev"].copy())
    qd_est = property(lambda self: self._v["qd_est"].copy())
    f_est = property(lambda self: self._v["f_est"].copy())
    position = property(lambda self: self._v["position"].copy())
    velocity = property(lambda self: self._v["velocity"].copy())
    rotation = property(lambda self: self._v["rotation"].reshape(3, 3).copy())


def _parameter(name: str) -> property:
    """A gain the C step reads from the buffer: setting it (a perturbation does) writes it there."""

    def get(self):
        return self._params[name]

    def set(self, value):
        value = float(value) if np.ndim(value) == 0 else np.array(value, dtype=float)
        self._params[name] = value
        if self._v is not None:
            self._v[name][:] = value

    return property(get, set)


for _name in ("kp", "kv", "kf", "tau_max", "payload_weight"):
    setattr(CompiledController, _name, _parameter(_name))


def make_controller(urdf_path: str, payload_weight: float, tcp_frame: str = "tcp",
                    config: ControllerConfig | None = None) -> HybridController:
    """The controller `config.step` names; the compiled one falls back to the Python step with
    one log line where it cannot be built (no gcc, a compile error, an unsupported joint)."""
    cfg = config or ControllerConfig()
    if cfg.step == "python":
        return HybridController(urdf_path, payload_weight, tcp_frame, cfg)
    if cfg.step != "compiled":
        raise ValueError(f"controller step {cfg.step!r}: choose 'compiled' or 'python'")
    try:
        return CompiledController(urdf_path, payload_weight, tcp_frame, cfg)
    except (CompileError, chain.UnsupportedModel, OSError, RuntimeError) as e:
        log.warning("compiled control step unavailable (%s); using the Python step", str(e).splitlines()[0])
        return HybridController(urdf_path, payload_weight, tcp_frame, cfg)
