"""The identifier: measurements in, estimates of base and target out, one sample at a time.

Uses only the robot description (the known arm) and the measured signals of the interface
contract; never the plant.
"""
from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np

from ..kinematics import ArmKinematics
from ..robots import Guess, Robot
from . import kernels
from . import regressors as rg
from .rls import RLS, ModifiedRLS

METHODS = ("momentum", "force")
SOLVERS = ("paper", "joint")
ACCEL_SOURCES = ("measured", "differenced")

#: measurement keys and their shapes (n = number of arm joints)
KEYS = ("r_S", "v_S", "A", "omega_B", "a_S", "alpha_B", "q", "qd", "qdd", "F", "M", "J", "H")

#: largest accepted input magnitude (SI units): far beyond any spacecraft state, far below
#: the magnitudes at which the equations' products would overflow
INPUT_LIMIT = 1e15

# status codes (see spacerobot.interface.STATUS)
NO_SAMPLE, REFERENCE, ESTIMATING, REJECT_NONFINITE, REJECT_INCONSISTENT = 0, 1, 2, 3, 4


@dataclass
class BodyEstimate:
    """Mass [kg], CoM offset b (3,) [m] and CoM inertia (Ixx, Iyy, Izz, Ixy, Ixz, Iyz) [kg.m2]."""

    m: float
    b: np.ndarray
    I: np.ndarray


