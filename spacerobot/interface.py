"""The interface contract: every FMI variable of both FMUs, defined once.

The FMU wrappers register exactly these variables, the SSD generator wires exactly these
connectors, and the tests check both against this table. Names are 1-based structured names
(``base.r[1]``, ``base.A[2,3]``, ``arm.q[4]``); units are Modelica unit strings.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple

import numpy as np

from .robots import INERTIA_NAMES, RigidBody, Robot, Scenario

#: unit -> SI base-unit exponents, for the FMI UnitDefinitions
UNITS: Dict[str, Dict[str, int]] = {
    "1": {},
    "s": {"s": 1},
    "1/s": {"s": -1},
    "1/s2": {"s": -2},
    "m": {"m": 1},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "kg": {"kg": 1},
    "kg.m2": {"kg": 1, "m": 2},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "N.s": {"kg": 1, "m": 1, "s": -1},
    "N.m.s": {"kg": 1, "m": 2, "s": -1},
}


@dataclass(frozen=True)
class Var:
    """One scalar FMI variable.

    ``key`` locates the value in the core's data: ``(group, index)``, e.g. ``("v_S", 0)`` for
    ``base.v[1]`` or ``("A", (1, 2))`` for ``base.A[2,3]``.
    """

    name: str
    causality: str            # parameter | input | output
    variability: str          # fixed | tunable | continuous | discrete
    type: str                 # Real | Integer
    unit: Optional[str]
    description: str
    start: Optional[float] = None
    key: Tuple = ()


def _vec(prefix, group, unit, what, causality, variability="continuous", start=None):
    axes = "xyz"
    return [Var(f"{prefix}[{i + 1}]", causality, variability, "Real", unit,
                f"{what}, {axes[i]} component", None if start is None else float(start[i]),
                (group, i)) for i in range(3)]


def _dcm(causality):
    return [Var(f"base.A[{i + 1},{j + 1}]", causality, "continuous", "Real", "1",
                f"Direction cosine matrix base -> inertial (x_I = A x_B), element ({i + 1},{j + 1})",
                None, ("A", (i, j))) for i in range(3) for j in range(3)]


def _joint(prefix, group, unit, what, n, causality):
    return [Var(f"{prefix}[{k + 1}]", causality, "continuous", "Real", unit,
                f"{what}, joint {k + 1}", None, (group, k)) for k in range(n)]


def measurement_vars(n: int, causality: str) -> List[Var]:
    """The signals the plant outputs and the estimator reads (interface contract §3)."""
    c = causality
    start = (0.0, 0.0, 0.0) if c == "input" else None
    out = []
    out += _vec("base.r", "r_S", "m", "Position of the base sensor point S, inertial frame", c, start=start)
    out += _vec("base.v", "v_S", "m/s", "Velocity of S, inertial frame", c, start=start)
    dcm = _dcm(c)
    if c == "input":  # identity start so that an unconnected estimator sees a valid DCM
        dcm = [Var(v.name, v.causality, v.variability, v.type, v.unit, v.description,
                   1.0 if v.key[1][0] == v.key[1][1] else 0.0, v.key) for v in dcm]
    out += dcm
    out += _vec("base.omega", "omega_B", "rad/s", "Base angular velocity, base frame", c, start=start)
    out += _vec("base.a", "a_S", "m/s2", "Acceleration of S, inertial frame", c, start=start)
    out += _vec("base.alpha", "alpha_B", "rad/s2", "Base angular acceleration, base frame", c, start=start)
    for group, unit, what in (("q", "rad", "Joint angle"), ("qd", "rad/s", "Joint rate"),
                              ("qdd", "rad/s2", "Joint acceleration")):
        vs = _joint(f"arm.{group}", group, unit, what, n, c)
        if c == "input":
            vs = [Var(v.name, v.causality, v.variability, v.type, v.unit, v.description, 0.0, v.key)
                  for v in vs]
        out += vs
    out += _vec("thrust.F", "F", "N", "Thruster force applied at S, inertial frame, at this instant", c, start=start)
    out += _vec("thrust.M", "M", "N.m", "Thruster torque, inertial frame, at this instant", c, start=start)
    out += _vec("thrust.J", "J", "N.s", "Accumulated impulse of the thruster force since t = 0", c, start=start)
    out += _vec("thrust.H", "H", "N.m.s",
                "Accumulated angular impulse of (M + r_S x F) about the inertial origin since t = 0",
                c, start=start)
    return out


def body_param_vars(prefix: str, body, causality: str, what: str, key_group: str,
                    variability: str = "fixed") -> List[Var]:
    """``<prefix>.m``, ``<prefix>.b[1..3]``, ``<prefix>.Ixx`` ... ``<prefix>.Iyz``."""
    frame = "target frame T (origin at the grasp point E)" if "target" in prefix else \
        "base frame B (origin at the sensor point S)"
    out = [Var(f"{prefix}.m", causality, variability, "Real", "kg", f"{what} mass", body.mass,
               (key_group, "m"))]
    out += [Var(f"{prefix}.b[{i + 1}]", causality, variability, "Real", "m",
                f"{what} centre-of-mass offset from the frame origin, {frame}, {'xyz'[i]} component",
                float(body.com[i]), (key_group, "b", i)) for i in range(3)]
    out += [Var(f"{prefix}.{nm}", causality, variability, "Real", "kg.m2",
                f"{what} inertia tensor element {nm} about the centre of mass, {frame}"
                + (" (tensor element = minus the product of inertia)" if nm[1] != nm[2] else ""),
                float(body.inertia[k]), (key_group, "I", k)) for k, nm in enumerate(INERTIA_NAMES)]
    return out


CONTROLLER_DOC = {
    "F_max": ("N", "Thruster force bound per axis (eq. 41)"),
    "K_F": ("1/s", "Linear momentum feedback gain F = K_F P (eq. 41)"),
    "P_max": ("N.s", "Linear momentum band of the bounded law (eq. 41)"),
    "M_max": ("N.m", "Thruster torque bound per axis (eq. 40)"),
    "K_M": ("1/s", "Angular momentum feedback gain M = K_M L (eq. 40)"),
    "L_max": ("N.m.s", "Angular momentum band of the bounded law (eq. 40)"),
    "K_D": ("1/s", "Base attitude law damping gain (eq. 39)"),
    "K_P": ("1/s2", "Base attitude law stiffness gain (eq. 39)"),
    "K_Dn": ("1/s", "Arm null-space posture damping gain"),
    "K_Pn": ("1/s2", "Arm null-space posture stiffness gain"),
    "qdd_max": ("rad/s2", "Bound on commanded joint accelerations"),
}


def plant_vars(robot: Robot, sc: Scenario) -> List[Var]:
    """All variables of the plant FMU for ``robot`` with defaults from scenario ``sc``."""
    n = robot.n_joints
    v = measurement_vars(n, "output")
    v += _vec("system.P", "P", "N.s", "Total linear momentum of the system, inertial frame (truth)", "output")
    v += _vec("system.L", "L", "N.m.s",
              "Total angular momentum about the inertial origin, inertial frame (truth)", "output")
    v += _joint("arm.tau", "tau", "N.m", "Joint torque commanded by the arm controller (diagnostic)",
                n, "output")
    v += body_param_vars("base", robot.base, "parameter", "Base (truth)", "base")
    v += body_param_vars("target", sc.target, "parameter", "Target (truth)", "target")
    v += _vec("base.v0", "v0", "m/s", "Initial velocity of S, inertial frame", "parameter", "fixed", sc.v0)
    v += _vec("base.omega0", "omega0", "rad/s", "Initial base angular velocity, base frame",
              "parameter", "fixed", sc.omega0)
    ctrl = sc.controller
    for name, (unit, doc) in CONTROLLER_DOC.items():
        v.append(Var(name, "parameter", "fixed", "Real", unit, doc, float(getattr(ctrl, name)),
                     ("ctrl", name)))
    v.append(Var("h", "parameter", "fixed", "Real", "s", "Internal RK4 step", sc.h, ("h",)))
    v += plant_excitation_vars(sc)
    return v


#: plant excitation parameters (``excite.<field>`` of robots.Excitation): unit, description
EXCITATION_DOC = {
    "att_max": ("rad", "Amplitude bound of the base attitude excitation reference, per axis"),
    "q_max": ("rad", "Amplitude bound of each joint excitation reference about the home posture"),
    "qd_max": ("rad/s", "Bound on each joint excitation reference rate"),
    "qdd_max": ("rad/s2", "Bound on each joint excitation reference acceleration"),
    "period": ("s", "Period of the slowest excitation component (components in [1, 3] x 2 pi/period)"),
    "ramp": ("s", "Duration of a change of the excitation level (quintic ramp, no jump)"),
}


def plant_excitation_vars(sc: Scenario) -> List[Var]:
    """The plant's excitation input ``ident.excite``, its level output and parameters."""
    ex = sc.excitation
    v = [Var("ident.excite", "input", "continuous", "Real", "1",
             "Requested excitation level, 0..1 (0 = none: the paper's motion; values outside "
             "are clipped with a warning, NaN makes the step fail with Discard)", 0.0, ("excite",)),
         Var("excite.level", "output", "continuous", "Real", "1",
             "Excitation level in effect (follows ident.excite along a quintic ramp)", None,
             ("excite_level", 0))]
    for name, (unit, doc) in EXCITATION_DOC.items():
        v.append(Var(f"excite.{name}", "parameter", "fixed", "Real", unit, doc,
                     float(getattr(ex, name)), ("excite_par", name)))
    return v


