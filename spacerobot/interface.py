"""The interface contract: every FMI variable of the three FMUs, defined once.

The FMU wrappers register exactly these variables, the SSD generator wires exactly these
connectors, and the tests check both against this table. Names are 1-based structured names
(``base.r[1]``, ``base.A[2,3]``, ``arm.q[4]``); units are Modelica unit strings.
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .robots import INERTIA_NAMES, RigidBody, Robot, Scenario

#: unit -> SI base-unit exponents, for the FMI UnitDefinitions
UNITS: Dict[str, Dict[str, int]] = {
    "1": {},
    "s": {"s": 1},
    "1/s": {"s": -1},
    "1/s2": {"s": -2},
    "Hz": {"s": -1},
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
                f"Direction cosine matrix base -> inertial (x_I = A x_B: column j is base axis j "
                f"in inertial axes), element ({i + 1},{j + 1})",
                None, ("A", (i, j))) for i in range(3) for j in range(3)]


def _joint(prefix, group, unit, what, n, causality):
    return [Var(f"{prefix}[{k + 1}]", causality, "continuous", "Real", unit,
                f"{what}, joint {k + 1}", None, (group, k)) for k in range(n)]


def measurement_vars(n: int, causality: str) -> List[Var]:
    """The signals the plant outputs and the estimator reads (interface contract §3)."""
    c = causality
    start = (0.0, 0.0, 0.0) if c == "input" else None
    out = []
    # the descriptions say what a plant of another origin must provide (docs/fmus.md)
    out += _vec("base.r", "r_S", "m", "Position of the base sensor point S (origin of the base "
                "frame B), inertial frame", c, start=start)
    out += _vec("base.v", "v_S", "m/s", "Velocity of S, dr_S/dt in inertial axes (the base "
                "frame origin, not the base centre of mass)", c, start=start)
    dcm = _dcm(c)
    if c == "input":  # identity start so that an unconnected estimator sees a valid DCM
        dcm = [Var(v.name, v.causality, v.variability, v.type, v.unit, v.description,
                   1.0 if v.key[1][0] == v.key[1][1] else 0.0, v.key) for v in dcm]
    out += dcm
    out += _vec("base.omega", "omega_B", "rad/s", "Base angular velocity in base axes (body "
                "rates, as a gyro measures: A^T omega_inertial)", c, start=start)
    out += _vec("base.a", "a_S", "m/s2", "Acceleration of S, d²r_S/dt² in inertial axes (not a "
                "spatial acceleration in body axes)", c, start=start)
    out += _vec("base.alpha", "alpha_B", "rad/s2", "Base angular acceleration in base axes, "
                "d(base.omega)/dt", c, start=start)
    for group, unit, what in (
            ("q", "rad", "Joint angle about the joint axis of the robot description (0 = its "
                         "zero posture)"),
            ("qd", "rad/s", "Joint rate, d(arm.q)/dt"),
            ("qdd", "rad/s2", "Joint acceleration, d²(arm.q)/dt²")):
        vs = _joint(f"arm.{group}", group, unit, what, n, c)
        if c == "input":
            vs = [Var(v.name, v.causality, v.variability, v.type, v.unit, v.description, 0.0, v.key)
                  for v in vs]
        out += vs
    out += _vec("thrust.F", "F", "N", "Resultant thruster force at this instant, inertial axes, "
                "taken as acting at S (a force elsewhere adds its moment about S to thrust.M)",
                c, start=start)
    out += _vec("thrust.M", "M", "N.m", "Resultant thruster torque about S at this instant, "
                "inertial axes", c, start=start)
    out += _vec("thrust.J", "J", "N.s", "Impulse of thrust.F, inertial axes, accumulated from a "
                "fixed instant (the plant: t = 0); the estimator uses only its changes", c,
                start=start)
    out += _vec("thrust.H", "H", "N.m.s", "Angular impulse of (thrust.M + r_S x thrust.F) about "
                "the inertial origin, inertial axes, accumulated from the same instant as "
                "thrust.J", c, start=start)
    return out


#: The estimated bodies, in the order of the estimate vector.
BODIES: Tuple[str, ...] = ("base", "target")
#: The 10 parameters of one body (``<body>.<name>``): mass, CoM offset, CoM inertia.
BODY_PARAMETERS: Tuple[str, ...] = ("m", "b[1]", "b[2]", "b[3]", *INERTIA_NAMES)
#: The paper's order of the six inertia entries, ``I# = [I11, I12, I13, I22, I23, I33]`` (eq. 21).
SHARP_NAMES: Tuple[str, ...] = ("Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz")


def body_param_vars(prefix: str, body, causality: str, what: str, key_group: str,
                    variability: str = "fixed") -> List[Var]:
    """``<prefix>.m``, ``<prefix>.b[1..3]``, ``<prefix>.Ixx`` ... ``<prefix>.Iyz``
    (:data:`BODY_PARAMETERS`)."""
    frame = "target frame T (origin at the grasp point E)" if "target" in prefix else \
        "base frame B (origin at the sensor point S)"
    m_name, b_names, i_names = BODY_PARAMETERS[0], BODY_PARAMETERS[1:4], BODY_PARAMETERS[4:]
    out = [Var(f"{prefix}.{m_name}", causality, variability, "Real", "kg", f"{what} mass",
               body.mass, (key_group, "m"))]
    out += [Var(f"{prefix}.{nm}", causality, variability, "Real", "m",
                f"{what} centre-of-mass offset from the frame origin, {frame}, {'xyz'[i]} component",
                float(body.com[i]), (key_group, "b", i)) for i, nm in enumerate(b_names)]
    out += [Var(f"{prefix}.{nm}", causality, variability, "Real", "kg.m2",
                f"{what} inertia tensor element {nm} about the centre of mass, {frame}"
                + (" (tensor element = minus the product of inertia)" if nm[1] != nm[2] else ""),
                float(body.inertia[k]), (key_group, "I", k)) for k, nm in enumerate(i_names)]
    return out


def _table_vars(table: str, *records) -> List[Var]:
    """The parameters of one of the C plant's parameter structs (``plant.h``'s tables, read
    from the library: FMI names, units, descriptions, order), started at the values of the
    Python record (its attributes named as the fields); key: the FMI name (the glue's). A
    struct of several records (the panels', the slosh modes'): field by field, ``<fmi>[i]``
    and ``<fmi>[i,k]`` for record i (1-based), keys ``(fmi, i - 1[, k - 1])``."""
    from .core.tables import fields
    out: List[Var] = []
    label = {"flex": "panel", "slosh": "slosh mode"}.get(table, table)
    for f in fields(table):
        if len(records) == 1:
            value = getattr(records[0], f.name)
            if f.size == 1:
                out.append(Var(f.fmi, "parameter", "fixed", "Real", f.unit, f.description,
                               float(value), (f.fmi,)))
            else:
                out += _vec(f.fmi, f.fmi, f.unit, f.description, "parameter", "fixed", value)
            continue
        for i, rec in enumerate(records):
            value = getattr(rec, f.name)
            if f.size == 1:
                out.append(Var(f"{f.fmi}[{i + 1}]", "parameter", "fixed", "Real", f.unit,
                               f"{f.description}, {label} {i + 1}", float(value),
                               (f.fmi, i)))
            else:
                out += [Var(f"{f.fmi}[{i + 1},{k + 1}]", "parameter", "fixed", "Real", f.unit,
                            f"{f.description}, {'xyz'[k]} component, {label} {i + 1}",
                            float(value[k]), (f.fmi, i, k)) for k in range(f.size)]
    return out


def _table_doc(table: str) -> Dict[str, Tuple[str, str]]:
    """``{field: (unit, description)}`` of the C plant's scalar fields of ``table``."""
    from .core.tables import fields
    return {f.name: (f.unit, f.description) for f in fields(table) if f.size == 1}


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
    v += _table_vars("controller", sc.controller)
    v.append(Var("h", "parameter", "fixed", "Real", "s", "Internal RK4 step", sc.h, ("h",)))
    v += plant_excitation_vars(sc)
    v += propellant_vars(sc)
    v += flexible_vars(sc)
    return v


def flexible_vars(sc: Scenario) -> List[Var]:
    """The plant's flexible parts (docs/models.md, "Flexible appendages and slosh"): the
    counts ``flex.n``, ``slosh.n`` (Integer; 0 = none, the rigid plant), the records of the
    panels ``flex.*[i]`` and of the slosh modes ``slosh.*[i]`` (all of the core's records,
    :func:`spacerobot.core.tables.records`, started at the scenario's), and the outputs: the
    flexible parts' momentum ``flex.P``, ``flex.L``, the deflections and strokes."""
    from .core.tables import records
    nf, ns = records("flex"), records("slosh")
    v = [Var("flex.n", "parameter", "fixed", "Integer", None,
             f"Number of hinged panels on the base: the first flex.n of the {nf} records "
             f"flex.*[i] (0 = none: the rigid plant, bit for bit)", int(sc.flex.n), ("flex.n",))]
    v += _table_vars("flex", *sc.flex.records(nf))
    v.append(Var("slosh.n", "parameter", "fixed", "Integer", None,
                 f"Number of propellant slosh modes: the first slosh.n of the {ns} records "
                 f"slosh.*[i] (0 = none)", int(sc.slosh.n), ("slosh.n",)))
    v += _table_vars("slosh", *sc.slosh.records(ns))
    v += _vec("flex.P", "flex_P", "N.s", "Linear momentum of the flexible parts (panels and "
              "slosh masses): the system's minus that of the composite rigid body (base + "
              "panels at rest + slosh masses at equilibrium) at the same base and arm motion, "
              "inertial frame (truth)", "output")
    v += _vec("flex.L", "flex_L", "N.m.s", "Angular momentum of the flexible parts (likewise), "
              "about the inertial origin, inertial frame (truth)", "output")
    for name, key, unit, what, count in (
            ("flex.q", "flex_q", "rad", "Deflection (truth; 0 past flex.n), panel", nf),
            ("flex.qd", "flex_qd", "rad/s", "Deflection rate (truth; 0 past flex.n), panel", nf),
            ("slosh.x", "slosh_x", "m", "Stroke from the equilibrium point (truth; 0 past "
                                        "slosh.n), slosh mode", ns),
            ("slosh.v", "slosh_v", "m/s", "Stroke rate (truth; 0 past slosh.n), slosh mode",
             ns)):
        v += [Var(f"{name}[{i + 1}]", "output", "continuous", "Real", unit, f"{what} {i + 1}",
                  None, (key, i)) for i in range(count)]
    return v


def propellant_vars(sc: Scenario) -> List[Var]:
    """The plant's propellant parameters and outputs (issue #17): ``prop.*`` and the base's
    current truth ``truth.base.*`` (the ``base.*`` parameters are the dry base)."""
    v = _table_vars("propellant", sc.propellant)
    v.append(Var("prop.m", "output", "continuous", "Real", "kg", "Propellant mass left (truth)",
                 None, ("m_p", 0)))
    v += _vec("prop.P", "P_x", "N.s", "Linear momentum carried away by the expelled propellant "
              "since t = 0 (it leaves the tank with the tank's motion), inertial frame; "
              "system.P + prop.P - system.P(0) = thrust.J", "output")
    v += _vec("prop.L", "L_x", "N.m.s", "Angular momentum about the inertial origin carried "
              "away by the expelled propellant since t = 0, inertial frame; "
              "system.L + prop.L - system.L(0) = thrust.H", "output")
    now = body_param_vars("truth.base", RigidBody(1.0, (0.0, 0.0, 0.0), (1.0,) * 3 + (0.0,) * 3),
                          "output", "Base now (truth: dry base + propellant left; with "
                          "flexible parts the composite rigid base: + panels at rest + slosh "
                          "masses at equilibrium)", "base_now")
    v += [Var(x.name, "output", "continuous", "Real", x.unit, x.description, None,
              ("base_now", k)) for k, x in enumerate(now)]
    return v


def plant_excitation_vars(sc: Scenario) -> List[Var]:
    """The plant's excitation inputs ``ident.excite`` (level) and ``ident.excite_rate``, the
    level and rate in effect, the references and the parameters."""
    ex = sc.excitation
    v = [Var("ident.excite", "input", "continuous", "Real", "1",
             "Requested excitation level, 0..1 (0 = none: the paper's motion; values outside "
             "are clipped with a warning, NaN makes the step fail with Discard)", 0.0, ("excite",)),
         Var("ident.excite_rate", "input", "continuous", "Real", "1",
             "Requested excitation rate: frequency multiplier of every excitation component "
             "(1 = excite.period as set; the joint amplitudes re-bounded for the new "
             "frequencies; the attitude amplitude kept, so the base turns faster). A change "
             "is made through a dip of the level: it ramps to 0, the new rate takes over "
             "there, it ramps back (2 excite.ramp). Values outside "
             "[0.1, 10] are clipped with a warning, NaN makes the step fail with Discard", 1.0,
             ("excite_rate",)),
         Var("excite.level", "output", "continuous", "Real", "1",
             "Excitation level in effect (follows ident.excite along a quintic ramp)", None,
             ("excite_level", 0)),
         Var("excite.rate", "output", "continuous", "Real", "1",
             "Excitation rate in effect (follows ident.excite_rate through a dip of the level)",
             None, ("excite_rate", 0))]
    v += _vec("excite.att_ref", "att_ref", "rad", "Base attitude excitation reference (rotation "
              "vector about the initial attitude; within excite.att_max per axis)", "output")
    v += _joint("excite.qd_ref", "qd_ref", "rad/s", "Joint rate excitation reference (within "
                "excite.qd_max)", sc.robot.n_joints, "output")
    v += _table_vars("excitation", ex)
    return v


class Code(IntEnum):
    """An estimator enumeration: the FMI Integer code is the value, the label the lower-case
    member name (``Method.FORCE == 2``, ``Method.FORCE.label == "force"``)."""

    @property
    def label(self) -> str:
        return self.name.lower()

    @classmethod
    def table(cls) -> Dict[int, str]:
        """``{code: label}``."""
        return {int(c): c.label for c in cls}

    @classmethod
    def parse(cls, value, what: Optional[str] = None) -> "Code":
        """The member for a member, an FMI code or a label; ``ValueError`` naming ``what``
        (default: the class name in lower case) and the choices otherwise."""
        if isinstance(value, cls):
            return value
        if isinstance(value, str):
            for c in cls:
                if c.label == value:
                    return c
        elif isinstance(value, (int, np.integer)) and not isinstance(value, bool):
            if int(value) in cls._value2member_map_:
                return cls(int(value))
        choices = ", ".join(f"{int(c)} ({c.label})" for c in cls)
        raise ValueError(f"{what or cls.__name__.lower()} = {value!r} is not one of {choices}")


class Method(Code):
    """Identification equations: momentum-based (eqs. 11/16) or force-based (eqs. 28/31)."""

    MOMENTUM = 1
    FORCE = 2


class Solver(Code):
    """The paper's modified RLS (eqs. 34-38), or one RLS over the 20 standard parameters."""

    PAPER = 1
    JOINT = 2


class AccelSource(Code):
    """Force method accelerations: the measured inputs, or derivatives of the velocities
    (native/src/differencing.c)."""

    MEASURED = 1
    DIFFERENCED = 2


#: smallest scale of a CoM component's relative error [m] (:meth:`ParameterLayout.error_scale`)
COM_SCALE_MIN = 0.05


class ExciteMode(Code):
    """When the estimator asks the plant for excitation (output ``ident.excite``): never, while
    a body is not identified yet, or always (tracking)."""

    OFF = 0
    UNTIL_IDENTIFIED = 1
    ALWAYS = 2


#: Estimator enumerations (Integer parameters): code -> label
METHODS: Dict[int, str] = Method.table()
SOLVERS: Dict[int, str] = Solver.table()
ACCEL_SOURCES: Dict[int, str] = AccelSource.table()
EXCITE_MODES: Dict[int, str] = ExciteMode.table()

def _status() -> Dict[int, str]:
    """``{code: text}`` of ``diag.status``: the estimator core's table
    (:data:`STATUS`)."""
    from .core.estimator import status_texts
    return status_texts()


def _profile_magnitudes() -> Tuple[str, ...]:
    """The sensors' magnitudes the estimator's noise profile reads (:data:`PROFILE_MAGNITUDES`):
    the ``noise.*`` parameters of the core's options table but ``noise.scale``."""
    from .core.estimator import option_table
    return tuple(o.name for o in option_table()
                 if o.parameter and o.name.startswith("noise.") and o.name != "noise.scale")


def _sensor_magnitudes() -> Tuple[str, ...]:
    """The sensors' error magnitudes (the ``noise.*`` parameters but ``noise.scale``) in the
    sensors core's order (native/src/sensor_noise.h) (:data:`SENSOR_MAGNITUDES`)."""
    from .core.sensors import parameter_names
    return tuple("noise." + n for n in parameter_names())


#: read from the native core when first used (module attributes, PEP 562; importing this
#: module loads no library): STATUS, the status codes' texts of ``diag.status``;
#: PROFILE_MAGNITUDES, the estimator FMU's ``noise.*`` parameters besides ``noise.scale``;
#: SENSOR_MAGNITUDES, the sensors FMU's; CONTROLLER_DOC, EXCITATION_DOC, PROPELLANT_DOC, FLEX_DOC, SLOSH_DOC, the
#: plant's parameter tables' ``{field: (unit, description)}``
_FROM_CORE = {"STATUS": _status, "PROFILE_MAGNITUDES": _profile_magnitudes,
              "SENSOR_MAGNITUDES": _sensor_magnitudes,
              "CONTROLLER_DOC": lambda: _table_doc("controller"),
              "EXCITATION_DOC": lambda: _table_doc("excitation"),
              "PROPELLANT_DOC": lambda: _table_doc("propellant"),
              "FLEX_DOC": lambda: _table_doc("flex"),
              "SLOSH_DOC": lambda: _table_doc("slosh")}


def __getattr__(name: str):
    if name in _FROM_CORE:
        value = _FROM_CORE[name]()
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    for who in ("base", "target"):
        for x in body_param_vars(f"crb.{who}", g.base if who == "base" else g.target, "output",
                                 f"Cramér-Rao bound (first order) of the {who} estimate, as a "
                                 "standard deviation: what the measurements so far allow any "
                                 "unbiased estimator (the information filter's; 0 without it, "
                                 "ident.information):", f"crb_{who}", "continuous"):
            v.append(Var(x.name, "output", "continuous", "Real", x.unit, x.description, None, x.key))
    for who, body in (("base", g.base), ("target", g.target)):
        for x in body_param_vars(f"guess.{who}", body, "parameter", f"Initial guess of the {who}",
                                 f"guess_{who}"):
            v.append(x)
    v += [
        Var("method", "parameter", "fixed", "Integer", None,
            f"Identification equations: {Method.MOMENTUM:d} = momentum-based (eqs. 11/16), "
            f"{Method.FORCE:d} = force-based (eqs. 28/31)", int(Method.MOMENTUM), ("method",)),
        Var("solver", "parameter", "fixed", "Integer", None,
            f"Solver: {Solver.PAPER:d} = the paper's modified RLS (eqs. 34-38), {Solver.JOINT:d} = "
            "joint RLS over the 20 standard parameters", int(Solver.PAPER), ("solver",)),
        Var("accel_source", "parameter", "fixed", "Integer", None,
            f"Force method accelerations: {AccelSource.MEASURED:d} = measured inputs, "
            f"{AccelSource.DIFFERENCED:d} = derivatives of the velocity inputs at the centre of "
            "2 ident.diff_half_window + 1 samples (Savitzky-Golay; the equations use that "
            "centre sample, ident.diff_half_window samples late)", int(AccelSource.MEASURED),
            ("accel_source",)),
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
            "Status: " + "; ".join(f"{k} = {s}" for k, s in _status().items()), None,
            ("status",)),
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
        Var("ident.sd_rel", "parameter", "fixed", "Real", "1",
            "A body counts as identified when every one of its identified estimates has a "
            "standard deviation below this fraction of its error scale", 1e-3, ("sd_rel",)),
        Var("ident.flag_confidence", "parameter", "fixed", "Real", "1",
            "With the information filter (ident.information): the probability, under the "
            "reported standard deviations, that every identified estimate of a body flagged "
            "identified lies within ident.sd_rel of its error scale (each standard deviation "
            "must be below the threshold over the two-sided normal quantile of "
            "(1 - this) / the body's identified estimates)", 0.99, ("flag_confidence",)),
        Var("ident.excite_mode", "parameter", "fixed", "Integer", None,
            f"Excitation request (output ident.excite): {ExciteMode.OFF:d} = never, "
            f"{ExciteMode.UNTIL_IDENTIFIED:d} = while a body is not identified, "
            f"{ExciteMode.ALWAYS:d} = always (tracking)", int(ExciteMode.UNTIL_IDENTIFIED),
            ("excite_mode",)),
        Var("ident.excite_level", "parameter", "fixed", "Real", "1",
            "Excitation level requested while excitation is wanted (0..1)", 1.0,
            ("excite_level",)),
        Var("ident.excite", "output", "continuous", "Real", "1",
            "Excitation level requested from the plant (wire to the plant input of the same "
            "name): ident.excite_level while wanted (ident.excite_mode), else 0", None,
            ("excite",)),
    ]
    for who in BODIES:
        v += [Var(f"diag.identified.{who}", "output", "discrete", "Integer", None,
                  f"1 when every identified estimate of the {who} has a standard deviation below "
                  f"ident.sd_rel of its error scale (with the information filter, "
                  f"ident.information: every estimate within it with probability "
                  f"ident.flag_confidence, after the filter's replay and only where the "
                  f"estimates moved over ident.fit_window within what their standard "
                  f"deviations allow), else 0", None,
                  ("identified", who)),
              Var(f"diag.physical.{who}", "output", "discrete", "Integer", None,
                  f"1 when the least-squares estimate of the {who} is a real rigid body; 0 when "
                  f"the reported {who} estimate is its projection onto real bodies", None,
                  ("physical", who))]
    v += noise_model_vars()
    return v


