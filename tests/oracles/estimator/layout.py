"""The oracle's own description of the estimation problem, written independently of the library
(no ``spacerobot`` import): where each parameter sits in the oracle's vectors, which ones a
robot's model identifies, the error scale, the codes of the options, the estimator FMU's
parameter names the oracle reads, the guessed bodies, and the known arm as arrays.

Vectors of 20 estimates: per body (base, then target) ``m``, ``b`` (3), ``I`` (6: ``Ixx Iyy Izz
Ixy Ixz Iyz`` about the centre of mass). The paper's ``mu = [m1, m1 b1, mn, mn bn]`` (8) and
``theta = [I1#, In#]`` (12) with ``I# = [I11, I12, I13, I22, I23, I33]`` (eq. 21); the standard
parameters ``[m, m b, I_O#]`` per body (20).
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum
from typing import Mapping, Tuple

import numpy as np

#: smallest scale of a centre-of-mass component's relative error [m]
COM_SCALE_MIN = 0.05
#: the estimates' names, base then target
BODY_NAMES = ("m", "b[1]", "b[2]", "b[3]", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")
NAMES = tuple(f"{body}.{n}" for body in ("base", "target") for n in BODY_NAMES)
#: the planar model's identified entries of a body (x, y translation, z rotation)
PLANAR = ("m", "b[1]", "b[2]", "Izz")
#: the tensor entries (i, j) of I# (eq. 21), and of the estimates' Ixx Iyy Izz Ixy Ixz Iyz
SHARP_PAIRS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))
ESTIMATE_PAIRS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


class _Code(IntEnum):
    """An option's code: parsed from itself, its integer code or its lower-case label."""

    @classmethod
    def parse(cls, value, what: str):
        if isinstance(value, str):
            for c in cls:
                if c.name.lower() == value:
                    return c
        elif isinstance(value, (int, np.integer)) and not isinstance(value, bool):
            if int(value) in {int(c) for c in cls}:
                return cls(int(value))
        choices = ", ".join(f"{int(c)} ({c.name.lower()})" for c in cls)
        raise ValueError(f"{what} = {value!r} is not one of {choices}")


class Method(_Code):
    MOMENTUM = 1
    FORCE = 2


class Solver(_Code):
    PAPER = 1
    JOINT = 2


class AccelSource(_Code):
    MEASURED = 1
    DIFFERENCED = 2


class ExciteMode(_Code):
    OFF = 0
    UNTIL_IDENTIFIED = 1
    ALWAYS = 2


#: the row standard deviations' parameters ``ident.sd_row.<suffix>``: (suffix, method)
ROW_SD_PARAMETERS = (("momentum_lin", Method.MOMENTUM), ("momentum_ang", Method.MOMENTUM),
                     ("force_lin", Method.FORCE), ("force_ang", Method.FORCE))
#: the signals' noise parameters ``ident.noise.<name>``: (key, name, acceleration source)
SIGNAL_NOISE_PARAMETERS = (("a_S", "base.a", "measured"), ("alpha_B", "base.alpha", "measured"),
                           ("qdd", "arm.qdd", "measured"), ("v_S", "base.v", "differenced"),
                           ("omega_B", "base.omega", "differenced"),
                           ("qd", "arm.qd", "differenced"))


@dataclass(frozen=True)
class Body:
    """A rigid body: mass [kg], centre of mass (3) [m], inertia about it (6: Ixx Iyy Izz Ixy Ixz
    Iyz) [kg.m2]."""

    mass: float
    com: Tuple[float, float, float]
    inertia: Tuple[float, ...]

    def inertia_matrix(self) -> np.ndarray:
        I = np.empty((3, 3))
        for v, (i, j) in zip(self.inertia, ESTIMATE_PAIRS):
            I[i, j] = I[j, i] = v
        return I


@dataclass(frozen=True)
class Guess:
    """The guessed bodies and the initial covariances of the masses and first moments
    (``P0_mu``) and of the inertias (``P0_theta``)."""

    base: Body
    target: Body
    P0_mu: float
    P0_theta: float


def body_of(values: Mapping[str, float], prefix: str) -> Body:
    """The body of the parameter values ``<prefix>.m``, ``<prefix>.b[1..3]``, ``<prefix>.Ixx``
    ..."""
    return Body(float(values[f"{prefix}.m"]),
                tuple(float(values[f"{prefix}.b[{i}]"]) for i in (1, 2, 3)),
                tuple(float(values[f"{prefix}.{n}"]) for n in BODY_NAMES[4:]))


