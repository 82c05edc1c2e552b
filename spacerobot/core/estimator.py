"""The native estimator core (``native/src/estimator.h``) bound with ctypes.

One :class:`NativeEstimator` is one constant Model (robot, options, prior), one Data block
(every state, a flat byte block without pointers) and a work space for its updates:
:meth:`~NativeEstimator.update` takes one flat sample (the signals of
:mod:`spacerobot.core.sample` one after the other), :meth:`~NativeEstimator.report` reads what
the estimator FMU outputs, :meth:`~NativeEstimator.get_state` /
:meth:`~NativeEstimator.set_state` copy the Data block.

The core's tables are read from it, never written again here: the options by the estimator
FMU's parameter names with their ranges and defaults (:func:`option_table`,
:func:`parameter_ranges`, :func:`options_from_values`), the outputs by their names
(:func:`output_names`), the status texts (:func:`status_texts`), the input limit. Every option
is checked by the core (:class:`ValueError` with its message).

Examples
--------
>>> est = NativeEstimator(sc.robot, {"method": 2, "lambda": 0.98})      # doctest: +SKIP
>>> est.update(t, flat)                                                   # doctest: +SKIP
2
>>> est.report()["vector"]                                                # doctest: +SKIP
"""
from __future__ import annotations

import ctypes
import math
import numbers
import os
from dataclasses import dataclass
from typing import Dict, Iterable, Mapping, Optional, Tuple, Union

import numpy as np

from . import dptr, lib as _default_lib
from .robot_record import SrRobot, c_read_record, c_robot

__all__ = ["NativeEstimator", "SrEstimatorOptions", "SrEstimatorReport", "Option",
           "default_options", "option_table", "parameter_ranges", "options_from_values",
           "profile_options", "profile_values", "output_names", "status_texts",
           "input_limit", "rotation_tol"]

#: message buffer length (SR_EST_MSG_LEN)
MSG_LEN = 256
#: the sensors' error magnitudes (SR_NOISE_COUNT, native/src/sensor_noise.h): the sensors
#: FMU's ``noise.*`` parameters but ``noise.scale``, in
#: :data:`spacerobot.interface.NOISE_PARAMETERS` order
N_SENSOR_NOISE = 17
#: sr_estimator_report.misfit_cause (SR_EST_MISFIT_*, native/src/estimator.h) by name
MISFIT_CAUSES = {1: "model", 2: "noise", 3: "thrust"}


