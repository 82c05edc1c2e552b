"""The native physical-consistency functions (``native/src/physical.h``) bound with ctypes:
whether an estimated body is a real rigid body, and its projection onto real bodies (what the
estimator's report does; :mod:`spacerobot.estimator.physical` is their Python face)."""
from __future__ import annotations

import ctypes
from typing import Optional, Tuple

import numpy as np

from . import dptr, lib as _default_lib

__all__ = ["second_moment", "is_physical", "project_body", "project_planar_body"]


def _bind(L: ctypes.CDLL) -> ctypes.CDLL:
    if getattr(L, "_sr_physical_bound", False):
        return L
    d, dp, ip = ctypes.c_double, ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_int)
    L.sr_is_physical.argtypes = [d, dp, dp]
    L.sr_is_physical.restype = ctypes.c_int
    L.sr_second_moment.argtypes = [dp, dp]
    L.sr_second_moment.restype = None
    for name in ("sr_project_body", "sr_project_planar_body"):
        f = getattr(L, name)
        f.argtypes = [d, dp, dp, d, d, dp, dp, ip]
        f.restype = ctypes.c_int
    L._sr_physical_bound = True
    return L


def _vec(x, n: int) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(x, dtype=float).reshape(n))


def second_moment(I6, lib: Optional[ctypes.CDLL] = None) -> np.ndarray:
    """``sr_second_moment``: Sigma_c (3, 3) of the inertia I6 (6)."""
    L = _bind(lib or _default_lib())
    I6, S = _vec(I6, 6), np.empty((3, 3))
    L.sr_second_moment(dptr(I6), dptr(S))
    return S


def is_physical(m: float, b, I6, lib: Optional[ctypes.CDLL] = None) -> bool:
    """``sr_is_physical``: finite, ``m > 0`` and ``Sigma_c`` positive definite."""
    L = _bind(lib or _default_lib())
    b, I6 = _vec(b, 3), _vec(I6, 6)
    return bool(L.sr_is_physical(float(m), dptr(b), dptr(I6)))


def _project(name: str, m, b, I6, m_min: float, rel_sigma_min: float,
             lib: Optional[ctypes.CDLL]) -> Tuple[float, np.ndarray, bool, bool]:
    """``(m, I6, projected, ok)`` of ``sr_project_body`` / ``sr_project_planar_body``
    (``ok``: the eigen-decomposition converged)."""
    L = _bind(lib or _default_lib())
    b, I6 = _vec(b, 3), _vec(I6, 6)
    m_out, I_out, projected = ctypes.c_double(), np.empty(6), ctypes.c_int()
    st = getattr(L, name)(float(m), dptr(b), dptr(I6), float(m_min), float(rel_sigma_min),
                          ctypes.byref(m_out), dptr(I_out), ctypes.byref(projected))
    return m_out.value, I_out, bool(projected.value), st == 0


def project_body(m, b, I6, m_min: float, rel_sigma_min: float,
                 lib: Optional[ctypes.CDLL] = None):
    """``sr_project_body``: ``(m, I6, projected, ok)``."""
    return _project("sr_project_body", m, b, I6, m_min, rel_sigma_min, lib)


def project_planar_body(m, b, I6, m_min: float, rel_sigma_min: float,
                        lib: Optional[ctypes.CDLL] = None):
    """``sr_project_planar_body``: ``(m, I6, projected, ok)``."""
    return _project("sr_project_planar_body", m, b, I6, m_min, rel_sigma_min, lib)
