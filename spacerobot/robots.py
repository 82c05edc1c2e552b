"""Robot and scenario definitions: the one description used by plant, estimator, SSP and tests.

Data and numpy (no Pinocchio, no FMI); the check of a body is the native core's
(:func:`check_body`). The robots
themselves are URDF files (``data/robots/``) that :mod:`spacerobot.urdf` reads into the
:class:`Robot` record, on first use of :data:`ROBOTS` (the FMUs get the record in their
configuration and never read a URDF).

Conventions (see docs/models.md, "Conventions"):

* Base frame ``B`` has its origin at the base sensor point ``S``; target frame ``T`` is the
  end-effector frame with origin at the grasp point ``E``.
* A :class:`RigidBody` holds the mass, the centre-of-mass offset ``b`` from the frame origin
  (in body coordinates) and the inertia tensor about the centre of mass, in body coordinates,
  as ``(Ixx, Iyy, Izz, Ixy, Ixz, Iyz)`` where ``Ixy`` is the tensor element (minus the
  product of inertia).
* Joint placements are given relative to the parent link frame; each arm joint is revolute
  about a unit ``axis`` expressed in its own (child) frame (URDF's joint ``<origin>`` and
  ``<axis>``).
* A robot is named by a key: ``planar``, ``spatial`` or a URDF file (:func:`robot_spec`).

Choices the paper leaves open are documented next to the numbers (``docs/models.md`` too).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from functools import lru_cache
from pathlib import Path
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

Vec3 = Tuple[float, float, float]
Inertia6 = Tuple[float, float, float, float, float, float]

#: Order of the 6 inertia components everywhere in this project.
INERTIA_NAMES = ("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")


def inertia_matrix(I6: Sequence[float]) -> np.ndarray:
    """3x3 symmetric tensor from ``(Ixx, Iyy, Izz, Ixy, Ixz, Iyz)``."""
    Ixx, Iyy, Izz, Ixy, Ixz, Iyz = (float(x) for x in I6)
    return np.array([[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], [Ixz, Iyz, Izz]])


def check_body(name: str, mass: float, com: Sequence[float], I6: Sequence[float]) -> None:
    """Raise ``ValueError`` with a readable message if the body is not one the project accepts.

    The rule of the native core (``native/src/body.h``, ``sr_body_check``): finite numbers,
    ``mass > 0``, inertia positive definite with principal moments satisfying the triangle
    inequality ``I1 <= I2 + I3`` (a real mass distribution), then the ranges of a real body
    (mass, centre of mass and principal moments; ``body.h``).
    """
    from .core.body import body_error
    com, I6 = list(com), list(I6)
    if len(com) != 3 or len(I6) != 6:
        raise ValueError(f"{name}: b needs 3 and the inertia 6 numbers, got b={com}, "
                         f"inertia={I6}")
    err = body_error(name, [mass, *com, *I6])
    if err is not None:
        raise ValueError(err)


@dataclass(frozen=True)
class RigidBody:
    """Inertial parameters of one rigid body.

    Attributes
    ----------
    mass : float
        Mass [kg].
    com : (3,) tuple
        Centre-of-mass offset ``b`` from the body frame origin, body coordinates [m].
    inertia : (6,) tuple
        Inertia about the centre of mass, body coordinates, ``(Ixx, Iyy, Izz, Ixy, Ixz, Iyz)``
        [kg.m2].
    """

    mass: float
    com: Vec3
    inertia: Inertia6

    def inertia_matrix(self) -> np.ndarray:
        return inertia_matrix(self.inertia)

    def check(self, name: str) -> None:
        check_body(name, self.mass, self.com, self.inertia)


def cuboid(mass: float, sx: float, sy: float, sz: float, com: Vec3 = (0.0, 0.0, 0.0)) -> RigidBody:
    """Uniform cuboid with edge lengths ``sx, sy, sz`` [m]."""
    k = mass / 12.0
    return RigidBody(mass, tuple(com), (k * (sy**2 + sz**2), k * (sx**2 + sz**2),
                                         k * (sx**2 + sy**2), 0.0, 0.0, 0.0))


def rot(axis: str, angle: float) -> np.ndarray:
    """Elementary rotation matrix about ``'x'``, ``'y'`` or ``'z'``."""
    c, s = math.cos(angle), math.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


@dataclass(frozen=True)
class ArmLink:
    """One revolute joint and the link it moves.

    Attributes
    ----------
    name : str
    xyz : (3,) tuple
        Joint frame origin in the parent frame [m] (parent = base frame for the first joint).
    rotation : (9,) tuple
        Row-major rotation parent -> joint frame at q = 0.
    axis : (3,) tuple
        Unit joint axis in the joint (child) frame.
    body : RigidBody
        Link inertial parameters in the joint frame.
    limits : (2,) tuple or None
        ``(lower, upper)`` joint limits [rad] when the description gives them (URDF
        ``<limit>``); they set the home posture and bound the excitation (see :func:`scenario`).
    """

    name: str
    xyz: Vec3
    rotation: Tuple[float, ...]
    axis: Vec3
    body: RigidBody
    limits: Optional[Tuple[float, float]] = None

    def R(self) -> np.ndarray:
        return np.array(self.rotation, dtype=float).reshape(3, 3)


@dataclass(frozen=True)
class Robot:
    """A free-floating space robot: base + serial revolute arm + end-effector frame.

    The captured target is not part of the robot; see :class:`Scenario`.
    """

    name: str
    planar: bool
    base: RigidBody
    links: Tuple[ArmLink, ...]
    ee_xyz: Vec3
    ee_rotation: Tuple[float, ...]
    q0: Tuple[float, ...]
    description: str = ""

    @property
    def n_joints(self) -> int:
        return len(self.links)

    def ee_R(self) -> np.ndarray:
        return np.array(self.ee_rotation, dtype=float).reshape(3, 3)

    def to_dict(self) -> dict:
        return asdict(self)

    @staticmethod
    def from_dict(d: dict) -> "Robot":
        links = tuple(ArmLink(name=l["name"], xyz=tuple(l["xyz"]), rotation=tuple(l["rotation"]),
                              axis=tuple(l["axis"]), body=_body(l["body"]),
                              limits=tuple(l["limits"]) if l.get("limits") else None)
                      for l in d["links"])
        return Robot(name=d["name"], planar=bool(d["planar"]), base=_body(d["base"]), links=links,
                     ee_xyz=tuple(d["ee_xyz"]), ee_rotation=tuple(d["ee_rotation"]),
                     q0=tuple(d["q0"]), description=d.get("description", ""))


def _body(d: dict) -> RigidBody:
    return RigidBody(float(d["mass"]), tuple(d["com"]), tuple(d["inertia"]))


# --------------------------------------------------------------------------------------------
# Built-in robots: the URDF files shipped in spacerobot/data/robots/ (read by spacerobot.urdf),
# plus what a URDF does not hold: the initial posture q0 and a description.
#
# planar: the paper's Table 2 was lost; the base is as the paper's results fix it (m = 500 kg,
# b = (0.10, -0.10) m, Izz = 83.61 kg.m2). The arm is ours: three revolute joints about z,
# links as slender rods (I = m l^2 / 12, a small Ixx, Izz = 1.01 Iyy), mounted on the +x face
# of a 1 m base; 1.0/1.0/0.5 m, 40/30/10 kg, typical of a 2-3 m manipulator on a 500 kg
# servicer and heavy enough (80 kg) for the arm to stabilise the base attitude (eq. 39).
#
# spatial: the paper's Table 3 masses and principal inertias; geometry PUMA-like and
# consistent with those inertias (slender links of 0.5, 0.72, 0.2, 0.2, 0.16 m along the axis
# of smallest inertia), mounted on the +y face of the 1 m base cube; at q = 0 it extends along
# +y. The base centre-of-mass offset b1 (fuel use) is our choice.
# --------------------------------------------------------------------------------------------

#: the folder of the shipped URDF files (planar.urdf, spatial.urdf, servicer7.urdf)
URDF_DIR = Path(__file__).resolve().parent / "data" / "robots"

#: built-in robot name -> (URDF file, initial posture q0 [rad], description)
BUILTIN_ROBOTS: Dict[str, Tuple[Path, Tuple[float, ...], str]] = {
    "planar": (URDF_DIR / "planar.urdf",
               (math.radians(30.0), math.radians(-60.0), math.radians(45.0)),
               "Planar free-floating robot: 500 kg base, 3-joint arm (1.0/1.0/0.5 m, "
               "40/30/10 kg), motion in x-y, rotation about z."),
    "spatial": (URDF_DIR / "spatial.urdf",
                (0.0, math.radians(-30.0), math.radians(60.0), 0.0, math.radians(-30.0), 0.0),
                "Spatial free-floating robot: 500 kg base (1 m cube), PUMA-like 6-joint arm "
                "with the paper's Table 3 masses and inertias."),
}


class _BuiltinRobots(Mapping):
    """``ROBOTS[name]``: the built-in robots, each read from its URDF on first use (so that
    importing this module, as the FMUs do, reads no file)."""

    def __init__(self):
        self._cache: Dict[str, Robot] = {}

    def __getitem__(self, name: str) -> Robot:
        if name not in self._cache:
            from .urdf import load_robot
            path, q0, description = BUILTIN_ROBOTS[name]
            self._cache[name] = replace(load_robot(path), name=name, q0=q0,
                                        description=description)
        return self._cache[name]

    def __iter__(self):
        return iter(BUILTIN_ROBOTS)

    def __len__(self) -> int:
        return len(BUILTIN_ROBOTS)


#: the built-in robots by name (``planar``, ``spatial``): aliases of their shipped URDF files
ROBOTS: Mapping[str, Robot] = _BuiltinRobots()


def __getattr__(name: str):
    """``PLANAR`` and ``SPATIAL``: ``ROBOTS["planar"]``, ``ROBOTS["spatial"]`` (read lazily)."""
    if name in ("PLANAR", "SPATIAL"):
        return ROBOTS[name.lower()]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# --------------------------------------------------------------------------------------------
# Robot keys: what the command line, the SSP builder, sweeps and Monte Carlo studies pass
# around. A key is a built-in name or a URDF file, optionally with the end-effector link and
# the motion model after '#': "arm.urdf", "arm.urdf#ee=tool0", "arm.urdf#ee=tool0&motion=planar".
# --------------------------------------------------------------------------------------------


def robot_spec(robot: str, ee: str | None = None, motion: str | None = None) -> str:
    """The key of ``robot`` (a built-in name or a URDF path) with the options of
    :func:`spacerobot.urdf.load_robot`; a path becomes absolute (keys travel to workers)."""
    if robot in BUILTIN_ROBOTS:
        if ee is not None or motion not in (None, "auto"):
            raise ValueError(f"--ee and --motion apply to a URDF file, not to the built-in "
                             f"robot {robot!r}")
        return robot
    path, opts = _split_spec(robot)
    if not path.endswith(".urdf") and not Path(path).is_file():
        raise ValueError(f"unknown robot {robot!r}: give {' or '.join(sorted(ROBOTS))} or a "
                         f".urdf file")
    if ee is not None:
        opts["ee"] = ee
    if motion not in (None, "auto"):
        opts["motion"] = motion
    key = str(Path(path).resolve())
    return key + ("#" + "&".join(f"{k}={v}" for k, v in sorted(opts.items())) if opts else "")


def _split_spec(key: str) -> Tuple[str, Dict[str, str]]:
    path, _, frag = key.partition("#")
    opts = {}
    for item in filter(None, frag.split("&")):
        k, eq, v = item.partition("=")
        if not eq or k not in ("ee", "motion"):
            raise ValueError(f"robot {key!r}: after '#' expected ee=LINK and/or motion=MODEL "
                             f"separated by '&', got {item!r}")
        opts[k] = v
    return path, opts


def get_robot(key: str) -> Robot:
    """The robot record of a key (built-in name, or URDF file with options, see
    :func:`robot_spec`); raises ``ValueError`` (a :class:`spacerobot.urdf.URDFError` for a bad
    URDF) naming what is wrong."""
    if key in BUILTIN_ROBOTS:
        return ROBOTS[key]
    path, opts = _split_spec(key)
    if not path.endswith(".urdf") and not Path(path).is_file():
        raise ValueError(f"unknown robot {key!r}: give {' or '.join(sorted(ROBOTS))} or a "
                         f".urdf file")
    p = Path(path)
    try:
        stamp = p.stat().st_mtime_ns
    except OSError as e:
        raise ValueError(f"robot {path}: {e.strerror or e}") from None
    return _load_urdf(str(p.resolve()), stamp, opts.get("ee"), opts.get("motion", "auto"))


@lru_cache(maxsize=32)
def _load_urdf(path: str, stamp: int, ee: str | None, motion: str) -> Robot:
    from .urdf import load_robot
    return load_robot(path, ee=ee, motion=motion)


def check_robot(key: str) -> None:
    """Raise ``ValueError`` if ``key`` names no usable robot (see :func:`get_robot`)."""
    get_robot(key)


def robot_kind(key: str) -> str:
    """``'planar'`` or ``'spatial'``: the table of defaults (targets, guesses, velocities,
    parameter sets) a robot takes. A built-in robot's own; a URDF robot's by its motion."""
    if key in BUILTIN_ROBOTS:
        return key
    return "planar" if get_robot(key).planar else "spatial"


def robot_label(key: str) -> str:
    """A short name for files and the SSD: the built-in name, or the URDF's robot name."""
    return key if key in BUILTIN_ROBOTS else get_robot(key).name


