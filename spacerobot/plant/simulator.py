"""The plant simulator: state, zero-order-hold controls, classic RK4, measured outputs.

Implementation notes (performance; the equations are those of :mod:`.dynamics` and
:mod:`.kernels`):

* The state lives in one vector ``x = [J (3), H (3), q (nq), v (nv), m_p, P_x (3), L_x (3)]``
  (the last seven: propellant mass and the momentum the expelled propellant carried away,
  :mod:`.kernels`); the public attributes ``q``, ``v``, ``J``, ``H`` are views of it. Every
  step makes a new ``x`` (the arrays a caller kept are never changed behind its back); a
  caller that assigns e.g. ``plant.q = ...`` is noticed at the next step.
* A communication step is one compiled call (:func:`.kernels.advance_measured`: :func:`.kernels.advance`
  then :func:`.kernels.measure` at the state reached): per 1 ms RK4 step the
  rigid-body terms (:func:`.rigid_body.terms`) and the control kernel at the start of the step
  (zero-order hold; its inverse dynamics give the first stage's accelerations), then three
  times the compiled articulated-body algorithm (:func:`.rigid_body.aba`) followed by the stage
  kernel, which also forms the next stage state and the combination of the four stages. The
  compiled model's arrays are read from the Pinocchio model (:func:`.rigid_body.chain_arrays`),
  which is otherwise not used while stepping. With a propellant model
  (:class:`~spacerobot.robots.Propellant`, ``m0 > 0``) the compiled base inertia follows the
  propellant mass inside the compiled call.
* The outputs (:func:`.kernels.measure`: the rigid-body terms and the controls at the current
  state, those the next step holds, and every output, written into one flat vector;
  :meth:`Plant.output_vector`, layout :func:`.kernels.output_layout`) come with the step that
  reached the state; at any other state (a restored one, the initial one, after
  :meth:`Plant.set_excitation`) they are one compiled call of their own.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

import pinocchio as pin

from ..robots import G0, Controller, Excitation, Propellant, RigidBody, Robot
from . import kernels, rigid_body
from .dynamics import PlantModel, base_generalised_velocity, build_model, initial_configuration


@dataclass
class Controls:
    """Commands held over one internal step, and the accelerations they produce at its start."""

    F: np.ndarray      # thruster force at S, inertial [N]
    M: np.ndarray      # thruster torque, inertial [N.m]
    tau: np.ndarray    # joint torques [N.m]
    a: np.ndarray      # generalised acceleration dv/dt (Pinocchio convention)


class Plant:
    """Free-floating space robot after capture, integrated with RK4 at the internal step ``h``.

    Parameters
    ----------
    robot : Robot
    base, target : RigidBody        truth of the base and of the grasped target
    controller : Controller
    v0 : (3,)      initial velocity of S, inertial [m/s]
    omega0 : (3,)  initial base angular velocity, base frame [rad/s]
    h : float      internal RK4 step [s]
    excitation : Excitation
        bounds and frequencies of the excitation motion; its level starts at 0 (the paper's
        behaviour) and follows :meth:`set_excitation`
    propellant : Propellant
        the base's propellant; ``base`` is then the dry base. The default (``m0 = 0``) is the
        paper's constant base.
    """

    def __init__(self, robot: Robot, base: RigidBody, target: RigidBody, controller: Controller,
                 v0, omega0, h: float = 1e-3, excitation: Excitation = Excitation(),
                 propellant: Propellant = Propellant()):
        if not (0.0 < h <= 1.0):
            raise ValueError(f"h must be in (0, 1] s, got {h}")
        base.check("base")
        target.check("target")
        controller.check()
        excitation.check()
        propellant.check()
        self._init_args = (robot, base, target, controller, tuple(v0), tuple(omega0), h,
                           excitation, propellant)
        self.propellant = propellant
        self.excitation = excitation
        self.pm: PlantModel = build_model(robot, base, target)
        self.controller = controller
        self.h = float(h)
        self.q_home = np.asarray(robot.q0, float)
        q = initial_configuration(self.pm)
        if robot.planar:
            v0 = (v0[0], v0[1], 0.0)
            omega0 = (0.0, 0.0, omega0[2])
        vb = base_generalised_velocity(self.pm, q, np.asarray(v0, float), np.asarray(omega0, float))
        v = np.concatenate([vb, np.zeros(self.pm.n)])
        # layout of the state vector and work space
        pm = self.pm
        self._nq, self._nv = pm.model.nq, pm.model.nv
        self._oq, self._ov = 6, 6 + self._nq                 # offsets of q and v in x
        self._om = self._ov + self._nv                       # offset of [m_p, P_x, L_x]
        nx = self._om + 7
        self._K = np.empty((4, nx))                          # the four stage derivatives
        self._xs = np.empty(nx)                              # stage state
        self._qn = np.empty(self._nq)                        # stage configuration (unit quat.)
        self._vs = np.empty(self._nv)                        # stage velocity
        self._gen = np.zeros(self._nv)                       # generalised force [f_b, tau]
        self._acc = np.zeros(self._nv)                       # dv/dt under the held controls
        self._FM = np.zeros(7)                     # thrust [F, M], inertial; mass flow [kg/s]
        self._par = np.array([getattr(controller, k) for k in kernels.PARAMS], float)
        # compiled rigid-body model (from the Pinocchio model) and its work space
        self._mdl = rigid_body.chain_arrays(pm.model)[1:]   # (R, p, I6, mc)
        # propellant: its array, the dry base (body 0), 1 kg of propellant, a scratch par
        pp = propellant_array(propellant)
        self._prop = (pp, self._mdl[2][0].copy(), unit_sphere_inertia(pp),
                      self._mdl[3][0].copy(), np.empty_like(self._par))
        self._ws = rigid_body.Workspace(pm.model.njoints - 2).arrays()
        self._cw = kernels.control_work(robot.planar, self._nv)
        self._M = np.zeros((self._nv, self._nv))
        self._nle = np.zeros(self._nv)
        self._hg = np.zeros(6)
        self._buf = (self._K, self._xs, self._qn, self._vs, self._gen, self._acc, self._FM,
                     self._M, self._nle, self._hg, np.empty(self._nv), np.empty(nx))
        # outputs: one flat vector (kernels.output_layout) and the dry base's truth
        self._dry = np.array([base.mass, *base.com, *base.inertia], float)
        self._layout, start = [], 0
        for key, shape in kernels.output_layout(self.pm.n):
            size = int(np.prod(shape))
            self._layout.append((key, start, start + size, shape))
            start += size
        self._y = np.empty(start)
        # excitation: reference channels (attitude axes, then joints) and the level ramp
        # [s0, u, t0, T] (kernels.ramp_level); level 0 until set_excitation asks for more
        self._ex_tab = excitation.channels(1 if robot.planar else 3, self.pm.n)
        self._ramp = np.array([0.0, 0.0, 0.0, excitation.ramp])
        self.t = 0.0
        self._x = np.concatenate([np.zeros(6), q, v, [propellant.m0], np.zeros(6)])
        self._publish()
        self._u: Controls | None = None
        self._loaded = None        # the state vector whose configuration is in _qn, _vs
        self._ctrl_x = None        # the state vector the control buffers were computed for
        self._y_x = None           # the state vector whose outputs are in _y
        self._finite = True        # whether the state reached by the last step is finite

    # -- copies (the integrator's closures refer to this instance's buffers) -------------------
    def __deepcopy__(self, memo):
        new = Plant(*self._init_args)
        new.set_state(self.get_state())
        memo[id(self)] = new
        return new

    def __reduce__(self):
        return _restore_plant, (self._init_args, self.get_state())

    # -- state -----------------------------------------------------------------------------
    def _publish(self) -> None:
        """Make the public state attributes views of the current state vector."""
        x, oq, ov, om = self._x, self._oq, self._ov, self._om
        self.J, self.H, self.q, self.v = x[0:3], x[3:6], x[oq:ov], x[ov:om]
        self._pub = (self.J, self.H, self.q, self.v)

    @property
    def m_p(self) -> float:
        """Propellant mass now [kg] (0 without propellant model)."""
        return float(self._x[self._om])

    def _collect(self) -> np.ndarray:
        """The state vector, rebuilt if a caller replaced one of the public attributes."""
        pub = self._pub
        if (self.J is not pub[0] or self.H is not pub[1] or self.q is not pub[2]
                or self.v is not pub[3]):
            self._x = np.concatenate([np.asarray(self.J, float), np.asarray(self.H, float),
                                      np.asarray(self.q, float), np.asarray(self.v, float),
                                      self._x[self._om:]])
            self._publish()
        return self._x

    def get_state(self) -> dict:
        """A deep copy of everything that determines the future (controls are derived)."""
        self._collect()
        return {"t": self.t, "q": self.q.copy(), "v": self.v.copy(), "J": self.J.copy(),
                "H": self.H.copy(), "excite_ramp": self._ramp.copy(),
                "prop": self._x[self._om:].copy()}

    def checkpoint(self) -> tuple:
        """What :meth:`rollback` returns to: the time, the state vector and the excitation
        ramp, by reference (no copy: a step makes a new state vector and a new level a new
        ramp, neither is written in place). Writes into the public arrays (``q``, ``v``, ``J``,
        ``H``) in place after it are not undone; :meth:`get_state` copies."""
        return self.t, self._collect(), self._ramp

    def rollback(self, cp: tuple) -> None:
        """Return to a :meth:`checkpoint` of this plant (e.g. after a step that failed)."""
        self.t, self._x, self._ramp = cp
        self._publish()
        self._u = None
        self._loaded = self._ctrl_x = self._y_x = None

    def set_state(self, s: dict) -> None:
        """Restore a state of :meth:`get_state`; raises ``ValueError`` (the plant unchanged)
        if it does not fit this plant."""
        t = float(s["t"])
        if not math.isfinite(t):
            raise ValueError(f"state time must be finite, got {t}")
        q = np.array(s["q"], float)
        v = np.array(s["v"], float)
        J = np.array(s["J"], float)
        H = np.array(s["H"], float)
        ramp = np.array(s.get("excite_ramp", [0.0, 0.0, 0.0, self.excitation.ramp]), float)
        prop = np.array(s.get("prop", [self.propellant.m0, 0, 0, 0, 0, 0, 0]), float)
        if prop.shape != (7,) or not np.all(np.isfinite(prop)):
            raise ValueError(f"propellant state must be 7 finite numbers [m_p, P_x, L_x], "
                             f"got {prop}")
        if q.shape != (self._nq,) or v.shape != (self._nv,) or J.shape != (3,) or H.shape != (3,):
            raise ValueError(f"state shapes q {q.shape}, v {v.shape}, J {J.shape}, H {H.shape} "
                             f"do not fit this plant (nq = {self._nq}, nv = {self._nv})")
        if ramp.shape != (4,) or not np.all(np.isfinite(ramp)) or not ramp[3] > 0.0:
            raise ValueError(f"excitation ramp state must be 4 finite numbers [s0, u, t0, T > 0], "
                             f"got {ramp}")
        if not all(np.all(np.isfinite(x)) for x in (q, v, J, H)):
            raise ValueError("state q, v, J, H must be finite")
        if not pin.isNormalized(self.pm.model, q, 1e-6):
            raise ValueError("state q: the base quaternion (or planar cos/sin pair) is not of "
                             "unit norm")
        m0 = self.propellant.m0
        if not (0.0 <= prop[0] <= m0 * (1.0 + 1e-12)):
            raise ValueError(f"propellant mass {prop[0]} kg outside [0, prop.m0 = {m0}] kg")
        self.t = t
        self._ramp = ramp
        self._x = np.concatenate([J, H, q, v, prop])
        self._publish()
        self._u = None
        self._loaded = self._ctrl_x = self._y_x = None

    # -- excitation --------------------------------------------------------------------------
    def set_excitation(self, level: float) -> None:
        """Ask for the excitation level ``level`` in [0, 1] from now on.

        The level in effect moves there from its current value in ``excitation.ramp`` seconds
        (:func:`.kernels.ramp_level`; no jump in the references); asking again for the level
        already requested changes nothing. Raises ``ValueError`` for a level outside [0, 1] or
        NaN (the plant is then unchanged).
        """
        level = float(level)
        if not (0.0 <= level <= 1.0):
            raise ValueError(f"excitation level must be in [0, 1], got {level}")
        if level == self._ramp[1]:
            return
        s_now = kernels.ramp_level(self.t, self._ramp)[0]
        self._ramp = np.array([s_now, level, self.t, self.excitation.ramp])
        self._u = None
        self._ctrl_x = self._y_x = None

    def excitation_level(self) -> tuple:
        """``(s, ds/dt, d2s/dt2)``: the excitation level in effect now and its derivatives."""
        return kernels.ramp_level(self.t, self._ramp)

    def references(self) -> dict:
        """The excitation references now (zero when the level is 0): ``att`` (r,) base attitude
        [rad] and ``q`` (n,) joint offsets from the home posture [rad], each with ``_d``
        (rate) and ``_dd`` (acceleration) companions; r = 1 planar (z), 3 spatial."""
        tab, r = self._ex_tab, 1 if self.pm.planar else 3
        vals = np.array([kernels.reference(self.t, self._ramp, tab, c) for c in range(len(tab))])
        return {"att": vals[:r, 0], "att_d": vals[:r, 1], "att_dd": vals[:r, 2],
                "q": vals[r:, 0], "q_d": vals[r:, 1], "q_dd": vals[r:, 2]}

    # -- controls ----------------------------------------------------------------------------
    def controls(self) -> Controls:
        """Commands for the step starting at the current state (cached until the state moves)."""
        if self._u is None:
            x = self._collect()
            if self._ctrl_x is not x:
                self._control_at(x)
            nb, FM = self.pm.nb, self._FM
            self._u = Controls(FM[0:3].copy(), FM[3:6].copy(), self._gen[nb:].copy(),
                               self._acc.copy())
        return self._u

    def _control_at(self, x: np.ndarray) -> None:
        """Fill the control buffers (``_FM``, ``_gen``, ``_acc``) for the state ``x``.

        The accelerations come from the inverse dynamics of the attitude law
        (``M a + c = [f_b, tau]`` by construction), so no forward-dynamics call is needed.
        """
        qn, vs = self._qn, self._vs
        if self._loaded is not x:
            kernels.load(self.pm.planar, x, qn, vs)
            self._loaded = x
        pp, I6d, I6u, mcd, parw = self._prop
        if pp[0] != 0.0:
            kernels.base_inertia(x[self._om], pp, I6d, I6u, mcd, self._mdl[2], self._mdl[3])
        rigid_body.terms(self.pm.planar, *self._mdl, qn, vs, self._M, self._nle, self._hg,
                         *self._ws)
        # the thrust held over the next internal step (a step of h)
        err = kernels.thrust_control(self.pm.planar, qn, vs, self._M, self._nle, self._hg,
                                     self._par, self.q_home, self.t, self._ramp, self._ex_tab,
                                     self._gen, self._acc, self._FM, pp, x[self._om], self.h,
                                     parw, self._cw)
        if err:
            raise np.linalg.LinAlgError(kernels.ERRORS[err])
        self._ctrl_x = x

    # -- integration -------------------------------------------------------------------------
    def _run(self, n: int, h: float, rest: float) -> None:
        """``n`` RK4 steps of ``h`` then one of ``rest`` (if > 0) in one compiled call
        (:func:`.kernels.advance_measured`); the controls of each step are held over it. The
        same call measures the outputs at the state reached (:meth:`output_vector` then needs
        no call of its own)."""
        x = self._collect()
        if self._loaded is not x:
            kernels.load(self.pm.planar, x, self._qn, self._vs)
        xn = np.empty_like(x)
        err, t, measured, self._finite = kernels.advance_measured(
            self.pm.planar, self._mdl, self._ws, self._cw, x, n, h, rest, self.t, self._par,
            self.q_home, self._ramp, self._ex_tab, self._prop, *self._buf, xn, self.h, self._dry,
            self._y)
        self._x, self.t = xn, t
        self._loaded = xn                 # the kernel left xn's configuration in _qn, _vs
        # and, measured, the controls for xn in _FM, _gen, _acc and its outputs in _y
        self._ctrl_x = self._y_x = xn if measured == 0 else None
        self._u = None
        self._publish()
        if err:
            raise np.linalg.LinAlgError(kernels.ERRORS[err])

    def rk4_step(self, dt: float) -> None:
        """One classic RK4 step of length ``dt`` with the controls held (zero-order hold)."""
        self._run(1, float(dt), 0.0)

    def advance(self, dt: float) -> None:
        """Integrate over ``dt``: whole internal steps ``h``, then one shorter step if needed."""
        if not (dt > 0.0 and math.isfinite(dt)):
            raise ValueError(f"communication step must be finite and > 0 s, got {dt}")
        n = int(math.floor(dt / self.h + 1e-9))
        rest = dt - n * self.h
        if rest < 1e-9 * self.h:
            rest = 0.0
        self._run(n, self.h, rest)
        if not self._finite:
            raise FloatingPointError(f"state became non-finite at t = {self.t:.6g} s")

    # -- measurements ------------------------------------------------------------------------
    def outputs(self) -> dict:
        """What the sensors measure at the current instant, plus truth momentum.

        Keys follow the interface contract: ``r_S, v_S, A, omega_B, a_S, alpha_B, q, qd, qdd,
        F, M, J, H, P, L, tau``, and ``excite_level`` (1,): the excitation level in effect;
        ``att_ref`` (3,), ``qd_ref`` (n,): the excitation references;
        the propellant: ``m_p`` (1,) [kg], ``P_x``, ``L_x`` (3,): the momentum the expelled
        propellant carried away (so ``P + P_x - P(0) = J`` and ``L + L_x - L(0) = H``), and
        ``base_now`` (10,): the base's current truth ``[m, b, I]`` (:meth:`base_now`).
        Each value is a new array (:meth:`output_vector` gives them all at once).
        """
        y = self.output_vector()
        return {key: y[a:b].reshape(shape) for key, a, b, shape in self._layout}

    def output_vector(self) -> np.ndarray:
        """Every output of :meth:`outputs` in one new flat array, in the order of
        :meth:`output_slices`, computed in one compiled call (:func:`.kernels.measure`: the
        controls held from this instant and the rigid-body terms at the current state)."""
        x = self._collect()
        if self._y_x is x:                # measured by the step that reached x (_run)
            return self._y.copy()
        err = kernels.measure(self.pm.planar, self._mdl, self._ws, self._cw, x, self.t, self.h,
                              self._par, self.q_home, self._ramp, self._ex_tab, self._prop,
                              self._dry, self._qn, self._vs, self._gen, self._acc, self._FM,
                              self._M, self._nle, self._hg, self._y)
        self._loaded = x                  # the kernel left x's configuration in _qn, _vs
        if err:
            self._ctrl_x = self._y_x = None
            raise np.linalg.LinAlgError(kernels.ERRORS[err])
        self._ctrl_x = self._y_x = x      # and the controls for x in _FM, _gen, _acc
        self._u = None
        return self._y.copy()

    def output_slices(self) -> dict:
        """``{key: (start, stop, shape)}``: where each output sits in :meth:`output_vector`."""
        return {key: (a, b, shape) for key, a, b, shape in self._layout}

    def base_now(self) -> RigidBody:
        """The base's truth now: the dry base plus the propellant left
        (:meth:`~spacerobot.robots.Propellant.base`); the dry base without propellant model."""
        base = self.pm.base
        return self.propellant.base(base, self.m_p) if self.propellant.active else base


def propellant_array(prop) -> np.ndarray:
    """The ``pp`` array (:data:`.kernels.PROP_FIELDS`) of a :class:`spacerobot.robots.Propellant`
    (all zero when its model is off, ``m0 = 0``)."""
    if not prop.active:
        return np.zeros(len(kernels.PROP_FIELDS))
    return np.array([1.0 / (prop.Isp * G0), 1.0 / prop.arm, 0.4 * prop.R * prop.R,
                     *prop.r], float)


def unit_sphere_inertia(pp) -> np.ndarray:
    """(6, 6) spatial inertia at the base frame origin of 1 kg of propellant (Pinocchio's
    ``[[m 1, -m [c]x], [m [c]x, I_c - m [c]x [c]x]]`` with ``m = 1``, ``c = r``,
    ``I_c = (2/5) R^2 1``): spatial inertias add, so the base's is ``I_dry + m_p`` times it."""
    r = np.asarray(pp[3:6], float)
    cx = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
    out = np.zeros((6, 6))
    out[:3, :3] = np.eye(3)
    out[:3, 3:] = -cx
    out[3:, :3] = cx
    out[3:, 3:] = pp[2] * np.eye(3) - cx @ cx
    return out


def _restore_plant(args, state) -> Plant:
    p = Plant(*args)
    p.set_state(state)
    return p
