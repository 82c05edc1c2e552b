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

from typing import NamedTuple, Tuple

import numpy as np

__all__ = ["Gram", "prior_pull", "residual_variance"]

#: eigenvalues of the scaled information below this fraction of the largest count as unobserved
REL_EIG_MIN = 1e-12


class Gram(NamedTuple):
    """Weighted Gram matrix ``S = sum_k lam^(N-k) [H_k | y_k]^T [H_k | y_k]`` of a linear model,
    the number of rows seen and the prior's remaining weight ``decay = lam^N``.

    Immutable: :meth:`add` returns the updated one (so a solver's snapshot is a reference).
    """

    S: np.ndarray
    rows: int = 0
    lam: float = 1.0
    decay: float = 1.0

    @classmethod
    def empty(cls, n: int, lam: float = 1.0) -> "Gram":
        """No rows yet; ``n`` columns (parameters + right-hand sides)."""
        return cls(np.zeros((n, n)), 0, float(lam), 1.0)

    def add(self, rows: np.ndarray) -> "Gram":
        """With the augmented rows (k, n) of one more sample."""
        rows = np.asarray(rows, dtype=float)
        if self.lam == 1.0:
            return Gram(self.S + rows.T @ rows, self.rows + rows.shape[0], 1.0, 1.0)
        return Gram(self.lam * self.S + rows.T @ rows, self.rows + rows.shape[0], self.lam,
                    self.lam * self.decay)


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


def observed_solve(G: np.ndarray, r: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """``G^-1 r`` in the directions the information ``G`` observes, and which parameters have
    a component along one it does not.

    Parameters
    ----------
    G : (p, p) information (symmetric, positive semi-definite);  r : (p,) right-hand side.

    Returns
    -------
    x : (p,) the solution restricted to the observed directions (0 along the others)
    unobserved : (p,) bool, parameters with a component along a direction whose scaled
        eigenvalue is below ``REL_EIG_MIN`` of the largest (or whose information is zero).
    """
    p = len(r)
    dg = np.diag(G).copy()
    unobserved = ~(dg > 0.0)
    d = np.sqrt(np.where(unobserved, 1.0, dg))
    Gs = G / np.outer(d, d)                                  # scale-free information
    Gs[unobserved, :] = 0.0
    Gs[:, unobserved] = 0.0
    lam, V = np.linalg.eigh(Gs)
    big = lam[-1] if p and lam[-1] > 0.0 else 0.0
    keep = lam > REL_EIG_MIN * big
    Vk = V[:, keep]
    x = (Vk / lam[keep]) @ (Vk.T @ (np.asarray(r, float) / d)) / d
    if not np.all(keep):
        unobserved = unobserved | (np.abs(V[:, ~keep]).max(axis=1) > 1e-6)
    return x, unobserved


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
