"""The C plant's tables (``native/src/plant.h``) read from the library: the fields of its
parameter structs (C names, FMI names, units, descriptions, sizes, offsets, ranges), the keys of
its outputs and the ranges of every parameter and input of the plant FMU.

Tables only (names, numbers), no plant code: :mod:`spacerobot.interface` builds the plant FMU's
variables from them, :mod:`spacerobot.core.plant` packs its structs by them.
"""
from __future__ import annotations

import ctypes
from dataclasses import dataclass
from typing import Dict, Optional, Tuple

from . import lib as _default_lib

__all__ = ["Field", "fields", "records", "output_names", "parameter_ranges", "TABLES"]

#: the parameter structs of plant.h (enum sr_plant_table): one record each, but the panels'
#: (``flex``) and the slosh modes' (``slosh``), of which the FMU has :func:`records`
TABLES = {"controller": 0, "excitation": 1, "propellant": 2, "flex": 3, "slosh": 4}


def _bind_tables(L: ctypes.CDLL) -> ctypes.CDLL:
    """Declare the table functions on the library ``L`` (once)."""
    if getattr(L, "_sr_tables_bound", False):
        return L
    ci, cp, cd, sz = ctypes.c_int, ctypes.c_char_p, ctypes.c_double, ctypes.c_size_t
    dp = ctypes.POINTER(cd)
    sig = {
        "sr_plant_output_count": ([], ci),
        "sr_plant_output_name": ([ci], cp),
        "sr_plant_table_records": ([ci], ci),
        "sr_plant_field_count": ([ci], ci),
        "sr_plant_field_name": ([ci, ci], cp),
        "sr_plant_field_fmi_name": ([ci, ci], cp),
        "sr_plant_field_unit": ([ci, ci], cp),
        "sr_plant_field_description": ([ci, ci], cp),
        "sr_plant_field_size": ([ci, ci], ci),
        "sr_plant_field_offset": ([ci, ci], ctypes.c_long),
        "sr_plant_field_range": ([ci, ci, dp, dp], ci),
        "sr_plant_param_name": ([ci, cp, sz], ci),
        "sr_plant_param_range": ([cp, dp, dp], ci),
    }
    for name, (args, res) in sig.items():
        f = getattr(L, name)
        f.argtypes, f.restype = args, res
    L._sr_plant_fields = {}
    L._sr_tables_bound = True
    return L


@dataclass(frozen=True)
class Field:
    """A field of a parameter struct of the C plant (``plant.h``'s tables): its C name (the
    Python record's attribute), FMI name (a 3-vector's variables are ``<fmi>[1..3]``), unit,
    description, number of doubles, byte offset in the struct, and the range the core
    enforces."""

    name: str
    fmi: str
    unit: str
    description: str
    size: int
    offset: int
    min: float
    max: float


def fields(table: str, lib: Optional[ctypes.CDLL] = None) -> Tuple[Field, ...]:
    """The fields of the C struct ``table`` (``"controller"``, ``"excitation"``,
    ``"propellant"``, ``"flex"``, ``"slosh"``), in the order of the FMU's variables, read from
    the library."""
    L = _bind_tables(lib or _default_lib())
    cache = L._sr_plant_fields
    if table not in cache:
        t = TABLES[table]
        lo, hi = ctypes.c_double(), ctypes.c_double()
        out = []
        for i in range(L.sr_plant_field_count(t)):
            L.sr_plant_field_range(t, i, ctypes.byref(lo), ctypes.byref(hi))
            out.append(Field(L.sr_plant_field_name(t, i).decode(),
                             L.sr_plant_field_fmi_name(t, i).decode(),
                             L.sr_plant_field_unit(t, i).decode(),
                             L.sr_plant_field_description(t, i).decode(),
                             L.sr_plant_field_size(t, i), L.sr_plant_field_offset(t, i),
                             lo.value, hi.value))
        cache[table] = tuple(out)
    return cache[table]


def records(table: str, lib: Optional[ctypes.CDLL] = None) -> int:
    """How many records of the C struct ``table`` the plant FMU has: 1, the panels'
    (``flex``) and the slosh modes' (``slosh``) maximum counts (FMI names ``<fmi>[i]``,
    ``<fmi>[i,k]``)."""
    L = _bind_tables(lib or _default_lib())
    return int(L.sr_plant_table_records(TABLES[table]))


def output_names(lib: Optional[ctypes.CDLL] = None) -> Tuple[str, ...]:
    """The keys of the plant's outputs in the order of its output vector (``plant.h``)."""
    L = _bind_tables(lib or _default_lib())
    return tuple(L.sr_plant_output_name(k).decode() for k in range(L.sr_plant_output_count()))


def parameter_ranges(lib: Optional[ctypes.CDLL] = None) -> Dict[str, Tuple[float, float]]:
    """``{FMI name: (min, max)}``: the closed range the C core enforces for every parameter
    and input of the plant FMU (``sr_plant_param_range``; all Real but the Integer counts
    ``flex.n`` and ``slosh.n``), in the FMU's order. An inertia element's range is the bound
    the principal moments' range implies; the inputs' values outside theirs are clipped."""
    L = _bind_tables(lib or _default_lib())
    out = {}
    name = ctypes.create_string_buffer(64)
    lo, hi = ctypes.c_double(), ctypes.c_double()
    i = 0
    while L.sr_plant_param_name(i, name, len(name)) == 0:
        key = name.value.decode()
        if L.sr_plant_param_range(key.encode(), ctypes.byref(lo), ctypes.byref(hi)) != 0:
            raise RuntimeError(f"sr_plant_param_range does not know {key!r}")
        out[key] = (lo.value, hi.value)
        i += 1
    return out
