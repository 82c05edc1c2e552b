"""Compiled (Numba) rigid-body dynamics of a floating base carrying a serial chain of revolute
joints: the articulated-body algorithm (forward dynamics), the composite-rigid-body algorithm
(joint-space inertia ``M``), the recursive Newton-Euler non-linear effects ``c(q, v)`` and the
centroidal momentum, in Pinocchio's conventions so that Pinocchio is the reference they are
tested against (tests/test_compiled_dynamics.py).

The model arrays come from a Pinocchio model (:func:`chain_arrays`: joint placements, body
inertias, joint axes), so any robot Pinocchio builds (from code or URDF) whose root joint is a
free-flyer or a planar joint, followed by a serial chain of one-axis revolute joints, runs here.

Conventions (Pinocchio's): spatial motion ``[linear; angular]`` and force ``[linear; angular]``
expressed in the body (joint) frame at its origin; body ``k = 0`` is the base (root joint),
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


@njit(**_NB)
def cho_solve(L, B):
    """Solve ``L L^T X = B`` in place of ``B`` (k, c)."""
    k, c = B.shape
    for col in range(c):
        for i in range(k):
            s = B[i, col]
            for p in range(i):
                s -= L[i, p] * B[p, col]
            B[i, col] = s / L[i, i]
        for i in range(k - 1, -1, -1):
            s = B[i, col]
            for p in range(i + 1, k):
                s -= L[p, i] * B[p, col]
            B[i, col] = s / L[i, i]


# -- spatial algebra ----------------------------------------------------------------------------


@njit(**_NB)
def _joint_transforms(planar, R, p, axis, q, X, oR, op):
    """Rotations ``X[k]`` (3, 3) = ``Rk = R[k] Rot(axis[k], q_k)`` (Rodrigues) of each body in
    its parent at the configuration ``q`` (unit quaternion / (cos, sin)), and the world
    placements ``oR[k]`` (3, 3), ``op[k]`` (3,). Body ``k`` sits at ``x_parent = Rk x_k + p[k]``.
    """
    nb = R.shape[0]
    nq0 = 4 if planar else 7
    # base world placement from the root joint
    if planar:
        c, s = q[2], q[3]
        oR[0, 0, 0], oR[0, 0, 1], oR[0, 0, 2] = c, -s, 0.0
        oR[0, 1, 0], oR[0, 1, 1], oR[0, 1, 2] = s, c, 0.0
        oR[0, 2, 0], oR[0, 2, 1], oR[0, 2, 2] = 0.0, 0.0, 1.0
        op[0, 0], op[0, 1], op[0, 2] = q[0], q[1], 0.0
    else:
        x, y, z, w = q[3], q[4], q[5], q[6]
        s2 = 2.0 / (x * x + y * y + z * z + w * w)
        oR[0, 0, 0] = 1.0 - s2 * (y * y + z * z)
        oR[0, 0, 1] = s2 * (x * y - z * w)
        oR[0, 0, 2] = s2 * (x * z + y * w)
        oR[0, 1, 0] = s2 * (x * y + z * w)
        oR[0, 1, 1] = 1.0 - s2 * (x * x + z * z)
        oR[0, 1, 2] = s2 * (y * z - x * w)
        oR[0, 2, 0] = s2 * (x * z - y * w)
        oR[0, 2, 1] = s2 * (y * z + x * w)
        oR[0, 2, 2] = 1.0 - s2 * (x * x + y * y)
        op[0, 0], op[0, 1], op[0, 2] = q[0], q[1], q[2]
    for k in range(1, nb):
        th = q[nq0 + k - 1]
        ax, ay, az = axis[k, 0], axis[k, 1], axis[k, 2]
        sn, cs = math.sin(th), math.cos(th)
        t = 1.0 - cs
        # Rot(a, th) = cos I + sin [a]x + (1 - cos) a a^T
        j00, j01, j02 = cs + t * ax * ax, t * ax * ay - sn * az, t * ax * az + sn * ay
        j10, j11, j12 = t * ax * ay + sn * az, cs + t * ay * ay, t * ay * az - sn * ax
        j20, j21, j22 = t * ax * az - sn * ay, t * ay * az + sn * ax, cs + t * az * az
        for i in range(3):
            r0, r1, r2 = R[k, i, 0], R[k, i, 1], R[k, i, 2]
            X[k, i, 0] = r0 * j00 + r1 * j10 + r2 * j20
            X[k, i, 1] = r0 * j01 + r1 * j11 + r2 * j21
            X[k, i, 2] = r0 * j02 + r1 * j12 + r2 * j22
        px, py, pz = p[k, 0], p[k, 1], p[k, 2]
        # world placement: oR_k = oR_p Rk, op_k = op_p + oR_p pk
        for i in range(3):
            for j in range(3):
                oR[k, i, j] = (oR[k - 1, i, 0] * X[k, 0, j] + oR[k - 1, i, 1] * X[k, 1, j]
                               + oR[k - 1, i, 2] * X[k, 2, j])
            op[k, i] = op[k - 1, i] + (oR[k - 1, i, 0] * px + oR[k - 1, i, 1] * py
                                       + oR[k - 1, i, 2] * pz)


@njit(**_NB)
def _xmul(Rk, pk, a, out):
    """Motion to the child: ``out_l = Rk^T (a_l - pk x a_w)``, ``out_w = Rk^T a_w``."""
    l0 = a[0] - (pk[1] * a[5] - pk[2] * a[4])
    l1 = a[1] - (pk[2] * a[3] - pk[0] * a[5])
    l2 = a[2] - (pk[0] * a[4] - pk[1] * a[3])
    w0, w1, w2 = a[3], a[4], a[5]
    for i in range(3):
        out[i] = Rk[0, i] * l0 + Rk[1, i] * l1 + Rk[2, i] * l2
        out[3 + i] = Rk[0, i] * w0 + Rk[1, i] * w1 + Rk[2, i] * w2


@njit(**_NB)
def _xtmul_add(Rk, pk, f, out):
    """Force to the parent: ``out_l += Rk f_l``, ``out_n += Rk f_n + pk x (Rk f_l)``."""
    l0 = Rk[0, 0] * f[0] + Rk[0, 1] * f[1] + Rk[0, 2] * f[2]
    l1 = Rk[1, 0] * f[0] + Rk[1, 1] * f[1] + Rk[1, 2] * f[2]
    l2 = Rk[2, 0] * f[0] + Rk[2, 1] * f[1] + Rk[2, 2] * f[2]
    out[0] += l0
    out[1] += l1
    out[2] += l2
    out[3] += Rk[0, 0] * f[3] + Rk[0, 1] * f[4] + Rk[0, 2] * f[5] + pk[1] * l2 - pk[2] * l1
    out[4] += Rk[1, 0] * f[3] + Rk[1, 1] * f[4] + Rk[1, 2] * f[5] + pk[2] * l0 - pk[0] * l2
    out[5] += Rk[2, 0] * f[3] + Rk[2, 1] * f[4] + Rk[2, 2] * f[5] + pk[0] * l1 - pk[1] * l0


@njit(**_NB)
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


@njit(**_NB)
def _congruence_add(Rk, pk, Ia, T, out):
    """``out += X^T Ia X`` (inertia to the parent) for the motion transform
    ``X = [[Rk^T, -Rk^T P], [0, Rk^T]]``, ``P = [pk]x``, by 3x3 blocks: with the symmetric
    ``Ia = [[A, B], [B^T, C]]`` and ``A' = Rk A Rk^T`` (same for B, C),
    ``X^T Ia X = [[A', B' - A' P], [(.)^T, C' + P B' + (P B')^T - P A' P]]``.
    Only the upper triangle of ``Ia`` is read. ``T`` (6, 6) scratch."""
    a00, a01, a02, a11, a12, a22 = _rot_sym(Rk, Ia[0, 0], Ia[0, 1], Ia[0, 2], Ia[1, 1],
                                            Ia[1, 2], Ia[2, 2])
    c00, c01, c02, c11, c12, c22 = _rot_sym(Rk, Ia[3, 3], Ia[3, 4], Ia[3, 5], Ia[4, 4],
                                            Ia[4, 5], Ia[5, 5])
    B = T[0:3, 0:3]
    W = T[3:6, 3:6]
    for i in range(3):                       # W = Rk B, B' = W Rk^T
        r0, r1, r2 = Rk[i, 0], Rk[i, 1], Rk[i, 2]
        for j in range(3):
            W[i, j] = r0 * Ia[0, 3 + j] + r1 * Ia[1, 3 + j] + r2 * Ia[2, 3 + j]
    for i in range(3):
        w0, w1, w2 = W[i, 0], W[i, 1], W[i, 2]
        for j in range(3):
            B[i, j] = w0 * Rk[j, 0] + w1 * Rk[j, 1] + w2 * Rk[j, 2]
    px, py, pz = pk[0], pk[1], pk[2]
    # A' P, P = [[0, -pz, py], [pz, 0, -px], [-py, px, 0]] (rows of A' are symmetric)
    ap00, ap01, ap02 = a01 * pz - a02 * py, a02 * px - a00 * pz, a00 * py - a01 * px
    ap10, ap11, ap12 = a11 * pz - a12 * py, a12 * px - a01 * pz, a01 * py - a11 * px
    ap20, ap21, ap22 = a12 * pz - a22 * py, a22 * px - a02 * pz, a02 * py - a12 * px
    # P (A' P): row i of P times the columns
    pap00 = -pz * ap10 + py * ap20
    pap01 = -pz * ap11 + py * ap21
    pap02 = -pz * ap12 + py * ap22
    pap11 = pz * ap01 - px * ap21
    pap12 = pz * ap02 - px * ap22
    pap22 = -py * ap02 + px * ap12
    # P B'
    pb00 = -pz * B[1, 0] + py * B[2, 0]
    pb01 = -pz * B[1, 1] + py * B[2, 1]
    pb02 = -pz * B[1, 2] + py * B[2, 2]
    pb10 = pz * B[0, 0] - px * B[2, 0]
    pb11 = pz * B[0, 1] - px * B[2, 1]
    pb12 = pz * B[0, 2] - px * B[2, 2]
    pb20 = -py * B[0, 0] + px * B[1, 0]
    pb21 = -py * B[0, 1] + px * B[1, 1]
    pb22 = -py * B[0, 2] + px * B[1, 2]
    # A'
    out[0, 0] += a00
    out[0, 1] += a01
    out[0, 2] += a02
    out[1, 0] += a01
    out[1, 1] += a11
    out[1, 2] += a12
    out[2, 0] += a02
    out[2, 1] += a12
    out[2, 2] += a22
    # B' - A' P and its transpose
    aps = ((ap00, ap01, ap02), (ap10, ap11, ap12), (ap20, ap21, ap22))
    for i in range(3):
        for j in range(3):
            bij = B[i, j] - aps[i][j]
            out[i, 3 + j] += bij
            out[3 + j, i] += bij
    # C' + P B' + (P B')^T - P A' P
    d00 = c00 + 2.0 * pb00 - pap00
    d11 = c11 + 2.0 * pb11 - pap11
    d22 = c22 + 2.0 * pb22 - pap22
    d01 = c01 + pb01 + pb10 - pap01
    d02 = c02 + pb02 + pb20 - pap02
    d12 = c12 + pb12 + pb21 - pap12
    out[3, 3] += d00
    out[4, 4] += d11
    out[5, 5] += d22
    out[3, 4] += d01
    out[4, 3] += d01
    out[3, 5] += d02
    out[5, 3] += d02
    out[4, 5] += d12
    out[5, 4] += d12


@njit(**_NB)
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


@njit(**_NB)
def _velocities(planar, X, p, axis, v, vel, cb):
    """Body velocities ``vel[k]`` and bias accelerations ``cb[k] = vel[k] x (S_k qd_k)``."""
    nb = X.shape[0]
    nr = 3 if planar else 6
    for i in range(6):
        vel[0, i] = 0.0
        cb[0, i] = 0.0
    for j in range(nr):
        vel[0, _row(planar, j)] = v[j]
    for k in range(1, nb):
        _xmul(X[k], p[k], vel[k - 1], vel[k])
        qd = v[nr + k - 1]
        w0, w1, w2 = axis[k, 0] * qd, axis[k, 1] * qd, axis[k, 2] * qd
        vel[k, 3] += w0
        vel[k, 4] += w1
        vel[k, 5] += w2
        # c_k = v_k x [0; w_J] = [v_l x w_J; w x w_J]
        vl0, vl1, vl2, a0, a1, a2 = vel[k, 0], vel[k, 1], vel[k, 2], vel[k, 3], vel[k, 4], vel[k, 5]
        cb[k, 0] = vl1 * w2 - vl2 * w1
        cb[k, 1] = vl2 * w0 - vl0 * w2
        cb[k, 2] = vl0 * w1 - vl1 * w0
        cb[k, 3] = a1 * w2 - a2 * w1
        cb[k, 4] = a2 * w0 - a0 * w2
        cb[k, 5] = a0 * w1 - a1 * w0


@njit(**_NB)
def _row(planar, i):
    """Row of the base spatial velocity ``[v; omega]`` that is the base's generalised velocity
    ``i``: all six for the free-flyer, rows 0, 1, 5 (``v_x, v_y, omega_z``) planar."""
    return 5 if planar and i == 2 else i


# -- algorithms -------------------------------------------------------------------------------


class Workspace:
    """Preallocated arrays of the algorithms for a chain of ``n`` links (a plain holder; the
    compiled functions take its arrays)."""

    def __init__(self, n: int):
        nb = n + 1
        self.X = np.zeros((nb, 3, 3))       # rotation of each body in its parent
        self.oR = np.zeros((nb, 3, 3))
        self.op = np.zeros((nb, 3))
        self.vel = np.zeros((nb, 6))
        self.cb = np.zeros((nb, 6))
        self.IA = np.zeros((nb, 6, 6))
        self.pA = np.zeros((nb, 6))
        self.acc = np.zeros((nb, 6))
        self.U = np.zeros((nb, 6))          # IA S of each joint
        self.Du = np.zeros((nb, 2))         # [S^T IA S, tau - S^T pA] of each joint
        self.M6 = np.zeros((3, 6, 6))       # scratch matrices
        self.v6 = np.zeros((6, 6))          # scratch vectors

    def arrays(self) -> tuple:
        return (self.X, self.oR, self.op, self.vel, self.cb, self.IA, self.pA, self.acc, self.U,
                self.Du, self.M6, self.v6)


@njit(**_NB)
def aba(planar, R, p, axis, I6, q, v, tau, ddq, X, oR, op, vel, cb, IA, pA, acc, U, Du, M6,
        v6):
    """Forward dynamics ``ddq = M^-1 (tau - c(q, v))`` by the articulated-body algorithm.

    Parameters
    ----------
    planar : bool
    R, p, axis, I6 : model arrays of :func:`chain_arrays`
    q : (nq,)   configuration (unit quaternion / (cos, sin) of the root)
    v : (nv,)   velocity ``[v_base (nb), qd (n)]``;  tau : (nv,) generalised force
    ddq : (nv,) output
    X, oR, op, vel, cb, IA, pA, acc, U, Du, M6, v6 : work arrays (:class:`Workspace`)

    Returns 0, or 1 if the base's articulated inertia is not positive definite.
    """
    nb = R.shape[0]
    nr = 3 if planar else 6
    _joint_transforms(planar, R, p, axis, q, X, oR, op)
    _velocities(planar, X, p, axis, v, vel, cb)
    # pass 1: IA_k = I_k, pA_k = v_k x* (I_k v_k)
    for k in range(nb):
        for i in range(6):
            s = 0.0
            for j in range(6):
                IA[k, i, j] = I6[k, i, j]
                s += I6[k, i, j] * vel[k, j]
            acc[k, i] = s                       # I v (scratch)
        for i in range(6):
            pA[k, i] = 0.0
        _crf_add(vel[k], acc[k], pA[k])
    # pass 2 (tip to base): U = IA S, D = S^T U, u = tau - S^T pA, articulated inertia to parent
    Ia, T, Sb = M6[0], M6[1], M6[2]
    pa = v6[0]
    for k in range(nb - 1, 0, -1):
        ax, ay, az = axis[k, 0], axis[k, 1], axis[k, 2]
        for i in range(6):
            U[k, i] = IA[k, i, 3] * ax + IA[k, i, 4] * ay + IA[k, i, 5] * az
        D = U[k, 3] * ax + U[k, 4] * ay + U[k, 5] * az
        u = tau[nr + k - 1] - (pA[k, 3] * ax + pA[k, 4] * ay + pA[k, 5] * az)
        Du[k, 0], Du[k, 1] = D, u
        # Ia = IA - U U^T / D ;  pa = pA + Ia c + U u / D
        for i in range(6):
            Ui = U[k, i] / D
            for j in range(6):
                Ia[i, j] = IA[k, i, j] - Ui * U[k, j]
        for i in range(6):
            s = pA[k, i] + U[k, i] * (u / D)
            for j in range(6):
                s += Ia[i, j] * cb[k, j]
            pa[i] = s
        _congruence_add(X[k], p[k], Ia, T, IA[k - 1])
        _xtmul_add(X[k], p[k], pa, pA[k - 1])
    # base: (S^T IA_0 S) dv_b = tau_b - S^T pA_0
    Sb, Lb, rhs = M6[0, :nr, :nr], M6[1, :nr, :nr], v6[1:2, :nr].T
    for i in range(nr):
        for j in range(nr):
            Sb[i, j] = IA[0, _row(planar, i), _row(planar, j)]
        rhs[i, 0] = tau[i] - pA[0, _row(planar, i)]
    if not cholesky(Sb, Lb):
        return 1
    cho_solve(Lb, rhs)
    for i in range(6):
        acc[0, i] = 0.0
    for i in range(nr):
        ddq[i] = rhs[i, 0]
        acc[0, _row(planar, i)] = rhs[i, 0]
    # pass 3 (base to tip): a_k = X a_p + c_k, qdd_k = (u_k - U_k^T a_k) / D_k, a_k += S qdd_k
    for k in range(1, nb):
        _xmul(X[k], p[k], acc[k - 1], acc[k])
        s = Du[k, 1]
        for i in range(6):
            acc[k, i] += cb[k, i]
            s -= U[k, i] * acc[k, i]
        qdd = s / Du[k, 0]
        ddq[nr + k - 1] = qdd
        acc[k, 3] += axis[k, 0] * qdd
        acc[k, 4] += axis[k, 1] * qdd
        acc[k, 5] += axis[k, 2] * qdd
    return 0


@njit(**_NB)
def terms(planar, R, p, axis, I6, mc, q, v, M, nle, hg, X, oR, op, vel, cb, IA, pA, acc, U, Du,
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
    _joint_transforms(planar, R, p, axis, q, X, oR, op)
    _velocities(planar, X, p, axis, v, vel, cb)
    # RNEA, forward: a_k = X a_p + c_k (a_0 = 0), f_k = I a_k + v x* (I v); momentum h_k = I v
    # composite inertias start as the body inertias (IA as scratch)
    P, L, com, hv, hw = v6[0, :3], v6[0, 3:], v6[1, :3], v6[2], v6[1, 3:]
    for i in range(3):
        P[i] = L[i] = com[i] = 0.0
    mtot = 0.0
    for k in range(nb):
        if k == 0:
            for i in range(6):
                acc[0, i] = 0.0
        else:
            _xmul(X[k], p[k], acc[k - 1], acc[k])
            for i in range(6):
                acc[k, i] += cb[k, i]
        for i in range(6):
            s = 0.0
            sh = 0.0
            for j in range(6):
                IA[k, i, j] = I6[k, i, j]
                s += I6[k, i, j] * acc[k, j]
                sh += I6[k, i, j] * vel[k, j]
            pA[k, i] = s
            hv[i] = sh
        _crf_add(vel[k], hv, pA[k])
        # momentum in the inertial frame about its origin: [oR h_l; oR h_n + op x oR h_l]
        for i in range(3):
            hw[i] = oR[k, i, 0] * hv[0] + oR[k, i, 1] * hv[1] + oR[k, i, 2] * hv[2]
            P[i] += hw[i]
        for i in range(3):
            L[i] += oR[k, i, 0] * hv[3] + oR[k, i, 1] * hv[4] + oR[k, i, 2] * hv[5]
        L[0] += op[k, 1] * hw[2] - op[k, 2] * hw[1]
        L[1] += op[k, 2] * hw[0] - op[k, 0] * hw[2]
        L[2] += op[k, 0] * hw[1] - op[k, 1] * hw[0]
        m = mc[k, 0]
        mtot += m
        for i in range(3):
            com[i] += m * (op[k, i] + oR[k, i, 0] * mc[k, 1] + oR[k, i, 1] * mc[k, 2]
                           + oR[k, i, 2] * mc[k, 3])
    for i in range(3):
        com[i] /= mtot
    # L_c = L_O - com x P
    hg[0], hg[1], hg[2] = P[0], P[1], P[2]
    hg[3] = L[0] - (com[1] * P[2] - com[2] * P[1])
    hg[4] = L[1] - (com[2] * P[0] - com[0] * P[2])
    hg[5] = L[2] - (com[0] * P[1] - com[1] * P[0])
    c0, c1, c2 = com[0], com[1], com[2]
    # backward: nle_k = S^T f_k, f_p += X^T f_k;  composite inertia Ic_p += X^T Ic_k X
    T = M6[0]
    for k in range(nb - 1, 0, -1):
        nle[nr + k - 1] = axis[k, 0] * pA[k, 3] + axis[k, 1] * pA[k, 4] + axis[k, 2] * pA[k, 5]
        _xtmul_add(X[k], p[k], pA[k], pA[k - 1])
        _congruence_add(X[k], p[k], IA[k], T, IA[k - 1])
    for i in range(nr):
        nle[i] = pA[0, _row(planar, i)]
    # CRBA: F = Ic_k S_k; M_kk = S_k^T F; up the chain M_jk = S_j^T (X^T ... F)
    F, G = v6[3], v6[4]
    for k in range(nb - 1, 0, -1):
        ax, ay, az = axis[k, 0], axis[k, 1], axis[k, 2]
        for i in range(6):
            F[i] = IA[k, i, 3] * ax + IA[k, i, 4] * ay + IA[k, i, 5] * az
        col = nr + k - 1
        for j in range(k, 0, -1):
            mj = axis[j, 0] * F[3] + axis[j, 1] * F[4] + axis[j, 2] * F[5]
            M[nr + j - 1, col] = mj
            M[col, nr + j - 1] = mj
            for i in range(6):
                G[i] = 0.0
            _xtmul_add(X[j], p[j], F, G)
            for i in range(6):
                F[i] = G[i]
        for i in range(nr):
            M[i, col] = F[_row(planar, i)]
            M[col, i] = F[_row(planar, i)]
    for i in range(nr):
        for j in range(nr):
            M[i, j] = IA[0, _row(planar, i), _row(planar, j)]
    return c0, c1, c2
