"""The oracle's kernels of one sample: its equations and the RLS step, written as plain loops
(run as Python, ``_nonumba``).

One sample needs the arm's forward kinematics (n links), the arm's momentum or rate of
momentum, the regressors of base and target and two RLS updates. The equations are those of the NumPy test oracles
``tests/oracles/kinematics.py`` (the arm recursion) and ``tests/oracles/regressors.py`` (the
regressors of one body, same notation), which the tests check these kernels against:

* kinematics, revolute joint ``i`` with parent frame ``p``: ``d = A_p xyz_i``,
  ``A_i = A_p R_i Rot(axis_i, q_i)``, ``z = A_i axis_i``, ``w_i = w_p + z qd_i``,
  ``v_i = v_p + w_p x d``, ``b_i = b_p + z qdd_i + w_p x z qd_i``,
  ``a_i = a_p + b_p x d + w_p x (w_p x d)``;
* momentum form (eqs. 11/16): ``B mu = J - P_arm``, ``Phi theta = H - L_arm - Psi D(mu)``;
* force form (eqs. 28/31, moments about S): ``G mu = F - F_arm``,
  ``Q theta = M - M_arm,S - S D(mu)``.

:func:`equations` writes one (3, 42) array ``E = [A (8) | b | phi (12) | y | psi (20)]``
(full 3D rows, base then target), with ``psi = -Psi`` (momentum) or ``-S`` (force), so that
``A mu = b`` and ``phi theta = y + psi D(mu)``; for the momentum form the identifier
subtracts the reference sample's ``E``.

Self-contained: the Cholesky solve of :func:`rls_update` is written out here.
"""
from __future__ import annotations

import math

import numpy as np
from ._nonumba import njit

_NB = dict(cache=True, nogil=True)

#: columns of the equation array E
COL_A, COL_B, COL_PHI, COL_Y, COL_PSI, N_COLS = 0, 8, 9, 21, 22, 42

#: layout of the flat measurement vector (KEYS order): offsets of the fixed-size signals;
#: q, qd, qdd follow at 24 (n each), then F, M, J, H (3 each)
R_S, V_S, A_B, OMEGA_B, A_S, ALPHA_B, Q0 = 0, 3, 6, 15, 18, 21, 24


