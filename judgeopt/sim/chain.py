"""A revolute arm's kinematics and dynamics as CasADi SX expressions, read from a Pinocchio Model.

Why: the compiled control step (judgeopt/sim/compiled.py) needs the same forward kinematics,
frame Jacobian, mass matrix and inverse dynamics Pinocchio computes, as one expression graph
that CasADi turns into C; pinocchio.casadi is not in the `pin` wheel. Everything here is
generic in the model's own data (joint placements, axes, inertias, parents, gravity), for
revolute joints (RX, RY, RZ, unaligned); tests/sim/test_chain.py checks each function against
Pinocchio on random configurations. Spatial quantities are expressed at the world origin in
world axes, (linear, angular) as Pinocchio orders them.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as cs
import numpy as np
import pinocchio as pin

from judgeopt.errors import BadInput

_AXES = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0), "JointModelRZ": (0.0, 0.0, 1.0)}


class UnsupportedModel(BadInput, ValueError):
    """The model has a joint this module does not write out (only revolute joints are)."""


def joint_axes(model: pin.Model) -> list[tuple[float, float, float]]:
    """Each joint's axis in its own frame (joint 1..njoints-1); raises UnsupportedModel otherwise."""
    axes = []
    for j in model.joints[1:]:
        name = j.shortname()
        if name in _AXES:
            axes.append(_AXES[name])
        elif name == "JointModelRevoluteUnaligned":
            axes.append(tuple(float(a) for a in j.extract().axis))
        else:
            raise UnsupportedModel(f"joint type {name} is not supported by the compiled control step")
    return axes


def model_data(model: pin.Model, frame: int) -> dict:
    """Every number the expressions below read from the model (and nothing else): what a built
    library's cache key hashes."""
    return {
        "parents": [int(p) for p in model.parents],
        "axes": joint_axes(model),
        "placements": [np.asarray(m.homogeneous).tolist() for m in model.jointPlacements],
        "inertias": [[float(i.mass), np.asarray(i.lever).tolist(), np.asarray(i.inertia).tolist()]
                     for i in model.inertias],
        "gravity": np.asarray(model.gravity.linear).tolist(),
        "frame_parent": int(model.frames[frame].parentJoint),
        "frame_placement": np.asarray(model.frames[frame].placement.homogeneous).tolist(),
    }


def _rotation(axis: tuple[float, float, float], q: cs.SX) -> cs.SX:
    """Rotation by angle q about a unit axis (Rodrigues); for a principal axis, its exact entries."""
    c, s = cs.cos(q), cs.sin(q)
    x, y, z = axis
    K = cs.SX(np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]]))
    a = np.array(axis)
    return cs.SX(np.eye(3)) * c + K * s + cs.SX(np.outer(a, a)) * (1 - c)


@dataclass
class Kinematics:
    """World placements of every joint and of one frame, and the joints' world motion axes."""

    R: list  # joint frames' rotations (index 0: the universe)
    p: list  # joint origins
    w: list  # joint axes in world axes
    frame_R: cs.SX
    frame_p: cs.SX


def kinematics(data: dict, q: cs.SX) -> Kinematics:
    """Forward kinematics: oMi = oMi[parent] * jointPlacement * exp(axis q)."""
    R, p, w = [cs.SX(np.eye(3))], [cs.SX.zeros(3, 1)], [cs.SX.zeros(3, 1)]
    for i, (parent, axis) in enumerate(zip(data["parents"][1:], data["axes"]), start=1):
        M = np.array(data["placements"][i])
        Rp = cs.mtimes(R[parent], cs.SX(M[:3, :3]))
        p.append(p[parent] + cs.mtimes(R[parent], cs.SX(M[:3, 3])))
        R.append(cs.mtimes(Rp, _rotation(axis, q[i - 1])))
        w.append(cs.mtimes(Rp, cs.SX(np.array(axis))))  # the axis is fixed by the joint's own rotation
    F = np.array(data["frame_placement"])
    k = data["frame_parent"]
    return Kinematics(R, p, w, cs.mtimes(R[k], cs.SX(F[:3, :3])), p[k] + cs.mtimes(R[k], cs.SX(F[:3, 3])))


