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
  ``SSR(x) / (rows - p)``; ``SSR(x) = sum_k lam^(N-k) |y_k - H_k x|^2 = z^T S z`` with
  ``z = [x; -1]`` and ``S`` the (weighted) Gram matrix of the augmented rows ``[H_k | y_k]``,
  kept with constant cost per sample (:class:`Gram`).

The standard deviation the estimator reports combines both, ``sd^2 = sigma^2 P_ii + delta_i^2``
mapped to the reported parameters (see ``Identifier.std``). Without noise it is the size of the prior's pull (the true error, to first order); with noise it
adds the statistical spread. A parameter touching an unobserved direction is flagged as such.
"""
from __future__ import annotations

from typing import Tuple

import numpy as np

__all__ = ["Gram", "prior_pull", "residual_variance"]

#: eigenvalues of the scaled information below this fraction of the largest count as unobserved
REL_EIG_MIN = 1e-12


class Gram:
    """Weighted Gram matrix ``S = sum_k lam^(N-k) [H_k | y_k]^T [H_k | y_k]`` of a linear model.

    Parameters
    ----------
    n : int
        Number of columns of the augmented rows (parameters + right-hand sides).
    lam : float
        Forgetting factor (the same as the solver's).
    """

    def __init__(self, n: int, lam: float = 1.0):
        self.S = np.zeros((n, n))
        self.lam = float(lam)
        self.rows = 0

    def update(self, rows: np.ndarray) -> None:
        """Add the augmented rows (k, n)."""
        rows = np.asarray(rows, dtype=float)
        if self.lam == 1.0:
            self.S = self.S + rows.T @ rows
        else:
            self.S = self.lam * self.S + rows.T @ rows
        self.rows += rows.shape[0]


def residual_variance(S: np.ndarray, z: np.ndarray, rows: int, p: int) -> float:
    """``SSR / (rows - p)`` with ``SSR = z^T S z`` (clipped at 0: round-off), 0 before there
    is redundancy.

    Parameters
    ----------
    S : (n, n) Gram matrix of the augmented rows;  z : (n,) the combination whose residual is
    wanted (e.g. ``[x, -1]``);  rows : rows seen;  p : number of parameters.
    """
    dof = rows - p
    if dof <= 0:
        return 0.0
    return max(float(z @ S @ z), 0.0) / dof


def prior_pull(P: np.ndarray, G: np.ndarray, x: np.ndarray, x0: np.ndarray
               ) -> Tuple[np.ndarray, np.ndarray]:
    """The prior's pull ``delta = x - x_LS = -G^-1 W0 (x - x0)`` with ``W0 = P^-1 - G``.

    Parameters
    ----------
    P : (p, p) solver covariance;  G : (p, p) information (same weighting);
    x : (p,) estimate;  x0 : (p,) initial estimate.

    Returns
    -------
    delta : (p,) the pull in the observed directions (0 along unobserved ones)
    unobserved : (p,) bool, parameters with a component along a direction the data have not
        observed (scaled eigenvalue of G below ``REL_EIG_MIN``): their error is not bounded by
        the data at all.
    """
    p = len(x)
    dg = np.diag(G).copy()
    unobserved = ~(dg > 0.0)
    d = np.where(unobserved, 1.0, np.sqrt(np.where(unobserved, 1.0, dg)))
    Gs = G / np.outer(d, d)                                  # scale-free information
    Gs[unobserved, :] = 0.0
    Gs[:, unobserved] = 0.0
    lam, V = np.linalg.eigh(Gs)
    big = lam[-1] if p and lam[-1] > 0.0 else 0.0
    keep = lam > REL_EIG_MIN * big
    W0 = np.linalg.inv(P) - G                                # the prior's remaining weight
    r = W0 @ (np.asarray(x, float) - np.asarray(x0, float)) / d
    Vk = V[:, keep]
    delta = -(Vk / lam[keep]) @ (Vk.T @ r) / d               # -G^-1 W0 (x - x0), observed part
    if not np.all(keep):
        Vn = V[:, ~keep]
        unobserved = unobserved | (np.abs(Vn).max(axis=1) > 1e-6)
    return delta, unobserved
