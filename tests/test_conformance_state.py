"""Interface conformance: FMU state.

For every FMU (plant, estimator, sensors) of both robots: save the state at t, continue to t_end, restore, continue again:
every output (estimates, standard deviations, diagnostics) is identical bit for bit. Through
fmi2GetFMUstate/fmi2SetFMUstate, and through fmi2SerializeFMUstate/fmi2DeSerializeFMUstate,
including restoring the bytes into a second instance that has run something else. A negative
control shows that the continuation does depend on the state (so the comparison can fail).
"""
from __future__ import annotations

import numpy as np
import pytest

from test_conformance_util import free_instances  # noqa: F401  (autouse fixture)
from test_conformance_util import (DT, KINDS, OTHER_PARAMETERS, ROBOTS, Inst, as_array,
                                   assert_same, fed_inputs, fmus_for, plant_samples)

N, K = 12, 5        # run 12 steps of 0.1 s, save after step 5


@pytest.fixture(params=[(r, k) for r in ROBOTS for k in KINDS], ids=lambda p: f"{p[0]}-{p[1]}")
def case(request):
    robot, kind = request.param
    fmus = fmus_for(request, robot)
    names, samples = plant_samples(fmus, N)
    return kind, fmus[kind], fed_inputs(kind, names), samples


def advance(inst, kind, names, samples, k0, k1):
    for k in range(k0, k1):
        if names is not None:
            inst.set_many(names, samples[k])
        assert inst.step(k * DT, DT) == 0


def test_get_set_state_round_trip(case):
    kind, path, names, samples = case
    inst = Inst(path, "s").init()
    advance(inst, kind, names, samples, 0, K)
    at_k = inst.outputs()
    state = inst.fmu.getFMUstate()
    advance(inst, kind, names, samples, K, N)
    first = inst.outputs()
    inst.fmu.setFMUstate(state)
    assert_same(inst.outputs(), at_k, "outputs right after fmi2SetFMUstate")
    advance(inst, kind, names, samples, K, N)
    second = inst.outputs()
    inst.fmu.setFMUstate(state)         # a state can be restored more than once
    advance(inst, kind, names, samples, K, N)
    third = inst.outputs()
    inst.fmu.freeFMUstate(state)
    inst.free()
    assert_same(second, first, "continuation after fmi2SetFMUstate")
    assert_same(third, first, "second restore of the same state")


def test_serialized_state_round_trip_into_another_instance(case):
    kind, path, names, samples = case
    a = Inst(path, "a").init()
    advance(a, kind, names, samples, 0, K)
    state = a.fmu.getFMUstate()
    data = a.fmu.serializeFMUstate(state)
    a.fmu.freeFMUstate(state)
    assert isinstance(data, bytes) and len(data) > 0
    advance(a, kind, names, samples, K, N)
    reference = a.outputs()

    # the same instance, from the bytes
    s = a.fmu.deSerializeFMUstate(data)
    a.fmu.setFMUstate(s)
    a.fmu.freeFMUstate(s)
    advance(a, kind, names, samples, K, N)
    assert_same(a.outputs(), reference, "same instance, deserialised state")
    a.free()

    # another instance that ran with other parameters takes over from the bytes
    other = dict(OTHER_PARAMETERS[kind], **({"method": 2} if kind == "estimator" else {}))
    b = Inst(path, "b").init(other)
    advance(b, kind, names, samples, 0, 3)
    s = b.fmu.deSerializeFMUstate(data)
    b.fmu.setFMUstate(s)
    b.fmu.freeFMUstate(s)
    advance(b, kind, names, samples, K, N)
    got = b.outputs()
    restored_params = b.values(b.names("parameter"))
    b.free()
    assert_same(got, reference, "other instance, deserialised state")
    defaults = Inst(path, "defaults")
    assert_same(restored_params, defaults.values(defaults.names("parameter")),
                "parameters come with the state")
    defaults.free()


def test_state_matters_negative_control(case):
    """Continuing from another run's state gives other outputs: the comparisons above can fail."""
    kind, path, names, samples = case
    a = Inst(path, "a").init()
    advance(a, kind, names, samples, 0, N)
    reference = as_array(a.outputs())
    a.free()
    other = OTHER_PARAMETERS[kind]
    b = Inst(path, "b").init(other)
    advance(b, kind, names, samples, 0, K)
    s = b.fmu.getFMUstate()
    data = b.fmu.serializeFMUstate(s)
    b.fmu.freeFMUstate(s)
    b.free()
    c = Inst(path, "c").init()
    advance(c, kind, names, samples, 0, K)
    s = c.fmu.deSerializeFMUstate(data)
    c.fmu.setFMUstate(s)
    c.fmu.freeFMUstate(s)
    advance(c, kind, names, samples, K, N)
    diverged = as_array(c.outputs())
    c.free()
    assert not np.array_equal(diverged, reference)