class SrEstimatorOptions(ctypes.Structure):
    """``sr_estimator_options`` (native/src/estimator.h)."""

    _fields_ = [
        ("method", ctypes.c_int), ("solver", ctypes.c_int), ("accel_source", ctypes.c_int),
        ("lambda_", ctypes.c_double), ("P0_mu", ctypes.c_double), ("P0_theta", ctypes.c_double),
        ("guess_base", ctypes.c_double * 10), ("guess_target", ctypes.c_double * 10),
        ("sd_rel", ctypes.c_double), ("flag_confidence", ctypes.c_double),
        ("excite_mode", ctypes.c_int),
        ("excite_level", ctypes.c_double), ("row_sd", ctypes.c_double * 4),
        ("diff_half_window", ctypes.c_int),
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
        ("modes", ctypes.c_int),
        ("mode_f", ctypes.c_double * 4), ("band", ctypes.c_int), ("fit_window", ctypes.c_double),
        ("fit_lags", ctypes.c_int), ("fit_rho_max", ctypes.c_double),
        ("fit_whiteness_max", ctypes.c_double), ("fit_chi2_max", ctypes.c_double),
        ("fit_thrust_max", ctypes.c_double), ("fit_bias_k", ctypes.c_double),
        ("fit_bias_k_info", ctypes.c_double), ("eiv_uncertainty", ctypes.c_double),
    ]


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
        ("mode_f", ctypes.c_double * 4), ("mode_zeta", ctypes.c_double * 4),
        ("model_fit", ctypes.c_double),
        ("misfit", ctypes.c_int), ("misfit_cause", ctypes.c_int), ("band", ctypes.c_int),
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
                                         ctypes.POINTER(SrEstimatorOptions), cp, sz]
    L.sr_noise_profile_apply.restype = ctypes.c_int
    L.sr_estimator_data_check.argtypes = [vp, vp, cp, sz]
    L.sr_estimator_data_check.restype = ctypes.c_int
    ip, op = ctypes.c_int, ctypes.POINTER(SrEstimatorOptions)
    for name, res in (("sr_estimator_option_name", cp), ("sr_estimator_option_field", cp),
                      ("sr_estimator_option_index", ip), ("sr_estimator_option_offset",
                                                          ctypes.c_long),
                      ("sr_estimator_option_integer", ip), ("sr_estimator_option_parameter", ip),
                      ("sr_estimator_output_name", cp), ("sr_estimator_output_integer", ip),
                      ("sr_estimator_status_text", cp)):
        getattr(L, name).argtypes = [ip]
        getattr(L, name).restype = res
    for name in ("sr_estimator_option_count", "sr_estimator_output_count"):
        getattr(L, name).argtypes = []
        getattr(L, name).restype = ip
    for name in ("sr_estimator_input_limit", "sr_estimator_rotation_tol"):
        getattr(L, name).argtypes = []
        getattr(L, name).restype = ctypes.c_double
    L.sr_estimator_param_range.argtypes = [cp, dp, dp]
    L.sr_estimator_param_range.restype = ip
    L.sr_estimator_options_set.argtypes = [op, cp, ctypes.c_double, cp, sz]
    L.sr_estimator_options_set.restype = ip
    L.sr_estimator_options_get.argtypes = [op, cp, dp]
    L.sr_estimator_options_get.restype = ip
    L.sr_estimator_options_check.argtypes = [op, cp, sz]
    L.sr_estimator_options_check.restype = ip
    L.sr_estimator_model_options.argtypes = [vp, op]
    L.sr_estimator_model_options.restype = None
    L.sr_estimator_excite_request.argtypes = [vp, ip, ip]
    L.sr_estimator_excite_request.restype = ctypes.c_double
    L.sr_estimator_outputs.argtypes = [ctypes.POINTER(SrEstimatorReport), dp]
    L.sr_estimator_outputs.restype = None
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


#: the struct field of an option's other names (the Identifier's ``lam``)
_FIELD = {"lambda": "lambda_", "lam": "lambda_"}


@dataclass(frozen=True)
class Option:
    """One row of the core's options table: ``name`` (the estimator FMU parameter's, or the
    option's own where no parameter sets it), where it sits in ``sr_estimator_options``
    (``field``, ``index``, byte ``offset``), ``integer`` (an Integer parameter), ``parameter``
    (an FMU parameter sets it), its accepted closed range ``min``, ``max`` (where it is a
    parameter) and ``default``."""

    name: str
    field: str
    index: int
    offset: int
    integer: bool
    parameter: bool
    min: float
    max: float
    default: float


def option_table(lib: Optional[ctypes.CDLL] = None) -> Tuple[Option, ...]:
    """The core's options table (``native/src/est_options.c``), in its order (the order of
    its checks)."""
    L = _bind(lib or _default_lib())
    if getattr(L, "_sr_option_table", None) is None:
        o = SrEstimatorOptions()
        L.sr_estimator_options_default(ctypes.byref(o))
        rows = []
        for i in range(L.sr_estimator_option_count()):
            name = L.sr_estimator_option_name(i)
            lo, hi, start = ctypes.c_double(math.nan), ctypes.c_double(math.nan), ctypes.c_double()
            L.sr_estimator_param_range(name, ctypes.byref(lo), ctypes.byref(hi))
            L.sr_estimator_options_get(ctypes.byref(o), name, ctypes.byref(start))
            rows.append(Option(name.decode(), L.sr_estimator_option_field(i).decode(),
                               L.sr_estimator_option_index(i), L.sr_estimator_option_offset(i),
                               bool(L.sr_estimator_option_integer(i)),
                               bool(L.sr_estimator_option_parameter(i)), lo.value, hi.value,
                               start.value))
        L._sr_option_table = tuple(rows)
    return L._sr_option_table


