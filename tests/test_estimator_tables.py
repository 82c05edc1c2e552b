"""The estimator core's tables against what Python and the FMUs read of them.

The core holds each table once (native/src/est_options.c: the options by the estimator FMU's
parameter names with their ranges and defaults; est_report.c: the outputs and the status texts;
sample.h: the sample's signals); Python binds them by name and offset. Each test fails where a
name, a type or an offset differs between the two, and the ranges the core reports are checked
against what it enforces.
"""
from __future__ import annotations

import ctypes
import math
from pathlib import Path

import numpy as np
import pytest

from spacerobot import interface
from spacerobot.core import estimator as core
from spacerobot.core import sample
from spacerobot.core.estimator import NativeEstimator, SrEstimatorOptions
from spacerobot.estimator import identifier
from spacerobot.robots import scenario

#: FMU parameters whose start value is the scenario's (guesses, covariances) or the sensors'
#: realistic default (noise.*), not the core's default
SCENARIO_STARTS = ("guess.", "P0_", "noise.")


@pytest.fixture(scope="module")
def spatial():
    return scenario("spatial")


def _vars(sc, causality):
    return [v for v in interface.estimator_vars(sc.robot, sc) if v.causality == causality]


def test_options_are_the_fmu_parameters(spatial):
    """Every estimator FMU parameter is one option of the core's table, of the same type, in
    the same order; the start values not taken from the scenario are the core's defaults."""
    table = [o for o in core.option_table() if o.parameter]
    params = _vars(spatial, "parameter")
    assert sorted(o.name for o in table) == sorted(v.name for v in params)
    by_name = {o.name: o for o in table}
    for v in params:
        assert by_name[v.name].integer == (v.type == "Integer"), v.name
        if not v.name.startswith(SCENARIO_STARTS):
            assert by_name[v.name].default == v.start, v.name
    # the noise.* magnitudes in the FMU's order (their value references)
    noise = [v.name for v in params if v.name.startswith("noise.") and v.name != "noise.scale"]
    assert list(interface.PROFILE_MAGNITUDES) == noise


def test_options_struct_offsets():
    """Python's view of sr_estimator_options (ctypes) puts every option where the core does:
    its field's offset plus its index times the element's size; the sizes agree."""
    L = core._bind(core._default_lib())
    assert L.sr_estimator_options_size() == ctypes.sizeof(SrEstimatorOptions)
    fields = dict(SrEstimatorOptions._fields_)
    for o in core.option_table():
        name = "lambda_" if o.field == "lambda" else o.field
        ctype = fields[name]
        elem = ctype._type_ if hasattr(ctype, "_length_") else ctype
        assert (elem is ctypes.c_int) == o.integer, o.name
        assert getattr(SrEstimatorOptions, name).offset + o.index * ctypes.sizeof(elem) \
            == o.offset, o.name


def test_options_set_by_name_land_in_their_field():
    """Setting an option by its name changes its field only (each option's own value)."""
    for o in core.option_table():
        opts = core._options({o.name: 7 if o.integer else 0.25}, core._default_lib())
        got = getattr(opts, "lambda_" if o.field == "lambda" else o.field)
        got = got[o.index] if hasattr(got, "__len__") else got
        assert got == (7 if o.integer else 0.25), o.name
    with pytest.raises(KeyError):
        core._options({"ident.no_such_option": 1.0}, core._default_lib())
    with pytest.raises(ValueError, match="ident.corr_lags must be an integer from 0 to 10000"):
        core._options({"ident.corr_lags": 2.5}, core._default_lib())


def _check(values) -> str:
    """The core's verdict on the options of ``values`` ('' when valid)."""
    L = core._bind(core._default_lib())
    o = core._options(values, L)
    err = ctypes.create_string_buffer(core.MSG_LEN)
    return "" if L.sr_estimator_options_check(ctypes.byref(o), err, len(err)) == 0 else \
        err.value.decode()


def test_parameter_ranges_are_what_the_core_enforces(spatial):
    """Every parameter has a closed range (min <= max); a value just outside it is refused with
    a message naming the parameter, the bounds themselves are accepted (where no rule between
    options or of the guessed body as a whole refuses them: a body's and the noise profile's
    products are checked as such); the rows' weights of either method are checked."""
    every = core.parameter_ranges()
    params = {v.name for v in _vars(spatial, "parameter")}
    inputs = {v.name for v in _vars(spatial, "input")}
    assert params | inputs <= set(every) and params.isdisjoint(inputs)
    assert all(every[name] == (-core.input_limit(), core.input_limit()) for name in inputs)
    assert set(every) - params - inputs <= {n for n in every if n.startswith("arm.")}  # 12 joints
    ranges = {name: every[name] for name in params}
    table = {o.name: o for o in core.option_table()}
    base = {"ident.noise_profile": 1}          # the profile's parameters are then checked
    for name, (lo, hi) in ranges.items():
        assert lo <= hi, name
        o = table[name]
        below = lo - 1 if o.integer else math.nextafter(lo, -math.inf)
        above = hi + 1 if o.integer else math.nextafter(hi, math.inf)
        method = {"method": 2} if name.startswith("ident.sd_row.force") else {}
        if name == "ident.modes":           # the modal columns need the joint solver
            method = {"solver": 2}
        for bad in (below, above):
            if o.integer and not (-2 ** 31 <= bad < 2 ** 31):
                continue
            msg = _check({**base, **method, name: bad})
            body = name.startswith("guess.")
            assert msg and (body or name in msg), (name, bad, msg)
            if method:                      # the other method's weights: checked too
                assert _check({**base, name: bad}) == msg, (name, bad)
        if name.startswith("guess.") or name.startswith("noise."):
            continue
        for good in (lo, hi):
            assert _check({**base, **method, name: good}) == "", (name, good)
    assert core.parameter_ranges(["lambda"]) == {"lambda": ranges["lambda"]}
    with pytest.raises(KeyError):
        core.parameter_ranges(["ident.no_such_parameter"])


