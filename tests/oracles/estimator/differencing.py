"""Accelerations differenced from measured velocities, filtered, with their delay compensated.

The force method needs the base's linear and angular accelerations and the joint accelerations.
Without an accelerometer they are derivatives of the measured velocities. A derivative at the
newest sample needs the future; a derivative at the centre of a window of ``2m + 1`` samples is
exact for polynomials up to degree 2 and has no phase lag, so the identifier evaluates the
whole equation (the regressors from the same sample's positions and velocities) at the centre:
the estimate lags by ``m`` samples, but no row mixes signals of different times.

* ``m = 1``: the 3-point central difference for uneven steps (exact for quadratics).
* ``m > 1``: a Savitzky-Golay derivative: the slope at the centre of the least-squares
  quadratic through the ``2m + 1`` samples (Savitzky and Golay 1964, for any sample times).
  White velocity noise ``sigma`` gives a derivative noise of
  ``sigma sqrt(3 / (m (m + 1) (2m + 1))) / h`` at an even step ``h`` (the weights are
  ``i / (h sum i^2)``, ``i = -m..m``), ``sigma / (sqrt 2 h)`` for ``m = 1``: ``m = 5`` divides
  it by 7.4. The window's price: a derivative that is exact only for quadratics over
  ``2m h``, wrong where the acceleration jumps (a saturated joint acceleration command).
"""
from __future__ import annotations

from typing import Sequence, Tuple

import numpy as np

__all__ = ["centre_derivative", "derivative_weights", "displacement_weights"]


def derivative_weights(t: np.ndarray, centre: int) -> np.ndarray:
    """Weights ``w`` (k,) with ``sum_i w_i x(t_i)`` = the slope at ``t[centre]`` of the
    least-squares quadratic through the samples ``(t_i, x(t_i))`` (exact for quadratics).

    Parameters
    ----------
    t : (k,) distinct sample times [s], k >= 3;  centre : index of the time of the slope.

    Returns
    -------
    w : (k,) [1/s]

    Three samples: the central difference for uneven steps ``h1 = t1 - t0``, ``h2 = t2 - t1``:
    ``w = (-h2 / (h1 (h1 + h2)), (h2 - h1) / (h1 h2), h1 / (h2 (h1 + h2)))``.
    """
    t = np.asarray(t, dtype=float)
    if len(t) == 3 and centre == 1:
        h1, h2 = t[1] - t[0], t[2] - t[1]
        return np.array([-h2 / (h1 * (h1 + h2)), (h2 - h1) / (h1 * h2), h1 / (h2 * (h1 + h2))])
    tau = t - t[centre]
    s = np.abs(tau).max()                      # scaled times: a well-conditioned 3x3 system
    V = np.column_stack([np.ones_like(tau), tau / s, (tau / s) ** 2])   # x = V c
    # c = (V^T V)^-1 V^T x; the slope at tau = 0 is c[1] / s
    return np.linalg.solve(V.T @ V, V.T)[1] / s


def displacement_weights(t: np.ndarray, centre: int, w: np.ndarray) -> np.ndarray:
    """Weights ``u`` (k,) with ``sum_j u_j v(t_j) = sum_i w_i (x(t_i) - x(t_c))`` for
    ``v = dx/dt`` a polynomial of degree ``k - 1``: the derivative weights ``w`` applied to the
    displacements, each the integral of the polynomial through the ``k`` velocity samples
    (for a position known only through its velocity; ``k = 3`` at an even step: Simpson's
    ``(1/6, 2/3, 1/6)``).

    Parameters
    ----------
    t : (k,) distinct sample times [s];  centre : index of ``t_c``;  w : (k,) weights [1/s]

    Returns
    -------
    u : (k,) [1] (``sum u = sum w (t - t_c)``, 1 for derivative weights)
    """
    t = np.asarray(t, dtype=float)
    tau = t - t[centre]
    s = np.abs(tau).max()
    k = len(t)
    powers = np.arange(k)
    V = (tau[:, None] / s) ** powers                       # v(t_j) = sum_p c_p (tau_j / s)^p
    W = s * (tau[:, None] / s) ** (powers + 1) / (powers + 1)   # int_0^tau_i (tau / s)^p
    return np.linalg.solve(V.T, W.T @ w)                   # u = V^-T W^T w


def centre_derivative(history: Sequence[Tuple[float, np.ndarray]],
                      pairs: Sequence[Tuple[slice, slice]]) -> Tuple[float, np.ndarray]:
    """The centre sample of a window with its accelerations replaced by the derivatives of
    their velocities at the centre's time (:func:`derivative_weights`).

    Parameters
    ----------
    history : ``2m + 1`` pairs ``(t [s], flattened sample (n,))``, oldest first
    pairs : (acceleration slice, velocity slice) into a flattened sample

    Returns
    -------
    (t_c, sample (n,)) : the centre's time and a new array (the inputs are not written into)

    Examples
    --------
    >>> h = [(t, np.array([t * t, 0.0])) for t in (0.0, 1.0, 2.0)]
    >>> centre_derivative(h, [(slice(1, 2), slice(0, 1))])     # x = t^2: x'(1) = 2
    (1.0, array([1., 2.]))
    """
    m = (len(history) - 1) // 2
    times = np.array([s[0] for s in history])
    w = derivative_weights(times, m)
    tc, xc = history[m]
    out = xc.copy()
    if m == 1:                 # the 3-point formula, term by term
        (_, x0), _, (_, x2) = history
        for acc, vel in pairs:
            out[acc] = w[0] * x0[vel] + w[1] * xc[vel] + w[2] * x2[vel]
        return tc, out
    X = np.stack([s[1] for s in history])
    for acc, vel in pairs:
        out[acc] = w @ X[:, vel]
    return tc, out