#: the estimator's noise model (docs/identification.md, "Under noise"): row standard
#: deviation parameters per method and equation, (name suffix, method, unit, equation)
ROW_SD_PARAMETERS = (("momentum_lin", Method.MOMENTUM, "N.s", "linear momentum (eq. 11)"),
                     ("momentum_ang", Method.MOMENTUM, "N.m.s", "angular momentum (eq. 16)"),
                     ("force_lin", Method.FORCE, "N", "force (eq. 28)"),
                     ("force_ang", Method.FORCE, "N.m", "moment (eq. 31)"))


def estimator_parameter_values(robot: Robot, sc: Scenario) -> Dict[str, float]:
    """The estimator FMU's parameters for ``robot`` at their start values, by FMU name."""
    return {v.name: v.start for v in estimator_vars(robot, sc) if v.causality == "parameter"}


def noise_model_vars() -> List[Var]:
    """The estimator's noise-model parameters: the row standard deviations of each method's
    equations (0 = unit weight), the differencing window and the residual correlation lags;
    the defaults are the estimator without a noise model."""
    v = [Var(f"ident.sd_row.{suffix}", "parameter", "fixed", "Real", unit,
             f"Standard deviation of one row of the {what} equation's error from the "
             f"measurement noise ({method.name.lower()} method); the rows are weighted by "
             f"its inverse. 0 = unit weight", 0.0, ("sd_row", suffix))
         for suffix, method, unit, what in ROW_SD_PARAMETERS]
    v += [Var("ident.diff_half_window", "parameter", "fixed", "Integer", None,
              "Differenced accelerations: derivative at the centre of 2m+1 samples, m >= 1 "
              "(1 = 3-point central difference; more = Savitzky-Golay, less noise); the "
              "equations are evaluated at the centre (the estimate lags m samples)", 1,
              ("diff_half_window",)),
          Var("ident.diff_momentum", "parameter", "fixed", "Integer", None,
              "Force method, differenced accelerations: where the derivative's weights go. "
              "1 = on the momentum equations of the window's samples (the force equations "
              "averaged by the same filter: no truncation error however fast the accelerations "
              "change between samples; diff_half_window at most 10), 2 = on the velocities (the "
              "force equations at the centre, the paper's form: exact only where the velocities "
              "are quadratic over the window), 0 = automatic (1, or 2 where diff_half_window "
              "is above 10)", 0, ("diff_momentum",)),
          Var("ident.corr_lags", "parameter", "fixed", "Integer", None,
              "Lags (>= 0) of the residual autocorrelation that inflates the standard "
              "deviations for correlated equation errors (0 = rows independent)", 0,
              ("corr_lags",)),
          Var("ident.momentum_window", "parameter", "fixed", "Real", "s",
              "Momentum method: each sample's equations differenced against the newest sample "
              "at least this much older (the first sample until then) instead of the first "
              "sample; tracks slow changes and keeps noise from accumulating. 0 = the paper's "
              "(against the first sample)", 0.0, ("window", "momentum")),
          Var("ident.momentum_point", "parameter", "fixed", "Integer", None,
              "Momentum method: angular equations about 0 = the inertial origin (the paper's), "
              "1 = the base's position at the newer sample of each difference (position, "
              "velocity and thrust errors not multiplied by the base's distance from the "
              "origin)", 0, ("momentum_point",)),
          Var("ident.accel_bias", "parameter", "fixed", "Integer", None,
              "Force method, measured accelerations: 1 = subtract the accelerometer bias "
              "estimated online from the navigation velocity (the slope of v - integral a), "
              "0 = the accelerations as measured", 0, ("accel_bias",)),
          Var("ident.sd_thrust.scale", "parameter", "fixed", "Real", "1",
              "Standard deviation of the thrust's scale-factor error (force and moment; "
              "constant over the run): a consider term adds what it leaves in the estimates "
              "to their standard deviations. 0 = the measured thrust is exact", 0.0,
              ("sd_thrust", "scale")),
          Var("ident.sd_thrust.misalign", "parameter", "fixed", "Real", "rad",
              "Standard deviation of the thrust's misalignment about each axis (force and "
              "moment; constant over the run), a consider term as ident.sd_thrust.scale. "
              "0 = the measured thrust direction is exact", 0.0, ("sd_thrust", "misalign"))]
    v += [Var(f"ident.noise.{name}", "parameter", "fixed", "Real", unit,
              f"Force method, {source} accelerations: white-noise standard deviation per "
              f"sample of {name}; with any of these > 0 the estimates are compensated for the "
              f"bias that noisy accelerations cause (errors in variables)"
              + ("; also the momentum method's with ident.modes = 1 over a momentum window: the "
                 "modal columns' answer compensated for the noisy velocities in its rows"
                 if source == "differenced" else "") + ". 0 = no noise",
              0.0, ("signal_sd", key))
          for key, name, unit, source in SIGNAL_NOISE_PARAMETERS]
    v += [Var("ident.noise_profile", "parameter", "fixed", "Integer", None,
              "One switch for real sensors: 0 = none (the options as set; by default the "
              "paper's equations), 1 = sensors: the noise model of the sensors described by "
              "this FMU's noise.* parameters (the sensors FMU's names, units and realistic "
              "defaults) sets every ident.* noise option left at its default: the thrust "
              "errors' consider term, the accelerations' noise compensated, the momentum "
              "window or the accelerometer bias or the 9-sample derivative in the momentum "
              "equations (docs/identification.md, 'One switch')", 0, ("noise_profile",)),
          Var("ident.information", "parameter", "fixed", "Integer", None,
              "The information filter (docs/identification.md, 'The information filter'): the "
              "estimates and standard deviations from the momentum equations weighted by the "
              "sensors' noise model, with the thrust errors, the gyro bias and the momentum as "
              "extra unknowns, and the Cramér-Rao bound (outputs crb.*). 0 = automatic (on "
              "with ident.noise_profile = 1 when the sensors have white noise), 1 = on (needs "
              "ident.noise_profile = 1), 2 = off (this estimator's own equations report)", 0,
              ("information",)),
          Var("diag.info_chi2", "output", "continuous", "Real", "1",
              "Information filter: the weighted residuals' mean square (1 when the sensors' "
              "noise model explains the equations' errors; the reported standard deviations "
              "are the bound times sqrt(max(1, diag.info_chi2))); 0 without the filter", None,
              ("info_chi2",))]
    v += model_fit_vars()
    v += excite_design_vars()
    v += [Var("ident.modes", "parameter", "fixed", "Integer", None,
              "The modal columns (docs/identification.md, 'Flexible parts: the modal "
              "columns'): the momentum of flexible panels and propellant slosh, to first order, "
              "as extra unknowns driven by the measured base motion, the modes' frequencies "
              "given (ident.mode_f) or found from the data; the reported estimates are then the "
              "composite rigid body's (with ident.momentum_window, each sample's columns "
              "differenced against the window's reference, as its rows; beside the information "
              "filter, their estimates are reported where the filter finds the rigid model's "
              "misfit and a mode is found, unless the rigid band has an answer; with the band on "
              "it also runs over the modes they find: where the wings' mode lies at 0.2-0.3 Hz "
              "the compliance band has no answer, and the found modes' band (diag.band 3) "
              "brings the wings at 0.3 Hz from the held filter's 161-323 % to 0.753-2.47 %, at "
              "0.2 Hz the columns to 1.95-8.5 %, sensors seeds 0-7). 1 = on (needs "
              "method = 1, solver = 2), 2 = off",
              2, ("modes",))]
    v += [Var(f"ident.mode_f[{i + 1}]", "parameter", "fixed", "Real", "Hz",
              f"With ident.modes = 1: the frequency of flexible mode {i + 1} with the base "
              "held (cantilevered panel, slosh) where known; 0 = not given (the modes are then "
              "found from the kept samples)", 0.0, ("mode_f", i)) for i in range(4)]
    v += [Var(f"diag.mode_f[{i + 1}]", "output", "continuous", "Real", "Hz",
              f"With ident.modes = 1: the frequency of mode {i + 1} in use (given, refined "
              "or found from the data); 0 = none", None, ("mode_f", i)) for i in range(4)]
    v += [Var(f"diag.mode_zeta[{i + 1}]", "output", "continuous", "Real", "1",
              f"With ident.modes = 1: the damping ratio of mode {i + 1} in use; 0 = none", None,
              ("mode_zeta", i)) for i in range(4)]
    v += [Var("ident.band", "parameter", "fixed", "Integer", None,
              "The rigid band (docs/identification.md, 'The rigid band'): beside the "
              "information filter, its momentum rows low-passed below 0.15 Hz (a Butterworth "
              "of order 6) with a quasi-static compliance block for flexible panels and slosh "
              "of 0.2 Hz and above; its estimates and sds are reported where the filter's "
              "model-fit test finds the rigid model's misfit (diag.misfit_cause = 1; "
              "diag.band), from the filter's replay on; with ident.modes = 1 also the band "
              "with the found modes' own columns in place of the compliance, where the "
              "compliance does not fit (modes of 0.2-0.3 Hz). 0 = automatic (on where the "
              "information filter runs and noise_dt is 0.01-2 s), 1 = on (needs them), "
              "2 = off", 0, ("band",)),
          Var("diag.band", "output", "discrete", "Integer", None,
              "The rigid band's answer is reported (ident.band): 1 its low-pass alone, 2 with "
              "the compliance block (taken where it halves the low-pass's chi2), 3 with the "
              "found modes' columns (ident.modes = 1, where the compliance's rows do not "
              "fit); 0 = not reported (the band off, no rigid-model misfit, or no answer that "
              "fits yet)", None,
              ("band",))]
    for name in ("noise.scale",) + _profile_magnitudes():
        unit, default, doc = NOISE_PARAMETERS[name]
        v.append(Var(name, "parameter", "fixed", "Real", unit,
                     "With ident.noise_profile = 1: the sensors' " + doc[0].lower() + doc[1:]
                     + " (as the sensors FMU's parameter of the same name)", default,
                     ("noise", name[len("noise."):])))
    return v


