"""The identifier: measurements in, estimates of base and target out, one sample at a time.

Uses only the robot description (the known arm) and the measured signals of the interface
contract; never the plant. The identifier validates a sample, builds its equations (momentum or
force form, :class:`.layout.Method`) and keeps the bookkeeping around them (the
momentum reference, the differencing history, counters, status, diagnostics); a solver
(:mod:`.solvers`, :class:`.layout.Solver`) owns the parameters.
"""
from __future__ import annotations

import copy
import math
import numbers
import operator
from dataclasses import dataclass
from typing import Mapping, Tuple

import numpy as np

from .layout import (COM_SCALE_MIN, ROW_SD_PARAMETERS, SIGNAL_NOISE_PARAMETERS, AccelSource,
                     ExciteMode, Guess, Layout, Method, Solver, arm_arrays, body_of)
from . import consider, eiv, kernels, report_kernels
from .accel_bias import BiasFit
from .differencing import centre_derivative, derivative_weights, displacement_weights
from .physical import project_body, project_planar_body
from .solvers import ParameterSolver, make_solver
from .tracking import DriftTracker

#: measurement keys and their shapes (n = number of arm joints)
KEYS = ("r_S", "v_S", "A", "omega_B", "a_S", "alpha_B", "q", "qd", "qdd", "F", "M", "J", "H")

#: largest accepted input magnitude (SI units): far beyond any spacecraft state, far below
#: the magnitudes at which the equations' products would overflow
INPUT_LIMIT = 1e15

#: the validation rule for ``base.A``: a rotation matrix, ``max |A^T A - I| <= ROTATION_TOL``
#: and ``det A > 0`` (:func:`.kernels.rotation_error`, the one test both validation paths use)
ROTATION_TOL = 1e-6

# status codes (see spacerobot.interface.STATUS)
NO_SAMPLE, REFERENCE, ESTIMATING, REJECT_NONFINITE, REJECT_INCONSISTENT = 0, 1, 2, 3, 4


#: default relative standard deviation below which every estimate of a body counts as identified
SD_REL = 1e-3


