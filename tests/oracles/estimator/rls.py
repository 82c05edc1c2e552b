"""Recursive least squares: the standard filter and the paper's modified one-step RLS.

Both minimise, with forgetting factor ``lam`` (1 = none), the weighted cost

    sum_k lam^(N-k) |y_k - H_k x|^2 + lam^N (x - x0)^T P0^-1 (x - x0)

one sample at a time, with cost independent of the number of samples.

An update replaces the solver's arrays by new ones and never writes into them, so that a
snapshot (:meth:`RLS.snapshot`) is a tuple of references and costs nothing.
"""
from __future__ import annotations

import numpy as np

from . import kernels


def _raise_for(status: int) -> None:
    """Map a kernel status to an exception (the solver's state is then left unchanged)."""
    if status == 1:
        raise np.linalg.LinAlgError("lam I + H P H^T is not positive definite "
                                    "(covariance no longer positive semi-definite)")
    if status == 2:
        raise FloatingPointError("the update produced non-finite numbers")


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
        self.rows = 0

    def snapshot(self) -> tuple:
        """The state an update changes, for :meth:`restore` (references; see the module
        docstring)."""
        return self.x, self.P, self.rows

    def restore(self, snap: tuple) -> None:
        self.x, self.P, self.rows = snap

    def update(self, H: np.ndarray, y: np.ndarray):
        """One sample, ``H`` (k, p), ``y`` (k,). Returns the a-priori residual ``y - H x`` and
        the gain ``K`` (p, k). Raises ``LinAlgError`` / ``FloatingPointError`` (state unchanged)
        if the covariance lost definiteness or the result is not finite.

        ``K = P H^T (lam I + H P H^T)^-1``, ``x += K (y - H x)``, ``P = (I - K H) P / lam``
        (compiled: :func:`.kernels.rls_update`).
        """
        H = np.ascontiguousarray(H, dtype=float)
        y = np.ascontiguousarray(y, dtype=float)
        x, P, e, K, q, status = kernels.rls_update(self.x, self.P, H, y, self.lam)
        _raise_for(status)
        self.rows += len(y)
        self.x, self.P = x, P
        return e, K


class ModifiedRLS:
    """The paper's one-step solver (eqs. 34-38) for

        A mu = b                        (masses and first moments, eq. 34)
        phi theta = y + psi D(mu)       (inertias, eq. 35)

    with ``D(mu) = [m1 J(b1); mn J(bn)]`` (:func:`.parameters.D_of_mu`, 20 entries).
    ``M = d theta / d D`` re-references the inertia estimate to the newest ``mu`` so that
    ``theta`` always equals the batch least-squares answer over all samples at the latest ``mu``.
    One update is one compiled call (:func:`.kernels.modified_rls_update`).

    Parameters
    ----------
    mu0 : (p,)  theta0 : (r,)  P_mu0 : (p, p)  P_th0 : (r, r)
    lam : forgetting factor
    mu_fixed : (8,), optional  a full mass vector ``[m1, m1 b1, mn, mn bn]``: ``mu`` holds its
                               entries ``active``, the others stay at these values (e.g. the
                               out-of-plane ones of a planar robot); default: ``mu0`` (8,)
    active : (p,) int, optional
    """

    def __init__(self, mu0, theta0, P_mu0, P_th0, lam: float = 1.0, mu_fixed=None, active=None):
        self.lin = RLS(mu0, P_mu0, lam)
        self.ang = RLS(theta0, P_th0, lam)
        self.mu_fixed = np.array(self.lin.x if mu_fixed is None else mu_fixed, float)
        self.active = (np.arange(len(self.lin.x)) if active is None
                       else np.array(active, dtype=np.int64))
        if self.mu_fixed.shape != (8,) or len(self.active) != len(self.lin.x):
            raise ValueError("mu_fixed must have 8 entries and active one index per entry of mu0")
        self.mu_fixed[self.active] = self.lin.x
        self.D_mu = kernels.D_of_mu(self.mu_fixed)
        self.M = np.zeros((len(theta0), len(self.D_mu)))   # M(0) = 0

    def snapshot(self) -> tuple:
        """The state an update changes, for :meth:`restore` (references)."""
        return self.lin.snapshot(), self.ang.snapshot(), self.M, self.D_mu

    def restore(self, snap: tuple) -> None:
        lin, ang, self.M, self.D_mu = snap
        self.lin.restore(lin)
        self.ang.restore(ang)

    @property
    def mu(self) -> np.ndarray:
        return self.lin.x

    @property
    def theta(self) -> np.ndarray:
        return self.ang.x

    def update(self, A, b, phi, y, psi):
        """One sample of both equations: ``A`` (k1, p), ``b`` (k1,), ``phi`` (k2, r), ``y`` (k2,),
        ``psi`` (k2, 20). Returns the two a-priori residuals and ``y + psi D(mu)`` at the new
        ``mu``."""
        c = np.ascontiguousarray
        lin, ang = self.lin, self.ang
        (x1, P1, x2, P2, M, D, e1, e2, q1, q2, rhs, status) = kernels.modified_rls_update(
            lin.x, lin.P, ang.x, ang.P, self.M, self.D_mu, c(A, dtype=float), c(b, dtype=float),
            c(phi, dtype=float), c(y, dtype=float), c(psi, dtype=float), lin.lam, self.mu_fixed,
            self.active)
        _raise_for(status)
        self.assign((x1, P1, x2, P2, M, D), len(e1), len(e2))
        return e1, e2, rhs

    def assign(self, state: tuple, k1: int, k2: int) -> None:
        """Take the state ``(lin_x, lin_P, ang_x, ang_P, M, D_mu)`` that an update of ``k1``
        and ``k2`` rows computed (:func:`.kernels.modified_rls_update`'s first six results,
        or a fused step's)."""
        lin, ang = self.lin, self.ang
        lin.x, lin.P, ang.x, ang.P, self.M, self.D_mu = state
        lin.rows += k1
        ang.rows += k2