def model_fit_vars() -> List[Var]:
    """The model-fit test (docs/identification.md, 'When the rigid model does not fit'): its
    parameters and outputs."""
    return [
        Var("ident.fit_window", "parameter", "fixed", "Real", "s",
            "Model-fit test without a noise model: the exponential window of the relative "
            "residual diag.model_fit; with the information filter: the identified flags' "
            "hold, the time over which the estimates' move is compared with their standard "
            "deviations (> 0)", 60.0, ("fit_window",)),
        Var("ident.fit_lags", "parameter", "fixed", "Integer", None,
            "Model-fit test with the information filter: the lags of the Ljung-Box whiteness "
            "test of its whitened residuals (1 to 100)", 50, ("fit_lags",)),
        Var("ident.fit_rho_max", "parameter", "fixed", "Real", "1",
            "Misfit where the relative residual is above this (estimator without a noise "
            "model; in (0, 1])", 1e-2, ("fit_rho_max",)),
        Var("ident.fit_whiteness_max", "parameter", "fixed", "Real", "1",
            "Misfit where the whitened residuals' Ljung-Box Q/L is above this (information "
            "filter; 1 for white residuals; in [1, 1e6])", 30.0, ("fit_whiteness_max",)),
        Var("ident.fit_chi2_max", "parameter", "fixed", "Real", "1",
            "Misfit where diag.info_chi2 is above this (information filter; in [1, 1e6]); "
            "alone, with white residuals, it says the noise values are too small: the "
            "estimates are then not held", 2.0,
            ("fit_chi2_max",)),
        Var("ident.fit_thrust_max", "parameter", "fixed", "Real", "1",
            "Misfit where the thrust's force or moment scale factor is estimated more than "
            "this many prior standard deviations from 0 (information filter; in [1, 1e6]); "
            "with white residuals the estimates are not held and their sds carry the "
            "difference to the estimates with the thrust held",
            3.0, ("fit_thrust_max",)),
        Var("ident.fit_bias_k", "parameter", "fixed", "Real", "1",
            "While diag.misfit = 1: the factor k of the model-error term of the standard "
            "deviations, sd^2 += k^2 [(A^T W A)^-1]_ii (the residual's sum of squares beyond "
            "the noise's), the estimator's own equations (in [0, 100]; 0 = none)", 0.5,
            ("fit_bias_k",)),
        Var("ident.fit_bias_k_info", "parameter", "fixed", "Real", "1",
            "As ident.fit_bias_k, for the information filter's and the rigid band's standard "
            "deviations (their whitened residual beyond the noise's; only for a misfit of the "
            "rigid model, not one by chi2 alone; in [0, 100]; 0 = none)", 0.25,
            ("fit_bias_k_info",)),
        Var("ident.eiv_uncertainty", "parameter", "fixed", "Real", "1",
            "Relative uncertainty of the information filter's errors-in-variables correction "
            "(of the noise values' variances it is built from): its standard deviations add "
            "this fraction f of the correction, sd^2 += (f (compensated - uncompensated))^2; "
            "while diag.misfit = 1 by chi2 alone (the noise values too small) max(f, chi2 - 1) "
            "(in [0, 1]; 0 = none)", 0.05, ("eiv_uncertainty",)),
        Var("diag.model_fit", "output", "continuous", "Real", "1",
            "How well the rigid model fits: without a noise model the relative residual of "
            "the equations (a-posteriori, over ident.fit_window; about 1e-4 on the "
            "project's rigid plant noise-free); with the information filter the Ljung-Box Q/L "
            "of its whitened residuals (about 1 where they are white; up to its replay the "
            "innovations, from then on, restarted, the residuals at its compensated estimate; "
            "0 for the first 2 ident.fit_lags samples of each)", None, ("model_fit",)),
        Var("diag.misfit", "output", "discrete", "Integer", None,
            "1 where the model-fit test fails (diag.model_fit, diag.info_chi2 or a thrust "
            "scale beyond its threshold; the information filter decides after its replay at "
            "600 samples): no body is flagged identified; where the residuals are coloured "
            "(the rigid model does not fit) the thrust errors are held at their priors and "
            "the standard deviations carry the model-error term (with the rigid band, on by the "
            "noise profile, its estimates and sds instead: diag.band; else with ident.modes = 1 "
            "and a mode found, the modal columns'; crb.* and diag.info_chi2 stay the "
            "filter's); where diag.info_chi2 set it with white "
            "residuals (the noise values too small) the estimates are kept and the sds "
            "widened; where a thrust scale set it with white residuals the sds carry the "
            "difference to the estimates with the thrust held; logged as a warning at each "
            "onset and change of cause",
            None, ("misfit",)),
        Var("diag.misfit_cause", "output", "discrete", "Integer", None,
            "Why diag.misfit is 1: 1 the rigid model does not fit (coloured residuals: "
            "flexible parts, sloshing propellant), 2 the noise values are too small (chi2 "
            "alone, white residuals), 3 a thrust scale beyond its prior with white residuals "
            "(a miscalibrated thrust, or momentum the rigid model lacks); 0 without a misfit",
            None, ("misfit_cause",)),
    ]


