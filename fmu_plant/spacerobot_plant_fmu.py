"""pythonfmu slave of the plant: a thin wrapper mapping FMI variables to spacerobot.plant.

Built by ``spacerobot build --backend pythonfmu``; inside the FMU the library is bundled as
``_spacerobot_plant`` (a unique name, so that it can share a process with the estimator FMU),
with the compiled native core it runs on (``_spacerobot_plant/core/lib/libspacerobot.*``: the
same C plant as the native plant FMU).
"""
import math

import numpy as np

from _spacerobot_plant.fmi.slave import InterfaceSlave, _escape
from _spacerobot_plant.core.plant import RATE_MAX, RATE_MIN
from _spacerobot_plant.interface import plant_vars
from _spacerobot_plant.plant import Plant
from _spacerobot_plant.robots import Controller, Excitation, Propellant
from pythonfmu.enums import Fmi2Status

#: longest accepted communication step [s] (1e5 internal steps at the default h)
MAX_COMM_STEP = 100.0


class SpaceRobotPlant(InterfaceSlave):
    """Free-floating space robot (base + arm + grasped target) after capture."""

    author = "spacerobot developers"
    description = ("Free-floating space robot after capture: base, arm and target (native C "
                   "core), RK4, bounded momentum controller on the base thrusters, arm motion that "
                   "stabilises the base attitude (Zhang, Yue, Yuan 2020).")
    version = "0.1.0"
    license = "MIT"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._setup(plant_vars)
        self.plant = None
        self._out_pos = None       # where each output sits in the core's outputs (first refresh)

    # -- parameters -> core ---------------------------------------------------------------------
    def _initialise(self) -> None:
        v = self.values
        try:
            base, target = self._body("base"), self._body("target")
            ctrl = Controller(**{k: float(v[k]) for k in Controller.__dataclass_fields__})
            ex = Excitation(**{k: float(v[f"excite.{k}"]) for k in Excitation.__dataclass_fields__})
            v0 = [float(v[f"base.v0[{i}]"]) for i in (1, 2, 3)]
            w0 = [float(v[f"base.omega0[{i}]"]) for i in (1, 2, 3)]
            prop = Propellant(m0=float(v["prop.m0"]), Isp=float(v["prop.Isp"]),
                              r=tuple(float(v[f"prop.r[{i}]"]) for i in (1, 2, 3)),
                              R=float(v["prop.R"]), arm=float(v["prop.arm"]))
            # the core checks the bodies, the controller, excitation and propellant bounds, h
            self.plant = Plant(self.robot, base, target, ctrl, v0, w0, float(v["h"]), ex, prop)
        except ValueError as e:
            self._fail(f"invalid plant parameters: {e}")
        self._refresh()

    def _refresh(self) -> None:
        y = self.plant.output_vector()
        if self._out_pos is None:
            self._out_pos = _output_positions(self.interface, self.plant.output_slices())
        names, pos = self._out_pos
        self._outputs = dict(zip(names, y[pos].tolist()))

    # -- stepping --------------------------------------------------------------------------------
    def do_step(self, current_time: float, step_size: float) -> bool:
        if not self._check_step(current_time, step_size, MAX_COMM_STEP):
            return False
        if abs(current_time - self.plant.t) > 1e-9 * max(1.0, abs(current_time)):
            self.log(_escape(f"communication point {current_time!r} s differs from the plant "
                             f"time {self.plant.t!r} s; continuing from the plant state"),
                     Fmi2Status.warning)
        level = self._excite_input("ident.excite", 0.0, 1.0, current_time)
        rate = self._excite_input("ident.excite_rate", RATE_MIN, RATE_MAX, current_time)
        if level is None or rate is None:
            return False
        before = self.plant.checkpoint()
        try:
            self.plant.set_excitation_rate(rate)
            self.plant.set_excitation(level)
            self.plant.advance(step_size)
            self._refresh()
        except (FloatingPointError, ValueError, np.linalg.LinAlgError) as e:
            self.plant.rollback(before)
            self._refresh()
            self.log(_escape(f"step from t = {current_time:.6g} s by {step_size:.6g} s failed: "
                             f"{e}; state kept at t = {self.plant.t:.6g} s"), Fmi2Status.discard)
            return False
        return True

    def _excite_input(self, name: str, lo: float, hi: float, current_time: float):
        """The excitation input ``name`` within [lo, hi]: clipped with a warning when outside,
        ``None`` (the step is discarded, state unchanged) when it is not a number."""
        u = float(self.values[name])
        if math.isnan(u):
            self.log(_escape(f"{name} is NaN at t = {current_time:.6g} s: step discarded, "
                             f"state kept at t = {self.plant.t:.6g} s"), Fmi2Status.discard)
            return None
        if not lo <= u <= hi:
            clipped = min(max(u, lo), hi)
            self.log(_escape(f"{name} = {u!r} at t = {current_time:.6g} s is outside "
                             f"[{lo:g}, {hi:g}]; using {clipped}"), Fmi2Status.warning)
            return clipped
        return u

    # -- state -----------------------------------------------------------------------------------
    def _core_state(self):
        return None if self.plant is None else self.plant.get_state()

    def _restore_core_state(self, core) -> None:
        if core is None:
            self.plant = None
            return
        if self.plant is None:
            self._initialise()
        self.plant.set_state(core)
        self._refresh()


def _output_positions(interface, slices: dict):
    """``(names, positions)``: the output variables and each one's index in the core's flat
    output vector (``Plant.output_vector``, whose ``slices`` are ``{key: (start, stop,
    shape)}``), so that a refresh is one fancy index."""
    outputs = [(n, v.key) for n, v in interface.items() if v.causality == "output"]
    pos = [slices[g][0] + int(np.ravel_multi_index(idx if isinstance(idx, tuple) else (idx,),
                                                   slices[g][2]))
           for _, (g, idx) in outputs]
    return [n for n, _ in outputs], np.array(pos)
