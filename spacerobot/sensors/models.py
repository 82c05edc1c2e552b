"""The sensor models' parameters (docs/sensors.md); the models themselves are the native
core's (``native/src/sensors.c``, :class:`spacerobot.core.sensors.NativeSensors`, exported as
:class:`spacerobot.sensors.SensorSuite`).

A sample is a dict of arrays keyed by the interface's groups (:func:`spacerobot.interface.
measurement_vars`): ``r_S, v_S (3,)``, ``A (3, 3)``, ``omega_B, a_S, alpha_B (3,)``,
``q, qd, qdd (n,)``, ``F, M, J, H (3,)``.
"""
from __future__ import annotations

from typing import Dict, Mapping, Optional

from ..interface import NOISE_PARAMETERS


def __getattr__(name: str):
    # SIGNALS: the measurement groups in the core's flat sample's order, read from the native
    # core's sample table (spacerobot.core.sample) when first used
    if name == "SIGNALS":
        from ..core.sample import keys
        return keys()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def default_parameters() -> Dict[str, float]:
    """``{'gyro.arw': ..., ...}``: the realistic defaults (names without ``noise.``; the
    scale is not a parameter of the models)."""
    return {k[len("noise."):]: float(d) for k, (_, d, _) in NOISE_PARAMETERS.items()
            if k != "noise.scale"}


def estimator_noise_settings(params: Optional[Mapping[str, float]] = None, scale: float = 1.0,
                             dt: float = 0.1, method: int = 2,
                             accel_source: int = 1) -> Dict[str, float]:
    """The estimator parameters that the noise profile (``ident.noise_profile`` = 1, the
    native core's ``sr_noise_profile_apply``; docs/identification.md, "One switch") sets for
    these sensors and the estimator's ``method`` / ``accel_source`` (codes of
    :class:`spacerobot.interface.Method` / ``AccelSource``): ``{FMU name: value}`` of each
    option it moves from its default, e.g. the thrust errors' consider covariance
    (``ident.sd_thrust.*``), the per-sample white noise of the signals the force method's
    accelerations come from (``ident.noise.*``), the method's windows.

    Parameters
    ----------
    params : sensor parameters (names without ``noise.``) over :func:`default_parameters`
    scale : ``noise.scale``;  dt : the sample interval [s] (densities ``d`` give ``d /
        sqrt(dt)`` per sample, as the sensors draw them)
    """
    from ..core.estimator import profile_values
    from ..interface import estimator_parameter_values
    from ..robots import scenario
    p = default_parameters()
    p.update({k: float(v) for k, v in (params or {}).items()})
    sc = scenario("planar")                  # any robot: the profile reads no robot
    values = estimator_parameter_values(sc.robot, sc)
    values.update({"method": int(method), "accel_source": int(accel_source),
                   "ident.noise_profile": 1, "noise.scale": float(scale)})
    values.update({f"noise.{k}": x for k, x in p.items()})
    return profile_values(values, dt)
