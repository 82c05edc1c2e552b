"""The plant: the free-floating space robot after capture, integrated with RK4 (no FMI).

The numerical core is the native C library (``native/src/plant.h``: model and data blocks, the
rigid-body algorithms, the controllers of eqs. 39-41, the excitation, the propellant, RK4 and
the outputs) bound with ctypes in :mod:`spacerobot.core.plant`. :class:`Plant` is that binding
(:class:`spacerobot.core.plant.NativePlant`); the plant FMUs (native and pythonfmu) run the
same library.

Examples
--------
>>> from spacerobot.plant import Plant                                         # doctest: +SKIP
>>> from spacerobot.robots import scenario                                     # doctest: +SKIP
>>> sc = scenario("planar")                                                    # doctest: +SKIP
>>> p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h)
>>> p.advance(0.1); p.outputs()["P"]                                           # doctest: +SKIP
"""
from ..core.plant import Controls, NativePlant

#: the plant (the native core; see :class:`spacerobot.core.plant.NativePlant`)
Plant = NativePlant

__all__ = ["Plant", "Controls"]
