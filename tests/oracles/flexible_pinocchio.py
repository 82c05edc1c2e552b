"""Test oracle: the free-floating robot with flexible parts on Pinocchio, the independent
reference of the native plant's panels and slosh modes (native/src/dynamics*.c leaves,
plant_leaves.c). Not part of the library; it shares no code with it (the records it reads,
spacerobot.robots.Panel / SloshMode / RigidBody / Robot, are data).

The model (after proto/flexsim.py of the non-rigid study): the base on a free-flyer (or planar)
root, the arm chain with the target appended at E (tests/oracles/pinocchio_model.py), then
each panel a ``RevoluteUnaligned`` joint of the root at its hinge point carrying the panel's
inertia, each slosh mode a ``PrismaticUnaligned`` joint of the root at its equilibrium point
carrying a point mass. Joints are numbered in that order, so Pinocchio's coordinates are the
plant's: ``q = [base, arm (n), leaves (nl)]``, ``v`` likewise.

Springs and dampers from the specification, written out here: a panel
``k = I_h w^2``, ``c = 2 zeta w I_h``, ``I_h = a^T (I_c + m (|d|^2 1 - d d^T)) a``,
``d = com - hinge``, ``w = 2 pi f``; a slosh mode ``k = m w^2``, ``c = 2 zeta w m``.

Hybrid dynamics (the arm's accelerations prescribed, the base and the leaves free):
``M_uu a_u = tau_u - [M_ua qdd + h_u]`` (the bracket: RNEA with ``a_u = 0``),
``tau_u = [A^T F; A^T M; -k q_l - c qd_l]``, ``tau_arm = M_au a_u + [M_aa qdd + h_a]``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import pinocchio as pin

from oracles.pinocchio_model import PlantModel, base_rotation, build_model


@dataclass
class FlexModel:
    """The Pinocchio model with its leaves: ``pm`` (the rigid robot's PlantModel, its model
    extended), ``nl`` leaves, their springs ``k`` and dampers ``c``, ``u`` the free velocity
    indices (base, leaves), ``arm`` the arm's, ``rest`` the leaves at rest (pin.Inertia each,
    at S in base axes)."""

    pm: PlantModel
    model: pin.Model
    data: pin.Data
    nl: int
    k: np.ndarray
    c: np.ndarray
    u: np.ndarray
    arm: np.ndarray
    rest: list

    @property
    def nb(self) -> int:
        return self.pm.nb


def _unit(a) -> np.ndarray:
    a = np.asarray(a, float)
    return a / np.linalg.norm(a)


def build(robot, base, target, panels: Sequence = (), slosh: Sequence = ()) -> FlexModel:
    """The model of ``robot`` with the ``base`` and ``target`` truth, the ``panels``
    (spacerobot.robots.Panel records) and the ``slosh`` modes (SloshMode records) in use."""
    pm = build_model(robot, base, target)
    m = pm.model
    root = 1
    k, c, rest = [], [], []
    for p in panels:
        a = _unit(p.axis)
        h = np.asarray(p.hinge, float)
        com = np.asarray(p.com, float)
        Ic = np.array([[p.Ixx, p.Ixy, p.Ixz], [p.Ixy, p.Iyy, p.Iyz], [p.Ixz, p.Iyz, p.Izz]])
        j = m.addJoint(root, pin.JointModelRevoluteUnaligned(a), pin.SE3(np.eye(3), h),
                       f"panel{len(k)}")
        Y = pin.Inertia(p.m, com - h, Ic)
        m.appendBodyToJoint(j, Y, pin.SE3.Identity())
        rest.append(pin.SE3(np.eye(3), h).act(Y))
        d = com - h
        Ih = float(a @ (Ic + p.m * (d @ d * np.eye(3) - np.outer(d, d))) @ a)
        w = 2.0 * math.pi * p.f
        k.append(Ih * w * w)
        c.append(2.0 * p.zeta * w * Ih)
    for s in slosh:
        a = _unit(s.axis)
        r = np.asarray(s.r, float)
        j = m.addJoint(root, pin.JointModelPrismaticUnaligned(a), pin.SE3(np.eye(3), r),
                       f"slosh{len(k)}")
        Y = pin.Inertia(s.m, np.zeros(3), np.zeros((3, 3)))
        m.appendBodyToJoint(j, Y, pin.SE3.Identity())
        rest.append(pin.SE3(np.eye(3), r).act(Y))
        w = 2.0 * math.pi * s.f
        k.append(s.m * w * w)
        c.append(2.0 * s.zeta * w * s.m)
    nl = len(k)
    nb, n = pm.nb, pm.n
    u = np.r_[np.arange(nb), nb + n + np.arange(nl)]
    arm = nb + np.arange(n)
    return FlexModel(pm, m, m.createData(), nl, np.array(k), np.array(c), u, arm, rest)


def body_vector(Y: pin.Inertia) -> np.ndarray:
    """m, b (3), Ixx Iyy Izz Ixy Ixz Iyz (about the centre of mass) of a pin.Inertia."""
    I = Y.inertia
    return np.array([Y.mass, *Y.lever, I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])


def composite(fm: FlexModel, base_extra: Sequence[pin.Inertia] = ()) -> np.ndarray:
    """The composite rigid base: the base (+ ``base_extra``, e.g. the rigid propellant, at S)
    + the leaves at rest, as the 10 numbers of :func:`body_vector`."""
    Y = pin.Inertia(fm.pm.base.mass, np.array(fm.pm.base.com, float),
                    fm.pm.base.inertia_matrix())
    for X in list(base_extra) + fm.rest:
        Y = Y + X
    return body_vector(Y)


def mass_matrix(fm: FlexModel, q) -> np.ndarray:
    M = pin.crba(fm.model, fm.data, np.asarray(q, float))
    return np.triu(M) + np.triu(M, 1).T


def hybrid(fm: FlexModel, q, v, qdd, F, M_S):
    """The free accelerations ``a_u`` (base: Pinocchio's convention, then the leaves) and the
    arm's torques for the arm accelerations ``qdd`` and the thrust ``F`` at S and its moment
    ``M_S`` about S (both inertial)."""
    q, v = np.asarray(q, float), np.asarray(v, float)
    nb, nl = fm.nb, fm.nl
    a0 = np.zeros(fm.model.nv)
    a0[fm.arm] = qdd
    M = mass_matrix(fm, q)
    b = pin.rnea(fm.model, fm.data, q, v, a0)
    A = base_rotation(fm.pm, q)
    fl, fn = A.T @ np.asarray(F, float), A.T @ np.asarray(M_S, float)
    fb = np.r_[fl[:2], fn[2]] if fm.pm.planar else np.r_[fl, fn]
    ql = q[fm.model.nq - nl:]
    tau_u = np.r_[fb, -fm.k * ql - fm.c * v[fm.u[nb:]]]
    au = np.linalg.solve(M[np.ix_(fm.u, fm.u)], tau_u - b[fm.u])
    tau = M[np.ix_(fm.arm, fm.u)] @ au + b[fm.arm]
    return au, tau


def momentum(fm: FlexModel, q, v, rigid: bool = False):
    """Total linear momentum P and angular momentum about the inertial origin L (inertial);
    ``rigid``: of the composite rigid body at the same base and arm motion (the leaves at rest,
    q_l = qd_l = 0)."""
    q, v = np.array(q, float), np.array(v, float)
    if rigid and fm.nl:
        q[fm.model.nq - fm.nl:] = 0.0
        v[fm.u[fm.nb:]] = 0.0
    pin.computeCentroidalMomentum(fm.model, fm.data, q, v)
    P = fm.data.hg.linear.copy()
    c = fm.data.com[0].copy()
    return P, fm.data.hg.angular + np.cross(c, P)


def energy(fm: FlexModel, q, v) -> float:
    """Kinetic energy plus the springs' energy."""
    v = np.asarray(v, float)
    ql = np.asarray(q, float)[fm.model.nq - fm.nl:]
    return float(0.5 * v @ mass_matrix(fm, q) @ v + 0.5 * fm.k @ (ql * ql))


def linear_frequencies(fm: FlexModel, q) -> np.ndarray:
    """The frequencies [Hz] of the flexible modes linearised about the configuration q with the
    arm held and the base free: the generalised eigenvalues of the springs over M_uu (the
    base's rigid-body ones, 0, dropped)."""
    from scipy.linalg import eigh
    M = mass_matrix(fm, q)[np.ix_(fm.u, fm.u)]
    K = np.zeros_like(M)
    K[fm.nb:, fm.nb:] = np.diag(fm.k)
    lam = eigh(K, M, eigvals_only=True)
    return np.sqrt(np.clip(np.sort(lam)[fm.nb:], 0.0, None)) / (2.0 * math.pi)


def matrix_pencil(y: np.ndarray, dt: float, order: int):
    """Frequencies [Hz] and damping ratios of the ``order`` poles of the multichannel signal
    y (N, c): block-Hankel matrices, truncated SVD, eigenvalues of the shift (ESPRIT)."""
    N, nc = y.shape
    L = N // 2
    H = np.vstack([np.stack([y[i:i + N - L, j] for i in range(L)]) for j in range(nc)])
    _, _, Vt = np.linalg.svd(H, full_matrices=False)
    V = Vt[:order].T
    Z = np.linalg.lstsq(V[:-1], V[1:], rcond=None)[0]
    s = np.log(np.linalg.eigvals(Z).astype(complex)) / dt
    f = np.abs(s.imag) / (2.0 * math.pi)
    i = np.argsort(f)
    return f[i], (-s.real / np.abs(s))[i]


def with_tank(dry, m: float, r, R: float):
    """The body (spacerobot.robots.RigidBody-like: mass, com, inertia_matrix()) of ``dry`` plus
    a rigid sphere of ``m`` kg of radius ``R`` centred at ``r`` (base frame), as a pin.Inertia
    sum: the base of the leaf model with the rigid part of the propellant."""
    Y = pin.Inertia(dry.mass, np.array(dry.com, float), dry.inertia_matrix())
    if m > 0.0:
        Y = Y + pin.SE3(np.eye(3), np.asarray(r, float)).act(
            pin.Inertia(m, np.zeros(3), 0.4 * m * R * R * np.eye(3)))
    return _Body(Y)


class _Body:
    """A pin.Inertia seen as a body (mass, com, inertia_matrix(), inertia)."""

    def __init__(self, Y: pin.Inertia):
        v = body_vector(Y)
        self.mass, self.com, self.inertia = float(v[0]), tuple(v[1:4]), tuple(v[4:])
        self._I = Y.inertia.copy()

    def inertia_matrix(self) -> np.ndarray:
        return self._I.copy()