@dataclass(frozen=True)
class Report:
    """What the estimator reports at one instant (:meth:`Identifier.report`).

    Attributes
    ----------
    vector : (20,) the estimates, each body a real rigid body: the least-squares estimate,
        projected onto real bodies where it is not one (:func:`.physical.project_body`; for a
        planar robot :func:`.physical.project_planar_body`, which keeps the identified entries)
    std : (20,) standard deviations of the least-squares estimate (:meth:`Identifier.std`)
    identified : {'base': bool, 'target': bool}, every identified estimate of the body has
        ``std <= sd_rel * error scale`` and is reported within that much of the least-squares
        estimate (and at least one sample was used)
    physical : {'base': bool, 'target': bool}, the least-squares estimate of the body was a
        real body already (False: ``vector`` holds its projection)
    """

    vector: np.ndarray
    std: np.ndarray
    identified: dict
    physical: dict


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
    method : Method or {'momentum', 'force'} or FMI code
        Momentum-based (eqs. 11/16, uses the impulses J, H) or force-based (eqs. 28/31, uses
        F, M and accelerations).
    solver : Solver or {'paper', 'joint'} or FMI code
        The paper's modified RLS over (mu, theta) (:class:`.PaperSolver`), or one RLS over the
        20 standard parameters (:class:`.JointSolver`).
    accel_source : AccelSource or {'measured', 'differenced'} or FMI code
        Force method only: measured accelerations, or derivatives of the velocities at the
        centre of a window of ``2 diff_half_window + 1`` samples, the whole equation evaluated
        at that centre (the estimate lags by ``diff_half_window`` samples;
        :mod:`.differencing`).
    lam : float
        Forgetting factor, 0 < lam <= 1.
    sd_rel : float
        Relative standard deviation below which a body counts as identified (:meth:`report`),
        0 < sd_rel < 1.
    row_sd : (float, float)
        Standard deviations of one row of the linear (masses, first moments) and of the
        angular (inertias) equation's error from the measurement noise, in the units of the
        method's equations (momentum: N.s, N.m.s; force: N, N.m). Each equation's rows are
        divided by theirs, so both equations, and the data against the prior ``P0``, weigh by
        their noise. 0: unit weight (no noise model; the equations as they are).
    diff_half_window : int
        ``m`` >= 1 of the differenced accelerations: 1 = the 3-point central difference,
        more = a Savitzky-Golay derivative over ``2m + 1`` samples (less noise).
    corr_lags : int
        Lags >= 0 of the residual autocorrelation that inflates the reported standard
        deviations for correlated equation errors (:class:`.uncertainty.Autocorrelation`);
        0 = rows taken as independent.
    window : float
        Moving reference [s] >= 0. Momentum: each sample's equations are differenced against
        the newest sample at least ``window`` seconds older (the first sample until then)
        instead of the first sample; force: likewise (a high-pass that removes constant
        equation errors, an accelerometer bias). 0 = the paper's equations (momentum: against
        the first sample; force: each sample alone). Any difference of two samples' valid
        equations is a valid equation: noise-free estimates stay exact.
    accel_bias : bool
        Force method with measured accelerations: subtract the accelerometer's bias,
        estimated online from the navigation velocity (:mod:`.accel_bias`). False = the
        accelerations as measured.
    moving_point : bool
        Momentum method: the angular rows about the base's position ``r_S`` at the newer
        sample of each difference (the same point for both samples: the rows minus
        ``[r_S]x`` times the linear rows) instead of the inertial origin, so that position,
        velocity and thrust errors do not enter multiplied by the distance the base drifted
        from the origin. False = the paper's (about the origin).
    thrust_sd : (float, float)
        Standard deviations of the thrust's scale factor error [1] and of its misalignment
        per axis [rad], constant over the run, the same for force and moment: a consider
        covariance (:mod:`.consider`) adds what they leave in the estimates to the reported
        standard deviations (the estimates are unchanged). (0, 0) = the thrust as measured
        is exact.
    signal_sd : mapping
        Force method: white-noise standard deviations per sample of the signals the
        accelerations come from, by measurement key: measured accelerations ``a_S``
        [m/s2], ``alpha_B`` [rad/s2], ``qdd`` [rad/s2]; differenced accelerations the
        velocities ``v_S`` [m/s], ``omega_B`` [rad/s], ``qd`` [rad/s] (the derivative's noise
        follows from its weights). With any > 0 the estimates are bias-compensated for the
        accelerations' noise (:mod:`.eiv`). Empty / 0 = the plain least-squares answers.
    diff_momentum : bool
        Force method with differenced accelerations: True = apply the derivative's weights to
        the momentum equations of the window's samples instead of to the velocities (the
        force equations averaged by the same filter, exact however fast the accelerations
        change between samples; :meth:`_differenced_momentum`, docs/identification.md,
        section 6). False = the force equations at the centre with the velocities'
        derivatives (exact only where the velocities are quadratic over the window).

    Attributes
    ----------
    layout : ParameterLayout     the identified parameters and equation rows of ``robot``
    solver : ParameterSolver     the parameters, their covariance and update

    Examples
    --------
    >>> ident = Identifier(robot, guess)              # doctest: +SKIP
    >>> status = ident.update(t, measurement_dict)    # doctest: +SKIP
    >>> ident.estimates()["target"].m                 # doctest: +SKIP
    """

    def __init__(self, robot, guess: Guess, method: Method | str = "momentum",
                 solver: Solver | str = "paper", accel_source: AccelSource | str = "measured",
                 lam: float = 1.0, sd_rel: float = SD_REL, row_sd=(0.0, 0.0),
                 diff_half_window: int = 1, corr_lags: int = 0, window: float = 0.0,
                 moving_point: bool = False, accel_bias: bool = False, thrust_sd=(0.0, 0.0),
                 signal_sd: Mapping[str, float] | None = None, diff_momentum: bool = False):
        method = Method.parse(method, "method")
        kind = Solver.parse(solver, "solver")
        accel_source = AccelSource.parse(accel_source, "accel_source")
        if not (0.0 < lam <= 1.0):
            raise ValueError(f"forgetting factor lambda must satisfy 0 < lambda <= 1, got {lam}")
        if not (0.0 < sd_rel < 1.0):
            raise ValueError(f"relative standard deviation threshold must satisfy "
                             f"0 < sd_rel < 1, got {sd_rel}")
        row_sd = tuple(float(x) for x in row_sd)
        if len(row_sd) != 2 or not all(x >= 0.0 and math.isfinite(x) for x in row_sd):
            raise ValueError(f"row standard deviations must be two finite numbers >= 0 "
                             f"(0 = unit weight), got {row_sd}")
        for name, val, low, high in (("differencing half window", diff_half_window, 1,
                                      MAX_HALF_WINDOW),
                                     ("correlation lags", corr_lags, 0, MAX_CORR_LAGS)):
            if not (math.isfinite(val) and int(val) == val and low <= val <= high):
                raise ValueError(f"{name} must be an integer from {low} to {high}, got {val}")
        window = _seconds(window, "reference window")
        thrust_sd = _thrust_sd(thrust_sd)
        moving_point = _flag(moving_point, "moving_point")
        accel_bias = _flag(accel_bias, "accel_bias")
        diff_momentum = _flag(diff_momentum, "diff_momentum")
        for name, body in (("guess.base", guess.base), ("guess.target", guess.target)):
            _check_body(name, body)
        for name, val in (("P0_mu", guess.P0_mu), ("P0_theta", guess.P0_theta)):
            if not (val > 0.0 and math.isfinite(val)):
                raise ValueError(f"{name} must be a finite covariance > 0, got {val}")
        self.robot, self.guess = robot, guess
        self.method, self.accel_source, self.lam, self.sd_rel = method, accel_source, lam, sd_rel
        self.row_sd, self.diff_half_window = row_sd, int(diff_half_window)
        self.window = window
        self.thrust_sd = thrust_sd
        # consider parameters' prior sd (8,); with any > 0 the equation array carries their
        # right-hand-side sensitivities as 16 more columns (:mod:`.consider`)
        self._sd_c, self._consider = consider.thrust_sd(*thrust_sd)
        self.signal_sd = _signal_sd(signal_sd, method, accel_source, window)
        self.moving_point = moving_point and method is Method.MOMENTUM
        self.accel_bias = accel_bias and method is Method.FORCE and (
            accel_source is AccelSource.MEASURED)
        self.diff_momentum = diff_momentum and method is Method.FORCE and (
            accel_source is AccelSource.DIFFERENCED)
        # row weights 1 / sd (1: unweighted, the rows untouched)
        self._w_lin, self._w_ang = (1.0 / x if x > 0.0 else 1.0 for x in row_sd)
        self.n = robot.n_joints
        self._geom = arm_arrays(robot)
        self._sizes = [3, 3, 9, 3, 3, 3, self.n, self.n, self.n, 3, 3, 3, 3]   # per KEYS entry
        self._n_flat = sum(self._sizes)
        n, q0 = self.n, kernels.Q0
        # (acceleration, velocity) slices of a flattened sample: a_S, alpha_B, qdd
        self._diff_slices = ((slice(kernels.A_S, kernels.A_S + 3), slice(kernels.V_S, kernels.V_S + 3)),
                             (slice(kernels.ALPHA_B, kernels.ALPHA_B + 3),
                              slice(kernels.OMEGA_B, kernels.OMEGA_B + 3)),
                             (slice(q0 + 2 * n, q0 + 3 * n), slice(q0 + n, q0 + 2 * n)))
        self.layout = Layout(robot)
        # the accelerations' noise sd per channel (.eiv), or None: no compensation
        self._accel_sd = (_channel_sd(self.signal_sd, accel_source, self.n)
                          if method is Method.FORCE else None)
        self._channels = eiv.accel_channels(self.n)
        self._vel_channels = eiv.velocity_channels(self.n)
        self.solver: ParameterSolver = make_solver(kind, self.layout, guess, lam, int(corr_lags))
        self.info_lin = np.zeros((len(self.layout.mu_active),) * 2)
        self.info_ang = np.zeros((len(self.layout.theta_active),) * 2)
        self.samples = 0
        self.rejected = 0
        self.status = NO_SAMPLE
        self.message = ""
        self.residual_lin = 0.0
        self.residual_ang = 0.0
        self.reference = None       # momentum method: terms at t0
        self.ring = ()              # window > 0: the (t, E) of the last `window` seconds
        self.bias_fit = BiasFit()   # accel_bias: the accelerometer bias's running fit
        self.history = []           # differenced accelerations: the window (t, flat sample);
        #                             diff_momentum: (t, own-point rows, their noise rows,
        #                             flat sample, momentum rows, momentum part)
        self._exc = None            # cached excitation() (cleared by update / set_state)
        self._reported = None       # what the fused step computed for the report (_kept)
        self.tracking = DriftTracker.empty(lam)   # the estimates' lag (:mod:`.tracking`)
        self.thrust = consider.ThrustIntegrals()   # momentum form with thrust_sd: int F, M

    # -- equations -----------------------------------------------------------------------------
    def _equations(self, flat: np.ndarray, t: float = 0.0):
        """The (3, 42) equation array ``[A | b | phi | y | psi]`` of one sample taken at ``t``
        (full 3D rows; see :mod:`.kernels`), from the flattened measurements: momentum form
        differenced against the reference sample (eqs. 11, 16), None for the first sample;
        with a window, differenced against the sample ``window`` earlier (:meth:`_windowed`);
        moving point: the angular rows about ``r_S`` of this sample (:func:`about_point`)."""
        force = self.method is Method.FORCE
        E = self._sample_rows(force, flat)
        if self.window > 0.0:
            dE = self._windowed(t, E)
        elif force:
            return E
        elif self.reference is None:
            self.reference = E
            return None
        else:
            dE = E - self.reference
        if self.moving_point and dE is not None:
            about_point(dE, flat[kernels.R_S:kernels.R_S + 3])
        return dE

    def _sample_rows(self, force: bool, flat: np.ndarray) -> np.ndarray:
        """The (3, 42 [+ 16]) equation array of one sample alone: force form (eqs. 28, 31) or
        momentum form before differencing (angular rows about the origin), with the thrust
        errors' consider columns if any (:mod:`.consider`)."""
        if not self._consider:
            E = np.empty((3, kernels.N_COLS))
            kernels.equations(force, flat, self.n, *self._geom, E)
            return E
        E = np.empty((3, kernels.N_COLS + 2 * consider.N_CONSIDER))
        kernels.equations(force, flat, self.n, *self._geom, E)
        o = kernels.Q0 + 3 * self.n                          # F, M, J, H
        consider.thrust_sensitivity(force, flat[o:o + 3], flat[o + 3:o + 6],
                                    flat[o + 6:o + 9], self.thrust, E[:, kernels.N_COLS:])
        return E

    def _windowed(self, t: float, E: np.ndarray):
        """``E - E_ref``, ``E_ref`` the newest stored sample at least ``window`` seconds before
        ``t`` (the oldest while the run is shorter); None for the first sample. "At least"
        to within 1e-9 s per second of ``t``: sample times ``k h`` carry round-off."""
        ring = self.ring + ((t, E),)
        k = 0
        limit = t - self.window + 1e-9 * max(1.0, abs(t))
        while k + 1 < len(ring) - 1 and ring[k + 1][0] <= limit:
            k += 1
        self.ring = ring[k:]
        if len(self.ring) == 1:
            return None
        return E - self.ring[0][1]

    def equations(self, s: dict):
        """``(A, b, phi, y, psi)`` for one sample, full 3D rows (before planar selection):
        ``A mu = b`` and ``phi theta = y + psi D(mu)``.

        Momentum: differences against the reference sample t0 (eqs. 11, 16). Returns None for
        the reference sample itself. Without a sample time: with a window use :meth:`rows`.
        """
        if self.window > 0.0:
            raise ValueError("equations() has no sample time; with a window use rows(t, s)")
        E = self._equations(np.concatenate([np.asarray(s[k], float).ravel() for k in KEYS]))
        return None if E is None else _split(E)

    def rows(self, t: float, meas: dict):
        """``(A, b, phi, y, psi)`` this sample contributes, as :meth:`update` would use them
        (full 3D rows, before the row weights and the planar selection), or None (a rejected
        sample, the momentum reference, a filling differencing window). Advances the
        references and histories as :meth:`update` does, but not the solver: for evaluating
        the equations at known parameters (:mod:`.noise_model`). A sample whose equations
        fail leaves the identifier as it was (as :meth:`update` does) and gives None."""
        status, _, flat = self._validate(meas)
        if flat is None or not math.isfinite(t) or not self._time_ok(t):
            return None
        before = self._snapshot()
        try:
            with np.errstate(all="ignore"):
                E, _ = self._sample_equations(t, flat)
            failed = E is not None and not np.all(np.isfinite(E))
        except (ArithmeticError, ValueError, np.linalg.LinAlgError):
            failed = True
        if failed:
            self._restore(before)
            return None
        return None if E is None else _split(E)

    # -- the update ------------------------------------------------------------------------------
    def validate(self, s: dict):
        """Return ``(status, message)``: ESTIMATING if the sample is usable."""
        return self._validate(s)[:2]

    def _validate(self, meas: dict):
        """``(status, message, flat)``; ``flat`` is the sample flattened in KEYS order (a new
        float array; ``A`` row-major), or None if the sample is rejected.

        One rule, two paths to it: a sample is accepted iff every signal has its shape, every
        value is finite with ``|x| <= INPUT_LIMIT``, and ``base.A`` passes the rotation test
        (:data:`ROTATION_TOL`). The fast path (one concatenation, one compiled check) accepts
        exactly those samples given as arrays; the careful path decides the rest with the same
        compiled rotation test and says what is wrong.
        """
        try:
            vals = [meas[k] for k in KEYS]
            vals[2] = np.ravel(vals[2])
            if [len(v) for v in vals] == self._sizes and np.shape(meas["A"]) == (3, 3):
                flat = np.concatenate(vals).astype(float, copy=False)
                if flat.ndim == 1 and kernels.sample_check(flat, INPUT_LIMIT, ROTATION_TOL) == 0:
                    return ESTIMATING, "", flat
        except (ValueError, TypeError, AttributeError):
            pass
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
        flat = np.concatenate(arrays)
        err, det = kernels.rotation_error(flat, kernels.A_B)
        if not (err <= ROTATION_TOL and det > 0.0):
            why = (f"base.A is not a rotation matrix (|A^T A - I| = {err:.3g} > "
                   f"{ROTATION_TOL:g} or det = {det:.6g} <= 0)")
            return REJECT_INCONSISTENT, why, None
        return ESTIMATING, "", flat

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
        return self._update(t, *self._validate(meas))

    def update_flat(self, t: float, flat: np.ndarray) -> int:
        """:meth:`update` with the sample given as one flat array: the signals of :data:`KEYS`
        one after the other, ``A`` row-major (``3 + 3 + 9 + 3 + 3 + 3 + 3 n + 4 * 3`` values;
        what the estimator FMU gathers from its inputs), so that it need not be split into a
        dictionary and concatenated again. The same checks and results as :meth:`update` with
        the dictionary of the same values.

        Parameters
        ----------
        t : float
            Sample time [s].
        flat : (6 + 3 n + 27,) array_like
            The sample, flattened as above. Copied.

        Returns
        -------
        status : int
            As :meth:`update`.
        """
        try:
            flat = np.array(flat, dtype=float)
        except (ValueError, TypeError) as e:
            return self._update(t, REJECT_INCONSISTENT, f"the sample is not numeric ({e})", None)
        if flat.shape != (self._n_flat,):
            return self._update(t, REJECT_INCONSISTENT, f"the flat sample has shape "
                                f"{flat.shape}, expected ({self._n_flat},)", None)
        if kernels.sample_check(flat, INPUT_LIMIT, ROTATION_TOL) == 0:
            return self._update(t, ESTIMATING, "", flat)
        return self.update(t, self._unflatten(flat))     # the careful path says what is wrong

    def _unflatten(self, flat: np.ndarray) -> dict:
        """The dictionary of :meth:`update` from a flat sample of the right length (views;
        ``A`` (3, 3))."""
        out, start = {}, 0
        for k, size in zip(KEYS, self._sizes):
            out[k] = flat[start:start + size].reshape((3, 3) if k == "A" else (size,))
            start += size
        return out

    def _update(self, t: float, status: int, message: str, flat) -> int:
        """:meth:`update` after the validation ``(status, message, flat)`` of the sample."""
        self.message = message
        if status != ESTIMATING or not math.isfinite(t):
            self.status = status if status != ESTIMATING else REJECT_NONFINITE
            if not math.isfinite(t):
                self.message = f"non-finite sample time {t}"
            self.rejected += 1
            return self.status
        if not self._time_ok(t):
            self.status, self.message = REJECT_INCONSISTENT, (
                f"differenced accelerations, the moving reference and the thrust integrals "
                f"need increasing sample times: t = {t:g} s after {self._last_time():g} s")
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
        """What an update may change, for :meth:`_restore`. Cheap: the solver's snapshot and
        the identifier's attributes are references (an update rebinds them, never writes into
        them), the history a shallow copy of its list."""
        return self.solver.snapshot(), _updated_of(self), list(self.history)

    def _restore(self, snap) -> None:
        solver, attrs, history = snap
        self.solver.restore(solver)
        for k, v in zip(_UPDATED, attrs):
            setattr(self, k, v)
        self.history = history

    def _time_ok(self, t: float) -> bool:
        """False if ``t`` does not advance past the last stored sample (differencing history,
        window ring, the thrust integrals of the consider term), which they need."""
        return not (t <= self._last_time())

    def _last_time(self) -> float:
        """The time of the newest sample the time-dependent state holds (-inf: none)."""
        last = -math.inf
        if self.history:
            last = self.history[-1][0]
        if self.ring:
            last = max(last, self.ring[-1][0])
        if self.thrust.t == self.thrust.t:            # not NaN: integrals started
            last = max(last, self.thrust.t)
        return last

    def _sample_equations(self, t: float, flat: np.ndarray):
        """``(E, noise)``: the equation array of a validated sample (differenced
        accelerations: of the window's centre), or None while a reference or window is being
        stored; and the noise rows of its accelerations (:mod:`.eiv`), or None."""
        if self.accel_bias:                          # a_S - the bias estimated so far
            k = kernels
            self.bias_fit = self.bias_fit.add(t, flat[k.V_S:k.V_S + 3], flat[k.A_S:k.A_S + 3])
            flat = flat.copy()
            flat[k.A_S:k.A_S + 3] -= self.bias_fit.bias()
        if self._consider and (self.method is Method.MOMENTUM or self.diff_momentum):
            o = kernels.Q0 + 3 * self.n
            self.thrust = self.thrust.add(t, flat[kernels.R_S:kernels.R_S + 3], flat[o:o + 3],
                                          flat[o + 3:o + 6])
        sd = self._accel_sd
        if self.diff_momentum:
            return self._differenced_momentum(t, flat)
        if self.method is Method.FORCE and self.accel_source is AccelSource.DIFFERENCED:
            centre = self._differenced(t, flat)
            if centre is None:
                return None, None
            t, flat, gain = centre
            sd = None if sd is None else sd * gain             # the derivative's noise
        E = self._equations(flat, t)
        if sd is None or E is None:
            return E, None
        equations = lambda x, out: kernels.equations(True, x, self.n, *self._geom, out)  # noqa: E731
        return E, _split(eiv.noise_rows(equations, flat, E, self._channels, sd))

    def _accept(self, t: float, flat: np.ndarray) -> int:
        """The update proper, for a validated sample (see :meth:`update`)."""
        E, noise = self._sample_equations(t, flat)
        if E is None:
            self.status = REFERENCE
            return self.status
        b_c, y_c = _split_consider(E) if self._consider else (None, None)
        # the tracker's clock is the sample count: the estimates depend on the samples, not on
        # the step sizes between them (a rate per sample times an age in samples)
        clock = float(self.samples)
        if self.solver.fuses(b_c, noise):            # the same steps in one compiled call
            ((self.residual_lin, self.residual_ang), (self.info_lin, self.info_ang),
             self.tracking, rcond, (vec, sd)) = self.solver.step(
                *self._identified_rows(*_split(E)), (self.info_lin, self.info_ang),
                self.tracking, clock)
            self._reported = (self.tracking, self.solver.mu, self.solver.theta, vec, sd)
        else:
            info = self.solver.information()
            self._solve(*_split(E), b_c, y_c, noise)
            u = self.solver.std_parts()
            self.tracking = self.solver.track(self.tracking, clock, u.data_only, u.sd, info,
                                              u.jacobian)
            rcond = u.rcond
        # the excitation diagnostics, where the standard deviations' spectra gave them
        self._exc = None if rcond is None else (float(rcond[0]), float(rcond[1]))
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
            if self.ring:
                total += self.ring[-1][1].sum()
            total += self.bias_fit.sx.sum()
        return math.isfinite(total)

    def _differenced(self, t: float, flat: np.ndarray):
        """The sample at the centre of the window of the last ``2m + 1`` (flattened samples,
        see :meth:`_validate`), its accelerations the derivatives of its velocities at its
        time (:func:`.differencing.centre_derivative`): every row of its equations belongs to
        one instant.

        Returns ``(t_c, completed centre sample, |w|)``, ``|w|`` [1/s] the norm of the
        derivative's weights (white velocity noise ``sigma`` gives a derivative noise
        ``sigma |w|``), or None while the window is not full.
        """
        k = 2 * self.diff_half_window + 1
        self.history = self.history + [(t, flat)]
        if len(self.history) < k:
            return None
        window, self.history = self.history, self.history[1:]
        t_c, flat_c = centre_derivative(window, self._diff_slices)
        times = np.array([tk for tk, _ in window])
        gain = float(np.linalg.norm(derivative_weights(times, self.diff_half_window)))
        return t_c, flat_c, gain

    def _differenced_momentum(self, t: float, flat: np.ndarray):
        """``(E, noise)`` of the momentum equations differentiated at the centre ``c`` of the
        window of the last ``2m + 1`` samples by the derivative's weights ``w``
        (:mod:`.differencing`), or ``(None, None)`` while the window fills.

        The momentum equations hold at every sample, so for any weights with ``sum w = 0``
        (the unknown initial momentum cancels) ``sum_i w_i E_mom(t_i)`` holds exactly: the
        force equations averaged by the derivative's filter, with no truncation error however
        fast the accelerations change between samples. The angular rows about the centre's
        ``r_c`` need the base's displacements ``r_i - r_c``; measured positions (navigation
        noise times the system's momentum, over the step) would swamp them, so they are
        integrated from the velocities. With ``P_i`` the momentum (a row in ``mu``), ``J_i``
        the impulse, ``P_i = P_c + J_i - J_c`` (at the truth), ``tau_i = t_i - t_c``::

            sum_i w_i (L_O,i - [r_c]x (P_i - J_i))
              = sum_i w_i (L_O,i - [r_i]x P_i)             own point: no position needed
              + [sum_i w_i (r_i - r_c)]x P_c               = [u . v]x P_c (velocities)
              + sum_i w_i [r_i - r_c]x (J_i - J_c)         ~ [v_c]x sum_i w_i tau_i (J_i - J_c)
              + [r_c]x sum_i w_i J_i

        (``u``: :func:`.differencing.displacement_weights`, exact for velocities polynomial
        over the window; the third line's neglected part is of order ``a x F h^2``).
        ``noise``: the rows ``sigma_l C_l`` of every sample's velocity channels (the rows are
        affine in the velocities: the ``[u v]x P(v)`` term's quadratic part is
        ``[e]x (m e)`` = 0; :mod:`.eiv`), or None.
        """
        E = self._sample_rows(False, flat)
        Mom = _momentum_part(E, flat, self.n)
        own = E.copy()
        about_point(own, flat[kernels.R_S:kernels.R_S + 3], lin_of=Mom)    # L_O - [r_i]x P_i
        C = None
        if self._accel_sd is not None:
            C = eiv.noise_rows(self._own_point_into, flat, own, self._vel_channels,
                               self._accel_sd)
        self.history = self.history + [(t, own, C, flat, E, Mom)]
        m = self.diff_half_window
        if len(self.history) < 2 * m + 1:
            return None, None
        window, self.history = self.history, self.history[1:]
        times = np.array([s[0] for s in window])
        w = derivative_weights(times, m)
        u = displacement_weights(times, m, w)
        x_c, Mom_c = window[m][3], window[m][5]
        vs = slice(kernels.V_S, kernels.V_S + 3)
        v_u = sum(uj * s[3][vs] for uj, s in zip(u, window))              # sum w (r - r_c)
        out = sum(wi * s[1] for wi, s in zip(w, window))                  # d/dt momentum ~ force
        imp = sum(wi * (s[4] - s[5]) for wi, s in zip(w, window))         # b = sum w J
        about_point(out, x_c[kernels.R_S:kernels.R_S + 3], lin_of=imp)    # + [r_c]x sum w J
        about_point(out, -v_u, lin_of=Mom_c)                              # + [u.v]x P_c
        imp_c = window[m][4] - Mom_c
        lever = sum(wi * (ti - times[m]) * (s[4] - s[5] - imp_c)
                    for wi, ti, s in zip(w, times, window))
        about_point(out, x_c[vs], lin_of=lever)                  # + [v_c]x sum w tau (J - J_c)
        if C is None:
            return out, None
        blocks = []
        for j, (wj, uj, s) in enumerate(zip(w, u, window)):
            Cj = wj * s[2]                                   # (3 L, N_COLS), sigma_l C_l
            for b, l in enumerate(np.flatnonzero(self._accel_sd > 0.0)):
                blk = Cj[3 * b:3 * b + 3]
                if l < 3:                                    # v_S: [u_j sigma e_l]x P_c
                    e = np.zeros(3)
                    e[l] = uj * self._accel_sd[l]
                    about_point(blk, -e, lin_of=Mom_c)
                if j == m:                                   # the centre's P_c: [u.v]x dP_c
                    about_point(blk, -v_u, lin_of=s[2][3 * b:3 * b + 3])
            blocks.append(Cj)
        return out, _split(np.concatenate(blocks))

    def _own_point_into(self, x: np.ndarray, out: np.ndarray) -> None:
        """The momentum equation array (3, N_COLS) of the flat sample ``x`` into ``out``, its
        momentum's angular rows about its own ``r_S`` (the impulse's about the origin):
        ``L_O - [r]x P`` (:meth:`_differenced_momentum`)."""
        kernels.equations(False, x, self.n, *self._geom, out)
        about_point(out, x[kernels.R_S:kernels.R_S + 3], lin_of=_momentum_part(out, x, self.n))

    def _solve(self, A, b, phi, y, psi, b_c=None, y_c=None, noise=None):
        """The solver's update on the identified rows, then the residuals and information;
        ``b_c``, ``y_c`` (3, 8): the right-hand sides' consider sensitivities, or None;
        ``noise``: the accelerations' noise rows ``(A, b, phi, y, psi)`` (3 per noisy
        channel), or None."""
        A, b, phi, y, psi = self._identified_rows(A, b, phi, y, psi)
        if b_c is not None:
            b_c, y_c = self._identified_rows(b_c, y_c)
        if noise is not None:
            noise = self._identified_rows(*noise)
        st = self.solver.update(A, b, phi, y, psi, b_c, y_c, noise)
        self.residual_lin = _relative_norm(st.e_lin, st.rhs_lin)
        self.residual_ang = _relative_norm(st.e_ang, st.rhs_ang)
        if self.lam == 1.0:
            self.info_lin = self.info_lin + st.H_lin.T.dot(st.H_lin)
            self.info_ang = self.info_ang + st.H_ang.T.dot(st.H_ang)
        else:
            self.info_lin = self.lam * self.info_lin + st.H_lin.T.dot(st.H_lin)
            self.info_ang = self.lam * self.info_ang + st.H_ang.T.dot(st.H_ang)

    def _identified_rows(self, *rows):
        """Rows ``(A, b, phi, y, psi)``, or right-hand sides ``(b, y)``, weighted by their
        noise (``1 / row_sd``) and reduced to the identified rows (planar robots); every
        block of 3 rows is one sample's x, y, z rows."""
        L = self.layout
        lin, ang = (rows[:2], rows[2:]) if len(rows) == 5 else (rows[:1], rows[1:])
        if self._w_lin != 1.0:
            lin = tuple(r * self._w_lin for r in lin)
        if self._w_ang != 1.0:
            ang = tuple(r * self._w_ang for r in ang)
        if not L.complete:
            lin = tuple(_rows_of(r, L.rows_lin) for r in lin)
            ang = tuple(_rows_of(r, L.rows_ang) for r in ang)
        return lin + ang

    # -- results --------------------------------------------------------------------------------
    def vector(self) -> np.ndarray:
        """Estimates as one (20,) vector in the order of
        :data:`spacerobot.interface.ESTIMATE_NAMES`: per body m, b (3), I (6)."""
        kept = self._kept()
        return self.solver.vector() if kept is None else kept[0].copy()

    def _kept(self):
        """``(vector, std)`` as the fused step computed them with the state it left
        (:meth:`.PaperSolver.step`), while that state is the current one (the tracker and the
        solver's vectors are those it made: an update rebinds them, never writes into them;
        a restored or copied state has others); else None. The fused step runs only with
        samples and without the consider term, so what it kept is the full report."""
        k = self._reported
        if (k is not None and k[0] is self.tracking and k[1] is self.solver.mu
                and k[2] is self.solver.theta):
            return k[3], k[4]
        return None

    def std(self) -> np.ndarray:
        """Standard deviations of :meth:`vector` (20,) (:meth:`.ParameterSolver.uncertainty`).

        ``sd^2`` = the data's scatter (solver covariance times the a-posteriori residual
        variance) + the square of the prior's pull (the distance from the estimate to the
        data-only least-squares answer), both through the delta-method Jacobian of the map from
        the solver's parameters to :meth:`vector`, + the part of the estimates' lag behind
        moving parameters that these do not explain (:func:`.tracking.total_sd`), + with
        ``thrust_sd`` the thrust errors' consider variance (:mod:`.consider`). Without
        noise the pull is the estimate's error itself (to first order). An estimate the data
        do not determine yet reports at least its error scale (100 %). Parameters that are not
        identified (planar out-of-plane ones) report the square root of their prior
        covariance.
        """
        if not self.samples:
            return self.solver.std()
        kept = self._kept()
        if kept is not None:
            return kept[1].copy()
        sd = self.tracking.total_sd()
        if self._consider:                           # + the thrust errors' share (.consider)
            s = self.solver
            sd_c = consider.consider_sd(s.jacobian(s.z()), s.consider_shift(), self._sd_c)
            sd = np.sqrt(sd * sd + sd_c * sd_c)
        return sd

    def report(self) -> Report:
        """The estimates as reported: physically consistent, with their standard deviations,
        and whether each body is identified (see :class:`Report`).

        The projection acts on the output only: the solver keeps the exact least-squares
        state, so the report equals :meth:`vector` as soon as that is physical.
        """
        kept = self._kept()
        ls, sd = (self.vector(), self.std()) if kept is None else (kept[0], kept[1].copy())
        out = ls.copy()
        # physical flags, and identified: small standard deviation, and the reported value is
        # the estimate's (|sd| and |out - ls| <= sd_rel * scale), for every identified entry of
        # the body; one call where both are physical (out = ls)
        flags = np.empty(4, bool)
        if not report_kernels.report_flags(ls, sd, COM_SCALE_MIN, self.sd_rel,
                                           self.layout.identified, flags):
            project = project_planar_body if self.robot.planar else project_body
            for b, g in zip(self.layout.bodies, (self.guess.base, self.guess.target)):
                if not flags[b.index]:
                    m, com, I6, _ = project(ls[b.m], ls[b.first], ls[b.inertia], g.mass)
                    out[b.m], out[b.first], out[b.inertia] = m, com, I6
            scale = report_kernels.error_scale(out, COM_SCALE_MIN)    # layout.error_scale(out)
            report_kernels.identified_bodies(sd, out, ls, scale, self.sd_rel,
                                             self.layout.identified, flags[2:])
        base, target = self.layout.bodies
        some = self.samples > 0
        return Report(out, sd, {base.name: bool(some and flags[2 + base.index]),
                                target.name: bool(some and flags[2 + target.index])},
                      {base.name: bool(flags[base.index]), target.name: bool(flags[target.index])})

    def estimates(self) -> dict:
        """``{'base': BodyEstimate, 'target': BodyEstimate}`` (the least-squares estimates;
        :meth:`report` has the physically consistent ones)."""
        vec = self.vector()
        return {b.name: BodyEstimate(float(vec[b.m]), vec[b.first], vec[b.inertia])
                for b in self.layout.bodies}

    def excitation(self):
        """Reciprocal condition numbers (scale-free) of the mass and inertia information.

        The paper solver's update computes them with its standard deviations (the spectra of
        the same scaled information, :func:`.report_kernels.rcond_of_spectrum`); otherwise
        (the joint solver, after a restored state) computed when asked for (:func:`_rcond`),
        then cached until the next accepted sample. The two agree to round-off.
        """
        if self._exc is None:
            self._exc = (_rcond(self.info_lin), _rcond(self.info_ang))
        return self._exc

    # -- state ------------------------------------------------------------------------------------
    def get_state(self) -> dict:
        """Deep copy of everything that evolves (estimates, covariances, M, references, history,
        the excitation diagnostics the last update computed)."""
        st = {k: _copy(getattr(self, k)) for k in _UPDATED + ("rejected", "history")}
        st["solver"] = _copy(self.solver.snapshot())
        return st

    def set_state(self, st: dict) -> None:
        st = dict(st)
        self.solver.restore(_copy(st.pop("solver")))
        self._exc = None                 # (a state without them: computed when asked for)
        for k, v in st.items():
            setattr(self, k, _copy(v))


