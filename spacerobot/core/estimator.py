"""The native estimator core (``native/src/estimator.h``) bound with ctypes.

One :class:`NativeEstimator` is one constant Model (robot, options, prior) and one Data block
(every state, a flat byte block without pointers): :meth:`~NativeEstimator.update` takes one
flat sample (the layout of ``Identifier.update_flat``), :meth:`~NativeEstimator.report` reads
what the estimator FMU outputs, :meth:`~NativeEstimator.get_state` /
:meth:`~NativeEstimator.set_state` copy the Data block.

Examples
--------
>>> est = NativeEstimator(sc.robot, {"method": 2, "lambda": 0.98})      # doctest: +SKIP
>>> est.update(t, flat)                                                   # doctest: +SKIP
2
>>> est.report()["vector"]                                                # doctest: +SKIP
"""
from __future__ import annotations

import ctypes
import os
from typing import Mapping, Optional, Union

import numpy as np

from . import dptr, lib as _default_lib
from .robot_record import SrRobot, c_read_record, c_robot

__all__ = ["NativeEstimator", "SrEstimatorOptions", "SrEstimatorReport", "default_options",
           "options_from_values", "profile_options", "profile_values"]

#: message buffer length (SR_EST_MSG_LEN)
MSG_LEN = 256
#: the sensors' error magnitudes (SR_NOISE_COUNT, native/src/sensor_noise.h): the sensors
#: FMU's ``noise.*`` parameters but ``noise.scale``, in
#: :data:`spacerobot.interface.NOISE_PARAMETERS` order
N_SENSOR_NOISE = 17


class SrEstimatorOptions(ctypes.Structure):
    """``sr_estimator_options`` (native/src/estimator.h)."""

    _fields_ = [
        ("method", ctypes.c_int), ("solver", ctypes.c_int), ("accel_source", ctypes.c_int),
        ("lambda_", ctypes.c_double), ("P0_mu", ctypes.c_double), ("P0_theta", ctypes.c_double),
        ("guess_base", ctypes.c_double * 10), ("guess_target", ctypes.c_double * 10),
        ("sd_rel", ctypes.c_double), ("excite_mode", ctypes.c_int),
        ("excite_level", ctypes.c_double), ("row_sd_lin", ctypes.c_double),
        ("row_sd_ang", ctypes.c_double), ("diff_half_window", ctypes.c_int),
        ("diff_momentum", ctypes.c_int), ("corr_lags", ctypes.c_int),
        ("signal_sd", ctypes.c_double * 6), ("momentum_window", ctypes.c_double),
        ("momentum_point", ctypes.c_int), ("sd_thrust_scale", ctypes.c_double),
        ("sd_thrust_misalign", ctypes.c_double), ("momentum_window_samples", ctypes.c_int),
        ("accel_bias", ctypes.c_int), ("noise_profile", ctypes.c_int),
        ("noise_scale", ctypes.c_double), ("noise", ctypes.c_double * N_SENSOR_NOISE),
        ("noise_dt", ctypes.c_double), ("information", ctypes.c_int),
        ("excite_adapt", ctypes.c_int), ("excite_rate_try", ctypes.c_double),
        ("excite_window", ctypes.c_double), ("excite_settle", ctypes.c_double),
        ("excite_horizon", ctypes.c_double),
    ]


class SrNoiseProfileError(ctypes.Structure):
    """``sr_noise_profile_error`` (native/src/noise_profile.h)."""

    _fields_ = [("name", ctypes.c_char_p), ("rule", ctypes.c_char_p), ("value", ctypes.c_double)]


class SrEstimatorReport(ctypes.Structure):
    """``sr_estimator_report`` (native/src/estimator.h)."""

    _fields_ = [
        ("vector", ctypes.c_double * 20), ("sd", ctypes.c_double * 20),
        ("identified", ctypes.c_int * 2), ("physical", ctypes.c_int * 2),
        ("residual_lin", ctypes.c_double), ("residual_ang", ctypes.c_double),
        ("excitation_mu", ctypes.c_double), ("excitation_theta", ctypes.c_double),
        ("samples", ctypes.c_int), ("rejected", ctypes.c_int), ("status", ctypes.c_int),
        ("excite", ctypes.c_double), ("crb", ctypes.c_double * 20),
        ("info_chi2", ctypes.c_double), ("excite_rate", ctypes.c_double),
        ("excite_score", ctypes.c_double * 2),
    ]


