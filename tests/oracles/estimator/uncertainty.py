"""What the estimate's uncertainty is made of: the data's scatter and the prior's pull.

An RLS solver with initial estimate ``x0``, initial covariance ``P0`` and forgetting factor
``lam`` returns, after the samples ``(H_k, y_k)``, the regularised least-squares answer

    x = argmin  sum_k lam^(N-k) |y_k - H_k x|^2 + (x - x0)^T W0 (x - x0),   W0 = lam^N P0^-1,
    P = (W0 + G)^-1,                    G = sum_k lam^(N-k) H_k^T H_k   (the information).

Two things separate ``x`` from the truth:

* the prior's pull ``delta = x - x_LS`` towards ``x0``, where ``x_LS`` is the answer the data
  alone give: from ``(W0 + G) x = G x_LS + W0 x0``,

      delta = -G^-1 W0 (x - x0)                                            (exact)

  Without noise ``x_LS`` is the truth, so ``delta`` is the estimate's error itself. Directions
  in which ``G`` is singular are not observed at all: the data say nothing there.
* the scatter of the data, ``sigma^2 P`` with ``sigma^2`` the a-posteriori residual variance
  ``SSR(x) / dof``; ``SSR(x) = sum_k lam^(N-k) |y_k - H_k x|^2 = z^T S z`` with
  ``z = [x; -1]`` and ``S`` the (weighted) Gram matrix of the augmented rows ``[H_k | y_k]``,
  kept with constant cost per sample (:class:`Gram`).

  With forgetting the rows count with their weights: ``n1 = sum_k lam^(N-k) k_k`` rows of
  weight ``w = lam^(N-k)`` and ``n2 = sum_k lam^(2(N-k)) k_k``. The weighted estimate's
  covariance is ``sigma^2 P G2 P`` with ``G2 = sum w^2 H^T H``, about ``(n2 / n1) sigma^2 P``
  for regressors of steady size (:attr:`Gram.var_scale`), and ``E[SSR] = sigma^2 (n1 - p
  n2 / n1)`` (:attr:`Gram.dof`). Both are the plain ``rows - p`` and 1 without forgetting.
* correlated equation errors: the scatter term assumes independent rows. Filtered or
  differenced signals, integrated impulses, biases and random walks make consecutive rows'
  errors correlated, and ``N`` correlated rows carry the information of fewer independent
  ones. :class:`Autocorrelation` estimates the variance inflation ``1 + 2 sum_j (1 - j/(L+1))
  rho_j`` (Bartlett weights, lags ``j <= L``) from the solver's a-priori residuals; the
  long-run variance estimate of Newey and West (1987). ``L = 0`` is no correction.

The standard deviation the estimator reports combines both, ``sd^2 = sigma^2 P_ii + delta_i^2``
mapped to the reported parameters (see ``Identifier.std``). Without noise it is the size of the prior's pull (the true error, to first order); with noise it
adds the statistical spread. A parameter touching an unobserved direction is flagged as such.
"""
from __future__ import annotations

from typing import NamedTuple, Tuple

import numpy as np

from . import report_kernels

__all__ = ["Autocorrelation", "Gram", "prior_pull", "residual_variance"]

#: eigenvalues of the scaled information below this fraction of the largest count as unobserved
REL_EIG_MIN = report_kernels.REL_EIG_MIN