try:       # the gufunc of np.linalg.eigvalsh (lower triangle), for _rcond's short path
    from numpy.linalg._umath_linalg import eigvalsh_lo as _EIGVALSH
except ImportError:                                        # pragma: no cover - other NumPy
    _EIGVALSH = None

#: largest ``diff_half_window`` (samples each side of the differencing window's centre)
MAX_HALF_WINDOW = 50
#: largest ``corr_lags`` (lags of the residual autocorrelation kept per solver)
MAX_CORR_LAGS = 10_000
#: largest reference window [s]
MAX_WINDOW = 1e6
#: largest thrust scale-factor / misalignment standard deviation (1, rad)
MAX_THRUST_SD = 1.0

#: attributes of the identifier an update rebinds (restored by reference)
_UPDATED = ("info_lin", "info_ang", "samples", "status", "residual_lin", "residual_ang",
            "reference", "ring", "bias_fit", "tracking", "thrust", "_exc")
#: their values, in that order, in one call (:meth:`Identifier._snapshot`)
_updated_of = operator.attrgetter(*_UPDATED)


def about_point(dE: np.ndarray, p: np.ndarray, lin_of: np.ndarray | None = None) -> None:
    """The angular rows of a momentum difference ``dE`` (3, 42 [+ 16]) about the point ``p`` (3,)
    instead of the origin, in place: ``L_p = L_O - p x P`` and ``H_p = H_O - p x J``, so the
    angular residual becomes ``r_ang - [p]x r_lin`` with ``r_lin = A mu - b``,
    ``r_ang = phi theta - y - psi D(mu)``: ``y -= [p]x b`` and, ``mu`` being the entries
    ``m, m b`` of ``D(mu)`` of each body, ``psi[:, D index of mu] += [p]x A``. ``lin_of``:
    take ``r_lin`` from this array (same columns) instead of ``dE``'s own linear rows."""
    k = kernels
    P = consider.skew(p)                                 # [p]x
    src = dE if lin_of is None else lin_of
    lin = P @ src[:, k.COL_A:k.COL_B + 1]
    dE[:, k.COL_Y] -= lin[:, 8]                          # y' = y - [p]x b
    dE[:, k.COL_PSI:k.COL_PSI + 4] += lin[:, 0:4]        # base m, m b
    dE[:, k.COL_PSI + 10:k.COL_PSI + 14] += lin[:, 4:8]  # target m, m b
    if dE.shape[1] > k.N_COLS:                           # consider columns: y_c -= [p]x b_c
        y_c = _split_consider(dE)[1]
        y_c -= P @ _split_consider(src)[0]