def robot_files(key: str) -> Tuple[Path, ...]:
    """The URDF file(s) a robot is read from (to know when a build is stale)."""
    if key in BUILTIN_ROBOTS:
        return (BUILTIN_ROBOTS[key][0],)
    return (Path(_split_spec(key)[0]),)

# --------------------------------------------------------------------------------------------
# Targets (rigidly grasped at E; parameters in the E frame).
# planar medium: fixed by the paper's results (250 kg, b = (0.25, 0.10) m, Izz = 10.41 kg.m2,
#   i.e. a 0.5 m cube of 250 kg). small/large are ours: 100 kg and 500 kg cubes of 0.4 m and
#   0.6 m held at their face centre (b_x = half the edge) with a lateral offset.
# spatial default: Table 3 (503.76 kg, diag 20.83 kg.m2, a 0.5 m cube); b_y = 0 as in the paper,
#   centre 0.25 m along the approach axis z of E plus a 0.1 m lateral x offset (our choice).
# --------------------------------------------------------------------------------------------

TARGETS: Dict[str, Dict[str, RigidBody]] = {
    "planar": {
        "small": replace(cuboid(100.0, 0.4, 0.4, 0.4), com=(0.20, 0.05, 0.0)),
        "medium": RigidBody(250.0, (0.25, 0.10, 0.0), (10.41, 10.41, 10.41, 0.0, 0.0, 0.0)),
        "large": replace(cuboid(500.0, 0.6, 0.6, 0.6), com=(0.30, 0.15, 0.0)),
    },
    "spatial": {
        "default": RigidBody(503.76, (0.10, 0.0, 0.25), (20.83, 20.83, 20.83, 0.0, 0.0, 0.0)),
    },
}

