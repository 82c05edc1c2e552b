"""Sensor models between the plant's true signals and the estimator: gyro, star tracker,
relative navigation, accelerometer / IMU, joint encoders, thrust knowledge, sample delay.

Importable and testable without FMI: :class:`SensorSuite` runs the native core
(``native/src/sensors.c``) that ``SpaceRobotSensors.fmu`` runs, with its portable random
generator (a seed gives the same noise on every platform and in the FMU). Parameters and their
realistic defaults: :data:`spacerobot.interface.NOISE_PARAMETERS`; models: docs/sensors.md.
"""
from .models import default_parameters, estimator_noise_settings

__all__ = ["SIGNALS", "SensorSuite", "default_parameters", "estimator_noise_settings"]


def __getattr__(name):
    # imported when first used: the binding imports this package's models module, and the
    # signals are read from the native core's sample table
    if name == "SensorSuite":
        from ..core.sensors import NativeSensors
        return NativeSensors
    if name == "SIGNALS":
        from ..core.sample import keys
        return keys()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
