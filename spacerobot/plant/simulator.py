"""The plant simulator: state, zero-order-hold controls, classic RK4, measured outputs."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..robots import Controller, RigidBody, Robot
from . import control
from .dynamics import (PlantModel, base_acceleration, base_generalised_velocity, base_position,
                       base_rotation, base_velocity, build_model, configuration_derivative,
                       initial_configuration, momentum, normalise, thruster_generalised_force)


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
        if not (h > 0.0 and math.isfinite(h)):
            raise ValueError(f"h must be a finite step > 0 s, got {h}")
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
        self.t = 0.0
        self.q, self.v = q, v
        self.J = np.zeros(3)
        self.H = np.zeros(3)
        self._u: Controls | None = None

    # -- state -----------------------------------------------------------------------------
    def get_state(self) -> dict:
        """A deep copy of everything that determines the future (controls are derived)."""
        return {"t": self.t, "q": self.q.copy(), "v": self.v.copy(), "J": self.J.copy(),
                "H": self.H.copy()}

    def set_state(self, s: dict) -> None:
        self.t = float(s["t"])
        self.q = np.array(s["q"], float)
        self.v = np.array(s["v"], float)
        self.J = np.array(s["J"], float)
        self.H = np.array(s["H"], float)
        self._u = None

    # -- controls ----------------------------------------------------------------------------
    def controls(self) -> Controls:
        """Commands for the step starting at the current state (cached until the state moves)."""
        if self._u is None:
            pm, q, v = self.pm, self.q, self.v
            A = base_rotation(pm, q)
            P, L_c, _, _ = momentum(pm, self.data, q, v)
            F, M = control.thruster_command(P, L_c, self.controller)
            f_b = thruster_generalised_force(pm, A, F, M)
            tau, _, _ = control.arm_command(pm, self.data, q, v, f_b, self.controller, self.q_home)
            a = pin.aba(pm.model, self.data, q, v, np.concatenate([f_b, tau])).copy()
            self._u = Controls(F, M, tau, a)
        return self._u

    # -- integration -------------------------------------------------------------------------
    def _deriv(self, q, v, u: Controls):
        pm = self.pm
        A = base_rotation(pm, q)
        qn = normalise(pm, q.copy())
        gen = np.concatenate([thruster_generalised_force(pm, A, u.F, u.M), u.tau])
        a = pin.aba(pm.model, self.data, qn, v, gen).copy()
        dq = configuration_derivative(pm, q, v, A)
        dH = u.M + np.cross(base_position(pm, q), u.F)
        return dq, a, dH

    def rk4_step(self, dt: float) -> None:
        """One classic RK4 step of length ``dt`` with the controls held (zero-order hold)."""
        u = self.controls()
        q, v = self.q, self.v
        # stage 1: the accelerations at the step start are already in the controls
        k1q = configuration_derivative(self.pm, q, v, base_rotation(self.pm, q))
        k1v, k1h = u.a, u.M + np.cross(base_position(self.pm, q), u.F)
        k2q, k2v, k2h = self._deriv(q + 0.5 * dt * k1q, v + 0.5 * dt * k1v, u)
        k3q, k3v, k3h = self._deriv(q + 0.5 * dt * k2q, v + 0.5 * dt * k2v, u)
        k4q, k4v, k4h = self._deriv(q + dt * k3q, v + dt * k3v, u)
        self.q = normalise(self.pm, q + dt / 6.0 * (k1q + 2 * k2q + 2 * k3q + k4q))
        self.v = v + dt / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
        self.H = self.H + dt / 6.0 * (k1h + 2 * k2h + 2 * k3h + k4h)
        self.J = self.J + dt * u.F  # F is constant over the step: exact impulse
        self.t += dt
        self._u = None

    def advance(self, dt: float) -> None:
        """Integrate over ``dt``: whole internal steps ``h``, then one shorter step if needed."""
        if not (dt > 0.0 and math.isfinite(dt)):
            raise ValueError(f"communication step must be finite and > 0 s, got {dt}")
        n = int(math.floor(dt / self.h + 1e-9))
        rest = dt - n * self.h
        if rest < 1e-9 * self.h:
            rest = 0.0
        for _ in range(n):
            self.rk4_step(self.h)
        if rest > 0.0:
            self.rk4_step(rest)
        if not (np.all(np.isfinite(self.q)) and np.all(np.isfinite(self.v))):
            raise FloatingPointError(f"state became non-finite at t = {self.t:.6g} s")

    # -- measurements ------------------------------------------------------------------------
    def outputs(self) -> dict:
        """What the sensors measure at the current instant, plus truth momentum.

        Keys follow the interface contract: ``r_S, v_S, A, omega_B, a_S, alpha_B, q, qd, qdd,
        F, M, J, H, P, L, tau``.
        """
        pm, q, v = self.pm, self.q, self.v
        u = self.controls()
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