DEFAULT_TARGET = {"planar": "medium", "spatial": "default"}


@dataclass(frozen=True)
class Controller:
    """Bounded momentum controller (paper eqs. 40-41) and attitude law (eq. 39) gains.

    ``K_D``, ``K_P``: eq. 39 gains (diagonal). ``K_Dn``, ``K_Pn``: null-space posture gains that
    pull the arm back towards ``q0`` without disturbing the base attitude, and ``qdd_max``: bound
    on commanded joint accelerations [rad/s2] (our choices). The fields, their units and the
    ranges the plant accepts are the C plant's (``plant.h``, ``SR_PLANT_CONTROLLER_FIELDS``;
    :func:`spacerobot.core.plant.fields`), in its order.
    """

    F_max: float = 10.0
    K_F: float = -1.0
    P_max: float = 10.0
    M_max: float = 10.0
    K_M: float = -1.0
    L_max: float = 10.0
    K_D: float = math.sqrt(2.0) / 2.0
    K_P: float = 0.25
    K_Dn: float = 1.0
    K_Pn: float = 0.25
    qdd_max: float = 1.0


#: golden-ratio conjugate and sqrt(2): irrational steps that spread the excitation frequencies
#: and phases over their ranges without repeating (no two channels share a frequency)
_PHI = (math.sqrt(5.0) - 1.0) / 2.0
_SQRT2 = math.sqrt(2.0)


@dataclass(frozen=True)
class Excitation:
    """Bounded, persistently exciting motion the plant adds on request (input ``ident.excite``).

    Two references, each channel a sum of two sines at incommensurate frequencies in
    ``[w_f, 3 w_f]``, ``w_f = 2 pi / period``, scaled by the excitation level ``s(t)``:

    * base attitude (rotation vector about the initial attitude; z only for a planar robot),
      amplitude ``att_max`` per axis, tracked through the paper's arm law (eq. 39 becomes the
      error dynamics about the reference);
    * joint posture, ``q_home + s f_i(t)``, tracked by the null-space posture term, so the
      attitude task is not disturbed. The amplitude of each joint channel is the largest that
      keeps ``|q_ref - q_home| <= q_max``, ``|qd_ref| <= qd_max`` and ``|qdd_ref| <= qdd_max``,
      ramp included (see :meth:`channels`).

    ``s(t)`` moves from its current value to a new input value in ``ramp`` seconds along a
    quintic whose first and second derivatives vanish at both ends, so switching the
    excitation on or off never makes the references jump (nor, from a settled level, their
    accelerations).

    Attributes
    ----------
    att_max : float   amplitude bound of the base attitude reference, per axis [rad]
    q_max : float     amplitude bound of each joint reference about the home posture [rad]
    qd_max : float    bound on each joint reference rate [rad/s]
    qdd_max : float   bound on each joint reference acceleration [rad/s2]
    period : float    period of the slowest component, 2 pi / w_f [s]
    ramp : float      duration of a change of the excitation level [s]

    The fields, their units and the ranges the plant accepts are the C plant's (``plant.h``,
    ``SR_PLANT_EXCITATION_FIELDS``; :func:`spacerobot.core.plant.fields`), in its order.
    """

    att_max: float = 0.3
    q_max: float = 0.3
    qd_max: float = 0.2
    qdd_max: float = 0.1
    period: float = 30.0
    ramp: float = 10.0

    def ramp_bounds(self) -> Tuple[float, float]:
        """``(max |s'|, max |s''|)`` of the ramp of a unit change [1/s, 1/s2]: the quintic
        ``p(x) = 10 x^3 - 15 x^4 + 6 x^5`` has ``max p' = 15/8`` (x = 1/2) and
        ``max |p''| = 10/sqrt(3)`` (x = (3 -+ sqrt(3))/6)."""
        T = self.ramp
        return 15.0 / 8.0 / T, 10.0 / math.sqrt(3.0) / (T * T)

    def channels(self, n_att: int, n_joints: int) -> np.ndarray:
        """The reference channels as a ``(n_att + n_joints, 5)`` table.

        Row ``c``: ``(a, w1, phi1, w2, phi2)``; the channel is
        ``f_c(t) = a/2 [sin(w1 t + phi1) + sin(w2 t + phi2)]``, rows ``0..n_att-1`` the attitude
        axes, then the joints. ``|f| <= a``, ``|f'| <= a (w1 + w2)/2``,
        ``|f''| <= a (w1^2 + w2^2)/2``; with the level ``s`` (``0 <= s <= 1``, ``|s'| <= S1``,
        ``|s''| <= S2``) the joint reference ``s f`` has rate ``<= a (S1 + (w1 + w2)/2)`` and
        acceleration ``<= a (S2 + S1 (w1 + w2) + (w1^2 + w2^2)/2)``, and ``a`` is the largest
        value keeping these within ``qd_max``, ``qdd_max`` (and ``a <= q_max``).
        """
        wf = 2.0 * math.pi / self.period
        S1, S2 = self.ramp_bounds()
        tab = np.empty((n_att + n_joints, 5))
        for c in range(n_att + n_joints):
            k = 2 * c + 1
            w1 = wf * (1.0 + 2.0 * ((_PHI * k) % 1.0))          # in [w_f, 3 w_f)
            w2 = wf * (1.0 + 2.0 * ((_PHI * (k + 1)) % 1.0))
            p1 = 2.0 * math.pi * ((_SQRT2 * k) % 1.0)
            p2 = 2.0 * math.pi * ((_SQRT2 * (k + 1)) % 1.0)
            if c < n_att:
                a = self.att_max
            else:
                rate = S1 + 0.5 * (w1 + w2)
                acc = S2 + S1 * (w1 + w2) + 0.5 * (w1 * w1 + w2 * w2)
                a = min(self.q_max, self.qd_max / rate, self.qdd_max / acc)
            tab[c] = (a, w1, p1, w2, p2)
        return tab


