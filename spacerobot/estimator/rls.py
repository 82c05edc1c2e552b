"""Recursive least squares: the standard filter and the paper's modified one-step RLS.

Both minimise, with forgetting factor ``lam`` (1 = none), the weighted cost

    sum_k lam^(N-k) |y_k - H_k x|^2 + lam^N (x - x0)^T P0^-1 (x - x0)

one sample at a time, with cost independent of the number of samples.
"""
from __future__ import annotations

import copy
from typing import Callable

import numpy as np


def _copy_attrs(obj, memo):
    """Deep copy of a solver object: arrays by ``ndarray.copy``, the rest by ``deepcopy``
    (much cheaper than the generic deepcopy of the object; same result)."""
    new = obj.__class__.__new__(obj.__class__)
    memo[id(obj)] = new
    for k, v in obj.__dict__.items():
        new.__dict__[k] = v.copy() if type(v) is np.ndarray else copy.deepcopy(v, memo)
    return new


class RLS:
    """Standard RLS for ``H x = y`` (unit measurement weight).

    Parameters
    ----------
    x0 : (p,) initial estimate;  P0 : (p, p) initial covariance;  lam : forgetting factor
    """

    def __init__(self, x0: np.ndarray, P0: np.ndarray, lam: float = 1.0):
        self.x = np.array(x0, float)
        self.P = np.array(P0, float)
        self.lam = float(lam)
        self.ssr = 0.0      # weighted sum of squared normalised a-priori residuals
        self.rows = 0

    def __deepcopy__(self, memo):
        return _copy_attrs(self, memo)

    def update(self, H: np.ndarray, y: np.ndarray):
        """One sample. Returns the a-priori residual ``y - H x`` and the gain ``K``."""
        lam = self.lam
        e = y - H.dot(self.x)
        PHt = self.P.dot(H.T)
        S = H.dot(PHt)
        k = S.shape[0]
        S.flat[::k + 1] += lam                                # lam I + H P H^T
        Si = _spd_inverse(S)                                  # small: explicit formulas
        if Si is None:
            Sinv_e, KT = np.split(np.linalg.solve(S, np.column_stack([e, PHt.T])), [1], axis=1)
            K, Sinv_e = KT.T, Sinv_e[:, 0]
        else:
            K = PHt.dot(Si)                                   # K = P H^T (lam I + H P H^T)^-1
            Sinv_e = Si.dot(e)
        self.ssr = lam * self.ssr + float(e.dot(Sinv_e))
        self.rows += k
        self.x = self.x + K.dot(e)                            # x += K (y - H x)
        P = self.P - K.dot(PHt.T)                             # P = (I - K H) P / lam
        if lam != 1.0:
            P /= lam
        P += P.T
        P *= 0.5
        self.P = P
        return e, K

    def sigma2(self, p: int) -> float:
        """Residual variance estimate ``ssr / (rows - p)`` (1 before there is redundancy)."""
        dof = self.rows - p
        return self.ssr / dof if dof > 0 and self.ssr > 0 else 1.0


class ModifiedRLS:
    """The paper's one-step solver (eqs. 34-38) for

        A mu = b                        (masses and first moments, eq. 34)
        phi theta = y + psi D(mu)       (inertias, eq. 35)

    ``M = d theta / d D`` re-references the inertia estimate to the newest ``mu`` so that
    ``theta`` always equals the batch least-squares answer over all samples at the latest ``mu``.

    Parameters
    ----------
    mu0 : (p,)  theta0 : (r,)  P_mu0 : (p, p)  P_th0 : (r, r)
    D : callable, ``D(mu) -> (d,)`` (only evaluated here and in :meth:`update`, not stored, so
        that the solver state is plain arrays)
    lam : forgetting factor
    """

    def __init__(self, mu0, theta0, P_mu0, P_th0, D: Callable[[np.ndarray], np.ndarray],
                 lam: float = 1.0):
        self.lin = RLS(mu0, P_mu0, lam)
        self.ang = RLS(theta0, P_th0, lam)
        self.D_mu = D(self.lin.x)
        self.M = np.zeros((len(theta0), len(self.D_mu)))   # M(0) = 0

    def __deepcopy__(self, memo):
        return _copy_attrs(self, memo)

    @property
    def mu(self) -> np.ndarray:
        return self.lin.x

    @property
    def theta(self) -> np.ndarray:
        return self.ang.x

    def update(self, A, b, phi, y, psi, D: Callable[[np.ndarray], np.ndarray]):
        """One sample of both equations. Returns the two a-priori residuals."""
        e_lin, _ = self.lin.update(A, b)                      # step 1: mu_N
        D_new = D(self.lin.x)
        self.ang.x = self.ang.x + self.M.dot(D_new - self.D_mu)  # step 2 (eqs. 36-37)
        self.D_mu = D_new
        e_ang, K = self.ang.update(phi, y + psi.dot(D_new))  # step 3
        self.M = self.M + K.dot(psi - phi.dot(self.M))        # step 4: M = (I - K phi) M + K psi
        return e_lin, e_ang


def _spd_inverse(S: np.ndarray):
    """Inverse of a small symmetric positive definite matrix (1x1 to 3x3) by explicit
    formulas, or None (larger, or not safely invertible): then the caller solves with LAPACK."""
    k = S.shape[0]
    if k == 1:
        s = S[0, 0]
        return np.array([[1.0 / s]]) if s > 0.0 else None
    if k == 2:
        a, b, _, d = S.ravel().tolist()
        det = a * d - b * b
        if not det > 1e-12 * (a * d):
            return None
        return np.array([[d, -b], [-b, a]]) / det
    if k == 3:
        a, b, c, _, d, e, _, _, f = S.ravel().tolist()
        A0, B0, C0 = d * f - e * e, c * e - b * f, b * e - c * d
        det = a * A0 + b * B0 + c * C0
        if not det > 1e-12 * (a * d * f):
            return None
        D0, E0, F0 = a * f - c * c, b * c - a * e, a * d - b * b
        return np.array([[A0, B0, C0], [B0, D0, E0], [C0, E0, F0]]) / det
    return None
