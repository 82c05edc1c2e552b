"""The two solvers of the identification equations, behind one interface.

Both take, one sample at a time, the equations of the identified rows (see
:mod:`.kernels`)::

    A mu = b                       (masses and first moments; eqs. 11 / 28)
    phi theta = y + psi D(mu)      (inertias; eqs. 16 / 31)

and own everything that depends on how they parameterise the bodies: the update, the 20
estimates, their uncertainty (:mod:`.uncertainty`: the a-posteriori residual variance and the
prior's pull, propagated by the delta method), and the snapshot that undoes a failed update.

* :class:`PaperSolver`: the paper's modified RLS (eqs. 34-38) over ``(mu, theta)``.
* :class:`JointSolver`: one RLS over the 20 standard parameters ``[m, m b, I_O#]`` per body,
  in which both equations are linear.

Parameters that the robot's model does not identify (a planar robot's out-of-plane ones,
:class:`.layout.Layout`) stay at their guesses: their columns move to the
right-hand side.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from typing import NamedTuple, Optional, Tuple

import numpy as np

from .layout import COM_SCALE_MIN, Guess, Layout, Solver
from . import eiv
from . import parameters as par
from . import report_kernels as rk
from .rls import RLS, ModifiedRLS, _raise_for
from .tracking import NOISE_LAG, RATE_MEMORY, DriftTracker, matrix_lag
from .uncertainty import Autocorrelation, Gram, eig_scaled, prior_pull


class Uncertainty(NamedTuple):
    """What :meth:`ParameterSolver.uncertainty_parts` computes for the 20 estimates.

    sd (20,): standard deviations;  unobserved (20,) bool: estimates that depend on a direction
    the data have not observed;  data_only (20,): the data-only answer ``v(z - delta)`` (the
    estimate without the prior's pull; its first-order image where ``z - delta`` has no
    positive mass);  jacobian (20, 20): ``d vector_of / d z`` at the estimate;  rcond (2,):
    the reciprocal condition numbers of the scaled mass and inertia information (the
    identifier's excitation diagnostics) where the computation had their spectra on the way
    (the paper solver), else None.
    """

    sd: np.ndarray
    unobserved: np.ndarray
    data_only: np.ndarray
    jacobian: np.ndarray
    rcond: Optional[np.ndarray] = None


class Step(NamedTuple):
    """What one solver update reports to the identifier (k1, k2 = linear, angular rows).

    e_lin (k1,), e_ang (k2,): a-priori residuals;  rhs_lin (k1,), rhs_ang (k2,): the right-hand
    sides they are relative to;  H_lin (k1, p1), H_ang (k2, p2): the regressor columns of the
    identified masses / first moments and inertias (for the excitation diagnostics).
    """

    e_lin: np.ndarray
    e_ang: np.ndarray
    rhs_lin: np.ndarray
    rhs_ang: np.ndarray
    H_lin: np.ndarray
    H_ang: np.ndarray


class ParameterSolver(ABC):
    """Interface of a solver (see the module docstring).

    Parameters
    ----------
    layout : ParameterLayout
        The identified parameters and equation rows.
    guess : Guess
        Initial guesses of both bodies and the initial covariances ``P0_mu`` (masses, first
        moments) and ``P0_theta`` (inertias).
    lam : float
        Forgetting factor, 0 < lam <= 1.
    lags : int
        Lags of the residual autocorrelation that inflates the data's scatter
        (:class:`.uncertainty.Autocorrelation`; 0 = independent rows assumed).
    """

    kind: Solver

    def __init__(self, layout: Layout, guess: Guess, lam: float, lags: int = 0):
        self.layout, self.guess, self.lam, self.lags = layout, guess, lam, int(lags)

    @abstractmethod
    def update(self, A, b, phi, y, psi, b_c=None, y_c=None, noise=None) -> Step:
        """One sample: ``A`` (k1, 8), ``b`` (k1,), ``phi`` (k2, 12), ``y`` (k2,), ``psi``
        (k2, 20); optionally the right-hand sides' sensitivities to the consider parameters,
        ``b_c`` (k1, c) and ``y_c`` (k2, c) (:mod:`.consider`), accumulated for
        :meth:`consider_shift`; and ``noise = (A, b, phi, y, psi)`` with rows whose Gram
        matrix is the expected noise part of this sample's (:mod:`.eiv`): the estimates are
        then the bias-compensated answers. Raises (``LinAlgError``, ``FloatingPointError``) with the
        solver unchanged if the update cannot be completed with finite numbers."""

    @abstractmethod
    def consider_shift(self) -> np.ndarray:
        """``d z / d c`` (20, c): how the least-squares answer moves per unit of each
        consider parameter, ``G^-1 sum_k w_k H_k^T R_k`` per least-squares problem
        (:mod:`.consider`), in the directions the data observe (0 along the others); zeros
        before any sensitivity was given."""

    @abstractmethod
    def z(self) -> np.ndarray:
        """The internal parameter vector (20,)."""

    @abstractmethod
    def vector_of(self, z: np.ndarray) -> np.ndarray:
        """The map from internal parameters ``z`` to the 20 estimates (``ESTIMATE_NAMES``)."""

    @abstractmethod
    def covariance(self) -> np.ndarray:
        """Covariance (20, 20) of :meth:`z` from the data's scatter: the solver covariance
        scaled by the a-posteriori residual variance (:func:`.uncertainty.residual_variance`);
        parameters that are not identified keep their prior covariance."""

    @abstractmethod
    def prior_pull(self) -> Tuple[np.ndarray, np.ndarray]:
        """``(delta (20,), unobserved (20,) bool)`` for :meth:`z`: how far the prior pulls the
        estimate from the data-only least-squares answer (:func:`.uncertainty.prior_pull`),
        and the entries the data have not determined at all."""

    @abstractmethod
    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """``d vector_of / d z`` (20, 20), written out (the delta method's Jacobian)."""

    #: whether :meth:`fuses` may say yes (the paper solver's class sets it; set it False on an
    #: instance to run every sample through the layers, the reference of the fused step)
    fused = False

    def fuses(self, b_c, noise) -> bool:
        """Whether the identifier may run a sample with consider sensitivities ``b_c`` and
        noise rows ``noise`` (None: none) through one fused compiled step
        (:meth:`PaperSolver.step`) instead of :meth:`update`, :meth:`std_parts` and
        :meth:`track`."""
        return False

    @abstractmethod
    def information(self) -> Tuple[np.ndarray, ...]:
        """The weighted Gram matrices ``sum_k lam^(N-k) [H_k | y_k ...]^T [H_k | y_k ...]`` of
        the augmented rows, one per least-squares problem (:class:`.uncertainty.Gram`; for
        :mod:`.tracking`)."""

    @abstractmethod
    def drift_lag(self, rate_z: np.ndarray, growth: float, ages: Tuple[np.ndarray, ...]
                  ) -> np.ndarray:
        """The lag (20,) of :meth:`z` behind parameters moving at the rate the estimate shows,
        ``rate_z`` (20,) (:mod:`.tracking`, eq. 2): ``A r`` per least-squares problem, ``A =
        G^-1 M`` with ``M = sum w (t - t_k) H^T H`` the age-weighted Gram matrices ``ages``
        (same layout as :meth:`information`) and ``r = (1 - growth A)^-1 rate``. Raises
        ``LinAlgError`` where an information block is singular."""

    def estimates_lag(self, rate_x: np.ndarray, growth: float, ages: Tuple[np.ndarray, ...],
                      jac: np.ndarray) -> np.ndarray | None:
        """The lag (20,) of the estimates behind parameters moving at the rate ``rate_x`` (20,)
        the estimates show, ``J drift_lag(J^-1 rate_x, growth, ages)`` with ``J`` = ``jac``
        (20, 20) the Jacobian of :meth:`vector_of` (:func:`.tracking.matrix_lag`); None where an
        information block is singular."""
        return matrix_lag(rate_x, growth, ages, jac, self.drift_lag)

    def track(self, tracker: DriftTracker, t: float, x: np.ndarray, sd: np.ndarray,
              info_before: Tuple[np.ndarray, ...], jac: np.ndarray) -> DriftTracker:
        """``tracker`` after the sample of clock time ``t`` (:meth:`.DriftTracker.add` with
        this solver's :meth:`drift_lag`): ``x`` (20,) the data-only estimates, ``sd`` (20,)
        their standard deviations, ``info_before`` the Gram matrices before the sample
        (:meth:`information`), ``jac`` (20, 20) the Jacobian of :meth:`vector_of`."""
        return tracker.add(t, x, sd, info_before, jac, self.drift_lag, self.estimates_lag)

    @abstractmethod
    def snapshot(self) -> tuple:
        """The state an update changes, for :meth:`restore` (cheap: references)."""

    @abstractmethod
    def restore(self, snap: tuple) -> None:
        """Undo every update since :meth:`snapshot` returned ``snap``."""

    def vector(self) -> np.ndarray:
        """The 20 estimates: per body m, b (3), I (6) (``ESTIMATE_NAMES`` order)."""
        return self.vector_of(self.z())

    def uncertainty(self) -> Tuple[np.ndarray, np.ndarray]:
        """``(sd (20,), unobserved (20,) bool)`` of :meth:`vector`.

        ``sd^2 = diag(J C J^T) + (v(z) - v(z - delta))^2``: the data's scatter
        (:meth:`covariance` ``C`` through the first-order, delta-method, Jacobian ``J`` of the
        map ``v`` = :meth:`vector_of`) and the prior's pull ``delta`` (:meth:`prior_pull`)
        through the map itself (its first-order image ``J delta`` where ``z - delta`` has no
        positive mass). ``unobserved``: estimates that
        depend on a direction the data have not observed (their ``sd`` bounds nothing).
        """
        u = self.uncertainty_parts()
        return u.sd, u.unobserved

    def uncertainty_parts(self) -> "Uncertainty":
        """:meth:`uncertainty` with what it computes on the way: the data-only answer and the
        Jacobian (:class:`Uncertainty`)."""
        z = self.z()
        J = self.jacobian(z)
        delta, unobserved_z = self.prior_pull()
        x = self.vector_of(z)
        with np.errstate(all="ignore"):
            pull = x - self.vector_of(z - delta)                   # the map's exact difference
        if not np.all(np.isfinite(pull)):                          # the data-only mass <= 0
            pull = J @ delta
        # diag(J C J^T) + pull^2, and the rows of J that touch an unobserved parameter
        var, unobserved = rk.scatter_and_pull(J, self.covariance(), pull, unobserved_z)
        return Uncertainty(np.sqrt(np.clip(var, 0.0, None)), unobserved, x - pull, J)

    def std(self) -> np.ndarray:
        """Standard deviations (20,) of :meth:`vector` (:meth:`uncertainty`); an unobserved
        estimate reports at least its error scale (a relative standard deviation of 100 %)."""
        return self.std_parts().sd

    def std_parts(self) -> "Uncertainty":
        """:meth:`uncertainty_parts` with ``sd`` = :meth:`std`."""
        u = self.uncertainty_parts()
        if u.unobserved.any():
            floor = self.layout.error_scale(self.vector())
            u.sd[u.unobserved] = np.maximum(u.sd[u.unobserved], floor[u.unobserved])
        return u

    def prior(self) -> np.ndarray:
        """Diagonal (20,) of the initial covariance of a 20-vector in the layout's order."""
        g = self.guess
        return np.where(self.layout.first_order, g.P0_mu, g.P0_theta).astype(float)


def _columns(*blocks: np.ndarray) -> np.ndarray:
    """``np.column_stack(blocks)`` (k, sum of widths) of (k, w) and (k,) float arrays: the same
    new C-ordered array, with less call overhead (two per sample)."""
    return np.concatenate([a if a.ndim == 2 else a[:, None] for a in blocks], axis=1)


def _noise_gram(g, lam: float, rows: np.ndarray) -> Gram:
    """``g`` (an expected-noise Gram matrix, :mod:`.eiv`) with ``rows`` added; sized by the
    rows the first time (``g`` None)."""
    return (g if g is not None else Gram.empty(rows.shape[1], lam)).add(rows)


def _accumulate(total, lam: float, term: np.ndarray) -> np.ndarray:
    """``lam total + term`` (a new array; ``term`` alone the first time)."""
    return term.copy() if total is None else lam * total + term


def _observed_solve_columns(G: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``G^-1 R`` (p, c) column by column in the directions ``G`` observes
    (:func:`.uncertainty.observed_solve`, one eigen-decomposition)."""
    eig = eig_scaled(G)
    out = np.empty_like(R)
    for j in range(R.shape[1]):
        out[:, j] = rk.eig_solve(*eig, np.ascontiguousarray(R[:, j]))[0]
    return out


def compensation_gain(S: np.ndarray, N: np.ndarray) -> np.ndarray:
    """``K = d x_c / d x_r`` (p, p) of the bias-compensated answer ``x_c = x_r + (S - N)^-1
    (N x_r - N_Hr)`` (:func:`.eiv.compensation`): ``K = 1 + (S - N)^-1 N`` in the directions
    ``S - N`` observes (there ``(S - N)^-1 S``), 1 in the others (left uncorrected).

    Parameters
    ----------
    S, N : (p, p) the Gram matrix of the rows and its expected noise part
    """
    return np.eye(len(S)) + _observed_solve_columns(S - N, N)


def block_lag(G: np.ndarray, M: np.ndarray, rate: np.ndarray, growth: float
              ) -> Tuple[np.ndarray, np.ndarray]:
    """``(A r, r)`` (p,) of one least-squares problem: ``A = G^-1 M`` (the information-weighted
    mean age; ``G``, ``M`` (p, p)), ``r = (1 - growth A)^-1 rate`` (the truth's rate from the
    estimate's, ``rate`` (p,)); NaN where a matrix is singular (compiled:
    :func:`.report_kernels.block_lag`)."""
    return rk.block_lag(*(np.ascontiguousarray(a, dtype=float) for a in (G, M, rate)),
                        float(growth))


class PaperSolver(ParameterSolver):
    """The paper's modified RLS (eqs. 34-38) over ``z = [mu (8), theta (12)]``
    (:class:`.ModifiedRLS`): ``theta`` is always the batch least-squares answer at the
    latest ``mu``."""

    kind = Solver.PAPER
    fused = True

    def __init__(self, layout: Layout, guess: Guess, lam: float = 1.0, lags: int = 0):
        super().__init__(layout, guess, lam, lags)
        L = layout
        mu0, th0 = par.paper_vectors(guess)
        self._mu_out = np.setdiff1d(np.arange(L.n_mu), L.mu_active)
        self._th_out = np.setdiff1d(np.arange(L.n_theta), L.theta_active)
        self.rls = ModifiedRLS(mu0[L.mu_active], th0[L.theta_active],
                               guess.P0_mu * np.eye(len(L.mu_active)),
                               guess.P0_theta * np.eye(len(L.theta_active)), lam, mu_fixed=mu0,
                               active=L.mu_active)
        self.mu, self.theta = mu0, th0          # full vectors (rebound by each update)
        p, r = len(L.mu_active), len(L.theta_active)
        self._mu0, self._th0 = mu0[L.mu_active], th0[L.theta_active]
        # Gram matrices of the rows [A | b] and [phi | y | psi] (residuals at any mu, theta)
        self.gram_lin = Gram.empty(p + 1, lam)
        self.gram_ang = Gram.empty(r + 1 + len(self.rls.D_mu), lam)
        # autocorrelation of the a-priori residuals of each equation
        self.corr_lin = self.corr_ang = Autocorrelation.empty(self.lags, lam)
        self._s2p = np.ascontiguousarray(par.SHARP_TO_PROJECT, dtype=np.int64)
        # consider sums sum w A^T b_c (p, c) and sum w phi^T y_c (r, c), or None
        self.cons_lin = self.cons_ang = None
        # expected noise parts of gram_lin, gram_ang (errors in variables, .eiv), or None
        self.eiv_lin = self.eiv_ang = None

    def _active(self, A, b, phi, y):
        """The rows with the fixed parameters' columns moved to the right-hand sides."""
        L = self.layout
        if len(self._mu_out):
            b = b - A[:, self._mu_out].dot(self.mu[self._mu_out])
            A = A[:, L.mu_active]
        if len(self._th_out):
            y = y - phi[:, self._th_out].dot(self.theta[self._th_out])
            phi = phi[:, L.theta_active]
        return A, b, phi, y

    def update(self, A, b, phi, y, psi, b_c=None, y_c=None, noise=None) -> Step:
        L = self.layout
        A, b, phi, y = self._active(A, b, phi, y)
        rls = self.rls
        e_lin, e_ang, rhs_ang = rls.update(A, b, phi, y, psi)
        self.gram_lin = self.gram_lin.add(_columns(A, b))
        self.gram_ang = self.gram_ang.add(_columns(phi, y, psi))
        if self.lags:
            self.corr_lin, self.corr_ang = self.corr_lin.add(e_lin), self.corr_ang.add(e_ang)
        if b_c is not None:
            self.cons_lin = _accumulate(self.cons_lin, self.lam, A.T @ b_c)
            self.cons_ang = _accumulate(self.cons_ang, self.lam, phi.T @ y_c)
        mu, theta = rls.mu, rls.theta
        if noise is not None:
            An, bn, phin, yn = self._active(*noise[:4])
            self.eiv_lin = _noise_gram(self.eiv_lin, self.lam, _columns(An, bn))
            self.eiv_ang = _noise_gram(self.eiv_ang, self.lam,
                                       _columns(phin, yn, noise[4]))
            mu, theta = self._compensated(mu, theta)
        self._take(mu, theta)
        return Step(e_lin, e_ang, b, rhs_ang, A, phi)

    def _take(self, mu: np.ndarray, theta: np.ndarray) -> None:
        """The full vectors with the active entries ``mu``, ``theta`` (new arrays)."""
        L = self.layout
        if L.complete:
            self.mu, self.theta = mu, theta
        else:
            self.mu, self.theta = self.mu.copy(), self.theta.copy()
            self.mu[L.mu_active] = mu
            self.theta[L.theta_active] = theta

    def fuses(self, b_c, noise) -> bool:
        """Yes without consider sensitivities, noise rows and residual autocorrelation: the
        configurations :func:`.report_kernels.paper_step` implements."""
        return self.fused and b_c is None and noise is None and not self.lags

    def step(self, A, b, phi, y, psi, info: Tuple[np.ndarray, np.ndarray],
             tracker: DriftTracker, clock: float):
        """:meth:`update`, :meth:`std_parts` and :meth:`track` of one sample in one compiled
        call (:func:`.report_kernels.paper_step`: the same operations), where :meth:`fuses`.

        Parameters
        ----------
        A (k1, p1), b (k1,), phi (k2, p2), y (k2,), psi (k2, 20) : the identified rows (as
            :meth:`update` takes them)
        info : ``(info_lin (p, p), info_ang (r, r))``, the identifier's information matrices
            before the sample
        tracker : the identifier's :class:`.tracking.DriftTracker` before the sample
        clock : its clock at this sample (the sample count)

        Returns
        -------
        residuals : ``(lin, ang)`` relative a-priori residuals (the identifier's outputs)
        info : the information matrices after the sample
        tracker : the tracker after the sample
        rcond : ``(lin, ang)`` the excitation diagnostics (:class:`Uncertainty`)
        report : ``(vector (20,), sd (20,))`` after the sample: :meth:`vector` and the
            tracker's :meth:`.tracking.DriftTracker.total_sd` (what the identifier reports)

        Raises ``LinAlgError`` / ``FloatingPointError`` as :meth:`update` and :meth:`std_parts`
        do, with this solver unchanged.
        """
        L, rls, gl, ga, g0 = self.layout, self.rls, self.gram_lin, self.gram_ang, self.guess
        A, b, phi, y = self._active(A, b, phi, y)
        c = np.ascontiguousarray
        rows = (c(A, dtype=float), c(b, dtype=float), c(phi, dtype=float), c(y, dtype=float),
                c(psi, dtype=float))
        k1, k2 = len(rows[1]), len(rows[3])
        gl2, ga2 = gl.counted(gl.S, k1), ga.counted(ga.S, k2)         # the counts after it
        p, r = len(rls.mu), len(rls.theta)
        scalars = np.array([gl2.dof(p), ga2.dof(r), gl2.var_scale, ga2.var_scale, gl2.decay,
                            ga2.decay])
        sums = tracker.regression_sums(len(self.mu) + len(self.theta))
        M_lin, M_ang = tracker.ages or (np.zeros_like(gl.S), np.zeros_like(ga.S))
        tr_in = np.array([tracker.lam, tracker.s0, tracker.s1, tracker.t_ref, tracker.t,
                          tracker.a_bar, float(clock), RATE_MEMORY, NOISE_LAG])
        st, rls_new, (S_lin, S_ang, info_lin, info_ang), scal, tr_s, pack, M_lin, M_ang = (
            rk.paper_step((rls.lin.x, rls.lin.P, rls.ang.x, rls.ang.P, rls.M, rls.D_mu), rows,
                          self.lam, rls.mu_fixed, L.mu_active, L.theta_active, gl.S, ga.S,
                          info[0], info[1], self.mu, self.theta, scalars,
                          (g0.P0_mu, g0.P0_theta, self._mu0, self._th0), self._s2p,
                          COM_SCALE_MIN, tr_in, sums, M_lin, M_ang))
        if st == 3:
            raise np.linalg.LinAlgError("Eigenvalues did not converge")
        _raise_for(st)
        rls.assign(rls_new, k1, k2)
        # gl2, ga2 with the new sums (as _replace(S=...), without its keyword machinery)
        self.gram_lin, self.gram_ang = gl2._make((S_lin,) + gl2[1:]), ga2._make((S_ang,) + ga2[1:])
        self._take(rls.mu, rls.theta)
        s0, s1, t_ref, a_bar, da_dt, has_lag = tr_s
        tracker = DriftTracker(tracker.lam, s0, s1, t_ref, float(clock), a_bar, da_dt, pack[0],
                               pack[1], pack[2], pack[3], pack[4], pack[8], (M_lin, M_ang),
                               pack[7] if has_lag else None, pack[5], pack[6])
        return scal[:2], (info_lin, info_ang), tracker, scal[2:], (pack[9], pack[10])

    def _compensated(self, mu_r: np.ndarray, th_r: np.ndarray):
        """The bias-compensated answers (:mod:`.eiv`) from the RLS's ``mu_r``, ``th_r``."""
        L = self.layout
        mu = mu_r + eiv.compensation(self.gram_lin.S, self.eiv_lin.S, mu_r)
        full = self.mu.copy()
        full[L.mu_active] = mu
        D_c, D_r = par.D_of_mu(full), self.rls.D_mu
        Sa, Na, r = self.gram_ang.S, self.eiv_ang.S, len(th_r)
        # -N_ppsi D(mu_c) + S_ppsi (D(mu_c) - D(mu_r)), the psi D(mu) part of the rhs
        extra = Sa[:r, r + 1:] @ (D_c - D_r) - Na[:r, r + 1:] @ D_c
        return mu, th_r + eiv.compensation(Sa, Na, th_r, extra)

    def z(self) -> np.ndarray:
        return np.concatenate([self.mu, self.theta])

    def vector_of(self, z: np.ndarray) -> np.ndarray:
        """Per body ``m``, ``b = c / m``, ``I = I#`` permuted (compiled:
        :func:`.report_kernels.paper_vector_of`)."""
        return rk.paper_vector_of(np.ascontiguousarray(z, dtype=float), self._s2p)

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """Per body: the m and b rows, ``db/dc = 1 / m``, ``db/dm = -c / m^2``; the CoM
        inertia is a parameter (permuted) (compiled: :func:`.report_kernels.paper_jacobian`)."""
        return rk.paper_jacobian(np.ascontiguousarray(z, dtype=float), self._s2p)

    def covariance(self) -> np.ndarray:
        """``Cov(mu)`` from the first RLS; ``theta`` depends on ``mu`` through
        ``d theta / d mu = M dD/dmu``, so ``Cov(theta) = C_theta + T Cov(mu) T^T`` and
        ``Cov(theta, mu) = T Cov(mu)`` with ``T = M dD/dmu`` (compiled:
        :func:`.report_kernels.paper_covariance`)."""
        L, g0, rls = self.layout, self.guess, self.rls
        s2_lin, s2_ang = self._residual_variances()
        P_lin, P_ang = self._covariances()
        return rk.paper_covariance(P_lin, P_ang, rls.M, self.mu, s2_lin, s2_ang,
                                   g0.P0_mu, g0.P0_theta, L.mu_active, L.theta_active)

    def _residual_variances(self) -> Tuple[float, float]:
        """Scales of the two covariances ``P``: the a-posteriori residual variances of both
        equations at the current ``mu``, ``theta`` (``|A mu - b|^2`` and
        ``|phi theta - y - psi D(mu)|^2`` over all samples, per degree of freedom), times the
        forgetting's and the residuals' correlation factors (:mod:`.uncertainty`)."""
        rls, gl, ga = self.rls, self.gram_lin, self.gram_ang
        mu, theta, D_mu = rls.mu, rls.theta, rls.D_mu
        if self.eiv_lin is not None:                # at the compensated answers (.eiv)
            L = self.layout
            mu, theta, D_mu = self.mu[L.mu_active], self.theta[L.theta_active], par.D_of_mu(self.mu)
        # z^T S z with z = [mu, -1] and [theta, -1, -D(mu)] (compiled)
        return rk.paper_residual_variances(mu, theta, D_mu, gl.S, ga.S, *self._variance_factors())

    def _variance_factors(self) -> Tuple[float, ...]:
        """``(dof_lin, dof_ang, scale_lin, inflation_lin, scale_ang, inflation_ang)``: the
        degrees of freedom of both residual sums, the forgetting's scales and the
        correlation's inflations (1: not applied) (:meth:`_residual_variances`)."""
        rls, gl, ga = self.rls, self.gram_lin, self.gram_ang
        one = 1.0                                   # a factor that does not apply
        vs_lin, vs_ang = (gl.var_scale, ga.var_scale) if self.lam != 1.0 else (one, one)
        inf_lin, inf_ang = ((self.corr_lin.inflation(), self.corr_ang.inflation())
                            if self.lags else (one, one))
        return (gl.dof(len(rls.mu)), ga.dof(len(rls.theta)), vs_lin, inf_lin, vs_ang, inf_ang)

    def uncertainty_parts(self) -> "Uncertainty":
        """As :meth:`ParameterSolver.uncertainty_parts`, in one compiled call
        (:func:`.report_kernels.paper_std_parts`: :meth:`_residual_variances`, the
        eigen-decompositions of :meth:`_pull_inputs` and
        :func:`.report_kernels.paper_uncertainty`), with ``rcond`` from the same spectra."""
        L, rls, gl, ga, g0 = self.layout, self.rls, self.gram_lin, self.gram_ang, self.guess
        if self.eiv_lin is not None:       # compensated: K P K^T, residuals at its answers
            s2_lin, s2_ang = self._residual_variances()
            w_mu, w_theta, eig_lin, eig_ang = self._pull_inputs()
            P_lin, P_ang = self._covariances()
            rcond = np.array([rk.rcond_of_spectrum(e[0], e[3]) for e in (eig_lin, eig_ang)])
            return Uncertainty(*rk.paper_uncertainty(
                self.mu, self.theta, rls.mu, rls.theta, rls.D_mu, rls.M, P_lin, P_ang, ga.S,
                s2_lin, s2_ang, g0.P0_mu, g0.P0_theta, w_mu, w_theta, self._mu0, self._th0,
                L.mu_active, L.theta_active, self._s2p, eig_lin, eig_ang, self._mu_rls_full()),
                rcond)
        *parts, ok = rk.paper_std_parts(
            self.mu, self.theta, rls.mu, rls.theta, rls.D_mu, rls.M, rls.lin.P, rls.ang.P, gl.S,
            ga.S, *self._variance_factors(), g0.P0_mu, g0.P0_theta,
            gl.decay * (1.0 / g0.P0_mu), ga.decay * (1.0 / g0.P0_theta), self._mu0, self._th0,
            L.mu_active, L.theta_active, self._s2p, self._mu_rls_full())
        if not ok:
            raise np.linalg.LinAlgError("Eigenvalues did not converge")
        return Uncertainty(*parts)

    def _covariances(self) -> Tuple[np.ndarray, np.ndarray]:
        """The unscaled covariances of the two answers: the RLS's ``P`` of each equation, or,
        with the accelerations' noise compensated (:mod:`.eiv`), ``K P K^T`` with
        :func:`compensation_gain` ``K``: the bias-compensated answer moves ``K`` times as far
        as the RLS's, so its scatter is ``K`` times the RLS's (large where the noise takes
        most of the rows' information)."""
        rls = self.rls
        if self.eiv_lin is None:
            return rls.lin.P, rls.ang.P
        p, r = len(rls.mu), len(rls.theta)
        K_lin = compensation_gain(self.gram_lin.S[:p, :p], self.eiv_lin.S[:p, :p])
        K_ang = compensation_gain(self.gram_ang.S[:r, :r], self.eiv_ang.S[:r, :r])
        return K_lin @ rls.lin.P @ K_lin.T, K_ang @ rls.ang.P @ K_ang.T

    def _mu_rls_full(self) -> np.ndarray:
        """The 8 mu of the RLS itself (``self.mu`` holds the bias-compensated ones where the
        accelerations' noise is compensated, :mod:`.eiv`): the prior's pull is the RLS's."""
        if self.eiv_lin is None:
            return self.mu
        full = self.mu.copy()
        full[self.layout.mu_active] = self.rls.mu
        return full

    def _pull_inputs(self):
        """The prior's remaining weights ``decay / P0`` of mu and theta (``W0 = w 1``) and the
        eigen-decompositions of their scaled information (:func:`.uncertainty.eig_scaled`)."""
        rls, gl, ga, g0 = self.rls, self.gram_lin, self.gram_ang, self.guess
        p, r = len(rls.mu), len(rls.theta)
        return (gl.decay * (1.0 / g0.P0_mu), ga.decay * (1.0 / g0.P0_theta),
                eig_scaled(gl.S[:p, :p]), eig_scaled(ga.S[:r, :r]))

    def prior_pull(self) -> Tuple[np.ndarray, np.ndarray]:
        """``mu``: :func:`.uncertainty.prior_pull`. ``theta``: the distance to the data-only
        answer at the data-only ``mu``; ``theta`` is affine in ``D`` (eqs. 35-38), and the
        data-only answer moves with ``D`` by ``G^-1 S_phi,psi``, so

            theta - theta_LS = G^-1 [-W0 (theta - theta0) + S_phi,psi (D(mu) - D(mu_LS))]

        with ``S_phi,psi = sum phi^T psi`` from the Gram matrix of ``[phi | y | psi]``
        (compiled: :func:`.report_kernels.paper_prior_pull`)."""
        L, rls = self.layout, self.rls
        w_mu, w_theta, eig_lin, eig_ang = self._pull_inputs()
        return rk.paper_prior_pull(self._mu_rls_full(), rls.mu, rls.theta, rls.D_mu, rls.M,
                                   self.gram_ang.S,
                                   w_mu, w_theta, self._mu0, self._th0, L.mu_active,
                                   L.theta_active, eig_lin, eig_ang)

    def information(self):
        return self.gram_lin.S, self.gram_ang.S

    def consider_shift(self) -> np.ndarray:
        """``mu = G_lin^-1 sum A^T b`` and ``theta = G_ang^-1 sum phi^T (y + psi D(mu))``, so
        ``dmu/dc = G_lin^-1 C_lin`` and ``dtheta/dc = G_ang^-1 (C_ang + S_phi,psi dD/dmu
        dmu/dc)`` (``C``: the consider sums, ``S_phi,psi`` from the Gram matrix)."""
        L = self.layout
        if self.cons_lin is None:
            return np.zeros((L.n_mu + L.n_theta, 0))
        p, r = len(L.mu_active), len(L.theta_active)
        Sl, Sa = self.information()
        d_mu = _observed_solve_columns(Sl[:p, :p], self.cons_lin)
        dD = par.D_jacobian(self.mu)[:, L.mu_active]                  # (20, p)
        d_th = _observed_solve_columns(Sa[:r, :r], self.cons_ang + Sa[:r, r + 1:] @ (dD @ d_mu))
        out = np.zeros((L.n_mu + L.n_theta, d_mu.shape[1]))
        out[L.mu_active], out[L.n_mu + L.theta_active] = d_mu, d_th
        return out

    def drift_lag(self, rate_z, growth, ages):
        """Masses and first moments: eq. (2) of :mod:`.tracking`. Inertias: theta is the batch
        answer at the latest mu (eq. 35), ``theta = G^-1 sum w phi^T (y + psi D(mu))``; with
        rows ``y_k = phi_k theta_k - psi_k D_k`` of a truth moving at ``r_theta``, ``dD/dt =
        dD/dmu r_mu`` and ``mu`` lagging by ``lag_mu``::

            lag_theta = A r_theta + G^-1 (S_phi,psi dD/dmu lag_mu - M_phi,psi dD/dmu r_mu)

        (``S``, ``M``: the Gram and age-weighted Gram blocks of phi against psi)
        (compiled: :func:`.report_kernels.paper_drift_lag`)."""
        L, (S_lin, S_ang), (M_lin, M_ang) = self.layout, self.information(), ages
        return rk.paper_drift_lag(S_lin, S_ang, M_lin, M_ang, rate_z, float(growth), self.mu,
                                  L.mu_active, L.theta_active)

    def estimates_lag(self, rate_x, growth, ages, jac):
        """:meth:`ParameterSolver.estimates_lag` in one compiled call
        (:func:`.report_kernels.paper_estimates_lag`: the same operations)."""
        L, (S_lin, S_ang), (M_lin, M_ang) = self.layout, self.information(), ages
        lag, finite = rk.paper_estimates_lag(np.ascontiguousarray(jac, dtype=float), rate_x,
                                             float(growth), S_lin, S_ang, M_lin, M_ang, self.mu,
                                             L.mu_active, L.theta_active)
        return lag if finite else None

    def track(self, tracker, t, x, sd, info_before, jac):
        """:meth:`ParameterSolver.track` in one compiled call
        (:func:`.report_kernels.paper_tracker_add`: the operations of
        :meth:`.DriftTracker.add`, :meth:`estimates_lag` included)."""
        tr, L, (S_lin, S_ang) = tracker, self.layout, self.information()
        x = np.ascontiguousarray(x, dtype=float)
        sd = np.ascontiguousarray(sd, dtype=float)
        w, mt, mx, ctt, ctx = tr.regression_sums(len(x))
        M_lin, M_ang = tr.ages or [np.zeros_like(G) for G in info_before]
        (s0, s1, t_ref, a_bar, da_dt, w, mt, mx, ctt, ctx, slope, gain, M_lin, M_ang, lag,
         has_lag) = rk.paper_tracker_add(
            tr.lam, tr.s0, tr.s1, tr.t_ref, tr.t, tr.a_bar, w, mt, mx, ctt, ctx, float(t), x, sd,
            RATE_MEMORY, M_lin, M_ang, info_before[0], info_before[1],
            np.ascontiguousarray(jac, dtype=float), S_lin, S_ang, self.mu, L.mu_active,
            L.theta_active)
        return DriftTracker(tr.lam, s0, s1, t_ref, float(t), a_bar, da_dt, w, mt, mx, ctt, ctx,
                            sd, (M_lin, M_ang), lag if has_lag else None, slope, gain)

    def snapshot(self) -> tuple:
        return (self.rls.snapshot(), self.mu, self.theta, self.gram_lin, self.gram_ang,
                self.corr_lin, self.corr_ang, self.cons_lin, self.cons_ang, self.eiv_lin,
                self.eiv_ang)

    def restore(self, snap: tuple) -> None:
        (rls, self.mu, self.theta, self.gram_lin, self.gram_ang, self.corr_lin, self.corr_ang,
         self.cons_lin, self.cons_ang, self.eiv_lin, self.eiv_ang) = snap
        self.rls.restore(rls)


class JointSolver(ParameterSolver):
    """One RLS over the 20 standard parameters ``z = [m, m b, I_O#]`` per body (:class:`.RLS`).

    Rows: linear ``[B, 0]``, angular ``[Psi[:, :4], D]`` per body, with ``Psi = -psi`` (its
    columns of ``m`` and ``m b``; the quadratic ones are the parallel-axis part of ``I_O``).
    """

    kind = Solver.JOINT

    def __init__(self, layout: Layout, guess: Guess, lam: float = 1.0, lags: int = 0):
        super().__init__(layout, guess, lam, lags)
        L = layout
        self.pi = par.standard_vector((guess.base, guess.target))
        act = L.standard_active
        self._out = np.setdiff1d(np.arange(len(L.names)), act)
        self.rls = RLS(self.pi[act], np.diag(self.prior()[act]), lam)
        self._pi0, self._W0 = self.pi[act], np.diag(1.0 / self.prior()[act])
        self.gram = Gram.empty(len(act) + 1, lam)        # rows [Y | y]
        self.corr = Autocorrelation.empty(self.lags, lam)   # of the a-priori residuals
        self._ix = np.ix_(act, act)
        # the identified columns that are masses / first moments, and inertias
        self._lin_cols = np.flatnonzero(L.first_order[act])
        self._ang_cols = np.flatnonzero(~L.first_order[act])
        self._s2p = np.ascontiguousarray(par.SHARP_TO_PROJECT, dtype=np.int64)
        self.cons = None                                  # sum w Y^T [b_c; y_c] (p, c)
        self.eiv = None                                   # noise part of gram (.eiv), or None

    def _stack(self, A, b, phi, y, psi):
        """``(Y (k1 + k2, 20), yy)``: both equations' rows over the standard parameters, the
        fixed parameters' columns moved to the right-hand side."""
        L = self.layout
        nl = len(b)
        Y = np.zeros((nl + len(y), len(L.names)))
        for body in L.bodies:
            Y[:nl, body.mass_first] = A[:, body.mu]                 # [B, 0]
            Y[nl:, body.mass_first] = -psi[:, body.mass_first]      # [Psi[:, :4], D]
            Y[nl:, body.inertia] = phi[:, body.theta]
        yy = np.concatenate([b, y])
        if len(self._out):
            yy = yy - Y[:, self._out].dot(self.pi[self._out])
        return Y, yy

    def update(self, A, b, phi, y, psi, b_c=None, y_c=None, noise=None) -> Step:
        L = self.layout
        nl = len(b)
        Y, yy = self._stack(A, b, phi, y, psi)
        act = L.standard_active
        e, _ = self.rls.update(Y[:, act], yy)
        self.gram = self.gram.add(_columns(Y[:, act], yy))
        if self.lags:
            self.corr = self.corr.add(e)
        if b_c is not None:                               # fixed entries: no consider part
            self.cons = _accumulate(self.cons, self.lam, Y[:, act].T @ np.vstack([b_c, y_c]))
        x = self.rls.x
        if noise is not None:                             # bias-compensated (.eiv, eq. 2)
            Yn, yn = self._stack(*noise)
            self.eiv = _noise_gram(self.eiv, self.lam, _columns(Yn[:, act], yn))
            x = x + eiv.compensation(self.gram.S, self.eiv.S, x)
        if L.complete:
            self.pi = x
        else:
            self.pi = self.pi.copy()
            self.pi[act] = x
        Ya = Y[:, act]
        return Step(e[:nl], e[nl:], b, yy[nl:], Ya[:nl, self._lin_cols], Ya[nl:, self._ang_cols])

    def z(self) -> np.ndarray:
        return self.pi

    def vector_of(self, z: np.ndarray) -> np.ndarray:
        """Per body ``m``, ``b = c / m``, ``I_c = I_O - m (|b|^2 1 - b b^T)`` permuted
        (:func:`.parameters.physical_from_standard`; compiled:
        :func:`.report_kernels.joint_vector_of`)."""
        return rk.joint_vector_of(np.ascontiguousarray(z, dtype=float), self._s2p)

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """Per body: ``db/dc = 1 / m``, ``db/dm = -c / m^2``; ``I_c = I_O - S(c) / m`` with
        ``S(c) = |c|^2 I - c c^T``, so ``dI_c/dI_O = I``, ``dI_c/dm = S / m^2`` and
        ``dI_c,ij/dc_k = -(2 c_k d_ij - d_ik c_j - c_i d_jk) / m`` (compiled:
        :func:`.report_kernels.joint_jacobian`)."""
        return rk.joint_jacobian(np.ascontiguousarray(z, dtype=float), self._s2p)

    def covariance(self) -> np.ndarray:
        """The RLS's ``P`` times the residual variance; with the accelerations' noise
        compensated (:mod:`.eiv`) ``K P K^T`` (:func:`compensation_gain`) and the residual
        variance at the compensated answer."""
        g, x = self.gram, self.rls.x
        P = self.rls.P
        if self.eiv is not None:
            p = len(x)
            x = self.pi[self.layout.standard_active]
            K = compensation_gain(g.S[:p, :p], self.eiv.S[:p, :p])
            P = K @ P @ K.T
        cov = np.diag(self.prior())
        s2 = g.residual_variance(np.append(x, -1.0), len(x))
        if self.lam != 1.0:
            s2 *= g.var_scale
        if self.lags:
            s2 *= self.corr.inflation()
        cov[self._ix] = P * s2
        return cov

    def prior_pull(self) -> Tuple[np.ndarray, np.ndarray]:
        g, x, act = self.gram, self.rls.x, self.layout.standard_active
        d, u = prior_pull(g.decay * self._W0, g.S[:len(x), :len(x)], x, self._pi0)
        delta, unobserved = np.zeros(len(self.pi)), np.zeros(len(self.pi), bool)
        delta[act], unobserved[act] = d, u
        return delta, unobserved

    def information(self):
        return (self.gram.S,)

    def consider_shift(self) -> np.ndarray:
        """``d pi / d c = G^-1 C`` (``C``: the consider sums)."""
        act = self.layout.standard_active
        if self.cons is None:
            return np.zeros((len(self.pi), 0))
        out = np.zeros((len(self.pi), self.cons.shape[1]))
        out[act] = _observed_solve_columns(self.gram.S[:len(act), :len(act)], self.cons)
        return out

    def drift_lag(self, rate_z, growth, ages):
        act = self.layout.standard_active
        p = len(act)
        lag = np.zeros(len(self.pi))
        lag[act] = block_lag(self.gram.S[:p, :p], ages[0][:p, :p], rate_z[act], growth)[0]
        return lag

    def snapshot(self) -> tuple:
        return self.rls.snapshot(), self.pi, self.gram, self.corr, self.cons, self.eiv

    def restore(self, snap: tuple) -> None:
        rls, self.pi, self.gram, self.corr, self.cons, self.eiv = snap
        self.rls.restore(rls)


#: solver class per :class:`spacerobot.interface.Solver` code
SOLVERS = {Solver.PAPER: PaperSolver, Solver.JOINT: JointSolver}


def make_solver(kind: Solver, layout: Layout, guess: Guess, lam: float = 1.0,
                lags: int = 0) -> ParameterSolver:
    """The solver of kind ``kind``."""
    return SOLVERS[Solver.parse(kind, "solver")](layout, guess, lam, lags)