#: standard gravity [m/s2]: converts a specific impulse [s] into an exhaust velocity
G0 = 9.80665


@dataclass(frozen=True)
class Propellant:
    """The base's propellant: one spherical tank whose content is used by the thrusters.

    Model (docs/models.md, "Propellant"): the propellant is a rigid sphere of liquid of mass
    ``m_p`` centred at ``r`` in the base frame, radius ``R`` (``R = 0``: a point mass), inertia
    ``(2/5) m_p R^2`` about its centre; it empties uniformly (its centre stays at ``r``). The
    base is the dry base (the ``base.*`` truth parameters) plus the propellant. The thrusters
    use ``dm_p/dt = -(|F_x| + |F_y| + |F_z| + (|M_x| + |M_y| + |M_z|) / arm) / (Isp g0)``:
    one thruster per inertial force axis, and per torque axis a couple of two thrusters
    ``arm`` apart (together ``|M_i| / arm`` of thrust). When the tank cannot feed a whole
    internal step the thrust of that step is scaled down so that the tank empties at its end;
    afterwards the thrusters are silent.

    ``m0 = 0`` switches the model off: the thrusters have an unmodelled supply and the base is
    constant (the paper's plant, bit for bit).

    Attributes
    ----------
    m0 : float     initial propellant mass [kg]
    Isp : float    specific impulse [s]
    R : float      tank radius [m]
    arm : float    distance between the two thrusters of a torque couple [m]
    r : (3,)       tank centre, base frame [m]

    The fields, their units and the ranges the plant accepts are the C plant's (``plant.h``,
    ``SR_PLANT_PROPELLANT_FIELDS``; :func:`spacerobot.core.plant.fields`), in its order.
    """

    m0: float = 0.0
    Isp: float = 220.0
    R: float = 0.0
    arm: float = 1.0
    r: Vec3 = (0.0, 0.0, 0.0)

    @property
    def active(self) -> bool:
        return self.m0 > 0.0

    def base(self, dry: RigidBody, m_p: float) -> RigidBody:
        """The base with ``m_p`` [kg] of propellant: mass, CoM and CoM inertia (base frame).

        ``m = m_d + m_p``; ``b = b_d + (m_p / m)(r - b_d)``;
        ``I = I_d + m_d S(b_d - b) + (2/5) m_p R^2 1 + m_p S(r - b)``, ``S(d) = |d|^2 1 - d d^T``
        (parallel axes). With ``m_p = 0`` the result is ``dry`` exactly.
        """
        m_p = float(m_p)
        m = dry.mass + m_p
        bd, r = np.asarray(dry.com, float), np.asarray(self.r, float)
        b = bd + (m_p / m) * (r - bd)
        dd, dp = bd - b, r - b
        I = (dry.inertia_matrix() + dry.mass * (dd @ dd * np.eye(3) - np.outer(dd, dd))
             + m_p * ((0.4 * self.R * self.R + dp @ dp) * np.eye(3) - np.outer(dp, dp)))
        return RigidBody(m, tuple(float(x) for x in b),
                         tuple(float(x) for x in (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2],
                                                  I[1, 2])))


@dataclass(frozen=True)
class Panel:
    """A hinged panel on the base (a solar wing, a radiator): a rigid body on a hinge with a
    torsional spring and damper, one flexible mode (docs/models.md, "Flexible appendages and
    slosh"). Geometry at rest (deflection 0) in the base frame B (origin S).

    Attributes
    ----------
    m : float           mass [kg]
    com : (3,)          centre of mass at rest [m]
    Ixx ... Iyz : float inertia about the centre of mass, base axes at rest [kg.m2]
    hinge : (3,)        a point of the hinge axis [m]
    axis : (3,)         hinge axis (normalised by the plant; a planar robot's: along z)
    f : float           cantilevered frequency (base held) [Hz]: k = I_h (2 pi f)^2, I_h the
                        inertia about the hinge axis
    zeta : float        damping ratio: c = 2 zeta (2 pi f) I_h
    q0, qd0 : float     initial deflection [rad] and rate [rad/s]

    The fields, their units and the ranges the plant accepts are the C plant's (``plant.h``,
    ``SR_PLANT_FLEX_FIELDS``; :func:`spacerobot.core.plant.fields`), in its order.
    """

    m: float
    com: Vec3
    Ixx: float
    Iyy: float
    Izz: float
    Ixy: float
    Ixz: float
    Iyz: float
    hinge: Vec3
    axis: Vec3
    f: float
    zeta: float = 0.005
    q0: float = 0.0
    qd0: float = 0.0

    def body(self) -> RigidBody:
        """The panel at rest as a :class:`RigidBody` in base axes."""
        return RigidBody(self.m, self.com, (self.Ixx, self.Iyy, self.Izz, self.Ixy, self.Ixz,
                                            self.Iyz))