def _bind(L: ctypes.CDLL) -> ctypes.CDLL:
    """Declare the estimator's functions on the library ``L`` (once)."""
    if getattr(L, "_sr_estimator_bound", False):
        return L
    vp, sz, cp = ctypes.c_void_p, ctypes.c_size_t, ctypes.c_char_p
    dp = ctypes.POINTER(ctypes.c_double)
    L.sr_estimator_options_default.argtypes = [ctypes.POINTER(SrEstimatorOptions)]
    L.sr_estimator_options_default.restype = None
    L.sr_estimator_model_new.argtypes = [ctypes.POINTER(SrRobot),
                                         ctypes.POINTER(SrEstimatorOptions), cp, sz]
    L.sr_estimator_model_new.restype = vp
    L.sr_estimator_model_free.argtypes = [vp]
    L.sr_estimator_model_free.restype = None
    L.sr_estimator_data_size.argtypes = [vp]
    L.sr_estimator_data_size.restype = sz
    L.sr_estimator_data_init.argtypes = [vp, vp]
    L.sr_estimator_data_init.restype = None
    L.sr_estimator_sample_length.argtypes = [vp]
    L.sr_estimator_sample_length.restype = ctypes.c_int
    L.sr_estimator_work_size.argtypes = [vp]
    L.sr_estimator_work_size.restype = sz
    L.sr_estimator_update.argtypes = [vp, vp, vp, ctypes.c_double, dp, cp, sz]
    L.sr_estimator_update.restype = ctypes.c_int
    L.sr_estimator_report_get.argtypes = [vp, vp, ctypes.POINTER(SrEstimatorReport)]
    L.sr_estimator_report_get.restype = None
    L.sr_estimator_message.argtypes = [vp, vp, cp, sz]
    L.sr_estimator_message.restype = None
    L.sr_estimator_estimates.argtypes = [vp, vp, dp, dp]
    L.sr_estimator_estimates.restype = None
    L.sr_estimator_sd_without_lag.argtypes = [vp, vp, dp]
    L.sr_estimator_sd_without_lag.restype = None
    L.sr_noise_profile_apply.argtypes = [ctypes.POINTER(SrEstimatorOptions),
                                         ctypes.POINTER(SrEstimatorOptions),
                                         ctypes.POINTER(SrNoiseProfileError)]
    L.sr_noise_profile_apply.restype = ctypes.c_int
    if hasattr(L, "sr_estimator_data_check"):    # (a library built before it: no check_state)
        L.sr_estimator_data_check.argtypes = [vp, vp, cp, sz]
        L.sr_estimator_data_check.restype = ctypes.c_int
    for name in ("sr_estimator_options_size", "sr_estimator_report_size",
                 "sr_estimator_data_head_size"):
        getattr(L, name).argtypes = []
        getattr(L, name).restype = sz
    for name, cls in (("sr_estimator_options_size", SrEstimatorOptions),
                      ("sr_estimator_report_size", SrEstimatorReport)):
        if getattr(L, name)() != ctypes.sizeof(cls):
            raise RuntimeError(f"{name}: {getattr(L, name)()} bytes in the library, "
                               f"{ctypes.sizeof(cls)} in spacerobot.core.estimator")
    L._sr_estimator_bound = True
    return L


#: option names (keys of the options mapping) -> struct field
_FIELD = {"lambda": "lambda_", "lam": "lambda_"}


def default_options(lib: Optional[ctypes.CDLL] = None) -> dict:
    """The options' defaults (``sr_estimator_options_default``) as a dictionary (lists for
    the arrays; ``lambda`` under its FMU name)."""
    L = _bind(lib or _default_lib())
    o = SrEstimatorOptions()
    L.sr_estimator_options_default(ctypes.byref(o))
    return _as_dict(o)


def _as_dict(o: SrEstimatorOptions) -> dict:
    out = {}
    for name, _ in SrEstimatorOptions._fields_:
        v = getattr(o, name)
        out["lambda" if name == "lambda_" else name] = list(v) if hasattr(v, "__len__") else v
    return out


def profile_options(options: Mapping, lib: Optional[ctypes.CDLL] = None) -> dict:
    """The options (a mapping as :class:`NativeEstimator` takes) with their noise profile
    applied (``sr_noise_profile_apply``, native/src/noise_profile.h): what the estimator runs
    with. ``ValueError`` names the parameter a profile cannot be applied with."""
    L = _bind(lib or _default_lib())
    o, out, why = _options(options, L), SrEstimatorOptions(), SrNoiseProfileError()
    if L.sr_noise_profile_apply(ctypes.byref(o), ctypes.byref(out), ctypes.byref(why)):
        raise ValueError(f"{why.name.decode()} must be {why.rule.decode()}, got {why.value!r}")
    return _as_dict(out)


