"""The plant simulator: state, zero-order-hold controls, classic RK4, measured outputs.

Implementation notes (performance; the equations are those of :mod:`.dynamics`):

* The state lives in one vector ``x = [J (3), H (3), q (nq), v (nv)]``; the public attributes
  ``q``, ``v``, ``J``, ``H`` are views of it. Every step makes a new ``x`` (the arrays a caller
  kept are never changed behind its back); a caller that assigns e.g. ``plant.q = ...`` is
  noticed at the next step.
* One RK4 step evaluates the controls once (zero-order hold) and ABA three more times; the four
  stage derivatives are rows of one preallocated matrix, combined by one product at the end.
  Everything about the base (DCM, thruster force in the base frame, ``dq/dt`` of the root joint,
  ``dH/dt = M + r_S x F``) is computed on Python floats with explicit formulas.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..robots import Controller, RigidBody, Robot
from . import control
from .dynamics import (PlantModel, base_acceleration, base_generalised_velocity, base_position,
                       base_rotation, base_velocity, build_model, initial_configuration, momentum,
                       quat_dcm)

#: weights of the four RK4 stages (times dt / 6)
_RK4_W = np.array([1.0, 2.0, 2.0, 1.0])


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
    """

    def __init__(self, robot: Robot, base: RigidBody, target: RigidBody, controller: Controller,
                 v0, omega0, h: float = 1e-3):
        if not (0.0 < h <= 1.0):
            raise ValueError(f"h must be in (0, 1] s, got {h}")
        base.check("base")
        target.check("target")
        controller.check()
        self._init_args = (robot, base, target, controller, tuple(v0), tuple(omega0), h)
        self.pm: PlantModel = build_model(robot, base, target)
        self.data = self.pm.model.createData()
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
        self._nqb = 4 if pm.planar else 7                    # root-joint configuration size
        self._nsc = 6 + self._nqb                            # scalar part of a stage row
        nx = self._ov + self._nv
        self._K = np.empty((4, nx))
        self._xs = np.empty(nx)
        self._tmp = np.empty(nx)
        self._qn = np.empty(self._nq)                        # normalised stage configuration
        self._vs = np.empty(self._nv)                        # stage velocity (owned, aligned)
        self._gen = np.zeros(self._nv)                       # generalised force
        self._ctrl = control.ArmController(pm, controller, self.q_home)
        self.t = 0.0
        self._x = np.concatenate([np.zeros(6), q, v])
        self._publish()
        self._u: Controls | None = None
        self._held = None          # (F and M as 6 floats, tau, a) of the held controls
        self._step = self._make_step()

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
        x, oq, ov = self._x, self._oq, self._ov
        self.J, self.H, self.q, self.v = x[0:3], x[3:6], x[oq:ov], x[ov:]
        self._pub = (self.J, self.H, self.q, self.v)

    def _collect(self) -> np.ndarray:
        """The state vector, rebuilt if a caller replaced one of the public attributes."""
        pub = self._pub
        if (self.J is not pub[0] or self.H is not pub[1] or self.q is not pub[2]
                or self.v is not pub[3]):
            self._x = np.concatenate([np.asarray(self.J, float), np.asarray(self.H, float),
                                      np.asarray(self.q, float), np.asarray(self.v, float)])
            self._publish()
        return self._x

    def get_state(self) -> dict:
        """A deep copy of everything that determines the future (controls are derived)."""
        self._collect()
        return {"t": self.t, "q": self.q.copy(), "v": self.v.copy(), "J": self.J.copy(),
                "H": self.H.copy()}

    def set_state(self, s: dict) -> None:
        self.t = float(s["t"])
        q = np.array(s["q"], float)
        v = np.array(s["v"], float)
        J = np.array(s["J"], float)
        H = np.array(s["H"], float)
        if q.shape != (self._nq,) or v.shape != (self._nv,) or J.shape != (3,) or H.shape != (3,):
            raise ValueError(f"state shapes q {q.shape}, v {v.shape}, J {J.shape}, H {H.shape} "
                             f"do not fit this plant (nq = {self._nq}, nv = {self._nv})")
        self._x = np.concatenate([J, H, q, v])
        self._publish()
        self._u = None
        self._held = None

    # -- controls ----------------------------------------------------------------------------
    def controls(self) -> Controls:
        """Commands for the step starting at the current state (cached until the state moves)."""
        if self._u is None:
            x = self._collect()
            held = self._held
            if held is None or held[3] is not x:
                held = self._held = self._controls(x)
            FM, tau, a = held[0], held[1], held[2]
            self._u = Controls(np.array(FM[0:3]), np.array(FM[3:6]), tau, a)
        return self._u

    def _controls(self, x: np.ndarray):
        """Controls at the state ``x``: ``(F and M as 6 floats, tau, a, x)``.

        The accelerations ``a = [dv_b, qdd]`` come from the inverse dynamics of the attitude
        law (``M a + c = [f_b, tau]`` by construction), so no forward-dynamics call is needed.
        """
        pm, c, data, model = self.pm, self.controller, self.data, self.pm.model
        q, v = self._qn, self._vs           # owned copies (Pinocchio is faster on them)
        q[:] = x[self._oq:self._ov]
        v[:] = x[self._ov:]
        hg = pin.computeCentroidalMomentum(model, data, q, v).vector.tolist()
        # eq. 41 on the linear momentum, eq. 40 on the angular momentum about the CoM
        F0, F1, F2, M0, M1, M2 = control.thruster_scalars(hg, c)
        gen = self._gen
        nb = pm.nb
        if pm.planar:
            cs, sn = q[2:4].tolist()
            k = 1.0 / math.hypot(cs, sn)
            cs, sn = cs * k, sn * k
            f_b = (cs * F0 + sn * F1, -sn * F0 + cs * F1, M2)
        else:
            a00, a01, a02, a10, a11, a12, a20, a21, a22 = quat_dcm(*q[3:7].tolist())
            f_b = (a00 * F0 + a10 * F1 + a20 * F2, a01 * F0 + a11 * F1 + a21 * F2,
                   a02 * F0 + a12 * F1 + a22 * F2, a00 * M0 + a10 * M1 + a20 * M2,
                   a01 * M0 + a11 * M1 + a21 * M2, a02 * M0 + a12 * M1 + a22 * M2)
        gen[:nb] = f_b
        tau, _, _, acc = self._ctrl.command(data, q, v, gen[:nb])
        return (F0, F1, F2, M0, M1, M2), tau, acc.copy(), x

    # -- integration -------------------------------------------------------------------------
    def _make_stage(self):
        """The stage function ``stage(xs, row, FM, a)``: fills ``row`` with the derivative of the
        state vector at the stage state ``xs`` under the held thrust ``FM`` (6 floats) and the
        held joint torques (in ``self._gen``); ``a`` is the generalised acceleration if already
        known (stage 1), else None. A closure, so that the hot loop does no attribute lookups.
        """
        model, data, aba = self.pm.model, self.data, pin.aba
        qn, vs, gen = self._qn, self._vs, self._gen
        oq, ov, nsc = self._oq, self._ov, self._nsc
        sqrt, hypot = math.sqrt, math.hypot

        nq = ov - oq

        def stage_planar(xs, row, FM, a):
            st = xs[oq:ov + 3].tolist()            # q, then the base part of v
            px, py, c, s = st[0:4]
            vx, vy, wz = st[nq:nq + 3]
            F0, F1, F2, M0, M1, M2 = FM
            k = 1.0 / hypot(c, s)
            cn, sn = c * k, s * k
            if a is None:
                qn[:] = xs[oq:ov]
                nrm = sqrt(c * c + s * s)
                qn[2] = c / nrm
                qn[3] = s / nrm
                vs[:] = xs[ov:]
                gen[0] = cn * F0 + sn * F1
                gen[1] = -sn * F0 + cn * F1
                gen[2] = M2
                a = aba(model, data, qn, vs, gen)
            # [dJ = F, dH = M + r_S x F, dq/dt of the planar root joint]
            row[0:nsc] = (F0, F1, F2, M0 + (py * F2 - 0.0 * F1), M1 + (0.0 * F0 - px * F2),
                          M2 + (px * F1 - py * F0), cn * vx - sn * vy, sn * vx + cn * vy,
                          -s * wz, c * wz)
            row[nsc:ov] = xs[ov + 3:]
            row[ov:] = a

        def stage_spatial(xs, row, FM, a):
            st = xs[oq:ov + 6].tolist()            # q, then the base part of v
            rx, ry, rz, x, y, z, w = st[0:7]
            vx, vy, vz, wx, wy, wz = st[nq:nq + 6]
            F0, F1, F2, M0, M1, M2 = FM
            a00, a01, a02, a10, a11, a12, a20, a21, a22 = quat_dcm(x, y, z, w)
            if a is None:
                qn[:] = xs[oq:ov]
                nrm = sqrt(x * x + y * y + z * z + w * w)
                qn[3:7] = (x / nrm, y / nrm, z / nrm, w / nrm)
                vs[:] = xs[ov:]
                gen[0:6] = (a00 * F0 + a10 * F1 + a20 * F2, a01 * F0 + a11 * F1 + a21 * F2,
                            a02 * F0 + a12 * F1 + a22 * F2, a00 * M0 + a10 * M1 + a20 * M2,
                            a01 * M0 + a11 * M1 + a21 * M2, a02 * M0 + a12 * M1 + a22 * M2)
                a = aba(model, data, qn, vs, gen)
            # [dJ, dH, A v_l for the position, 1/2 q (x) (0, w) for the quaternion]
            row[0:nsc] = (F0, F1, F2, M0 + (ry * F2 - rz * F1), M1 + (rz * F0 - rx * F2),
                          M2 + (rx * F1 - ry * F0),
                          a00 * vx + a01 * vy + a02 * vz, a10 * vx + a11 * vy + a12 * vz,
                          a20 * vx + a21 * vy + a22 * vz,
                          0.5 * (w * wx + y * wz - z * wy), 0.5 * (w * wy + z * wx - x * wz),
                          0.5 * (w * wz + x * wy - y * wx), -0.5 * (x * wx + y * wy + z * wz))
            row[nsc:ov] = xs[ov + 6:]
            row[ov:] = a

        return stage_planar if self.pm.planar else stage_spatial

    def _make_step(self):
        """The RK4 step ``step(x, dt) -> x_new`` as a closure (see :meth:`_make_stage`)."""
        K, xs, tmp, gen = self._K, self._xs, self._tmp, self._gen
        row0, row1, row2, row3 = K[0], K[1], K[2], K[3]
        stage = self._make_stage()
        nb, oq = self.pm.nb, self._oq
        planar = self.pm.planar
        add, mul, sqrt = np.add, np.multiply, math.sqrt
        W = _RK4_W

        def step(x, dt):
            held = self._held
            if held is None or held[3] is not x:
                held = self._controls(x)
            FM = held[0]
            gen[nb:] = held[1]                 # joint torques, held over the step
            stage(x, row0, FM, held[2])        # stage 1: the accelerations are in the controls
            hdt = 0.5 * dt
            add(x, mul(row0, hdt, out=tmp), out=xs)
            stage(xs, row1, FM, None)
            add(x, mul(row1, hdt, out=tmp), out=xs)
            stage(xs, row2, FM, None)
            add(x, mul(row2, dt, out=tmp), out=xs)
            stage(xs, row3, FM, None)
            xn = W.dot(K)
            xn *= dt / 6.0
            xn += x
            # restore the unit norm of the quaternion / (cos, sin) pair
            if planar:
                c, s = xn[oq + 2:oq + 4].tolist()
                nrm = sqrt(c * c + s * s)
                xn[oq + 2] = c / nrm
                xn[oq + 3] = s / nrm
            else:
                r = xn[oq + 3:oq + 7]
                r /= sqrt(r.dot(r))
            self._u = None
            self._held = None
            return xn

        return step

    def rk4_step(self, dt: float) -> None:
        """One classic RK4 step of length ``dt`` with the controls held (zero-order hold)."""
        x = self._collect()
        self._x = self._step(x, dt)
        self.t += dt
        self._publish()

    def advance(self, dt: float) -> None:
        """Integrate over ``dt``: whole internal steps ``h``, then one shorter step if needed."""
        if not (dt > 0.0 and math.isfinite(dt)):
            raise ValueError(f"communication step must be finite and > 0 s, got {dt}")
        n = int(math.floor(dt / self.h + 1e-9))
        rest = dt - n * self.h
        if rest < 1e-9 * self.h:
            rest = 0.0
        x = self._collect()
        h, step = self.h, self._step
        try:
            # a diverging state is detected below and reported; numpy need not warn as well
            with np.errstate(over="ignore", invalid="ignore"):
                for _ in range(n):
                    x = step(x, h)
                    self.t += h
                if rest > 0.0:
                    x = step(x, rest)
                    self.t += rest
        finally:
            self._x = x
            self._publish()
        if not np.all(np.isfinite(x)):
            raise FloatingPointError(f"state became non-finite at t = {self.t:.6g} s")

    # -- measurements ------------------------------------------------------------------------
    def outputs(self) -> dict:
        """What the sensors measure at the current instant, plus truth momentum.

        Keys follow the interface contract: ``r_S, v_S, A, omega_B, a_S, alpha_B, q, qd, qdd,
        F, M, J, H, P, L, tau``.
        """
        u = self.controls()
        pm, q, v = self.pm, self.q, self.v
        v_S, omega_B = base_velocity(pm, q, v)
        a_S, alpha_B = base_acceleration(pm, q, v, u.a)
        P, _, L_O, _ = momentum(pm, self.data, q, v)
        n = pm.n
        return {
            "r_S": base_position(pm, q), "v_S": v_S, "A": base_rotation(pm, q),
            "omega_B": omega_B, "a_S": a_S, "alpha_B": alpha_B,
            "q": q[-n:].copy(), "qd": v[-n:].copy(), "qdd": u.a[-n:].copy(),
            "F": u.F.copy(), "M": u.M.copy(), "J": self.J.copy(), "H": self.H.copy(),
            "P": P, "L": L_O, "tau": u.tau.copy(),
        }


def _restore_plant(args, state) -> Plant:
    p = Plant(*args)
    p.set_state(state)
    return p