#: the rate choice's two scores (``diag.excite_score.<name>``), in the order of the core's
#: ``excite_score``: rate 1, the candidate
EXCITE_SCORES = ("rate_1", "rate_try")


def excite_design_vars() -> List[Var]:
    """The estimator's choice of the excitation's rate (native/src/excite_design.h;
    docs/identification.md, 'Excitation that buys information'): its parameters, the rate it
    asks of the plant and the scores it chose by."""
    return [
        Var("ident.excite_adapt", "parameter", "fixed", "Integer", None,
            "The excitation's rate chosen from the information: after the information filter's "
            "replay the estimator measures the information one window (ident.excite_window) "
            "adds at the plant's own rate, then asks for ident.excite_rate_try and measures "
            "again, and keeps the candidate where its predicted largest scaled Cramér-Rao "
            "bound at ident.excite_horizon (from the first sample) is below 0.85 times rate "
            "1's (output ident.excite_rate). 0 = automatic (on "
            "where the information filter runs and ident.excite_mode asks for excitation), "
            "1 = on (needs the information filter), 2 = off (rate 1)", 0, ("excite_adapt",)),
        Var("ident.excite_rate_try", "parameter", "fixed", "Real", "1",
            "The candidate rate tried against the plant's own (frequency multiplier of its "
            "excitation, in [0.1, 10], not 1)", 4.0, ("excite_rate_try",)),
        Var("ident.excite_window", "parameter", "fixed", "Real", "s",
            "Length of each window the information is measured over (> 0)", 30.0,
            ("excite_window",)),
        Var("ident.excite_settle", "parameter", "fixed", "Real", "s",
            "Time the plant takes to switch rates, not measured (>= 0; the project's plant "
            "switches through a dip of its level: 2 excite.ramp)", 20.0, ("excite_settle",)),
        Var("ident.excite_horizon", "parameter", "fixed", "Real", "s",
            "The run's length the bound is predicted for (> 0)", 300.0, ("excite_horizon",)),
        Var("ident.excite_rate", "output", "continuous", "Real", "1",
            "Excitation rate requested from the plant (wire to the plant input of the same "
            "name): frequency multiplier of its excitation, 1 = its own; "
            "ident.excite_rate_try while that is tried or chosen (ident.excite_adapt)", None,
            ("excite_rate",)),
        Var(f"diag.excite_score.{EXCITE_SCORES[0]}", "output", "continuous", "Real", "1",
            "The choice of the excitation's rate: predicted largest Cramér-Rao bound (relative "
            "to each estimate's error scale) at ident.excite_horizon with the rest of the run "
            "at rate 1; 0 before the choice", None, ("excite_score", EXCITE_SCORES[0])),
        Var(f"diag.excite_score.{EXCITE_SCORES[1]}", "output", "continuous", "Real", "1",
            "As diag.excite_score.rate_1, at ident.excite_rate_try", None,
            ("excite_score", EXCITE_SCORES[1])),
    ]


