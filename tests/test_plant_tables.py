"""The plant's tables (native/src/plant.h) are the one source of its layouts, and the Python side
reads them:

* the parameter structs: every field's name and offset as the library reports them are the
  ones the C core reads: a value written by the Python binding into one field only, out of
  that field's range, is refused by the core with a message naming exactly that field (a
  field written at another field's offset, or two swapped fields, would name another one);
  the Python records (robots.Controller, Excitation, Propellant) have the C fields, in order;
* the ranges (sr_plant_param_range, spacerobot.core.plant.parameter_ranges): one for every
  Real parameter and input of the plant FMU (the names of spacerobot/interface.py, in its
  order), closed: both ends are accepted and the next double beyond either is refused (the
  inertia elements: a value beyond the implied bound makes every body with it refused); the
  default scenarios lie within them;
* the output vector: its first outputs are the sample's signals (sample.h: keys and sizes),
  its length 86 + 5 n for the shipped robots, its pieces contiguous.
"""
from __future__ import annotations

import ctypes
import dataclasses
import math

import numpy as np
import pytest

from spacerobot.core import lib as core_lib
from spacerobot.core.plant import NativePlant, fields, output_names, parameter_ranges
from spacerobot.interface import plant_vars
from spacerobot.core.tables import records
from spacerobot.robots import (DEPLETION_PROPELLANT, Appendages, Controller, Excitation, Panel,
                               Propellant, RigidBody, Slosh, SloshMode, parameter_set_scenario,
                               scenario)

RECORDS = {"controller": Controller, "excitation": Excitation, "propellant": Propellant,
           "flex": Panel, "slosh": SloshMode}


def _plant(sc, **change):
    """A NativePlant of scenario ``sc`` with some arguments replaced."""
    args = dict(robot=sc.robot, base=sc.robot.base, target=sc.target, controller=sc.controller,
                v0=sc.v0, omega0=sc.omega0, h=sc.h, excitation=sc.excitation,
                propellant=DEPLETION_PROPELLANT)
    args.update(change)
    return NativePlant(**args)


def _with(record, f, k, value):
    """``record`` with element ``k`` of field ``f`` set to ``value``."""
    if f.size == 1:
        return dataclasses.replace(record, **{f.name: value})
    vec = list(getattr(record, f.name))
    vec[k] = value
    return dataclasses.replace(record, **{f.name: tuple(vec)})


def _element(f, k, rec=None):
    """The FMI name of element k of field f (of record rec of a struct of several)."""
    if rec is None:
        return f.fmi if f.size == 1 else f"{f.fmi}[{k + 1}]"
    return f"{f.fmi}[{rec + 1}]" if f.size == 1 else f"{f.fmi}[{rec + 1},{k + 1}]"


def _changed(sc, table, f, k, value, rec):
    """The plant arguments with element k of field f of ``table``'s record (rec: of the
    panels' or slosh modes' record rec, none of them in use) set to value."""
    if table in ("flex", "slosh"):
        group = sc.flex if table == "flex" else sc.slosh
        recs = list(group.records(records(table)))
        recs[rec] = _with(recs[rec], f, k, value)
        new = Appendages(0, tuple(recs)) if table == "flex" else Slosh(0, tuple(recs))
        return {table: new}
    arg = {"controller": "controller", "excitation": "excitation",
           "propellant": "propellant"}[table]
    base_record = {"controller": sc.controller, "excitation": sc.excitation,
                   "propellant": DEPLETION_PROPELLANT}[table]
    return {arg: _with(base_record, f, k, value)}


@pytest.mark.parametrize("table", list(RECORDS))
def test_python_records_have_the_c_fields_in_order(table):
    c_names = [f.name for f in fields(table)]
    assert c_names == [x.name for x in dataclasses.fields(RECORDS[table])]
    # the layout the library reports: doubles, one after the other, without overlap
    at = 0
    for f in fields(table):
        assert f.offset == at and f.size in (1, 3), f
        at += 8 * f.size
    assert at == getattr(core_lib(), f"sr_plant_{table}_size")()


@pytest.mark.parametrize("table", list(RECORDS))
def test_each_field_is_read_by_the_core_where_python_writes_it(table):
    """Every element alone out of its range, by a margin and by one double: the core names
    that element (so the core reads it at the offset Python wrote it to, under its name); at
    both ends of its range it is accepted. The panels' and slosh modes' records: each of the
    FMU's records (none in use: the core checks them all)."""
    sc = scenario("spatial")
    recs = range(records(table)) if table in ("flex", "slosh") else [None]
    names = set()
    for rec in recs:
        for f in fields(table):
            for k in range(f.size):
                name = _element(f, k, rec)
                for bad in (f.max + 1.0 + abs(f.max), np.nextafter(f.max, math.inf),
                            np.nextafter(f.min, -math.inf), math.nan):
                    with pytest.raises(ValueError) as exc:
                        _plant(sc, **_changed(sc, table, f, k, float(bad), rec))
                    msg = str(exc.value)
                    assert msg.startswith(f"{name} must be within ["), (name, bad, msg)
                for good in (f.min, f.max):
                    _plant(sc, **_changed(sc, table, f, k, float(good), rec))
                names.add(name)
    assert len(names) == len(recs) * sum(f.size for f in fields(table))


