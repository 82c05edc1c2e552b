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

    Immutable: :meth:`add` returns the updated tracker (a snapshot is a reference).

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
    w, mt, mx, ctt, ctx : the exponentially weighted line through ``(t_k, x_k)``: weight,
        weighted means of t [clock] and x (p,), centred sums ``sum w (t - mt)^2`` and
        ``sum w (t - mt)(x - mx)`` (p,)
    sd : (p,) the latest standard deviations without the lag
    ages : ``M = sum w (t - t_k) H^T H`` per information block (eq. 2)
    mat_lag : (p,) the latest lag by eq. (2), or None (then eq. 1)
    """

    lam: float
    s0: float = 0.0
    s1: float = 0.0
    t_ref: float = math.nan
    t: float = math.nan
    a_bar: float = 0.0
    da_dt: float = 0.0
    w: float = 0.0
    mt: float = 0.0
    mx: np.ndarray | float = 0.0
    ctt: float = 0.0
    ctx: np.ndarray | float = 0.0
    sd: np.ndarray | float = 0.0
    ages: tuple = ()
    mat_lag: np.ndarray | None = None

    @classmethod
    def empty(cls, lam: float) -> "DriftTracker":
        """No sample yet, for an estimator with forgetting factor ``lam``."""
        return cls(float(lam))

    def add(self, t: float, x: np.ndarray, sd: np.ndarray, info_before=(),
            jac: np.ndarray | None = None, lag_of=None) -> "DriftTracker":
        """With the estimate ``x`` (p,) and its standard deviation ``sd`` (p,) (without the
        lag) after the sample of time ``t`` [clock]. For the lag through the information-weighted
        mean age (module docstring, eq. 2), optionally: the solver's Gram matrices before the
        sample (:meth:`.ParameterSolver.information`), the Jacobian ``d x / d z`` (p, p) of the
        estimates in the solver's parameters ``z``, and ``lag_of(rate_z, growth, ages)`` (the
        solver's :meth:`.ParameterSolver.drift_lag`)."""
        lam = self.lam
        t_ref = t if self.s0 == 0.0 else self.t_ref
        s0 = lam * self.s0 + 1.0                      # sum w,  w = lam^(N-k)
        s1 = lam * self.s1 + (t - t_ref)              # sum w (t_k - t_ref)
        a_bar = (t - t_ref) - s1 / s0                 # sum w (t - t_k) / sum w
        step = t - self.t
        da_dt = (a_bar - self.a_bar) / step if self.s0 > 0.0 and step > 0.0 else 0.0
        # rate regression: forgetting lam_r, memory RATE_MEMORY x the estimator's (s0 samples);
        # each point weighs 1 / sd^2, so that answers the data did not determine yet (large sd)
        # do not count as movement
        lam_r = 1.0 - 1.0 / (RATE_MEMORY * s0)
        v = 1.0 / np.maximum(sd * sd, 1e-300)
        w_old = lam_r * self.w
        w = w_old + v
        d_t, d_x = t - self.mt, x - self.mx
        f = v * w_old / w                             # weighted Welford update
        ctt, ctx = lam_r * self.ctt + f * d_t * d_t, lam_r * self.ctx + f * d_t * d_x
        # eq. (2): M_age = sum w (t - t_k) H^T H, one block per least-squares problem;
        # after a step dt every old row is dt older: M_age <- lam (M_age + dt G_before)
        dt = step if self.s0 > 0.0 and step > 0.0 else 0.0
        ages = tuple(lam * (M + dt * G) for M, G in
                     zip(self.ages or [np.zeros_like(G) for G in info_before], info_before))
        mat_lag = None
        if lag_of is not None and ages and ctt.shape == np.shape(x) and np.all(ctt > 0.0):
            growth = da_dt / a_bar if a_bar > 0.0 else 0.0
            mat_lag = _matrix_lag(ctx / ctt, growth, ages, jac, lag_of)
        return DriftTracker(lam, s0, s1, t_ref, t, a_bar, da_dt, w,
                            self.mt + v * d_t / w, self.mx + v * d_x / w, ctt, ctx, sd, ages,
                            mat_lag)

    def rate(self) -> np.ndarray | float:
        """Slope of the estimates' weighted lines, ``r_est`` (p,) [unit / clock] (0 before two
        samples)."""
        with np.errstate(all="ignore"):
            r = self.ctx / self.ctt
        return np.where(self.ctt > 0.0, r, 0.0)

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
        about ``sd / T_r``). About 1 with forgetting in steady state, about 3.5 without."""
        with np.errstate(all="ignore"):
            spread = np.sqrt(self.ctt / self.w)
            gain = self.lag_factor() / spread
        return np.where(spread > 0.0, np.maximum(gain, 1.0), 1.0)

    def total_sd(self) -> np.ndarray:
        """The latest ``sd`` with the part of the lag it does not explain (module
        docstring)."""
        return total_sd(self.sd, self.lag(), self.noise_gain())


def total_sd(sd: np.ndarray, lag: np.ndarray | float, gain: np.ndarray | float = 1.0
             ) -> np.ndarray:
    """``sqrt(sd^2 + max(0, lag^2 - (NOISE_LAG gain sd)^2))`` (module docstring): the standard
    deviation ``sd`` (p,) with the part of the lag (p,) that the estimate's own movement
    (``gain`` sd, :meth:`DriftTracker.noise_gain`) does not explain."""
    sd2 = np.square(sd)
    excess = np.maximum(np.square(lag) - np.square(NOISE_LAG * gain) * sd2, 0.0)
    return np.sqrt(sd2 + excess)


def _matrix_lag(rate_x: np.ndarray, growth: float, ages, jac: np.ndarray, lag_of
                ) -> np.ndarray | None:
    """Eq. (2): ``lag_x = J lag_of(J^-1 rate_x, growth, ages)``; None where an information
    block is singular (then eq. 1)."""
    try:
        with np.errstate(all="ignore"):
            lag = jac @ lag_of(np.linalg.solve(jac, rate_x), growth, ages)
    except np.linalg.LinAlgError:
        return None
    return lag if np.all(np.isfinite(lag)) else None
