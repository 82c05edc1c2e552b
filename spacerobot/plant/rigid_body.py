"""Compiled (Numba) rigid-body dynamics of a floating base carrying a serial chain of revolute
joints: the articulated-body algorithm (forward dynamics), the composite-rigid-body algorithm
(joint-space inertia ``M``), the recursive Newton-Euler non-linear effects ``c(q, v)`` and the
centroidal momentum, in Pinocchio's conventions so that Pinocchio is the reference they are
tested against (tests/test_compiled_dynamics.py).

The model arrays come from a Pinocchio model (:func:`chain_arrays`: joint placements and body
inertias in joint frames whose ``z`` is the joint axis), so any robot Pinocchio builds (from
code or URDF) whose root joint is a free-flyer or a planar joint, followed by a serial chain of
one-axis revolute joints, runs here.

Conventions (Pinocchio's): spatial motion ``[linear; angular]`` and force ``[linear; angular]``;
the algorithms express them in base axes (the "spatial algebra" comment below: ``terms`` at the
base origin, ``aba`` at each joint's origin), and their results (``ddq``, ``M``, ``nle``, ``hg``)
are Pinocchio's. Body ``k = 0`` is the base (root joint),
``k = 1..n`` the links. ``R[k], p[k]`` is the placement of joint ``k`` in its parent's joint
frame at ``q_k = 0`` (``x_parent = R Rz(q_k) x_k + p``; for ``k = 0`` the identity). The planar root joint is the free-flyer restricted to
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


def _z_frame(a) -> np.ndarray:
    """A rotation ``Q`` (3, 3) whose third column is the unit vector along ``a``: the joint
    frame in which the revolute axis ``a`` (body frame) is ``z``. The identity and exact
    permutations for the ``z``, ``x`` and ``y`` axes (their placements and inertias keep their
    values), otherwise two orthonormal vectors completing ``a``."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    if a[0] == 0.0 and a[1] == 0.0 and a[2] == 1.0:
        return np.eye(3)
    if a[0] == 1.0 and a[1] == 0.0 and a[2] == 0.0:
        return np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])    # (y, z, x)
    if a[0] == 0.0 and a[1] == 1.0 and a[2] == 0.0:
        return np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])    # (z, x, y)
    x = np.cross([1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0], a)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(a, x), a])


