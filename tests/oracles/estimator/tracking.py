"""The lag of a forgetting estimator behind parameters that move, as a term of the reported
standard deviation (docs/identification.md, section 7).

A least-squares estimator with forgetting factor ``lam`` weighs the sample of age ``j``
(in samples) by ``w = lam^j``. Where a parameter moves at a steady rate ``r`` and the rows keep
a steady size, its estimate is the weighted mean of the parameter's past values, so it lags the
current truth by ``r a_bar``, ``a_bar = sum_k w_k (t - t_k) / sum_k w_k`` (the data's mean
age), and itself moves at ``r (1 - d a_bar / dt)``: at ``r`` with forgetting in steady state
(``a_bar = lam / (1 - lam)`` samples), at ``r / 2`` without (``a_bar = (t - t_0) / 2``). The
truth's rate is not known, the estimate's ``r_est`` is observed, so

    lag = r_est a_bar / (1 - d a_bar / dt).                                   (1)

Rows that vary in size and mix the parameters (an excitation) weigh the past unevenly. For
the linear model ``H_k z = y_k`` with ``z`` moving at ``r_z`` the least-squares answer is
``z - A r_z`` with the information-weighted mean age

    A = G^-1 M,   G = sum_k w_k H_k^T H_k,   M = sum_k w_k (t - t_k) H_k^T H_k,
    lag = J A r_z,   r_z = (1 - dA/dt)^-1 dz/dt,   dA/dt ~ A (d a_bar / dt) / a_bar   (2)

per independent least-squares problem of the solver (:meth:`.ParameterSolver.information`),
``J`` the Jacobian of the reported estimates in the solver's parameters ``z``. ``M`` needs no
rows: after a step ``dt`` every old row is ``dt`` older, ``M <- lam (M + dt G_before)``. Eq. (1)
serves where a block is singular.

The rate is the slope of an exponentially weighted least-squares line through the recent
*data-only* answers (the estimate without the prior's pull, which would make a converging
estimate look like a moving truth), each weighted by ``1 / sd^2`` (answers the data have not
determined yet do not count as movement), with a memory :data:`RATE_MEMORY` times the
estimator's (``1 - lam_r = (1 - lam) / RATE_MEMORY``; without forgetting it grows with the
data, ``1 - lam_r = 1 / (RATE_MEMORY N)``).

An estimate also moves by its own scatter, which the reported standard deviation ``sd``
(:meth:`.ParameterSolver.std`) already describes. Only the part of the lag beyond what that
movement explains counts (:func:`total_sd`)::

    sd_total^2 = sd^2 + max(0, lag^2 - (NOISE_LAG g sd)^2)

with ``g`` (:meth:`DriftTracker.noise_gain`) the factor by which the slope turns a scatter of
``sd`` into lag: about 1 with forgetting, about 3.5 without.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from . import report_kernels as rk

__all__ = ["DriftTracker", "RATE_MEMORY", "NOISE_LAG", "total_sd"]

#: memory of the rate regression, in multiples of the estimator's memory
RATE_MEMORY = 2.0
#: a lag estimate up to this many reported standard deviations is taken as the estimate's own
#: movement (convergence, noise), not as a moving truth
NOISE_LAG = 1.0


class DriftTracker(NamedTuple):
    """Mean age of the estimator's data and the rate of its estimates, one sample at a time.

    Any clock: the identifier uses the sample count (ages in samples, rates per sample), so
    that the standard deviations, like the estimates, depend on the samples and not on the
    step sizes between them.

    Immutable: :meth:`add` returns the updated tracker (a snapshot is a reference). Its
    arithmetic is compiled (:func:`.report_kernels.drift_regression`, ``age_step``,
    ``lu_solve``, ``total_sd``).

    Times below are in the clock the caller uses (``[clock]``: samples in
    :class:`.Identifier`, seconds if the caller passes seconds); rates are per clock unit.

    Attributes
    ----------
    lam : forgetting factor of the estimator
    s0 : ``sum_k lam^(N-k)`` (the data's weight; ``N`` without forgetting)
    s1 : ``sum_k lam^(N-k) (t_k - t_ref)``  [clock]
    t_ref : time of the first sample [clock] (keeps ``s1`` small)
    t : time of the latest sample [clock]
    a_bar : mean age of the data at ``t`` [clock]
    da_dt : ``d a_bar / dt`` over the latest step
    w, mt, mx, ctt, ctx : (p,) the exponentially weighted lines through ``(t_k, x_k)``: weight,
        weighted means of t [clock] and x, centred sums ``sum w (t - mt)^2`` and
        ``sum w (t - mt)(x - mx)`` (0.0 before the first sample)
    sd : (p,) the latest standard deviations without the lag
    ages : ``M = sum w (t - t_k) H^T H`` per information block (eq. 2)
    mat_lag : (p,) the latest lag by eq. (2), or None (then eq. 1)
    slope : (p,) :meth:`rate` at the latest sample
    gain : (p,) :meth:`noise_gain` at the latest sample
    """

    lam: float
    s0: float = 0.0
    s1: float = 0.0
    t_ref: float = math.nan
    t: float = math.nan
    a_bar: float = 0.0
    da_dt: float = 0.0
    w: np.ndarray | float = 0.0
    mt: np.ndarray | float = 0.0
    mx: np.ndarray | float = 0.0
    ctt: np.ndarray | float = 0.0
    ctx: np.ndarray | float = 0.0
    sd: np.ndarray | float = 0.0
    ages: tuple = ()
    mat_lag: np.ndarray | None = None
    slope: np.ndarray | float = 0.0
    gain: np.ndarray | float = 1.0

    @classmethod
    def empty(cls, lam: float) -> "DriftTracker":
        """No sample yet, for an estimator with forgetting factor ``lam``."""
        return cls(float(lam))

    def regression_sums(self, p: int):
        """``(w, mt, mx, ctt, ctx)`` (p,) each: the rate regression's running sums, zeros
        before its first point (the lines start from 0)."""
        if self.s0 == 0.0:
            zero = np.zeros(p)
            return zero, zero, zero, zero, zero
        return self.w, self.mt, self.mx, self.ctt, self.ctx

    def add(self, t: float, x: np.ndarray, sd: np.ndarray, info_before=(),
            jac: np.ndarray | None = None, lag_of=None, estimates_lag=None) -> "DriftTracker":
        """With the estimate ``x`` (p,) and its standard deviation ``sd`` (p,) (without the
        lag) after the sample of time ``t`` [clock]. For the lag through the information-weighted
        mean age (module docstring, eq. 2), optionally: the solver's Gram matrices before the
        sample (:meth:`.ParameterSolver.information`), the Jacobian ``d x / d z`` (p, p) of the
        estimates in the solver's parameters ``z``, and ``lag_of(rate_z, growth, ages)`` (the
        solver's :meth:`.ParameterSolver.drift_lag`); ``estimates_lag(rate_x, growth, ages,
        jac)``, if given, computes :func:`matrix_lag` of these in one call (the solver's
        :meth:`.ParameterSolver.estimates_lag`)."""
        x = np.ascontiguousarray(x, dtype=float)
        sd = np.ascontiguousarray(sd, dtype=float)
        w, mt, mx, ctt, ctx = self.regression_sums(len(x))
        # the data's mean age, and the rate regression: forgetting lam_r, memory RATE_MEMORY x
        # the estimator's (s0 samples); each point weighs 1 / sd^2, so that answers the data did
        # not determine yet (large sd) do not count as movement
        (s0, s1, t_ref, a_bar, da_dt, dt, w, mt, mx, ctt, ctx, slope, gain
         ) = rk.drift_regression(self.lam, self.s0, self.s1, self.t_ref, self.t, self.a_bar,
                                 w, mt, mx, ctt, ctx, float(t), x, sd, RATE_MEMORY)
        # eq. (2): M_age = sum w (t - t_k) H^T H, one block per least-squares problem;
        # after a step dt every old row is dt older: M_age <- lam (M_age + dt G_before)
        ages = tuple(rk.age_step(M, G, self.lam, dt) for M, G in
                     zip(self.ages or [np.zeros_like(G) for G in info_before], info_before))
        mat_lag = None
        if lag_of is not None and ages and (ctt > 0.0).all():
            growth = da_dt / a_bar if a_bar > 0.0 else 0.0
            if estimates_lag is not None:
                mat_lag = estimates_lag(slope, growth, ages, jac)
            else:
                mat_lag = matrix_lag(slope, growth, ages, jac, lag_of)
        return DriftTracker(self.lam, s0, s1, t_ref, float(t), a_bar, da_dt, w, mt, mx, ctt,
                            ctx, sd, ages, mat_lag, slope, gain)

    def rate(self) -> np.ndarray | float:
        """Slope of the estimates' weighted lines, ``r_est = ctx / ctt`` (p,) [unit / clock]
        (0 before two samples)."""
        return self.slope

    def lag_factor(self) -> float:
        """``a_bar / (1 - d a_bar / dt)`` [clock], the factor of eq. (1); ``d a_bar/dt < 1`` always
        (0 steady, 1/2 without forgetting), floored against an irregular step."""
        return self.a_bar / max(1.0 - self.da_dt, 0.1)

    def lag(self) -> np.ndarray | float:
        """Expected lag of the estimates behind the truth (p,): eq. (2) of the module
        docstring where the information is known and regular, else eq. (1); 0 before two
        samples."""
        if self.mat_lag is not None:
            return self.mat_lag
        return self.rate() * self.lag_factor()

    def noise_gain(self) -> np.ndarray | float:
        """``max(1, lag_factor / T_r)`` (p,): how many of the estimate's standard deviations
        of movement eq. (1) turns into lag, ``T_r = sqrt(ctt / w)`` the time spread of the
        rate regression (an estimate that scatters by ``sd`` has a slope that scatters by
        about ``sd / T_r``); 1 where ``T_r`` is 0. About 1 with forgetting in steady state,
        about 3.5 without."""
        return self.gain

    def total_sd(self) -> np.ndarray:
        """The latest ``sd`` with the part of the lag it does not explain (module
        docstring)."""
        sd, lag, gain = self.sd, self.lag(), self.noise_gain()
        arrays = type(sd) is type(lag) is type(gain) is np.ndarray
        if arrays and sd.shape == lag.shape == gain.shape:        # the identifier's case
            return rk.total_sd(sd, lag, gain, NOISE_LAG)
        return total_sd(sd, lag, gain)


def total_sd(sd: np.ndarray, lag: np.ndarray | float, gain: np.ndarray | float = 1.0
             ) -> np.ndarray:
    """``sqrt(sd^2 + max(0, lag^2 - (NOISE_LAG gain sd)^2))`` (module docstring): the standard
    deviation ``sd`` (p,) with the part of the lag (p,) that the estimate's own movement
    (``gain`` sd, :meth:`DriftTracker.noise_gain`) does not explain (compiled:
    :func:`.report_kernels.total_sd`; ``lag`` and ``gain`` may be scalars)."""
    sd = np.ascontiguousarray(sd, dtype=float)
    shape = sd.shape
    sd = sd.reshape(-1)

    def vec(a):
        return np.ascontiguousarray(np.broadcast_to(np.asarray(a, dtype=float), shape)
                                    ).reshape(-1)

    return rk.total_sd(sd, vec(lag), vec(gain), NOISE_LAG).reshape(shape)


def matrix_lag(rate_x: np.ndarray, growth: float, ages, jac: np.ndarray, lag_of
               ) -> np.ndarray | None:
    """Eq. (2): ``lag_x = J lag_of(J^-1 rate_x, growth, ages)`` (p,) for the estimates' rate
    ``rate_x`` (p,), the Jacobian ``jac`` (p, p) of the estimates in the solver's parameters,
    the age-weighted Gram matrices ``ages`` and the solver's ``lag_of`` (its ``drift_lag``);
    None where an information block is singular (then eq. 1)."""
    jac = np.ascontiguousarray(jac, dtype=float)
    lag = lag_of(rk.lu_solve_vec(jac, rate_x), growth, ages)
    lag = rk.matvec(jac, np.ascontiguousarray(lag, dtype=float))
    return lag if np.all(np.isfinite(lag)) else None
