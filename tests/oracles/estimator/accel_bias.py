"""The accelerometer's bias, estimated from the navigation velocity it must integrate to.

The force method with measured accelerations reads the base's linear acceleration ``a_S`` from
an accelerometer whose bias (hundreds of micro-g for a navigation-grade unit) is a sizeable
fraction of a servicer's accelerations (~0.01 m/s2) and enters every row of the force equations
multiplied by the whole system's mass: a systematic error that more samples do not average.
The navigation measures the base's velocity ``v_S`` too, and over a run

    v_S(t) = v_S(t0) + integral_t0^t (a_meas - b) dt + noise,

so ``x(t) = v_S(t) - I(t)``, ``I`` the running trapezoidal integral of the measured
acceleration, is a straight line ``c - b (t - t0)`` plus the navigation noise, the
accelerometer's integrated white noise and the trapezoid's error where the acceleration
jumps. Its least-squares slope is ``-b``; from running sums, constant cost per sample.

What limits it is the accelerometer's own white noise: integrated, it is a random walk of
``vrw sqrt(t)`` in ``x`` that a line fit cannot tell from a slope, a slope error of about
``vrw sqrt(1.2 / T)`` after ``T`` seconds (the navigation's white velocity noise adds only
``sigma sqrt(12 / N) / T``). Measured on the noise benchmark's telemetry (realistic sensors:
a 3e-3 m/s2 bias, vrw 5e-4 m/s2 over 1 s): the estimate within 1e-4 to 3e-4 m/s2 of the bias
from 5 s on. Without noise the trapezoid's error where the acceleration changes within a step
remains (2e-4 m/s2 on the paper's spatial run, whose base accelerates at 0.4 m/s2): the option
is for noisy sensors.

Assumption: ``b`` is constant in the frame of ``a_S``, the inertial frame, as the sensors
model (:mod:`spacerobot.sensors.models`) draws it. A strapdown accelerometer's bias is fixed in
the base, ``A(t) b_B`` inertial; on a base that rotates much during the fit this line fit does
not describe it (the regressor would be ``integral A dt`` instead of ``t``).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = ["BiasFit"]


class BiasFit(NamedTuple):
    """Running least-squares line through ``x(t) = v(t) - integral a dt`` per axis; the bias is
    minus its slope (module docstring). Immutable: :meth:`add` returns the updated fit (so an
    identifier's snapshot holds it by reference).

    ``t0`` first sample time [s]; ``t_last``, ``a_last`` (3,) the last sample's time and
    measured acceleration (for the trapezoid); ``integral`` (3,) [m/s]; sums over samples of
    ``1, tau, tau^2`` (``s``, (3,)) and of ``x, tau x`` (``sx``, (2, 3)), ``tau = t - t0``.
    """

    t0: float = 0.0
    t_last: float = 0.0
    a_last: np.ndarray = np.zeros(3)
    integral: np.ndarray = np.zeros(3)
    s: np.ndarray = np.zeros(3)
    sx: np.ndarray = np.zeros((2, 3))

    def add(self, t: float, v: np.ndarray, a: np.ndarray) -> "BiasFit":
        """With one more sample: time ``t`` [s] (after the last), measured velocity ``v`` (3,)
        [m/s] and measured acceleration ``a`` (3,) [m/s2]."""
        v, a = np.array(v, float), np.array(a, float)
        if self.s[0] == 0.0:
            t0, integral = float(t), np.zeros(3)
        else:
            # trapezoid: integral += (t - t_last) (a_last + a) / 2
            t0, integral = self.t0, self.integral + 0.5 * (t - self.t_last) * (self.a_last + a)
        tau = float(t) - t0
        x = v - integral                                   # x = v - I = c - b tau + noise
        return BiasFit(t0, float(t), a, integral, self.s + (1.0, tau, tau * tau),
                       self.sx + np.stack([x, tau * x]))

    def bias(self) -> np.ndarray:
        """The bias estimate (3,) [m/s2]: minus the least-squares slope, 0 before two distinct
        times. ``slope = (n sum tau x - sum tau sum x) / (n sum tau^2 - (sum tau)^2)``."""
        n, s1, s2 = self.s
        den = n * s2 - s1 * s1
        if not den > 0.0:
            return np.zeros(3)
        return -(n * self.sx[1] - s1 * self.sx[0]) / den
