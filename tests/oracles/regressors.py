"""Test oracle: the identification equations' regressors of one body (paper eqs. 11-33).

Notation (README "Equations"): a body with frame origin O (S for the base, E for the target),
DCM ``A``, angular velocity ``w`` and acceleration ``beta`` (inertial), CoM offset ``b`` (body
frame), mass ``m``, CoM inertia ``I_c``. ``I#`` is the paper's 6-vector
``[I11, I12, I13, I22, I23, I33]`` (eq. 21) and ``[#v]`` the 3x6 matrix with ``I v = [#v] I#``
(eq. 20). ``J(b) = [1, b, bx^2, bx by, bx bz, by^2, by bz, bz^2]`` (eq. 23, 10 entries).

Momentum of one body (about the inertial origin):

    m v_c = m v_O + [w]x A (m b)                                    -> B_i mu_i
    L_i   = A [#(A^T w)] I_c#                                         -> D_i theta_i
          + m r_O x v_O + ([r_O]x [w]x - [v_O]x) A (m b)
          + A [#(A^T w)] T (m bb)                                     -> Psi_i m J(b)

where ``T`` maps the quadratic monomials ``m bb = m [bx^2, bx by, bx bz, by^2, by bz, bz^2]`` to
``(m (|b|^2 I - b b^T))#`` (the parallel-axis term). Force form about the moving point S
(``rho = r_O - r_S``, ``K = [beta]x + [w]x[w]x``):

    m a_c = m a_O + K A (m b)                                         -> G_i mu_i
    M_i,S = (A [#(A^T beta)] + [w]x A [#(A^T w)]) I_c#                 -> Q_i theta_i
          + m rho x a_O + ([rho]x K - [a_O]x) A (m b) + Q_i T (m bb)   -> S_i m J(b)

The identifier evaluates these rows for both bodies at once in compiled code
(:func:`oracles.estimator.kernels.equations`); this module is the NumPy reference it is
tested against (a test oracle, not part of the library: it does not ship in the FMUs). The maps
between parameterisations (``D(mu)``, ``I#``, standard parameters) are the library's
(:mod:`oracles.estimator.parameters`).

With the 10 standard parameters ``[m, m b, I_O#]`` (``I_O = I_c + m(|b|^2 I - b b^T)``) the same
rows are linear: ``Y_i = [[B_i, 0], [Psi_i[:, :4], D_i]]`` (momentum) and
``[[G_i, 0], [S_i[:, :4], Q_i]]`` (force).
"""
from __future__ import annotations

import numpy as np

from oracles.kinematics import cross3, skew

#: (m(|b|^2 I - b b^T))# = T @ [m bx^2, m bx by, m bx bz, m by^2, m by bz, m bz^2]
T_SHIFT = np.array([
    [0, 0, 0, 1, 0, 1],    # I11 = by^2 + bz^2
    [0, -1, 0, 0, 0, 0],   # I12 = -bx by
    [0, 0, -1, 0, 0, 0],   # I13 = -bx bz
    [1, 0, 0, 0, 0, 1],    # I22 = bx^2 + bz^2
    [0, 0, 0, 0, -1, 0],   # I23 = -by bz
    [1, 0, 0, 1, 0, 0],    # I33 = bx^2 + by^2
], dtype=float)


def sharp_matrix(v: np.ndarray) -> np.ndarray:
    """``[#v]`` of eq. 20: ``I @ v == sharp_matrix(v) @ I#``. Shape (3, 6)."""
    v1, v2, v3 = v
    return np.array([[v1, v2, v3, 0, 0, 0], [0, v1, 0, v2, v3, 0], [0, 0, v1, 0, v2, v3]])


def momentum_terms(r_O, A, v_O, w):
    """Momentum regressors of one body.

    Returns
    -------
    B : (3, 4)    linear momentum = B @ [m, m b]
    D : (3, 6)    CoM-inertia part of L = D @ I_c#
    Psi : (3, 10) rest of L = Psi @ (m J(b))
    """
    B = np.empty((3, 4))
    B[:, 0] = v_O
    B[:, 1:] = skew(w) @ A                                      # [w]x A (m b)
    D = A @ sharp_matrix(A.T @ w)                                # A I_c A^T w
    Psi = np.empty((3, 10))
    Psi[:, 0] = cross3(r_O, v_O)                                 # m r_O x v_O
    Psi[:, 1:4] = (skew(r_O) @ skew(w) - skew(v_O)) @ A         # r_O x (w x A mb) + A mb x v_O
    Psi[:, 4:] = D @ T_SHIFT                                     # parallel-axis term
    return B, D, Psi


def force_terms(rho, A, a_O, w, beta):
    """Force-form regressors of one body, moments about the point at ``r_O - rho``.

    Returns
    -------
    G : (3, 4)   force = G @ [m, m b]                              (eq. 29)
    Q : (3, 6)   CoM-inertia part of the moment = Q @ I_c#          (eq. 32)
    S : (3, 10)  rest of the moment = S @ (m J(b))
    """
    K = skew(beta) + skew(w) @ skew(w)
    G = np.empty((3, 4))
    G[:, 0] = a_O
    G[:, 1:] = K @ A
    Q = A @ sharp_matrix(A.T @ beta) + skew(w) @ A @ sharp_matrix(A.T @ w)
    S = np.empty((3, 10))
    S[:, 0] = cross3(rho, a_O)
    S[:, 1:4] = (skew(rho) @ K - skew(a_O)) @ A
    S[:, 4:] = Q @ T_SHIFT
    return G, Q, S