def plate_panel(mass: float, hinge: Sequence[float], outward: Sequence[float],
                axis: Sequence[float], length: float, width: float, thickness: float = 0.03,
                f: float = 0.5, zeta: float = 0.005) -> Panel:
    """A uniform plate hinged along ``axis`` through ``hinge``, reaching ``length`` [m] from the
    hinge along ``outward`` (perpendicular to ``axis``), ``width`` [m] along the hinge, of
    ``thickness`` [m]: its centre of mass ``hinge + outward length / 2`` and its inertia
    ``m/12 (w^2 + t^2, L^2 + t^2, L^2 + w^2)`` about (outward, axis, their normal), turned into
    base axes."""
    u, a = (np.asarray(x, float) / np.linalg.norm(x) for x in (outward, axis))
    R = np.column_stack([u, a, np.cross(u, a)])
    k = mass / 12.0
    I = R @ np.diag([k * (width ** 2 + thickness ** 2), k * (length ** 2 + thickness ** 2),
                     k * (length ** 2 + width ** 2)]) @ R.T
    com = np.asarray(hinge, float) + u * (length / 2.0)
    clean = lambda x: float(x) + 0.0                                      # noqa: E731 (no -0.0)
    return Panel(float(mass), tuple(clean(x) for x in com),
                 *(clean(I[i, j]) for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))),
                 hinge=tuple(clean(x) for x in hinge), axis=tuple(clean(x) for x in a),
                 f=float(f), zeta=float(zeta))


@dataclass(frozen=True)
class SloshMode:
    """One lateral propellant slosh mode: the spring-mass equivalent (a point mass on a
    prismatic joint with a spring and damper; docs/models.md, "Flexible appendages and slosh").

    Attributes
    ----------
    m : float        slosh mass [kg] (with a propellant model part of the propellant)
    r : (3,)         equilibrium point, base frame [m]
    axis : (3,)      direction of motion (normalised by the plant; a planar robot's: in x-y)
    f : float        frequency with the base held [Hz]: k = m (2 pi f)^2
    zeta : float     damping ratio: c = 2 zeta (2 pi f) m
    x0, v0 : float   initial stroke [m] and rate [m/s]

    The fields, their units and the ranges the plant accepts are the C plant's (``plant.h``,
    ``SR_PLANT_SLOSH_FIELDS``), in its order.
    """

    m: float
    r: Vec3
    axis: Vec3
    f: float
    zeta: float = 0.01
    x0: float = 0.0
    v0: float = 0.0


#: the panels of the spatial robot's defaults: the issue's two solar wings (50 kg plates of
#: 4 m x 1.6 m hinged on the base's +-x faces along y, 0.5 Hz cantilevered, 0.5 % damping),
#: then two 10 kg radiators (1 m x 0.6 m on the -y face, hinged along z, 1.5 Hz, 1 %)
SPATIAL_PANELS: Tuple[Panel, ...] = (
    plate_panel(50.0, (0.5, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), 4.0, 1.6),
    plate_panel(50.0, (-0.5, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), 4.0, 1.6),
    plate_panel(10.0, (0.3, -0.5, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0), 1.0, 0.6,
                f=1.5, zeta=0.01),
    plate_panel(10.0, (-0.3, -0.5, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0), 1.0, 0.6,
                f=1.5, zeta=0.01),
)
#: the planar robot's: the same in its plane (hinged along z on the +-y faces, the wings
#: standing in the y-z plane), the radiators on the -x face
PLANAR_PANELS: Tuple[Panel, ...] = (
    plate_panel(50.0, (0.0, 0.5, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), 4.0, 1.6),
    plate_panel(50.0, (0.0, -0.5, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0), 4.0, 1.6),
    plate_panel(10.0, (-0.5, 0.3, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0), 1.0, 0.6,
                f=1.5, zeta=0.01),
    plate_panel(10.0, (-0.5, -0.3, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0), 1.0, 0.6,
                f=1.5, zeta=0.01),
)
#: the slosh modes of the spatial robot's defaults: the issue's 2 x 25 kg in one tank (along x
#: at 0.30 Hz, along y at 0.35 Hz, 1 % damping), then 2 x 10 kg in a second tank (0.40 and
#: 0.45 Hz)
SPATIAL_SLOSH: Tuple[SloshMode, ...] = (
    SloshMode(25.0, (-0.2, 0.1, -0.4), (1.0, 0.0, 0.0), 0.30, 0.01),
    SloshMode(25.0, (-0.2, 0.1, -0.4), (0.0, 1.0, 0.0), 0.35, 0.01),
    SloshMode(10.0, (0.25, -0.15, -0.35), (1.0, 0.0, 0.0), 0.40, 0.01),
    SloshMode(10.0, (0.25, -0.15, -0.35), (0.0, 1.0, 0.0), 0.45, 0.01),
)
#: the planar robot's: the same in its plane (z = 0)
PLANAR_SLOSH: Tuple[SloshMode, ...] = tuple(replace(s, r=(s.r[0], s.r[1], 0.0))
                                            for s in SPATIAL_SLOSH)


@dataclass(frozen=True)
class Appendages:
    """The base's flexible appendages: the first ``n`` of ``panels`` are on the spacecraft
    (``n = 0``, the default: none; the plant is then the rigid one bit for bit). The FMU has a
    fixed number of panel records (the C core's, 4): ``panels`` gives them (fewer are filled up
    with the defaults)."""

    n: int = 0
    panels: Tuple[Panel, ...] = SPATIAL_PANELS

    @property
    def active(self) -> Tuple[Panel, ...]:
        return tuple(self.panels[:self.n])

    def records(self, count: int) -> Tuple[Panel, ...]:
        """``count`` records (the FMU's, :func:`spacerobot.core.tables.records`): ``panels``
        filled up with the defaults; ``ValueError`` if there are more."""
        return _fill("flex", self.panels, SPATIAL_PANELS, count)