class Identifier:
    """Online one-step identification of base and target inertial parameters.

    Parameters
    ----------
    robot : Robot
        Robot description; only the arm links (known) and ``planar`` are used.
    guess : Guess
        Initial guesses of both bodies and the initial covariances ``P0_mu``, ``P0_theta``.
    method : {'momentum', 'force'}
        Momentum-based (eqs. 11/16, uses the impulses J, H) or force-based (eqs. 28/31, uses
        F, M and accelerations).
    solver : {'paper', 'joint'}
        The paper's modified RLS over (mu, theta), or one RLS over the 20 standard parameters.
    accel_source : {'measured', 'differenced'}
        Force method only: measured accelerations, or central differences of the velocities
        (the estimate then lags by one sample).
    lam : float
        Forgetting factor, 0 < lam <= 1.

    Examples
    --------
    >>> ident = Identifier(robot, guess)              # doctest: +SKIP
    >>> status = ident.update(t, measurement_dict)    # doctest: +SKIP
    >>> ident.estimates()["target"].m                 # doctest: +SKIP
    """

    def __init__(self, robot: Robot, guess: Guess, method: str = "momentum", solver: str = "paper",
                 accel_source: str = "measured", lam: float = 1.0):
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        if solver not in SOLVERS:
            raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
        if accel_source not in ACCEL_SOURCES:
            raise ValueError(f"accel_source must be one of {ACCEL_SOURCES}, got {accel_source!r}")
        if not (0.0 < lam <= 1.0):
            raise ValueError(f"forgetting factor lambda must satisfy 0 < lambda <= 1, got {lam}")
        for name, body in (("guess.base", guess.base), ("guess.target", guess.target)):
            body.check(name)
        for name, val in (("P0_mu", guess.P0_mu), ("P0_theta", guess.P0_theta)):
            if not (val > 0.0 and math.isfinite(val)):
                raise ValueError(f"{name} must be a finite covariance > 0, got {val}")
        self.robot, self.guess = robot, guess
        self.method, self.solver, self.accel_source, self.lam = method, solver, accel_source, lam
        self.kin = ArmKinematics(robot)
        self.n = robot.n_joints
        kin = self.kin
        self._geom = tuple(np.ascontiguousarray(a, dtype=float) for a in (
            kin.xyz, kin.R, kin.axis, kin.mass, kin.com, kin.I, kin.ee_xyz, kin.ee_R))
        self._sizes = [3, 3, 9, 3, 3, 3, self.n, self.n, self.n, 3, 3, 3, 3]   # per KEYS entry
        n, q0 = self.n, kernels.Q0
        # (acceleration, velocity) slices of a flattened sample: a_S, alpha_B, qdd
        self._diff_slices = ((slice(kernels.A_S, kernels.A_S + 3), slice(kernels.V_S, kernels.V_S + 3)),
                             (slice(kernels.ALPHA_B, kernels.ALPHA_B + 3),
                              slice(kernels.OMEGA_B, kernels.OMEGA_B + 3)),
                             (slice(q0 + 2 * n, q0 + 3 * n), slice(q0 + n, q0 + 2 * n)))
        planar = robot.planar
        # active rows / parameters (planar: x, y translation and z rotation only)
        self.rows_lin = np.array([0, 1]) if planar else np.arange(3)
        self.rows_ang = np.array([2]) if planar else np.arange(3)
        self.mu_idx = np.array([0, 1, 2, 4, 5, 6]) if planar else np.arange(8)
        self.th_idx = np.array([5, 11]) if planar else np.arange(12)
        # inactive parameters (fixed at their guesses) and whether there are any
        self._mu_in = np.setdiff1d(np.arange(8), self.mu_idx)
        self._th_in = np.setdiff1d(np.arange(12), self.th_idx)
        self._all_rows = len(self.rows_lin) == 3 and len(self.rows_ang) == 3
        self._cov_ix = (np.ix_(self.mu_idx, self.mu_idx), np.ix_(self.th_idx, np.arange(8)),
                        np.ix_(self.th_idx, self.th_idx))
        mu0, th0 = self._paper_vector(guess)
        self.mu_full, self.th_full = mu0, th0
        if solver == "paper":
            p, r = len(self.mu_idx), len(self.th_idx)
            self.rls = ModifiedRLS(mu0[self.mu_idx], th0[self.th_idx], guess.P0_mu * np.eye(p),
                                   guess.P0_theta * np.eye(r), lam, mu_fixed=mu0,
                                   active=self.mu_idx)
        else:
            pi0 = self._standard_vector(guess)
            self.pi_full = pi0
            self.pi_idx = np.concatenate([self._std_idx(0), self._std_idx(1)])
            P0 = np.array([guess.P0_mu if (i % 10) < 4 else guess.P0_theta for i in self.pi_idx])
            self.rls = RLS(pi0[self.pi_idx], np.diag(P0), lam)
            self._pi_out = np.setdiff1d(np.arange(20), self.pi_idx)
            self._lin_cols = np.array([i for i, p in enumerate(self.pi_idx) if p % 10 < 4])
            self._ang_cols = np.array([i for i, p in enumerate(self.pi_idx) if p % 10 >= 4])
        self.info_lin = np.zeros((len(self.mu_idx),) * 2)
        self.info_ang = np.zeros((len(self.th_idx),) * 2)
        self.samples = 0
        self.rejected = 0
        self.status = NO_SAMPLE
        self.residual_lin = 0.0
        self.residual_ang = 0.0
        self.reference = None       # momentum method: terms at t0
        self.history = []           # differenced accelerations: last samples (t, flat sample)
        self._exc = None            # cached excitation() (cleared by update / set_state)

    # -- parameter vectors -------------------------------------------------------------------
    @staticmethod
    def _paper_vector(g: Guess):
        mu = np.concatenate([[g.base.mass], g.base.mass * np.array(g.base.com),
                             [g.target.mass], g.target.mass * np.array(g.target.com)])
        th = np.concatenate([np.asarray(g.base.inertia)[rg.PROJECT_TO_SHARP],
                             np.asarray(g.target.inertia)[rg.PROJECT_TO_SHARP]])
        return mu, th

    @staticmethod
    def _standard_vector(g: Guess):
        return np.concatenate([rg.standard_from_physical(b.mass, b.com, b.inertia_matrix())
                               for b in (g.base, g.target)])

    def _std_idx(self, k: int) -> np.ndarray:
        loc = np.array([0, 1, 2, 9]) if self.robot.planar else np.arange(10)
        return 10 * k + loc

    # -- equations -----------------------------------------------------------------------------
    def _equations(self, flat: np.ndarray):
        """The (3, 42) equation array ``[A | b | phi | y | psi]`` of one sample (full 3D rows;
        see :mod:`.kernels`), from the flattened measurements; momentum form: differenced
        against the reference sample t0 (eqs. 11, 16), None for the reference itself."""
        E = np.empty((3, kernels.N_COLS))
        force = self.method == "force"
        kernels.equations(force, flat, self.n, *self._geom, E)
        if force:
            return E
        if self.reference is None:
            self.reference = E
            return None
        return E - self.reference

    def equations(self, s: dict):
        """``(A, b, phi, y, psi)`` for one sample, full 3D rows (before planar selection):
        ``A mu = b`` and ``phi theta = y + psi D(mu)``.

        Momentum: differences against the reference sample t0 (eqs. 11, 16). Returns None for
        the reference sample itself.
        """
        E = self._equations(np.concatenate([np.asarray(s[k], float).ravel() for k in KEYS]))
        return None if E is None else _split(E)

    # -- the update ------------------------------------------------------------------------------
    def validate(self, s: dict):
        """Return ``(status, message)``: ESTIMATING if the sample is usable."""
        return self._validate(s)[:2]

    def _validate(self, meas: dict):
        """``(status, message, flat)``; ``flat`` is the sample flattened in KEYS order (a new
        float array; ``A`` row-major), or None if the sample is rejected."""
        try:
            # fast path: one concatenation, shapes by length, one compiled range/rotation test
            vals = [meas[k] for k in KEYS]
            vals[2] = np.ravel(vals[2])
            if [len(v) for v in vals] == self._sizes and np.shape(meas["A"]) == (3, 3):
                flat = np.concatenate(vals).astype(float, copy=False)
                if flat.ndim == 1 and kernels.sample_check(flat, INPUT_LIMIT) == 0:
                    return ESTIMATING, "", flat
        except (ValueError, TypeError, AttributeError):
            pass
        # careful path (and the messages; it also accepts what the fast path's tighter
        # rotation test or its type handling left to it)
        arrays = []
        for k, size in zip(KEYS, self._sizes):
            try:
                x = np.array(meas[k], float)
            except (ValueError, TypeError) as e:
                return REJECT_INCONSISTENT, f"input {k} is not numeric ({e})", None
            shape = (3, 3) if k == "A" else (size,)
            if x.shape != shape:
                return REJECT_INCONSISTENT, f"input {k} has shape {x.shape}, expected {shape}", None
            if not np.all(np.isfinite(x)):
                return (REJECT_NONFINITE, f"non-finite input {k} = "
                        f"{np.array2string(x, precision=4)}", None)
            if np.abs(x).max() > INPUT_LIMIT:
                return REJECT_NONFINITE, (f"input {k} = {np.array2string(x, precision=4)} is beyond "
                                          f"the physical range |x| <= {INPUT_LIMIT:g} (SI units?)"), None
            arrays.append(x.ravel())
        A = np.asarray(meas["A"], float)
        err = np.abs(A.T @ A - np.eye(3)).max()
        if err > 1e-6 or np.linalg.det(A) <= 0.0:
            return REJECT_INCONSISTENT, (f"base.A is not a rotation matrix (|A^T A - I| = "
                                         f"{err:.3g}, det = {np.linalg.det(A):.6g})"), None
        return ESTIMATING, "", np.concatenate(arrays)

    def update(self, t: float, meas: dict) -> int:
        """Process one sample taken at time ``t``. Never raises on bad data.

        Parameters
        ----------
        t : float
            Sample time [s].
        meas : dict
            Keys :data:`KEYS`; vectors (3,), ``A`` (3, 3), joint arrays (n,). Copied.

        Returns
        -------
        status : int
            See :data:`spacerobot.interface.STATUS`. A rejected sample leaves every estimate,
            covariance and internal state untouched; ``self.message`` says why.
        """
        status, self.message, flat = self._validate(meas)
        if status != ESTIMATING or not math.isfinite(t):
            self.status = status if status != ESTIMATING else REJECT_NONFINITE
            if not math.isfinite(t):
                self.message = f"non-finite sample time {t}"
            self.rejected += 1
            return self.status
        # finite but huge inputs can still overflow inside the equations or the RLS: the update
        # is a transaction, undone entirely if anything non-finite comes out of it
        before = self._snapshot()
        try:
            with np.errstate(all="ignore"):
                status = self._accept(t, flat)
            ok = self._finite(status)
            why = "the update failed: it produced non-finite numbers"
        except (ArithmeticError, ValueError, np.linalg.LinAlgError) as e:
            ok, why = False, f"the update failed ({type(e).__name__}: {e})"
        if not ok:
            rejected = self.rejected + 1
            self._restore(before)
            self.rejected, self.status = rejected, REJECT_NONFINITE
            self.message = f"{why}; are the inputs in SI units and of physical size?"
            return self.status
        return status

    def _snapshot(self):
        """What an update may change, for :meth:`_restore`. Cheap: the solvers and the
        identifier replace their arrays rather than writing into them, except the full
        parameter vectors (copied here)."""
        r = self.rls
        solvers = [r] + ([r.lin, r.ang] if self.solver == "paper" else [])
        attrs = {k: getattr(self, k) for k in _UPDATED}
        arrays = {k: getattr(self, k).copy() for k in _WRITTEN if hasattr(self, k)}
        return [(o, o.__dict__.copy()) for o in solvers], attrs, arrays, list(self.history)

    def _restore(self, snap) -> None:
        solvers, attrs, arrays, history = snap
        for o, d in solvers:
            o.__dict__.clear()
            o.__dict__.update(d)
        for k, v in {**attrs, **arrays}.items():
            setattr(self, k, v)
        self.history = history
        self._exc = None

    def _accept(self, t: float, flat: np.ndarray) -> int:
        """The update proper, for a validated sample (see :meth:`update`)."""
        if self.method == "force" and self.accel_source == "differenced":
            flat = self._differenced(t, flat)
            if flat is None:
                self.status = REFERENCE
                return self.status
        E = self._equations(flat)
        if E is None:
            self.status = REFERENCE
            return self.status
        self._solve(*_split(E))
        self._exc = None
        self.samples += 1
        self.status = ESTIMATING
        return self.status

    def _finite(self, status: int) -> bool:
        """True if the update left only finite numbers behind.

        After a solve: the residuals (the solvers refuse non-finite results themselves, see
        :meth:`.RLS.update`). After a sample that was only stored (the momentum reference, the
        differencing history): what was stored. One sum per array: a sum is non-finite if any
        element is.
        """
        total = self.residual_lin + self.residual_ang
        if status == REFERENCE:
            if self.reference is not None:
                total += self.reference.sum()
            if self.history:
                total += self.history[-1][1].sum()
        return math.isfinite(total)

    def _differenced(self, t: float, flat: np.ndarray):
        """Replace the accelerations of the previous sample by 3-point central differences of
        the velocities (flattened samples, see :meth:`_validate`).

        Returns the completed previous sample, or None while the history is too short.
        """
        self.history.append((t, flat))
        if len(self.history) < 3:
            return None
        (t0, x0), (t1, x1), (t2, x2) = self.history[-3:]
        self.history = self.history[-2:]
        h1, h2 = t1 - t0, t2 - t1
        c0, c1, c2 = -h2 / (h1 * (h1 + h2)), (h2 - h1) / (h1 * h2), h1 / (h2 * (h1 + h2))
        out = x1.copy()
        for acc, vel in self._diff_slices:
            out[acc] = c0 * x0[vel] + c1 * x1[vel] + c2 * x2[vel]
        return out

    def _solve(self, A, b, phi, y, psi):
        rl, ra = self.rows_lin, self.rows_ang
        if not self._all_rows:
            A, b, phi, y, psi = A[rl], b[rl], phi[ra], y[ra], psi[ra]
        if self.solver == "paper":
            # inactive (planar out-of-plane) parameters stay at their guesses: move them right
            mu_in, th_in = self._mu_in, self._th_in
            if len(mu_in):
                b = b - A[:, mu_in].dot(self.mu_full[mu_in])
                A = A[:, self.mu_idx]
            if len(th_in):
                y = y - phi[:, th_in].dot(self.th_full[th_in])
                phi = phi[:, self.th_idx]
            e_lin, e_ang, rhs_ang = self.rls.update(A, b, phi, y, psi)
            self.mu_full[self.mu_idx] = self.rls.mu
            self.th_full[self.th_idx] = self.rls.theta
        else:
            # standard rows: linear [B, 0]; angular [Psi[:, :4], D] per body (sign: psi = -Psi)
            Y = np.zeros((len(rl) + len(ra), 20))
            for k in range(2):
                Y[:len(rl), 10 * k:10 * k + 4] = A[:, 4 * k:4 * k + 4]
                Y[len(rl):, 10 * k:10 * k + 4] = -psi[:, 10 * k:10 * k + 4]
                Y[len(rl):, 10 * k + 4:10 * k + 10] = phi[:, 6 * k:6 * k + 6]
            yy = np.concatenate([b, y])
            idx = self.pi_idx
            out = self._pi_out
            if len(out):
                yy = yy - Y[:, out].dot(self.pi_full[out])
            e, _ = self.rls.update(Y[:, idx], yy)
            self.pi_full[idx] = self.rls.x
            e_lin, e_ang = e[:len(rl)], e[len(rl):]
            phi, A = Y[len(rl):, idx], Y[:len(rl), idx]
            rhs_ang = yy[len(rl):]
        self.residual_lin = math.sqrt(e_lin.dot(e_lin)) / max(math.sqrt(b.dot(b)), 1e-300)
        self.residual_ang = math.sqrt(e_ang.dot(e_ang)) / max(math.sqrt(rhs_ang.dot(rhs_ang)),
                                                              1e-300)
        if self.solver == "joint":
            A, phi = A[:, self._lin_cols], phi[:, self._ang_cols]
        if self.lam == 1.0:
            self.info_lin = self.info_lin + A.T.dot(A)
            self.info_ang = self.info_ang + phi.T.dot(phi)
        else:
            self.info_lin = self.lam * self.info_lin + A.T.dot(A)
            self.info_ang = self.lam * self.info_ang + phi.T.dot(phi)

    # -- results --------------------------------------------------------------------------------
    def parameters(self):
        """Current estimate as ``(mu (8,), theta (12,))`` in the paper's parameterisation."""
        if self.solver == "paper":
            return self.mu_full.copy(), self.th_full.copy()
        mu, th = np.empty(8), np.empty(12)
        for k in range(2):
            m, b, I_c = rg.physical_from_standard(self.pi_full[10 * k:10 * k + 10])
            mu[4 * k], mu[4 * k + 1:4 * k + 4] = m, m * b
            th[6 * k:6 * k + 6] = rg.sharp_vector(I_c)
        return mu, th

    def estimates(self) -> dict:
        """``{'base': BodyEstimate, 'target': BodyEstimate}``."""
        mu, th = self.parameters()
        out = {}
        for k, who in enumerate(("base", "target")):
            m = mu[4 * k]
            out[who] = BodyEstimate(m, mu[4 * k + 1:4 * k + 4] / m,
                                    th[6 * k:6 * k + 6][rg.SHARP_TO_PROJECT])
        return out

    def vector(self) -> np.ndarray:
        """Estimates as one (20,) vector: per body m, b (3), I (6, project order)."""
        if self.solver == "paper":
            mu, th = self.mu_full, self.th_full
            out = np.empty(20)
            for k in range(2):
                m = mu[4 * k]
                out[10 * k] = m
                out[10 * k + 1:10 * k + 4] = mu[4 * k + 1:4 * k + 4] / m
                out[10 * k + 4:10 * k + 10] = th[6 * k:6 * k + 6][rg.SHARP_TO_PROJECT]
            return out
        e = self.estimates()
        return np.concatenate([np.concatenate([[x.m], x.b, x.I]) for x in (e["base"], e["target"])])

    def std(self) -> np.ndarray:
        """Standard deviations of :meth:`vector` (20,), residual-variance scaled.

        Parameters that are not identified (planar out-of-plane ones) report the square root of
        their prior covariance. Propagated with the first-order (delta-method) Jacobian of the
        map from the internal parameters to :meth:`vector`, written out in :meth:`_jacobian`.
        """
        cov, z, _ = self._covariance()
        J = self._jacobian(z)
        return np.sqrt(np.clip(np.einsum("ij,jk,ik->i", J, cov, J), 0.0, None))

    def _jacobian(self, z: np.ndarray) -> np.ndarray:
        """d vector / d z (20, 20) for the internal parameters ``z`` of :meth:`_covariance`.

        Per body (m, c = m b): ``b = c / m`` gives ``db/dc = I / m``, ``db/dm = -c / m^2``.
        Paper solver: the CoM inertia is a parameter (permuted). Joint solver:
        ``I_c = I_O - S(c) / m`` with ``S(c) = |c|^2 I - c c^T``, so ``dI_c/dI_O = I``,
        ``dI_c/dm = S / m^2`` and ``dI_c,ij/dc_k = -(2 c_k d_ij - d_ik c_j - c_i d_jk) / m``.
        """
        J = np.zeros((20, 20))
        perm = rg.SHARP_TO_PROJECT
        paper = self.solver == "paper"
        for k in range(2):
            o = 10 * k
            zm = 4 * k if paper else o                   # index of m (then c) in z
            m = z[zm]
            c = z[zm + 1:zm + 4]
            J[o, zm] = 1.0
            for i in range(3):
                J[o + 1 + i, zm + 1 + i] = 1.0 / m
                J[o + 1 + i, zm] = -c[i] / m**2
            zs = 8 + 6 * k if paper else o + 4           # the six inertia entries (paper order)
            for jp, p in enumerate(perm):                 # output jp <- paper-order entry p
                J[o + 4 + jp, zs + p] = 1.0
                if paper:
                    continue
                i, j = rg.SHARP_PAIRS[p]
                S_ij = (c @ c if i == j else 0.0) - c[i] * c[j]
                J[o + 4 + jp, zm] = S_ij / m**2
                for kk in range(3):
                    dS = (2.0 * c[kk] if i == j else 0.0) - (c[j] if kk == i else 0.0) \
                        - (c[i] if kk == j else 0.0)
                    J[o + 4 + jp, zm + 1 + kk] = -dS / m
        return J

    def _covariance(self):
        """Covariance of the internal parameter vector z, z itself, and z -> :meth:`vector`."""
        g0 = self.guess
        if self.solver == "paper":
            p = len(self.mu_idx)
            full = p == 8 and len(self.th_idx) == 12
            cov = np.empty((20, 20))
            Cmu = self.rls.lin.P * self.rls.lin.sigma2(p)
            TmA = self.rls.M.dot(rg.D_jacobian(self.mu_full))
            Cth = self.rls.ang.P * self.rls.ang.sigma2(len(self.th_idx))
            if full:
                Cmu_full, Tm = Cmu, TmA
            else:
                ix = self._cov_ix
                Cmu_full = g0.P0_mu * np.eye(8)
                Cmu_full[ix[0]] = Cmu
                # theta depends on mu through M: d theta / d mu = M dD/dmu
                Tm = np.zeros((12, 8))
                Tm[ix[1]] = TmA
                Cth_full = g0.P0_theta * np.eye(12)
                Cth_full[ix[2]] = Cth
                Cth = Cth_full
            cov[:8, :8] = Cmu_full
            TC = Tm.dot(Cmu_full)
            cov[8:, :8] = TC
            cov[:8, 8:] = TC.T
            cov[8:, 8:] = Cth + TC.dot(Tm.T)
            z = np.concatenate([self.mu_full, self.th_full])

            def g(z):
                out = []
                for k in range(2):
                    m = z[4 * k]
                    out += [[m], z[4 * k + 1:4 * k + 4] / m,
                            z[8 + 6 * k:8 + 6 * k + 6][rg.SHARP_TO_PROJECT]]
                return np.concatenate(out)
            return cov, z, g
        cov = np.diag([g0.P0_mu if i % 10 < 4 else g0.P0_theta for i in range(20)]).astype(float)
        cov[np.ix_(self.pi_idx, self.pi_idx)] = self.rls.P * self.rls.sigma2(len(self.pi_idx))

        def g(z):
            out = []
            for k in range(2):
                m, b, I_c = rg.physical_from_standard(z[10 * k:10 * k + 10])
                out += [[m], b, rg.sharp_vector(I_c)[rg.SHARP_TO_PROJECT]]
            return np.concatenate(out)
        return cov, self.pi_full.copy(), g

    def excitation(self):
        """Reciprocal condition numbers (scale-free) of the mass and inertia information.

        Computed when asked for (eigenvalues), then cached until the next accepted sample.
        """
        if self._exc is None:
            self._exc = (_rcond(self.info_lin), _rcond(self.info_ang))
        return self._exc

    # -- state ------------------------------------------------------------------------------------
    def get_state(self) -> dict:
        """Deep copy of everything that evolves (estimates, covariances, M, references, history)."""
        keep = ("rls", "mu_full", "th_full", "info_lin", "info_ang", "samples", "rejected",
                "status", "residual_lin", "residual_ang", "reference", "history")
        st = {k: _copy(getattr(self, k)) for k in keep}
        if self.solver == "joint":
            st["pi_full"] = self.pi_full.copy()
        return st

    def set_state(self, st: dict) -> None:
        for k, v in st.items():
            setattr(self, k, _copy(v))
        self._exc = None