#: Estimator enumerations (Integer parameters)
METHODS = {1: "momentum", 2: "force"}
SOLVERS = {1: "paper", 2: "joint"}
ACCEL_SOURCES = {1: "measured", 2: "differenced"}

#: Estimator status codes (``diag.status``)
STATUS = {
    0: "no sample yet",
    1: "reference sample stored (momentum method) or waiting for differencing history",
    2: "estimating: last sample used",
    3: "last sample rejected: non-finite or out-of-range input, or an update that overflowed",
    4: "last sample rejected: inconsistent input (base.A not a rotation matrix)",
}


def estimator_vars(robot: Robot, sc: Scenario) -> List[Var]:
    """All variables of the estimator FMU for ``robot``; guesses default to the paper's."""
    n = robot.n_joints
    g = sc.guess
    v = measurement_vars(n, "input")
    v += body_param_vars("base", g.base, "output", "Base estimated", "est_base", "continuous")
    v += body_param_vars("target", g.target, "output", "Target estimated", "est_target", "continuous")
    v = [Var(x.name, x.causality, x.variability, x.type, x.unit, x.description, None, x.key)
         if x.causality == "output" else x for x in v]
    for who in ("base", "target"):
        for x in body_param_vars(f"sd.{who}", g.base if who == "base" else g.target, "output",
                                 f"Standard deviation of the {who} estimate:", f"sd_{who}",
                                 "continuous"):
            v.append(Var(x.name, "output", "continuous", "Real", x.unit, x.description, None, x.key))
    for who, body in (("base", g.base), ("target", g.target)):
        for x in body_param_vars(f"guess.{who}", body, "parameter", f"Initial guess of the {who}",
                                 f"guess_{who}"):
            v.append(x)
    v += [
        Var("method", "parameter", "fixed", "Integer", None,
            "Identification equations: 1 = momentum-based (eqs. 11/16), 2 = force-based (eqs. 28/31)",
            1, ("method",)),
        Var("solver", "parameter", "fixed", "Integer", None,
            "Solver: 1 = the paper's modified RLS (eqs. 34-38), 2 = joint RLS over the 20 standard "
            "parameters", 1, ("solver",)),
        Var("accel_source", "parameter", "fixed", "Integer", None,
            "Force method accelerations: 1 = measured inputs, 2 = central differences of the "
            "velocity inputs (one sample delay)", 1, ("accel_source",)),
        Var("lambda", "parameter", "fixed", "Real", "1", "RLS forgetting factor (0 < lambda <= 1)",
            1.0, ("lambda",)),
        Var("P0_mu", "parameter", "fixed", "Real", "1",
            "Initial covariance (diagonal) of masses and first moments", g.P0_mu, ("P0_mu",)),
        Var("P0_theta", "parameter", "fixed", "Real", "1",
            "Initial covariance (diagonal) of the inertia parameters", g.P0_theta, ("P0_theta",)),
        Var("diag.samples", "output", "discrete", "Integer", None, "Number of samples used", None,
            ("samples",)),
        Var("diag.rejected", "output", "discrete", "Integer", None,
            "Number of samples rejected (non-finite or inconsistent)", None, ("rejected",)),
        Var("diag.status", "output", "discrete", "Integer", None,
            "Status: " + "; ".join(f"{k} = {s}" for k, s in STATUS.items()), None, ("status",)),
        Var("diag.residual_lin", "output", "continuous", "Real", "1",
            "A-priori residual of the linear (mass) equations, relative to the norm of their "
            "right-hand side", None, ("residual_lin",)),
        Var("diag.residual_ang", "output", "continuous", "Real", "1",
            "A-priori residual of the angular (inertia) equations, relative to the norm of their "
            "right-hand side", None, ("residual_ang",)),
        Var("diag.excitation_mu", "output", "continuous", "Real", "1",
            "Identifiability of masses/first moments: reciprocal condition number of their "
            "information matrix (0 = not identifiable yet)", None, ("excitation_mu",)),
        Var("diag.excitation_theta", "output", "continuous", "Real", "1",
            "Identifiability of the inertias: reciprocal condition number of their information "
            "matrix (0 = not identifiable yet)", None, ("excitation_theta",)),
    ]
    return v