#: the estimator's accelerations' noise parameters (errors in variables): (measurement key,
#: interface name, unit, acceleration source that uses it)
SIGNAL_NOISE_PARAMETERS = (("a_S", "base.a", "m/s2", "measured"),
                           ("alpha_B", "base.alpha", "rad/s2", "measured"),
                           ("qdd", "arm.qdd", "rad/s2", "measured"),
                           ("v_S", "base.v", "m/s", "differenced"),
                           ("omega_B", "base.omega", "rad/s", "differenced"),
                           ("qd", "arm.qd", "rad/s", "differenced"))


def body_of(values: Mapping[str, float], prefix: str) -> RigidBody:
    """The rigid body held in values ``<prefix>.m``, ``<prefix>.b[1..3]``, ``<prefix>.Ixx`` ...
    (FMU parameters or a telemetry file's truth). Not checked here: the cores check their
    bodies (``Plant``, ``Identifier``) with the same names."""
    return RigidBody(float(values[f"{prefix}.m"]),
                     tuple(float(values[f"{prefix}.b[{i}]"]) for i in (1, 2, 3)),
                     tuple(float(values[f"{prefix}.{n}"]) for n in INERTIA_NAMES))


#: The 20 estimates (and truth parameters), in the order of ``Identifier.vector()``.
ESTIMATE_NAMES: Tuple[str, ...] = tuple(f"{who}.{p}" for who in BODIES for p in BODY_PARAMETERS)