def parameter_ranges(names: Optional[Iterable[str]] = None,
                     lib: Optional[ctypes.CDLL] = None) -> Dict[str, Tuple[float, float]]:
    """``{FMI name: (min, max)}``: the closed ranges the core accepts
    (``sr_estimator_param_range``) of every estimator FMU parameter and input (of a robot with the
    most joints the core takes), or of ``names``
    (parameters or inputs, e.g. ``"base.A[1,2]"``; ``KeyError`` for another name). A value in
    its range may still be refused with the others (``sr_estimator_options_check``)."""
    L = _bind(lib or _default_lib())
    if names is None:
        from ..interface import measurement_vars
        from .robot_record import MAX_JOINTS
        names = [o.name for o in option_table(L) if o.parameter]
        names += [v.name for v in measurement_vars(MAX_JOINTS, "input")]
    out = {}
    for name in names:
        lo, hi = ctypes.c_double(), ctypes.c_double()
        if L.sr_estimator_param_range(name.encode(), ctypes.byref(lo), ctypes.byref(hi)):
            raise KeyError(f"{name!r} is not a parameter or input of the estimator FMU")
        out[name] = (lo.value, hi.value)
    return out


def output_names(lib: Optional[ctypes.CDLL] = None) -> Tuple[str, ...]:
    """The estimator FMU's outputs in the core's order (:meth:`NativeEstimator.outputs`)."""
    L = _bind(lib or _default_lib())
    return tuple(L.sr_estimator_output_name(i).decode()
                 for i in range(L.sr_estimator_output_count()))


def status_texts(lib: Optional[ctypes.CDLL] = None) -> Dict[int, str]:
    """``{code: text}`` of ``diag.status`` (``sr_estimator_status_text``)."""
    L = _bind(lib or _default_lib())
    out, code = {}, 0
    while (text := L.sr_estimator_status_text(code)) is not None:
        out[code] = text.decode()
        code += 1
    return out


def input_limit(lib: Optional[ctypes.CDLL] = None) -> float:
    """The largest input magnitude the core accepts, SI units (``SR_EST_INPUT_LIMIT``)."""
    return float(_bind(lib or _default_lib()).sr_estimator_input_limit())


def rotation_tol(lib: Optional[ctypes.CDLL] = None) -> float:
    """``base.A`` is a rotation when ``max |A^T A - I|`` is at most this (and ``det A > 0``)."""
    return float(_bind(lib or _default_lib()).sr_estimator_rotation_tol())


def default_options(lib: Optional[ctypes.CDLL] = None) -> dict:
    """The options' defaults (``sr_estimator_options_default``) as a dictionary of the struct's
    fields (lists for the arrays; ``lambda`` under its FMU name)."""
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


def _set(o: SrEstimatorOptions, name: str, value, L: ctypes.CDLL) -> None:
    """The option ``name`` (an FMU parameter's name) of ``o`` set by the core
    (``sr_estimator_options_set``); ``ValueError`` with its message for a value an Integer
    option cannot hold, ``KeyError`` for an unknown name."""
    if not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a number, got {value!r}")
    x = float(value)
    err = ctypes.create_string_buffer(MSG_LEN)
    st = L.sr_estimator_options_set(ctypes.byref(o), name.encode(), x, err, len(err))
    if st == 2:
        raise KeyError(f"unknown estimator option {name!r}")
    if st:
        raise ValueError(err.value.decode("utf-8", "replace"))