def arm_arrays(robot):
    """The known arm of a robot description (its ``links``: ``xyz``, ``rotation`` (9, row-major),
    ``axis``, ``body``; ``ee_xyz``, ``ee_rotation``) as the arrays of
    :func:`.kernels.equations`: ``(xyz (n, 3), R (n, 3, 3), axis (n, 3) unit, mass (n,),
    com (n, 3), I (n, 3, 3), ee_xyz (3,), ee_R (3, 3))``."""
    links = robot.links
    axis = np.array([l.axis for l in links], float)
    I = np.empty((len(links), 3, 3))
    for k, l in enumerate(links):
        for v, (i, j) in zip(l.body.inertia, ESTIMATE_PAIRS):
            I[k, i, j] = I[k, j, i] = v
    c = np.ascontiguousarray
    return (c([l.xyz for l in links], float), c([np.reshape(l.rotation, (3, 3)) for l in links],
                                                float),
            c(axis / np.sqrt((axis * axis).sum(axis=1))[:, None]), c([l.body.mass for l in links],
                                                                   float),
            c([l.body.com for l in links], float), c(I), c(robot.ee_xyz, float),
            c(np.reshape(robot.ee_rotation, (3, 3)), float))


@dataclass(frozen=True)
class BodySlots:
    """Where one body (``index`` 0 base, 1 target) sits in each vector: the 20-vectors (``vec``:
    ``m``, the first-order triple ``first``, ``mass_first`` = m and first, the six inertia entries
    ``inertia``, the principal moments ``principal``) and the paper's mu (``mu``, ``mu_m``,
    ``mu_first``) and theta (``theta``)."""

    name: str
    index: int
    vec: slice
    m: int
    first: slice
    mass_first: slice
    inertia: slice
    principal: slice
    mu: slice
    mu_m: int
    mu_first: slice
    theta: slice


def _slots(k: int) -> BodySlots:
    o, u, t = 10 * k, 4 * k, 6 * k
    return BodySlots(("base", "target")[k], k, slice(o, o + 10), o, slice(o + 1, o + 4),
                     slice(o, o + 4), slice(o + 4, o + 10), slice(o + 4, o + 7), slice(u, u + 4),
                     u, slice(u + 1, u + 4), slice(t, t + 6))


class Layout:
    """The identified parameters and equation rows of a robot's model: all 20 for a spatial
    robot; for a planar one (``robot.planar``) m, b[1], b[2], Izz of each body and the rows of
    the x, y translation and the z rotation.

    ``names``, ``bodies`` (two :class:`BodySlots`), ``n_mu`` 8, ``n_theta`` 12, ``first_order``
    (20, bool: masses and first moments), ``identified`` (20, bool), ``mu_active``,
    ``theta_active``, ``standard_active`` (the identified entries of mu, theta and the standard
    parameters), ``rows_lin``, ``rows_ang``, ``complete``, ``sharp_to_project`` (I = I#[it]),
    ``project_to_sharp``."""

    n_mu, n_theta = 8, 12
    sharp_to_project = np.array([SHARP_PAIRS.index(p) for p in ESTIMATE_PAIRS])
    project_to_sharp = np.array([ESTIMATE_PAIRS.index(p) for p in SHARP_PAIRS])

    def __init__(self, robot=None, planar: bool | None = None):
        planar = bool(robot.planar if planar is None else planar)
        self.names = NAMES
        self.bodies = (_slots(0), _slots(1))
        self.base, self.target = self.bodies
        self.first_order = np.array([i % 10 < 4 for i in range(20)])
        self.identified = np.array([not planar or n.split(".", 1)[1] in PLANAR for n in NAMES])
        self.complete = bool(self.identified.all())
        mu, th, std = [], [], []
        for b in self.bodies:
            for i in range(4):                                   # m, b -> mu, [m, m b]
                if self.identified[b.m + i]:
                    mu.append(b.mu_m + i)
                    std.append(b.m + i)
            sharp = sorted(int(self.sharp_to_project[i]) for i in range(6)
                           if self.identified[b.inertia.start + i])
            th += [b.theta.start + s for s in sharp]
            std += [b.inertia.start + s for s in sharp]
        self.mu_active, self.theta_active = np.array(mu, int), np.array(th, int)
        self.standard_active = np.array(std, int)
        base = self.base
        self.rows_lin = np.flatnonzero(self.identified[base.first])
        self.rows_ang = np.flatnonzero(self.identified[base.principal])

    def error_scale(self, vec) -> np.ndarray:
        """Scale of the relative error of each entry of a (20,) vector: |m| (1 if 0),
        max(|b_i|, COM_SCALE_MIN), |I_ii| (the body's largest |I_ii| if 0), and for the products
        of inertia the body's largest |I_ii| (1 if none is > 0)."""
        vec = np.abs(np.asarray(vec, float))
        out = np.empty(20)
        for b in self.bodies:
            v = vec[b.vec]
            moments = v[4:7]
            largest = float(np.max(moments))                     # (NaN: none)
            largest = largest if largest > 0.0 else 1.0
            out[b.m] = v[0] if v[0] != 0.0 else 1.0
            out[b.first] = np.maximum(v[1:4], COM_SCALE_MIN)
            out[b.principal] = np.where(moments == 0.0, largest, moments)
            out[b.inertia.start + 3:b.inertia.stop] = largest
        return out