def _support(data: dict, joint: int) -> list[int]:
    """Joints from the root to `joint` (its ancestors and itself), in no order that matters: the
    Jacobian's columns are indexed by joint."""
    chain = []
    while joint > 0:
        chain.append(joint)
        joint = data["parents"][joint]
    return chain[::-1]


def frame_jacobian(data: dict, kin: Kinematics) -> cs.SX:
    """The frame's 6 x nv Jacobian, LOCAL_WORLD_ALIGNED: linear part the velocity of the frame's
    origin, both parts in world axes."""
    nv = len(data["axes"])
    J = cs.SX.zeros(6, nv)
    for j in _support(data, data["frame_parent"]):
        J[:3, j - 1] = cs.cross(kin.w[j], kin.frame_p - kin.p[j])
        J[3:, j - 1] = kin.w[j]
    return J


def _motion_axes(kin: Kinematics) -> list:
    """Each joint's unit motion at the world origin: (p x w, w)."""
    return [None] + [cs.vertcat(cs.cross(kin.p[j], kin.w[j]), kin.w[j]) for j in range(1, len(kin.p))]


def _world_inertias(data: dict, kin: Kinematics) -> list:
    """Each body's inertia at the world origin as (mass, first moment m c, 3x3 rotational inertia
    about the origin), the form in which composite inertias add up."""
    out = [None]
    for i in range(1, len(kin.p)):
        m, lever, I = data["inertias"][i]
        c = kin.p[i] + cs.mtimes(kin.R[i], cs.SX(np.array(lever)))
        Iw = cs.mtimes(cs.mtimes(kin.R[i], cs.SX(np.array(I))), kin.R[i].T)
        cx = cs.skew(c)
        out.append((m, m * c, Iw - m * cs.mtimes(cx, cx)))
    return out


def _apply(inertia: tuple, motion: cs.SX) -> cs.SX:
    """The force (momentum) of a body of `inertia` moving with `motion` (both at the origin)."""
    m, h, I = inertia
    v, w = motion[:3], motion[3:]
    return cs.vertcat(m * v - cs.cross(h, w), cs.mtimes(I, w) + cs.cross(h, v))


def mass_matrix(data: dict, kin: Kinematics) -> cs.SX:
    """The joint-space mass matrix by composite rigid bodies: M[i, j] = S_i . (Ic_j S_j) for i an
    ancestor of j (or j itself), Ic_j the inertia of j's subtree."""
    parents, n = data["parents"], len(kin.p)
    S, I = _motion_axes(kin), _world_inertias(data, kin)
    composite = list(I)
    for j in range(n - 1, 0, -1):  # a parent's index is below its children's
        k = parents[j]
        if k > 0:
            composite[k] = tuple(a + b for a, b in zip(composite[k], composite[j]))
    M = cs.SX.zeros(n - 1, n - 1)
    for j in range(1, n):
        F = _apply(composite[j], S[j])
        for i in _support(data, j):
            M[i - 1, j - 1] = M[j - 1, i - 1] = cs.dot(S[i], F)
    return M


def _cross_motion(a: cs.SX, b: cs.SX) -> cs.SX:
    return cs.vertcat(cs.cross(a[3:], b[:3]) + cs.cross(a[:3], b[3:]), cs.cross(a[3:], b[3:]))


def _cross_force(a: cs.SX, f: cs.SX) -> cs.SX:
    return cs.vertcat(cs.cross(a[3:], f[:3]), cs.cross(a[3:], f[3:]) + cs.cross(a[:3], f[:3]))


