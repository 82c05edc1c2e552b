"""The sensor models (docs/sensors.md) in NumPy: the independent reference of the native
sensors core (native/src/sensors.c, which the library's :class:`spacerobot.sensors.SensorSuite`
and the sensors FMU run). NumPy's generator: the same statistics, not the same numbers.

A sample is a dict of arrays keyed by the interface's groups (:func:`spacerobot.interface.
measurement_vars`): ``r_S, v_S (3,)``, ``A (3, 3)``, ``omega_B, a_S, alpha_B (3,)``,
``q, qd, qdd (n,)``, ``F, M, J, H (3,)``.

Timing: :meth:`SensorSuite.measure` is a pure function of the true sample and the suite's
state (any number of calls give the same answer); :meth:`SensorSuite.advance` then moves the
noise processes one sample interval on (bias random walks, the next white-noise draws, the
angular impulse error, the delay line). A co-simulation reads the measurement of ``t`` at
``t`` (direct feedthrough) and advances in ``doStep(t, dt)``.
"""
from __future__ import annotations

import collections
import copy
from typing import Dict, Mapping, Optional

import numpy as np

from spacerobot.sensors import SIGNALS, default_parameters

#: one independent random stream per sensor (changing one sensor's parameters leaves the
#: other sensors' noise unchanged)
_STREAMS = ("gyro", "star", "nav", "imu", "enc", "thrust")