#: attributes an update rebinds (restored by reference) and arrays it writes into (copied)
_UPDATED = ("info_lin", "info_ang", "samples", "status", "residual_lin", "residual_ang",
            "reference")
_WRITTEN = ("mu_full", "th_full", "pi_full")


def _split(E: np.ndarray):
    """``(A, b, phi, y, psi)`` views of the equation array (see :mod:`.kernels`)."""
    k = kernels
    return (E[:, k.COL_A:k.COL_B], E[:, k.COL_B], E[:, k.COL_PHI:k.COL_Y], E[:, k.COL_Y],
            E[:, k.COL_PSI:k.N_COLS])


def _copy(v):
    """Deep copy of a state entry; arrays, and containers of arrays, without deepcopy's memo
    bookkeeping (the state holds no shared or self-referencing objects)."""
    t = type(v)
    if t is np.ndarray:
        return v.copy()
    if t in (float, int, bool, str, type(None)):
        return v
    if t is tuple:
        return tuple(_copy(x) for x in v)
    if t is list:
        return [_copy(x) for x in v]
    if t is dict:
        return {k: _copy(x) for k, x in v.items()}
    return copy.deepcopy(v)


def _rcond(info: np.ndarray) -> float:
    dg = info.diagonal()
    if not min(dg.tolist()) > 0.0:              # a zero (or negative/NaN) diagonal entry
        d = np.sqrt(np.clip(dg, 0.0, None))
        if np.any(d == 0.0):
            return 0.0
    else:
        d = np.sqrt(dg)
    lam = np.linalg.eigvalsh(info / (d[:, None] * d))
    return float(max(lam[0], 0.0) / lam[-1])