@dataclass(frozen=True)
class Slosh:
    """The propellant's slosh modes: the first ``n`` of ``modes`` move (``n = 0``, the default:
    none). With a propellant model (``Propellant.m0 > 0``) their masses are part of the
    propellant (docs/models.md)."""

    n: int = 0
    modes: Tuple[SloshMode, ...] = SPATIAL_SLOSH

    @property
    def active(self) -> Tuple[SloshMode, ...]:
        return tuple(self.modes[:self.n])

    def records(self, count: int) -> Tuple[SloshMode, ...]:
        """``count`` records (the FMU's): ``modes`` filled up with the defaults."""
        return _fill("slosh", self.modes, SPATIAL_SLOSH, count)


def _fill(what: str, given: Sequence, defaults: Sequence, count: int) -> tuple:
    if len(given) > count:
        raise ValueError(f"{what}: at most {count} records, got {len(given)}")
    return tuple(given) + tuple(defaults[len(given):count])


@dataclass(frozen=True)
class Guess:
    """Initial guesses and initial covariances of the estimator (paper §V defaults)."""

    base: RigidBody
    target: RigidBody
    P0_mu: float = 1e6
    P0_theta: float = 1e6


PAPER_GUESS = {
    "planar": Guess(RigidBody(600.0, (0.0, 0.0, 0.0), (100.0, 100.0, 100.0, 0.0, 0.0, 0.0)),
                    RigidBody(100.0, (0.1, 0.1, 0.0), (10.0, 10.0, 10.0, 0.0, 0.0, 0.0))),
    "spatial": Guess(RigidBody(600.0, (0.0, 0.0, 0.0), (100.0, 100.0, 100.0, 0.0, 0.0, 0.0)),
                     RigidBody(100.0, (0.1, 0.1, 0.1), (10.0, 10.0, 10.0, 0.0, 0.0, 0.0))),
}


@dataclass(frozen=True)
class Scenario:
    """Everything a run needs: robot, target truth, initial state, controller, estimator set-up."""

    name: str
    robot: Robot
    target: RigidBody
    v0: Vec3
    omega0: Vec3
    controller: Controller = field(default_factory=Controller)
    guess: Guess = None  # type: ignore[assignment]
    excitation: Excitation = field(default_factory=Excitation)
    h: float = 1e-3
    sample_time: float = 0.1
    stop_time: float = 30.0
    propellant: Propellant = field(default_factory=Propellant)
    flex: Appendages = field(default_factory=Appendages)
    slosh: Slosh = field(default_factory=Slosh)


def scenario_to_dict(sc: Scenario) -> dict:
    """JSON-able dict of a scenario (what the FMUs carry as their defaults)."""
    return asdict(sc)


def scenario_from_dict(d: dict) -> Scenario:
    """Inverse of :func:`scenario_to_dict`."""
    g = d["guess"]
    return Scenario(name=d["name"], robot=Robot.from_dict(d["robot"]), target=_body(d["target"]),
                    v0=tuple(d["v0"]), omega0=tuple(d["omega0"]),
                    controller=Controller(**d["controller"]),
                    guess=Guess(_body(g["base"]), _body(g["target"]), g["P0_mu"], g["P0_theta"]),
                    h=d["h"], sample_time=d["sample_time"], stop_time=d["stop_time"],
                    excitation=Excitation(**d.get("excitation", {})),
                    propellant=_propellant(d.get("propellant", {})),
                    flex=_appendages(d.get("flex")), slosh=_slosh(d.get("slosh")))


def _propellant(d: dict) -> Propellant:
    return Propellant(**{**d, **({"r": tuple(d["r"])} if "r" in d else {})})


def _tuples(d: dict) -> dict:
    """A record's dict with its lists (3-vectors) as tuples."""
    return {k: tuple(v) if isinstance(v, list) else v for k, v in d.items()}


def _appendages(d: Optional[dict]) -> Appendages:
    if d is None:
        return Appendages()
    return Appendages(int(d["n"]), tuple(Panel(**_tuples(p)) for p in d["panels"]))


def _slosh(d: Optional[dict]) -> Slosh:
    if d is None:
        return Slosh()
    return Slosh(int(d["n"]), tuple(SloshMode(**_tuples(m)) for m in d["modes"]))


#: An excitation with zero amplitudes: whatever level is requested, the plant moves as the
#: paper's (bit for bit, ``tests/test_excitation.py``).
NO_EXCITATION = Excitation(att_max=0.0, q_max=0.0)


@dataclass(frozen=True)
class ParameterSet:
    """A named parameter set of the generated SSP: a target and whether the plant excites;
    optionally a propellant, a stop time, and the estimator settings the set is meant for
    (``(name, value)`` pairs, bound to the estimator component from the set's
    ``resources/estimator/<set>.ssv``, :mod:`spacerobot.system.ssd`)."""

    target: str
    excited: bool
    description: str
    propellant: Propellant = field(default_factory=Propellant)
    stop_time: Optional[float] = None
    estimator: Tuple[Tuple[str, float], ...] = ()
    #: ``noise.scale`` of the sensors FMU (docs/sensors.md); None: not a sensors set (the set
    #: belongs to the plant + estimator system only)
    noise: float | None = None
    #: the number of the robot's default panels (``flex.n``) and slosh modes (``slosh.n``) on
    #: the spacecraft (docs/models.md, "Flexible appendages and slosh")
    flex: int = 0
    slosh: int = 0
    #: the initial velocities and the excitation's bounds, where the set has its own (None:
    #: the scenario's)
    v0: Optional[Vec3] = None
    omega0: Optional[Vec3] = None
    excitation: Optional[Excitation] = None


#: the ``depletion`` set's propellant: 80 kg of hydrazine (about 1000 kg/m3: a 0.27 m sphere)
#: off the base's centre, Isp 220 s (issue #17: about 0.28 kg per minute per 10 N)
DEPLETION_PROPELLANT = Propellant(m0=80.0, Isp=220.0, r=(0.3, 0.2, -0.2), R=0.27, arm=1.0)

