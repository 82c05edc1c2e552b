"""Controllers inside the plant.

* Base thrusters: the bounded momentum law of the paper (eqs. 40-41), per inertial axis.
* Arm: joint torques that make the base attitude follow ``e'' + K_D e' + K_P e = 0`` (eq. 39)
  through the free-floating coupling, with a null-space posture term.

Both are evaluated once per internal step ``h`` and held over it (zero-order hold, a 1/h Hz
digital controller), so the RK4 right-hand side is smooth inside every step and the impulse of
the thrust over a step is exactly ``h F``.

Performance: the controller runs once per internal step, so :class:`ArmController` keeps its
work buffers, calls LAPACK directly for the tiny solves and handles the 1x1 (planar) and the
well-conditioned 3x3 (spatial) attitude couplings without an eigen-decomposition (the damped
eigen-decomposition is used only when a direction is actually damped; results agree with it
to rounding).
"""
from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
from scipy.linalg import lapack

from ..robots import Controller
from .dynamics import PlantModel

#: eigenvalue ratio below which the attitude solve is damped (singularity robustness)
DLS_RATIO = 1e-2

_dgesv = lapack.dgesv


def bounded_law(x: float, K: float, x_max: float, u_max: float) -> float:
    """Paper eqs. 40/41 for one axis.

    ``u = K x`` inside the band ``|x| < x_max`` (saturated at ``u_max``), and
    ``u = sign(K x) u_max`` outside it. With the paper's gains (|K| x_max = u_max) this is
    exactly the printed law; with a lowered ``u_max`` (e.g. F_max = 0.1 N) it keeps |u| <= u_max.
    Plain floats (it runs once per axis and internal step); NaN passes through.
    """
    kx = K * x
    if abs(x) >= x_max:
        return u_max if kx > 0.0 else (-u_max if kx < 0.0 else 0.0 * u_max)
    if kx < -u_max:
        return -u_max
    if kx > u_max:
        return u_max
    return kx


def thruster_scalars(hg, c: Controller):
    """Thruster force at S and torque, inertial frame, from the system momentum.

    Parameters
    ----------
    hg : 6 floats ``[P, L_c]``: total linear momentum [kg.m/s] and total angular momentum
         about the system centre of mass [kg.m2/s]. The centre of mass is used (not the
         inertial origin) so that the torque damps the spin of the system and does not react
         to its translation (r_c x P).

    Returns
    -------
    ``[F (3), M (3)]`` as 6 floats [N, N.m]
    """
    P0, P1, P2, L0, L1, L2 = hg
    return [bounded_law(P0, c.K_F, c.P_max, c.F_max),   # eq. 41
            bounded_law(P1, c.K_F, c.P_max, c.F_max),
            bounded_law(P2, c.K_F, c.P_max, c.F_max),
            bounded_law(L0, c.K_M, c.L_max, c.M_max),   # eq. 40
            bounded_law(L1, c.K_M, c.L_max, c.M_max),
            bounded_law(L2, c.K_M, c.L_max, c.M_max)]


def _sym3_eigenvalues(a00, a01, a02, a11, a12, a22):
    """Eigenvalues (ascending) of a symmetric 3x3 matrix, closed form (trigonometric)."""
    p1 = a01 * a01 + a02 * a02 + a12 * a12
    qm = (a00 + a11 + a22) / 3.0
    if p1 == 0.0:
        return sorted((a00, a11, a22))
    b00, b11, b22 = a00 - qm, a11 - qm, a22 - qm
    p2 = b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * p1
    p = math.sqrt(p2 / 6.0)
    det = (b00 * (b11 * b22 - a12 * a12) - a01 * (a01 * b22 - a12 * a02)
           + a02 * (a01 * a12 - b11 * a02))
    r = det / (2.0 * p * p * p)
    phi = math.pi / 3.0 if r <= -1.0 else (0.0 if r >= 1.0 else math.acos(r) / 3.0)
    e_hi = qm + 2.0 * p * math.cos(phi)
    e_lo = qm + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    return e_lo, 3.0 * qm - e_lo - e_hi, e_hi


def attitude_error_fast(planar: bool, q) -> tuple:
    """Base attitude of eq. 39 as a 3-tuple of floats (rotation vector; theta_z planar).

    Spatial: from the quaternion (``2 atan2(|v|, w) v / |v|`` on the hemisphere ``w >= 0``),
    equal to ``pin.log3`` of the DCM up to rounding.
    """
    if planar:
        c, s = q[2:4].tolist()
        return 0.0, 0.0, math.atan2(s, c)
    x, y, z, w = q[3:7].tolist()
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    nv = math.sqrt(x * x + y * y + z * z)
    if nv > 1e-8 * w:
        k = 2.0 * math.atan2(nv, w) / nv
    else:  # |angle| < ~2e-8 rad: atan2(nv, w) / nv = 1/w (1 - (nv/w)^2/3 + ...)
        k = 2.0 / w
    return k * x, k * y, k * z


