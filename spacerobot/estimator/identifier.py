"""The identifier: measurements in, estimates of base and target out, one sample at a time.

Uses only the robot description (the known arm) and the measured signals of the interface
contract; never the plant. Runs on the native C core (``native/src/estimator.h``, bound by
:class:`spacerobot.core.estimator.NativeEstimator`): the one implementation of the estimator
that the estimator FMU, ``spacerobot identify``, the Monte Carlo and this class share. This
module maps the Python arguments onto the core's options (by the estimator FMU's parameter
names; the core checks them and its message is the error), flattens the samples in the core's
order (the sample's table, :mod:`spacerobot.core.sample`) and builds the :class:`Report` and
:class:`BodyEstimate` from the core's report.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping, Optional, Tuple

import numpy as np

from ..core import estimator as _core
from ..core import sample as _sample
from ..interface import SIGNAL_NOISE_PARAMETERS, AccelSource, Method, ParameterLayout, Solver
from ..robots import Guess, RigidBody, Robot

__all__ = ["Identifier", "Report", "BodyEstimate", "identifier_from_values", "KEYS",
           "INPUT_LIMIT", "ROTATION_TOL", "SD_REL"]

#: the sample's signals (keys) in the order of a flat sample (native/src/sample.h)
KEYS = _sample.keys()

#: largest accepted input magnitude (SI units): far beyond any spacecraft state, far below
#: the magnitudes at which the equations' products would overflow (the core's)
INPUT_LIMIT = _core.input_limit()

#: the validation rule for ``base.A``: a rotation matrix, ``max |A^T A - I| <= ROTATION_TOL``
#: and ``det A > 0`` (the core's)
ROTATION_TOL = _core.rotation_tol()

# status codes (see spacerobot.interface.STATUS)
NO_SAMPLE, REFERENCE, ESTIMATING, REJECT_NONFINITE, REJECT_INCONSISTENT = 0, 1, 2, 3, 4

#: default relative standard deviation below which every estimate of a body counts as identified
SD_REL = 1e-3

#: the ``signal_sd`` keys and their estimator FMU parameters (``ident.noise.*``)
SIGNAL_SD_NAMES = {key: f"ident.noise.{name}" for key, name, _, _ in SIGNAL_NOISE_PARAMETERS}


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
    crb : (20,) the information filter's first-order Cramér-Rao bound, as standard deviations
        (``crb.*``; 0 without the filter, ``ident.information``)
    info_chi2 : its weighted residuals' mean square (``diag.info_chi2``; 0 without it)
    excite_rate : the excitation rate asked of the plant (``ident.excite_rate``; 1 = its own)
    excite_score : (2,) the rate choice's predicted largest scaled bounds at rate 1 and at the
        candidate (``diag.excite_score.*``; 0 before the choice)
    """

    vector: np.ndarray
    std: np.ndarray
    identified: dict
    physical: dict
    crb: np.ndarray = None
    info_chi2: float = 0.0
    excite_rate: float = 1.0
    excite_score: np.ndarray = None


@dataclass
class BodyEstimate:
    """Mass [kg], CoM offset b (3,) [m] and CoM inertia (Ixx, Iyy, Izz, Ixy, Ixz, Iyz) [kg.m2]."""

    m: float
    b: np.ndarray
    I: np.ndarray