#: the estimator's scalar noise options (``sr_estimator_options`` fields) the noise profile may
#: set, by their FMU parameter names
PROFILE_OPTION_NAMES = {"sd_thrust_scale": "ident.sd_thrust.scale",
                        "sd_thrust_misalign": "ident.sd_thrust.misalign",
                        "momentum_window": "ident.momentum_window",
                        "momentum_point": "ident.momentum_point", "corr_lags": "ident.corr_lags",
                        "accel_bias": "ident.accel_bias", "diff_momentum": "ident.diff_momentum",
                        "diff_half_window": "ident.diff_half_window",
                        "information": "ident.information"}


#: the excitation design's options (``sr_estimator_options`` fields) by their FMU parameter
#: names and types
EXCITE_DESIGN_OPTIONS = {"excite_adapt": ("ident.excite_adapt", int),
                         "excite_rate_try": ("ident.excite_rate_try", float),
                         "excite_window": ("ident.excite_window", float),
                         "excite_settle": ("ident.excite_settle", float),
                         "excite_horizon": ("ident.excite_horizon", float)}


def excite_design_values(values: Mapping[str, float]) -> dict:
    """The excitation design's options of the estimator FMU's parameter ``values`` (those
    absent keep the core's defaults)."""
    return {field: kind(values[name]) for field, (name, kind) in EXCITE_DESIGN_OPTIONS.items()
            if name in values}


def profile_values(values: Mapping[str, float], sample_time: float = 0.1,
                   lib: Optional[ctypes.CDLL] = None) -> dict:
    """``{FMU parameter name: value}`` of the estimator options the noise profile of the
    estimator FMU's parameter ``values`` sets (``ident.noise_profile``, ``noise.*``; the
    sensors' densities at ``sample_time`` [s]): what ``sr_noise_profile_apply`` changes, by
    name; empty with ``ident.noise_profile`` = 0."""
    from ..interface import SIGNAL_NOISE_PARAMETERS
    given = {**options_from_values(values), "noise_dt": float(sample_time)}
    used = profile_options(given, lib)
    out = {name: used[field] for field, name in PROFILE_OPTION_NAMES.items()
           if used[field] != given[field]}
    for i, (_, name, _, _) in enumerate(SIGNAL_NOISE_PARAMETERS):
        if used["signal_sd"][i] != given["signal_sd"][i]:
            out[f"ident.noise.{name}"] = used["signal_sd"][i]
    return out


def _body10(body) -> list:
    """``[m, b (3), Ixx Iyy Izz Ixy Ixz Iyz]`` of a RigidBody or a sequence of 10."""
    if hasattr(body, "mass"):
        return [float(body.mass), *map(float, body.com), *map(float, body.inertia)]
    return [float(x) for x in body]


def _options(values: Mapping, L: ctypes.CDLL) -> SrEstimatorOptions:
    o = SrEstimatorOptions()
    L.sr_estimator_options_default(ctypes.byref(o))
    for key, v in dict(values).items():
        if key == "guess":                                   # a robots.Guess
            o.guess_base[:] = _body10(v.base)
            o.guess_target[:] = _body10(v.target)
            o.P0_mu, o.P0_theta = float(v.P0_mu), float(v.P0_theta)
            continue
        if key == "thrust_sd":                               # Identifier(thrust_sd=...)
            o.sd_thrust_scale, o.sd_thrust_misalign = (float(x) for x in v)
            continue
        name = _FIELD.get(key, key)
        if name not in dict(SrEstimatorOptions._fields_):
            raise KeyError(f"unknown estimator option {key!r}")
        if name in ("guess_base", "guess_target"):
            getattr(o, name)[:] = _body10(v)
        elif name in ("signal_sd", "noise"):
            getattr(o, name)[:] = [float(x) for x in v]
        elif dict(SrEstimatorOptions._fields_)[name] is ctypes.c_int:
            setattr(o, name, int(v))
        else:
            setattr(o, name, float(v))
    return o


