"""The sensor models of the native core (``native/src/sensors.h``) through ctypes.

:class:`NativeSensors` (exported as :class:`spacerobot.sensors.SensorSuite`) takes samples as
``{signal: array}`` of the core's sample table (:mod:`spacerobot.core.sample`) and draws its
noise from the core's portable generator: the same seed gives the same bits on every platform
and in the sensors FMU. :func:`parameter_ranges` gives the ranges the core accepts, which the
FMU's model description declares as ``min`` / ``max``.
"""
from __future__ import annotations

import ctypes
from typing import Dict, Mapping, Optional, Tuple

import numpy as np

from . import dptr, lib
from . import sample
from ..sensors.models import default_parameters

_bound = set()


def _bind(L: ctypes.CDLL) -> ctypes.CDLL:
    if id(L) in _bound:
        return L
    dp, vp = ctypes.POINTER(ctypes.c_double), ctypes.c_void_p
    L.sr_sensors_model_size.restype = ctypes.c_size_t
    L.sr_sensors_state_size.restype = ctypes.c_size_t
    L.sr_sensors_parameter_name.restype = ctypes.c_char_p
    L.sr_sensors_parameter_name.argtypes = [ctypes.c_int]
    L.sr_sensors_init.argtypes = [vp, ctypes.c_int, dp, ctypes.c_double, ctypes.c_longlong,
                                  ctypes.c_int, ctypes.c_int, ctypes.c_double, ctypes.c_char_p,
                                  ctypes.c_int]
    L.sr_sensors_start.argtypes = [vp, vp]
    L.sr_sensors_measure.argtypes = [vp, vp, dp, dp]
    L.sr_sensors_advance.argtypes = [vp, vp, dp, ctypes.c_double]
    L.sr_sensors_param_range.argtypes = [ctypes.c_char_p, dp, dp]
    _bound.add(id(L))
    return L


def parameter_ranges(L: Optional[ctypes.CDLL] = None) -> Dict[str, Tuple[float, float]]:
    """``{FMU name: (min, max)}`` the sensors core accepts (``sr_sensors_param_range``) for every
    parameter of the sensors FMU and every input ``true.<name>`` of a robot with the most joints
    the core takes; the model description declares them."""
    from ..interface import NOISE_PARAMETERS, SENSOR_INTEGER_PARAMETERS, TRUE_PREFIX
    from ..interface import measurement_vars
    from .robot_record import MAX_JOINTS

    L = _bind(L or lib())
    names = [*NOISE_PARAMETERS, *SENSOR_INTEGER_PARAMETERS,
             *(TRUE_PREFIX + v.name for v in measurement_vars(MAX_JOINTS, "input"))]
    lo, hi, out = ctypes.c_double(), ctypes.c_double(), {}
    for name in names:
        if L.sr_sensors_param_range(name.encode(), ctypes.byref(lo), ctypes.byref(hi)) != 0:
            raise ValueError(f"the sensors core knows no range of {name}")
        out[name] = (lo.value, hi.value)
    return out


def parameter_names(L: Optional[ctypes.CDLL] = None) -> list:
    """The core's order of the noise magnitudes (``noise.`` names without the prefix)."""
    L = _bind(L or lib())
    out, i = [], 0
    while (name := L.sr_sensors_parameter_name(i)) is not None:
        out.append(name.decode()[len("noise."):])
        i += 1
    return out


