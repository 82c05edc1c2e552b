"""pythonfmu slave of the sensor models: a thin wrapper mapping FMI variables to
spacerobot.sensors. It never imports plant or estimator code: inside the FMU the library is
bundled as ``_spacerobot_sensors`` with only the robot description, the interface table, the
FMI base class and the sensor models (``fmi/build.py``'s ``BUNDLES``).

Direct feedthrough: the outputs at ``t`` are the measurement of the inputs set at ``t`` (a
master that reads the plant, sets these inputs, then reads these outputs passes the sample on
within the same communication point); ``doStep(t, dt)`` moves the noise processes on.
"""
import math

import numpy as np

from _spacerobot_sensors.fmi.slave import InterfaceSlave, _escape
from _spacerobot_sensors.interface import NOISE_PARAMETERS, sensors_vars
from _spacerobot_sensors.sensors import SensorSuite
from pythonfmu.enums import Fmi2Status


class SpaceRobotSensors(InterfaceSlave):
    """Sensors of a space robot: the plant's true signals in, measurements out."""

    author = "spacerobot developers"
    description = ("Sensors of a space robot servicer: gyro (white noise, bias random walk), "
                   "star tracker, relative navigation, accelerometer / IMU, joint encoders "
                   "(quantisation), thrust knowledge (scale factor, misalignment), sample "
                   "delay. noise.scale = 0: outputs equal inputs.")
    version = "0.1.0"
    license = "MIT"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._setup(sensors_vars)
        self.suite = None
        n = self.robot.n_joints
        self._inputs = [n_ for n_, v in self.interface.items() if v.causality == "input"]
        # where each output sits in the measurement arrays: (name, group, index)
        self._outs = [(n_, v.key[0], v.key[1]) for n_, v in self.interface.items()
                      if v.causality == "output"]
        self._shapes = {"A": (3, 3), "q": (n,), "qd": (n,), "qdd": (n,)}
        self._keys = [self.interface[n_].key for n_ in self._inputs]

    def _initialise(self) -> None:
        v = self.values
        params = {k[len("noise."):]: float(v[k]) for k in NOISE_PARAMETERS if k != "noise.scale"}
        if int(v["noise.imu"]) not in (0, 1):
            self._fail(f"noise.imu must be 0 or 1, got {v['noise.imu']!r}")
        try:
            self.suite = SensorSuite(self.robot.n_joints, params, float(v["noise.scale"]),
                                     int(v["seed"]), int(v["noise.delay"]),
                                     bool(int(v["noise.imu"])), self.scenario.sample_time)
        except ValueError as e:
            self._fail(f"invalid sensor parameters: {e}")

    def _sample(self) -> dict:
        """The true sample: the inputs as the core's arrays."""
        x = {g: np.zeros(s) for g, s in self._shapes.items()}
        for name, (group, idx) in zip(self._inputs, self._keys):
            x.setdefault(group, np.zeros(3))[idx] = float(self.values[name])
        return x

    def _measure(self) -> dict:
        """Outputs: the measurement of the current inputs (computed when read)."""
        if self.suite is None:
            return {}
        y = self.suite.measure(self._sample())
        return {name: float(y[group][idx]) for name, group, idx in self._outs}

    def get_real(self, vrs):
        self._ensure_current()
        self._outputs = self._measure()
        return super().get_real(vrs)

    def _get_output(self, name: str):
        self._ensure_current()
        return self._measure().get(name, 0)

    def do_step(self, current_time: float, step_size: float) -> bool:
        if not self._check_step(current_time, step_size, math.inf):
            return False
        x = self._sample()
        bad = [n for n in self._inputs if not math.isfinite(float(self.values[n]))]
        if bad:
            self.log(_escape(f"t = {current_time:.6g} s: non-finite input(s) "
                             f"{', '.join(bad[:5])}: passed on unchanged"), Fmi2Status.warning)
        self.suite.advance(x, step_size)
        return True

    def _core_state(self):
        return None if self.suite is None else self.suite.get_state()

    def _restore_core_state(self, core) -> None:
        if core is None:
            self.suite = None
            return
        if self.suite is None:
            self._initialise()
        self.suite.set_state(core)