@dataclass(frozen=True)
class BodyLayout:
    """Where one body's parameters sit in each of the estimator's vectors.

    The 20-vectors (estimates and truth in the order of :data:`ESTIMATE_NAMES`; the standard
    parameters ``[m, m b, I_O#]``; ``D(mu)`` = ``[m J(b)]``) share one shape, 10 entries per body:
    ``m``, then a first-order triple (``b`` or ``m b``), then six inertia entries (``I`` in
    :data:`INERTIA_NAMES` order, ``I_O#`` in :data:`SHARP_NAMES` order, or ``m bb``). The
    paper's ``mu = [m1, m1 b1, mn, mn bn]`` (8,) and ``theta = [I1#, In#]`` (12,) hold 4 and 6.
    """

    name: str            # 'base' | 'target'
    index: int           # 0 | 1
    vec: slice           # the body's 10 entries of a 20-vector
    m: int               # its mass
    first: slice         # b (estimates) or m b (standard parameters, D)
    mass_first: slice    # m and first: [m, b] or [m, m b]
    inertia: slice       # I (estimates), I_O# (standard parameters) or m bb (D)
    principal: slice     # Ixx, Iyy, Izz in the estimates
    mu: slice            # [m, m b] in the paper's mu (8,)
    mu_m: int
    mu_first: slice
    theta: slice         # I# in the paper's theta (12,)

    @classmethod
    def of(cls, name: str) -> "BodyLayout":
        k = BODIES.index(name)
        o, n_i = len(BODY_PARAMETERS) * k, len(INERTIA_NAMES)
        return cls(name, k, slice(o, o + 1 + 3 + n_i), o, slice(o + 1, o + 4), slice(o, o + 4),
                   slice(o + 4, o + 4 + n_i), slice(o + 4, o + 7), slice(4 * k, 4 * k + 4), 4 * k,
                   slice(4 * k + 1, 4 * k + 4), slice(n_i * k, n_i * k + n_i))