#: the estimator settings of the ``depletion`` set: tracking (excitation always on, forgetting
#: factor below 1, the residual-correlation correction over the estimator's memory of 50
#: samples; the choice, and why the force-based method, in benchmarks/DEPLETION.md and
#: docs/identification.md section 7)
DEPLETION_ESTIMATOR = (("ident.excite_mode", 2), ("lambda", 0.98), ("ident.corr_lags", 50))
#: the estimator settings of the ``realistic`` sets: the noise profile of the sensors
#: (``ident.noise_profile`` = 1 with the sensors' realistic defaults, ``noise.scale`` as the
#: sensors') and the equations the noise benchmark found most accurate under them (force
#: method, accelerations differenced in the momentum equations; benchmarks/NOISE.md)
REALISTIC_ESTIMATOR = (("ident.noise_profile", 1), ("noise.scale", 1.0), ("method", 2),
                       ("accel_source", 2))


#: the motion of the sets with flexible parts (``wings``, ``slosh``, ``flexible``): the initial
#: velocities of a spacecraft after capture (0.37 m/s, 0.06 rad/s) and an excitation of 0.1 rad
#: (attitude and joints); over 300 s with the excitation on, the wings bend by up to 2.3
#: degrees, the slosh masses move by up to 20 cm and the flexible parts carry up to 10 N s and
#: 92 N m s (benchmarks/FLEXIBLE_PLANT.md; docs/models.md). The paper's spatial rates
#: (0.37 rad/s) would bend the wings by tens of degrees.
FLEXIBLE_MOTION = dict(v0=(0.3, -0.2, 0.1), omega0=(0.02, -0.03, 0.05),
                       excitation=Excitation(att_max=0.1, q_max=0.1))

#: The parameter sets of each robot's SSP (one ``.ssv`` each). The paper's scenarios keep the
#: excitation off (:data:`NO_EXCITATION`), so they reproduce the paper's figures with the
#: excitation loop wired; the others let the estimator's request move the plant. The sets with
#: a ``noise`` level (``ideal``, ``realistic``) belong to the system with the sensors FMU only.
PARAMETER_SETS: Dict[str, Dict[str, ParameterSet]] = {
    "planar": {
        "small": ParameterSet("small", False, "the paper's planar scenario, small target"),
        "medium": ParameterSet("medium", False, "the paper's planar scenario, medium target"),
        "large": ParameterSet("large", False, "the paper's planar scenario, large target"),
        "paper": ParameterSet("medium", False, "the paper's planar scenario (medium target), "
                                               "no excitation"),
        "excited": ParameterSet("medium", True, "medium target, excitation on request of the "
                                                "estimator"),
        "ideal": ParameterSet("medium", True, "medium target, excitation on request, ideal "
                                              "sensors", noise=0.0),
        "realistic": ParameterSet("medium", True, "medium target, excitation on request, "
                                                  "realistic sensor noise; the estimator's "
                                                  "noise profile (force method, differenced "
                                                  "accelerations)",
                                  estimator=REALISTIC_ESTIMATOR, noise=1.0),
    },
    "spatial": {
        "paper": ParameterSet("default", False, "the paper's spatial scenario, no excitation"),
        "default": ParameterSet("default", True, "the paper's spatial robot and target, "
                                                 "excitation on request of the estimator"),
        "depletion": ParameterSet("default", True, "the paper's spatial robot and target with "
                                                   "80 kg of propellant used by the thrusters "
                                                   "(5 min); meant for tracking with the "
                                                   "force-based method: estimator "
                                                   "ident.excite_mode=2, lambda=0.98, "
                                                   "ident.corr_lags=50",
                                  DEPLETION_PROPELLANT, 300.0, DEPLETION_ESTIMATOR),
        "ideal": ParameterSet("default", True, "the paper's spatial robot and target, "
                                               "excitation on request, ideal sensors", noise=0.0),
        "realistic": ParameterSet("default", True, "the paper's spatial robot and target, "
                                                   "excitation on request, realistic sensor "
                                                   "noise; the estimator's noise profile "
                                                   "(force method, differenced accelerations)",
                                  estimator=REALISTIC_ESTIMATOR, noise=1.0),
        "wings": ParameterSet("default", True, "the paper's spatial robot and target with two "
                                               "50 kg solar wings (4 m x 1.6 m, hinged, 0.5 Hz "
                                               "cantilevered, 0.5 % damping); excitation on "
                                               "request; truth.base.* is the composite rigid "
                                               "base", flex=2, **FLEXIBLE_MOTION),
        "slosh": ParameterSet("default", True, "the paper's spatial robot and target with 2 x "
                                               "25 kg of sloshing propellant (one tank, along x "
                                               "at 0.30 Hz, along y at 0.35 Hz, 1 % damping); "
                                               "excitation on request; truth.base.* is the "
                                               "composite rigid base", slosh=2,
                              **FLEXIBLE_MOTION),
        "flexible": ParameterSet("default", True, "the paper's spatial robot and target with "
                                                  "the two solar wings of 'wings' and the "
                                                  "slosh of 'slosh'; excitation on request; "
                                                  "truth.base.* is the composite rigid base",
                                 flex=2, slosh=2, **FLEXIBLE_MOTION),
    },
}


def parameter_set_scenario(robot: str, name: str) -> Scenario:
    """The scenario of parameter set ``name`` of ``robot`` (:data:`PARAMETER_SETS` of its
    :func:`robot_kind`)."""
    sets = PARAMETER_SETS[robot_kind(robot)]
    if name not in sets:
        raise ValueError(f"unknown parameter set {name!r} for robot {robot_label(robot)!r}; "
                         f"choose from {sorted(sets)}")
    ps = sets[name]
    sc = scenario(robot, ps.target)
    excitation = ps.excitation or sc.excitation
    return replace(sc, name=f"{robot_label(robot)}-{name}",
                   excitation=excitation if ps.excited else NO_EXCITATION,
                   v0=ps.v0 or sc.v0, omega0=ps.omega0 or sc.omega0,
                   propellant=ps.propellant, stop_time=ps.stop_time or sc.stop_time,
                   flex=replace(sc.flex, n=ps.flex), slosh=replace(sc.slosh, n=ps.slosh))


def excitation_within_limits(robot: Robot, excitation: Excitation = Excitation()) -> Excitation:
    """``excitation`` with its joint amplitude ``q_max`` reduced so that the excitation keeps
    every joint within its limits about the home posture ``q0`` (``ArmLink.limits``; joints
    without limits do not bound it)."""
    margin = [min(q - l.limits[0], l.limits[1] - q)
              for q, l in zip(robot.q0, robot.links) if l.limits is not None]
    if not margin:
        return excitation
    return replace(excitation, q_max=max(0.0, min(excitation.q_max, *margin)))