def options_from_values(values: Mapping[str, float]) -> dict:
    """The options from the estimator FMU's parameter values (names of
    :func:`spacerobot.interface.estimator_vars`), as :func:`.identifier_from_values` reads
    them: the row standard deviations of the chosen method, the signal noise in
    ``SIGNAL_NOISE_PARAMETERS`` order."""
    from ..interface import BODY_PARAMETERS, SENSOR_MAGNITUDES, SIGNAL_NOISE_PARAMETERS
    v = values
    method = int(v["method"])
    kind = "momentum" if method == 1 else "force"
    return {
        "method": method, "solver": int(v["solver"]), "accel_source": int(v["accel_source"]),
        "lambda": float(v["lambda"]), "P0_mu": float(v["P0_mu"]),
        "P0_theta": float(v["P0_theta"]),
        "guess_base": [float(v[f"guess.base.{n}"]) for n in BODY_PARAMETERS],
        "guess_target": [float(v[f"guess.target.{n}"]) for n in BODY_PARAMETERS],
        "sd_rel": float(v["ident.sd_rel"]), "excite_mode": int(v["ident.excite_mode"]),
        "excite_level": float(v["ident.excite_level"]),
        "row_sd_lin": float(v[f"ident.sd_row.{kind}_lin"]),
        "row_sd_ang": float(v[f"ident.sd_row.{kind}_ang"]),
        "diff_half_window": int(v["ident.diff_half_window"]),
        "diff_momentum": int(v["ident.diff_momentum"]), "corr_lags": int(v["ident.corr_lags"]),
        "signal_sd": [float(v[f"ident.noise.{name}"]) for _, name, _, _ in
                      SIGNAL_NOISE_PARAMETERS],
        "momentum_window": float(v["ident.momentum_window"]),
        "momentum_point": int(v["ident.momentum_point"]),
        "sd_thrust_scale": float(v["ident.sd_thrust.scale"]),
        "sd_thrust_misalign": float(v["ident.sd_thrust.misalign"]),
        "accel_bias": int(v["ident.accel_bias"]),
        "noise_profile": int(v["ident.noise_profile"]),
        "noise_scale": float(v["noise.scale"]),
        "information": int(v.get("ident.information", 0)),
        # the magnitudes the profile reads (the others stay 0: the estimator has no use for them)
        "noise": [float(v.get(name, 0.0)) for name in SENSOR_MAGNITUDES],
        **excite_design_values(v),
    }


