"""The one check of a rigid body's parameters (``native/src/body.h``) bound with ctypes.

:func:`body_error` is ``sr_body_check``: the rule and the ranges (``BODY_LIMITS``) by which the
plant, the estimator and the Python library (:func:`spacerobot.robots.check_body`) accept a
body.
"""
from __future__ import annotations

import ctypes
from typing import Optional, Sequence

import numpy as np

from . import dptr, lib as _default_lib

__all__ = ["body_error"]

MSG_LEN = 512


def _bind(L: ctypes.CDLL) -> ctypes.CDLL:
    if not getattr(L, "_sr_body_bound", False):
        f = L.sr_body_check
        f.argtypes = [ctypes.c_char_p, ctypes.POINTER(ctypes.c_double), ctypes.c_char_p,
                      ctypes.c_size_t]
        f.restype = ctypes.c_int
        L._sr_body_bound = True
    return L


def body_error(name: str, g: Sequence[float], lib: Optional[ctypes.CDLL] = None) -> Optional[str]:
    """None when ``g`` (10: m [kg], b (3) [m], Ixx Iyy Izz Ixy Ixz Iyz [kg.m2]) is a body the
    project accepts, else the reason (naming the body ``name``)."""
    L = _bind(lib or _default_lib())
    arr = np.array([float(x) for x in g], dtype=np.float64)
    if arr.shape != (10,):
        return f"{name}: 10 parameters expected (m, b (3), 6 inertia elements), got {arr.size}"
    err = ctypes.create_string_buffer(MSG_LEN)
    if L.sr_body_check(name.encode("utf-8", "replace"), dptr(arr), err, MSG_LEN) == 0:
        return None
    return err.value.decode("utf-8", "replace")