def chain_arrays(model) -> tuple:
    """Arrays of the compiled model from a Pinocchio model.

    Each link is described in its joint frame: the body frame turned by :func:`_z_frame` so
    that the joint axis is ``z`` (the joint's rotation is then ``Rz(q_k)``, cheaper to apply
    than a rotation about a general axis; the base keeps its frame).

    Parameters
    ----------
    model : pinocchio.Model
        root joint 1 a ``JointModelFreeFlyer`` or ``JointModelPlanar`` at the identity
        placement, joints 2.. one-axis revolute joints (``RX``, ``RY``, ``RZ``,
        ``RevoluteUnaligned``), each the child of the previous one; zero gravity.

    Returns
    -------
    planar : bool
    R : (n + 1, 3, 3), p : (n + 1, 3)   joint placements in the parent's joint frame:
                                         ``x_parent = R[k] Rz(q_k) x_k + p[k]``
    I6 : (n + 1, 6, 6)                   spatial inertias at the joint origins (joint frames)
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
    I6, mc = np.zeros((n + 1, 6, 6)), np.zeros((n + 1, 4))
    unit = {"JointModelRX": (1.0, 0.0, 0.0), "JointModelRY": (0.0, 1.0, 0.0),
            "JointModelRZ": (0.0, 0.0, 1.0)}
    Qp = np.eye(3)                       # the parent's joint frame in its body frame
    for k in range(n + 1):
        j = k + 1
        Q = np.eye(3)
        if k > 0:
            jm = model.joints[j]
            name = jm.shortname()
            if model.parents[j] != j - 1:
                raise ValueError(f"joint {j} is not the child of joint {j - 1}: not a serial chain")
            if name in unit:
                Q = _z_frame(unit[name])
            elif name == "JointModelRevoluteUnaligned":
                Q = _z_frame(jm.extract().axis)
            else:
                raise ValueError(f"joint {j} ({name}) is not a one-axis revolute joint")
        # body k at x_p = Rj Rot(a, q) x_k + pj with Rot(a, q) = Q Rz(q) Q^T: in joint frames
        # (x = Q x'), x_p' = (Qp^T Rj Q) Rz(q) x_k' + Qp^T pj
        M = model.jointPlacements[j]
        R[k], p[k] = Qp.T @ M.rotation @ Q, Qp.T @ M.translation
        Y = model.inertias[j]
        m, c = float(Y.mass), Q.T @ np.asarray(Y.lever, float)
        cx = np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])
        # I6 = [[m 1, -m [c]x], [m [c]x, I_c - m [c]x [c]x]]  (Pinocchio's Inertia.matrix())
        I6[k, :3, :3] = m * np.eye(3)
        I6[k, :3, 3:] = -m * cx
        I6[k, 3:, :3] = m * cx
        I6[k, 3:, 3:] = Q.T @ np.asarray(Y.inertia, float) @ Q - m * cx @ cx
        mc[k, 0], mc[k, 1:] = m, c
        Qp = Q
    return root == "JointModelPlanar", R, p, I6, mc


# -- small linear algebra -------------------------------------------------------------------


@njit(**_NB)
def cholesky(S, L):
    """Lower Cholesky factor of the SPD matrix ``S`` into ``L``; False if a pivot is <= 0
    (a NaN pivot passes, so that NaN propagates). One division per pivot: the column is scaled
    by its reciprocal."""
    k = S.shape[0]
    for j in range(k):
        d = S[j, j]
        for p in range(j):
            d -= L[j, p] * L[j, p]
        if d <= 0.0:
            return False
        d = math.sqrt(d)
        L[j, j] = d
        r = 1.0 / d
        for i in range(j + 1, k):
            s = S[i, j]
            for p in range(j):
                s -= L[i, p] * L[j, p]
            L[i, j] = s * r
        for i in range(j):
            L[i, j] = 0.0
    return True


@njit(**_NI)
def cho_solve(L, B):
    """Solve ``L L^T X = B`` in place of ``B`` (k, c).

    Row by row with the columns innermost (independent, so they pipeline), each entry summed
    in the same order as a column-by-column substitution; one division per row (its entries
    are scaled by the reciprocal of the pivot)."""
    k, c = B.shape
    for i in range(k):                   # L Y = B
        for p in range(i):
            lip = L[i, p]
            for col in range(c):
                B[i, col] -= lip * B[p, col]
        r = 1.0 / L[i, i]
        for col in range(c):
            B[i, col] *= r
    for i in range(k - 1, -1, -1):       # L^T X = Y
        for p in range(i + 1, k):
            lpi = L[p, i]
            for col in range(c):
                B[i, col] -= lpi * B[p, col]
        r = 1.0 / L[i, i]
        for col in range(c):
            B[i, col] *= r


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
def _rot_sym(r00, r01, r02, r10, r11, r12, r20, r21, r22, a00, a01, a02, a11, a12, a22):
    """Upper triangle of ``Rk A Rk^T`` for the rotation ``Rk`` (its entries ``rij``) and the
    symmetric ``A`` given by its upper triangle."""
    w00 = r00 * a00 + r01 * a01 + r02 * a02          # W = Rk A
    w01 = r00 * a01 + r01 * a11 + r02 * a12
    w02 = r00 * a02 + r01 * a12 + r02 * a22
    w10 = r10 * a00 + r11 * a01 + r12 * a02
    w11 = r10 * a01 + r11 * a11 + r12 * a12
    w12 = r10 * a02 + r11 * a12 + r12 * a22
    w20 = r20 * a00 + r21 * a01 + r22 * a02
    w21 = r20 * a01 + r21 * a11 + r22 * a12
    w22 = r20 * a02 + r21 * a12 + r22 * a22
    return (w00 * r00 + w01 * r01 + w02 * r02,     # (W Rk^T)_ij = W_i . Rk_j
            w00 * r10 + w01 * r11 + w02 * r12,
            w00 * r20 + w01 * r21 + w02 * r22,
            w10 * r10 + w11 * r11 + w12 * r12,
            w10 * r20 + w11 * r21 + w12 * r22,
            w20 * r20 + w21 * r21 + w22 * r22)


@njit(**_NI)
def _place(R, p, k, th, b00, b01, b02, b10, b11, b12, b20, b21, b22, o0, o1, o2):
    """Placement of body ``k`` (joint angle ``th``) in the base frame from its parent's,
    ``E_p`` (entries ``bij``) and ``bp_p = o``: body ``k``'s joint frame sits at
    ``x_parent = R[k] Rz(th) x_k + p[k]``, so ``E_k = E_p R[k] Rz(th)``,
    ``bp_k = bp_p + E_p p[k]``, and its joint axis in the base frame is the third column of
    ``E_p R[k]``. Returns ``E_k`` (9 floats, row-major), ``bp_k`` (3) and the axis (3)."""
    sn, cs = math.sin(th), math.cos(th)
    px, py, pz = p[k, 0], p[k, 1], p[k, 2]
    q00, q01, q02 = R[k, 0, 0], R[k, 0, 1], R[k, 0, 2]
    q10, q11, q12 = R[k, 1, 0], R[k, 1, 1], R[k, 1, 2]
    q20, q21, q22 = R[k, 2, 0], R[k, 2, 1], R[k, 2, 2]
    # A = E_p R_k, row by row
    a00 = b00 * q00 + b01 * q10 + b02 * q20
    a01 = b00 * q01 + b01 * q11 + b02 * q21
    a02 = b00 * q02 + b01 * q12 + b02 * q22
    a10 = b10 * q00 + b11 * q10 + b12 * q20
    a11 = b10 * q01 + b11 * q11 + b12 * q21
    a12 = b10 * q02 + b11 * q12 + b12 * q22
    a20 = b20 * q00 + b21 * q10 + b22 * q20
    a21 = b20 * q01 + b21 * q11 + b22 * q21
    a22 = b20 * q02 + b21 * q12 + b22 * q22
    # A Rz(th): columns 0, 1 turned, column 2 (the axis) kept
    return (a00 * cs + a01 * sn, a01 * cs - a00 * sn, a02,
            a10 * cs + a11 * sn, a11 * cs - a10 * sn, a12,
            a20 * cs + a21 * sn, a21 * cs - a20 * sn, a22,
            o0 + (b00 * px + b01 * py + b02 * pz), o1 + (b10 * px + b11 * py + b12 * pz),
            o2 + (b20 * px + b21 * py + b22 * pz), a02, a12, a22)


@njit(**_NI)
def _shift(px, py, pz, a00, a01, a02, a11, a12, a22, b00, b01, b02, b10, b11, b12, b20, b21,
           b22, c00, c01, c02, c11, c12, c22):
    """``X^T Ia X`` (an inertia moved to the parent's origin) for the pure translation
    ``X = [[1, -P], [0, 1]]``, ``P = [d]x``, ``d = (px, py, pz)`` the child's origin seen from
    the parent's: with the symmetric ``Ia = [[A, B], [B^T, C]]`` (``A``, ``C`` by their upper
    triangles ``aij``, ``cij``; ``B`` row-major ``bij``),
    ``X^T Ia X = [[A, B - A P], [(.)^T, C + P B + (P B)^T - P A P]]``.
    Returns the 21 entries of the result in the same order as its arguments."""
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
    pb00 = -pz * b10 + py * b20
    pb01 = -pz * b11 + py * b21
    pb02 = -pz * b12 + py * b22
    pb10 = pz * b00 - px * b20
    pb11 = pz * b01 - px * b21
    pb12 = pz * b02 - px * b22
    pb20 = -py * b00 + px * b10
    pb21 = -py * b01 + px * b11
    pb22 = -py * b02 + px * b12
    return (a00, a01, a02, a11, a12, a22,
            b00 - ap00, b01 - ap01, b02 - ap02, b10 - ap10, b11 - ap11, b12 - ap12,
            b20 - ap20, b21 - ap21, b22 - ap22,
            c00 + 2.0 * pb00 - pap00, c01 + pb01 + pb10 - pap01, c02 + pb02 + pb20 - pap02,
            c11 + 2.0 * pb11 - pap11, c12 + pb12 + pb21 - pap12, c22 + 2.0 * pb22 - pap22)


@njit(**_NI)
def _rbi_mul(m, g0, g1, g2, j00, j01, j02, j11, j12, j22, vl0, vl1, vl2, w0, w1, w2):
    """``I v`` for the rigid-body inertia ``I = [[m 1, -[g]x], [[g]x, J]]`` (``g`` the first
    moment, ``J`` symmetric by its upper triangle) and the motion ``v = [v_l; w]``:
    ``[m v_l - g x w; g x v_l + J w]`` (6 floats)."""
    return (m * vl0 - (g1 * w2 - g2 * w1), m * vl1 - (g2 * w0 - g0 * w2),
            m * vl2 - (g0 * w1 - g1 * w0),
            (g1 * vl2 - g2 * vl1) + (j00 * w0 + j01 * w1 + j02 * w2),
            (g2 * vl0 - g0 * vl2) + (j01 * w0 + j11 * w1 + j12 * w2),
            (g0 * vl1 - g1 * vl0) + (j02 * w0 + j12 * w1 + j22 * w2))


@njit(**_NI)
def _crf(vl0, vl1, vl2, w0, w1, w2, fl0, fl1, fl2, fn0, fn1, fn2):
    """Force cross product ``v x* f = [w x f_l; w x f_n + v_l x f_l]`` (6 floats)."""
    return (w1 * fl2 - w2 * fl1, w2 * fl0 - w0 * fl2, w0 * fl1 - w1 * fl0,
            w1 * fn2 - w2 * fn1 + vl1 * fl2 - vl2 * fl1,
            w2 * fn0 - w0 * fn2 + vl2 * fl0 - vl0 * fl2,
            w0 * fn1 - w1 * fn0 + vl0 * fl1 - vl1 * fl0)


@njit(**_NI)
def _base_motion(planar, v, I6, pA):
    """The base's velocity ``v_0 = [v_l; w]`` from ``v`` (planar: ``v_x, v_y, w_z``), its
    momentum ``I_0 v_0`` and its bias force ``pA[0] = v_0 x* (I_0 v_0)`` (written), where the
    articulated-body and the composite-body passes start: 12 floats ``v_l, w, h_l, h_n``."""
    vl0, vl1, vl2, w0, w1, w2 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if planar:
        vl0, vl1, w2 = v[0], v[1], v[2]
    else:
        vl0, vl1, vl2, w0, w1, w2 = v[0], v[1], v[2], v[3], v[4], v[5]
    hl0, hl1, hl2, hn0, hn1, hn2 = _rbi_mul(I6[0, 0, 0], I6[0, 5, 1], I6[0, 3, 2], I6[0, 4, 0],
                                            I6[0, 3, 3], I6[0, 3, 4], I6[0, 3, 5], I6[0, 4, 4],
                                            I6[0, 4, 5], I6[0, 5, 5], vl0, vl1, vl2, w0, w1, w2)
    pA[0, 0], pA[0, 1], pA[0, 2], pA[0, 3], pA[0, 4], pA[0, 5] = _crf(
        vl0, vl1, vl2, w0, w1, w2, hl0, hl1, hl2, hn0, hn1, hn2)
    return vl0, vl1, vl2, w0, w1, w2, hl0, hl1, hl2, hn0, hn1, hn2


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
        L[j, j] = r                      # the diagonal is not read again: 1 / d_j
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
        x[i] *= L[i, i]
    for i in range(nr - 1, -1, -1):      # L^T x = y
        s = x[i]
        for p in range(i + 1, nr):
            s -= L[p, i] * x[p]
        x[i] = s
    return True


# -- algorithms -------------------------------------------------------------------------------


class Workspace:
    """Preallocated arrays of the algorithms for a chain of ``n`` links (a plain holder; the
    compiled functions take its arrays, :meth:`arrays`)."""

    def __init__(self, n: int):
        nb = n + 1
        self.bp = np.zeros((nb, 3))         # joint origins in the base frame (aba)
        self.S = np.zeros((nb, 6))          # joint motions, base frame
        self.cb = np.zeros((nb, 6))         # joint bias accelerations (aba)
        self.IA = np.zeros((nb, 6, 6))      # body inertias (defining entries); base's IA (aba)
        self.pA = np.zeros((nb, 6))         # bias forces (aba), RNEA forces (terms)
        self.U = np.zeros((nb, 6))          # IA S (aba), Ic S (terms) of each joint
        self.Du = np.zeros((nb, 2))         # [1 / S^T IA S, tau - S^T pA] of each joint (aba)
        self.M6 = np.zeros((6, 6))          # scratch matrix (the base solve's factor)
        self.v6 = np.zeros((2, 6))          # scratch vectors

    def arrays(self) -> tuple:
        """``(bp, S, cb, IA, pA, U, Du, M6, v6)``, the work arrays :func:`aba` and :func:`terms`
        take."""
        return (self.bp, self.S, self.cb, self.IA, self.pA, self.U, self.Du, self.M6, self.v6)


@njit(**_NI)
def aba(planar, R, p, I6, q, v, tau, ddq, bp, S, cb, IA, pA, U, Du, M6, v6):
    """Forward dynamics ``ddq = M^-1 (tau - c(q, v))`` by the articulated-body algorithm.

    Parameters
    ----------
    planar : bool
    R, p, I6 : model arrays of :func:`chain_arrays`
    q : (nq,)   configuration (unit quaternion / (cos, sin) of the root)
    v : (nv,)   velocity ``[v_base (nb), qd (n)]``;  tau : (nv,) generalised force
    ddq : (nv,) output
    bp, S, cb, IA, pA, U, Du, M6, v6 : work arrays (:class:`Workspace`; ``S[:, :3]`` is not
    written)

    Returns 0, or 1 if the base's articulated inertia is not positive definite.

    Spatial quantities of body ``k`` are in base axes at its joint's origin ``bp[k]``: the
    joint's motion is then the pure rotation ``[0; s]``, and from one body to its parent only
    the origin moves (by ``d = bp[k] - bp[p]``), which keeps the recursion's lever arms as
    short as in body frames (the rounding of Pinocchio's local ABA) at the cost of one rotation
    of each body's inertia.

    What one body hands to the next (its parent's placement and velocity in pass 1, its
    articulated inertia and bias force in pass 2, its acceleration in pass 3) stays in local
    variables (registers): a serial chain needs only the previous body's. Memory holds what a
    later pass reads: ``bp``, ``S`` and ``cb`` (passes 2, 3), the body's rotated inertia
    (``IA[k]``: the entries of ``[h']x`` and the upper triangle of ``I_o'``, as in ``I6``) and
    its bias force ``pA[k]`` (pass 2), ``U``, ``Du`` (pass 3).
    """
    nb = R.shape[0]
    nr = 3 if planar else 6
    nq0 = 4 if planar else 7
    # pass 1 (base to tip): v_k = shift(v_p) + [0; s qd], c_k = v_k x [0; s qd],
    # body inertia in base axes, pA_k = v_k x* (I_k v_k)
    # the base: pA_0 = v_0 x* (I_0 v_0)
    vl0, vl1, vl2, w0, w1, w2, hl0, hl1, hl2, hn0, hn1, hn2 = _base_motion(planar, v, I6, pA)
    b00, b01, b02, b10, b11, b12, b20, b21, b22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    o0, o1, o2 = 0.0, 0.0, 0.0
    bp[0, 0], bp[0, 1], bp[0, 2] = 0.0, 0.0, 0.0
    for k in range(1, nb):
        (b00, b01, b02, b10, b11, b12, b20, b21, b22, n0, n1, n2, s0, s1, s2) = _place(
            R, p, k, q[nq0 + k - 1], b00, b01, b02, b10, b11, b12, b20, b21, b22,
            o0, o1, o2)
        d0, d1, d2 = n0 - o0, n1 - o1, n2 - o2
        o0, o1, o2 = n0, n1, n2
        bp[k, 0], bp[k, 1], bp[k, 2] = o0, o1, o2
        S[k, 3], S[k, 4], S[k, 5] = s0, s1, s2
        # linear velocity at the new origin: v_l + w x d
        vl0, vl1, vl2 = (vl0 + (w1 * d2 - w2 * d1), vl1 + (w2 * d0 - w0 * d2),
                         vl2 + (w0 * d1 - w1 * d0))
        qd = v[nr + k - 1]
        z0, z1, z2 = s0 * qd, s1 * qd, s2 * qd
        cb[k, 0] = vl1 * z2 - vl2 * z1
        cb[k, 1] = vl2 * z0 - vl0 * z2
        cb[k, 2] = vl0 * z1 - vl1 * z0
        cb[k, 3] = w1 * z2 - w2 * z1
        cb[k, 4] = w2 * z0 - w0 * z2
        cb[k, 5] = w0 * z1 - w1 * z0
        w0, w1, w2 = w0 + z0, w1 + z1, w2 + z2
        # body inertia in base axes: h' = bR_k h, I_o' = bR_k I_o bR_k^T ([h]x = m [c]x)
        m = I6[k, 0, 0]
        hx, hy, hz = I6[k, 5, 1], I6[k, 3, 2], I6[k, 4, 0]
        h0 = b00 * hx + b01 * hy + b02 * hz
        h1 = b10 * hx + b11 * hy + b12 * hz
        h2 = b20 * hx + b21 * hy + b22 * hz
        i00, i01, i02, i11, i12, i22 = _rot_sym(b00, b01, b02, b10, b11, b12, b20, b21, b22,
                                                I6[k, 3, 3], I6[k, 3, 4], I6[k, 3, 5],
                                                I6[k, 4, 4], I6[k, 4, 5], I6[k, 5, 5])
        IA[k, 5, 1], IA[k, 3, 2], IA[k, 4, 0] = h0, h1, h2
        IA[k, 3, 3], IA[k, 3, 4], IA[k, 3, 5] = i00, i01, i02
        IA[k, 4, 4], IA[k, 4, 5], IA[k, 5, 5] = i11, i12, i22
        # pA_k = v_k x* (I_k v_k), I_k v_k = [m v_l + w x h; h x v_l + I_o w]
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
    # pass 2 (tip to base): IA_k = I_k + (the child's articulated inertia at this origin),
    # U = IA S, D = S^T U, u = tau - S^T pA; Ia = IA - U U^T / D, pa = pA + Ia c + U u / D
    # to the parent. IA = [[A, B], [B^T, C]] and the child's bias force f carried in scalars.
    a00 = a01 = a02 = a11 = a12 = a22 = 0.0
    e00 = e01 = e02 = e10 = e11 = e12 = e20 = e21 = e22 = 0.0      # B
    c00 = c01 = c02 = c11 = c12 = c22 = 0.0
    f0 = f1 = f2 = f3 = f4 = f5 = 0.0
    for k in range(nb - 1, 0, -1):
        m = I6[k, 0, 0]
        h0, h1, h2 = IA[k, 5, 1], IA[k, 3, 2], IA[k, 4, 0]
        a00, a11, a22 = a00 + m, a11 + m, a22 + m
        e01, e02, e10 = e01 + h2, e02 - h1, e10 - h2               # -[h]x
        e12, e20, e21 = e12 + h0, e20 + h1, e21 - h0
        c00, c01, c02 = c00 + IA[k, 3, 3], c01 + IA[k, 3, 4], c02 + IA[k, 3, 5]
        c11, c12, c22 = c11 + IA[k, 4, 4], c12 + IA[k, 4, 5], c22 + IA[k, 5, 5]
        P0, P1, P2 = pA[k, 0] + f0, pA[k, 1] + f1, pA[k, 2] + f2
        P3, P4, P5 = pA[k, 3] + f3, pA[k, 4] + f4, pA[k, 5] + f5
        s0, s1, s2 = S[k, 3], S[k, 4], S[k, 5]
        U0 = e00 * s0 + e01 * s1 + e02 * s2
        U1 = e10 * s0 + e11 * s1 + e12 * s2
        U2 = e20 * s0 + e21 * s1 + e22 * s2
        U3 = c00 * s0 + c01 * s1 + c02 * s2
        U4 = c01 * s0 + c11 * s1 + c12 * s2
        U5 = c02 * s0 + c12 * s1 + c22 * s2
        D = U3 * s0 + U4 * s1 + U5 * s2
        u = tau[nr + k - 1] - (P3 * s0 + P4 * s1 + P5 * s2)
        U[k, 0], U[k, 1], U[k, 2], U[k, 3], U[k, 4], U[k, 5] = U0, U1, U2, U3, U4, U5
        rD = 1.0 / D                      # one division per joint
        Du[k, 0], Du[k, 1] = rD, u
        x0, x1, x2, x3, x4, x5 = cb[k, 0], cb[k, 1], cb[k, 2], cb[k, 3], cb[k, 4], cb[k, 5]
        # pa = pA + IA c + U (u - U^T c) / D
        g = (u - (U0 * x0 + U1 * x1 + U2 * x2 + U3 * x3 + U4 * x4 + U5 * x5)) * rD
        pa0 = P0 + U0 * g + a00 * x0 + a01 * x1 + a02 * x2 + e00 * x3 + e01 * x4 + e02 * x5
        pa1 = P1 + U1 * g + a01 * x0 + a11 * x1 + a12 * x2 + e10 * x3 + e11 * x4 + e12 * x5
        pa2 = P2 + U2 * g + a02 * x0 + a12 * x1 + a22 * x2 + e20 * x3 + e21 * x4 + e22 * x5
        pa3 = P3 + U3 * g + e00 * x0 + e10 * x1 + e20 * x2 + c00 * x3 + c01 * x4 + c02 * x5
        pa4 = P4 + U4 * g + e01 * x0 + e11 * x1 + e21 * x2 + c01 * x3 + c11 * x4 + c12 * x5
        pa5 = P5 + U5 * g + e02 * x0 + e12 * x1 + e22 * x2 + c02 * x3 + c12 * x4 + c22 * x5
        # Ia = IA - U U^T / D, then to the parent's origin
        y0, y1, y2, y3, y4, y5 = U0 * rD, U1 * rD, U2 * rD, U3 * rD, U4 * rD, U5 * rD
        d0, d1, d2 = bp[k, 0] - bp[k - 1, 0], bp[k, 1] - bp[k - 1, 1], bp[k, 2] - bp[k - 1, 2]
        (a00, a01, a02, a11, a12, a22, e00, e01, e02, e10, e11, e12, e20, e21, e22,
         c00, c01, c02, c11, c12, c22) = _shift(
            d0, d1, d2, a00 - y0 * U0, a01 - y0 * U1, a02 - y0 * U2, a11 - y1 * U1,
            a12 - y1 * U2, a22 - y2 * U2,
            e00 - y0 * U3, e01 - y0 * U4, e02 - y0 * U5, e10 - y1 * U3, e11 - y1 * U4,
            e12 - y1 * U5, e20 - y2 * U3, e21 - y2 * U4, e22 - y2 * U5,
            c00 - y3 * U3, c01 - y3 * U4, c02 - y3 * U5, c11 - y4 * U4, c12 - y4 * U5,
            c22 - y5 * U5)
        # force to the parent's origin: f_l, f_n + d x f_l
        f0, f1, f2 = pa0, pa1, pa2
        f3 = pa3 + (d1 * pa2 - d2 * pa1)
        f4 = pa4 + (d2 * pa0 - d0 * pa2)
        f5 = pa5 + (d0 * pa1 - d1 * pa0)
    # base: IA_0 = I_0 + the chain's, pA_0 += f; (S^T IA_0 S) dv_b = tau_b - S^T pA_0
    IB = IA[0]
    for i in range(6):
        for j in range(6):
            IB[i, j] = I6[0, i, j]
    IB[0, 0] += a00
    IB[0, 1] += a01
    IB[0, 2] += a02
    IB[1, 0] += a01
    IB[1, 1] += a11
    IB[1, 2] += a12
    IB[2, 0] += a02
    IB[2, 1] += a12
    IB[2, 2] += a22
    IB[0, 3] += e00
    IB[0, 4] += e01
    IB[0, 5] += e02
    IB[1, 3] += e10
    IB[1, 4] += e11
    IB[1, 5] += e12
    IB[2, 3] += e20
    IB[2, 4] += e21
    IB[2, 5] += e22
    IB[3, 0] += e00
    IB[4, 0] += e01
    IB[5, 0] += e02
    IB[3, 1] += e10
    IB[4, 1] += e11
    IB[5, 1] += e12
    IB[3, 2] += e20
    IB[4, 2] += e21
    IB[5, 2] += e22
    IB[3, 3] += c00
    IB[3, 4] += c01
    IB[3, 5] += c02
    IB[4, 3] += c01
    IB[4, 4] += c11
    IB[4, 5] += c12
    IB[5, 3] += c02
    IB[5, 4] += c12
    IB[5, 5] += c22
    pA[0, 0] += f0
    pA[0, 1] += f1
    pA[0, 2] += f2
    pA[0, 3] += f3
    pA[0, 4] += f4
    pA[0, 5] += f5
    if not _base_solve(planar, IB, pA[0], tau, M6, v6[0], v6[1], ddq):
        return 1
    # pass 3 (base to tip): a = shift(a_p) + c_k, qdd_k = (u_k - U_k^T a) / D_k, a_k = a + S qdd
    x0, x1, x2, x3, x4, x5 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    if planar:
        x0, x1, x5 = ddq[0], ddq[1], ddq[2]
    else:
        x0, x1, x2, x3, x4, x5 = ddq[0], ddq[1], ddq[2], ddq[3], ddq[4], ddq[5]
    for k in range(1, nb):
        d0, d1, d2 = bp[k, 0] - bp[k - 1, 0], bp[k, 1] - bp[k - 1, 1], bp[k, 2] - bp[k - 1, 2]
        x0, x1, x2 = (x0 + (x4 * d2 - x5 * d1) + cb[k, 0], x1 + (x5 * d0 - x3 * d2) + cb[k, 1],
                      x2 + (x3 * d1 - x4 * d0) + cb[k, 2])
        x3, x4, x5 = x3 + cb[k, 3], x4 + cb[k, 4], x5 + cb[k, 5]
        s = (Du[k, 1] - U[k, 0] * x0 - U[k, 1] * x1 - U[k, 2] * x2 - U[k, 3] * x3
             - U[k, 4] * x4 - U[k, 5] * x5)
        qdd = s * Du[k, 0]
        ddq[nr + k - 1] = qdd
        x3, x4, x5 = x3 + S[k, 3] * qdd, x4 + S[k, 4] * qdd, x5 + S[k, 5] * qdd
    return 0


@njit(**_NI)
def terms(planar, R, p, I6, mc, q, v, M, nle, hg, bp, S, cb, IA, pA, U, Du, M6, v6):
    """Joint-space inertia (CRBA), non-linear effects (RNEA at zero acceleration) and the
    centroidal momentum, as Pinocchio's ``computeAllTerms`` gives ``data.M``, ``data.nle`` and
    ``data.hg``.

    Writes ``M`` (nv, nv) (both triangles), ``nle`` (nv,) and ``hg`` (6,) = ``[P, L_c]``
    (inertial frame; angular momentum about the system centre of mass). Returns the system
    centre of mass (3 floats, inertial frame). Of the work arrays (:class:`Workspace`, as
    :func:`aba` takes them) it writes ``S`` (the joint motions ``[bp x s; s]``), ``IA`` (each
    body's inertia at the base origin by its defining entries, as :func:`aba`), ``pA`` (each
    body's RNEA force) and ``U`` (the CRBA's ``Ic S``).

    Everything is in the base frame at the base origin (the spatial-algebra comment above);
    the chain's running quantities (placement, velocity, acceleration, momentum in the forward
    pass; composite inertia and force in the backward pass) stay in local variables, and every
    inertia is a rigid body's ``(m, g, J)`` (:func:`_rbi_mul`), composites included.
    """
    nb = R.shape[0]
    nr = 3 if planar else 6
    nq0 = 4 if planar else 7
    # RNEA, forward: v_k = v_p + S qd, a_k = a_p + c_k (a_0 = 0), c_k = v_k x (S qd);
    # f_k = I a_k + v x* (I v); momentum h = sum I v
    vl0, vl1, vl2, w0, w1, w2, hl0, hl1, hl2, hn0, hn1, hn2 = _base_motion(planar, v, I6, pA)
    a0, a1, a2, a3, a4, a5 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    b00, b01, b02, b10, b11, b12, b20, b21, b22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
    ox, oy, oz = 0.0, 0.0, 0.0
    for k in range(1, nb):
        (b00, b01, b02, b10, b11, b12, b20, b21, b22, ox, oy, oz, s3, s4, s5) = _place(
            R, p, k, q[nq0 + k - 1], b00, b01, b02, b10, b11, b12, b20, b21, b22,
            ox, oy, oz)
        s0, s1, s2 = oy * s5 - oz * s4, oz * s3 - ox * s5, ox * s4 - oy * s3
        S[k, 0], S[k, 1], S[k, 2], S[k, 3], S[k, 4], S[k, 5] = s0, s1, s2, s3, s4, s5
        # velocity: v_k = v_p + S qd;  c_k = v_k x (S qd) = [w x sl + vl x sw; w x sw] qd
        qd = v[nr + k - 1]
        vl0, vl1, vl2 = vl0 + s0 * qd, vl1 + s1 * qd, vl2 + s2 * qd
        w0, w1, w2 = w0 + s3 * qd, w1 + s4 * qd, w2 + s5 * qd
        a0 += (w1 * s2 - w2 * s1 + vl1 * s5 - vl2 * s4) * qd
        a1 += (w2 * s0 - w0 * s2 + vl2 * s3 - vl0 * s5) * qd
        a2 += (w0 * s1 - w1 * s0 + vl0 * s4 - vl1 * s3) * qd
        a3 += (w1 * s5 - w2 * s4) * qd
        a4 += (w2 * s3 - w0 * s5) * qd
        a5 += (w0 * s4 - w1 * s3) * qd
        # inertia at the base origin: h' = bR_k h, I_o' = bR_k I_o bR_k^T, then shifted:
        # g = h' + m o, J = I_o' + (2 o.h' + m |o|^2) 1 - (h' o^T + o h'^T + m o o^T)
        m = I6[k, 0, 0]
        hx, hy, hz = I6[k, 5, 1], I6[k, 3, 2], I6[k, 4, 0]          # [h]x = m [c]x
        h0 = b00 * hx + b01 * hy + b02 * hz
        h1 = b10 * hx + b11 * hy + b12 * hz
        h2 = b20 * hx + b21 * hy + b22 * hz
        i00, i01, i02, i11, i12, i22 = _rot_sym(b00, b01, b02, b10, b11, b12, b20, b21, b22,
                                                I6[k, 3, 3], I6[k, 3, 4], I6[k, 3, 5],
                                                I6[k, 4, 4], I6[k, 4, 5], I6[k, 5, 5])
        mo0, mo1, mo2 = m * ox, m * oy, m * oz
        dd = 2.0 * (ox * h0 + oy * h1 + oz * h2) + (mo0 * ox + mo1 * oy + mo2 * oz)
        g0, g1, g2 = h0 + mo0, h1 + mo1, h2 + mo2       # h' o^T + o h'^T + m o o^T = g o^T + o h'^T
        j00 = i00 + dd - (g0 * ox + ox * h0)
        j11 = i11 + dd - (g1 * oy + oy * h1)
        j22 = i22 + dd - (g2 * oz + oz * h2)
        j01 = i01 - (g0 * oy + ox * h1)
        j02 = i02 - (g0 * oz + ox * h2)
        j12 = i12 - (g1 * oz + oy * h2)
        IA[k, 5, 1], IA[k, 3, 2], IA[k, 4, 0] = g0, g1, g2
        IA[k, 3, 3], IA[k, 3, 4], IA[k, 3, 5] = j00, j01, j02
        IA[k, 4, 4], IA[k, 4, 5], IA[k, 5, 5] = j11, j12, j22
        yl0, yl1, yl2, yn0, yn1, yn2 = _rbi_mul(m, g0, g1, g2, j00, j01, j02, j11, j12, j22,
                                                vl0, vl1, vl2, w0, w1, w2)
        hl0, hl1, hl2, hn0, hn1, hn2 = hl0 + yl0, hl1 + yl1, hl2 + yl2, hn0 + yn0, hn1 + yn1, \
            hn2 + yn2
        fl0, fl1, fl2, fn0, fn1, fn2 = _rbi_mul(m, g0, g1, g2, j00, j01, j02, j11, j12, j22,
                                                a0, a1, a2, a3, a4, a5)
        cl0, cl1, cl2, cn0, cn1, cn2 = _crf(vl0, vl1, vl2, w0, w1, w2, yl0, yl1, yl2, yn0, yn1,
                                           yn2)
        pA[k, 0], pA[k, 1], pA[k, 2] = fl0 + cl0, fl1 + cl1, fl2 + cl2
        pA[k, 3], pA[k, 4], pA[k, 5] = fn0 + cn0, fn1 + cn1, fn2 + cn2
    # backward: f_p += f_k, nle_k = S^T f_k; composite Ic_p += Ic_k; CRBA: F = Ic_k S_k,
    # M_jk = S_j^T F (j <= k), base rows F
    mt = g0 = g1 = g2 = j00 = j01 = j02 = j11 = j12 = j22 = 0.0
    f0 = f1 = f2 = f3 = f4 = f5 = 0.0
    for k in range(nb - 1, 0, -1):
        mt += I6[k, 0, 0]
        g0, g1, g2 = g0 + IA[k, 5, 1], g1 + IA[k, 3, 2], g2 + IA[k, 4, 0]
        j00, j01, j02 = j00 + IA[k, 3, 3], j01 + IA[k, 3, 4], j02 + IA[k, 3, 5]
        j11, j12, j22 = j11 + IA[k, 4, 4], j12 + IA[k, 4, 5], j22 + IA[k, 5, 5]
        f0, f1, f2 = f0 + pA[k, 0], f1 + pA[k, 1], f2 + pA[k, 2]
        f3, f4, f5 = f3 + pA[k, 3], f4 + pA[k, 4], f5 + pA[k, 5]
        s0, s1, s2, s3, s4, s5 = S[k, 0], S[k, 1], S[k, 2], S[k, 3], S[k, 4], S[k, 5]
        col = nr + k - 1
        nle[col] = s0 * f0 + s1 * f1 + s2 * f2 + s3 * f3 + s4 * f4 + s5 * f5
        F = U[k]
        F[0], F[1], F[2], F[3], F[4], F[5] = _rbi_mul(mt, g0, g1, g2, j00, j01, j02, j11, j12,
                                                      j22, s0, s1, s2, s3, s4, s5)
        for j in range(k, 0, -1):
            mj = (S[j, 0] * F[0] + S[j, 1] * F[1] + S[j, 2] * F[2] + S[j, 3] * F[3]
                  + S[j, 4] * F[4] + S[j, 5] * F[5])
            M[nr + j - 1, col] = mj
            M[col, nr + j - 1] = mj
        for i in range(nr):
            M[i, col] = F[_row(planar, i)]
            M[col, i] = F[_row(planar, i)]
    # the base: the whole system's composite inertia and force
    mt += I6[0, 0, 0]
    g0, g1, g2 = g0 + I6[0, 5, 1], g1 + I6[0, 3, 2], g2 + I6[0, 4, 0]
    j00, j01, j02 = j00 + I6[0, 3, 3], j01 + I6[0, 3, 4], j02 + I6[0, 3, 5]
    j11, j12, j22 = j11 + I6[0, 4, 4], j12 + I6[0, 4, 5], j22 + I6[0, 5, 5]
    f0, f1, f2 = f0 + pA[0, 0], f1 + pA[0, 1], f2 + pA[0, 2]
    f3, f4, f5 = f3 + pA[0, 3], f4 + pA[0, 4], f5 + pA[0, 5]
    if planar:
        nle[0], nle[1], nle[2] = f0, f1, f5
        # rows/columns (v_x, v_y, omega_z) of [[m 1, -[g]x], [[g]x, J]]
        M[0, 0], M[0, 1], M[0, 2] = mt, 0.0, -g1
        M[1, 0], M[1, 1], M[1, 2] = 0.0, mt, g0
        M[2, 0], M[2, 1], M[2, 2] = -g1, g0, j22
    else:
        nle[0], nle[1], nle[2], nle[3], nle[4], nle[5] = f0, f1, f2, f3, f4, f5
        M[0, 0], M[0, 1], M[0, 2], M[0, 3], M[0, 4], M[0, 5] = mt, 0.0, 0.0, 0.0, g2, -g1
        M[1, 0], M[1, 1], M[1, 2], M[1, 3], M[1, 4], M[1, 5] = 0.0, mt, 0.0, -g2, 0.0, g0
        M[2, 0], M[2, 1], M[2, 2], M[2, 3], M[2, 4], M[2, 5] = 0.0, 0.0, mt, g1, -g0, 0.0
        M[3, 0], M[3, 1], M[3, 2], M[3, 3], M[3, 4], M[3, 5] = 0.0, -g2, g1, j00, j01, j02
        M[4, 0], M[4, 1], M[4, 2], M[4, 3], M[4, 4], M[4, 5] = g2, 0.0, -g0, j01, j11, j12
        M[5, 0], M[5, 1], M[5, 2], M[5, 3], M[5, 4], M[5, 5] = -g1, g0, 0.0, j02, j12, j22
    # centre of mass (base frame): the composite's first moment over its mass
    cx, cy, cz = g0 / mt, g1 / mt, g2 / mt
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
    l0, l1, l2 = hl0, hl1, hl2
    n0 = hn0 - (cy * l2 - cz * l1)
    n1 = hn1 - (cz * l0 - cx * l2)
    n2 = hn2 - (cx * l1 - cy * l0)
    hg[0] = a00 * l0 + a01 * l1 + a02 * l2
    hg[1] = a10 * l0 + a11 * l1 + a12 * l2
    hg[2] = a20 * l0 + a21 * l1 + a22 * l2
    hg[3] = a00 * n0 + a01 * n1 + a02 * n2
    hg[4] = a10 * n0 + a11 * n1 + a12 * n2
    hg[5] = a20 * n0 + a21 * n1 + a22 * n2
    return (r0 + a00 * cx + a01 * cy + a02 * cz, r1 + a10 * cx + a11 * cy + a12 * cz,
            r2 + a20 * cx + a21 * cy + a22 * cz)