def profile_options(options: Mapping, lib: Optional[ctypes.CDLL] = None) -> dict:
    """The options (a mapping as :class:`NativeEstimator` takes) with their noise profile
    applied (``sr_noise_profile_apply``, native/src/noise_profile.h): what the estimator runs
    with. ``ValueError`` with the core's message for invalid options."""
    L = _bind(lib or _default_lib())
    o, out = _options(options, L), SrEstimatorOptions()
    err = ctypes.create_string_buffer(MSG_LEN)
    if L.sr_noise_profile_apply(ctypes.byref(o), ctypes.byref(out), err, len(err)):
        raise ValueError(err.value.decode("utf-8", "replace"))
    return _as_dict(out)


def profile_values(values: Mapping[str, float], sample_time: float = 0.1,
                   lib: Optional[ctypes.CDLL] = None) -> dict:
    """``{FMU parameter name: value}`` of the estimator options the noise profile of the
    estimator FMU's parameter ``values`` sets (``ident.noise_profile``, ``noise.*``; the
    sensors' densities at ``sample_time`` [s]): what ``sr_noise_profile_apply`` changes, by
    name; empty with ``ident.noise_profile`` = 0."""
    L = _bind(lib or _default_lib())
    given = _options({**options_from_values(values, L), "noise_dt": float(sample_time)}, L)
    used, err = SrEstimatorOptions(), ctypes.create_string_buffer(MSG_LEN)
    if L.sr_noise_profile_apply(ctypes.byref(given), ctypes.byref(used), err, len(err)):
        raise ValueError(err.value.decode("utf-8", "replace"))
    out = {}
    for opt in option_table(L):
        if opt.parameter:
            a, b = ctypes.c_double(), ctypes.c_double()
            L.sr_estimator_options_get(ctypes.byref(given), opt.name.encode(), ctypes.byref(a))
            L.sr_estimator_options_get(ctypes.byref(used), opt.name.encode(), ctypes.byref(b))
            if a.value != b.value:
                out[opt.name] = int(b.value) if opt.integer else b.value
    return out


def _body10(body) -> list:
    """``[m, b (3), Ixx Iyy Izz Ixy Ixz Iyz]`` of a RigidBody or a sequence of 10."""
    if hasattr(body, "mass"):
        return [float(body.mass), *map(float, body.com), *map(float, body.inertia)]
    return [float(x) for x in body]


def _options(values: Mapping, L: ctypes.CDLL) -> SrEstimatorOptions:
    """The options of ``values``: the struct's fields (``guess_base``, ``signal_sd``, ...), the
    core's option names (the estimator FMU's parameters, ``noise_dt``), ``guess`` (a
    ``robots.Guess``) or ``thrust_sd`` (``(scale, misalignment)``); the rest the defaults."""
    o = SrEstimatorOptions()
    L.sr_estimator_options_default(ctypes.byref(o))
    fields = dict(SrEstimatorOptions._fields_)
    names = {opt.name for opt in option_table(L)}
    for key, v in dict(values).items():
        if key == "guess":                                   # a robots.Guess
            o.guess_base[:] = _body10(v.base)
            o.guess_target[:] = _body10(v.target)
            o.P0_mu, o.P0_theta = float(v.P0_mu), float(v.P0_theta)
            continue
        if key == "thrust_sd":                               # Identifier(thrust_sd=...)
            o.sd_thrust_scale, o.sd_thrust_misalign = (float(x) for x in v)
            continue
        if key in names:
            _set(o, key, v, L)
            continue
        name = _FIELD.get(key, key)
        if name not in fields:
            raise KeyError(f"unknown estimator option {key!r}")
        if name in ("guess_base", "guess_target"):
            getattr(o, name)[:] = _body10(v)
        elif name in ("signal_sd", "noise", "row_sd", "mode_f"):
            getattr(o, name)[:] = [float(x) for x in v]
        elif fields[name] is ctypes.c_int:
            setattr(o, name, int(v))
        else:
            setattr(o, name, float(v))
    return o


