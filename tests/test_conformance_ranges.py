"""Interface conformance: the ``min`` / ``max`` of the parameters and inputs.

For every FMU whose core gives its ranges (``spacerobot.fmi.native.MODELS[kind].ranges``), in
FMI 2.0 and FMI 3.0:

- every Real and Integer parameter and input declares ``min`` and ``max``, and its start value
  lies between them (FMI 2.0 and 3.0 ask for min <= start <= max), as fmpy's validation of the
  whole model description also finds;
- the bounds are the core's own: each equals what the core's range function answers for the
  name (``spacerobot.core.<module>.parameter_ranges()``), and FMI 3.0 declares the same as
  FMI 2.0;
- the FMU refuses a value just outside: a parameter one step beyond a bound (the next double,
  or the next integer) makes fmi2ExitInitializationMode return fmi2Error with a logged error
  naming it; an input beyond a bound is reported in a logged warning or error naming it when
  the FMU steps.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from test_conformance_util import ERROR, OK, WARNING, Inst
from test_conformance_util import free_instances  # noqa: F401  (autouse fixture)

from spacerobot.fmi.native import MODELS, build_native_fmu, variable_ranges
from spacerobot.robots import scenario

KINDS = [k for k, m in MODELS.items() if m.ranges]
INT32 = (-2**31, 2**31 - 1)


@pytest.fixture(scope="module", params=KINDS)
def kind(request):
    return request.param


@pytest.fixture(scope="module")
def fmus(kind, tmp_path_factory):
    d = tmp_path_factory.mktemp(f"ranges_{kind}")
    sc = scenario("spatial")
    return {v: build_native_fmu(kind, sc, d / f"fmi{v}", fmi_version=v) for v in (2, 3)}


def _declared(path):
    from fmpy import read_model_description
    return [v for v in read_model_description(str(path)).modelVariables
            if v.causality in ("parameter", "input")]


@pytest.mark.slow
def test_every_parameter_and_input_declares_min_and_max_around_its_start(kind, fmus):
    from fmpy.validation import validate_fmu

    ranges = variable_ranges(kind)
    for version, path in fmus.items():
        assert validate_fmu(str(path)) == [], version
        declared = _declared(path)
        assert declared
        for v in declared:
            assert v.min is not None and v.max is not None, (version, v.name)
            lo, hi, start = float(v.min), float(v.max), float(v.start)
            assert lo <= start <= hi, (version, v.name, lo, start, hi)
            assert (lo, hi) == ranges[v.name], (version, v.name)   # the core's, exactly
    fmi2 = {v.name: (v.min, v.max) for v in _declared(fmus[2])}
    fmi3 = {v.name: (v.min, v.max) for v in _declared(fmus[3])}
    assert fmi2 == fmi3


def test_a_start_value_outside_the_range_is_not_packaged(kind, fmus, monkeypatch, tmp_path):
    """The build checks min <= start <= max: a default outside the core's range fails it."""
    from spacerobot.fmi import native

    ranges = variable_ranges(kind)
    name = next(v.name for v in _declared(fmus[2]) if v.causality == "parameter")
    lo, hi = ranges[name]
    monkeypatch.setattr(native, "variable_ranges",
                        lambda k: {**ranges, name: (lo, lo)} if k == kind else {})
    sc = scenario("spatial")
    start = next(v.start for v in _declared(fmus[2]) if v.name == name)
    if start == lo:
        monkeypatch.setattr(native, "variable_ranges",
                            lambda k: {**ranges, name: (hi, hi)} if k == kind else {})
    with pytest.raises(ValueError, match=f"{name}: the start value .* outside the range"):
        build_native_fmu(kind, sc, tmp_path, fmi_version=2)


def _beyond(v, bound: str):
    """The value one step outside ``v``'s ``min`` or ``max`` (None if the type cannot hold it)."""
    x = float(v.min if bound == "min" else v.max)
    if v.type == "Integer":
        y = int(x) - 1 if bound == "min" else int(x) + 1
        return y if INT32[0] <= y <= INT32[1] else None
    with np.errstate(over="ignore"):      # beyond the largest double: inf, refused alike
        return float(np.nextafter(x, -math.inf if bound == "min" else math.inf))


def _outside(path, causality):
    """(variable, value one step beyond one of its bounds) of every parameter or input."""
    cases = [(v, _beyond(v, bound)) for v in _declared(path) if v.causality == causality
             for bound in ("min", "max")]
    cases = [(v, x) for v, x in cases if x is not None]
    assert cases
    return cases


@pytest.mark.slow
def test_a_parameter_outside_its_range_is_refused_with_its_name(kind, fmus):
    for v, value in _outside(fmus[2], "parameter"):
        inst = Inst(fmus[2], "range")
        inst.fmu.setupExperiment(startTime=0.0)
        inst.fmu.enterInitializationMode()
        assert inst.set(v.name, value) == OK
        status, msgs = inst.call(inst.fmu.fmi2ExitInitializationMode, inst.fmu.component)
        assert status == ERROR, (v.name, value, msgs)
        assert any(st == ERROR and _named(v.name, m) for st, _, m in msgs), (v.name, msgs)
        inst.free()


def _named(name: str, message: str) -> bool:
    """The message names the variable, or for an inertia element (one rule over the tensor's
    principal moments, body.h) the body's inertia ("base inertia")."""
    body, _, element = name.rpartition(".")
    return name in message or (element.startswith("I") and f"{body} inertia" in message)


def test_an_input_outside_its_range_is_reported_with_its_name(kind, fmus):
    for v, value in _outside(fmus[2], "input"):
        inst = Inst(fmus[2], "range").init()
        assert inst.set(v.name, value) == OK
        status, msgs = inst.call(inst.step, 0.0, 0.1)
        assert any(st in (WARNING, ERROR) and v.name in m for st, _, m in msgs), \
            (v.name, value, status, msgs)
        inst.free()
