"""The row standard deviations of the identification equations under measurement noise.

The identifier weighs each equation's rows by the inverse of the standard deviation of their
error (``Identifier(row_sd=...)``, FMU parameters ``ident.sd_row.*``). The error of a row is
what the measurement errors leave in it at the true parameters:

    r_lin = A(x) mu - b(x),    r_ang = phi(x) theta - y(x) - psi(x) D(mu)

with ``x`` the measured signals. Its size follows from the sensors' noise levels through
equations that are nonlinear in the measurements (attitudes, lever arms, products of rates),
so it is measured here rather than written out: run the sensors' models on a simulated run
whose truth is known (a pilot run with another seed), evaluate the equations of each sample at
the truth and take the root mean square of the rows of each equation, with the rows as the
identifier builds them (:meth:`.Identifier.rows`, so with its equation settings: the momentum
window and point, the accelerometer bias, the differencing window). The result depends on the
run's length for the momentum method with the paper's reference (its errors, integrated
impulses differenced against the first sample, grow with time), not with a momentum window.
"""
from __future__ import annotations

import math
from typing import Iterable, Mapping, Tuple

import numpy as np

from . import parameters as par
from .layout import AccelSource, Guess, Method
from .identifier import Identifier

__all__ = ["equation_error_sd"]


def equation_error_sd(robot, base, target,
                      samples: Iterable[Tuple[float, Mapping[str, np.ndarray]]],
                      method: Method | str = "momentum",
                      accel_source: AccelSource | str = "measured",
                      diff_half_window: int = 1, **options) -> Tuple[float, float]:
    """Root mean square of the rows of the linear and of the angular equation at the true
    parameters, over measured samples (see the module docstring).

    Parameters
    ----------
    robot : the robot description
    base, target : the true bodies
    samples : ``(t [s], measurements)`` in time order, measurements as for
        :meth:`Identifier.update` (keys :data:`.identifier.KEYS`)
    method, accel_source, diff_half_window : as the identifier that will use the result
    options : further :class:`.Identifier` options that shape the rows (``window``,
        ``moving_point``), as the identifier that will use the result

    Returns
    -------
    (sd_lin, sd_ang) : in the units of the method's equations (momentum N.s and N.m.s, force
        N and N.m); ``ident.sd_row.<method>_lin`` / ``_ang``. NaN without a usable sample.
    """
    truth = Guess(base, target, 1.0, 1.0)
    ident = Identifier(robot, truth, method, accel_source=accel_source,
                       diff_half_window=diff_half_window, **options)
    mu, theta = par.paper_vectors(truth)
    D = par.D_of_mu(mu)
    L = ident.layout
    sums, counts = np.zeros(2), np.zeros(2)
    for t, meas in samples:
        eq = ident.rows(t, meas)
        if eq is None:                        # rejected, a reference, a filling window
            continue
        A, b, phi, y, psi = eq
        r_lin = (A @ mu - b)[L.rows_lin]                       # A mu = b
        r_ang = (phi @ theta - y - psi @ D)[L.rows_ang]        # phi theta = y + psi D(mu)
        sums += (r_lin @ r_lin, r_ang @ r_ang)
        counts += (len(r_lin), len(r_ang))
    if not counts.all():
        return math.nan, math.nan
    sd = np.sqrt(sums / counts)
    return float(sd[0]), float(sd[1])
