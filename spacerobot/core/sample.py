"""The sample's table of the native core (``native/src/sample.h``) through ctypes: the signals
of one flat sample, their keys, units and sizes, in the core's order. Python reads the layout
here instead of writing it again."""
from __future__ import annotations

import ctypes
from functools import lru_cache
from typing import List, Optional, Tuple

from . import lib

_bound = set()


def _bind(L: ctypes.CDLL) -> ctypes.CDLL:
    if id(L) in _bound:
        return L
    for name in ("sr_sample_signal_key", "sr_sample_signal_unit"):
        getattr(L, name).restype = ctypes.c_char_p
        getattr(L, name).argtypes = [ctypes.c_int]
    L.sr_sample_signal_count.restype = ctypes.c_int
    L.sr_sample_signal_size.argtypes = [ctypes.c_int, ctypes.c_int]
    L.sr_sample_length.argtypes = [ctypes.c_int]
    _bound.add(id(L))
    return L


@lru_cache(maxsize=None)
def signals(L: Optional[ctypes.CDLL] = None) -> Tuple[str, ...]:
    """The signals' keys in the flat sample's order: ``("r_S", "v_S", "A", ...)``."""
    L = _bind(L or lib())
    return tuple(L.sr_sample_signal_key(i).decode() for i in range(L.sr_sample_signal_count()))


def units(L: Optional[ctypes.CDLL] = None) -> Tuple[str, ...]:
    """Each signal's unit, in the order of :func:`signals`."""
    L = _bind(L or lib())
    return tuple(L.sr_sample_signal_unit(i).decode() for i in range(len(signals(L))))


def sizes(n: int, L: Optional[ctypes.CDLL] = None) -> List[Tuple[str, int]]:
    """``[(key, number of values)]`` of a robot with ``n`` joints (3, 9 or ``n``)."""
    L = _bind(L or lib())
    return [(key, L.sr_sample_signal_size(i, int(n))) for i, key in enumerate(signals(L))]


def length(n: int, L: Optional[ctypes.CDLL] = None) -> int:
    """Values in the flat sample of a robot with ``n`` joints."""
    return int(_bind(L or lib()).sr_sample_length(int(n)))
