"""The native plant (``native/src/plant.h``) bound with ctypes.

:class:`NativePlant` is the library's plant (:class:`spacerobot.plant.Plant`): the
constructor, ``t``, ``m_p``, ``q``/``v``/``J``/``H``,
:meth:`~NativePlant.advance`, :meth:`~NativePlant.set_excitation`,
:meth:`~NativePlant.excitation_level`, :meth:`~NativePlant.references`,
:meth:`~NativePlant.outputs`, :meth:`~NativePlant.output_vector`,
:meth:`~NativePlant.output_slices`, :meth:`~NativePlant.get_state` /
:meth:`~NativePlant.set_state`, :meth:`~NativePlant.checkpoint` /
:meth:`~NativePlant.rollback`, :meth:`~NativePlant.base_now`, :meth:`~NativePlant.controls`.

One instance is one constant ``sr_plant_model`` and one ``sr_plant_data`` block (plain structs
without pointers, held in ctypes buffers): a checkpoint is a copy of the data block. A failed
step leaves the plant as it was before the call (the C step is transactional).

The layouts are the C core's tables, read from the library (:mod:`spacerobot.core.tables`,
re-exported here): the parameter structs' fields (:func:`fields`: names, FMI names, units,
offsets, ranges; the binding writes each value at its field's offset), the outputs
(:func:`output_names`) and the ranges of every parameter and input of the plant FMU
(:func:`parameter_ranges`).

Examples
--------
>>> from spacerobot.robots import scenario                                     # doctest: +SKIP
>>> sc = scenario("spatial")                                                    # doctest: +SKIP
>>> p = NativePlant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0)
>>> p.advance(0.1); p.outputs()["P"]                                            # doctest: +SKIP
"""
from __future__ import annotations

import ctypes
import math
import struct
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..robots import (Appendages, Controller, Excitation, Propellant, RigidBody, Robot, Slosh)
from . import dptr, lib as _default_lib
from .robot_record import SrBody, SrRobot, c_robot
from .tables import (Field, _bind_tables, fields, output_names, parameter_ranges,  # noqa: F401
                     records)

__all__ = ["NativePlant", "Controls", "Field", "fields", "output_names", "parameter_ranges",
           "STATUS_OK"]