def test_the_parameters_with_ranges_are_the_fmus_in_its_order():
    for sc in (scenario("planar"), parameter_set_scenario("spatial", "depletion"),
               parameter_set_scenario("spatial", "flexible")):
        vs = [v for v in plant_vars(sc.robot, sc) if v.causality in ("parameter", "input")]
        ranges = parameter_ranges()
        assert [v.name for v in vs] == list(ranges)
        for v in vs:
            lo, hi = ranges[v.name]
            assert lo <= v.start <= hi, (v.name, v.start, lo, hi)
    L = core_lib()
    lo, hi = ctypes.c_double(7.0), ctypes.c_double(7.0)
    for unknown in (b"base.b[4]", b"base.b[0]", b"base.b", b"prop.r[3]x", b"F_maxx", b"", None,
                    b"flex.m", b"flex.m[5]", b"flex.m[0]", b"flex.m[1,1]", b"flex.com[1]",
                    b"flex.com[1,4]", b"flex.com[5,1]", b"flex.com[1,1]x", b"flex.com[1,1,1]",
                    b"flex.n[1]", b"slosh.r[2,]", b"slosh.r[,2]", b"flex.com[12,1]"):
        assert L.sr_plant_param_range(unknown, ctypes.byref(lo), ctypes.byref(hi)) == 1
    assert lo.value == 7.0 and hi.value == 7.0


def _body_plant(sc, who, mass=None, com=None, inertia=None):
    body = sc.robot.base if who == "base" else sc.target
    body = RigidBody(body.mass if mass is None else mass, body.com if com is None else com,
                     body.inertia if inertia is None else inertia)
    return _plant(sc, **{who: body})


def test_ranges_of_the_other_parameters_are_closed():
    sc = scenario("spatial")
    r = parameter_ranges()
    below, above = (lambda x: np.nextafter(x, -math.inf)), (lambda x: np.nextafter(x, math.inf))
    # h, the initial velocities
    lo, hi = r["h"]
    for good in (lo, hi):
        _plant(sc, h=good)
    for bad in (below(lo), above(hi)):
        with pytest.raises(ValueError, match=r"^h must be within"):
            _plant(sc, h=bad)
    for name, arg in (("base.v0", "v0"), ("base.omega0", "omega0")):
        for k in range(3):
            lo, hi = r[f"{name}[{k + 1}]"]
            for value, ok in ((lo, True), (hi, True), (below(lo), False), (above(hi), False)):
                vec = list(getattr(sc, arg))
                vec[k] = value
                if ok:
                    _plant(sc, **{arg: vec})
                else:
                    with pytest.raises(ValueError, match=rf"^{name}\[{k + 1}\] must be within"):
                        _plant(sc, **{arg: vec})
    # the bodies: mass and centre of mass closed; an inertia element beyond its bound refused
    for who in ("base", "target"):
        lo, hi = r[f"{who}.m"]
        for good in (lo, hi):
            _body_plant(sc, who, mass=good)
        for bad in (below(lo), above(hi)):
            with pytest.raises(ValueError, match=rf"^{who}\.m must be"):
                _body_plant(sc, who, mass=bad)
        lo, hi = r[f"{who}.b[2]"]
        for good in (lo, hi):
            _body_plant(sc, who, com=(0.0, good, 0.0))
        for bad in (below(lo), above(hi)):
            with pytest.raises(ValueError, match=rf"^{who}\.b\[2\] must be"):
                _body_plant(sc, who, com=(0.0, bad, 0.0))
        dlo, dhi = r[f"{who}.Iyy"]
        plo, phi = r[f"{who}.Ixz"]
        assert (dlo, dhi) == r[f"{who}.Ixx"] == r[f"{who}.Izz"]
        assert (plo, phi) == r[f"{who}.Ixy"] == r[f"{who}.Iyz"] and plo == -phi
        _body_plant(sc, who, inertia=(dhi,) * 3 + (0.0,) * 3)         # principal moments at max
        _body_plant(sc, who, inertia=(dlo,) * 3 + (0.0,) * 3)         # ... at min
        for bad in ((above(dhi), dhi, dhi, 0.0, 0.0, 0.0), (below(dlo), dlo, dlo, 0.0, 0.0, 0.0),
                    (dhi, dhi, dhi, 0.0, above(phi), 0.0)):
            with pytest.raises(ValueError, match=rf"^{who} inertia"):
                _body_plant(sc, who, inertia=bad)
    # the inputs
    p = _plant(sc)
    for name, ask in (("ident.excite", p.set_excitation),
                      ("ident.excite_rate", p.set_excitation_rate)):
        lo, hi = r[name]
        for good in (lo, hi):
            ask(good)
        for bad in (below(lo), above(hi)):
            with pytest.raises(ValueError):
                ask(bad)


def test_output_vector_starts_with_a_sample_and_has_the_documented_length():
    L = core_lib()
    for f in (L.sr_sample_signal_key, L.sr_plant_output_name):
        f.restype = ctypes.c_char_p
    L.sr_sample_signal_count.restype = ctypes.c_int
    names = output_names()
    sample = [L.sr_sample_signal_key(i).decode() for i in range(L.sr_sample_signal_count())]
    assert list(names[:len(sample)]) == sample
    for robot in ("planar", "spatial"):
        sc = scenario(robot)
        p = _plant(sc)
        n = p.n
        slices = p.output_slices()
        assert list(slices) == list(names)
        at = 0
        for key, (a, b, _) in slices.items():
            assert a == at and b > a, key
            at = b
        assert at == p.output_vector().size == 86 + 5 * n
        for i, key in enumerate(sample):
            assert slices[key][1] - slices[key][0] == L.sr_sample_signal_size(i, n)
