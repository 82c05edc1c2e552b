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

from ..core import physical as _native

__all__ = ["second_moment", "is_physical", "project_body", "project_planar_body"]

#: smallest eigenvalue of Sigma_c kept by the projection, relative to the largest |eigenvalue|
#: (a body this flat is still a real one: its inertia satisfies the strict triangle inequality;
#: SR_REL_SIGMA_MIN)
REL_SIGMA_MIN = 1e-6
#: smallest mass kept by the projection, relative to the caller's mass scale (SR_REL_MASS_MIN)
REL_MASS_MIN = 1e-6


def second_moment(I6) -> np.ndarray:
    """``Sigma_c = tr(I_c)/2 * 1 - I_c`` (3, 3) from ``I6 = (Ixx, Iyy, Izz, Ixy, Ixz, Iyz)``:
    ``Sigma_c = integral of x x^T dm`` about the centre of mass [kg.m2] (the core's
    ``sr_second_moment``)."""
    return _native.second_moment(I6)


def is_physical(m: float, b, I6) -> bool:
    """True iff ``(m, b, I6)`` is a real rigid body: finite, ``m > 0``, ``Sigma_c > 0``
    (equivalently the pseudo-inertia matrix positive definite; no tolerance: a body on the
    boundary, e.g. a rod, is not accepted; the core's ``sr_is_physical``)."""
    return _native.is_physical(m, b, I6)


def project_body(m: float, b, I6, m_scale: float = 1.0) -> Tuple[float, np.ndarray, np.ndarray, bool]:
    """The nearest real rigid body to ``(m, b, I6)`` in the ``(m, b, Sigma_c)`` coordinates
    (the module docstring; the core's ``sr_project_body``, what the estimator's report uses).

    The mass is clipped at ``REL_MASS_MIN * |m_scale|`` (pass the body's guessed mass), ``b``
    kept, the eigenvalues of ``Sigma_c`` clipped at ``REL_SIGMA_MIN`` times the largest
    |eigenvalue|.

    Returns
    -------
    m : float
    b : (3,) ndarray
    I6 : (6,) ndarray (NaN where the inertia is not finite: nothing to project)
    projected : bool
        False when the input was already physical; the outputs are then the inputs, exactly.
    """
    return _projected(_native.project_body, m, b, I6, m_scale)


def project_planar_body(m: float, b, I6, m_scale: float = 1.0
                        ) -> Tuple[float, np.ndarray, np.ndarray, bool]:
    """A real rigid body with the identified entries of a planar estimate kept (the core's
    ``sr_project_planar_body``).

    Keeps ``m`` (unless below the mass floor of :func:`project_body`), ``b`` and ``Izz``; sets
    the unidentified ``Ixx``, ``Iyy``, ``Ixy``, ``Ixz``, ``Iyz`` so that ``Sigma_c > 0``: the
    in-plane block of ``Sigma_c`` gets its eigenvalues clipped at ``s_min`` with their sum
    (``Izz``) kept, ``Sigma_xz = Sigma_yz = 0``, ``Sigma_zz`` clipped at ``s_min``. An ``Izz`` too
    small for any real body (``Izz <= 2 s_min``) cannot be kept: :func:`project_body` then.

    Parameters and returns as :func:`project_body`.
    """
    return _projected(_native.project_planar_body, m, b, I6, m_scale)


def _projected(kernel, m, b, I6, m_scale):
    """A projection in one native call ``kernel``; a non-finite inertia (the eigen-decomposition
    did not converge) gives NaN."""
    b = np.array(b, dtype=float)
    I6 = np.array(I6, dtype=float)
    m_out, I_out, projected, ok = kernel(float(m), b, I6, REL_MASS_MIN * abs(m_scale),
                                         REL_SIGMA_MIN)
    if not projected:
        return float(m), b, I6, False
    return float(m_out), b, (I_out if ok else np.full(6, np.nan)), True
