"""The maps between the estimator's parameterisations of the two bodies.

Positions in every vector come from :class:`.layout.Layout`:

* estimates (20,): per body ``m``, ``b`` (3), ``I`` (6, ``Ixx Iyy Izz Ixy Ixz Iyz``), CoM inertia;
* the paper's ``mu = [m1, m1 b1, mn, mn bn]`` (8,) and ``theta = [I1#, In#]`` (12,), with
  ``I# = [I11, I12, I13, I22, I23, I33]`` (eq. 21);
* ``D(mu) = [m1 J(b1); mn J(bn)]`` (20,), ``J(b) = [1, b, bx^2, bx by, bx bz, by^2, by bz, bz^2]``
  (eq. 23);
* the standard parameters ``[m, m b, I_O#]`` per body (20,), ``I_O = I_c + m(|b|^2 I - b b^T)``
  the inertia about the frame origin (Pinocchio's dynamic-parameter convention), in which every
  identification equation is linear.
"""
from __future__ import annotations

import numpy as np

from . import kernels, report_kernels
from .layout import Guess, Layout

LAYOUT = Layout(planar=False)

#: ``I = I#[SHARP_TO_PROJECT]`` (the paper's order into the project's); ``I# = I[PROJECT_TO_SHARP]``
SHARP_TO_PROJECT = LAYOUT.sharp_to_project
PROJECT_TO_SHARP = LAYOUT.project_to_sharp

#: positions in one body's own 10-vector (the base's: its block starts at 0)
_ONE = LAYOUT.base

#: index pairs (i, j) of the entries of I# (eq. 21)
SHARP_PAIRS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def sharp_vector(I: np.ndarray) -> np.ndarray:
    """``I#`` of eq. 21 from a symmetric 3x3 tensor."""
    return np.array([I[i, j] for i, j in SHARP_PAIRS])


def sharp_to_matrix(s: np.ndarray) -> np.ndarray:
    """3x3 tensor from ``I#``."""
    return np.array([[s[0], s[1], s[2]], [s[1], s[3], s[4]], [s[2], s[4], s[5]]])


def D_of_mu(mu: np.ndarray) -> np.ndarray:
    """``D(mu)`` (20,) from ``mu`` (8,) (compiled: :func:`.kernels.D_of_mu`)."""
    return kernels.D_of_mu(np.ascontiguousarray(mu, dtype=float))


def D_jacobian(mu: np.ndarray) -> np.ndarray:
    """``dD/dmu`` (20, 8), used to propagate the covariance of mu into theta.

    Per body with ``c = m b``: ``D = [m, c, c_i c_j / m (i <= j)]``, so
    ``d(c_i c_j / m) = -c_i c_j / m^2 dm + c_j / m dc_i + c_i / m dc_j`` (compiled:
    :func:`.report_kernels.D_jacobian`).
    """
    return report_kernels.D_jacobian(np.ascontiguousarray(mu, dtype=float))


def paper_vectors(g: Guess):
    """``(mu (8,), theta (12,))`` of the two guessed bodies."""
    mu, th = np.empty(LAYOUT.n_mu), np.empty(LAYOUT.n_theta)
    for b, body in zip(LAYOUT.bodies, (g.base, g.target)):
        mu[b.mu_m] = body.mass
        mu[b.mu_first] = body.mass * np.array(body.com)
        th[b.theta] = np.asarray(body.inertia)[PROJECT_TO_SHARP]
    return mu, th


def standard_from_physical(m: float, b: np.ndarray, I_c: np.ndarray) -> np.ndarray:
    """``[m, m b, I_O#]`` (10,) from mass, CoM offset and CoM inertia (3, 3)."""
    b = np.asarray(b, float)
    I_O = I_c + m * (b @ b * np.eye(3) - np.outer(b, b))      # parallel-axis theorem
    out = np.empty(_ONE.vec.stop)
    out[_ONE.m], out[_ONE.first], out[_ONE.inertia] = m, m * b, sharp_vector(I_O)
    return out


def physical_from_standard(pi: np.ndarray):
    """Inverse of :func:`standard_from_physical`: ``(m, b, I_c)``."""
    m = pi[_ONE.m]
    b = pi[_ONE.first] / m
    I_O = sharp_to_matrix(pi[_ONE.inertia])
    return m, b, I_O - m * (b @ b * np.eye(3) - np.outer(b, b))


def standard_vector(bodies) -> np.ndarray:
    """The standard parameters (20,) of two :class:`~spacerobot.robots.RigidBody`."""
    out = np.empty(len(LAYOUT.names))
    for b, body in zip(LAYOUT.bodies, bodies):
        out[b.vec] = standard_from_physical(body.mass, body.com, body.inertia_matrix())
    return out