def options_from_values(values: Mapping[str, float], lib: Optional[ctypes.CDLL] = None) -> dict:
    """The options from the estimator FMU's parameter values (any mapping; the names of the
    core's table are read, the rest ignored) as :class:`NativeEstimator` takes them (the
    struct's fields): what the FMU builds at initialisation. ``ValueError`` with the core's
    message for a value an Integer parameter cannot hold."""
    L = _bind(lib or _default_lib())
    o = SrEstimatorOptions()
    L.sr_estimator_options_default(ctypes.byref(o))
    for opt in option_table(L):
        if opt.name in values:
            _set(o, opt.name, values[opt.name], L)
    return _as_dict(o)


class NativeEstimator:
    """The C estimator: one Model and one Data block.

    Parameters
    ----------
    robot : spacerobot.robots.Robot, SrRobot, or path of a robot record file
    options : mapping, optional
        By the names of the core's options table (the estimator FMU's parameters,
        ``"ident.diff_half_window"``; ``noise_dt``, ``momentum_window_samples``: the momentum
        window's ring capacity, 0 = automatic, samples at least 1 ms apart), or by the fields of
        ``sr_estimator_options`` (``method``, ``lambda``, ``guess_base`` / ``guess_target`` (a
        RigidBody or 10 numbers), ``row_sd`` (4), ``signal_sd`` (6), ``noise`` (17), ...),
        ``guess`` (a ``robots.Guess``: both bodies and P0) and ``thrust_sd`` (``(scale,
        misalignment)``); the rest keep ``sr_estimator_options_default``.
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

    def model_options(self) -> dict:
        """The options the core runs with (``sr_estimator_model_options``: the noise profile
        applied, those that do not apply to the method and accelerations at 0)."""
        o = SrEstimatorOptions()
        self._lib.sr_estimator_model_options(self._model, ctypes.byref(o))
        return _as_dict(o)

    def excite_request(self, identified: Mapping[str, bool]) -> float:
        """The excitation level requested for the bodies' identified flags
        (``{'base': bool, 'target': bool}``; ``sr_estimator_excite_request``)."""
        return float(self._lib.sr_estimator_excite_request(
            self._model, int(bool(identified["base"])), int(bool(identified["target"]))))

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
        bounds at rate 1 and at the candidate; 0 before the choice); ``mode_f`` [Hz] and
        ``mode_zeta`` (4,: the modal columns' modes in use, 0 for none); ``model_fit`` and
        ``misfit`` (the model-fit test: diag.model_fit, diag.misfit) and ``misfit_cause``
        (the FMU's Integer diag.misfit_cause as its name: "" without a misfit, "model" where
        the rigid model does not fit (the estimates held), "thrust" where a thrust scale is beyond its prior with white
        residuals, "noise" for chi2 alone: the noise values too small); ``band`` (the rigid
        band's answer reported, ident.band = 1: 1 the low-pass alone, 2 with the compliance
        block, 3 with the found modes' columns (ident.modes = 1), 0 none)."""
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
            "mode_f": np.array(r.mode_f[:]), "mode_zeta": np.array(r.mode_zeta[:]),
            "model_fit": r.model_fit, "misfit": bool(r.misfit),
            "misfit_cause": MISFIT_CAUSES.get(r.misfit_cause, ""), "band": r.band,
        }

    def outputs(self) -> np.ndarray:
        """The estimator FMU's outputs of the current state, in the order of
        :func:`output_names` (``sr_estimator_outputs``; the Integer ones as exact floats)."""
        r, out = self._report, np.empty(self._lib.sr_estimator_output_count())
        self._lib.sr_estimator_report_get(self._model, self._data, ctypes.byref(r))
        self._lib.sr_estimator_outputs(ctypes.byref(r), dptr(out))
        return out

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
