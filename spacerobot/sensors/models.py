"""The sensor models' parameters (docs/sensors.md); the models themselves are the native
core's (``native/src/sensors.c``, :class:`spacerobot.core.sensors.NativeSensors`, exported as
:class:`spacerobot.sensors.SensorSuite`).

A sample is a dict of arrays keyed by the interface's groups (:func:`spacerobot.interface.
measurement_vars`): ``r_S, v_S (3,)``, ``A (3, 3)``, ``omega_B, a_S, alpha_B (3,)``,
``q, qd, qdd (n,)``, ``F, M, J, H (3,)``.
"""
from __future__ import annotations

import math
from typing import Dict, Mapping, Optional

from ..interface import NOISE_PARAMETERS

#: the measurement groups, in the interface's order (and the core's flat sample's)
SIGNALS = ("r_S", "v_S", "A", "omega_B", "a_S", "alpha_B", "q", "qd", "qdd", "F", "M", "J", "H")


def default_parameters() -> Dict[str, float]:
    """``{'gyro.arw': ..., ...}``: the realistic defaults (names without ``noise.``; the
    scale is not a parameter of the models)."""
    return {k[len("noise."):]: float(d) for k, (_, d, _) in NOISE_PARAMETERS.items()
            if k != "noise.scale"}


def estimator_noise_settings(params: Optional[Mapping[str, float]] = None, scale: float = 1.0,
                             dt: float = 0.1) -> Dict[str, float]:
    """The estimator parameters that describe these sensors' errors to it
    (docs/identification.md, section 6): the thrust errors' consider covariance
    (``ident.sd_thrust.*``) and the per-sample white noise of the signals the force method's
    accelerations come from (``ident.noise.*``: measured ``base.a``, ``base.alpha``,
    ``arm.qdd``; for differenced accelerations ``base.v``, ``base.omega``, ``arm.qd``).

    Parameters
    ----------
    params : sensor parameters (names without ``noise.``) over :func:`default_parameters`
    scale : ``noise.scale``;  dt : the sample interval [s] (densities ``d`` give ``d /
        sqrt(dt)`` per sample, as the sensors draw them)
    """
    p = default_parameters()
    p.update({k: float(v) for k, v in (params or {}).items()})
    p = {k: scale * v for k, v in p.items()}
    rt = math.sqrt(dt)
    return {"ident.sd_thrust.scale": p["thrust.scale"],
            "ident.sd_thrust.misalign": p["thrust.misalign"],
            "ident.noise.base.a": p["accel.vrw"] / rt,
            "ident.noise.base.alpha": p["alpha"],
            "ident.noise.arm.qdd": p["enc.qdd"],
            "ident.noise.base.v": p["nav.v"],
            "ident.noise.base.omega": p["gyro.arw"] / rt,
            "ident.noise.arm.qd": p["enc.qd"]}