def rnea(data: dict, kin: Kinematics, v: cs.SX, a: cs.SX) -> cs.SX:
    """Inverse dynamics tau = M(q) a + C(q, v) v + g(q) by recursive Newton-Euler, gravity as
    the base's upward acceleration (Pinocchio's convention)."""
    parents, n = data["parents"], len(kin.p)
    S, I = _motion_axes(kin), _world_inertias(data, kin)
    vel = [cs.SX.zeros(6, 1)] * n
    acc = [cs.vertcat(-cs.SX(np.array(data["gravity"])), cs.SX.zeros(3, 1))] * n
    f = [None] * n
    for i in range(1, n):
        k = parents[i]
        vi = S[i] * v[i - 1]
        vel[i] = vel[k] + vi
        acc[i] = acc[k] + S[i] * a[i - 1] + _cross_motion(vel[i], vi)
        f[i] = _apply(I[i], acc[i]) + _cross_force(vel[i], _apply(I[i], vel[i]))
    tau = [None] * (n - 1)
    for i in range(n - 1, 0, -1):
        tau[i - 1] = cs.dot(S[i], f[i])
        if parents[i] > 0:
            f[parents[i]] = f[parents[i]] + f[i]
    return cs.vertcat(*tau)


def log3(R: cs.SX) -> cs.SX:
    """Pinocchio's log3 (pinocchio/spatial/log.hxx): the rotation vector of R, renormalised first,
    with its Taylor expansions near 0 and its branch near pi."""
    eps = float(np.finfo(float).eps)
    prec = eps ** (1.0 / 3.0)  # TaylorSeriesExpansion<double>::precision<2>()
    c0 = R[:, 0] / cs.norm_2(R[:, 0])
    c1 = R[:, 1] / cs.norm_2(R[:, 1])
    c2 = cs.cross(c0, c1)
    c0 = cs.cross(c1, c2)
    Rn = cs.horzcat(c0, c1, c2)
    tr = Rn[0, 0] + Rn[1, 1] + Rn[2, 2]
    cos_value = (tr - 1) / 2
    # singular branch (theta near pi): the axis from the largest diagonal entry
    val = [2 * Rn[k, k] - tr + 1 for k in range(3)]
    thetas, axes = [], []
    for i0 in range(3):
        i1, i2 = (i0 + 1) % 3, (i0 + 2) % 3
        s = cs.sqrt(val[i0] + eps + eps * eps) * cs.if_else(Rn[i2, i1] >= Rn[i1, i2], 1.0, -1.0)
        ax = [None] * 3
        ax[i0] = s / 2
        ax[i1] = 1 / (2 * s) * (Rn[i1, i0] + Rn[i0, i1])
        ax[i2] = 1 / (2 * s) * (Rn[i2, i0] + Rn[i0, i2])
        w = 1 / (2 * s) * (Rn[i2, i1] - Rn[i1, i2])
        axis = cs.vertcat(*ax)
        nrm = cs.norm_2(axis)
        thetas.append(2 * cs.atan2(nrm, w))
        axes.append(axis / nrm)

    def pick(x0, x1, x2):
        return cs.if_else(val[0] >= val[1], cs.if_else(val[0] >= val[2], x0, x2), cs.if_else(val[1] >= val[2], x1, x2))

    theta_singular = pick(*thetas)
    axis_singular = pick(*axes)
    acos_expansion = cs.sqrt(2 * (1 - cos_value) + eps * eps)
    theta = cs.if_else(tr <= 3 - prec, cs.if_else(tr >= -1 + prec, cs.acos(cos_value), np.pi - acos_expansion),
                       acos_expansion)
    anti = cs.vertcat(Rn[2, 1] - Rn[1, 2], Rn[0, 2] - Rn[2, 0], Rn[1, 0] - Rn[0, 1]) / 2
    n2 = cs.dot(anti, anti)
    t = cs.if_else(theta >= prec, theta / cs.sin(theta), 1 + n2 / 6 + n2 * n2 * 3 / 40)
    return cs.if_else(cos_value >= -1 + prec, t * anti, theta_singular * axis_singular)