class NativeEstimator:
    """The C estimator: one Model and one Data block.

    Parameters
    ----------
    robot : spacerobot.robots.Robot, SrRobot, or path of a robot record file
    options : mapping, optional
        Fields of ``sr_estimator_options`` (``method``, ``solver``, ``accel_source``,
        ``lambda``, ``P0_mu``, ``P0_theta``, ``guess_base`` / ``guess_target`` (a RigidBody or
        10 numbers), ``sd_rel``, ``excite_mode``, ``excite_level``, ``row_sd_lin``,
        ``row_sd_ang``, ``diff_half_window``, ``diff_momentum``, ``corr_lags``,
        ``signal_sd`` (6), ``momentum_window``, ``momentum_point``, ``sd_thrust_scale``,
        ``sd_thrust_misalign``, ``momentum_window_samples`` (the momentum window's ring
        capacity, 0 = automatic: samples at least 1 ms apart), ``accel_bias``), ``guess`` (a
        ``robots.Guess``: both bodies and P0) and ``thrust_sd`` (``(scale, misalignment)``,
        as the Identifier's); the rest keep ``sr_estimator_options_default``.
    lib : the library (default: :func:`spacerobot.core.lib`)

    Raises ``ValueError`` with the core's message for invalid options.
    """

    def __init__(self, robot: Union[object, SrRobot, os.PathLike, str],
                 options: Optional[Mapping] = None, lib: Optional[ctypes.CDLL] = None):
        self._lib = L = _bind(lib or _default_lib())
        if isinstance(robot, SrRobot):
            rob = robot
        elif isinstance(robot, (str, os.PathLike)):
            st, rob, msg = c_read_record(robot, L)
            if st != 0:
                raise ValueError(msg)
        else:
            rob = c_robot(robot, L)
        self.robot = rob
        self.options = _options(options or {}, L)
        err = ctypes.create_string_buffer(MSG_LEN)
        self._model = L.sr_estimator_model_new(ctypes.byref(rob), ctypes.byref(self.options),
                                               err, len(err))
        if not self._model:
            raise ValueError(err.value.decode("utf-8", "replace"))
        self.size = int(L.sr_estimator_data_size(self._model))
        self._data = ctypes.create_string_buffer(self.size)
        L.sr_estimator_data_init(self._model, self._data)
        #: the update's work space (no part of the state)
        self._work = ctypes.create_string_buffer(int(L.sr_estimator_work_size(self._model)))
        self.n_flat = int(L.sr_estimator_sample_length(self._model))
        self._msg = ctypes.create_string_buffer(MSG_LEN)
        self._report = SrEstimatorReport()
        #: bytes at the start of the state that a rejected sample changes (counters, status,
        #: message)
        self.head_size = int(L.sr_estimator_data_head_size())

    def __del__(self):
        model, L = getattr(self, "_model", None), getattr(self, "_lib", None)
        if model and L is not None:
            L.sr_estimator_model_free(model)
            self._model = None

    def reset(self) -> None:
        """The state before any sample."""
        self._lib.sr_estimator_data_init(self._model, self._data)

    def update(self, t: float, flat) -> int:
        """One sample (the flat layout of ``Identifier.update_flat``); returns the status."""
        x = np.ascontiguousarray(flat, dtype=float)
        if x.shape != (self.n_flat,):
            raise ValueError(f"the flat sample has shape {x.shape}, expected ({self.n_flat},)")
        return int(self._lib.sr_estimator_update(self._model, self._data, self._work, float(t),
                                                 dptr(x), self._msg, len(self._msg)))

    @property
    def message(self) -> str:
        """Why the last sample was rejected ("" if it was accepted)."""
        self._lib.sr_estimator_message(self._model, self._data, self._msg, len(self._msg))
        return self._msg.value.decode("utf-8", "replace")

    def estimates(self):
        """``(vector (20,), sd (20,))``: the least-squares estimates (before the physical
        projection) and their standard deviations (``Identifier.vector()``, ``std()``)."""
        vec, sd = np.empty(20), np.empty(20)
        self._lib.sr_estimator_estimates(self._model, self._data, dptr(vec), dptr(sd))
        return vec, sd

    def sd_without_lag(self) -> np.ndarray:
        """The standard deviations (20,) without the drift tracker's lag term
        (``Identifier.solver.std_parts().sd``)."""
        sd = np.empty(20)
        self._lib.sr_estimator_sd_without_lag(self._model, self._data, dptr(sd))
        return sd

    def report(self) -> dict:
        """What the estimator FMU outputs: ``vector``, ``sd`` (20,), ``identified`` and
        ``physical`` (``{'base': bool, 'target': bool}``), ``residual_lin``, ``residual_ang``,
        ``excitation_mu``, ``excitation_theta``, ``samples``, ``rejected``, ``status``,
        ``excite``; the information filter's ``crb`` (20,: the Cramér-Rao bound's standard
        deviations, 0 without the filter) and ``info_chi2`` (its misfit); ``excite_rate`` (the
        rate asked of the plant) and ``excite_score`` (2,: the choice's predicted largest scaled
        bounds at rate 1 and at the candidate; 0 before the choice)."""
        r = self._report
        self._lib.sr_estimator_report_get(self._model, self._data, ctypes.byref(r))
        return {
            "vector": np.array(r.vector[:]), "sd": np.array(r.sd[:]),
            "identified": {"base": bool(r.identified[0]), "target": bool(r.identified[1])},
            "physical": {"base": bool(r.physical[0]), "target": bool(r.physical[1])},
            "residual_lin": r.residual_lin, "residual_ang": r.residual_ang,
            "excitation_mu": r.excitation_mu, "excitation_theta": r.excitation_theta,
            "samples": r.samples, "rejected": r.rejected, "status": r.status,
            "excite": r.excite, "crb": np.array(r.crb[:]), "info_chi2": r.info_chi2,
            "excite_rate": r.excite_rate, "excite_score": np.array(r.excite_score[:]),
        }

    def get_state(self) -> bytes:
        """A copy of the Data block."""
        return self._data.raw

    def set_state(self, state: bytes) -> None:
        """Restore a Data block of :meth:`get_state` (of an estimator with the same options)."""
        if len(state) != self.size:
            raise ValueError(f"a state of {len(state)} bytes, expected {self.size}")
        ctypes.memmove(self._data, state, self.size)

    def check_state(self, state: Optional[bytes] = None) -> str:
        """Why the Data block ``state`` (default: the estimator's own) is not valid for this
        estimator's options (``sr_estimator_data_check``: a count, index, flag or status out of
        its range), or ``""`` when it is."""
        if state is None:
            buf = self._data
        else:
            if len(state) != self.size:
                return f"a state of {len(state)} bytes, expected {self.size}"
            buf = ctypes.create_string_buffer(bytes(state), self.size)
        err = ctypes.create_string_buffer(MSG_LEN)
        if self._lib.sr_estimator_data_check(self._model, buf, err, len(err)) == 0:
            return ""
        return err.value.decode("utf-8", "replace")