@njit(**_NB)
def _cross(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit(**_NB)
def _matvec(A, x, out):
    for i in range(3):
        out[i] = A[i, 0] * x[0] + A[i, 1] * x[1] + A[i, 2] * x[2]


@njit(**_NB)
def _matTvec(A, x, out):
    for i in range(3):
        out[i] = A[0, i] * x[0] + A[1, i] * x[1] + A[2, i] * x[2]


@njit(**_NB)
def _matmul3(A, B, out):
    for i in range(3):
        for j in range(3):
            out[i, j] = A[i, 0] * B[0, j] + A[i, 1] * B[1, j] + A[i, 2] * B[2, j]


@njit(**_NB)
def _inertia_times(A, I, w, tmp, out):
    """``A I A^T w`` (inertia in body coordinates applied to an inertial vector)."""
    _matTvec(A, w, tmp)
    for i in range(3):
        s = I[i, 0] * tmp[0] + I[i, 1] * tmp[1] + I[i, 2] * tmp[2]
        out[i] = s
    tmp[0], tmp[1], tmp[2] = out[0], out[1], out[2]
    _matvec(A, tmp, out)


@njit(**_NB)
def _a_sharp(A, u, E, row0, col, sign):
    """``E[:, col:col+6] += sign * A [#u]`` (eq. 20: ``I v = [#v] I#``)."""
    for i in range(3):
        a0, a1, a2 = A[i, 0], A[i, 1], A[i, 2]
        E[row0 + i, col + 0] += sign * (a0 * u[0])
        E[row0 + i, col + 1] += sign * (a0 * u[1] + a1 * u[0])
        E[row0 + i, col + 2] += sign * (a0 * u[2] + a2 * u[0])
        E[row0 + i, col + 3] += sign * (a1 * u[1])
        E[row0 + i, col + 4] += sign * (a1 * u[2] + a2 * u[1])
        E[row0 + i, col + 5] += sign * (a2 * u[2])


@njit(**_NB)
def _shift(E, src, dst, sign):
    """``E[:, dst:dst+6] = sign * E[:, src:src+6] @ T_SHIFT`` (the parallel-axis map)."""
    for i in range(3):
        x0, x1, x2, x3, x4, x5 = (E[i, src], E[i, src + 1], E[i, src + 2], E[i, src + 3],
                                  E[i, src + 4], E[i, src + 5])
        E[i, dst + 0] = sign * (x3 + x5)
        E[i, dst + 1] = sign * -x1
        E[i, dst + 2] = sign * -x2
        E[i, dst + 3] = sign * (x0 + x5)
        E[i, dst + 4] = sign * -x4
        E[i, dst + 5] = sign * (x0 + x3)


@njit(**_NB)
def _body_rows(force, k, r_O, A, v_O, w, a_O, beta, rho, E):
    """Columns of body ``k`` (0 base, 1 target) in ``E`` (see the module docstring).

    Momentum: ``B = [v_O, [w]x A]``, ``D = A [#(A^T w)]``,
    ``-Psi = -[r_O x v_O, ([r_O]x [w]x - [v_O]x) A, D T]``.
    Force: ``G = [a_O, K A]`` with ``K = [beta]x + [w]x[w]x``,
    ``Q = A [#(A^T beta)] + [w]x A [#(A^T w)]``, ``-S = -[rho x a_O, ([rho]x K - [a_O]x) A, Q T]``.
    The two share their shape: a vector ``l`` (v_O / a_O), a lever ``r`` (r_O / rho) and a map
    ``X`` ([w]x / K): ``[l, X A]`` and ``[r x l, ([r]x X - [l]x) A, ...]``.
    """
    cA, cP, cS = COL_A + 4 * k, COL_PHI + 6 * k, COL_PSI + 10 * k
    lvec = a_O if force else v_O
    lever = rho if force else r_O
    u = np.empty(3)
    t1 = np.empty(3)
    t2 = np.empty(3)
    col = np.empty(3)
    _cross(lever, lvec, t1)
    for i in range(3):
        E[i, cA] = lvec[i]
        E[i, cS] = -t1[i]
    for j in range(3):
        col[0], col[1], col[2] = A[0, j], A[1, j], A[2, j]
        _cross(w, col, t1)                            # [w]x A_j
        if force:
            _cross(w, t1, t2)                         # w x (w x A_j)
            _cross(beta, col, t1)                     # beta x A_j
            for i in range(3):
                t1[i] += t2[i]                        # K A_j
        _cross(lever, t1, t2)                         # r x X A_j
        _cross(lvec, col, u)                          # l x A_j
        for i in range(3):
            E[i, cA + 1 + j] = t1[i]
            E[i, cS + 1 + j] = -(t2[i] - u[i])
    for i in range(3):
        for c in range(6):
            E[i, cP + c] = 0.0
    _matTvec(A, beta if force else w, u)
    _a_sharp(A, u, E, 0, cP, 1.0)                     # A [#(A^T w)] or A [#(A^T beta)]
    if force:                                         # + [w]x A [#(A^T w)]
        _matTvec(A, w, u)
        tmpE = np.zeros((3, 6))
        _a_sharp(A, u, tmpE, 0, 0, 1.0)
        for c in range(6):
            col[0], col[1], col[2] = tmpE[0, c], tmpE[1, c], tmpE[2, c]
            _cross(w, col, t1)
            for i in range(3):
                E[i, cP + c] += t1[i]
    _shift(E, cP, cS + 4, -1.0)                       # -(D or Q) T


@njit(**_NB)
def equations(force, x, n, xyz, R, axis, mass, com, I, ee_xyz, ee_R, E):
    """The equations of one sample into ``E`` (3, 42), see the module docstring.

    Parameters
    ----------
    force : bool                 force form (else momentum form)
    x : (24 + 3 n + 12,)         measurements, flattened in the order of
                                 ``spacerobot.estimator.identifier.KEYS`` (``A`` row-major)
    n : int                      number of arm joints
    xyz (n, 3), R (n, 3, 3), axis (n, 3) unit, mass (n,), com (n, 3), I (n, 3, 3), ee_xyz (3,),
    ee_R (3, 3):                 the arm (joint placements in the parent frame, link inertias
                                 about their centres of mass in link coordinates) and E
    """
    r_S = x[R_S:R_S + 3]
    v_S = x[V_S:V_S + 3]
    a_S = x[A_S:A_S + 3]
    A0 = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            A0[i, j] = x[A_B + 3 * i + j]
    q, qd, qdd = x[Q0:Q0 + n], x[Q0 + n:Q0 + 2 * n], x[Q0 + 2 * n:Q0 + 3 * n]
    o = Q0 + 3 * n
    Fm, Mm, Jm, Hm = x[o:o + 3], x[o + 3:o + 6], x[o + 6:o + 9], x[o + 9:o + 12]
    w0 = np.empty(3)
    b0 = np.empty(3)
    _matvec(A0, x[OMEGA_B:OMEGA_B + 3], w0)
    _matvec(A0, x[ALPHA_B:ALPHA_B + 3], b0)           # d/dt(A w_B) = A dw_B/dt
    # parent frame state (starts at the base, origin S)
    Ap = A0.copy()
    rp, vp, wp, ap, bp = r_S.copy(), v_S.copy(), w0.copy(), a_S.copy(), b0.copy()
    Ai = np.empty((3, 3))
    Rq = np.empty((3, 3))
    T = np.empty((3, 3))
    d = np.empty(3)
    z = np.empty(3)
    c = np.empty(3)
    t1 = np.empty(3)
    t2 = np.empty(3)
    t3 = np.empty(3)
    rc = np.empty(3)
    vc = np.empty(3)
    ac = np.empty(3)
    Iw = np.empty(3)
    Ib = np.empty(3)
    lin = np.zeros(3)                                  # P_arm or F_arm
    ang = np.zeros(3)                                  # L_arm (about O) or M_arm (about S)
    for i in range(n):
        _matvec(Ap, xyz[i], d)
        # Rot(axis, q) = cos q I + sin q [k]x + (1 - cos q) k k^T
        k0, k1, k2 = axis[i, 0], axis[i, 1], axis[i, 2]
        cq, sq = math.cos(q[i]), math.sin(q[i])
        vq = 1.0 - cq
        Rq[0, 0], Rq[0, 1], Rq[0, 2] = cq + vq * k0 * k0, vq * k0 * k1 - sq * k2, vq * k0 * k2 + sq * k1
        Rq[1, 0], Rq[1, 1], Rq[1, 2] = vq * k1 * k0 + sq * k2, cq + vq * k1 * k1, vq * k1 * k2 - sq * k0
        Rq[2, 0], Rq[2, 1], Rq[2, 2] = vq * k2 * k0 - sq * k1, vq * k2 * k1 + sq * k0, cq + vq * k2 * k2
        _matmul3(Ap, R[i], T)
        _matmul3(T, Rq, Ai)
        _matvec(Ai, axis[i], z)
        # origin of frame i: r, v (a) from the parent
        _cross(wp, d, t1)
        for j in range(3):
            rp[j] += d[j]
            vp[j] += t1[j]
        if force:
            _cross(bp, d, t2)
            _cross(wp, t1, t3)
            for j in range(3):
                ap[j] += t2[j] + t3[j]
            _cross(wp, z, t2)                          # b_i = b_p + z qdd + w_p x z qd
            for j in range(3):
                bp[j] += z[j] * qdd[i] + t2[j] * qd[i]
        for j in range(3):
            wp[j] += z[j] * qd[i]
        # the link's centre of mass
        _matvec(Ai, com[i], c)
        _cross(wp, c, t1)
        for j in range(3):
            rc[j] = rp[j] + c[j]
            vc[j] = vp[j] + t1[j]
        m = mass[i]
        _inertia_times(Ai, I[i], wp, t2, Iw)
        if not force:
            # P = sum m v_c ;  L = sum A I A^T w + m r_c x v_c
            _cross(rc, vc, t2)
            for j in range(3):
                lin[j] += m * vc[j]
                ang[j] += Iw[j] + m * t2[j]
        else:
            # F = sum m a_c ;  M_S = sum A I A^T beta + w x A I A^T w + m (r_c - r_S) x a_c
            _cross(bp, c, t2)
            _cross(wp, t1, t3)
            for j in range(3):
                ac[j] = ap[j] + t2[j] + t3[j]
            _inertia_times(Ai, I[i], bp, t2, Ib)
            _cross(wp, Iw, t1)
            for j in range(3):
                t3[j] = rc[j] - r_S[j]
            _cross(t3, ac, t2)
            for j in range(3):
                lin[j] += m * ac[j]
                ang[j] += Ib[j] + t1[j] + m * t2[j]
        for a in range(3):
            for b in range(3):
                Ap[a, b] = Ai[a, b]
    # end-effector frame E (the target's frame)
    _matvec(Ap, ee_xyz, d)
    AE = np.empty((3, 3))
    _matmul3(Ap, ee_R, AE)
    _cross(wp, d, t1)
    rE = np.empty(3)
    vE = np.empty(3)
    aE = np.empty(3)
    for j in range(3):
        rE[j] = rp[j] + d[j]
        vE[j] = vp[j] + t1[j]
    if force:
        _cross(bp, d, t2)
        _cross(wp, t1, t3)
        for j in range(3):
            aE[j] = ap[j] + t2[j] + t3[j]
    zero = np.zeros(3)
    if force:
        rho = np.empty(3)
        for j in range(3):
            rho[j] = rE[j] - r_S[j]
        _body_rows(True, 0, r_S, A0, v_S, w0, a_S, b0, zero, E)
        _body_rows(True, 1, rE, AE, vE, wp, aE, bp, rho, E)
        for j in range(3):
            E[j, COL_B] = Fm[j] - lin[j]
            E[j, COL_Y] = Mm[j] - ang[j]               # the thrust acts at S: no moment about S
    else:
        _body_rows(False, 0, r_S, A0, v_S, w0, a_S, b0, zero, E)
        _body_rows(False, 1, rE, AE, vE, wp, aE, bp, zero, E)
        for j in range(3):
            E[j, COL_B] = Jm[j] - lin[j]
            E[j, COL_Y] = Hm[j] - ang[j]


@njit(**_NB)
def D_of_mu(mu):
    """``D(mu) = [m1 J(b1); mn J(bn)]`` (20,) from ``mu = [m1, m1 b1, mn, mn bn]`` (8,), with
    ``J(b) = [1, b, bx^2, bx by, bx bz, by^2, by bz, bz^2]`` (eq. 23)."""
    out = np.empty(20)
    for k in range(2):
        m = mu[4 * k]
        bx, by, bz = mu[4 * k + 1] / m, mu[4 * k + 2] / m, mu[4 * k + 3] / m
        o = 10 * k
        out[o], out[o + 1], out[o + 2], out[o + 3] = m, m * bx, m * by, m * bz
        out[o + 4], out[o + 5], out[o + 6] = m * (bx * bx), m * (bx * by), m * (bx * bz)
        out[o + 7], out[o + 8], out[o + 9] = m * (by * by), m * (by * bz), m * (bz * bz)
    return out


@njit(**_NB)
def rls_update(x, P, H, y, lam):
    """One RLS step for ``H x = y`` with forgetting factor ``lam`` (new arrays; inputs kept).

    ``S = lam I + H P H^T``, ``K = P H^T S^-1``, ``x+ = x + K e`` (``e = y - H x``),
    ``P+ = (P - K H P) / lam`` symmetrised.

    Returns
    -------
    x_new (p,), P_new (p, p), e (k,), K (p, k), e^T S^-1 e (float), status (0 ok, 1 S not
    positive definite, 2 non-finite result; if not 0 nothing may be used)
    """
    p, k = x.shape[0], y.shape[0]
    e = np.empty(k)
    for i in range(k):
        s = y[i]
        for j in range(p):
            s -= H[i, j] * x[j]
        e[i] = s
    PHt = np.empty((p, k))
    for a in range(p):
        for i in range(k):
            s = 0.0
            for j in range(p):
                s += P[a, j] * H[i, j]
            PHt[a, i] = s
    S = np.empty((k, k))
    for i in range(k):
        for j in range(k):
            s = lam if i == j else 0.0
            for a in range(p):
                s += H[i, a] * PHt[a, j]
            S[i, j] = s
    # Cholesky S = L L^T (S is symmetric positive definite for a PSD P)
    L = np.zeros((k, k))
    for j in range(k):
        s = S[j, j]
        for a in range(j):
            s -= L[j, a] * L[j, a]
        if not s > 0.0:
            return x.copy(), P.copy(), e, np.zeros((p, k)), 0.0, 2 if s != s else 1
        L[j, j] = math.sqrt(s)
        for i in range(j + 1, k):
            t = S[i, j]
            for a in range(j):
                t -= L[i, a] * L[j, a]
            L[i, j] = t / L[j, j]
    # K^T = S^-1 (P H^T)^T and S^-1 e by the two triangular solves
    Kt = np.empty((k, p + 1))
    for i in range(k):
        for a in range(p):
            Kt[i, a] = PHt[a, i]
        Kt[i, p] = e[i]
    for c in range(p + 1):
        for i in range(k):
            s = Kt[i, c]
            for a in range(i):
                s -= L[i, a] * Kt[a, c]
            Kt[i, c] = s / L[i, i]
        for i in range(k - 1, -1, -1):
            s = Kt[i, c]
            for a in range(i + 1, k):
                s -= L[a, i] * Kt[a, c]
            Kt[i, c] = s / L[i, i]
    q = 0.0
    for i in range(k):
        q += e[i] * Kt[i, p]                           # e^T S^-1 e
    x_new = np.empty(p)
    K = np.empty((p, k))
    for a in range(p):
        s = x[a]
        for i in range(k):
            K[a, i] = Kt[i, a]
            s += Kt[i, a] * e[i]
        x_new[a] = s
    P_new = np.empty((p, p))
    total = q
    for a in range(p):
        total += x_new[a]
        for b in range(a, p):
            s1 = P[a, b]
            s2 = P[b, a]
            for i in range(k):
                s1 -= K[a, i] * PHt[b, i]
                s2 -= K[b, i] * PHt[a, i]
            v = 0.5 * (s1 + s2) / lam
            P_new[a, b] = v
            P_new[b, a] = v
            total += v
    return x_new, P_new, e, K, q, 0 if math.isfinite(total) else 2


@njit(**_NB)
def modified_rls_update(lin_x, lin_P, ang_x, ang_P, M, D_mu, A, b, phi, y, psi, lam, mu_full,
                        active):
    """One sample of the paper's modified RLS (eqs. 34-38), see ``rls.ModifiedRLS``.

    ``mu`` = ``lin_x`` are the entries ``active`` of the full mass vector ``mu_full`` (8,) (the
    others stay fixed); ``D(mu)`` is :func:`D_of_mu` of the full vector.

    1. ``mu+`` by RLS on ``A mu = b``;
    2. ``theta += M (D(mu+) - D(mu))`` (re-reference the inertia estimate to the new mu);
    3. ``theta+`` by RLS on ``phi theta = y + psi D(mu+)``;
    4. ``M = (I - K phi) M + K psi`` (``K`` the gain of step 3).

    Returns ``(lin_x, lin_P, ang_x, ang_P, M, D(mu+), e_lin, e_ang, q_lin, q_ang, rhs_ang,
    status)`` (new arrays; ``q`` = ``e^T S^-1 e`` of each RLS step, ``rhs_ang = y + psi D(mu+)``,
    status as :func:`rls_update`'s, for both steps and M).
    """
    x1, P1, e1, K1, q1, st1 = rls_update(lin_x, lin_P, A, b, lam)
    mu = mu_full.copy()
    for i in range(active.shape[0]):
        mu[active[i]] = x1[i]
    D_new = D_of_mu(mu)
    r, nd, k = ang_x.shape[0], D_new.shape[0], y.shape[0]
    th = ang_x.copy()
    for i in range(r):
        s = 0.0
        for j in range(nd):
            s += M[i, j] * (D_new[j] - D_mu[j])
        th[i] += s
    rhs = np.empty(k)
    for i in range(k):
        s = y[i]
        for j in range(nd):
            s += psi[i, j] * D_new[j]
        rhs[i] = s
    x2, P2, e2, K2, q2, st2 = rls_update(th, ang_P, phi, rhs, lam)
    # M+ = M + K (psi - phi M)
    W = np.empty((k, nd))
    for i in range(k):
        for j in range(nd):
            s = psi[i, j]
            for a in range(r):
                s -= phi[i, a] * M[a, j]
            W[i, j] = s
    M2 = M.copy()
    total = 0.0
    for a in range(r):
        for j in range(nd):
            s = 0.0
            for i in range(k):
                s += K2[a, i] * W[i, j]
            M2[a, j] += s
            total += M2[a, j]
    st = max(st1, st2)
    if st == 0 and not math.isfinite(total):
        st = 2
    return x1, P1, x2, P2, M2, D_new, e1, e2, q1, q2, rhs, st


@njit(**_NB)
def rotation_error(x, o):
    """``(max |A^T A - I|, det A)`` of the DCM stored row-major at ``x[o:o + 9]``."""
    a00, a01, a02, a10, a11, a12, a20, a21, a22 = (x[o], x[o + 1], x[o + 2], x[o + 3], x[o + 4],
                                                   x[o + 5], x[o + 6], x[o + 7], x[o + 8])
    err = max(abs(a00 * a00 + a10 * a10 + a20 * a20 - 1.0),
              abs(a01 * a01 + a11 * a11 + a21 * a21 - 1.0),
              abs(a02 * a02 + a12 * a12 + a22 * a22 - 1.0),
              abs(a00 * a01 + a10 * a11 + a20 * a21),
              abs(a00 * a02 + a10 * a12 + a20 * a22),
              abs(a01 * a02 + a11 * a12 + a21 * a22))
    det = (a00 * (a11 * a22 - a12 * a21) - a01 * (a10 * a22 - a12 * a20)
           + a02 * (a10 * a21 - a11 * a20))
    return err, det


@njit(**_NB)
def sample_check(x, limit, tol):
    """0 if every entry of the flattened sample ``x`` is within ``[-limit, limit]`` (NaN is
    not) and its base DCM is a rotation (:func:`rotation_error` ``<= tol``, det > 0); 1 for a
    value out of range or non-finite, 2 for a non-rotation."""
    for i in range(x.shape[0]):
        if not abs(x[i]) <= limit:
            return 1
    err, det = rotation_error(x, A_B)
    if err <= tol and det > 0.0:
        return 0
    return 2


# -- the oracle: the RLS step in NumPy / LAPACK in place of the loops above (same contract) --------
def rls_update(x, P, H, y, lam):  # noqa: F811
    """One RLS step for ``H x = y`` (see the loop version above), NumPy: ``S`` factorised by
    LAPACK's Cholesky, ``S^-1 [P H^T, e]`` by its solve."""
    p, k = x.shape[0], y.shape[0]
    e = y - H @ x
    PHt = P @ H.T
    S = lam * np.eye(k) + H @ PHt
    if not np.all(np.isfinite(S)):
        return x.copy(), P.copy(), e, np.zeros((p, k)), 0.0, 2
    try:
        np.linalg.cholesky(S)
    except np.linalg.LinAlgError:
        return x.copy(), P.copy(), e, np.zeros((p, k)), 0.0, 1
    Kt = np.linalg.solve(S, np.column_stack([PHt.T, e]))
    K = Kt[:, :p].T.copy()
    q = float(e @ Kt[:, p])
    x_new = x + K @ e
    R = P - K @ PHt.T
    P_new = 0.5 * (R + R.T) / lam
    ok = math.isfinite(q) and np.all(np.isfinite(x_new)) and np.all(np.isfinite(P_new))
    return x_new, P_new, e, K, q, 0 if ok else 2


def modified_rls_update(lin_x, lin_P, ang_x, ang_P, M, D_mu, A, b, phi, y, psi, lam,  # noqa: F811
                        mu_full, active):
    """One sample of the paper's modified RLS (eqs. 34-38; see the loop version above), NumPy."""
    x1, P1, e1, K1, q1, st1 = rls_update(lin_x, lin_P, A, b, lam)
    mu = mu_full.copy()
    mu[active] = x1
    D_new = D_of_mu(mu)
    th = ang_x + M @ (D_new - D_mu)                       # eq. 36: re-referenced theta
    rhs = y + psi @ D_new
    x2, P2, e2, K2, q2, st2 = rls_update(th, ang_P, phi, rhs, lam)
    M2 = M + K2 @ (psi - phi @ M)                         # M+ = M + K (psi - phi M)
    st = max(st1, st2)
    if st == 0 and not np.all(np.isfinite(M2)):
        st = 2
    return x1, P1, x2, P2, M2, D_new, e1, e2, q1, q2, rhs, st