def _momentum_part(E: np.ndarray, flat: np.ndarray, n: int) -> np.ndarray:
    """The linear rows of a momentum equation array ``E`` without the impulse: ``A mu = b - J``
    (residual ``P``, the system's momentum; ``b = J - P_arm``), no consider columns (only the
    impulse depends on the thrust). Same columns as ``E``; only the linear rows are meaningful."""
    out = np.zeros_like(E)
    k = kernels
    out[:, k.COL_A:k.COL_B] = E[:, k.COL_A:k.COL_B]
    o = k.Q0 + 3 * n + 6                                 # J
    out[:, k.COL_B] = E[:, k.COL_B] - flat[o:o + 3]
    return out


def _relative_norm(e: np.ndarray, rhs: np.ndarray) -> float:
    """``|e| / |rhs|`` (``|rhs|`` floored at 1e-300)."""
    return math.sqrt(e.dot(e)) / max(math.sqrt(rhs.dot(rhs)), 1e-300)


def _split(E: np.ndarray):
    """``(A, b, phi, y, psi)`` views of the equation array (see :mod:`.kernels`)."""
    k = kernels
    return (E[:, k.COL_A:k.COL_B], E[:, k.COL_B], E[:, k.COL_PHI:k.COL_Y], E[:, k.COL_Y],
            E[:, k.COL_PSI:k.N_COLS])