class NativeSensors:
    """Every sensor of the servicer, with its state (biases, draws, delay line).

    Parameters
    ----------
    n_joints : int
    params : mapping, optional
        Model parameters by name without ``noise.`` (:func:`spacerobot.sensors.default_parameters`;
        missing ones take their defaults). Every magnitude is multiplied by ``scale``.
    scale : float
        0 = ideal (the measurement is the true sample, bit for bit), 1 = ``params`` as given.
    seed : int
        Seed of the random streams (one per sensor; deterministic per seed, on every platform).
    delay : int
        Sample delay: :meth:`measure` returns the measurement of ``delay`` samples before
        (the first measurement while fewer have been taken), 0..100.
    imu : bool
        False: no accelerometer / IMU; ``a_S`` and ``alpha_B`` are 0.
    dt : float
        Nominal sample interval [s], for the white-noise draws of the first sample.
    """

    def __init__(self, n_joints: int, params: Optional[Mapping[str, float]] = None,
                 scale: float = 1.0, seed: int = 0, delay: int = 0, imu: bool = True,
                 dt: float = 0.1, library: Optional[ctypes.CDLL] = None):
        self._L = L = _bind(library or lib())
        p = default_parameters()
        unknown = set(params or {}) - set(p)
        if unknown:
            raise ValueError(f"unknown noise parameters {sorted(unknown)}; known: {sorted(p)}")
        p.update({k: float(v) for k, v in (params or {}).items()})
        noise = np.array([p[k] for k in parameter_names(L)], dtype=float)
        if not (float(delay) == int(delay)):
            raise ValueError(f"noise.delay must be an integer >= 0, got {delay!r}")
        self.n = int(n_joints)
        self._model = ctypes.create_string_buffer(L.sr_sensors_model_size())
        self._state = ctypes.create_string_buffer(L.sr_sensors_state_size())
        msg = ctypes.create_string_buffer(256)
        if L.sr_sensors_init(self._model, self.n, dptr(noise), float(scale), int(seed),
                             int(delay), int(bool(imu)), float(dt), msg, len(msg)) != 0:
            raise ValueError(msg.value.decode())
        L.sr_sensors_start(self._model, self._state)
        self._sizes = [(s.key, s.size) for s in sample.signals(self.n, L)]
        self._len = sample.sample_length(self.n, L)

    def flat(self, x: Mapping[str, np.ndarray]) -> np.ndarray:
        """The flat sample (the core's order) of ``x``."""
        return np.concatenate([np.asarray(x[s], dtype=float).ravel() for s, _ in self._sizes])

    def sample(self, y: np.ndarray) -> Dict[str, np.ndarray]:
        """``{signal: array}`` of a flat sample."""
        out, k = {}, 0
        for s, size in self._sizes:
            out[s] = y[k:k + size].reshape((3, 3) if s == "A" else (size,)).copy()
            k += size
        return out

    def measure(self, x: Mapping[str, np.ndarray]) -> Dict[str, np.ndarray]:
        """The measurement at the time of the true sample ``x`` (state unchanged)."""
        xf, y = self.flat(x), np.empty(self._len)
        if self._L.sr_sensors_measure(self._model, self._state, dptr(xf), dptr(y)) != 0:
            raise ValueError("the sensors' state is inconsistent")
        return self.sample(y)

    def advance(self, x: Mapping[str, np.ndarray], dt: float) -> None:
        """Move on from the sample ``x`` to the next, ``dt`` [s] later."""
        status = self._L.sr_sensors_advance(self._model, self._state, dptr(self.flat(x)),
                                            float(dt))
        if status == 2:
            raise ValueError(f"sample interval must be > 0, got {dt!r}")
        if status != 0:
            raise ValueError("the sensors' state is inconsistent")

    def update(self, x: Mapping[str, np.ndarray], dt: float) -> Dict[str, np.ndarray]:
        """:meth:`measure` then :meth:`advance`: the measurement of ``x``."""
        y = self.measure(x)
        self.advance(x, dt)
        return y

    def get_state(self) -> bytes:
        """Everything that evolves (the generators included)."""
        return self._state.raw

    def set_state(self, state: bytes) -> None:
        """Restore :meth:`get_state` (of sensors built with the same parameters)."""
        if len(state) != len(self._state):
            raise ValueError(f"a sensors state has {len(self._state)} bytes, got {len(state)}")
        ctypes.memmove(self._state, state, len(state))
