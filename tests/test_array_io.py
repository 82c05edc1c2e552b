"""ArrayIO (spacerobot/system/instance.py): the master's and the recorder's FMI reads and writes
through preallocated arrays give what fmpy's own getReal/getInteger/setReal give, and a
refused call raises fmpy's FMICallException (which the runner turns into a SimulationError)."""
import numpy as np
import pytest
from fmpy.fmi1 import FMICallException

from spacerobot import FMUInstance, Master
from spacerobot.system.errors import Calls, SimulationError, fmi_errors
from spacerobot.system.instance import ArrayIO, FMULog


@pytest.fixture()
def pair(planar_fmus):
    plant = FMUInstance(planar_fmus["plant"], "plant").init()
    est = FMUInstance(planar_fmus["estimator"], "estimator").init()
    master = Master({"plant": plant, "estimator": est},
                    [("plant", n, "estimator", n) for n in est.names("input")])
    for k in range(3):
        master.step(0.1 * k, 0.1)
    yield plant, est
    plant.free()
    est.free()


def _vrs(inst, causality, typ):
    return [v.valueReference for v in inst.vars.values()
            if v.causality == causality and v.type == typ]


def test_reads_equal_fmpy(pair):
    plant, est = pair
    for inst, typ, get in ((plant, "Real", plant.fmu.getReal), (est, "Real", est.fmu.getReal),
                           (est, "Integer", est.fmu.getInteger)):
        vrs = _vrs(inst, "output", typ)
        assert vrs
        io = ArrayIO(inst.fmu, typ, vrs)
        np.testing.assert_array_equal(io.get(), np.array(get(vrs)))
        assert io.values.dtype == (np.float64 if typ == "Real" else np.int32)


def test_write_reaches_the_inputs_and_a_shared_array_wires(pair):
    plant, est = pair
    vrs = _vrs(est, "input", "Real")
    put = ArrayIO(est.fmu, "Real", vrs)
    put.values[:] = np.linspace(-1.0, 1.0, len(vrs))
    put.set()
    np.testing.assert_array_equal(est.fmu.getReal(vrs), put.values)
    # a get and a set on one array: the set sends what the get read (the master's wiring)
    src = plant.vrs(est.names("input"))
    get = ArrayIO(plant.fmu, "Real", src)
    wire = ArrayIO(est.fmu, "Real", est.vrs(est.names("input")), values=get.values)
    get.get()
    wire.set()
    np.testing.assert_array_equal(est.fmu.getReal(est.vrs(est.names("input"))),
                                  plant.fmu.getReal(src))


def test_refused_call_raises_like_fmpy(pair):
    plant, _ = pair
    with pytest.raises(FMICallException) as e:
        ArrayIO(plant.fmu, "Real", [99999]).get()
    assert e.value.status >= 3
    out = _vrs(plant, "output", "Real")[:1]
    with pytest.raises(FMICallException) as e:
        ArrayIO(plant.fmu, "Real", out).set()            # an output cannot be set
    assert e.value.status >= 3
    calls = Calls()
    calls("plant", "fmi2GetReal")
    with pytest.raises(SimulationError, match="'plant' returned .* from fmi2GetReal"):
        with fmi_errors(calls, FMULog(), {"plant": plant}):
            ArrayIO(plant.fmu, "Real", [99999]).get()


def test_values_of_the_wrong_shape_or_type_are_refused(pair):
    plant, _ = pair
    vrs = _vrs(plant, "output", "Real")[:3]
    with pytest.raises(ValueError, match="values must be"):
        ArrayIO(plant.fmu, "Real", vrs, values=np.zeros(2))
    with pytest.raises(ValueError, match="values must be"):
        ArrayIO(plant.fmu, "Integer", vrs, values=np.zeros(3))


def test_recorder_reads_parameters_once_and_repeats_them(pair):
    """The Recorder reads parameters at its first row only (they cannot change while the
    master steps) and every other variable at every row: its columns equal fmpy's own reads at
    every row, parameters and outputs interleaved as in ``names``; the parameter reads are
    counted once."""
    from spacerobot.system.recorder import Recorder
    plant, est = pair
    names = {"plant": [n for n, v in plant.vars.items()
                       if v.causality in ("parameter", "output")][:120],
             "estimator": [n for n, v in est.vars.items()
                           if v.causality in ("parameter", "output", "input")]}
    assert any(plant.vars[n].causality == "parameter" for n in names["plant"])
    calls = []

    class Counting(Calls):
        def __call__(self, component, function):
            calls.append((component, function))

    master = Master({"plant": plant, "estimator": est},
                    [("plant", n, "estimator", n) for n in est.names("input")])
    rec = Recorder({"plant": plant, "estimator": est}, names, 4, Counting())
    want = []
    for k in range(4):
        master.exchange()
        rec.record(k, 0.1 * k)
        want.append({f"{c}.{n}": float(inst.get(n)) for c, inst in (("plant", plant),
                                                                  ("estimator", est))
                     for n in names[c]})
        if k < 3:
            master.do_step(0.1 * (k + 3), 0.1)
    data = rec.data()
    for col, values in data.items():
        if col == "time":
            continue
        np.testing.assert_array_equal(values.astype(float), [w[col] for w in want], col)
    # one FMI call per component, type and kind (parameter or not): the first kind once
    kinds = {(c, inst.vars[n].type, inst.vars[n].causality == "parameter")
             for c, inst in (("plant", plant), ("estimator", est)) for n in names[c]}
    once = sum(1 for k in kinds if k[2])
    assert once >= 1 and len(calls) == once + 4 * (len(kinds) - once)
    # outputs change from row to row (so the equality above tests the per-row reads)
    assert not np.array_equal(data["plant.base.r[1]"][:1], data["plant.base.r[1]"][3:])


def test_value_reference_lists_of_same_length_and_ends_are_not_confused(pair):
    """The slaves cache one plan per list of value references, keyed by its length and ends and
    checked against the whole list: two lists that differ only inside, asked for in turn, each
    get their own values (as the per-variable reads give them)."""
    plant, _ = pair
    vrs = _vrs(plant, "output", "Real")
    assert len(vrs) > 5
    a = [vrs[0], vrs[1], vrs[-1]]
    b = [vrs[0], vrs[2], vrs[-1]]
    single = {vr: plant.fmu.getReal([vr])[0] for vr in set(a + b)}
    assert single[vrs[1]] != single[vrs[2]]
    for _ in range(3):
        for lst in (a, b):
            assert plant.fmu.getReal(lst) == [single[vr] for vr in lst]