class Identifier:
    """Online one-step identification of base and target inertial parameters (the native core).

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
        The paper's modified RLS over (mu, theta) (eqs. 34-38), or one RLS over the 20
        standard parameters.
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
        deviations for correlated equation errors ;
        0 = rows taken as independent.
    window : float
        Momentum method: moving reference [s] >= 0 (``ident.momentum_window``): each sample's
        equations are differenced against the newest sample at least ``window`` seconds older
        (the first sample until then) instead of the first sample. 0 = the paper's equations
        (against the first sample). Any difference of two samples' valid equations is a valid
        equation: noise-free estimates stay exact. The force method takes 0 only (its high-pass
        was measured and not kept: docs/identification.md, section 6).
    accel_bias : bool
        Force method with measured accelerations: subtract the accelerometer's bias,
        estimated online from the navigation velocity (the slope of ``v - integral a``).
        False = the accelerations as measured.
    moving_point : bool
        Momentum method: the angular rows about the base's position ``r_S`` at the newer
        sample of each difference (the same point for both samples: the rows minus
        ``[r_S]x`` times the linear rows) instead of the inertial origin, so that position,
        velocity and thrust errors do not enter multiplied by the distance the base drifted
        from the origin. False = the paper's (about the origin).
    thrust_sd : (float, float)
        Standard deviations of the thrust's scale factor error [1] and of its misalignment
        per axis [rad], constant over the run, the same for force and moment: a consider
        covariance adds what they leave in the estimates to the reported
        standard deviations (the estimates are unchanged). (0, 0) = the thrust as measured
        is exact.
    signal_sd : mapping
        Force method: white-noise standard deviations per sample of the signals the
        accelerations come from, by measurement key: measured accelerations ``a_S``
        [m/s2], ``alpha_B`` [rad/s2], ``qdd`` [rad/s2]; differenced accelerations the
        velocities ``v_S`` [m/s], ``omega_B`` [rad/s], ``qd`` [rad/s] (the derivative's noise
        follows from its weights). With any > 0 the estimates are bias-compensated for the
        accelerations' noise (errors in variables). Empty / 0 = the plain least-squares answers.
    diff_momentum : bool or None
        Force method with differenced accelerations: None (default) = automatic (True unless
        ``diff_half_window`` > 10); True = apply the derivative's weights to
        the momentum equations of the window's samples instead of to the velocities (the
        force equations averaged by the same filter, exact however fast the accelerations
        change between samples; est_rows.c, docs/identification.md, section 6; at most
        ``diff_half_window`` = 10). False = the force equations at the centre with the velocities'
        derivatives (exact only where the velocities are quadratic over the window).
    excite : mapping
        The excitation request and the choice of its rate, as the core's options
        ``excite_mode``, ``excite_level``, ``excite_adapt``, ``excite_rate_try``,
        ``excite_window``, ``excite_settle``, ``excite_horizon`` (the estimator FMU's
        ``ident.excite_*``; absent: their defaults). The rate is chosen only with the
        information filter (``sensors_noise``).

    lib : ctypes.CDLL, optional
        The native library (default: :func:`spacerobot.core.lib`, ``$SPACEROBOT_CORE_LIB``).

    Invalid options raise ``ValueError`` naming the option (the core's message).

    Attributes
    ----------
    layout : ParameterLayout     the identified parameters and equation rows of ``robot``
    core : NativeEstimator       the C estimator (options, state)
    samples, rejected, status, message, residual_lin, residual_ang : the core's counters and
        diagnostics after the last sample

    Examples
    --------
    >>> ident = Identifier(robot, guess)              # doctest: +SKIP
    >>> status = ident.update(t, measurement_dict)    # doctest: +SKIP
    >>> ident.estimates()["target"].m                 # doctest: +SKIP
    """

    def __init__(self, robot: Robot, guess: Guess, method: Method | str = "momentum",
                 solver: Solver | str = "paper", accel_source: AccelSource | str = "measured",
                 lam: float = 1.0, sd_rel: float = SD_REL, row_sd=(0.0, 0.0),
                 diff_half_window: int = 1, corr_lags: int = 0, window: float = 0.0,
                 moving_point: bool = False, accel_bias: bool = False, thrust_sd=(0.0, 0.0),
                 signal_sd: Mapping[str, float] | None = None, diff_momentum: bool | None = None,
                 sensors_noise: Mapping | None = None, excite: Mapping | None = None, lib=None):
        method = Method.parse(method, "method")
        kind = Solver.parse(solver, "solver")
        accel_source = AccelSource.parse(accel_source, "accel_source")
        row_sd, thrust_sd = tuple(row_sd), tuple(thrust_sd)
        if len(row_sd) != 2 or len(thrust_sd) != 2:
            raise ValueError(f"row_sd and thrust_sd are two numbers each (linear, angular; "
                             f"scale factor, misalignment [rad]), got {row_sd!r}, {thrust_sd!r}")
        unknown = set(signal_sd or {}) - set(SIGNAL_SD_NAMES)
        if unknown:
            raise ValueError(f"signal_sd: unknown signal {sorted(unknown)[0]!r}; known: "
                             f"{sorted(SIGNAL_SD_NAMES)}")
        if method is Method.FORCE and window > 0.0:
            # the argument, not an option: the core's ident.momentum_window is the momentum
            # method's, which the force method ignores; this constructor has one window
            raise ValueError(f"window = {window:g} s: the reference window is the momentum "
                             f"method's (ident.momentum_window); the force method takes 0 (its "
                             f"high-pass was measured and not kept, docs/identification.md)")
        m = method.name.lower()
        options = {
            "method": int(method), "solver": int(kind), "accel_source": int(accel_source),
            "lambda": lam, "guess": guess, "ident.sd_rel": sd_rel,
            f"ident.sd_row.{m}_lin": row_sd[0], f"ident.sd_row.{m}_ang": row_sd[1],
            "ident.diff_half_window": diff_half_window, "ident.corr_lags": corr_lags,
            "ident.momentum_window": window, "ident.momentum_point": moving_point,
            "ident.accel_bias": accel_bias,
            "ident.diff_momentum": {None: 0, True: 1, False: 2}[diff_momentum],
            "ident.sd_thrust.scale": thrust_sd[0], "ident.sd_thrust.misalign": thrust_sd[1],
            **{SIGNAL_SD_NAMES[k]: v for k, v in (signal_sd or {}).items()},
            # the sensors' noise model (the core's noise_profile, noise_scale, noise,
            # noise_dt, information): what the information filter weighs the rows by
            **(sensors_noise or {}),
            # the excitation request and the choice of its rate (the core's excite_mode,
            # excite_level, excite_adapt, excite_rate_try, excite_window, excite_settle,
            # excite_horizon)
            **(excite or {}),
        }
        self._build(robot, _struct_options(options, lib), lib)

    def _build(self, robot: Robot, options: dict, lib) -> None:
        """The core of ``options`` (the struct's fields; the core checks them) and what this
        class reads of it."""
        self._options, self._lib_arg = dict(options), lib
        self.core = _core.NativeEstimator(robot, options, lib=lib)
        used = self.core.model_options()
        self.robot = robot
        self.guess = Guess(RigidBody(used["guess_base"][0], used["guess_base"][1:4],
                                     used["guess_base"][4:]),
                           RigidBody(used["guess_target"][0], used["guess_target"][1:4],
                                     used["guess_target"][4:]),
                           used["P0_mu"], used["P0_theta"])
        self.method = Method(used["method"])
        self.solver_kind = Solver(used["solver"])
        self.accel_source = AccelSource(used["accel_source"])
        self.lam, self.sd_rel = used["lambda"], used["sd_rel"]
        k = 2 * (self.method - 1)
        self.row_sd = (used["row_sd"][k], used["row_sd"][k + 1])
        self.diff_half_window, self.corr_lags = used["diff_half_window"], used["corr_lags"]
        # the options as the core uses them: those of another method or accelerations 0
        self.window = used["momentum_window"]
        self.thrust_sd = (used["sd_thrust_scale"], used["sd_thrust_misalign"])
        self.signal_sd = {k: sd for k, sd in zip(SIGNAL_SD_NAMES, used["signal_sd"]) if sd}
        self.moving_point = bool(used["momentum_point"])
        self.accel_bias = bool(used["accel_bias"])
        self.diff_momentum = bool(used["diff_momentum"])
        self.n = robot.n_joints
        self._signals = _sample.signals(self.n)
        self._sizes = [sg.size for sg in self._signals]
        self._n_flat = sum(self._sizes)
        self.layout = ParameterLayout.for_robot(robot)
        self._zero = np.zeros(self._n_flat)       # a sample the core rejects (base.A = 0)
        self._note = None       # a rejection decided here (shape, type): its message
        self._rep = None        # the core's report, cached until the next update / set_state

    @classmethod
    def from_options(cls, robot: Robot, options: Mapping, lib=None) -> "Identifier":
        """An identifier of the core's options (``options``: by the estimator FMU's parameter
        names or the struct's fields, :class:`spacerobot.core.estimator.NativeEstimator`)."""
        out = cls.__new__(cls)
        out._build(robot, _struct_options(options, lib), lib)
        return out

    def excite_request(self, identified: Mapping[str, bool]) -> float:
        """The excitation level requested (output ``ident.excite``) for the bodies' identified
        flags (``{'base': bool, 'target': bool}``): the core's rule."""
        return self.core.excite_request(identified)

    # -- the update ------------------------------------------------------------------------------
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
        flat, why = self._flatten(meas)
        return self._update(t, flat, why)

    def update_flat(self, t: float, flat: np.ndarray) -> int:
        """:meth:`update` with the sample given as one flat array: the signals of :data:`KEYS`
        one after the other, ``A`` row-major (``3 + 3 + 9 + 3 + 3 + 3 + 3 n + 4 * 3`` values;
        what the estimator FMU gathers from its inputs). The same checks and results as
        :meth:`update` with the dictionary of the same values.
        """
        try:
            x = np.array(flat, dtype=float)
        except (ValueError, TypeError) as e:
            return self._update(t, None, f"the sample is not numeric ({e})")
        if x.shape != (self._n_flat,):
            return self._update(t, None, f"the flat sample has shape {x.shape}, expected "
                                         f"({self._n_flat},)")
        return self._update(t, x, None)

    def _flatten(self, meas):
        """``(flat, None)``, or ``(None, why)`` for a sample whose signals do not have their
        shapes or are not numbers (the core judges the values)."""
        try:
            vals = [np.ravel(meas[k]) if k == "A" else meas[k] for k in KEYS]
            if [len(v) for v in vals] == self._sizes and np.shape(meas["A"]) == (3, 3):
                flat = np.concatenate(vals).astype(float, copy=False)
                if flat.ndim == 1:
                    return flat, None
        except (ValueError, TypeError, AttributeError, KeyError):
            pass
        arrays = []
        for k, size in zip(KEYS, self._sizes):
            try:
                x = np.array(meas[k], float)
            except KeyError:
                return None, f"input {k} is missing"
            except (ValueError, TypeError) as e:
                return None, f"input {k} is not numeric ({e})"
            shape = (3, 3) if k == "A" else (size,)
            if x.shape != shape:
                return None, f"input {k} has shape {x.shape}, expected {shape}"
            arrays.append(x.ravel())
        return np.concatenate(arrays), None

    def _update(self, t: float, flat, why: Optional[str]) -> int:
        self._rep = None
        try:
            t = float(t)
        except (TypeError, ValueError):
            t, why = math.nan, why or f"the sample time {t!r} is not a number"
        if why is None:
            self._note = None
            return self.core.update(t, flat)
        # counted as the core counts its own rejections: a sample it refuses (base.A = 0),
        # with this message in place of its own
        self.core.update(t, self._zero)
        self._note = why
        return REJECT_INCONSISTENT if self.status == REJECT_INCONSISTENT else self.status

    # -- results --------------------------------------------------------------------------------
    def _report(self) -> dict:
        if self._rep is None:
            self._rep = self.core.report()
        return self._rep

    @property
    def samples(self) -> int:
        """Samples used so far."""
        return self._report()["samples"]

    @property
    def rejected(self) -> int:
        """Samples rejected so far."""
        return self._report()["rejected"]

    @property
    def status(self) -> int:
        """Status of the last sample (:data:`spacerobot.interface.STATUS`)."""
        st = self._report()["status"]
        return REJECT_INCONSISTENT if self._note is not None and st in (3, 4) else st

    @property
    def message(self) -> str:
        """Why the last sample was rejected ("" if it was accepted)."""
        return self._note if self._note is not None else self.core.message

    @property
    def residual_lin(self) -> float:
        """Relative residual of the last linear (mass) equations."""
        return self._report()["residual_lin"]

    @property
    def residual_ang(self) -> float:
        """Relative residual of the last angular (inertia) equations."""
        return self._report()["residual_ang"]

    def vector(self) -> np.ndarray:
        """Estimates as one (20,) vector in the order of
        :data:`spacerobot.interface.ESTIMATE_NAMES`: per body m, b (3), I (6) (the
        least-squares estimates, before the physical projection)."""
        return self.core.estimates()[0]

    def std(self) -> np.ndarray:
        """Standard deviations of :meth:`vector` (20,): the data's scatter and the prior's
        pull through the delta method, the estimates' lag behind moving parameters, the
        thrust errors' consider variance (``thrust_sd``); the prior's sd before any sample and
        for parameters that are not identified (docs/identification.md). With the information
        filter (``ident.information``): its bound times ``sqrt(max(1, chi2))``, and
        :meth:`vector` its estimates."""
        return self.core.estimates()[1]

    def std_without_lag(self) -> np.ndarray:
        """The equations' own :meth:`std` without the drift tracker's lag term (20,) (with the
        information filter too: a diagnostic of the estimator underneath)."""
        return self.core.sd_without_lag()

    def report(self) -> Report:
        """The estimates as reported: physically consistent, with their standard deviations,
        and whether each body is identified (see :class:`Report`). The projection acts on the
        output only: the core keeps the exact least-squares state."""
        r = self._report()
        return Report(r["vector"].copy(), r["sd"].copy(), dict(r["identified"]),
                      dict(r["physical"]), r["crb"].copy(), float(r["info_chi2"]),
                      float(r["excite_rate"]), r["excite_score"].copy())

    def estimates(self) -> dict:
        """``{'base': BodyEstimate, 'target': BodyEstimate}`` (the least-squares estimates;
        :meth:`report` has the physically consistent ones)."""
        vec = self.vector()
        return {b.name: BodyEstimate(float(vec[b.m]), vec[b.first].copy(),
                                     vec[b.inertia].copy())
                for b in self.layout.bodies}

    def excitation(self):
        """Reciprocal condition numbers (scale-free) of the mass and inertia information
        (``diag.excitation_mu``, ``diag.excitation_theta``)."""
        r = self._report()
        return float(r["excitation_mu"]), float(r["excitation_theta"])

    # -- state ------------------------------------------------------------------------------------
    def get_state(self) -> bytes:
        """A copy of everything that evolves: the core's Data block (bytes)."""
        return self.core.get_state()

    def set_state(self, st: bytes) -> None:
        """Restore a state of :meth:`get_state` (of an identifier with the same options);
        ``ValueError`` for a block of another size or one the core finds invalid."""
        st = bytes(st)
        why = self.core.check_state(st)
        if why:
            raise ValueError(f"invalid estimator state: {why}")
        self.core.set_state(st)
        self._rep, self._note = None, None

    def __getstate__(self):
        return {"robot": self.robot, "options": self._options, "lib": self._lib_arg,
                "state": self.get_state(), "note": self._note}

    def __setstate__(self, d):
        self._build(d["robot"], d["options"], d["lib"])
        self.set_state(d["state"])
        self._note = d["note"]

    def __deepcopy__(self, memo):
        out = Identifier.__new__(Identifier)
        out.__setstate__(self.__getstate__())
        return out


def _struct_options(options: Mapping, lib=None) -> dict:
    """The core's options (the struct's fields) of ``options`` (by the estimator FMU's
    parameter names or the struct's fields)."""
    L = _core._bind(lib or _core._default_lib())
    return _core._as_dict(_core._options(options, L))


def identifier_from_values(robot: Robot, values: Mapping[str, float], sample_time: float = 0.1,
                           lib=None) -> Tuple[Identifier, Callable[[Mapping[str, bool]], float]]:
    """The estimator core and its excitation request (:meth:`Identifier.excite_request`) from
    the estimator FMU's parameter values (names of :func:`spacerobot.interface.estimator_vars`):
    what the FMU builds at initialisation, and ``spacerobot identify`` on recorded telemetry;
    ``sample_time`` [s]: the interval the sensors' noise densities are drawn at (the FMU's
    scenario sample time; ``ident.noise_profile``). Raises ``ValueError`` with the core's
    message for an invalid value."""
    ident = Identifier.from_options(
        robot, {**_core.options_from_values(values, lib), "noise_dt": float(sample_time)}, lib)
    return ident, ident.excite_request