class ArmController:
    """The attitude law (eq. 39) by inverse dynamics, with preallocated work space.

    Base rows of the dynamics, ``M_bb dv_b + M_bm qdd = f_b - c_b``, give the base acceleration
    for any joint acceleration: ``dv_b = y0 - X qdd`` with ``X = M_bb^-1 M_bm``,
    ``y0 = M_bb^-1 (f_b - c_b)``. Asking its angular rows to equal
    ``alpha_des = -K_D omega_B - K_P e`` is ``G qdd = y0_rot - alpha_des`` (``G = X_rot``),
    solved by an inertia-weighted, slightly damped right pseudo-inverse; the null space carries
    a posture term ``-K_Dn qd - K_Pn (q - q_home)``. Commanded accelerations are scaled down to
    ``|qdd| <= qdd_max``; then the base follows eq. 39 only approximately (this happens in the
    spatial scenario, whose initial angular momentum is more than the arm can store while
    holding the base). The torques follow from the arm rows.
    """

    def __init__(self, pm: PlantModel, c: Controller, q_home):
        self.pm = pm
        self.model = pm.model
        self.c = c
        self.q_home = np.array(q_home, float)
        nb, n = pm.nb, pm.n
        self.nb, self.n = nb, n
        self.rows = pm.rot_rows
        self.rhs = np.empty((nb, n + 1), order="F")
        self.acc = np.empty(nb + n)
        # posture term -K_Dn qd - K_Pn (q - q_home) = Wq q + Wv v + K_Pn q_home
        self.Wq = np.zeros((n, pm.model.nq))
        self.Wq[:, -n:] = -float(c.K_Pn) * np.eye(n)
        self.Wv = np.zeros((n, pm.model.nv))
        self.Wv[:, nb:] = -float(c.K_Dn) * np.eye(n)
        self.p0 = float(c.K_Pn) * self.q_home

    def command(self, data: pin.Data, q: np.ndarray, v: np.ndarray, f_base):
        """Joint torques for the attitude law.

        Parameters
        ----------
        data : pin.Data;  q, v : generalised state;  f_base : (nb,) base generalised force

        Returns
        -------
        tau : (n,) joint torques [N.m];  qdd : (n,) joint accelerations;  dv_b : (nb,) base
        accel.;  acc : (nb + n,) = [dv_b, qdd] (a work buffer, overwritten by the next call)
        """
        nb, n, c = self.nb, self.n, self.c
        model = self.model
        M = pin.crba(model, data, q)
        h = pin.nonLinearEffects(model, data, q, v)
        rhs = self.rhs
        rhs[:, :n] = M[:nb, nb:]
        np.subtract(f_base, h[:nb], out=rhs[:, n])
        _, _, sol, info = _dgesv(M[:nb, :nb], rhs)
        if info != 0:
            raise np.linalg.LinAlgError("singular base inertia")
        X, y0 = sol[:, :n], sol[:, n]
        e = attitude_error_fast(self.pm.planar, q)
        G = X[self.rows]
        _, _, WiGt, info = _dgesv(M[nb:, nb:], G.T)
        if info != 0:
            raise np.linalg.LinAlgError("singular arm inertia")
        GWG = G.dot(WiGt)
        post = self.Wq.dot(q)
        post += self.Wv.dot(v)
        post += self.p0
        if nb == 3:
            # planar: one rotational row, GWG is 1x1 (its eigenvector is 1)
            g = GWG.tolist()[0][0]
            lmax = max(g, 1e-300)
            r = max(g / lmax, 0.0)
            damp = DLS_RATIO * lmax * (1.0 - r / DLS_RATIO) ** 2 if r < DLS_RATIO else 0.0
            w = v[2:3].tolist()[0]
            alpha_des = -c.K_D * w - c.K_P * e[2]
            rhs_att = y0[2:3].tolist()[0] - alpha_des - G.dot(post).tolist()[0]
            qdd = WiGt[:, 0] * (rhs_att / (g + damp))
        else:
            g00, g01, g02, _, g11, g12, _, _, g22 = GWG.ravel().tolist()
            lam = _sym3_eigenvalues(g00, g01, g02, g11, g12, g22)
            lmax = max(lam[2], 1e-300)
            if lam[0] / lmax >= 1.01 * DLS_RATIO:
                # no direction damped: Gp = WiGt GWG^-1 (GWG symmetric)
                _, _, GpT, info = _dgesv(GWG, WiGt.T)
                if info != 0:
                    raise np.linalg.LinAlgError("singular attitude coupling")
                Gp = GpT.T
            else:
                lam, U = np.linalg.eigh(GWG)
                lmax = max(lam[-1], 1e-300)
                r = np.clip(lam / lmax, 0.0, None)
                damp = np.where(r < DLS_RATIO, DLS_RATIO * lmax * (1.0 - r / DLS_RATIO) ** 2, 0.0)
                Gp = WiGt.dot(U / (lam + damp)).dot(U.T)
            w0, w1, w2 = v[3:6].tolist()
            KD, KP = c.K_D, c.K_P
            rhs_att = y0[3:6] - G.dot(post)
            rhs_att += (KD * w0 + KP * e[0], KD * w1 + KP * e[1], KD * w2 + KP * e[2])
            qdd = Gp.dot(rhs_att)
        qdd += post
        peak = max(map(abs, qdd.tolist()))
        if peak > c.qdd_max:  # scale down (keeps the direction) rather than clip per joint
            qdd *= c.qdd_max / peak
        dv_b = y0 - X.dot(qdd)
        acc = self.acc
        acc[:nb] = dv_b
        acc[nb:] = qdd
        tau = M[nb:].dot(acc)
        tau += h[nb:]
        return tau, qdd, dv_b, acc