def _skew(w: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def rotation_vector_to_matrix(phi: np.ndarray) -> np.ndarray:
    """``exp([phi]x)`` (3, 3) of a rotation vector ``phi`` (3,) [rad] (Rodrigues)."""
    angle = float(np.linalg.norm(phi))
    K = _skew(phi)
    if angle < 1e-8:                        # series: exact to round-off for such angles
        return np.eye(3) + K + 0.5 * K @ K
    # R = I + sin(a)/a K + (1 - cos(a))/a^2 K^2
    return np.eye(3) + (np.sin(angle) / angle) * K + ((1.0 - np.cos(angle)) / angle ** 2) * K @ K


class SensorSuite:
    """Every sensor of the servicer, with its state (biases, draws, delay line).

    Parameters
    ----------
    n_joints : int
    params : mapping, optional
        Model parameters by name without ``noise.`` (:func:`default_parameters`; missing ones
        take their defaults). Every magnitude is multiplied by ``scale``.
    scale : float
        0 = ideal (the measurement is the true sample, bit for bit), 1 = ``params`` as given.
    seed : int
        Seed of the random streams (deterministic per seed).
    delay : int
        Sample delay: :meth:`measure` returns the measurement of ``delay`` samples before
        (the first measurement while fewer have been taken).
    imu : bool
        False: no accelerometer / IMU; ``a_S`` and ``alpha_B`` are 0.
    dt : float
        Nominal sample interval [s], for the white-noise draws of the first sample.
    """

    def __init__(self, n_joints: int, params: Optional[Mapping[str, float]] = None,
                 scale: float = 1.0, seed: int = 0, delay: int = 0, imu: bool = True,
                 dt: float = 0.1):
        p = default_parameters()
        unknown = set(params or {}) - set(p)
        if unknown:
            raise ValueError(f"unknown noise parameters {sorted(unknown)}; known: {sorted(p)}")
        p.update({k: float(v) for k, v in (params or {}).items()})
        bad = [f"{k} = {v!r}" for k, v in p.items() if not (np.isfinite(v) and v >= 0.0)]
        if bad:
            raise ValueError("noise parameters must be finite and >= 0: " + ", ".join(bad))
        if not (np.isfinite(scale) and scale >= 0.0):
            raise ValueError(f"noise.scale must be finite and >= 0, got {scale!r}")
        if int(delay) != delay or delay < 0:
            raise ValueError(f"noise.delay must be an integer >= 0, got {delay!r}")
        if not (np.isfinite(dt) and dt > 0.0):
            raise ValueError(f"the sample interval must be > 0, got {dt!r}")
        self.n, self.scale, self.delay, self.imu = int(n_joints), float(scale), int(delay), bool(imu)
        # magnitudes in effect: every error scaled by noise.scale
        self.p = {k: self.scale * v for k, v in p.items()}
        self.seed = int(seed)
        self.rng = dict(zip(_STREAMS, (np.random.Generator(np.random.PCG64(s)) for s in
                                       np.random.SeedSequence(self.seed).spawn(len(_STREAMS)))))
        pp, g = self.p, self.rng
        # constant per run: initial biases, thrust scale factor and misalignment
        self.gyro_bias = pp["gyro.bias"] * g["gyro"].standard_normal(3)
        self.accel_bias = pp["accel.bias"] * g["imu"].standard_normal(3)
        self.E_F = self._thrust_error(g["thrust"])        # F_meas = (1 + E_F) F
        self.E_M = self._thrust_error(g["thrust"])
        self.H_err = np.zeros(3)          # integral of the thrust error's angular impulse
        self.draw = self._draw(float(dt))
        self.line = collections.deque(maxlen=self.delay)   # the last `delay` measurements

    def _thrust_error(self, g: np.random.Generator) -> np.ndarray:
        """``(1 + s) R(phi) - I`` with scale factor error ``s`` and misalignment ``phi``."""
        s = self.p["thrust.scale"] * g.standard_normal()
        phi = self.p["thrust.misalign"] * g.standard_normal(3)
        return (1.0 + s) * rotation_vector_to_matrix(phi) - np.eye(3)

    def _draw(self, dt: float) -> Dict[str, np.ndarray]:
        """White-noise draws of one sample; white noise of density ``d`` (its standard
        deviation averaged over 1 s) sampled at interval ``dt`` [s] has standard deviation
        ``d / sqrt(dt)``."""
        p, g, n = self.p, self.rng, self.n
        rt = np.sqrt(dt)
        return {
            "omega_B": (p["gyro.arw"] / rt) * g["gyro"].standard_normal(3),
            "att": np.array([p["star.cross"], p["star.cross"], p["star.roll"]])
            * g["star"].standard_normal(3),
            "r_S": p["nav.r"] * g["nav"].standard_normal(3),
            "v_S": p["nav.v"] * g["nav"].standard_normal(3),
            "a_S": (p["accel.vrw"] / rt) * g["imu"].standard_normal(3),
            "alpha_B": p["alpha"] * g["imu"].standard_normal(3),
            "q": p["enc.q"] * g["enc"].standard_normal(n),
            "qd": p["enc.qd"] * g["enc"].standard_normal(n),
            "qdd": p["enc.qdd"] * g["enc"].standard_normal(n),
        }

    # -- measurement --------------------------------------------------------------------------
    def _corrupt(self, x: Mapping[str, np.ndarray]) -> Dict[str, np.ndarray]:
        """The measurement of the true sample ``x`` now (no delay)."""
        if self.scale == 0.0:              # ideal: the true sample itself, bit for bit
            y = {k: np.array(x[k], dtype=float, copy=True) for k in SIGNALS}
        else:
            d = self.draw
            res = self.p["enc.resolution"]
            q = x["q"] + d["q"]
            y = {
                "r_S": x["r_S"] + d["r_S"],
                "v_S": x["v_S"] + d["v_S"],
                # star tracker: a small rotation in the base frame, x_I = A exp([att]x) x_B
                "A": np.asarray(x["A"]) @ rotation_vector_to_matrix(d["att"]),
                "omega_B": x["omega_B"] + self.gyro_bias + d["omega_B"],
                "a_S": x["a_S"] + self.accel_bias + d["a_S"],
                "alpha_B": x["alpha_B"] + d["alpha_B"],
                "q": res * np.round(q / res) if res > 0.0 else q,   # encoder quantisation
                "qd": x["qd"] + d["qd"],
                "qdd": x["qdd"] + d["qdd"],
                "F": x["F"] + self.E_F @ x["F"],
                "M": x["M"] + self.E_M @ x["M"],
                # J = int F dt, and E_F is constant: int (1 + E_F) F dt = J + E_F J
                "J": x["J"] + self.E_F @ x["J"],
                "H": x["H"] + self.H_err,
            }
        if not self.imu:
            y["a_S"], y["alpha_B"] = np.zeros(3), np.zeros(3)
        return y

    def measure(self, x: Mapping[str, np.ndarray]) -> Dict[str, np.ndarray]:
        """The measurement output at the time of the true sample ``x`` (with the sample delay:
        the measurement of ``delay`` samples before). Does not change the state."""
        y = self._corrupt(x)
        if self.delay == 0:
            return y
        line = list(self.line) + [y]
        return copy.deepcopy(line[max(0, len(line) - 1 - self.delay)])

    def advance(self, x: Mapping[str, np.ndarray], dt: float) -> None:
        """Move on from the sample ``x`` to the next, ``dt`` [s] later: remember the
        measurement of ``x`` (delay line), integrate the thrust error's angular impulse over
        the interval (thrust held), walk the biases, draw the next white noise."""
        if not (np.isfinite(dt) and dt > 0.0):
            raise ValueError(f"sample interval must be > 0, got {dt!r}")
        if self.delay:
            self.line.append(self._corrupt(x))
        if self.scale == 0.0:
            return
        p, g = self.p, self.rng
        # H = int (M + r_S x F) dt: its error is int (E_M M + r_S x E_F F) dt; a non-finite
        # sample (passed on for the estimator to reject) adds nothing
        dH = dt * (self.E_M @ x["M"] + np.cross(x["r_S"], self.E_F @ x["F"]))
        if np.all(np.isfinite(dH)):
            self.H_err = self.H_err + dH
        # bias random walks: b(t + dt) = b(t) + d sqrt(dt) N(0, 1), d the change over 1 s
        self.gyro_bias = self.gyro_bias + p["gyro.rrw"] * np.sqrt(dt) * g["gyro"].standard_normal(3)
        self.accel_bias = self.accel_bias + p["accel.brw"] * np.sqrt(dt) * g["imu"].standard_normal(3)
        self.draw = self._draw(dt)

    def update(self, x: Mapping[str, np.ndarray], dt: float) -> Dict[str, np.ndarray]:
        """:meth:`measure` then :meth:`advance`: the measurement of ``x``."""
        y = self.measure(x)
        self.advance(x, dt)
        return y

    # -- state ----------------------------------------------------------------------------------
    def get_state(self) -> dict:
        """Everything that evolves (random generators included), as a picklable copy."""
        return copy.deepcopy({
            "rng": {k: g.bit_generator.state for k, g in self.rng.items()},
            "gyro_bias": self.gyro_bias, "accel_bias": self.accel_bias, "H_err": self.H_err,
            "E_F": self.E_F, "E_M": self.E_M, "draw": self.draw, "line": list(self.line)})

    def set_state(self, state: dict) -> None:
        """Restore :meth:`get_state` (of a suite built with the same parameters)."""
        s = copy.deepcopy(state)
        for k, st in s["rng"].items():
            self.rng[k].bit_generator.state = st
        self.gyro_bias, self.accel_bias, self.H_err = s["gyro_bias"], s["accel_bias"], s["H_err"]
        self.E_F, self.E_M, self.draw = s["E_F"], s["E_M"], s["draw"]
        self.line = collections.deque(s["line"], maxlen=self.delay)