class Gram(NamedTuple):
    """Weighted Gram matrix ``S = sum_k lam^(N-k) [H_k | y_k]^T [H_k | y_k]`` of a linear model,
    the number of rows seen, the prior's remaining weight ``decay = lam^N`` and the weighted
    row counts ``n1 = sum_k lam^(N-k) k_k``, ``n2 = sum_k lam^(2(N-k)) k_k`` (``k_k`` rows in
    sample ``k``; both equal ``rows`` without forgetting).

    Immutable: :meth:`add` returns the updated one (so a solver's snapshot is a reference).
    """

    S: np.ndarray
    rows: int = 0
    lam: float = 1.0
    decay: float = 1.0
    n1: float = 0.0
    n2: float = 0.0

    @classmethod
    def empty(cls, n: int, lam: float = 1.0) -> "Gram":
        """No rows yet; ``n`` columns (parameters + right-hand sides)."""
        return cls(np.zeros((n, n)), 0, float(lam), 1.0, 0.0, 0.0)

    def add(self, rows: np.ndarray) -> "Gram":
        """With the augmented rows (k, n) of one more sample."""
        rows = np.asarray(rows, dtype=float)
        S = self.S + rows.T @ rows if self.lam == 1.0 else self.lam * self.S + rows.T @ rows
        return self.counted(S, rows.shape[0])

    def counted(self, S: np.ndarray, k: int) -> "Gram":
        """The Gram matrix ``S`` (n, n) of these rows and ``k`` more, with the counts and the
        prior's decay stepped by one sample of ``k`` rows (what :meth:`add` does besides the
        sum; ``S`` is computed elsewhere, e.g. in a fused compiled step)."""
        if self.lam == 1.0:
            n = self.rows + k
            return Gram(S, n, 1.0, 1.0, float(n), float(n))
        lam = self.lam
        return Gram(S, self.rows + k, lam, lam * self.decay, lam * self.n1 + k,
                    lam * lam * self.n2 + k)

    def dof(self, p: int) -> float:
        """Degrees of freedom of the weighted residual sum for ``p`` parameters,
        ``n1 - p n2 / n1`` (``rows - p`` without forgetting)."""
        if self.lam == 1.0:
            return float(self.rows - p)
        return self.n1 - p * self.n2 / self.n1 if self.n1 > 0.0 else 0.0

    @property
    def var_scale(self) -> float:
        """``n2 / n1``: the weighted estimate's covariance is about ``var_scale sigma^2 P``
        (1 without forgetting)."""
        if self.lam == 1.0 or self.n1 <= 0.0:
            return 1.0
        return self.n2 / self.n1

    def residual_variance(self, z: np.ndarray, p: int) -> float:
        """:func:`residual_variance` of the combination ``z`` with these rows' degrees of
        freedom (:meth:`dof`)."""
        return residual_variance(self.S, z, self.dof(p), 0)


class Autocorrelation(NamedTuple):
    """Weighted autocorrelation sums of a residual sequence and the variance inflation they
    imply (module docstring, correlated equation errors).

    ``c[j] = sum_t lam^(N-t) e_t . e_(t-j)`` for lags ``j = 0..L`` over the residual vectors
    ``e_t`` (the rows of one sample pooled; a pair of different lengths does not count). The
    last ``L`` of them are kept in a ring: ``ring`` (L, width) holds ``e_t`` in row ``t mod L``,
    its length in ``sizes`` (L,); ``head`` is the row the next one goes to, ``count`` how many
    are stored (<= L); ``factor`` is :meth:`inflation`. Immutable (:meth:`add` returns the
    updated one, its arrays new: a snapshot is a reference); the sums and the factor are one
    compiled call per sample (:func:`.report_kernels.autocorrelation_add`).
    """

    c: np.ndarray
    ring: np.ndarray
    sizes: np.ndarray
    head: int = 0
    count: int = 0
    lam: float = 1.0
    factor: float = 1.0

    @classmethod
    def empty(cls, lags: int, lam: float = 1.0) -> "Autocorrelation":
        """No residual yet; lags ``0..lags``."""
        if lags < 0:
            raise ValueError(f"the number of correlation lags must be >= 0, got {lags}")
        return cls(np.zeros(lags + 1), np.zeros((lags, 0)), np.zeros(lags, np.int64), 0, 0,
                   float(lam), 1.0)

    @property
    def lags(self) -> int:
        return len(self.c) - 1

    def add(self, e: np.ndarray) -> "Autocorrelation":
        """With the residual vector ``e`` of one more sample (no-op without lags)."""
        L = self.lags
        if L == 0:
            return self
        e = np.ascontiguousarray(e, dtype=float).ravel()
        ring = self.ring
        if ring.shape[1] < len(e):                   # wider rows than stored so far
            ring = np.zeros((L, len(e)))
            ring[:, :self.ring.shape[1]] = self.ring
        c, ring, sizes, factor = report_kernels.autocorrelation_add(
            self.c, self.lam, ring, self.sizes, self.head, self.count, e)
        return Autocorrelation(c, ring, sizes, (self.head + 1) % L, min(self.count + 1, L),
                               self.lam, factor)

    def inflation(self) -> float:
        """``max(1, 1 + 2 sum_j (1 - j/(L+1)) c_j / c_0)``: the factor by which correlated
        residuals make the independent-rows variance of an estimate too small; 1 without lags
        or data (a negative sum, e.g. from central differences, is not used to shrink it).
        Computed by :meth:`add`."""
        return self.factor


