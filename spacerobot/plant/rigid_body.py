"""Compiled (Numba) rigid-body dynamics of a floating base carrying a serial chain of revolute
joints: the articulated-body algorithm (forward dynamics), the composite-rigid-body algorithm
(joint-space inertia ``M``), the recursive Newton-Euler non-linear effects ``c(q, v)`` and the
centroidal momentum, in Pinocchio's conventions so that Pinocchio is the reference they are
tested against (tests/test_compiled_dynamics.py).

The model arrays come from a Pinocchio model (:func:`chain_arrays`: joint placements, body
inertias, joint axes), so any robot Pinocchio builds (from code or URDF) whose root joint is a
free-flyer or a planar joint, followed by a serial chain of one-axis revolute joints, runs here.

Conventions (Pinocchio's): spatial motion ``[linear; angular]`` and force ``[linear; angular]``;
the algorithms express them in base axes (the "spatial algebra" comment below: ``terms`` at the
base origin, ``aba`` at each joint's origin), and their results (``ddq``, ``M``, ``nle``, ``hg``)
are Pinocchio's. Body ``k = 0`` is the base (root joint),
``k = 1..n`` the links. ``R[k], p[k]`` is the placement of joint ``k`` in its parent's frame
(``x_parent = R x_k + p``; for ``k = 0`` the identity); a revolute joint turns about
``axis[k]`` (unit, in its own frame). The planar root joint is the free-flyer restricted to
``(v_x, v_y, omega_z)``: its motion subspace is the columns 0, 1, 5 of the identity
(:func:`_row`), with no bias acceleration (as for the free-flyer, whose velocity is
expressed in the base frame). The model must be gravity-free (a free-floating robot).

Self-contained (only NumPy and Numba) because it is a compiled kernel module with a persistent
cache (:mod:`spacerobot.jit`); :mod:`.kernels` uses its functions and is cached with it.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

# error_model='numpy': a division by zero gives inf/NaN (no Python exception check per division)
_NB = dict(cache=True, nogil=True, error_model="numpy")
# inlined into their callers (Numba IR): a call that passes arrays costs about as much as a
# joint's arithmetic (every array is passed as its fields, and reference-counted)
_NI = dict(_NB, inline="always")


def chain_arrays(model) -> tuple:
    """Arrays of the compiled model from a Pinocchio model.

    Parameters
    ----------
    model : pinocchio.Model
        root joint 1 a ``JointModelFreeFlyer`` or ``JointModelPlanar`` at the identity
        placement, joints 2.. one-axis revolute joints (``RX``, ``RY``, ``RZ``,
        ``RevoluteUnaligned``), each the child of the previous one; zero gravity.

    Returns
    -------
    planar : bool
    R : (n + 1, 3, 3), p : (n + 1, 3)   joint placements in the parent frame
    axis : (n + 1, 3)                    revolute axes (row 0 unused)
    I6 : (n + 1, 6, 6)                   spatial inertias at the joint origins
    mc : (n + 1, 4)                      mass [kg] and centre of mass (joint frame) [m]

    Raises ``ValueError`` for a model outside that family.
    """
    nj = model.njoints
    root = model.joints[1].shortname() if nj > 1 else ""
    if root not in ("JointModelFreeFlyer", "JointModelPlanar"):
        raise ValueError(f"root joint must be a free-flyer or planar joint, got {root!r}")
    if not np.allclose(model.jointPlacements[1].homogeneous, np.eye(4), rtol=0.0, atol=0.0):
        raise ValueError("the root joint must be placed at the identity")
    if np.any(np.asarray(model.gravity.vector) != 0.0):
        raise ValueError("the compiled dynamics is for a gravity-free model")
    n = nj - 2
    R, p = np.zeros((n + 1, 3, 3)), np.zeros((n + 1, 3))
    axis, I6, mc = np.zeros((n + 1, 3)), np.zeros((n + 1, 6, 6)), np.zeros((n + 1, 4))
    unit = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0),
            "JointModelRZ": (0.0, 0.0, 1.0)}
    for k in range(n + 1):
        j = k + 1
        if k > 0:
            jm = model.joints[j]
            name = jm.shortname()
            if model.parents[j] != j - 1:
                raise ValueError(f"joint {j} is not the child of joint {j - 1}: not a serial chain")
            if name in unit:
                axis[k] = unit[name]
            elif name == "JointModelRevoluteUnaligned":
                axis[k] = np.asarray(jm.extract().axis, float)
            else:
                raise ValueError(f"joint {j} ({name}) is not a one-axis revolute joint")
        M = model.jointPlacements[j]
        R[k], p[k] = M.rotation, M.translation
        Y = model.inertias[j]
        m, c = float(Y.mass), np.asarray(Y.lever, float)
        cx = np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])
        # I6 = [[m 1, -m [c]x], [m [c]x, I_c - m [c]x [c]x]]  (Pinocchio's Inertia.matrix())
        I6[k, :3, :3] = m * np.eye(3)
        I6[k, :3, 3:] = -m * cx
        I6[k, 3:, :3] = m * cx
        I6[k, 3:, 3:] = np.asarray(Y.inertia, float) - m * cx @ cx
        mc[k, 0], mc[k, 1:] = m, c
    return root == "JointModelPlanar", R, p, axis, I6, mc


# -- small linear algebra -------------------------------------------------------------------


@njit(**_NB)
def cholesky(S, L):
    """Lower Cholesky factor of the SPD matrix ``S`` into ``L``; False if a pivot is <= 0
    (a NaN pivot passes, so that NaN propagates)."""
    k = S.shape[0]
    for j in range(k):
        d = S[j, j]
        for p in range(j):
            d -= L[j, p] * L[j, p]
        if d <= 0.0:
            return False
        d = math.sqrt(d)
        L[j, j] = d
        for i in range(j + 1, k):
            s = S[i, j]
            for p in range(j):
                s -= L[i, p] * L[j, p]
            L[i, j] = s / d
        for i in range(j):
            L[i, j] = 0.0
    return True


@njit(**_NI)
def cho_solve(L, B):
    """Solve ``L L^T X = B`` in place of ``B`` (k, c).

    Row by row with the columns innermost (independent, so they pipeline), each entry summed
    in the same order as a column-by-column substitution."""
    k, c = B.shape
    for i in range(k):                   # L Y = B
        for p in range(i):
            lip = L[i, p]
            for col in range(c):
                B[i, col] -= lip * B[p, col]
        d = L[i, i]
        for col in range(c):
            B[i, col] /= d
    for i in range(k - 1, -1, -1):       # L^T X = Y
        for p in range(i + 1, k):
            lpi = L[p, i]
            for col in range(c):
                B[i, col] -= lpi * B[p, col]
        d = L[i, i]
        for col in range(c):
            B[i, col] /= d


# -- spatial algebra ----------------------------------------------------------------------------
#
# Every algorithm works in the base frame: the inertial frame that coincides with the base's body
# frame at the instant considered. Without gravity the dynamics do not depend on the base's
# pose, and in that frame the base's generalised velocity and acceleration (Pinocchio's, in the
# base frame) are its spatial velocity and acceleration, so only the chain's placements relative
# to the base are needed. Spatial vectors of all bodies are then expressed in one frame at one
# point (the base origin): velocities, accelerations and forces add along the chain without
# transforms, and each body's inertia is moved into that frame once per call (Pinocchio's
# WORLD convention of its ABA, with the base frame as the world).


@njit(**_NI)
def _rot_sym(Rk, a00, a01, a02, a11, a12, a22):
    """Upper triangle of ``Rk A Rk^T`` for the symmetric ``A`` given by its upper triangle."""
    w00 = Rk[0, 0] * a00 + Rk[0, 1] * a01 + Rk[0, 2] * a02          # W = Rk A
    w01 = Rk[0, 0] * a01 + Rk[0, 1] * a11 + Rk[0, 2] * a12
    w02 = Rk[0, 0] * a02 + Rk[0, 1] * a12 + Rk[0, 2] * a22
    w10 = Rk[1, 0] * a00 + Rk[1, 1] * a01 + Rk[1, 2] * a02
    w11 = Rk[1, 0] * a01 + Rk[1, 1] * a11 + Rk[1, 2] * a12
    w12 = Rk[1, 0] * a02 + Rk[1, 1] * a12 + Rk[1, 2] * a22
    w20 = Rk[2, 0] * a00 + Rk[2, 1] * a01 + Rk[2, 2] * a02
    w21 = Rk[2, 0] * a01 + Rk[2, 1] * a11 + Rk[2, 2] * a12
    w22 = Rk[2, 0] * a02 + Rk[2, 1] * a12 + Rk[2, 2] * a22
    return (w00 * Rk[0, 0] + w01 * Rk[0, 1] + w02 * Rk[0, 2],     # (W Rk^T)_ij = W_i . Rk_j
            w00 * Rk[1, 0] + w01 * Rk[1, 1] + w02 * Rk[1, 2],
            w00 * Rk[2, 0] + w01 * Rk[2, 1] + w02 * Rk[2, 2],
            w10 * Rk[1, 0] + w11 * Rk[1, 1] + w12 * Rk[1, 2],
            w10 * Rk[2, 0] + w11 * Rk[2, 1] + w12 * Rk[2, 2],
            w20 * Rk[2, 0] + w21 * Rk[2, 1] + w22 * Rk[2, 2])


@njit(**_NI)
def _placements(planar, R, p, axis, q, bR, bp, S):
    """Placement of every body in the base frame, ``bR[k]`` (3, 3), ``bp[k]`` (3,)
    (``x_base = bR x_k + bp``), and the axis of joint ``k`` in the base frame,
    ``S[k, 3:] = bR_p R[k] axis[k]``. Body ``k`` sits at
    ``x_parent = R[k] Rot(axis[k], q_k) x_k + p[k]``."""
    nb = R.shape[0]
    nq0 = 4 if planar else 7
    for i in range(3):
        bp[0, i] = 0.0
        for j in range(3):
            bR[0, i, j] = 1.0 if i == j else 0.0
    for k in range(1, nb):
        th = q[nq0 + k - 1]
        ax, ay, az = axis[k, 0], axis[k, 1], axis[k, 2]
        sn, cs = math.sin(th), math.cos(th)
        t = 1.0 - cs
        # Rot(a, th) = cos I + sin [a]x + (1 - cos) a a^T
        j00, j01, j02 = cs + t * ax * ax, t * ax * ay - sn * az, t * ax * az + sn * ay
        j10, j11, j12 = t * ax * ay + sn * az, cs + t * ay * ay, t * ay * az - sn * ax
        j20, j21, j22 = t * ax * az - sn * ay, t * ay * az + sn * ax, cs + t * az * az
        px, py, pz = p[k, 0], p[k, 1], p[k, 2]
        for i in range(3):
            # row i of A = bR_p R_k; bR_k = A Rot; bp_k = bp_p + bR_p p_k; s = A axis
            b0, b1, b2 = bR[k - 1, i, 0], bR[k - 1, i, 1], bR[k - 1, i, 2]
            a0 = b0 * R[k, 0, 0] + b1 * R[k, 1, 0] + b2 * R[k, 2, 0]
            a1 = b0 * R[k, 0, 1] + b1 * R[k, 1, 1] + b2 * R[k, 2, 1]
            a2 = b0 * R[k, 0, 2] + b1 * R[k, 1, 2] + b2 * R[k, 2, 2]
            bR[k, i, 0] = a0 * j00 + a1 * j10 + a2 * j20
            bR[k, i, 1] = a0 * j01 + a1 * j11 + a2 * j21
            bR[k, i, 2] = a0 * j02 + a1 * j12 + a2 * j22
            bp[k, i] = bp[k - 1, i] + (b0 * px + b1 * py + b2 * pz)
            S[k, 3 + i] = a0 * ax + a1 * ay + a2 * az


@njit(**_NI)
def _kinematics(planar, R, p, axis, I6, q, v, bR, bp, S, vel, cb, Ib):
    """Placements, joint motions, velocities and inertias of every body in the base frame at
    the base origin (the frame of :func:`terms`).

    Writes :func:`_placements`' ``bR``, ``bp`` and, for body ``k``: ``S[k]`` (6,) the motion of
    joint ``k`` per unit rate, ``[bp x s; s]`` (row 0 unused); ``vel[k]`` (6,) its spatial
    velocity; ``cb[k] = vel[k] x (S_k qd_k)`` (the bias acceleration, ``dS/dt qd`` in a fixed
    frame); ``Ib[k]`` (6, 6) its spatial inertia.
    """
    nb = R.shape[0]
    nr = 3 if planar else 6
    _placements(planar, R, p, axis, q, bR, bp, S)
    for i in range(6):
        vel[0, i] = 0.0
        cb[0, i] = 0.0
        S[0, i] = 0.0
        for j in range(6):
            Ib[0, i, j] = I6[0, i, j]
    for j in range(nr):
        vel[0, _row(planar, j)] = v[j]
    for k in range(1, nb):
        ox, oy, oz = bp[k, 0], bp[k, 1], bp[k, 2]
        s3, s4, s5 = S[k, 3], S[k, 4], S[k, 5]
        s0, s1, s2 = oy * s5 - oz * s4, oz * s3 - ox * s5, ox * s4 - oy * s3
        S[k, 0], S[k, 1], S[k, 2] = s0, s1, s2
        # velocity: v_k = v_p + S qd;  c_k = v_k x (S qd) = [w x sl + vl x sw; w x sw] qd
        qd = v[nr + k - 1]
        vl0 = vel[k - 1, 0] + s0 * qd
        vl1 = vel[k - 1, 1] + s1 * qd
        vl2 = vel[k - 1, 2] + s2 * qd
        w0 = vel[k - 1, 3] + s3 * qd
        w1 = vel[k - 1, 4] + s4 * qd
        w2 = vel[k - 1, 5] + s5 * qd
        vel[k, 0], vel[k, 1], vel[k, 2], vel[k, 3], vel[k, 4], vel[k, 5] = vl0, vl1, vl2, w0, w1, w2
        cb[k, 0] = (w1 * s2 - w2 * s1 + vl1 * s5 - vl2 * s4) * qd
        cb[k, 1] = (w2 * s0 - w0 * s2 + vl2 * s3 - vl0 * s5) * qd
        cb[k, 2] = (w0 * s1 - w1 * s0 + vl0 * s4 - vl1 * s3) * qd
        cb[k, 3] = (w1 * s5 - w2 * s4) * qd
        cb[k, 4] = (w2 * s3 - w0 * s5) * qd
        cb[k, 5] = (w0 * s4 - w1 * s3) * qd
        _inertia_to_base(I6, k, bR[k], ox, oy, oz, Ib[k])


@njit(**_NI)
def _inertia_rotated(I6, k, Rk, out):
    """Spatial inertia (6, 6) of body ``k`` at its own origin in the axes of ``Rk`` (its
    rotation in the base frame), from ``I6[k] = [[m 1, -[h]x], [[h]x, I_o]]`` (``h = m c``):
    ``[[m 1, -[h']x], [[h']x, I_o']]`` with ``h' = Rk h``, ``I_o' = Rk I_o Rk^T``.
    Returns ``m``, ``h'`` (3 floats) and the upper triangle of ``I_o'`` (6 floats)."""
    m = I6[k, 0, 0]
    hx, hy, hz = I6[k, 5, 1], I6[k, 3, 2], I6[k, 4, 0]          # [h]x = m [c]x
    g0 = Rk[0, 0] * hx + Rk[0, 1] * hy + Rk[0, 2] * hz
    g1 = Rk[1, 0] * hx + Rk[1, 1] * hy + Rk[1, 2] * hz
    g2 = Rk[2, 0] * hx + Rk[2, 1] * hy + Rk[2, 2] * hz
    i00, i01, i02, i11, i12, i22 = _rot_sym(Rk, I6[k, 3, 3], I6[k, 3, 4], I6[k, 3, 5],
                                            I6[k, 4, 4], I6[k, 4, 5], I6[k, 5, 5])
    out[3, 3], out[4, 4], out[5, 5] = i00, i11, i22
    out[3, 4], out[4, 3] = i01, i01
    out[3, 5], out[5, 3] = i02, i02
    out[4, 5], out[5, 4] = i12, i12
    _mass_blocks(m, g0, g1, g2, out)
    return m, g0, g1, g2, i00, i01, i02, i11, i12, i22


@njit(**_NI)
def _mass_blocks(m, g0, g1, g2, out):
    """The blocks ``[[m 1, -[g]x], [[g]x, .]]`` of a spatial inertia of first moment ``g``."""
    for i in range(3):
        for j in range(3):
            out[i, j] = m if i == j else 0.0
    out[0, 3], out[0, 4], out[0, 5] = 0.0, g2, -g1
    out[1, 3], out[1, 4], out[1, 5] = -g2, 0.0, g0
    out[2, 3], out[2, 4], out[2, 5] = g1, -g0, 0.0
    out[3, 0], out[3, 1], out[3, 2] = 0.0, -g2, g1
    out[4, 0], out[4, 1], out[4, 2] = g2, 0.0, -g0
    out[5, 0], out[5, 1], out[5, 2] = -g1, g0, 0.0


@njit(**_NI)
def _shift_add(px, py, pz, Ia, T, out):
    """``out += X^T Ia X`` (inertia to the parent's origin) for the pure translation
    ``X = [[1, -P], [0, 1]]``, ``P = [d]x``, ``d = (px, py, pz)`` the child's origin seen from
    the parent's: with the symmetric ``Ia = [[A, B], [B^T, C]]``,
    ``X^T Ia X = [[A, B - A P], [(.)^T, C + P B + (P B)^T - P A P]]``.
    Only the upper triangle of ``Ia`` is read. ``T`` (6, 6) scratch."""
    a00, a01, a02, a11, a12, a22 = Ia[0, 0], Ia[0, 1], Ia[0, 2], Ia[1, 1], Ia[1, 2], Ia[2, 2]
    B = Ia[0:3, 3:6]
    # A P, P = [[0, -pz, py], [pz, 0, -px], [-py, px, 0]] (rows of A are symmetric)
    ap00, ap01, ap02 = a01 * pz - a02 * py, a02 * px - a00 * pz, a00 * py - a01 * px
    ap10, ap11, ap12 = a11 * pz - a12 * py, a12 * px - a01 * pz, a01 * py - a11 * px
    ap20, ap21, ap22 = a12 * pz - a22 * py, a22 * px - a02 * pz, a02 * py - a12 * px
    # P (A P): row i of P times the columns
    pap00 = -pz * ap10 + py * ap20
    pap01 = -pz * ap11 + py * ap21
    pap02 = -pz * ap12 + py * ap22
    pap11 = pz * ap01 - px * ap21
    pap12 = pz * ap02 - px * ap22
    pap22 = -py * ap02 + px * ap12
    # P B
    pb00 = -pz * B[1, 0] + py * B[2, 0]
    pb01 = -pz * B[1, 1] + py * B[2, 1]
    pb02 = -pz * B[1, 2] + py * B[2, 2]
    pb10 = pz * B[0, 0] - px * B[2, 0]
    pb11 = pz * B[0, 1] - px * B[2, 1]
    pb12 = pz * B[0, 2] - px * B[2, 2]
    pb20 = -py * B[0, 0] + px * B[1, 0]
    pb21 = -py * B[0, 1] + px * B[1, 1]
    pb22 = -py * B[0, 2] + px * B[1, 2]
    # A
    out[0, 0] += a00
    out[0, 1] += a01
    out[0, 2] += a02
    out[1, 0] += a01
    out[1, 1] += a11
    out[1, 2] += a12
    out[2, 0] += a02
    out[2, 1] += a12
    out[2, 2] += a22
    # B - A P and its transpose
    T[0, 0], T[0, 1], T[0, 2] = ap00, ap01, ap02
    T[1, 0], T[1, 1], T[1, 2] = ap10, ap11, ap12
    T[2, 0], T[2, 1], T[2, 2] = ap20, ap21, ap22
    for i in range(3):
        for j in range(3):
            bij = B[i, j] - T[i, j]
            out[i, 3 + j] += bij
            out[3 + j, i] += bij
    # C + P B + (P B)^T - P A P
    d00 = Ia[3, 3] + 2.0 * pb00 - pap00
    d11 = Ia[4, 4] + 2.0 * pb11 - pap11
    d22 = Ia[5, 5] + 2.0 * pb22 - pap22
    d01 = Ia[3, 4] + pb01 + pb10 - pap01
    d02 = Ia[3, 5] + pb02 + pb20 - pap02
    d12 = Ia[4, 5] + pb12 + pb21 - pap12
    out[3, 3] += d00
    out[4, 4] += d11
    out[5, 5] += d22
    out[3, 4] += d01
    out[4, 3] += d01
    out[3, 5] += d02
    out[5, 3] += d02
    out[4, 5] += d12
    out[5, 4] += d12


@njit(**_NI)
def _inertia_to_base(I6, k, Rk, ox, oy, oz, out):
    """Spatial inertia (6, 6) at the base origin of body ``k``, whose frame sits at ``Rk``,
    ``o`` in the base frame, from ``I6[k] = [[m 1, -[h]x], [[h]x, I_o]]`` at its own origin
    (``h = m c``): ``h' = Rk h``, ``I_o' = Rk I_o Rk^T``, then the shift to the base origin,
    ``h_b = h' + m o`` and ``I_O = I_o' - [o]x [h']x - [h']x [o]x - m [o]x [o]x``
    ``= I_o' + (2 o.h' + m |o|^2) 1 - (h' o^T + o h'^T + m o o^T)``."""
    m = I6[k, 0, 0]
    hx, hy, hz = I6[k, 5, 1], I6[k, 3, 2], I6[k, 4, 0]          # [h]x = m [c]x
    h0 = Rk[0, 0] * hx + Rk[0, 1] * hy + Rk[0, 2] * hz
    h1 = Rk[1, 0] * hx + Rk[1, 1] * hy + Rk[1, 2] * hz
    h2 = Rk[2, 0] * hx + Rk[2, 1] * hy + Rk[2, 2] * hz
    i00, i01, i02, i11, i12, i22 = _rot_sym(Rk, I6[k, 3, 3], I6[k, 3, 4], I6[k, 3, 5],
                                            I6[k, 4, 4], I6[k, 4, 5], I6[k, 5, 5])
    mo0, mo1, mo2 = m * ox, m * oy, m * oz
    d = 2.0 * (ox * h0 + oy * h1 + oz * h2) + (mo0 * ox + mo1 * oy + mo2 * oz)
    # h' o^T + o h'^T + m o o^T = g o^T + o h'^T with g = h' + m o = h_b
    g0, g1, g2 = h0 + mo0, h1 + mo1, h2 + mo2
    out[3, 3] = i00 + d - (g0 * ox + ox * h0)
    out[4, 4] = i11 + d - (g1 * oy + oy * h1)
    out[5, 5] = i22 + d - (g2 * oz + oz * h2)
    e01 = i01 - (g0 * oy + ox * h1)
    e02 = i02 - (g0 * oz + ox * h2)
    e12 = i12 - (g1 * oz + oy * h2)
    out[3, 4], out[4, 3] = e01, e01
    out[3, 5], out[5, 3] = e02, e02
    out[4, 5], out[5, 4] = e12, e12
    _mass_blocks(m, g0, g1, g2, out)          # [[m 1, -[g]x], [[g]x, I_O]]


@njit(**_NI)
def _crf_add(v, f, out):
    """Force cross product ``out += v x* f`` = ``[w x f_l; w x f_n + v_l x f_l]``."""
    vl0, vl1, vl2, w0, w1, w2 = v[0], v[1], v[2], v[3], v[4], v[5]
    fl0, fl1, fl2, fn0, fn1, fn2 = f[0], f[1], f[2], f[3], f[4], f[5]
    out[0] += w1 * fl2 - w2 * fl1
    out[1] += w2 * fl0 - w0 * fl2
    out[2] += w0 * fl1 - w1 * fl0
    out[3] += w1 * fn2 - w2 * fn1 + vl1 * fl2 - vl2 * fl1
    out[4] += w2 * fn0 - w0 * fn2 + vl2 * fl0 - vl0 * fl2
    out[5] += w0 * fn1 - w1 * fn0 + vl0 * fl1 - vl1 * fl0


@njit(**_NI)
def _row(planar, i):
    """Row of the base spatial velocity ``[v; omega]`` that is the base's generalised velocity
    ``i``: all six for the free-flyer, rows 0, 1, 5 (``v_x, v_y, omega_z``) planar."""
    return 5 if planar and i == 2 else i


@njit(**_NI)
def _base_solve(planar, IA0, pA0, tau, L, d, w, x):
    """The base's acceleration of the articulated-body algorithm: ``x[:nr]`` from
    ``(S^T IA0 S) x = tau[:nr] - S^T pA0`` (``S`` the rows :func:`_row`; ``nr`` = 3 planar,
    6 free-flyer) by ``L D L^T`` (no square roots; one division per pivot).

    ``IA0`` (6, 6) articulated inertia of the base, ``pA0`` (6,) its bias force, ``tau``
    (nr + n,); ``L`` (6, 6), ``d``, ``w`` (6,) scratch. Returns False if a pivot is <= 0 (not
    positive definite; a NaN pivot passes, so that NaN propagates).
    """
    nr = 3 if planar else 6
    for i in range(nr):
        ri = _row(planar, i)
        x[i] = tau[i] - pA0[ri]
        for j in range(i + 1):
            L[i, j] = IA0[ri, _row(planar, j)]
    for j in range(nr):
        # w_p = L_jp d_p;  d_j = A_jj - sum_p L_jp w_p;  L_ij = (A_ij - sum_p L_ip w_p) / d_j
        dj = L[j, j]
        for p in range(j):
            w[p] = L[j, p] * d[p]
            dj -= L[j, p] * w[p]
        if dj <= 0.0:
            return False
        d[j] = dj
        r = 1.0 / dj
        for i in range(j + 1, nr):
            s = L[i, j]
            for p in range(j):
                s -= L[i, p] * w[p]
            L[i, j] = s * r
    for i in range(nr):                  # L z = b
        s = x[i]
        for p in range(i):
            s -= L[i, p] * x[p]
        x[i] = s
    for i in range(nr):                  # D y = z
        x[i] /= d[i]
    for i in range(nr - 1, -1, -1):      # L^T x = y
        s = x[i]
        for p in range(i + 1, nr):
            s -= L[p, i] * x[p]
        x[i] = s
    return True


# -- algorithms -------------------------------------------------------------------------------


class Workspace:
    """Preallocated arrays of the algorithms for a chain of ``n`` links (a plain holder; the
    compiled functions take its arrays)."""

    def __init__(self, n: int):
        nb = n + 1
        self.bR = np.zeros((nb, 3, 3))      # placement of each body in the base frame
        self.bp = np.zeros((nb, 3))
        self.S = np.zeros((nb, 6))          # joint motion axes (base frame)
        self.vel = np.zeros((nb, 6))
        self.cb = np.zeros((nb, 6))
        self.IA = np.zeros((nb, 6, 6))      # body, articulated or composite inertias
        self.pA = np.zeros((nb, 6))
        self.acc = np.zeros((nb, 6))
        self.U = np.zeros((nb, 6))          # IA S of each joint
        self.Du = np.zeros((nb, 2))         # [S^T IA S, tau - S^T pA] of each joint
        self.M6 = np.zeros((2, 6, 6))       # scratch matrices
        self.v6 = np.zeros((6, 6))          # scratch vectors

    def arrays(self) -> tuple:
        return (self.bR, self.bp, self.S, self.vel, self.cb, self.IA, self.pA, self.acc, self.U,
                self.Du, self.M6, self.v6)


@njit(**_NI)
def aba(planar, R, p, axis, I6, q, v, tau, ddq, bR, bp, S, vel, cb, IA, pA, acc, U, Du, M6,
        v6):
    """Forward dynamics ``ddq = M^-1 (tau - c(q, v))`` by the articulated-body algorithm.

    Parameters
    ----------
    planar : bool
    R, p, axis, I6 : model arrays of :func:`chain_arrays`
    q : (nq,)   configuration (unit quaternion / (cos, sin) of the root)
    v : (nv,)   velocity ``[v_base (nb), qd (n)]``;  tau : (nv,) generalised force
    ddq : (nv,) output
    bR, bp, S, vel, cb, IA, pA, acc, U, Du, M6, v6 : work arrays (:class:`Workspace`)

    Returns 0, or 1 if the base's articulated inertia is not positive definite.

    Spatial quantities of body ``k`` are in base axes at its joint's origin ``bp[k]``: the
    joint's motion is then the pure rotation ``[0; s]``, and from one body to its parent only
    the origin moves (by ``d = bp[k] - bp[p]``), which keeps the recursion's lever arms as
    short as in body frames (the rounding of Pinocchio's local ABA) at the cost of one rotation
    of each body's inertia.
    """
    nb = R.shape[0]
    nr = 3 if planar else 6
    _placements(planar, R, p, axis, q, bR, bp, S)
    # pass 1 (base to tip): v_k = shift(v_p) + [0; s qd], c_k = v_k x [0; s qd],
    # IA_k = I_k (in base axes), pA_k = v_k x* (I_k v_k)
    for i in range(6):
        vel[0, i] = 0.0
        cb[0, i] = 0.0
        for j in range(6):
            IA[0, i, j] = I6[0, i, j]
    for j in range(nr):
        vel[0, _row(planar, j)] = v[j]
    for k in range(1, nb):
        d0, d1, d2 = bp[k, 0] - bp[k - 1, 0], bp[k, 1] - bp[k - 1, 1], bp[k, 2] - bp[k - 1, 2]
        w0, w1, w2 = vel[k - 1, 3], vel[k - 1, 4], vel[k - 1, 5]
        # linear velocity at the new origin: v_l + w x d
        vl0 = vel[k - 1, 0] + (w1 * d2 - w2 * d1)
        vl1 = vel[k - 1, 1] + (w2 * d0 - w0 * d2)
        vl2 = vel[k - 1, 2] + (w0 * d1 - w1 * d0)
        qd = v[nr + k - 1]
        z0, z1, z2 = S[k, 3] * qd, S[k, 4] * qd, S[k, 5] * qd
        vel[k, 0], vel[k, 1], vel[k, 2] = vl0, vl1, vl2
        vel[k, 3], vel[k, 4], vel[k, 5] = w0 + z0, w1 + z1, w2 + z2
        cb[k, 0] = vl1 * z2 - vl2 * z1
        cb[k, 1] = vl2 * z0 - vl0 * z2
        cb[k, 2] = vl0 * z1 - vl1 * z0
        cb[k, 3] = w1 * z2 - w2 * z1
        cb[k, 4] = w2 * z0 - w0 * z2
        cb[k, 5] = w0 * z1 - w1 * z0
        m, h0, h1, h2, i00, i01, i02, i11, i12, i22 = _inertia_rotated(I6, k, bR[k], IA[k])
        # pA_k = v_k x* (I_k v_k), I_k v_k = [m v_l + w x h; h x v_l + I_o w] (w = w_p + z)
        w0, w1, w2 = w0 + z0, w1 + z1, w2 + z2
        fl0 = m * vl0 + (w1 * h2 - w2 * h1)
        fl1 = m * vl1 + (w2 * h0 - w0 * h2)
        fl2 = m * vl2 + (w0 * h1 - w1 * h0)
        fn0 = (h1 * vl2 - h2 * vl1) + (i00 * w0 + i01 * w1 + i02 * w2)
        fn1 = (h2 * vl0 - h0 * vl2) + (i01 * w0 + i11 * w1 + i12 * w2)
        fn2 = (h0 * vl1 - h1 * vl0) + (i02 * w0 + i12 * w1 + i22 * w2)
        pA[k, 0] = w1 * fl2 - w2 * fl1                       # [w x f_l; w x f_n + v_l x f_l]
        pA[k, 1] = w2 * fl0 - w0 * fl2
        pA[k, 2] = w0 * fl1 - w1 * fl0
        pA[k, 3] = w1 * fn2 - w2 * fn1 + vl1 * fl2 - vl2 * fl1
        pA[k, 4] = w2 * fn0 - w0 * fn2 + vl2 * fl0 - vl0 * fl2
        pA[k, 5] = w0 * fn1 - w1 * fn0 + vl0 * fl1 - vl1 * fl0
    hv = v6[0]                            # the base: pA_0 = v_0 x* (I_0 v_0)
    for i in range(6):
        s = 0.0
        for j in range(6):
            s += IA[0, i, j] * vel[0, j]
        hv[i] = s
        pA[0, i] = 0.0
    _crf_add(vel[0], hv, pA[0])
    # pass 2 (tip to base): U = IA S, D = S^T U, u = tau - S^T pA, articulated inertia to parent
    Ia, T = M6[0], M6[1]
    pa = v6[0]
    for k in range(nb - 1, 0, -1):
        s0, s1, s2 = S[k, 3], S[k, 4], S[k, 5]
        for i in range(6):
            U[k, i] = IA[k, i, 3] * s0 + IA[k, i, 4] * s1 + IA[k, i, 5] * s2
        D = U[k, 3] * s0 + U[k, 4] * s1 + U[k, 5] * s2
        u = tau[nr + k - 1] - (pA[k, 3] * s0 + pA[k, 4] * s1 + pA[k, 5] * s2)
        Du[k, 0], Du[k, 1] = D, u
        # Ia = IA - U U^T / D (upper triangle: all _shift_add reads);
        # pa = pA + Ia c + U u / D = pA + IA c + U (u - U^T c) / D
        f = (u - (U[k, 0] * cb[k, 0] + U[k, 1] * cb[k, 1] + U[k, 2] * cb[k, 2]
                  + U[k, 3] * cb[k, 3] + U[k, 4] * cb[k, 4] + U[k, 5] * cb[k, 5])) / D
        for i in range(6):
            Ui = U[k, i] / D
            s = pA[k, i] + U[k, i] * f
            for j in range(6):
                s += IA[k, i, j] * cb[k, j]
            pa[i] = s
            for j in range(i, 6):
                Ia[i, j] = IA[k, i, j] - Ui * U[k, j]
        d0, d1, d2 = bp[k, 0] - bp[k - 1, 0], bp[k, 1] - bp[k - 1, 1], bp[k, 2] - bp[k - 1, 2]
        _shift_add(d0, d1, d2, Ia, T, IA[k - 1])
        # force to the parent's origin: f_l, f_n + d x f_l
        pA[k - 1, 0] += pa[0]
        pA[k - 1, 1] += pa[1]
        pA[k - 1, 2] += pa[2]
        pA[k - 1, 3] += pa[3] + (d1 * pa[2] - d2 * pa[1])
        pA[k - 1, 4] += pa[4] + (d2 * pa[0] - d0 * pa[2])
        pA[k - 1, 5] += pa[5] + (d0 * pa[1] - d1 * pa[0])
    # base: (S^T IA_0 S) dv_b = tau_b - S^T pA_0
    if not _base_solve(planar, IA[0], pA[0], tau, M6[0], v6[1], v6[2], ddq):
        return 1
    for i in range(6):
        acc[0, i] = 0.0
    for i in range(nr):
        acc[0, _row(planar, i)] = ddq[i]
    # pass 3 (base to tip): a = shift(a_p) + c_k, qdd_k = (u_k - U_k^T a) / D_k, a_k = a + S qdd
    for k in range(1, nb):
        d0, d1, d2 = bp[k, 0] - bp[k - 1, 0], bp[k, 1] - bp[k - 1, 1], bp[k, 2] - bp[k - 1, 2]
        w0, w1, w2 = acc[k - 1, 3], acc[k - 1, 4], acc[k - 1, 5]
        acc[k, 0] = acc[k - 1, 0] + (w1 * d2 - w2 * d1) + cb[k, 0]
        acc[k, 1] = acc[k - 1, 1] + (w2 * d0 - w0 * d2) + cb[k, 1]
        acc[k, 2] = acc[k - 1, 2] + (w0 * d1 - w1 * d0) + cb[k, 2]
        acc[k, 3] = w0 + cb[k, 3]
        acc[k, 4] = w1 + cb[k, 4]
        acc[k, 5] = w2 + cb[k, 5]
        s = Du[k, 1]
        for i in range(6):
            s -= U[k, i] * acc[k, i]
        qdd = s / Du[k, 0]
        ddq[nr + k - 1] = qdd
        acc[k, 3] += S[k, 3] * qdd
        acc[k, 4] += S[k, 4] * qdd
        acc[k, 5] += S[k, 5] * qdd
    return 0


@njit(**_NI)
def terms(planar, R, p, axis, I6, mc, q, v, M, nle, hg, bR, bp, S, vel, cb, IA, pA, acc, U, Du,
          M6, v6):
    """Joint-space inertia (CRBA), non-linear effects (RNEA at zero acceleration) and the
    centroidal momentum, as Pinocchio's ``computeAllTerms`` gives ``data.M``, ``data.nle`` and
    ``data.hg``.

    Writes ``M`` (nv, nv) (both triangles), ``nle`` (nv,) and ``hg`` (6,) = ``[P, L_c]``
    (inertial frame; angular momentum about the system centre of mass). Returns the system
    centre of mass (3 floats, inertial frame).
    """
    nb = R.shape[0]
    nr = 3 if planar else 6
    _kinematics(planar, R, p, axis, I6, q, v, bR, bp, S, vel, cb, IA)
    # RNEA, forward: a_k = a_p + c_k (a_0 = 0), f_k = I a_k + v x* (I v); momentum h += I v
    hv, h = v6[0], v6[1]
    for i in range(6):
        h[i] = 0.0
    for k in range(nb):
        for i in range(6):
            acc[k, i] = 0.0 if k == 0 else acc[k - 1, i] + cb[k, i]
        for i in range(6):
            s = 0.0
            sh = 0.0
            for j in range(6):
                s += IA[k, i, j] * acc[k, j]
                sh += IA[k, i, j] * vel[k, j]
            pA[k, i] = s
            hv[i] = sh
            h[i] += sh
        _crf_add(vel[k], hv, pA[k])
    # backward: nle_k = S^T f_k, f_p += f_k;  composite inertia Ic_p += Ic_k (all in one frame)
    for k in range(nb - 1, 0, -1):
        nle[nr + k - 1] = (S[k, 0] * pA[k, 0] + S[k, 1] * pA[k, 1] + S[k, 2] * pA[k, 2]
                           + S[k, 3] * pA[k, 3] + S[k, 4] * pA[k, 4] + S[k, 5] * pA[k, 5])
        for i in range(6):
            pA[k - 1, i] += pA[k, i]
            for j in range(6):
                IA[k - 1, i, j] += IA[k, i, j]
    for i in range(nr):
        nle[i] = pA[0, _row(planar, i)]
    # CRBA: F = Ic_k S_k; M_jk = S_j^T F (j <= k), base rows F
    for k in range(nb - 1, 0, -1):
        s0, s1, s2, s3, s4, s5 = S[k, 0], S[k, 1], S[k, 2], S[k, 3], S[k, 4], S[k, 5]
        F = U[k]
        for i in range(6):
            F[i] = (IA[k, i, 0] * s0 + IA[k, i, 1] * s1 + IA[k, i, 2] * s2 + IA[k, i, 3] * s3
                    + IA[k, i, 4] * s4 + IA[k, i, 5] * s5)
        col = nr + k - 1
        for j in range(k, 0, -1):
            mj = (S[j, 0] * F[0] + S[j, 1] * F[1] + S[j, 2] * F[2] + S[j, 3] * F[3]
                  + S[j, 4] * F[4] + S[j, 5] * F[5])
            M[nr + j - 1, col] = mj
            M[col, nr + j - 1] = mj
        for i in range(nr):
            M[i, col] = F[_row(planar, i)]
            M[col, i] = F[_row(planar, i)]
    for i in range(nr):
        for j in range(nr):
            M[i, j] = IA[0, _row(planar, i), _row(planar, j)]
    # centre of mass (base frame): the composite's first moment over its mass
    mt = IA[0, 0, 0]
    cx, cy, cz = IA[0, 5, 1] / mt, IA[0, 3, 2] / mt, IA[0, 4, 0] / mt
    # inertial frame: base rotation A and position r; P = A h_l, L_c = A (h_n - c x h_l)
    if planar:
        c, s = q[2], q[3]
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0
        r0, r1, r2 = q[0], q[1], 0.0
    else:
        x, y, z, w = q[3], q[4], q[5], q[6]
        s2 = 2.0 / (x * x + y * y + z * z + w * w)
        a00, a01, a02 = 1.0 - s2 * (y * y + z * z), s2 * (x * y - z * w), s2 * (x * z + y * w)
        a10, a11, a12 = s2 * (x * y + z * w), 1.0 - s2 * (x * x + z * z), s2 * (y * z - x * w)
        a20, a21, a22 = s2 * (x * z - y * w), s2 * (y * z + x * w), 1.0 - s2 * (x * x + y * y)
        r0, r1, r2 = q[0], q[1], q[2]
    l0, l1, l2 = h[0], h[1], h[2]
    n0 = h[3] - (cy * l2 - cz * l1)
    n1 = h[4] - (cz * l0 - cx * l2)
    n2 = h[5] - (cx * l1 - cy * l0)
    hg[0] = a00 * l0 + a01 * l1 + a02 * l2
    hg[1] = a10 * l0 + a11 * l1 + a12 * l2
    hg[2] = a20 * l0 + a21 * l1 + a22 * l2
    hg[3] = a00 * n0 + a01 * n1 + a02 * n2
    hg[4] = a10 * n0 + a11 * n1 + a12 * n2
    hg[5] = a20 * n0 + a21 * n1 + a22 * n2
    return (r0 + a00 * cx + a01 * cy + a02 * cz, r1 + a10 * cx + a11 * cy + a12 * cz,
            r2 + a20 * cx + a21 * cy + a22 * cz)
