"""Compiled (Numba) kernels of the plant's hot path: the controllers, the RK4 bookkeeping and
the loop over a whole communication step.

The plant runs its controllers once per 1 ms internal step and evaluates four RK4 stages per
step. :func:`advance` runs all the internal steps of one communication step in one call: per
step the rigid-body terms of :mod:`.rigid_body` (``M``, non-linear effects, centroidal
momentum) feed :func:`control`, whose inverse dynamics give the first stage's accelerations,
and the compiled articulated-body algorithm gives those of the three other stages, each
followed by :func:`stage`. Python is entered once per communication step.

The equations are the paper's (docs/models.md, "Controllers") and those of :mod:`.dynamics`:

* thrusters, eqs. 40-41, per inertial axis on the system momentum ``[P, L_c]``;
* arm attitude law, eq. 39, by an inertia-weighted, selectively damped right pseudo-inverse
  with a null-space posture term and a bound on the joint accelerations;
* the optional excitation (issue #12): eq. 39 about a multi-sine attitude reference and the
  posture term about a multi-sine joint reference, scaled by a ramped level
  (:func:`ramp_level`, :func:`channel`, :func:`reference`; design in ``docs/models.md``);
  within a communication step the sines of the references are stepped by rotation
  (:func:`rotate_trig`, :data:`TRIG_ANCHOR`);
* state derivative ``[dJ = F, dH = M + r_S x F, dq/dt, dv/dt, dm_p/dt, dP_x/dt, dL_x/dt]``
  with ``dq/dt`` of the root joint written out (quaternion / (cos, sin) kinematics), so
  classic RK4 applies unchanged;
* the propellant (issue #17, :class:`spacerobot.robots.Propellant`): the base's spatial
  inertia follows the propellant mass ``m_p`` (:func:`base_inertia`, at every stage), the
  thrust uses propellant (:func:`thrust_control`), and the expelled mass carries away the
  momentum ``P_x``, ``L_x`` of the tank's rigid motion (:func:`stage`).

Parameters that are arrays are written in place (the plant's preallocated buffers); every
kernel returns 0, or a positive code for a singular matrix (see :data:`ERRORS`). A non-finite
state propagates as NaN (the plant reports it after the step) and is not mistaken for a
singular matrix.

Compiled on first use and cached on disk (see :mod:`spacerobot.jit`): this module uses only
NumPy, Numba and :mod:`.rigid_body` (another kernel module, whose source is part of this
module's cache key).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .rigid_body import aba, cho_solve, cholesky, terms

#: eigenvalue ratio below which the attitude solve is damped (singularity robustness)
DLS_RATIO = 1e-2

#: steps between fresh evaluations of the excitation references' sines in :func:`advance`
#: (rotated by the step in between, :func:`rotate_trig`: the rounding of the rotation grows by
#: about one unit in the last place per step)
TRIG_ANCHOR = 20

#: kernel return codes
ERRORS = {1: "singular base inertia", 2: "singular arm inertia",
          3: "singular attitude coupling", 4: "singular articulated base inertia"}

#: order of the controller parameters in the ``par`` array of :func:`control`
PARAMS = ("K_F", "P_max", "F_max", "K_M", "L_max", "M_max", "K_D", "K_P", "K_Pn", "K_Dn",
          "qdd_max")

# error_model='numpy': a division by zero gives inf/NaN (no Python exception check per
# division; the inlined rigid-body kernels are compiled with these flags too), so that a
# non-finite state propagates as NaN as documented above
_NB = dict(cache=True, nogil=True, error_model="numpy")
# inlined into their callers (Numba IR): small kernels called per RK4 stage, where passing the
# arrays would cost about as much as their arithmetic
_NI = dict(_NB, inline="always")


@njit(**_NI)
def bounded_law(x, K, x_max, u_max):
    """Paper eqs. 40/41 for one axis: ``u = K x`` inside ``|x| < x_max`` (saturated at
    ``u_max``), ``u = sign(K x) u_max`` outside it. NaN passes through."""
    kx = K * x
    if abs(x) >= x_max:
        if kx > 0.0:
            return u_max
        if kx < 0.0:
            return -u_max
        return 0.0 * u_max
    if kx < -u_max:
        return -u_max
    if kx > u_max:
        return u_max
    return kx


@njit(**_NI)
def quat_dcm(x, y, z, w):
    """DCM entries (body -> inertial, row-major, 9 floats) of a not necessarily unit
    quaternion ``(x, y, z, w)``. Callable from Python too."""
    s = 2.0 / (x * x + y * y + z * z + w * w)
    xx, yy, zz = x * x, y * y, z * z
    xy, xz, yz = x * y, x * z, y * z
    xw, yw, zw = x * w, y * w, z * w
    return (1.0 - s * (yy + zz), s * (xy - zw), s * (xz + yw),
            s * (xy + zw), 1.0 - s * (xx + zz), s * (yz - xw),
            s * (xz - yw), s * (yz + xw), 1.0 - s * (xx + yy))


@njit(**_NB)
def _jacobi_eigh(S, lam, U):
    """Eigen-decomposition of a small symmetric matrix (cyclic Jacobi): ``S = U diag(lam) U^T``,
    eigenvalues ascending."""
    k = S.shape[0]
    a = S.copy()
    for i in range(k):
        for j in range(k):
            U[i, j] = 1.0 if i == j else 0.0
    for _ in range(50):
        off = 0.0
        for i in range(k):
            for j in range(i + 1, k):
                off += a[i, j] * a[i, j]
        if off <= 1e-30 * (a[0, 0] * a[0, 0] + a[k - 1, k - 1] * a[k - 1, k - 1]) or off == 0.0:
            break
        for p in range(k):
            for r in range(p + 1, k):
                if a[p, r] == 0.0:
                    continue
                th = (a[r, r] - a[p, p]) / (2.0 * a[p, r])
                t = (1.0 if th >= 0.0 else -1.0) / (abs(th) + math.sqrt(th * th + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for i in range(k):           # a <- a G (columns p, r)
                    aip, air = a[i, p], a[i, r]
                    a[i, p] = c * aip - s * air
                    a[i, r] = s * aip + c * air
                for i in range(k):           # a <- G^T a (rows p, r)
                    api, ari = a[p, i], a[r, i]
                    a[p, i] = c * api - s * ari
                    a[r, i] = s * api + c * ari
                for i in range(k):
                    uip, uir = U[i, p], U[i, r]
                    U[i, p] = c * uip - s * uir
                    U[i, r] = s * uip + c * uir
    for i in range(k):
        lam[i] = a[i, i]
    for i in range(1, k):                    # insertion sort, ascending, columns of U along
        j = i
        while j > 0 and lam[j - 1] > lam[j]:
            lam[j - 1], lam[j] = lam[j], lam[j - 1]
            for r in range(k):
                U[r, j - 1], U[r, j] = U[r, j], U[r, j - 1]
            j -= 1


@njit(**_NI)
def _sym3_eigenvalues(a00, a01, a02, a11, a12, a22):
    """Smallest and largest eigenvalue of a symmetric 3x3 matrix, closed form."""
    p1 = a01 * a01 + a02 * a02 + a12 * a12
    qm = (a00 + a11 + a22) / 3.0
    if p1 == 0.0:
        return min(a00, min(a11, a22)), max(a00, max(a11, a22))
    b00, b11, b22 = a00 - qm, a11 - qm, a22 - qm
    p = math.sqrt((b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * p1) / 6.0)
    det = (b00 * (b11 * b22 - a12 * a12) - a01 * (a01 * b22 - a12 * a02)
           + a02 * (a01 * a12 - b11 * a02))
    r = det / (2.0 * p * p * p)
    phi = math.pi / 3.0 if r <= -1.0 else (0.0 if r >= 1.0 else math.acos(r) / 3.0)
    return qm + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0), qm + 2.0 * p * math.cos(phi)


@njit(**_NI)
def ramp_level(t, ramp):
    """Excitation level ``s`` and its derivatives at time ``t`` [s].

    ``ramp = [s0, u, t0, T]``: from ``s0`` at ``t0`` the level moves to ``u`` in ``T`` along
    the quintic ``s = s0 + (u - s0) p(x)``, ``p = 10 x^3 - 15 x^4 + 6 x^5``,
    ``x = (t - t0) / T``, whose first and second derivatives vanish at both ends (a ramp from
    rest starts and ends without a step in the reference accelerations); it stays at ``u``
    afterwards. Returns ``(s, ds/dt, d2s/dt2)``.
    """
    s0, u, t0, T = ramp[0], ramp[1], ramp[2], ramp[3]
    x = (t - t0) / T
    if x >= 1.0:
        return u, 0.0, 0.0
    if x <= 0.0:
        x = 0.0
    d = u - s0
    xm = 1.0 - x
    return (s0 + d * x * x * x * (10.0 + x * (6.0 * x - 15.0)),
            d * 30.0 * x * x * xm * xm / T,
            d * 60.0 * x * xm * (1.0 - 2.0 * x) / (T * T))


@njit(**_NI)
def channel(tab, c, t):
    """Reference channel ``c`` of the excitation table at ``t``: ``(f, f', f'')`` of
    ``f = a/2 [sin(w1 t + p1) + sin(w2 t + p2)]`` (table rows ``(a, w1, p1, w2, p2)``)."""
    a, w1, p1, w2, p2 = tab[c, 0], tab[c, 1], tab[c, 2], tab[c, 3], tab[c, 4]
    s1, c1 = math.sin(w1 * t + p1), math.cos(w1 * t + p1)
    s2, c2 = math.sin(w2 * t + p2), math.cos(w2 * t + p2)
    h = 0.5 * a
    return h * (s1 + s2), h * (w1 * c1 + w2 * c2), -h * (w1 * w1 * s1 + w2 * w2 * s2)


@njit(**_NI)
def channel_trig(tab, c, trig):
    """:func:`channel` from ``trig[c] = [sin(w1 t + p1), cos(w1 t + p1), sin(w2 t + p2),
    cos(w2 t + p2)]`` (:func:`fill_trig`, :func:`rotate_trig`) instead of ``t``."""
    a, w1, w2 = tab[c, 0], tab[c, 1], tab[c, 3]
    s1, c1, s2, c2 = trig[c, 0], trig[c, 1], trig[c, 2], trig[c, 3]
    h = 0.5 * a
    return h * (s1 + s2), h * (w1 * c1 + w2 * c2), -h * (w1 * w1 * s1 + w2 * w2 * s2)


@njit(**_NI)
def fill_trig(tab, t, trig):
    """``trig[c]`` = the sines and cosines of both phases of every channel ``c`` at ``t``
    (:func:`channel_trig`); row ``len(tab)`` holds ``t`` (the time they are for)."""
    m = tab.shape[0]
    for c in range(m):
        a1, a2 = tab[c, 1] * t + tab[c, 2], tab[c, 3] * t + tab[c, 4]
        trig[c, 0], trig[c, 1] = math.sin(a1), math.cos(a1)
        trig[c, 2], trig[c, 3] = math.sin(a2), math.cos(a2)
    trig[m, 0] = t


@njit(**_NI)
def rotate_trig(rot, trig, t):
    """``trig`` (:func:`fill_trig`) advanced by the step ``h`` of ``rot[c] = [cos(w1 h),
    sin(w1 h), cos(w2 h), sin(w2 h)]`` by the angle-addition formulas, now for the time
    ``t``: two products per sine instead of a sine and cosine per phase and step."""
    m = rot.shape[0]
    for c in range(m):
        for j in (0, 2):
            sn, cs, ch, sh = trig[c, j], trig[c, j + 1], rot[c, j], rot[c, j + 1]
            trig[c, j] = sn * ch + cs * sh
            trig[c, j + 1] = cs * ch - sn * sh
    trig[m, 0] = t


@njit(**_NB)
def reference(t, ramp, tab, c):
    """Scaled reference ``s(t) f_c(t)`` of channel ``c`` and its first two time derivatives
    (product rule; ``s`` from :func:`ramp_level`). Callable from Python (tests, docs)."""
    s, ds, dds = ramp_level(t, ramp)
    return _scaled(s, ds, dds, tab, c, t)


@njit(**_NI)
def _scaled(s, ds, dds, tab, c, t):
    """``s f_c(t)`` and its first two time derivatives, for the level ``(s, s', s'')``."""
    f, df, ddf = channel(tab, c, t)
    return _level_times(s, ds, dds, f, df, ddf)


@njit(**_NI)
def _level_times(s, ds, dds, f, df, ddf):
    """``s f`` and its first two time derivatives (product rule)."""
    return s * f, ds * f + s * df, dds * f + 2.0 * ds * df + s * ddf


@njit(**_NI)
def control(planar, q, v, M, nle, hg, par, q_home, t, ramp, tab, gen, acc, FM, cw):
    """Thruster and arm commands at the state ``(q, v)``, held over the next internal step.

    Parameters
    ----------
    planar : bool
    q : (nq,), v : (nv,)     generalised state (Pinocchio convention)
    M : (nv, nv)             joint-space inertia (symmetric), ``nle`` : (nv,) non-linear effects
    hg : (6,)                system momentum ``[P, L_c]`` (inertial; L about the system CoM)
    par : (11,)              controller parameters in the order :data:`PARAMS`
    q_home : (n,)            null-space posture
    t : float                time of the state [s] (the excitation references)
    ramp : (4,)              excitation level ramp ``[s0, u, t0, T]`` (:func:`ramp_level`)
    tab : (r + n, 5)         excitation channels: ``r`` attitude axes (1 planar, 3 spatial),
                             then the joints (:func:`channel`)
    cw : tuple               scratch arrays of :func:`control_work`; its ``trig`` array holds
                             the references' sines where they are for ``t`` (row ``len(tab)``
                             equal to ``t``: :func:`advance` steps them), else they are
                             evaluated here (:func:`fill_trig`)

    With the excitation level and its derivatives all zero, the references are not evaluated
    at all (the law is then exactly the paper's, bit for bit). Otherwise eq. 39 becomes the
    error dynamics about the attitude reference ``e_r``,
    ``alpha_des = e_r'' - K_D (omega - e_r') - K_P (e - e_r)``, and the posture term tracks the
    joint reference ``q_home + q_r``: ``q_r'' - K_Pn (q - q_home - q_r) - K_Dn (qd - q_r')``.

    Writes ``FM`` (6,) = thruster ``[F, M]`` (inertial), ``gen`` (nv,) = ``[f_b, tau]`` (the
    base part is the thrust in base coordinates, the arm part the joint torques) and ``acc``
    (nv,) = the resulting ``dv/dt`` (``M acc + nle = gen`` by construction).
    """
    nv = v.shape[0]
    nb = 3 if planar else 6
    n = nv - nb
    r = 1 if planar else 3               # rotational rows of the base velocity
    r0 = nb - r
    KD, KP, KPn, KDn, qdd_max = par[6], par[7], par[8], par[9], par[10]
    # eq. 41 on the linear momentum, eq. 40 on the angular momentum about the CoM
    for i in range(3):
        FM[i] = bounded_law(hg[i], par[0], par[1], par[2])
        FM[3 + i] = bounded_law(hg[3 + i], par[3], par[4], par[5])
    Lb, sol, Lm, WiGt, GWG, Lg, zz, vec, trig, rot = cw
    e, post, rhs, zv = vec[0, :3], vec[1, :n], vec[2, :r], vec[3, :r]
    # thrust in base coordinates, and the attitude error e (rotation vector; theta_z planar)
    e[0] = e[1] = e[2] = 0.0
    if planar:
        c, s = q[2], q[3]
        k = 1.0 / math.hypot(c, s)
        cs, sn = c * k, s * k
        gen[0] = cs * FM[0] + sn * FM[1]
        gen[1] = -sn * FM[0] + cs * FM[1]
        gen[2] = FM[5]
        e[2] = math.atan2(s, c)
    else:
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = quat_dcm(q[3], q[4], q[5], q[6])
        F0, F1, F2, M0, M1, M2 = FM[0], FM[1], FM[2], FM[3], FM[4], FM[5]
        gen[0] = a00 * F0 + a10 * F1 + a20 * F2                   # A^T F
        gen[1] = a01 * F0 + a11 * F1 + a21 * F2
        gen[2] = a02 * F0 + a12 * F1 + a22 * F2
        gen[3] = a00 * M0 + a10 * M1 + a20 * M2                   # A^T M
        gen[4] = a01 * M0 + a11 * M1 + a21 * M2
        gen[5] = a02 * M0 + a12 * M1 + a22 * M2
        x, y, z, w = q[3], q[4], q[5], q[6]
        if w < 0.0:                      # hemisphere w >= 0
            x, y, z, w = -x, -y, -z, -w
        nvec = math.sqrt(x * x + y * y + z * z)
        kk = 2.0 * math.atan2(nvec, w) / nvec if nvec > 1e-8 * w else 2.0 / w
        e[0], e[1], e[2] = kk * x, kk * y, kk * z
    # base rows: M_bb dv_b + M_bm qdd = f_b - c_b  ->  dv_b = y0 - X qdd
    if not cholesky(M[:nb, :nb], Lb):
        return 1
    for i in range(nb):
        for j in range(n):
            sol[i, j] = M[i, nb + j]
        sol[i, n] = gen[i] - nle[i]
    cho_solve(Lb, sol)                  # [X, y0]
    # attitude rows: G qdd = y0_rot - alpha_des with G = X_rot; W = M_mm weights the solve
    if not cholesky(M[nb:, nb:], Lm):
        return 2
    for i in range(n):
        for j in range(r):
            WiGt[i, j] = sol[r0 + j, i]
    cho_solve(Lm, WiGt)                 # W^-1 G^T
    for i in range(r):
        for j in range(r):
            s = 0.0
            for p in range(n):
                s += sol[r0 + i, p] * WiGt[p, j]
            GWG[i, j] = s
    # posture: -K_Pn (q - q_home) - K_Dn qd
    nq = q.shape[0]
    for i in range(n):
        post[i] = -KPn * (q[nq - n + i] - q_home[i]) - KDn * v[nb + i]
    # rhs_att = y0_rot - alpha_des - G post, alpha_des = -K_D omega - K_P e
    for j in range(r):
        s = sol[r0 + j, n] + KD * v[r0 + j] + KP * e[3 - r + j]
        rhs[j] = s
    lev, dlev, ddlev = ramp_level(t, ramp)
    if lev != 0.0 or dlev != 0.0 or ddlev != 0.0:
        # excitation: posture about q_home + q_r, attitude error about e_r
        if trig.shape[0] != tab.shape[0] + 1:       # work arrays not made for this table
            trig = np.full((tab.shape[0] + 1, 4), np.nan)
        if trig[tab.shape[0], 0] != t:
            fill_trig(tab, t, trig)
        for i in range(n):
            f, df, ddf = channel_trig(tab, r + i, trig)
            qr, dqr, ddqr = _level_times(lev, dlev, ddlev, f, df, ddf)
            post[i] += ddqr + KPn * qr + KDn * dqr
        for j in range(r):
            f, df, ddf = channel_trig(tab, j, trig)
            er, der, dder = _level_times(lev, dlev, ddlev, f, df, ddf)
            rhs[j] -= dder + KD * der + KP * er
    for j in range(r):
        s = rhs[j]
        for p in range(n):
            s -= sol[r0 + j, p] * post[p]
        rhs[j] = s
    # selectively damped inverse of GWG (damped only near a singular coupling)
    if r == 3:
        g00, g01, g02, g11, g12, g22 = GWG[0, 0], GWG[0, 1], GWG[0, 2], GWG[1, 1], GWG[1, 2], \
            GWG[2, 2]
        det = (g00 * (g11 * g22 - g12 * g12) - g01 * (g01 * g22 - g12 * g02)
               + g02 * (g01 * g12 - g11 * g02))
        tr = g00 + g11 + g22
        # positive definite (leading minors > 0) with lo / hi >= 4 det / tr^3 (lo = det /
        # (mid hi), mid hi <= (tr / 2)^2, hi <= tr) twice the threshold: the eigenvalues would
        # choose the undamped branch too, so they are not computed
        plain = (g00 > 0.0 and g00 * g11 - g01 * g01 > 0.0 and det > 0.0
                 and 4.0 * det >= 2.0 * 1.01 * DLS_RATIO * (tr * tr * tr))
        if not plain:
            lo, hi = _sym3_eigenvalues(g00, g01, g02, g11, g12, g22)
            plain = lo / max(hi, 1e-300) >= 1.01 * DLS_RATIO
    else:
        plain = GWG[0, 0] / max(GWG[0, 0], 1e-300) >= 1.01 * DLS_RATIO
    if plain:                            # z = (GWG)^+ rhs
        if not cholesky(GWG, Lg):
            return 3
        for j in range(r):
            zz[j, 0] = rhs[j]
        cho_solve(Lg, zz)
        for j in range(r):
            zv[j] = zz[j, 0]
    else:
        lam = np.empty(r)
        U = np.empty((r, r))
        _jacobi_eigh(GWG, lam, U)
        lmax = max(lam[r - 1], 1e-300)
        for j in range(r):
            zv[j] = 0.0
        for k in range(r):
            rr = max(lam[k] / lmax, 0.0)
            damp = DLS_RATIO * lmax * (1.0 - rr / DLS_RATIO) ** 2 if rr < DLS_RATIO else 0.0
            uk = 0.0
            for j in range(r):
                uk += U[j, k] * rhs[j]
            uk /= lam[k] + damp
            for j in range(r):
                zv[j] += U[j, k] * uk
    # qdd = W^-1 G^T z + post, scaled down (direction kept) to |qdd| <= qdd_max
    peak = 0.0
    for i in range(n):
        s = post[i]
        for j in range(r):
            s += WiGt[i, j] * zv[j]
        acc[nb + i] = s
        if abs(s) > peak:
            peak = abs(s)
    if peak > qdd_max:
        f = qdd_max / peak
        for i in range(n):
            acc[nb + i] *= f
    for i in range(nb):                  # dv_b = y0 - X qdd
        s = sol[i, n]
        for p in range(n):
            s -= sol[i, p] * acc[nb + p]
        acc[i] = s
    for i in range(n):                   # tau = M_m. acc + c_m (arm rows)
        s = nle[nb + i]
        for p in range(nv):
            s += M[nb + i, p] * acc[p]
        gen[nb + i] = s
    return 0


def control_work(planar: bool, nv: int) -> tuple:
    """Scratch arrays of :func:`control` for a robot with ``nv`` velocities (allocated once by
    the plant, so that the kernel allocates nothing per call); the last two: the excitation
    references' sines ``trig`` (:func:`fill_trig`, for no time yet) and their rotation per
    step ``rot`` (:func:`rotate_trig`), for the ``r + n`` channels of
    :meth:`spacerobot.robots.Excitation.channels`."""
    nb = 3 if planar else 6
    n, r = nv - nb, 1 if planar else 3
    trig = np.zeros((r + n + 1, 4))
    trig[r + n, 0] = np.nan
    return (np.empty((nb, nb)), np.empty((nb, n + 1)), np.empty((n, n)), np.empty((n, r)),
            np.empty((r, r)), np.empty((r, r)), np.empty((r, 1)), np.empty((4, max(n, 3))),
            trig, np.empty((r + n, 4)))


#: layout of the propellant array ``pp`` (:func:`.simulator.propellant_array`): 1/(Isp g0)
#: [s/m] (0: no propellant model), 1/arm [1/m], (2/5) R^2 [m2], tank centre r (base frame) [m]
PROP_FIELDS = ("k_flow", "inv_arm", "k_sphere", "rx", "ry", "rz")


@njit(**_NI)
def base_inertia(m_p, pp, I6d, I6u, mcd, I6, mc):
    """Body 0 (the base) of the compiled model with ``m_p`` [kg] of propellant:
    ``I6[0] = I6d + m_p I6u`` (spatial inertias add), mass ``mc[0, 0] = m_d + m_p`` and CoM
    ``b = b_d + (m_p / m)(r - b_d)``. ``I6d``, ``mcd``: the dry base; ``I6u``:
    :func:`.simulator.unit_sphere_inertia`. With ``m_p = 0`` the dry arrays are reproduced
    exactly."""
    for i in range(6):
        for j in range(6):
            I6[0, i, j] = I6d[i, j] + m_p * I6u[i, j]
    m = mcd[0] + m_p
    mc[0, 0] = m
    f = m_p / m
    for i in range(3):
        mc[0, 1 + i] = mcd[1 + i] + f * (pp[3 + i] - mcd[1 + i])


@njit(**_NI)
def mass_flow(FM, pp):
    """Propellant mass flow [kg/s] of the thrust ``FM = [F, M]``:
    ``(|F_x| + |F_y| + |F_z| + (|M_x| + |M_y| + |M_z|) / arm) / (Isp g0)``."""
    return (abs(FM[0]) + abs(FM[1]) + abs(FM[2])
            + (abs(FM[3]) + abs(FM[4]) + abs(FM[5])) * pp[1]) * pp[0]


@njit(**_NI)
def thrust_control(planar, q, v, M, nle, hg, par, q_home, t, ramp, tab, gen, acc, FM, pp, m_p,
                   dt, parw, cw):
    """:func:`control` limited by the propellant ``m_p`` [kg] available for a step of ``dt``.

    Writes ``FM[6]`` = the mass flow of the thrust applied [kg/s] (0 without propellant model,
    ``pp[0] = 0``). When the flow would need more than ``m_p`` in ``dt``, the thrust is scaled
    by ``s = m_p / (flow dt)`` (the tank empties at the end of the step; ``s = 0`` once empty):
    :func:`control` runs again with the gains and bounds of the two thruster laws scaled by
    ``s`` (``bounded_law`` is then ``s`` times the unscaled one), so that the accelerations
    and joint torques are those of the scaled thrust. ``parw`` (11,) scratch, ``cw``: as in
    :func:`control`.
    """
    pw = par
    flow = 0.0
    for attempt in range(2):             # one call site of control (it is inlined here)
        err = control(planar, q, v, M, nle, hg, pw, q_home, t, ramp, tab, gen, acc, FM, cw)
        if attempt == 0 and (err or pp[0] == 0.0):
            FM[6] = 0.0
            return err
        flow = mass_flow(FM, pp)
        need = flow * dt
        if attempt == 1 or need <= m_p:
            break
        s = max(m_p, 0.0) / need
        for i in range(par.shape[0]):
            parw[i] = par[i]
        for i in (0, 2, 3, 5):           # K_F, F_max, K_M, M_max
            parw[i] *= s
        pw = parw
    FM[6] = flow
    return err


@njit(**_NI)
def _propellant_rates(planar, xa, flow, pp, ov, nv, row):
    """Rows ``[dm_p, dP_x (3), dL_x (3)]`` of the state derivative at the stage state ``xa``
    (after ``J, H, q, v``), for the mass flow ``flow`` [kg/s] (see :func:`stage`)."""
    o = ov + nv
    row[o] = -flow                       # dm_p/dt
    if flow == 0.0:
        for j in range(1, 7):
            row[o + j] = 0.0
        return
    oq = 6
    rtx, rty, rtz = pp[3], pp[4], pp[5]
    if planar:
        c, s = xa[oq + 2], xa[oq + 3]
        k = 1.0 / math.hypot(c, s)
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = c * k, -s * k, 0.0, s * k, c * k, 0.0, \
            0.0, 0.0, 1.0
        rx, ry, rz = xa[oq], xa[oq + 1], 0.0
        vx, vy, vz, wx, wy, wz = xa[ov], xa[ov + 1], 0.0, 0.0, 0.0, xa[ov + 2]
    else:
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = quat_dcm(xa[oq + 3], xa[oq + 4],
                                                               xa[oq + 5], xa[oq + 6])
        rx, ry, rz = xa[oq], xa[oq + 1], xa[oq + 2]
        vx, vy, vz, wx, wy, wz = (xa[ov], xa[ov + 1], xa[ov + 2], xa[ov + 3], xa[ov + 4],
                                  xa[ov + 5])
    # tank centre velocity, base frame: u = v_l + omega_B x r_t; inertial v_c = A u
    ux = vx + (wy * rtz - wz * rty)
    uy = vy + (wz * rtx - wx * rtz)
    uz = vz + (wx * rty - wy * rtx)
    vcx = a00 * ux + a01 * uy + a02 * uz
    vcy = a10 * ux + a11 * uy + a12 * uz
    vcz = a20 * ux + a21 * uy + a22 * uz
    # tank centre r_c = r_S + A r_t; omega_I = A omega_B
    cx = rx + a00 * rtx + a01 * rty + a02 * rtz
    cy = ry + a10 * rtx + a11 * rty + a12 * rtz
    cz = rz + a20 * rtx + a21 * rty + a22 * rtz
    k2 = pp[2]
    wix = a00 * wx + a01 * wy + a02 * wz
    wiy = a10 * wx + a11 * wy + a12 * wz
    wiz = a20 * wx + a21 * wy + a22 * wz
    row[o + 1] = flow * vcx              # dP_x = flow v_c
    row[o + 2] = flow * vcy
    row[o + 3] = flow * vcz
    row[o + 4] = flow * (cy * vcz - cz * vcy + k2 * wix)   # dL_x = flow (r_c x v_c + k2 w_I)
    row[o + 5] = flow * (cz * vcx - cx * vcz + k2 * wiy)
    row[o + 6] = flow * (cx * vcy - cy * vcx + k2 * wiz)


@njit(**_NI)
def stage(planar, i, x, xa, a, K, FM, dt, xs, qn, vs, gen, xn, pp):
    """RK4 stage ``i`` (0..3) of a step of length ``dt`` from ``x``.

    ``xa`` is the stage state at which ``a`` (= dv/dt) was evaluated (``x`` itself for stage
    0; it may be ``xs``). Writes row ``i`` of ``K`` (the state derivative there). For ``i < 3`` it then
    forms the next stage state in ``xs`` and, for Pinocchio, its normalised configuration
    ``qn``, velocity ``vs`` and the held thrust in the base coordinates of that stage in
    ``gen[:nb]`` (the joint torques in ``gen[nb:]`` are held). For ``i = 3`` it writes the new
    state into ``xn`` (unit quaternion / (cos, sin) restored) and ``qn``, ``vs`` of it.

    State layout: ``x = [J (3), H (3), q (nq), v (nv), m_p, P_x (3), L_x (3)]``: the
    propellant mass and the momentum the expelled propellant carried away (inertial, about
    the inertial origin): it leaves the tank with the tank's rigid motion, so
    ``dP_x = flow v_c``, ``dL_x = flow (r_c x v_c + (2/5) R^2 omega)`` (``r_c``, ``v_c``:
    tank centre; ``flow = FM[6]``, ``pp``: :data:`PROP_FIELDS`).
    """
    nq = qn.shape[0]
    nv = vs.shape[0]
    oq, ov = 6, 6 + nq
    nb = 3 if planar else 6
    row = K[i]
    F0, F1, F2, M0, M1, M2 = FM[0], FM[1], FM[2], FM[3], FM[4], FM[5]
    # [dJ = F, dH = M + r_S x F, dq/dt of the root joint]
    row[0], row[1], row[2] = F0, F1, F2
    if planar:
        px, py, c, s = xa[oq], xa[oq + 1], xa[oq + 2], xa[oq + 3]
        vx, vy, wz = xa[ov], xa[ov + 1], xa[ov + 2]
        k = 1.0 / math.hypot(c, s)
        cn, sn = c * k, s * k
        row[3] = M0 + py * F2
        row[4] = M1 - px * F2
        row[5] = M2 + (px * F1 - py * F0)
        row[6] = cn * vx - sn * vy
        row[7] = sn * vx + cn * vy
        row[8] = -s * wz
        row[9] = c * wz
        nsc = 10
    else:
        rx, ry, rz = xa[oq], xa[oq + 1], xa[oq + 2]
        x_, y_, z_, w_ = xa[oq + 3], xa[oq + 4], xa[oq + 5], xa[oq + 6]
        vx, vy, vz, wx, wy, wz = (xa[ov], xa[ov + 1], xa[ov + 2], xa[ov + 3], xa[ov + 4],
                                  xa[ov + 5])
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = quat_dcm(x_, y_, z_, w_)
        row[3] = M0 + (ry * F2 - rz * F1)
        row[4] = M1 + (rz * F0 - rx * F2)
        row[5] = M2 + (rx * F1 - ry * F0)
        row[6] = a00 * vx + a01 * vy + a02 * vz                    # dr_S/dt = A v_l
        row[7] = a10 * vx + a11 * vy + a12 * vz
        row[8] = a20 * vx + a21 * vy + a22 * vz
        row[9] = 0.5 * (w_ * wx + y_ * wz - z_ * wy)
        row[10] = 0.5 * (w_ * wy + z_ * wx - x_ * wz)
        row[11] = 0.5 * (w_ * wz + x_ * wy - y_ * wx)
        row[12] = -0.5 * (x_ * wx + y_ * wy + z_ * wz)
        nsc = 13
    for j in range(nsc, ov):             # dq_arm/dt = qd
        row[j] = xa[ov + nb + j - nsc]
    for j in range(nv):                  # dv/dt
        row[ov + j] = a[j]
    _propellant_rates(planar, xa, FM[6], pp, ov, nv, row)
    nx = x.shape[0]
    if i < 3:
        f = dt if i == 2 else 0.5 * dt
        for j in range(nx):
            xs[j] = x[j] + f * row[j]
        target = xs
    else:
        f = dt / 6.0
        for j in range(nx):
            xn[j] = x[j] + f * (K[0, j] + 2.0 * K[1, j] + 2.0 * K[2, j] + K[3, j])
        target = xn
    # normalised configuration of the new state (and the unit constraint for x_{n+1})
    for j in range(nq):
        qn[j] = target[oq + j]
    for j in range(nv):
        vs[j] = target[ov + j]
    if planar:
        c, s = target[oq + 2], target[oq + 3]
        nrm = math.sqrt(c * c + s * s)
        qn[2], qn[3] = c / nrm, s / nrm
        if i == 3:
            xn[oq + 2], xn[oq + 3] = qn[2], qn[3]
        else:
            k = 1.0 / math.hypot(c, s)
            cn, sn = c * k, s * k
            gen[0] = cn * F0 + sn * F1
            gen[1] = -sn * F0 + cn * F1
            gen[2] = M2
    else:
        x_, y_, z_, w_ = target[oq + 3], target[oq + 4], target[oq + 5], target[oq + 6]
        nrm = math.sqrt(x_ * x_ + y_ * y_ + z_ * z_ + w_ * w_)
        qn[3], qn[4], qn[5], qn[6] = x_ / nrm, y_ / nrm, z_ / nrm, w_ / nrm
        if i == 3:
            for j in range(4):
                xn[oq + 3 + j] = qn[3 + j]
        else:
            a00, a01, a02, a10, a11, a12, a20, a21, a22 = quat_dcm(x_, y_, z_, w_)
            gen[0] = a00 * F0 + a10 * F1 + a20 * F2
            gen[1] = a01 * F0 + a11 * F1 + a21 * F2
            gen[2] = a02 * F0 + a12 * F1 + a22 * F2
            gen[3] = a00 * M0 + a10 * M1 + a20 * M2
            gen[4] = a01 * M0 + a11 * M1 + a21 * M2
            gen[5] = a02 * M0 + a12 * M1 + a22 * M2
    return 0


@njit(**_NI)
def load(planar, x, qn, vs):
    """Configuration (unit quaternion / (cos, sin) pair) and velocity of the state ``x`` into
    the Pinocchio buffers ``qn``, ``vs``."""
    nq = qn.shape[0]
    for j in range(nq):
        qn[j] = x[6 + j]
    for j in range(vs.shape[0]):
        vs[j] = x[6 + nq + j]
    if planar:
        nrm = math.sqrt(qn[2] * qn[2] + qn[3] * qn[3])
        qn[2] /= nrm
        qn[3] /= nrm
    else:
        nrm = math.sqrt(qn[3] * qn[3] + qn[4] * qn[4] + qn[5] * qn[5] + qn[6] * qn[6])
        for j in range(3, 7):
            qn[j] /= nrm
    return 0


@njit(**_NB)
def advance(planar, mdl, ws, cw, x, n_steps, h, rest, t, par, q_home, ramp, tab, prop, K, xs, qn,
            vs, gen, acc, FM, M, nle, hg, ddq, xa, xout):
    """``n_steps`` RK4 steps of length ``h``, then one of length ``rest`` if ``rest > 0``, from
    the state ``x`` at time ``t``: the plant's whole communication step in one call.

    Each step holds the controls of its start (zero-order hold): the rigid-body terms
    (:func:`.rigid_body.terms`: ``M``, non-linear effects, centroidal momentum) feed
    :func:`control`, whose accelerations are the first stage's; stages 2-4 call
    :func:`.rigid_body.aba` on the stage state :func:`stage` prepared. With the excitation
    on, the references' sines are evaluated at the call's first step and every
    :data:`TRIG_ANCHOR` steps, and rotated by ``h`` (:func:`rotate_trig`) at the steps between
    (they differ from a fresh evaluation by a few units in the last place; a run gives the
    same results for the same sequence of calls).

    Parameters
    ----------
    planar : bool
    mdl : tuple ``(R, p, I6, mc)`` of :func:`.rigid_body.chain_arrays`
    ws : tuple, the work arrays of :class:`.rigid_body.Workspace`
    cw : tuple, the scratch arrays of :func:`control_work`
    x : (nx,) state ``[J, H, q, v, m_p, P_x, L_x]`` (:func:`stage`); ``qn``, ``vs`` must hold
    its normalised configuration and velocity (:func:`load`)
    par, q_home, ramp, tab : as in :func:`control`
    prop : tuple ``(pp, I6d, I6u, mcd, parw)``: the propellant (:data:`PROP_FIELDS`; the model
    is off when ``pp[0] = 0``), the dry base's ``I6[0]`` and ``mc[0]``,
    :func:`.simulator.unit_sphere_inertia` and a scratch copy of ``par``; with the model on,
    body 0 of ``mdl`` follows the propellant mass of each stage state (:func:`base_inertia`)
    K, xs, qn, vs, gen, acc, FM, M, nle, hg, ddq, xa : work arrays (the plant's buffers; on
    return ``qn``, ``vs`` hold the configuration of the state reached)
    xout : (nx,) the state reached

    Returns ``(status, t_reached)``: status 0, or the code (:data:`ERRORS`) of the step that
    could not be taken; ``xout`` and ``t_reached`` are then the state and time at its start.
    """
    R, p, I6, mc = mdl
    bp, S, cb, IA, pA, U, Du, M6, v6 = ws
    pp, I6d, I6u, mcd, parw = prop
    trig, rot = cw[8], cw[9]
    nx = x.shape[0]
    om = 6 + qn.shape[0] + vs.shape[0]   # m_p in the state
    on = pp[0] != 0.0
    for j in range(nx):
        xa[j] = x[j]
    # the excitation references' sines: evaluated at the call's start and every TRIG_ANCHOR
    # steps, rotated by h in between (the results depend only on the state and the call)
    m, mt = tab.shape[0], trig.shape[0] - 1       # the channels; the row of trig's time
    trig[mt, 0] = np.nan
    excited = ((ramp[0] != 0.0 or ramp[1] != 0.0) and trig.shape[0] == m + 1
               and rot.shape[0] == m)
    if excited:
        for c in range(m):
            rot[c, 0], rot[c, 1] = math.cos(tab[c, 1] * h), math.sin(tab[c, 1] * h)
            rot[c, 2], rot[c, 3] = math.cos(tab[c, 3] * h), math.sin(tab[c, 3] * h)
    total = n_steps + (1 if rest > 0.0 else 0)
    for k in range(total):
        dt = h if k < n_steps else rest
        if on:
            base_inertia(xa[om], pp, I6d, I6u, mcd, I6, mc)
        terms(planar, R, p, I6, mc, qn, vs, M, nle, hg, bp, S, cb, IA, pA, U, Du, M6, v6)
        err = thrust_control(planar, qn, vs, M, nle, hg, par, q_home, t, ramp, tab, gen, acc, FM,
                             pp, xa[om], dt, parw, cw)
        if err:
            trig[mt, 0] = np.nan
            for j in range(nx):
                xout[j] = xa[j]
            return err, t
        stage(planar, 0, xa, xa, acc, K, FM, dt, xs, qn, vs, gen, xout, pp)
        for i in range(1, 4):
            if on:
                base_inertia(xs[om], pp, I6d, I6u, mcd, I6, mc)
            if aba(planar, R, p, I6, qn, vs, gen, ddq, bp, S, cb, IA, pA, U, Du, M6, v6):
                trig[mt, 0] = np.nan
                for j in range(nx):
                    xout[j] = xa[j]
                load(planar, xa, qn, vs)
                return 4, t
            stage(planar, i, xa, xs, ddq, K, FM, dt, xs, qn, vs, gen, xout, pp)
        for j in range(nx):            # the stage kernel left xout's configuration in qn, vs
            xa[j] = xout[j]
        t_prev = t
        t += dt
        # the next step's sines from this step's (where the control evaluated them at t_prev)
        if excited and trig[mt, 0] == t_prev and dt == h and (k + 1) % TRIG_ANCHOR != 0:
            rotate_trig(rot, trig, t)
        else:
            trig[mt, 0] = np.nan
    trig[mt, 0] = np.nan                 # outside this call the sines are evaluated afresh
    for j in range(nx):
        xout[j] = xa[j]
    return 0, t


@njit(**_NB)
def advance_measured(planar, mdl, ws, cw, x, n_steps, h, rest, t, par, q_home, ramp, tab, prop, K,
                     xs, qn, vs, gen, acc, FM, M, nle, hg, ddq, xa, xout, h_ctrl, dry, y):
    """:func:`advance`, then, where it succeeded, :func:`measure` at the state reached (its
    outputs ``y`` and the controls held from there for a step of ``h_ctrl``), in one call: what
    a co-simulation step needs, with one entry into compiled code instead of two.

    Returns ``(status, t_reached, measured, finite)``: :func:`advance`'s status and time;
    ``measured`` :func:`measure`'s return (0: ``y`` and the control buffers hold the state
    reached; -1: not called); ``finite`` whether every entry of ``xout`` is finite.
    """
    err, t1 = advance(planar, mdl, ws, cw, x, n_steps, h, rest, t, par, q_home, ramp, tab, prop,
                      K, xs, qn, vs, gen, acc, FM, M, nle, hg, ddq, xa, xout)
    finite = True
    for j in range(xout.shape[0]):
        if not math.isfinite(xout[j]):
            finite = False
    if err:
        return err, t1, -1, finite
    return 0, t1, measure(planar, mdl, ws, cw, xout, t1, h_ctrl, par, q_home, ramp, tab, prop,
                          dry, qn, vs, gen, acc, FM, M, nle, hg, y), finite


def output_layout(n: int) -> tuple:
    """``(name, shape)`` of every plant output in the order :func:`measure` writes them into its
    flat output vector, for a robot with ``n`` joints (keys of ``Plant.outputs``)."""
    return (("r_S", (3,)), ("v_S", (3,)), ("A", (3, 3)), ("omega_B", (3,)), ("a_S", (3,)),
            ("alpha_B", (3,)), ("q", (n,)), ("qd", (n,)), ("qdd", (n,)), ("F", (3,)),
            ("M", (3,)), ("J", (3,)), ("H", (3,)), ("P", (3,)), ("L", (3,)), ("tau", (n,)),
            ("excite_level", (1,)), ("att_ref", (3,)), ("qd_ref", (n,)), ("m_p", (1,)),
            ("P_x", (3,)), ("L_x", (3,)), ("base_now", (10,)))


@njit(**_NB)
def measure(planar, mdl, ws, cw, x, t, h, par, q_home, ramp, tab, prop, dry, qn, vs, gen, acc,
            FM, M, nle, hg, y):
    """The controls at the state ``x`` (time ``t``) for the next internal step of ``h`` (as
    :func:`advance` computes them) and every output of the plant there, in one call.

    Writes the control buffers ``gen``, ``acc``, ``FM`` (:func:`thrust_control`), ``M``,
    ``nle``, ``hg`` (:func:`.rigid_body.terms`), ``qn``, ``vs`` (:func:`load`) and the output
    vector ``y`` in the order of :func:`output_layout`: base position ``r_S``, velocity
    ``v_S = A v_l`` (inertial), DCM ``A`` (row-major), ``omega_B``, the classical acceleration
    of S ``a_S = A (dv_l/dt + omega_B x v_l)`` (inertial), ``alpha_B``; ``q``, ``qd``, ``qdd``
    of the arm; thrust ``F``, ``M`` and impulses ``J``, ``H``; the system momentum ``P`` and
    ``L`` about the inertial origin (``L_c + c x P``); joint torques; the excitation level and
    references (``att_ref`` (3,), ``qd_ref`` (n,); zero when no excitation was asked for);
    the propellant ``m_p``, ``P_x``, ``L_x``; the base's current truth ``[m, b, Ixx, Iyy, Izz,
    Ixy, Ixz, Iyz]`` (the dry base ``dry`` (10,) plus the propellant left, by
    ``spacerobot.robots.Propellant.base``'s parallel-axis formula).
    ``mdl``, ``ws``, ``cw``, ``par``, ``q_home``, ``ramp``, ``tab``, ``prop``: as in
    :func:`advance`. Returns 0 or the code (:data:`ERRORS`) of a singular matrix.
    """
    R, p, I6, mc = mdl
    bp, S, cb, IA, pA, U, Du, M6, v6 = ws
    pp, I6d, I6u, mcd, parw = prop
    nq, nv = qn.shape[0], vs.shape[0]
    nb = 3 if planar else 6
    n = nv - nb
    om = 6 + nq + nv
    m_p = x[om]
    load(planar, x, qn, vs)
    if pp[0] != 0.0:
        base_inertia(m_p, pp, I6d, I6u, mcd, I6, mc)
    c0, c1, c2 = terms(planar, R, p, I6, mc, qn, vs, M, nle, hg, bp, S, cb, IA, pA, U, Du, M6,
                       v6)
    cw[8][cw[8].shape[0] - 1, 0] = np.nan   # the references' sines evaluated afresh at t
    err = thrust_control(planar, qn, vs, M, nle, hg, par, q_home, t, ramp, tab, gen, acc, FM, pp,
                         m_p, h, parw, cw)
    if err:
        return err
    q, v = x[6:6 + nq], x[6 + nq:om]
    # base pose and motion: A, v_l, omega_B, dv_l/dt, alpha_B (planar: in the plane)
    if planar:
        c, s = q[2], q[3]
        k = 1.0 / math.hypot(c, s)
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = c * k, -s * k, 0.0, s * k, c * k, 0.0, \
            0.0, 0.0, 1.0
        r0, r1, r2 = q[0], q[1], 0.0
        vl0, vl1, vl2, w0, w1, w2 = v[0], v[1], 0.0, 0.0, 0.0, v[2]
        dl0, dl1, dl2, al0, al1, al2 = acc[0], acc[1], 0.0, 0.0, 0.0, acc[2]
    else:
        a00, a01, a02, a10, a11, a12, a20, a21, a22 = quat_dcm(q[3], q[4], q[5], q[6])
        r0, r1, r2 = q[0], q[1], q[2]
        vl0, vl1, vl2, w0, w1, w2 = v[0], v[1], v[2], v[3], v[4], v[5]
        dl0, dl1, dl2, al0, al1, al2 = acc[0], acc[1], acc[2], acc[3], acc[4], acc[5]
    # classical acceleration of S in base axes: dv_l/dt + omega x v_l
    e0 = dl0 + (w1 * vl2 - w2 * vl1)
    e1 = dl1 + (w2 * vl0 - w0 * vl2)
    e2 = dl2 + (w0 * vl1 - w1 * vl0)
    y[0], y[1], y[2] = r0, r1, r2
    y[3] = a00 * vl0 + a01 * vl1 + a02 * vl2
    y[4] = a10 * vl0 + a11 * vl1 + a12 * vl2
    y[5] = a20 * vl0 + a21 * vl1 + a22 * vl2
    y[6], y[7], y[8], y[9], y[10], y[11], y[12], y[13], y[14] = (a00, a01, a02, a10, a11, a12,
                                                                 a20, a21, a22)
    y[15], y[16], y[17] = w0, w1, w2
    y[18] = a00 * e0 + a01 * e1 + a02 * e2
    y[19] = a10 * e0 + a11 * e1 + a12 * e2
    y[20] = a20 * e0 + a21 * e1 + a22 * e2
    y[21], y[22], y[23] = al0, al1, al2
    o = 24
    for i in range(n):
        y[o + i] = q[nq - n + i]
        y[o + n + i] = v[nb + i]
        y[o + 2 * n + i] = acc[nb + i]
    o += 3 * n
    for i in range(6):                   # F, M, J, H
        y[o + i] = FM[i]
        y[o + 6 + i] = x[i]
    o += 12
    # P and L about the inertial origin: L_c + c x P
    P0, P1, P2 = hg[0], hg[1], hg[2]
    y[o], y[o + 1], y[o + 2] = P0, P1, P2
    y[o + 3] = hg[3] + (c1 * P2 - c2 * P1)
    y[o + 4] = hg[4] + (c2 * P0 - c0 * P2)
    y[o + 5] = hg[5] + (c0 * P1 - c1 * P0)
    o += 6
    for i in range(n):
        y[o + i] = gen[nb + i]
    o += n
    lev = ramp_level(t, ramp)[0]
    y[o] = lev
    o += 1
    r = 1 if planar else 3
    for i in range(3 + n):               # att_ref (3,), qd_ref (n,)
        y[o + i] = 0.0
    if ramp[0] != 0.0 or ramp[1] != 0.0:
        s, ds, dds = ramp_level(t, ramp)
        for j in range(r):
            y[o + 3 - r + j] = _scaled(s, ds, dds, tab, j, t)[0]
        for i in range(n):
            y[o + 3 + i] = _scaled(s, ds, dds, tab, r + i, t)[1]
    o += 3 + n
    for i in range(7):                   # m_p, P_x, L_x
        y[o + i] = x[om + i]
    o += 7
    _base_now(dry, pp, m_p, y[o:o + 10])
    return 0


@njit(**_NB)
def _base_now(dry, pp, m_p, out):
    """``[m, b, Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`` of the base with ``m_p`` of propellant
    (``spacerobot.robots.Propellant.base``): ``m = m_d + m_p``, ``b = b_d + (m_p / m)(r - b_d)``,
    ``I = I_d + m_d S(b_d - b) + (2/5) m_p R^2 1 + m_p S(r - b)``, ``S(d) = |d|^2 1 - d d^T``;
    the dry base ``dry`` itself without propellant model (``pp[0] = 0``)."""
    for i in range(10):
        out[i] = dry[i]
    if pp[0] == 0.0:
        return
    md = dry[0]
    m = md + m_p
    f = m_p / m
    b0 = dry[1] + f * (pp[3] - dry[1])
    b1 = dry[2] + f * (pp[4] - dry[2])
    b2 = dry[3] + f * (pp[5] - dry[3])
    d0, d1, d2 = dry[1] - b0, dry[2] - b1, dry[3] - b2
    e0, e1, e2 = pp[3] - b0, pp[4] - b1, pp[5] - b2
    dd = d0 * d0 + d1 * d1 + d2 * d2
    ee = e0 * e0 + e1 * e1 + e2 * e2
    out[0], out[1], out[2], out[3] = m, b0, b1, b2
    out[4] = dry[4] + md * (dd - d0 * d0) + m_p * ((pp[2] + ee) - e0 * e0)
    out[5] = dry[5] + md * (dd - d1 * d1) + m_p * ((pp[2] + ee) - e1 * e1)
    out[6] = dry[6] + md * (dd - d2 * d2) + m_p * ((pp[2] + ee) - e2 * e2)
    out[7] = dry[7] + md * (-d0 * d1) + m_p * (-e0 * e1)
    out[8] = dry[8] + md * (-d0 * d2) + m_p * (-e0 * e2)
    out[9] = dry[9] + md * (-d1 * d2) + m_p * (-e1 * e2)
