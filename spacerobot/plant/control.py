"""Controllers inside the plant.

* Base thrusters: the bounded momentum law of the paper (eqs. 40-41), per inertial axis.
* Arm: joint torques that make the base attitude follow ``e'' + K_D e' + K_P e = 0`` (eq. 39)
  through the free-floating coupling, with a null-space posture term.

Both are evaluated once per internal step ``h`` and held over it (zero-order hold, a 1/h Hz
digital controller), so the RK4 right-hand side is smooth inside every step and the impulse of
the thrust over a step is exactly ``h F``.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..robots import Controller
from .dynamics import PlantModel, attitude_error


#: eigenvalue ratio below which the attitude solve is damped (singularity robustness)
DLS_RATIO = 1e-2


def bounded_law(x: np.ndarray, K: float, x_max: float, u_max: float) -> np.ndarray:
    """Paper eqs. 40/41 per axis.

    ``u = K x`` inside the band ``|x| < x_max`` (saturated at ``u_max``), and
    ``u = sign(K x) u_max`` outside it. With the paper's gains (|K| x_max = u_max) this is
    exactly the printed law; with a lowered ``u_max`` (e.g. F_max = 0.1 N) it keeps |u| <= u_max.
    """
    inside = np.clip(K * x, -u_max, u_max)
    return np.where(np.abs(x) >= x_max, np.sign(K * x) * u_max, inside)


def thruster_command(P: np.ndarray, L_c: np.ndarray, c: Controller):
    """Thruster force at S and torque, inertial frame, from the system momentum.

    Parameters
    ----------
    P : (3,)    total linear momentum [kg.m/s]
    L_c : (3,)  total angular momentum about the system centre of mass [kg.m2/s]. The centre of
                mass is used (not the inertial origin) so that the torque damps the spin of the
                system and does not react to its translation (r_c x P).
    """
    F = bounded_law(P, c.K_F, c.P_max, c.F_max)   # eq. 41
    M = bounded_law(L_c, c.K_M, c.L_max, c.M_max)  # eq. 40
    return F, M


def arm_command(pm: PlantModel, data: pin.Data, q: np.ndarray, v: np.ndarray, f_base: np.ndarray,
                c: Controller, q_home: np.ndarray):
    """Joint torques for the attitude law (eq. 39), by inverse dynamics.

    Base rows of the dynamics, ``M_bb dv_b + M_bm qdd = f_b - c_b``, give the base acceleration
    for any joint acceleration: ``dv_b = y0 - X qdd`` with ``X = M_bb^-1 M_bm``,
    ``y0 = M_bb^-1 (f_b - c_b)``. Asking its angular rows to equal
    ``alpha_des = -K_D omega_B - K_P e`` is ``G qdd = y0_rot - alpha_des`` (``G = X_rot``),
    solved by an inertia-weighted, slightly damped right pseudo-inverse; the null space carries a posture term
    ``-K_Dn qd - K_Pn (q - q_home)``. Commanded accelerations are scaled down to
    ``|qdd| <= qdd_max``; then the base follows eq. 39 only approximately (this happens in the
    spatial scenario, whose initial angular momentum is more than the arm can store while
    holding the base). The torques follow from the arm rows.

    Returns
    -------
    tau : (n,) joint torques [N.m];  qdd : (n,) joint accelerations;  dv_b : (nb,) base accel.
    """
    nb = pm.nb
    M = pin.crba(pm.model, data, q)
    h = pin.nonLinearEffects(pm.model, data, q, v).copy()
    Mbb, Mbm = M[:nb, :nb], M[:nb, nb:]
    sol = np.linalg.solve(Mbb, np.column_stack([Mbm, f_base - h[:nb]]))
    X, y0 = sol[:, :-1], sol[:, -1]
    rows = pm.rot_rows
    e = attitude_error(pm, q)[2:3] if pm.planar else attitude_error(pm, q)
    w = v[rows]
    alpha_des = -c.K_D * w - c.K_P * e                      # eq. 39
    G = X[rows]
    # inertia-weighted right pseudo-inverse: among the joint accelerations that give alpha_des,
    # the one of least kinetic-energy rate (moves the heavy target, not the light wrist)
    WiGt = np.linalg.solve(M[nb:, nb:], G.T)
    GWG = G @ WiGt
    # selectively damped least squares: exact where the coupling is well conditioned, damped
    # only in the directions whose eigenvalue falls below DLS_RATIO of the largest one
    lam, U = np.linalg.eigh(GWG)
    lmax = max(lam[-1], 1e-300)
    r = np.clip(lam / lmax, 0.0, None)
    damp = np.where(r < DLS_RATIO, DLS_RATIO * lmax * (1.0 - r / DLS_RATIO) ** 2, 0.0)
    Gp = WiGt @ (U / (lam + damp)) @ U.T
    qd, qa = v[nb:], q[-pm.n:]
    posture = -c.K_Dn * qd - c.K_Pn * (qa - q_home)
    qdd = Gp @ (y0[rows] - alpha_des) + posture - Gp @ (G @ posture)
    peak = np.max(np.abs(qdd))
    if peak > c.qdd_max:  # scale down (keeps the direction) rather than clip per joint
        qdd *= c.qdd_max / peak
    dv_b = y0 - X @ qdd
    tau = M[nb:, :nb] @ dv_b + M[nb:, nb:] @ qdd + h[nb:]
    return tau, qdd, dv_b
