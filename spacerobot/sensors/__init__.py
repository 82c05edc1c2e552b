"""Sensor models between the plant's true signals and the estimator: gyro, star tracker,
relative navigation, accelerometer / IMU, joint encoders, thrust knowledge, sample delay.

Importable and testable without FMI; ``fmu_sensors/`` wraps :class:`SensorSuite` as
``SpaceRobotSensors.fmu``. Parameters and their realistic defaults:
:data:`spacerobot.interface.NOISE_PARAMETERS`; models: docs/sensors.md.
"""
from .models import (SIGNALS, SensorSuite, default_parameters, estimator_noise_settings,
                     rotation_vector_to_matrix)

__all__ = ["SIGNALS", "SensorSuite", "default_parameters", "estimator_noise_settings",
           "rotation_vector_to_matrix"]