def _rows_of(r: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """The rows ``keep`` (of 0, 1, 2) of every block of 3 rows of ``r``."""
    if len(r) == 3:
        return r[keep]
    return r.reshape(len(r) // 3, 3, *r.shape[1:])[:, keep].reshape(-1, *r.shape[1:])


def _split_consider(E: np.ndarray):
    """``(b_c, y_c)`` (3, 8) views of the consider columns of an equation array that has
    them (:mod:`.consider`)."""
    n, c = kernels.N_COLS, consider.N_CONSIDER
    return E[:, n:n + c], E[:, n + c:n + 2 * c]


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


def _windows(values: Mapping[str, float]) -> dict:
    """``{Method: window [s]}`` from ``ident.momentum_window`` and ``ident.force_window`` (both
    checked, as the row standard deviations of both methods are)."""
    names = {m: f"ident.{m.name.lower()}_window" for m in Method}
    return {m: _seconds(values.get(n, 0.0), n) for m, n in names.items()}   # (force: gone)


def _seconds(x, name: str) -> float:
    """A reference window [s] from 0 to :data:`MAX_WINDOW`, as a float."""
    real = isinstance(x, numbers.Real)
    if not (real and math.isfinite(x) and 0.0 <= x <= MAX_WINDOW):
        raise ValueError(f"{name} must be a number of seconds from 0 to {MAX_WINDOW:g}, "
                         f"got {x if real else repr(x)}")
    return float(x)


#: signals whose noise the errors-in-variables compensation takes (.eiv), per acceleration
#: source: the accelerations as measured, or the velocities they are differenced from
SIGNAL_SD_KEYS = {src: tuple(k for k, _, s in SIGNAL_NOISE_PARAMETERS if s == src.name.lower())
                  for src in AccelSource}


def _signal_sd(signal_sd, method: Method, source: AccelSource, window: float) -> dict:
    """The checked ``signal_sd`` option: ``{key: sd}`` (floats >= 0) for keys of
    :data:`SIGNAL_SD_KEYS`; only the force method uses it, and not with a force window."""
    out = {}
    known = {k for keys in SIGNAL_SD_KEYS.values() for k in keys}
    for key, x in dict(signal_sd or {}).items():
        if key not in known:
            raise ValueError(f"signal_sd: unknown signal {key!r}; known: {sorted(known)}")
        if not (isinstance(x, numbers.Real) and math.isfinite(x) and x >= 0.0):
            name = dict((k, n) for k, n, _ in SIGNAL_NOISE_PARAMETERS)[key]
            raise ValueError(f"ident.noise.{name} (signal_sd[{key!r}]) must be a finite number "
                             f">= 0, got {x!r}")
        out[key] = float(x)
    if any(out.values()) and method is Method.FORCE and window > 0.0:
        raise ValueError("the accelerations' noise compensation (signal_sd) does not apply to "
                         "force-window differences (ident.force_window > 0)")
    return out


def _channel_sd(signal_sd: dict, source: AccelSource, n: int):
    """Noise sd (6 + n,) of ``a_S``, ``alpha_B``, ``qdd`` (for differenced accelerations:
    of the velocities, times the derivative's gain later), or None if all are 0."""
    a, alpha, arm = (signal_sd.get(k, 0.0) for k in SIGNAL_SD_KEYS[source])
    if not (a or alpha or arm):
        return None
    return np.array([a] * 3 + [alpha] * 3 + [arm] * n)


#: the thrust's standard deviations (scale factor, misalignment) as FMU parameters
THRUST_SD_NAMES = ("ident.sd_thrust.scale", "ident.sd_thrust.misalign")


def _thrust_sd(pair, names=("thrust_sd scale factor", "thrust_sd misalignment [rad]")
               ) -> Tuple[float, float]:
    """``(scale, misalignment)``, each a number from 0 to :data:`MAX_THRUST_SD` (``names``
    for the error message: the constructor's option or the FMU parameters)."""
    pair = tuple(pair)
    if len(pair) != 2:
        raise ValueError(f"thrust standard deviations must be two numbers (scale factor, "
                         f"misalignment [rad]), got {pair!r}")
    for x, name in zip(pair, names):
        if not (isinstance(x, numbers.Real) and 0.0 <= x <= MAX_THRUST_SD):
            raise ValueError(f"{name} must be a number from 0 to {MAX_THRUST_SD:g}, got {x!r}")
    return float(pair[0]), float(pair[1])


def _flag(x, name: str) -> bool:
    """An FMI Integer switch, 0 or 1."""
    if x not in (0, 1):
        raise ValueError(f"{name} must be 0 or 1, got {x}")
    return bool(x)


def _rcond(info: np.ndarray) -> float:
    """Reciprocal condition number ``max(lam_min, 0) / lam_max`` of the information ``info``
    (p, p) scaled to unit diagonal (``info / (d d^T)``, ``d = sqrt(diag info)``); 0 where a
    diagonal entry is 0.

    The excitation diagnostics are recorded at every communication step, so the usual case
    (every diagonal entry > 0, finite entries) takes a short path: the scaling in one compiled
    call (:func:`.report_kernels.rcond_scaled`, the same divisions) and LAPACK's
    eigenvalues through NumPy's gufunc itself (what ``np.linalg.eigvalsh`` calls, without its
    argument checks and error-state set-up): the same numbers. Anything else, or a result
    that is not a number, goes through :func:`_rcond_numpy` (its errors and warnings too).
    """
    if _EIGVALSH is not None:
        Gs, ok = report_kernels.rcond_scaled(info)
        if ok:
            lam = _EIGVALSH(Gs, signature="d->d").tolist()
            lo, hi = lam[0], lam[-1]
            if lo == lo and hi == hi:                    # not NaN: converged
                return float(max(lo, 0.0) / hi)
    return _rcond_numpy(info)


def _rcond_numpy(info: np.ndarray) -> float:
    """:func:`_rcond` in NumPy (the reference of its short path; every case)."""
    dg = info.diagonal()
    if not min(dg.tolist()) > 0.0:              # a zero (or negative/NaN) diagonal entry
        d = np.sqrt(np.clip(dg, 0.0, None))
        if np.any(d == 0.0):
            return 0.0
    else:
        d = np.sqrt(dg)
    lam = np.linalg.eigvalsh(info / (d[:, None] * d))
    return float(max(lam[0], 0.0) / lam[-1])



@dataclass(frozen=True)
class ExcitationRequest:
    """The excitation level the estimator asks the plant for (output ``ident.excite``).

    Parameters
    ----------
    mode : :class:`.layout.ExciteMode` (member, code or label)
        OFF: 0. UNTIL_IDENTIFIED: ``level`` while a body is not identified, 0 once both are.
        ALWAYS: ``level`` (keeps the parameters observable, for tracking slow changes with a
        forgetting factor).
    level : float
        Requested level, 0..1.
    """

    mode: ExciteMode = ExciteMode.UNTIL_IDENTIFIED
    level: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "mode", ExciteMode.parse(self.mode, "ident.excite_mode"))
        if not (0.0 <= self.level <= 1.0):
            raise ValueError(f"ident.excite_level must be in [0, 1], got {self.level}")

    def __call__(self, identified: dict) -> float:
        """The level for the bodies' identified flags (:attr:`Report.identified`)."""
        if self.mode is ExciteMode.ALWAYS or (self.mode is ExciteMode.UNTIL_IDENTIFIED
                                              and not all(identified.values())):
            return float(self.level)
        return 0.0


def _check_body(name: str, body) -> None:
    """A real body: finite, m > 0, the inertia positive definite with its principal moments
    obeying the triangle inequality (to 1e-12 of the largest); ValueError naming it else."""
    values = [body.mass, *body.com, *body.inertia]
    I = np.empty((3, 3))
    for v, (i, j) in zip(body.inertia, ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))):
        I[i, j] = I[j, i] = v
    ok = all(math.isfinite(v) for v in values) and body.mass > 0.0
    if ok:
        w = np.linalg.eigvalsh(I)
        ok = w[0] > 0.0 and w[2] <= w[0] + w[1] + 1e-12 * w[2]
    if not ok:
        raise ValueError(f"{name} is not a real rigid body: mass {body.mass!r}, inertia "
                         f"{list(body.inertia)!r}")