def residual_variance(S: np.ndarray, z: np.ndarray, rows: float, p: int) -> float:
    """``SSR / (rows - p)`` with ``SSR = z^T S z`` (clipped at 0: round-off), 0 before there
    is redundancy.

    Parameters
    ----------
    S : (n, n) Gram matrix of the augmented rows;  z : (n,) the combination whose residual is
    wanted (e.g. ``[x, -1]``);  rows : rows seen (weighted, :meth:`Gram.dof`, with
    forgetting);  p : number of parameters.
    """
    dof = rows - p
    if dof <= 0:
        return 0.0
    return max(float(z @ S @ z), 0.0) / dof


def observed_solve(G: np.ndarray, r: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """``G^-1 r`` in the directions the information ``G`` observes, and which parameters have
    a component along one it does not.

    Scale-free: with ``d = sqrt(diag G)``, ``G_s = G / (d d^T)`` (rows and columns of a zero
    diagonal entry set to 0) is eigen-decomposed, ``G_s = V diag(lam) V^T``, and
    ``x = V_k diag(1 / lam_k) V_k^T (r / d) / d`` over the eigenvalues ``lam_k`` above
    ``REL_EIG_MIN`` times the largest (:func:`eig_scaled`, then :func:`.report_kernels.eig_solve`;
    all compiled).

    Parameters
    ----------
    G : (p, p) information (symmetric, positive semi-definite);  r : (p,) right-hand side.

    Returns
    -------
    x : (p,) the solution restricted to the observed directions (0 along the others)
    unobserved : (p,) bool, parameters with a component along a direction whose scaled
        eigenvalue is below ``REL_EIG_MIN`` of the largest (or whose information is zero).
    """
    return report_kernels.eig_solve(*eig_scaled(G), np.ascontiguousarray(r, dtype=float))


def eig_scaled(G: np.ndarray) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(lam, V, d, unobserved)``: the eigen-decomposition ``G_s = V diag(lam) V^T`` (``lam``
    (p,) ascending, ``V`` (p, p)) of the scale-free information ``G_s = G / (d d^T)``,
    ``d = sqrt(diag G)`` (p,), and the parameters without information (p,) bool, as
    :func:`.report_kernels.eig_solve` takes them (compiled: :func:`.report_kernels.eig_scaled`,
    Householder and QL iterations, equal to LAPACK's ``np.linalg.eigh`` to round-off). Raises
    ``LinAlgError`` if the eigenvalues do not converge (as ``np.linalg.eigh``)."""
    lam, V, d, unobserved, ok = report_kernels.eig_scaled(np.ascontiguousarray(G, dtype=float))
    if not ok:
        raise np.linalg.LinAlgError("Eigenvalues did not converge")
    return lam, V, d, unobserved


def prior_pull(W0: np.ndarray, G: np.ndarray, x: np.ndarray, x0: np.ndarray
               ) -> Tuple[np.ndarray, np.ndarray]:
    """The prior's pull ``delta = x - x_LS = -G^-1 W0 (x - x0)``.

    Parameters
    ----------
    W0 : (p, p) the prior's remaining weight ``lam^N P0^-1``;  G : (p, p) information (same
    weighting, :class:`Gram`);  x : (p,) estimate;  x0 : (p,) initial estimate.

    Returns
    -------
    delta : (p,) the pull in the observed directions (0 along unobserved ones)
    unobserved : (p,) bool (:func:`observed_solve`): the data do not bound these at all.
    """
    return observed_solve(G, -(W0 @ (np.asarray(x, float) - np.asarray(x0, float))))