def scenario(robot: str = "planar", target: str | None = None, **overrides) -> Scenario:
    """The paper's scenario for ``robot`` with the named target; keyword overrides replace fields.

    ``robot`` is a built-in name or a URDF robot key (:func:`robot_spec`). A URDF robot takes
    the defaults of its kind (:func:`robot_kind`: the planar or the spatial robot's targets,
    guesses, initial velocities, controller and stop time), its home posture from the URDF
    (the middle of the joint limits, 0 without limits) and an excitation whose joint amplitude
    keeps the joints within their limits (:func:`excitation_within_limits`).

    Examples
    --------
    >>> scenario("planar", "medium").target.mass
    250.0
    """
    kind, rb = robot_kind(robot), get_robot(robot)
    target = target or DEFAULT_TARGET[kind]
    if target not in TARGETS[kind]:
        raise ValueError(f"unknown target {target!r} for robot {robot_label(robot)!r}; "
                         f"choose from {sorted(TARGETS[kind])}")
    if kind == "planar":
        base = dict(v0=(1.0, 2.0, 0.0), omega0=(0.0, 0.0, 0.1), stop_time=30.0,
                    flex=Appendages(0, PLANAR_PANELS), slosh=Slosh(0, PLANAR_SLOSH))
    else:
        base = dict(v0=(10.0, 20.0, 30.0), omega0=(0.1, 0.2, 0.3), stop_time=60.0,
                    flex=Appendages(0, SPATIAL_PANELS), slosh=Slosh(0, SPATIAL_SLOSH))
    base.update(name=f"{robot_label(robot)}-{target}", robot=rb, target=TARGETS[kind][target],
                guess=PAPER_GUESS[kind])
    if robot not in BUILTIN_ROBOTS:
        base.update(excitation=excitation_within_limits(rb))
    base.update(overrides)
    return Scenario(**base)


# --------------------------------------------------------------------------------------------
# Random real cases (Monte Carlo study): bodies a user might capture, not the paper's.
# --------------------------------------------------------------------------------------------

#: ranges of :func:`random_scenario` (masses [kg], box edges [m], CoM offset [m], tumbling
#: [rad/s], drift [m/s])
RANDOM_RANGES = {
    "base_mass": (400.0, 700.0), "base_edge": (0.6, 1.6),
    "target_mass": (50.0, 600.0), "target_edge": (0.3, 1.0),
    "com_offset": (0.02, 0.3), "omega0": (0.0, 0.2), "v0": (0.0, 5.0),
}


def _random_direction(rng: np.random.Generator, planar: bool) -> np.ndarray:
    """Unit vector uniform on the sphere (on the x-y circle when planar)."""
    if planar:
        a = rng.uniform(0.0, 2.0 * math.pi)
        return np.array([math.cos(a), math.sin(a), 0.0])
    d = rng.normal(size=3)
    return d / np.linalg.norm(d)


def _random_rotation(rng: np.random.Generator, planar: bool) -> np.ndarray:
    """Rotation uniform on SO(3) (about z only when planar)."""
    if planar:
        return rot("z", rng.uniform(0.0, 2.0 * math.pi))
    qv = rng.normal(size=4)
    x, y, z, w = qv / np.linalg.norm(qv)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def random_body(rng: np.random.Generator, mass_range, edge_range, planar: bool) -> RigidBody:
    """A uniform box of random mass and edges, turned by a random rotation ``R`` and with a
    random CoM offset: ``I_c = R diag(I_box) R^T`` (non-zero products of inertia, and a real
    body by construction: a box's principal moments obey the triangle inequality)."""
    m = rng.uniform(*mass_range)
    box = cuboid(m, *rng.uniform(*edge_range, size=3))
    R = _random_rotation(rng, planar)
    I = R @ box.inertia_matrix() @ R.T
    com = _random_direction(rng, planar) * rng.uniform(*RANDOM_RANGES["com_offset"])
    return RigidBody(float(m), tuple(float(c) for c in com),
                     tuple(float(x) for x in (I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])))


def random_scenario(robot: str, rng: np.random.Generator, name: str | None = None) -> Scenario:
    """A random real case for ``robot``: base, target and initial tumbling drawn from
    :data:`RANDOM_RANGES`; the robot's arm, the paper's guesses and controller, 60 s.

    Deterministic given the generator's state (``np.random.default_rng(seed)``). For the planar
    robot, offsets lie in x-y, inertia tensors are turned about z only, and the initial motion
    is a z rotation and an x-y drift.
    """
    rb = get_robot(robot)
    planar, rr = rb.planar, RANDOM_RANGES
    base = random_body(rng, rr["base_mass"], rr["base_edge"], planar)
    target = random_body(rng, rr["target_mass"], rr["target_edge"], planar)
    omega0 = _random_direction(rng, planar) * rng.uniform(*rr["omega0"])
    if planar:
        omega0 = np.array([0.0, 0.0, omega0[0]])   # signed rate about z
    v0 = _random_direction(rng, planar) * rng.uniform(*rr["v0"])
    return Scenario(name=name or f"{robot_label(robot)}-random", robot=replace(rb, base=base),
                    target=target, v0=tuple(float(x) for x in v0),
                    omega0=tuple(float(x) for x in omega0), guess=PAPER_GUESS[robot_kind(robot)],
                    stop_time=60.0, **({} if robot in BUILTIN_ROBOTS
                                       else dict(excitation=excitation_within_limits(rb))))


#: The values the paper prints for the planar medium target (Section V.A.1), CoM inertia Izz.
PAPER_PLANAR_MEDIUM = {
    "momentum": {"base.m": 500.00, "base.b[1]": 0.10, "base.b[2]": -0.10, "base.Izz": 83.61,
                 "target.m": 250.00, "target.b[1]": 0.25, "target.b[2]": 0.10, "target.Izz": 10.41},
    "force": {"base.m": 500.01, "base.b[1]": 0.10, "base.b[2]": -0.10, "base.Izz": 83.62,
              "target.m": 249.99, "target.b[1]": 0.25, "target.b[2]": 0.10, "target.Izz": 10.34},
}
