"""The sample's signals (``native/src/sample.h``: the one table of what the sensors measure and
the estimator takes) read from the native library: their keys, the FMU variables' names, units,
sizes and offsets in the flat sample.

Examples
--------
>>> [s.key for s in signals(6)][:3]                                       # doctest: +SKIP
['r_S', 'v_S', 'A']
>>> sample_length(6)                                                      # doctest: +SKIP
54
"""
from __future__ import annotations

import ctypes
from dataclasses import dataclass
from functools import lru_cache
from typing import Optional, Tuple

from . import lib as _default_lib

__all__ = ["Signal", "signals", "keys", "sample_length"]


@dataclass(frozen=True)
class Signal:
    """One signal of a robot of ``n`` joints: ``key`` (``"r_S"``), ``fmi_name`` (the FMU
    variables' name, ``"base.r"``, indexed ``[i]`` or ``[i,j]``), ``unit``, ``size`` (values)
    and ``offset`` in the flat sample."""

    key: str
    fmi_name: str
    unit: str
    size: int
    offset: int


def _bind(L: ctypes.CDLL) -> ctypes.CDLL:
    if getattr(L, "_sr_sample_bound", False):
        return L
    i, cp = ctypes.c_int, ctypes.c_char_p
    for name in ("sr_sample_signal_key", "sr_sample_signal_fmi_name", "sr_sample_signal_unit"):
        getattr(L, name).argtypes = [i]
        getattr(L, name).restype = cp
    for name in ("sr_sample_signal_size", "sr_sample_signal_offset"):
        getattr(L, name).argtypes = [i, i]
        getattr(L, name).restype = i
    L.sr_sample_signal_count.argtypes = []
    L.sr_sample_signal_count.restype = i
    L.sr_sample_length.argtypes = [i]
    L.sr_sample_length.restype = i
    L._sr_sample_bound = True
    return L


@lru_cache(maxsize=None)
def _signals(n: int, L: ctypes.CDLL) -> Tuple[Signal, ...]:
    L = _bind(L)
    return tuple(Signal(L.sr_sample_signal_key(k).decode(), L.sr_sample_signal_fmi_name(k).decode(),
                        L.sr_sample_signal_unit(k).decode(), L.sr_sample_signal_size(k, n),
                        L.sr_sample_signal_offset(k, n))
                 for k in range(L.sr_sample_signal_count()))


def signals(n_joints: int, lib: Optional[ctypes.CDLL] = None) -> Tuple[Signal, ...]:
    """The signals of a robot with ``n_joints`` joints, in the flat sample's order."""
    return _signals(int(n_joints), lib or _default_lib())


def keys(lib: Optional[ctypes.CDLL] = None) -> Tuple[str, ...]:
    """The signals' keys in the flat sample's order."""
    return tuple(s.key for s in signals(0, lib))


def sample_length(n_joints: int, lib: Optional[ctypes.CDLL] = None) -> int:
    """Values of the flat sample of a robot with ``n_joints`` joints."""
    return int(_bind(lib or _default_lib()).sr_sample_length(int(n_joints)))