class ParameterLayout:
    """The estimator's parameter vectors, named: derived from :data:`ESTIMATE_NAMES` and the set
    of estimates a robot's model identifies.

    Parameters
    ----------
    identified : sequence of str
        The identified estimates (:func:`identified_estimates`); the others stay at their
        guesses. Default: all 20.

    Attributes
    ----------
    names : (20,) the estimate names;  bodies : (base, target) :class:`BodyLayout`
    n_mu, n_theta : 8, 12 (sizes of the paper's mu and theta)
    first_order : (20,) bool
        Masses and first moments (initial covariance ``P0_mu``); the rest are inertias
        (``P0_theta``).
    identified : (20,) bool
        Identified entries of the estimates (and of the standard parameters, where the inertia
        entries are in :data:`SHARP_NAMES` order: see ``standard_active``).
    mu_active, theta_active, standard_active : int arrays
        The identified entries of mu (8,), theta (12,) and the standard parameters (20,).
    rows_lin, rows_ang : int arrays
        The equation rows that carry information: the translation axes whose CoM offset is
        identified, the rotation axes whose principal moment is identified (planar: x, y and z).
    sharp_to_project : (6,) int
        ``I = I#[sharp_to_project]`` (the paper's order into :data:`INERTIA_NAMES` order).
    """

    n_mu, n_theta = 8, 12
    #: ``I = I#[SHARP_TO_PROJECT]``; ``I# = I[PROJECT_TO_SHARP]``
    sharp_to_project = np.array([SHARP_NAMES.index(n) for n in INERTIA_NAMES])
    project_to_sharp = np.argsort(sharp_to_project)

    def __init__(self, identified: Sequence[str] = ESTIMATE_NAMES):
        unknown = set(identified) - set(ESTIMATE_NAMES)
        if unknown:
            raise ValueError(f"not estimate names: {sorted(unknown)}")
        self.names = ESTIMATE_NAMES
        self.bodies = tuple(BodyLayout.of(b) for b in BODIES)
        self.base, self.target = self.bodies
        self.first_order = np.zeros(len(self.names), bool)
        for b in self.bodies:
            self.first_order[b.mass_first] = True
        self.identified = np.array([n in identified for n in self.names])
        mu, th, std = [], [], []
        for b in self.bodies:
            first = np.flatnonzero(self.identified[b.mass_first])        # m, b
            sharp = np.sort(self.sharp_to_project[self.identified[b.inertia]])
            mu += (b.mu.start + first).tolist()
            th += (b.theta.start + sharp).tolist()
            std += (b.m + first).tolist() + (b.inertia.start + sharp).tolist()
        self.mu_active, self.theta_active = np.array(mu, int), np.array(th, int)
        self.standard_active = np.array(std, int)
        self.rows_lin = np.flatnonzero(self.identified[self.base.first])
        self.rows_ang = np.flatnonzero(self.identified[self.base.principal])
        self.complete = bool(self.identified.all())

    @classmethod
    def for_robot(cls, robot: Robot) -> "ParameterLayout":
        return cls(identified_estimates(robot))

    def body(self, name: str) -> BodyLayout:
        return self.bodies[BODIES.index(name)]

    def index(self, name: str) -> int:
        """Position of an estimate name (``"target.Izz"``) in the 20-vectors."""
        return self.names.index(name)

    def per_body(self, vec: np.ndarray) -> Dict[str, np.ndarray]:
        """``{'base': (..., 10), 'target': (..., 10)}`` views of a (..., 20) vector (estimates,
        their standard deviations, errors)."""
        vec = np.asarray(vec)
        return {b.name: vec[..., b.vec] for b in self.bodies}

    def vector(self, base: RigidBody, target: RigidBody) -> np.ndarray:
        """Two bodies as one (20,) vector in the order of :data:`ESTIMATE_NAMES`."""
        out = np.empty(len(self.names))
        for b, body in zip(self.bodies, (base, target)):
            out[b.m] = body.mass
            out[b.first] = body.com
            out[b.inertia] = body.inertia
        return out

    def error_scale(self, truth: np.ndarray) -> np.ndarray:
        """Scale of the relative error of each entry of a (20,) vector (a truth, or an estimate
        for relative standard deviations). Never zero, so a relative error is never NaN:

        * mass: ``|m|`` (1 kg if zero);
        * CoM component: ``max(|b_i|, COM_SCALE_MIN)``: a CoM error is relative to the offset,
          but to at least 5 cm (an offset near zero would make any error look huge);
        * moment ``Ixx, Iyy, Izz``: ``|I_ii|`` (the body's largest moment if zero);
        * product of inertia: the body's largest moment ``Ixx, Iyy, Izz`` (``|I_ij|`` never
          exceeds it for a real body; a product near zero would make any error look huge).
          1 kg.m2 if all moments are zero.
        """
        scale = np.abs(np.asarray(truth, float))
        # one row per body (10 entries each, positions as the base's): a few whole-array
        # operations instead of a loop per body, as the estimator computes this every sample
        per = scale.reshape(len(self.bodies), -1)            # a view: written into scale
        b = self.base
        principal = per[:, b.principal]
        imax = principal.max(axis=1)
        imax[~(imax > 0.0)] = 1.0
        mass = per[:, b.m]                                   # a view
        mass[mass == 0.0] = 1.0
        per[:, b.first] = np.maximum(per[:, b.first], COM_SCALE_MIN)
        per[:, b.principal] = np.where(principal == 0.0, imax[:, None], principal)
        per[:, b.principal.stop:b.inertia.stop] = imax[:, None]   # the products of inertia
        return scale


#: the layout of a spatial robot's estimates (all 20 identified): the error metric's
LAYOUT = ParameterLayout()


def estimate_vector(base: RigidBody, target: RigidBody) -> np.ndarray:
    """Two bodies as one (20,) vector in the order of :data:`ESTIMATE_NAMES` (the truth that
    ``Identifier.vector()`` estimates)."""
    return LAYOUT.vector(base, target)


def error_scale(truth: np.ndarray) -> np.ndarray:
    """Scale of the relative error of each entry of a (20,) truth vector
    (:meth:`ParameterLayout.error_scale`)."""
    return LAYOUT.error_scale(truth)