#: The 20 estimates (and truth parameters), in the order of ``Identifier.vector()``.
ESTIMATE_NAMES: Tuple[str, ...] = tuple(
    f"{who}.{p}" for who in ("base", "target") for p in ("m", "b[1]", "b[2]", "b[3]", *INERTIA_NAMES))


def estimate_vector(base: RigidBody, target: RigidBody) -> np.ndarray:
    """Two bodies as one (20,) vector in the order of :data:`ESTIMATE_NAMES` (the truth that
    ``Identifier.vector()`` estimates)."""
    return np.concatenate([[base.mass], base.com, base.inertia,
                           [target.mass], target.com, target.inertia]).astype(float)


def error_scale(truth: np.ndarray) -> np.ndarray:
    """Scale of the relative error of each entry of a (20,) truth vector: ``|truth|``, or where
    the truth is zero (a CoM component, a product of inertia) 1 m for ``b`` and the body's
    largest principal moment for the inertia elements."""
    truth = np.asarray(truth, float)
    scale = np.abs(truth)
    for o in (0, 10):
        imax = np.abs(truth[o + 4:o + 7]).max()
        for i in range(o, o + 10):
            if scale[i] == 0.0:
                scale[i] = 1.0 if i - o < 4 else (imax if imax > 0.0 else 1.0)
    return scale


def relative_errors(est: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """``|est - truth| / error_scale(truth)``; ``est`` (..., 20) in the order of
    :data:`ESTIMATE_NAMES`."""
    truth = np.asarray(truth, float)
    return np.abs(np.asarray(est, float) - truth) / error_scale(truth)


def identified_estimates(robot: Robot) -> List[str]:
    """The estimates the robot's model identifies: all 20 for a spatial robot; for a planar one
    (x, y translation and z rotation) m, b[1], b[2] and Izz of each body. The others keep their
    initial guess."""
    if not robot.planar:
        return list(ESTIMATE_NAMES)
    return [n for n in ESTIMATE_NAMES if n.split(".", 1)[1] in ("m", "b[1]", "b[2]", "Izz")]


def connections(robot: Robot) -> List[str]:
    """Names wired plant output -> estimator input of the same name."""
    return [v.name for v in measurement_vars(robot.n_joints, "input")]
