"""The modal columns' reference formulation (docs/identification.md section 8; the shipped
one is native/src/est_modal.c): each mode's filter states driven by the base motion, and the
165 momentum columns of one mode. Written from the equations, no code shared with the
library; used by tests/test_modal.py's batch least squares and by
benchmarks/modal_information.py's study."""
from __future__ import annotations

import numpy as np
from scipy.linalg import expm


def drive(A, a_S, alpha_B, omega_B) -> np.ndarray:
    """(12,) the modes' drive of one sample: [A^T a_S, alpha_B, w_x^2, w_y^2, w_z^2, w_x w_y,
    w_x w_z, w_y w_z] (base axes)."""
    w = np.asarray(omega_B, float)
    return np.r_[np.asarray(A).T @ np.asarray(a_S, float), alpha_B, w ** 2,
                 w[[0, 0, 1]] * w[[1, 2, 2]]]


def filter_states(u: np.ndarray, t: np.ndarray, w: float, zeta: float) -> np.ndarray:
    """(N, 2, 12) eta and eta' of eta'' + 2 zeta w eta' + w^2 eta = -u for each of the 12
    drive channels, at rest at t[0], the drive linear between samples: the exact step
    exp(M dt) of the state [eta, eta', u, du/dt dt]."""
    out = np.zeros((len(t), 2, u.shape[1]))
    x = np.zeros((2, u.shape[1]))
    for k in range(1, len(t)):
        dt = t[k] - t[k - 1]
        M = np.zeros((4, 4))
        M[0, 1] = 1.0
        M[1, 0], M[1, 1], M[1, 2] = -w * w, -2.0 * zeta * w, -1.0
        M[2, 3] = 1.0 / dt
        E = expm(M * dt)
        x = E[:2, :2] @ x + E[:2, 2:3] * u[k - 1] + E[:2, 3:4] * (u[k] - u[k - 1])
        out[k] = x
    return out


def modal_columns(eta, etad, s, p, blocks: str = "GCDT") -> np.ndarray:
    """(6, 165) momentum columns of one mode (docs/identification.md section 8): in base axes
    about S the blocks G (21: the symmetric l l^T), C (36), D (36: [w]x d, -[v_B]x d) and
    T (72: I(eta) w for I# = [Ixx Iyy Izz Ixy Ixz Iyz]), then to inertial axes, the angular
    rows about the point p; ``blocks`` a subset keeps those blocks only (in that order)."""
    w, A = s["omega_B"], s["A"]
    vB = A.T @ s["v_S"]
    cols = []
    if "G" in blocks:
        for i in range(6):
            for j in range(i, 6):
                h = np.zeros(6)
                h[i] += etad[j]
                h[j] += etad[i] if j != i else 0.0
                cols.append(h)
    if "C" in blocks:
        for i in range(6):
            for j in range(6):
                h = np.zeros(6)
                h[i] = etad[6 + j]
                cols.append(h)
    if "D" in blocks:
        for i in range(3):
            for j in range(12):
                d = np.zeros(3)
                d[i] = eta[j]
                cols.append(np.r_[np.cross(w, d), -np.cross(vB, d)])
    if "T" in blocks:
        omega = np.array([[w[0], 0, 0], [0, w[1], 0], [0, 0, w[2]],
                          [w[1], w[0], 0], [w[2], 0, w[0]], [0, w[2], w[1]]])
        for i in range(6):
            for j in range(12):
                cols.append(np.r_[np.zeros(3), omega[i] * eta[j]])
    H = np.array(cols).T
    lin = A @ H[:3]
    ang = A @ H[3:] + np.cross(s["r_S"] - p, lin.T).T
    return np.vstack([lin, ang])