def relative_errors(est: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """``|est - truth| / error_scale(truth)``; ``est`` (..., 20) in the order of
    :data:`ESTIMATE_NAMES`. Finite wherever ``est`` and ``truth`` are (also for a zero truth)."""
    truth = np.asarray(truth, float)
    return np.abs(np.asarray(est, float) - truth) / error_scale(truth)


def relative_errors_by_name(est: Mapping[str, float], truth: Mapping[str, float]
                            ) -> Dict[str, float]:
    """:func:`relative_errors` for mappings name -> value, for the names that have both an
    estimate and a truth (the scale of a missing truth entry is that of a zero truth)."""
    t = np.array([truth.get(n, 0.0) for n in ESTIMATE_NAMES], float)
    scale = error_scale(np.where(np.isfinite(t), t, 0.0))
    return {n: abs(float(est[n]) - float(truth[n])) / s
            for n, s in zip(ESTIMATE_NAMES, scale.tolist())
            if est.get(n) is not None and truth.get(n) is not None}


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


def feedback_connections() -> List[str]:
    """Names wired estimator output -> plant input of the same name (the excitation loop)."""
    return ["ident.excite", "ident.excite_rate"]


# ---------------------------------------------------------------------------------------------
# the sensors FMU (optional, between plant and estimator): docs/sensors.md
# ---------------------------------------------------------------------------------------------

#: prefix of the sensors FMU's inputs: ``true.<name>`` for each plant output ``<name>`` the
#: estimator reads
TRUE_PREFIX = "true."

#: Real noise parameters of the sensors FMU: name -> (unit, realistic default, description).
#: White noise and random walks are given by their density, expressed as the standard
#: deviation over 1 s (an angle random walk of d rad/sqrt(s) is a rate noise of d rad/s
#: averaged over 1 s; sampled at dt its standard deviation is d / sqrt(dt / 1 s)), so that
#: every parameter has an FMI unit. ``noise.scale`` multiplies every error magnitude below
#: (0 = ideal sensors).
NOISE_PARAMETERS: Dict[str, Tuple[str, float, str]] = {
    "noise.scale": ("1", 1.0, "Multiplies every error magnitude below: 0 = ideal sensors "
                    "(outputs equal inputs bit for bit), 1 = the realistic defaults"),
    "noise.gyro.arw": ("rad/s", 2.0e-5, "Gyro white rate noise averaged over 1 s, standard "
                       "deviation (angle random walk 0.07 deg/sqrt(h) = 2e-5 rad/sqrt(s), "
                       "fibre-optic gyro of an LN-200S class IMU)"),
    "noise.gyro.bias": ("rad/s", 4.8e-6, "Gyro initial bias, standard deviation per axis "
                        "(1 deg/h, fibre-optic gyro)"),
    "noise.gyro.rrw": ("rad/s", 2.0e-7, "Gyro bias random walk: standard deviation of the "
                       "bias change over 1 s (rate random walk, rad/s/sqrt(s))"),
    "noise.star.cross": ("rad", 9.7e-6, "Star tracker attitude noise about the base x and y "
                         "axes (cross-boresight), standard deviation (2 arcsec, ASTRO APS / "
                         "Hydra class)"),
    "noise.star.roll": ("rad", 4.8e-5, "Star tracker attitude noise about the base z axis "
                        "(boresight), standard deviation (10 arcsec)"),
    "noise.nav.r": ("m", 0.01, "Relative navigation position noise of S, standard deviation "
                    "per axis (close-range lidar / vision navigation)"),
    "noise.nav.v": ("m/s", 0.001, "Relative navigation velocity noise of S, standard "
                    "deviation per axis"),
    "noise.accel.vrw": ("m/s2", 5.0e-4, "Accelerometer white noise averaged over 1 s, "
                        "standard deviation (velocity random walk 0.03 m/s/sqrt(h) = 5e-4 "
                        "m/s/sqrt(s), LN-200S class)"),
    "noise.accel.bias": ("m/s2", 3.0e-3, "Accelerometer initial bias, standard deviation per "
                         "axis (300 micro-g, LN-200S class)"),
    "noise.accel.brw": ("m/s2", 5.0e-6, "Accelerometer bias random walk: standard deviation "
                        "of the bias change over 1 s"),
    "noise.alpha": ("rad/s2", 2.0e-4, "Angular acceleration noise (derived from the gyro), "
                    "standard deviation per axis"),
    "noise.enc.resolution": ("rad", 1.1984e-5, "Joint encoder quantisation step (19-bit "
                             "absolute encoder: 2 pi / 2^19)"),
    "noise.enc.q": ("rad", 5.0e-6, "Joint angle noise before quantisation, standard deviation"),
    "noise.enc.qd": ("rad/s", 1.0e-4, "Joint rate noise, standard deviation"),
    "noise.enc.qdd": ("rad/s2", 1.0e-3, "Joint acceleration noise, standard deviation"),
    "noise.thrust.scale": ("1", 0.02, "Thrust (force and torque) scale factor error, standard "
                           "deviation, drawn once per run (2 %, hydrazine / cold-gas thrusters)"),
    "noise.thrust.misalign": ("rad", 8.7e-3, "Thrust direction misalignment, standard "
                              "deviation per axis, drawn once per run (0.5 deg)"),
}


#: Integer parameters of the sensors FMU: name -> (default, description)
SENSOR_INTEGER_PARAMETERS: Dict[str, Tuple[int, str]] = {
    "seed": (0, "Seed of the random generators (the same seed gives the same run)"),
    "noise.delay": (0, "Sample delay: the outputs at t are the measurements of t - delay x "
                       "the communication step (0 = none; applies whatever noise.scale)"),
    "noise.imu": (1, "1 = an accelerometer / IMU measures base.a and base.alpha; 0 = absent: "
                     "both output 0 (use the momentum method, or accel_source = differenced)"),
}


def sensors_vars(robot: Robot, sc: Scenario) -> List[Var]:
    """All variables of the sensors FMU: inputs ``true.<name>`` for each measurement, outputs
    ``<name>`` (what the estimator reads), the noise parameters."""
    n = robot.n_joints
    v = [Var(TRUE_PREFIX + x.name, "input", "continuous", x.type, x.unit,
             "True value: " + x.description, x.start, x.key)
         for x in measurement_vars(n, "input")]
    v += [Var(x.name, "output", "continuous", x.type, x.unit, "Measured: " + x.description,
              None, x.key) for x in measurement_vars(n, "output")]
    v += [Var(name, "parameter", "fixed", "Real", unit, doc, default, ("noise", name))
          for name, (unit, default, doc) in NOISE_PARAMETERS.items()]
    v += [Var(name, "parameter", "fixed", "Integer", None, doc, default, ("noise", name))
          for name, (default, doc) in SENSOR_INTEGER_PARAMETERS.items()]
    return v


def sensor_connections(robot: Robot) -> List[Tuple[str, str]]:
    """``[(plant output, sensors input)]``: plant ``<name>`` -> sensors ``true.<name>``; the
    sensors output ``<name>`` goes to the estimator input of the same name."""
    return [(name, TRUE_PREFIX + name) for name in connections(robot)]


def sensors_dependencies(variables: Sequence[Var]) -> Dict[int, List[int]]:
    """``{output index: [input indices]}`` of the sensors FMU's variables (:func:`sensors_vars`,
    indices into ``variables``): the inputs each measurement is made from (its direct
    feedthrough; ``native/src/sensors.c``). Each signal element is measured from the same
    element of its true value, except that a row of ``base.A`` is turned by the star tracker's
    error (the row's three elements) and the thrust's scale factor and misalignment mix the
    three components of ``F``, ``M`` and ``J``."""
    index = {(v.causality, v.key): i for i, v in enumerate(variables)}
    mixed = ("F", "M", "J")
    deps: Dict[int, List[int]] = {}
    for i, v in enumerate(variables):
        if v.causality != "output":
            continue
        group, idx = v.key
        if group == "A":
            keys = [(group, (idx[0], j)) for j in range(3)]
        elif group in mixed:
            keys = [(group, j) for j in range(3)]
        else:
            keys = [v.key]
        deps[i] = [index[("input", k)] for k in keys]
    return deps

