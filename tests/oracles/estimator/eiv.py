"""Errors in the regressors: the force method's noisy accelerations, compensated
(docs/identification.md, section 6).

The force equations are affine in the accelerations ``x`` = ``a_S`` (3), ``alpha_B`` (3) and
``qdd`` (n): they enter the regressors (``A``, ``phi``, ``psi``: the bodies' accelerations)
and the right-hand sides (``b``, ``y``: the arm's rate of momentum), so each row of one
sample is ``E(x) = E(x_true) + sum_l dx_l C_l`` with ``C_l = E(x + e_l) - E(x)`` exactly.
White noise ``dx_l`` of standard deviation ``sigma_l`` then adds to the Gram matrix of the
rows ``S = sum w [H | r]^T [H | r]`` the expected amount

    N = sum_k w_k sum_l sigma_l^2 C_l,k^T C_l,k                                  (1)

and the least-squares answer, ``S_HH x = S_Hr``, is pulled toward zero (a 5 % mass
underestimate with a navigation-grade accelerometer on a slowly moving base: the classical
attenuation of errors in variables). The bias-compensated least-squares answer (Sagara and
Wada 1977; Söderström, *Errors-in-variables methods in system identification*, 2018, ch. 7)
solves the expected noise-free normal equations instead:

    (S_HH - N_HH) x_c = S_Hr - N_Hr.                                             (2)

For the paper's two equations (``A mu = b``, ``phi theta = y + psi D(mu)``) with ``mu_r``,
``theta_r`` the solver's answers, ``S_HH x_r = S_Hr``:

    (S_AA - N_AA) dmu = N_AA mu_r - N_Ab
    (S_pp - N_pp) dtheta = N_pp theta_r - N_py - N_ppsi D(mu_c) + S_ppsi (D(mu_c) - D(mu_r))

(``p`` = phi; :func:`compensation`). Only the noise's variance enters, not its correlation
in time, so differenced accelerations are compensated the same way with ``sigma`` = the
derivative's noise, ``sigma_v |w|`` for velocity noise ``sigma_v`` and derivative weights
``w`` (:func:`.differencing.derivative_weights`).
"""
from __future__ import annotations

from typing import Callable, Tuple

import numpy as np

from . import kernels
from .uncertainty import observed_solve

__all__ = ["accel_channels", "velocity_channels", "noise_rows", "compensation"]


def accel_channels(n: int) -> np.ndarray:
    """Indices (6 + n,) of ``a_S``, ``alpha_B``, ``qdd`` in a flat sample (``KEYS`` order)."""
    k = kernels
    return np.concatenate([np.arange(k.A_S, k.A_S + 3), np.arange(k.ALPHA_B, k.ALPHA_B + 3),
                           np.arange(k.Q0 + 2 * n, k.Q0 + 3 * n)])


def velocity_channels(n: int) -> np.ndarray:
    """Indices (6 + n,) of ``v_S``, ``omega_B``, ``qd`` in a flat sample (``KEYS`` order), in
    the order of :func:`accel_channels` (the velocities the accelerations are differenced from)."""
    k = kernels
    return np.concatenate([np.arange(k.V_S, k.V_S + 3), np.arange(k.OMEGA_B, k.OMEGA_B + 3),
                           np.arange(k.Q0 + n, k.Q0 + 2 * n)])


def noise_rows(equations: Callable[[np.ndarray, np.ndarray], None], flat: np.ndarray,
               E: np.ndarray, channels: np.ndarray, sd: np.ndarray) -> np.ndarray:
    """``sigma_l C_l`` stacked, ``((3 L), N_COLS)``: the rows whose Gram matrix is the
    expected noise part of this sample's, eq. (1).

    Parameters
    ----------
    equations : ``equations(flat, out)`` writes the (3, N_COLS) equation array of a sample
    flat : (n_flat,) the sample the equations ``E`` (3, >= N_COLS) were evaluated on
    channels : (L,) indices of the noisy accelerations in ``flat``;  sd : (L,) their noise sd
    """
    used = np.flatnonzero(sd > 0.0)
    out = np.empty((3 * len(used), kernels.N_COLS))
    x = flat.copy()
    Ek = np.empty((3, kernels.N_COLS))
    for j, l in enumerate(used):
        i = channels[l]
        x[i] = flat[i] + 1.0
        equations(x, Ek)
        x[i] = flat[i]
        out[3 * j:3 * j + 3] = sd[l] * (Ek - E[:, :kernels.N_COLS])    # sigma_l C_l
    return out


def compensation(S: np.ndarray, N: np.ndarray, x: np.ndarray, rhs: np.ndarray | None = None
                 ) -> np.ndarray:
    """``dx`` of eq. (2) for one least-squares problem with Gram matrix ``S`` and noise part
    ``N`` of the augmented rows ``[H (p) | r ...]``: ``(S_HH - N_HH) dx = N_HH x - N_Hr`` +
    ``rhs``, solved in the directions ``S_HH - N_HH`` observes (:func:`.observed_solve`; a
    direction the noise swamps is left uncorrected).

    Parameters
    ----------
    S, N : (p + k, p + k), the augmented rows ``[H | r | ...]``: column ``p`` is the
    right-hand side ``r`` (``N_Hr = N[:p, p]``); further columns (the inertias' ``psi``) enter
    only through ``rhs``;  x : (p,) the uncompensated answer;  rhs : (p,) extra terms (the
    inertias' ``-N_ppsi D + S_ppsi dD``), or None.
    """
    p = len(x)
    r = N[:p, :p] @ x - N[:p, p]
    if rhs is not None:
        r = r + rhs
    return observed_solve(S[:p, :p] - N[:p, :p], r)[0]
