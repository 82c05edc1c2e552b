"""Physical consistency of an estimated rigid body, and the projection onto real bodies.

A set of inertial parameters ``(m, b, I_c)`` (mass, centre-of-mass offset, inertia about the
centre of mass) belongs to a real mass distribution iff its 4x4 pseudo-inertia matrix

    J = [[Sigma_c + m b b^T, m b],      Sigma_c = tr(I_c)/2 * 1 - I_c
         [m b^T,             m  ]]      (the second moment of the mass about the CoM)

is positive definite (Wensing, Kim, Slotine, IEEE RA-L 2017). Its Schur complement with
respect to ``m`` is ``Sigma_c``, so

    J > 0   <=>   m > 0  and  Sigma_c > 0,

and ``Sigma_c > 0`` is exactly "I_c positive definite with strict triangle inequalities"
(the eigenvalues of ``Sigma_c`` are ``(I2 + I3 - I1) / 2`` and its two permutations).

The set of real bodies is therefore a product in the coordinates ``(m, b, Sigma_c)``:
``{m >= m_min} x R^3 x {Sigma_c >= s_min 1}``, and the Euclidean projection onto a product is
the product of the projections: clip the mass, keep the centre of mass, clip the eigenvalues of
``Sigma_c`` (the Frobenius-nearest matrix with eigenvalues >= s_min). That is
:func:`project_body`: a closed form, one 3x3 symmetric eigen-decomposition, constant cost, and
the identity (bit for bit) on a body that is already physical.

The estimator applies it to what it reports only; its least-squares state is never changed, so
the estimates stay the exact least-squares ones and converge to the truth as before, and the
projection stops acting as soon as the least-squares estimate is physical.

For a planar robot only ``m``, ``b_x``, ``b_y`` and ``Izz`` are identified; the other entries
are whatever the solver's prior left there (for the joint RLS, whose prior is about the body
frame origin, not even the guesses about the CoM). :func:`project_planar_body` keeps the
identified entries and moves only the others: since ``Izz = Sigma_xx + Sigma_yy`` is the trace
of the in-plane block of ``Sigma_c``, it clips that block's eigenvalues with their sum kept,
drops the out-of-plane couplings ``Sigma_xz``, ``Sigma_yz`` and clips ``Sigma_zz``.
"""
from __future__ import annotations

from typing import Tuple

import numpy as np

from . import report_kernels

__all__ = ["second_moment", "inertia_from_second_moment", "pseudo_inertia", "is_physical",
           "project_body", "project_planar_body"]

#: smallest eigenvalue of Sigma_c kept by the projection, relative to the largest |eigenvalue|
#: (a body this flat is still a real one: its inertia satisfies the strict triangle inequality)
REL_SIGMA_MIN = 1e-6
#: smallest mass kept by the projection, relative to the caller's mass scale
REL_MASS_MIN = 1e-6


def _six(M: np.ndarray) -> np.ndarray:
    return np.array([M[0, 0], M[1, 1], M[2, 2], M[0, 1], M[0, 2], M[1, 2]])


def second_moment(I6) -> np.ndarray:
    """``Sigma_c = tr(I_c)/2 * 1 - I_c`` (3, 3) from ``I6 = (Ixx, Iyy, Izz, Ixy, Ixz, Iyz)``.

    ``Sigma_c = integral of x x^T dm`` about the centre of mass [kg.m2] (compiled:
    :func:`.report_kernels.second_moment`).
    """
    return report_kernels.second_moment(np.ascontiguousarray(I6, dtype=float).reshape(6))


def inertia_from_second_moment(S: np.ndarray) -> np.ndarray:
    """``I_c = tr(Sigma_c) * 1 - Sigma_c`` as ``(Ixx, Iyy, Izz, Ixy, Ixz, Iyz)`` (6,)."""
    S = np.asarray(S, dtype=float)
    return _six(np.trace(S) * np.eye(3) - S)


def pseudo_inertia(m: float, b, I6) -> np.ndarray:
    """The 4x4 pseudo-inertia matrix ``J`` about the body frame origin (module docstring)."""
    b = np.asarray(b, dtype=float)
    J = np.empty((4, 4))
    J[:3, :3] = second_moment(I6) + m * np.outer(b, b)      # Sigma_O = Sigma_c + m b b^T
    J[:3, 3] = J[3, :3] = m * b                              # first moment h = m b
    J[3, 3] = m
    return J


def is_physical(m: float, b, I6) -> bool:
    """True iff ``(m, b, I6)`` is a real rigid body: finite, ``m > 0``, ``Sigma_c > 0``.

    Equivalent to the pseudo-inertia matrix being positive definite; tested by a Cholesky
    factorisation of ``Sigma_c`` (no tolerance: a body on the boundary, e.g. a rod, is not
    accepted; compiled: :func:`.report_kernels.is_physical`).
    """
    b = np.ascontiguousarray(b, dtype=float).reshape(3)
    I6 = np.ascontiguousarray(I6, dtype=float).reshape(6)
    return bool(report_kernels.is_physical(float(m), b, I6))


