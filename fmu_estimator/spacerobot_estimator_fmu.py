"""pythonfmu slave of the identifier: a thin wrapper mapping FMI variables to
spacerobot.estimator. It never imports plant code: inside the FMU the library is bundled as
``_spacerobot_estimator`` with only the robot description, kinematics and estimator.
"""
import math

import numpy as np

from _spacerobot_estimator.estimator import Identifier
from _spacerobot_estimator.fmi.slave import InterfaceSlave, _escape
from _spacerobot_estimator.interface import (ACCEL_SOURCES, METHODS, SOLVERS, STATUS,
                                             estimator_vars)
from _spacerobot_estimator.robots import Guess
from pythonfmu.enums import Fmi2Status


class SpaceRobotEstimator(InterfaceSlave):
    """Online one-step identification of base and target inertial parameters."""

    author = "spacerobot developers"
    description = ("Online one-step identification of the mass, centre of mass and inertia of "
                   "both the base and the captured target of a space robot, from measurements "
                   "alone (momentum- or force-based equations, modified RLS; Zhang, Yue, Yuan 2020).")
    version = "0.1.0"
    license = "MIT"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._setup(estimator_vars)
        self.ident = None
        self._inputs = [(n, v.key) for n, v in self.interface.items() if v.causality == "input"]
        self._sd = None

    def _initialise(self) -> None:
        v = self.values
        try:
            for name, table in (("method", METHODS), ("solver", SOLVERS),
                                ("accel_source", ACCEL_SOURCES)):
                if int(v[name]) not in table:
                    raise ValueError(f"{name} = {v[name]!r} is not one of "
                                     + ", ".join(f"{k} ({s})" for k, s in table.items()))
            guess = Guess(self._body("guess.base"), self._body("guess.target"),
                          float(v["P0_mu"]), float(v["P0_theta"]))
            self.ident = Identifier(self.robot, guess, METHODS[int(v["method"])],
                                    SOLVERS[int(v["solver"])], ACCEL_SOURCES[int(v["accel_source"])],
                                    float(v["lambda"]))
        except ValueError as e:
            self._fail(f"invalid estimator parameters: {e}")
        self._refresh()

    def _refresh(self) -> None:
        est = self.ident.vector()
        o = {}
        for name, var in self.interface.items():
            if var.causality != "output":
                continue
            o[name] = self._value(var, est)
        self._outputs = o
        self._sd = None

    def _value(self, var, est):
        key = var.key
        group = key[0]
        if group in ("est_base", "est_target"):
            return float(est[_flat(key, 0 if group == "est_base" else 10)])
        if group in ("sd_base", "sd_target"):
            return None  # computed lazily (see _get_output)
        ident = self.ident
        if group == "samples":
            return ident.samples
        if group == "rejected":
            return ident.rejected
        if group == "status":
            return ident.status
        if group == "residual_lin":
            return ident.residual_lin
        if group == "residual_ang":
            return ident.residual_ang
        exc = ident.excitation()
        return exc[0] if group == "excitation_mu" else exc[1]

    def _get_output(self, name: str):
        self._ensure_current()
        var = self.interface[name]
        if var.key[0] in ("sd_base", "sd_target"):
            if self.ident is None:
                return 0.0
            if self._sd is None:
                self._sd = self.ident.std()
            return float(self._sd[_flat(var.key, 0 if var.key[0] == "sd_base" else 10)])
        return self._outputs.get(name, 0)

    def do_step(self, current_time: float, step_size: float) -> bool:
        if not self._check_step(current_time, step_size, math.inf):
            return False
        meas = {}
        for name, (group, idx) in self._inputs:
            arr = meas.get(group)
            if arr is None:
                arr = meas[group] = np.zeros((3, 3) if group == "A" else
                                             (self.robot.n_joints if group in ("q", "qd", "qdd")
                                              else 3))
            arr[idx] = float(self.values[name])
        before = self.ident.get_state()
        try:
            with np.errstate(all="ignore"):
                status = self.ident.update(current_time, meas)
                self._refresh()
            finite = _all_finite(self.ident.get_state())
            error = "" if finite else "the update produced non-finite numbers"
        except (ArithmeticError, ValueError, np.linalg.LinAlgError) as e:
            finite, error = False, f"the update failed ({type(e).__name__}: {e})"
        if not finite:
            # finite but huge inputs can overflow inside the RLS: undo the update entirely
            rejected = self.ident.rejected + 1
            self.ident.set_state(before)
            self.ident.rejected, self.ident.status = rejected, 3
            self.ident.message = f"{error}; are the inputs in SI units and of physical size?"
            status = 3
        if status in (3, 4):
            # name the FMI inputs at fault, not only the core's signal name
            bad = [n for n, _ in self._inputs if not math.isfinite(float(self.values[n]))]
            where = f" [input {', '.join(bad)}]" if bad else ""
            self.log(_escape(f"t = {current_time:.6g} s: sample skipped ({STATUS[status]}){where}: "
                             f"{self.ident.message}; estimates unchanged"), Fmi2Status.warning)
        if not finite:
            self._refresh()         # outputs of the restored state
        return True

    def _core_state(self):
        return None if self.ident is None else self.ident.get_state()

    def _restore_core_state(self, core) -> None:
        if core is None:
            self.ident = None
            return
        if self.ident is None:
            self._initialise()
        self.ident.set_state(core)
        self._refresh()


def _all_finite(obj) -> bool:
    """True if every float in a (nested) core state is finite."""
    if isinstance(obj, np.ndarray):
        return obj.dtype.kind not in "fc" or bool(np.all(np.isfinite(obj)))
    if isinstance(obj, float):
        return math.isfinite(obj)
    if isinstance(obj, dict):
        return all(_all_finite(v) for v in obj.values())
    if isinstance(obj, (list, tuple)):
        return all(_all_finite(v) for v in obj)
    if hasattr(obj, "__dict__"):
        return _all_finite(vars(obj))
    return True


def _flat(key, offset: int) -> int:
    """Index in Identifier.vector() of a (group, 'm' | 'b', i | 'I', k) key."""
    if key[1] == "m":
        return offset
    if key[1] == "b":
        return offset + 1 + key[2]
    return offset + 4 + key[2]