def row_sd(values: Mapping[str, float], method: Method) -> Tuple[float, float]:
    """``(linear, angular)`` row standard deviations of ``method`` from the estimator's
    parameter values, every pair checked."""
    for suffix, _ in ROW_SD_PARAMETERS:
        x = float(values[f"ident.sd_row.{suffix}"])
        if not (math.isfinite(x) and x >= 0.0):
            raise ValueError(f"ident.sd_row.{suffix} must be a finite number >= 0 "
                             f"(0 = unit weight), got {x}")
    return tuple(float(values[f"ident.sd_row.{suffix}"])
                 for suffix, m in ROW_SD_PARAMETERS if m is method)


def identifier_from_values(robot, values: Mapping[str, float]
                           ) -> Tuple[Identifier, ExcitationRequest]:
    """The estimator core and its excitation request from the estimator FMU's parameter values
    (names of :func:`spacerobot.interface.estimator_vars`): what the FMU builds at
    initialisation, and ``spacerobot identify`` on recorded telemetry. Raises ``ValueError``
    for an invalid value."""
    v = values
    codes = [code.parse(int(v[name]), name) for name, code in (
        ("method", Method), ("solver", Solver), ("accel_source", AccelSource))]
    guess = Guess(body_of(v, "guess.base"), body_of(v, "guess.target"), float(v["P0_mu"]),
                  float(v["P0_theta"]))
    ident = Identifier(robot, guess, *codes, float(v["lambda"]), sd_rel=float(v["ident.sd_rel"]),
                       row_sd=row_sd(v, codes[0]),
                       diff_half_window=int(v["ident.diff_half_window"]),
                       corr_lags=int(v["ident.corr_lags"]),
                       window=_windows(v)[codes[0]],
                       moving_point=_flag(v["ident.momentum_point"], "ident.momentum_point"),
                       accel_bias=_flag(v["ident.accel_bias"], "ident.accel_bias"),
                       thrust_sd=_thrust_sd([v[n] for n in THRUST_SD_NAMES], THRUST_SD_NAMES),
                       diff_momentum=_flag(v["ident.diff_momentum"], "ident.diff_momentum"),
                       signal_sd={key: v[f"ident.noise.{name}"]
                                  for key, name, _ in SIGNAL_NOISE_PARAMETERS})
    return ident, ExcitationRequest(int(v["ident.excite_mode"]), float(v["ident.excite_level"]))