def test_input_ranges(spatial):
    """Every input has the range +-INPUT_LIMIT, and a sample beyond it is refused."""
    names = [v.name for v in _vars(spatial, "input")]
    ranges = core.parameter_ranges(names)
    assert set(ranges.values()) == {(-identifier.INPUT_LIMIT, identifier.INPUT_LIMIT)}
    nat = NativeEstimator(spatial.robot, {"guess": spatial.guess})
    x = np.zeros(nat.n_flat)
    x[6:15] = np.eye(3).ravel()
    assert nat.update(0.0, x) == 1
    x[0] = 2 * identifier.INPUT_LIMIT
    assert nat.update(0.1, x) == 3 and "beyond the physical range" in nat.message


def test_outputs_are_the_fmu_outputs(spatial):
    """The core's outputs table names every estimator FMU output once, Integer where the FMU
    variable is; its values are the report's."""
    outs = _vars(spatial, "output")
    names = core.output_names()
    assert sorted(names) == sorted(v.name for v in outs) and len(set(names)) == len(names)
    L = core._bind(core._default_lib())
    kinds = {v.name: v.type for v in outs}
    for i, name in enumerate(names):
        assert bool(L.sr_estimator_output_integer(i)) == (kinds[name] == "Integer"), name
    nat = NativeEstimator(spatial.robot, {"guess": spatial.guess})
    rep, values = nat.report(), dict(zip(names, nat.outputs()))
    for i, est in enumerate(interface.ESTIMATE_NAMES):
        assert values[est] == rep["vector"][i] and values[f"sd.{est}"] == rep["sd"][i]
        assert values[f"crb.{est}"] == rep["crb"][i]
    assert values["diag.status"] == rep["status"] == 0
    assert values["ident.excite"] == rep["excite"] == 1.0
    assert values["diag.identified.target"] == float(rep["identified"]["target"])


def test_the_fmu_glue_has_room_for_every_output():
    """fmu_estimator/estimator.c keeps the outputs' value references in a fixed array
    (MAX_OUTPUTS): the core's outputs table fits in it (else every instantiation fails)."""
    import re
    glue = (Path(__file__).resolve().parents[1] / "fmu_estimator" / "estimator.c").read_text()
    room = int(re.search(r"#define MAX_OUTPUTS (\d+)", glue).group(1))
    assert 0 < len(core.output_names()) <= room, (len(core.output_names()), room)


def test_status_texts():
    """interface.STATUS is the core's table; its codes are the update's statuses."""
    assert interface.STATUS == core.status_texts()
    assert sorted(interface.STATUS) == [identifier.NO_SAMPLE, identifier.REFERENCE,
                                        identifier.ESTIMATING, identifier.REJECT_NONFINITE,
                                        identifier.REJECT_INCONSISTENT]


@pytest.mark.parametrize("robot", ["planar", "spatial"])
def test_sample_layout(robot):
    """The sample's table (sample.h) against the estimator FMU's inputs (interface.py): the
    same signals in the same order, their FMU names, sizes and offsets; the Identifier's keys
    and flattening follow it."""
    sc = scenario(robot)
    n = sc.robot.n_joints
    signals = sample.signals(n)
    inputs = interface.measurement_vars(n, "input")
    offset = 0
    for s in signals:
        group = [v for v in inputs if v.key[0] == s.key]
        assert len(group) == s.size and s.offset == offset, s
        assert all(v.name.startswith(s.fmi_name + "[") for v in group), s
        assert {v.unit for v in group} == {s.unit}, s
        offset += s.size
    assert [v.key[0] for v in inputs] == [s.key for s in signals for _ in range(s.size)]
    assert offset == sample.sample_length(n) == NativeEstimator(sc.robot).n_flat
    assert identifier.KEYS == tuple(s.key for s in signals)
    # the Identifier flattens a dictionary sample in this order (A row-major)
    meas = {s.key: np.arange(s.size, dtype=float) + s.offset for s in signals}
    meas["A"] = meas["A"].reshape(3, 3)
    flat, why = identifier.Identifier(sc.robot, sc.guess)._flatten(meas)
    assert why is None and np.array_equal(flat, np.arange(offset))