MSG_LEN = 256
#: the doubles of the excitation state (SR_PLANT_EXCITE_STATE: ramp (4), level requested,
#: rates in effect and requested)
EXCITE_STATE = 7
STATUS_OK = 0
EARG = 1
ENONFINITE = 2
def _pack(L: ctypes.CDLL, table: str, *record) -> ctypes.Array:
    """The C struct ``table`` with the values of the Python record (its attributes named as the
    fields), written at the library's offsets; several records: an array of the structs."""
    size = getattr(L, f"sr_plant_{table}_size")()
    buf = (ctypes.c_double * ((len(record) * size + 7) // 8))()
    for i, rec in enumerate(record):
        for f in fields(table, L):
            value = getattr(rec, f.name)
            values = [float(x) for x in value] if f.size > 1 else [float(value)]
            if len(values) != f.size:
                raise ValueError(f"{f.fmi} must be {f.size} finite numbers [{f.unit}], got "
                                 f"{list(value)}")
            struct.pack_into(f"={f.size}d", buf, i * size + f.offset, *values)
    return buf



@dataclass
class Controls:
    """Commands held over one internal step, and the accelerations they produce at its start
    (the result of :meth:`NativePlant.controls`)."""

    F: np.ndarray      # thruster force at S, inertial [N]
    M: np.ndarray      # thruster torque, inertial [N.m]
    tau: np.ndarray    # joint torques [N.m]
    a: np.ndarray      # generalised acceleration dv/dt (Pinocchio convention)


def _bind(L: ctypes.CDLL) -> ctypes.CDLL:
    """Declare the plant's functions on the library ``L`` (once)."""
    if getattr(L, "_sr_plant_bound", False):
        return L
    vp, sz, cp, ci, cd = (ctypes.c_void_p, ctypes.c_size_t, ctypes.c_char_p, ctypes.c_int,
                          ctypes.c_double)
    dp = ctypes.POINTER(ctypes.c_double)
    ip = ctypes.POINTER(ctypes.c_int)
    sig = {
        "sr_plant_model_init": ([vp, ctypes.POINTER(SrRobot), ctypes.POINTER(SrBody),
                                 ctypes.POINTER(SrBody), vp, vp, vp, dp, dp, dp, cd, cp, sz], ci),
        "sr_plant_dims": ([vp, ip, ip, ip, ip, ip], ci),
        "sr_plant_output_offsets": ([vp, ip], ci),
        "sr_plant_status_message": ([ci], cp),
        "sr_plant_start": ([vp, vp], ci),
        "sr_plant_set_excitation": ([vp, vp, cd], ci),
        "sr_plant_excitation_level": ([vp, vp, dp], ci),
        "sr_plant_set_excitation_rate": ([vp, vp, cd], ci),
        "sr_plant_excitation_rate": ([vp, vp, dp], ci),
        "sr_plant_advance": ([vp, vp, cd], ci),
        "sr_plant_outputs": ([vp, vp, dp], ci),
        "sr_plant_controls": ([vp, vp, dp, dp, dp, dp, dp], ci),
        "sr_plant_base_now": ([vp, vp, dp], ci),
        "sr_plant_references": ([vp, vp, dp], ci),
        "sr_plant_get_state": ([vp, vp, dp, dp, dp], ci),
        "sr_plant_set_state": ([vp, vp, cd, dp, dp, cp, sz], ci),
        "sr_plant_model_set_leaves": ([vp, ci, vp, ci, vp, cp, sz], ci),
    }
    for name, (args, res) in sig.items():
        f = getattr(L, name)
        f.argtypes, f.restype = args, res
    for name in ("sr_plant_model_size", "sr_plant_data_size", "sr_plant_controller_size",
                 "sr_plant_excitation_size", "sr_plant_propellant_size", "sr_plant_flex_size",
                 "sr_plant_slosh_size"):
        getattr(L, name).argtypes = []
        getattr(L, name).restype = sz
    L._sr_plant_bound = True
    return _bind_tables(L)


def __getattr__(name: str):
    # the excitation rate's range (SR_PLANT_RATE_MIN, SR_PLANT_RATE_MAX), from the library
    if name in ("RATE_MIN", "RATE_MAX"):
        lo, hi = parameter_ranges()["ident.excite_rate"]
        return lo if name == "RATE_MIN" else hi
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _block(nbytes: int):
    """A zeroed, double-aligned ctypes buffer of at least ``nbytes`` bytes."""
    return (ctypes.c_double * ((nbytes + 7) // 8))()


def _body(b: RigidBody) -> SrBody:
    out = SrBody()
    out.m = float(b.mass)
    out.com[:] = [float(x) for x in b.com]
    Ixx, Iyy, Izz, Ixy, Ixz, Iyz = (float(x) for x in b.inertia)
    out.I[:] = [Ixx, Ixy, Ixz, Ixy, Iyy, Iyz, Ixz, Iyz, Izz]
    return out


class NativePlant:
    """The C plant (:class:`spacerobot.plant.Plant`): the free-floating space robot after
    capture, integrated with RK4 at the internal step ``h``.

    Parameters
    ----------
    robot : Robot (its record goes through the C reader) or an ``SrRobot``
    base, target : RigidBody        truth of the (dry) base and of the grasped target
    controller : Controller
    v0 : (3,)      initial velocity of S, inertial [m/s]
    omega0 : (3,)  initial base angular velocity, base frame [rad/s]
    h : float      internal RK4 step [s]
    excitation : Excitation
    propellant : Propellant
    q_home : (n,), optional   home (and initial) posture; default ``robot.q0``
    lib : the library (default :func:`spacerobot.core.lib`)
    flex : Appendages         the hinged panels (none by default)
    slosh : Slosh             the propellant's slosh modes (none by default)

    Raises ``ValueError`` with the C core's message (naming the parameter) for bad input.
    """

    def __init__(self, robot, base: RigidBody, target: RigidBody, controller: Controller,
                 v0, omega0, h: float = 1e-3, excitation: Excitation = Excitation(),
                 propellant: Propellant = Propellant(), q_home=None,
                 lib: Optional[ctypes.CDLL] = None, flex: Appendages = Appendages(),
                 slosh: Slosh = Slosh()):
        L = _bind(lib or _default_lib())
        self._lib = L
        self._init_args = (robot, base, target, controller, tuple(v0), tuple(omega0), h,
                           excitation, propellant, q_home, lib, flex, slosh)
        self.excitation, self.propellant, self.controller = excitation, propellant, controller
        self.flex, self.slosh = flex, slosh
        self.robot = robot
        self._dry = base
        if isinstance(robot, Robot):
            c_rob = c_robot(robot, L)
            qh = robot.q0 if q_home is None else q_home
        else:
            c_rob = robot
            qh = np.zeros(robot.n) if q_home is None else q_home
        self.q_home = np.array(qh, float)
        ctrl = _pack(L, "controller", controller)
        ex = _pack(L, "excitation", excitation)
        pr = _pack(L, "propellant", propellant)
        v0a = np.array(v0, float).reshape(3)
        w0a = np.array(omega0, float).reshape(3)
        if self.q_home.shape != (c_rob.n,):
            raise ValueError(f"q_home must have {c_rob.n} entries, got {self.q_home.shape}")
        self._model = _block(L.sr_plant_model_size())
        self._data = _block(L.sr_plant_data_size())
        err = ctypes.create_string_buffer(MSG_LEN)
        st = L.sr_plant_model_init(self._model, ctypes.byref(c_rob), ctypes.byref(_body(base)),
                                   ctypes.byref(_body(target)), ctrl, ex, pr, dptr(self.q_home),
                                   dptr(v0a), dptr(w0a), float(h), err, MSG_LEN)
        if st != STATUS_OK:
            raise ValueError(err.value.decode("ascii", "replace"))
        panels = _pack(L, "flex", *flex.records(records("flex", L)))
        modes = _pack(L, "slosh", *slosh.records(records("slosh", L)))
        st = L.sr_plant_model_set_leaves(self._model, int(flex.n), panels, int(slosh.n), modes,
                                         err, MSG_LEN)
        if st != STATUS_OK:
            raise ValueError(err.value.decode("ascii", "replace"))
        self.h = float(h)
        nq, nv, nx, ny, n = (ctypes.c_int() for _ in range(5))
        L.sr_plant_dims(self._model, *(ctypes.byref(x) for x in (nq, nv, nx, ny, n)))
        self._nq, self._nv, self._nx, self._ny, self.n = nq.value, nv.value, nx.value, \
            ny.value, n.value
        self.planar = bool(c_rob.planar)
        self._nb = 3 if self.planar else 6
        self._om = 6 + self._nq + self._nv
        names = output_names(L)
        off = (ctypes.c_int * (len(names) + 1))()
        L.sr_plant_output_offsets(self._model, off)
        self._layout = []
        for k, key in enumerate(names):
            a, b = off[k], off[k + 1]
            self._layout.append((key, a, b, (3, 3) if key == "A" else (b - a,)))
        self._y = np.empty(self._ny)
        self._xbuf = np.empty(self._nx)
        self._rbuf = np.empty(EXCITE_STATE)
        self._tbuf = ctypes.c_double()
        if L.sr_plant_start(self._model, self._data) != STATUS_OK:
            raise RuntimeError("sr_plant_start failed")

    @classmethod
    def of(cls, sc, **change) -> "NativePlant":
        """The plant of scenario ``sc`` (:class:`spacerobot.robots.Scenario`: its robot, base,
        target, controller, initial velocities, step, excitation, propellant and flexible
        parts); ``change``: constructor arguments replaced."""
        args = dict(robot=sc.robot, base=sc.robot.base, target=sc.target,
                    controller=sc.controller, v0=sc.v0, omega0=sc.omega0, h=sc.h,
                    excitation=sc.excitation, propellant=sc.propellant, flex=sc.flex,
                    slosh=sc.slosh)
        args.update(change)
        return cls(**args)

    # -- copies ------------------------------------------------------------------------------
    def __deepcopy__(self, memo):
        new = NativePlant(*self._init_args)
        ctypes.memmove(new._data, self._data, ctypes.sizeof(self._data))
        memo[id(self)] = new
        return new

    def __reduce__(self):
        # the library travels as its path (a CDLL does not pickle)
        args = self._init_args[:10] + (None,) + self._init_args[11:]
        return _restore_native_plant, (args, getattr(self._lib, "_name", None), self.get_state())

    # -- errors ------------------------------------------------------------------------------
    def _raise(self, st: int, what: str) -> None:
        msg = self._lib.sr_plant_status_message(st).decode("ascii")
        if st == EARG:
            raise ValueError(f"{what}: {msg}")
        if st == ENONFINITE:
            raise FloatingPointError(f"{what}: {msg} (state kept at t = {self.t:.6g} s)")
        raise np.linalg.LinAlgError(f"{what}: {msg} (state kept at t = {self.t:.6g} s)")

    # -- state -------------------------------------------------------------------------------
    def _state(self):
        self._lib.sr_plant_get_state(self._model, self._data, ctypes.byref(self._tbuf),
                                     dptr(self._xbuf), dptr(self._rbuf))
        return self._tbuf.value, self._xbuf, self._rbuf

    @property
    def t(self) -> float:
        """Time [s]."""
        return self._state()[0]

    @property
    def m_p(self) -> float:
        """Propellant mass now [kg] (0 without propellant model)."""
        return float(self._state()[1][self._om])

    def _part(self, a: int, b: int) -> np.ndarray:
        return self._state()[1][a:b].copy()

    def _set_part(self, a: int, b: int, value) -> None:
        t, x, ramp = self._state()
        x = x.copy()
        x[a:b] = np.asarray(value, float)
        self._set(t, x, ramp.copy())

    J = property(lambda self: self._part(0, 3), lambda self, v: self._set_part(0, 3, v),
                 doc="impulse of the thrust, inertial [N.s] (a copy)")
    H = property(lambda self: self._part(3, 6), lambda self, v: self._set_part(3, 6, v),
                 doc="angular impulse about the inertial origin [N.m.s] (a copy)")
    q = property(lambda self: self._part(6, 6 + self._nq),
                 lambda self, v: self._set_part(6, 6 + self._nq, v),
                 doc="generalised coordinates (Pinocchio's; a copy)")
    v = property(lambda self: self._part(6 + self._nq, self._om),
                 lambda self, val: self._set_part(6 + self._nq, self._om, val),
                 doc="generalised velocity (Pinocchio's; a copy)")

    def _set(self, t: float, x: np.ndarray, ramp: np.ndarray) -> None:
        err = ctypes.create_string_buffer(MSG_LEN)
        st = self._lib.sr_plant_set_state(self._model, self._data, float(t), dptr(x), dptr(ramp),
                                          err, MSG_LEN)
        if st != STATUS_OK:
            raise ValueError(err.value.decode("ascii", "replace"))

    def get_state(self) -> dict:
        """A deep copy of everything that determines the future."""
        t, x, ramp = self._state()
        nq, om = self._nq, self._om
        return {"t": t, "q": x[6:6 + nq].copy(), "v": x[6 + nq:om].copy(), "J": x[0:3].copy(),
                "H": x[3:6].copy(), "excite_ramp": ramp[:4].copy(),
                "excite_rate": ramp[4:].copy(), "prop": x[om:om + 7].copy()}

    def set_state(self, s: dict) -> None:
        """Restore a state of :meth:`get_state` (of this plant or of another plant of the same
        robot); ``ValueError`` (the plant unchanged) if it does not fit."""
        t = float(s["t"])
        q = np.array(s["q"], float)
        v = np.array(s["v"], float)
        J = np.array(s["J"], float)
        H = np.array(s["H"], float)
        ramp = np.array(s.get("excite_ramp", [0.0, 0.0, 0.0, self.excitation.ramp]), float)
        prop = np.array(s.get("prop", [self.propellant.m0, 0, 0, 0, 0, 0, 0]), float)
        # [level requested, rate in effect, rate requested]; a state without: the ramp's
        # level at the plant's own rate
        rate = np.array(s.get("excite_rate", [ramp[1] if ramp.shape == (4,) else 0.0, 1.0, 1.0]),
                        float)
        if (q.shape != (self._nq,) or v.shape != (self._nv,) or J.shape != (3,)
                or H.shape != (3,) or prop.shape != (7,) or ramp.shape != (4,)
                or rate.shape != (3,)):
            raise ValueError(f"state shapes q {q.shape}, v {v.shape}, J {J.shape}, H {H.shape}, "
                             f"prop {prop.shape}, excite_ramp {ramp.shape}, excite_rate "
                             f"{rate.shape} do not fit this plant (nq = {self._nq}, "
                             f"nv = {self._nv})")
        self._set(t, np.concatenate([J, H, q, v, prop]), np.concatenate([ramp, rate]))

    def checkpoint(self) -> bytes:
        """A copy of the data block (the whole state), for :meth:`rollback`."""
        return ctypes.string_at(self._data, ctypes.sizeof(self._data))

    def rollback(self, cp: bytes) -> None:
        """Return to a :meth:`checkpoint` of this plant."""
        if len(cp) != ctypes.sizeof(self._data):
            raise ValueError("not a checkpoint of this plant")
        ctypes.memmove(self._data, cp, len(cp))

    # -- excitation --------------------------------------------------------------------------
    def set_excitation(self, level: float) -> None:
        """Ask for the excitation level ``level`` in [0, 1];
        ``ValueError`` (plant unchanged) outside [0, 1] or NaN."""
        level = float(level)
        if self._lib.sr_plant_set_excitation(self._model, self._data, level) != STATUS_OK:
            lo, hi = parameter_ranges(self._lib)["ident.excite"]
            raise ValueError(f"excitation level must be in [{lo:g}, {hi:g}], got {level}")

    def set_excitation_rate(self, rate: float) -> None:
        """Ask for the excitation rate ``rate`` (frequency multiplier, 1 = the plant's own;
        in [RATE_MIN, RATE_MAX]): the level dips to 0, the new frequencies take over there and
        the level returns (``sr_plant_set_excitation_rate``); ``ValueError`` (plant unchanged)
        out of range or NaN."""
        rate = float(rate)
        if self._lib.sr_plant_set_excitation_rate(self._model, self._data, rate) != STATUS_OK:
            lo, hi = parameter_ranges(self._lib)["ident.excite_rate"]
            raise ValueError(f"excitation rate must be in [{lo:g}, {hi:g}], got {rate}")

    def excitation_rate(self) -> tuple:
        """``(rate in effect, rate requested)``."""
        out = np.empty(2)
        self._lib.sr_plant_excitation_rate(self._model, self._data, dptr(out))
        return float(out[0]), float(out[1])

    def excitation_level(self) -> tuple:
        """``(s, ds/dt, d2s/dt2)``: the excitation level in effect now and its derivatives."""
        s = np.empty(3)
        self._lib.sr_plant_excitation_level(self._model, self._data, dptr(s))
        return float(s[0]), float(s[1]), float(s[2])

    def references(self) -> dict:
        """The excitation references now: ``{"att", "att_d", "att_dd", "q", "q_d", "q_dd"}``
        (attitude axes, then the joint offsets from the home posture, and their derivatives)."""
        r = 1 if self.planar else 3
        vals = np.empty((r + self.n, 3))
        self._lib.sr_plant_references(self._model, self._data, dptr(vals))
        return {"att": vals[:r, 0], "att_d": vals[:r, 1], "att_dd": vals[:r, 2],
                "q": vals[r:, 0], "q_d": vals[r:, 1], "q_dd": vals[r:, 2]}

    # -- integration -------------------------------------------------------------------------
    def advance(self, dt: float) -> None:
        """Integrate over ``dt`` (whole internal steps ``h``, then one shorter step if needed).
        Raises ``ValueError`` for a bad ``dt``, ``np.linalg.LinAlgError`` for a singular
        matrix, ``FloatingPointError`` for a non-finite state; the plant is then unchanged."""
        dt = float(dt)
        if not (dt > 0.0 and math.isfinite(dt)):
            raise ValueError(f"communication step must be finite and > 0 s, got {dt}")
        st = self._lib.sr_plant_advance(self._model, self._data, dt)
        if st != STATUS_OK:
            self._raise(st, f"step of {dt:.6g} s")

    # -- measurements ------------------------------------------------------------------------
    def output_vector(self) -> np.ndarray:
        """Every output in one new flat array, in the order of :meth:`output_slices`."""
        st = self._lib.sr_plant_outputs(self._model, self._data, dptr(self._y))
        if st != STATUS_OK:
            self._raise(st, "outputs")
        return self._y.copy()

    def outputs(self) -> dict:
        """Every output now, by key (:func:`output_names`): what the sensors measure, the truth
        momentum, the excitation and the propellant."""
        y = self.output_vector()
        return {key: y[a:b].reshape(shape) for key, a, b, shape in self._layout}

    def output_slices(self) -> dict:
        """``{key: (start, stop, shape)}``: where each output sits in :meth:`output_vector`."""
        return {key: (a, b, shape) for key, a, b, shape in self._layout}

    def controls(self) -> Controls:
        """Commands for the step starting at the current state."""
        F, M, tau, a = np.empty(3), np.empty(3), np.empty(self.n), np.empty(self._nv)
        flow = np.empty(1)
        st = self._lib.sr_plant_controls(self._model, self._data, dptr(F), dptr(M), dptr(tau),
                                         dptr(a), dptr(flow))
        if st != STATUS_OK:
            self._raise(st, "controls")
        return Controls(F, M, tau, a)

    def base_now(self) -> RigidBody:
        """The base's truth now: the dry base plus the propellant left (the dry base without
        propellant model); with flexible parts the composite rigid base (plus the panels at
        rest and the slosh masses at their equilibrium)."""
        if not self.propellant.active and self.flex.n == 0 and self.slosh.n == 0:
            return self._dry
        out = np.empty(10)
        self._lib.sr_plant_base_now(self._model, self._data, dptr(out))
        return RigidBody(float(out[0]), tuple(float(x) for x in out[1:4]),
                         tuple(float(x) for x in out[4:10]))


def _restore_native_plant(args, lib_path, state) -> NativePlant:
    from . import load_library
    args = list(args)
    args[10] = load_library(lib_path) if lib_path else None      # the library's place
    p = NativePlant(*args)
    p.set_state(state)
    return p