def project_body(m: float, b, I6, m_scale: float = 1.0) -> Tuple[float, np.ndarray, np.ndarray, bool]:
    """The nearest real rigid body to ``(m, b, I6)`` in the ``(m, b, Sigma_c)`` coordinates.

    Parameters
    ----------
    m : float
        Mass estimate [kg], finite, any sign.
    b : (3,) array_like
        Centre-of-mass offset [m], finite; kept as it is.
    I6 : (6,) array_like
        Inertia about the CoM ``(Ixx, Iyy, Izz, Ixy, Ixz, Iyz)`` [kg.m2], finite, any values.
    m_scale : float
        Mass scale [kg] (e.g. the initial guess) setting the smallest mass kept,
        ``REL_MASS_MIN * m_scale``.

    Returns
    -------
    m : float
    b : (3,) ndarray
    I6 : (6,) ndarray
    projected : bool
        False when the input was already physical; the outputs are then the inputs, exactly.
    """
    return _projected(report_kernels.project_body, _project_body_numpy, m, b, I6, m_scale)


def _projected(kernel, reference, m, b, I6, m_scale):
    """A projection in one compiled call ``kernel`` (:func:`.report_kernels.project_body` or
    ``project_planar_body``; ``report()`` projects at every sample while an estimate is not
    physical); its NumPy ``reference`` where the kernel's eigen-decomposition did not converge
    (non-finite input: as NumPy answers it)."""
    b = np.array(b, dtype=float)
    I6 = np.array(I6, dtype=float)
    m_out, I_out, projected, ok = kernel(
        float(m), np.ascontiguousarray(b).reshape(3), np.ascontiguousarray(I6).reshape(6),
        REL_MASS_MIN * abs(m_scale), REL_SIGMA_MIN)
    if not projected:
        return float(m), b, I6, False
    if ok:
        return float(m_out), b, I_out, True
    return reference(m, b, I6, m_scale)


def _project_body_numpy(m: float, b, I6, m_scale: float = 1.0):
    """:func:`project_body` in NumPy (LAPACK's eigen-decomposition): the reference of the
    compiled :func:`.report_kernels.project_body` and its fallback for non-finite input."""
    b = np.array(b, dtype=float)
    I6 = np.array(I6, dtype=float)
    if is_physical(m, b, I6):
        return float(m), b, I6, False
    # m >= m_min: projection onto a half-line
    m_min = REL_MASS_MIN * abs(m_scale)
    m_out = float(m) if m >= m_min else m_min
    # Sigma_c >= s_min 1: clip the eigenvalues (Frobenius-nearest), I_c = tr(S) 1 - S
    lam, V = np.linalg.eigh(second_moment(I6))
    s_min = REL_SIGMA_MIN * max(float(np.max(np.abs(lam))), np.finfo(float).tiny)
    S = (V * np.maximum(lam, s_min)) @ V.T
    return m_out, b, inertia_from_second_moment(0.5 * (S + S.T)), True


def project_planar_body(m: float, b, I6, m_scale: float = 1.0
                        ) -> Tuple[float, np.ndarray, np.ndarray, bool]:
    """A real rigid body with the identified entries of a planar estimate kept.

    Keeps ``m`` (unless below the mass floor of :func:`project_body`), ``b`` and ``Izz``; sets
    the unidentified ``Ixx``, ``Iyy``, ``Ixy``, ``Ixz``, ``Iyz`` so that ``Sigma_c > 0``: the
    in-plane block of ``Sigma_c`` gets its eigenvalues clipped at ``s_min`` with their sum
    (``Izz``) kept, ``Sigma_xz = Sigma_yz = 0``, ``Sigma_zz`` clipped at ``s_min``. An ``Izz`` too
    small for any real body (``Izz <= 2 s_min``) cannot be kept: :func:`project_body` then.

    Parameters and returns as :func:`project_body`.
    """
    return _projected(report_kernels.project_planar_body, _project_planar_body_numpy, m, b, I6,
                      m_scale)


def _project_planar_body_numpy(m: float, b, I6, m_scale: float = 1.0):
    """:func:`project_planar_body` in NumPy: the reference of the compiled
    :func:`.report_kernels.project_planar_body` and its fallback for non-finite input."""
    b = np.array(b, dtype=float)
    I6 = np.array(I6, dtype=float)
    if is_physical(m, b, I6):
        return float(m), b, I6, False
    S = second_moment(I6)
    lam, V = np.linalg.eigh(S[:2, :2])
    izz = float(I6[2])                                       # = trace of the in-plane block
    s_min = REL_SIGMA_MIN * max(float(np.max(np.abs(np.linalg.eigvalsh(S)))),
                                np.finfo(float).tiny)
    if not izz > 2.0 * s_min:
        return _project_body_numpy(m, b, I6, m_scale)
    if lam[0] < s_min:                                       # clip with the sum kept
        lam = np.array([s_min, izz - s_min])
    P = np.zeros((3, 3))
    P[:2, :2] = (V * lam) @ V.T
    P[2, 2] = max(float(S[2, 2]), s_min)
    m_min = REL_MASS_MIN * abs(m_scale)
    I_out = inertia_from_second_moment(0.5 * (P + P.T))
    I_out[2] = izz                                           # exact, not re-rounded
    return (float(m) if m >= m_min else m_min), b, I_out, True
