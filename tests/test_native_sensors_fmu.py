"""The native sensors FMU (fmu_sensors/sensors.c over native/src/sensors.c) through fmpy.

What it claims (needsExecutionTool false, the platforms it carries, no robot in resources,
each output's direct-feedthrough inputs as spacerobot.interface.sensors_dependencies says and
as the core computes: an input not listed leaves the output unchanged), direct feedthrough
(outputs follow the inputs set at the same communication point, without a step), the realistic
noise levels it delivers (standard deviations of measurement - truth within 5 standard errors
of the configured values, noise.scale included), state save / restore through bytes into
another instance, and refusals (bad parameters: fmi2Error with the parameter named; a NaN
input: passed on, a warning logged).
"""
from __future__ import annotations

import zipfile

import numpy as np
import pytest

from spacerobot.fmi.native import build_native_fmu
from spacerobot.interface import NOISE_PARAMETERS, sensors_dependencies, sensors_vars
from spacerobot.robots import scenario
from test_conformance_util import free_instances  # noqa: F401  (autouse fixture)
from test_conformance_util import DT, ERROR, OK, WARNING, Inst

N_STAT = 4000


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    return build_native_fmu("sensors", scenario("spatial"), tmp_path_factory.mktemp("nsens"))


def _inputs(inst):
    ins = inst.names("input")
    return ins, [n[len("true."):] for n in ins]


def test_model_description_claims_what_it_carries(fmu):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert md.coSimulation.needsExecutionTool is False
    with zipfile.ZipFile(fmu) as zf:
        names = zf.namelist()
    plats = {n.split("/")[1] for n in names if n.startswith("binaries/")}
    assert "linux64" in plats and plats <= {"linux64", "win64"}
    assert not any(n.endswith("robot.txt") for n in names)      # the sensors know no robot
    sc = scenario("spatial")
    variables = sensors_vars(sc.robot, sc)
    deps = sensors_dependencies(variables)
    got = {o.variable.name: sorted(d.name for d in o.dependencies) for o in md.outputs}
    want = {variables[i].name: sorted(variables[j].name for j in js) for i, js in deps.items()}
    assert got == want and all(got.values())


def test_outputs_follow_the_inputs_without_a_step(fmu):
    s = Inst(fmu, "feedthrough").init({"noise.scale": 0.0})
    ins, outs = _inputs(s)
    rng = np.random.default_rng(3)
    for _ in range(3):
        x = rng.normal(size=len(ins))
        s.set_many(ins, x)
        assert np.array_equal(list(s.values(outs).values()), x)


def test_each_output_depends_on_the_declared_inputs_only(fmu):
    """Perturb one input at a time (realistic noise): the outputs that change are exactly those
    that declare it (the model description is what a master plans its loop with)."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu))
    declared = {o.variable.name: {d.name for d in o.dependencies} for o in md.outputs}
    s = Inst(fmu, "deps").init()
    ins, outs = _inputs(s)
    x = np.random.default_rng(4).normal(size=len(ins))
    s.set_many(ins, x)
    y0 = s.values(outs)
    for i, name in enumerate(ins):
        s.set_many(ins, x + np.eye(len(ins))[i] * 0.25)
        y = s.values(outs)
        changed = {o for o in outs if y[o] != y0[o]}
        assert changed == {o for o in outs if name in declared[o]}, name
    s.set_many(ins, x)


@pytest.mark.parametrize("scale", [1.0, 3.0])
def test_noise_levels_are_the_configured_ones(fmu, scale):
    s = Inst(fmu, "levels").init({"noise.scale": scale, "seed": 11, "noise.enc.resolution": 0.0})
    ins, outs = _inputs(s)
    x = np.zeros(len(ins))
    x[[ins.index(f"true.base.A[{i},{i}]") for i in (1, 2, 3)]] = 1.0
    err = []
    for k in range(N_STAT):
        s.set_many(ins, x)
        err.append(np.array(list(s.values(outs).values())) - x)
        assert s.step(k * DT, DT) == OK
    err = np.array(err)
    for name, param in [("base.r[1]", "noise.nav.r"), ("base.v[3]", "noise.nav.v"),
                        ("arm.q[2]", "noise.enc.q"), ("arm.qd[1]", "noise.enc.qd"),
                        ("arm.qdd[3]", "noise.enc.qdd"), ("base.alpha[2]", "noise.alpha")]:
        sd = scale * NOISE_PARAMETERS[param][1]
        got = err[:, outs.index(name)].std()
        assert abs(got - sd) < 5 * sd / np.sqrt(2 * N_STAT), (name, got, sd)


def test_state_round_trip_through_bytes_into_another_instance(fmu):
    a = Inst(fmu, "a").init({"seed": 5, "noise.delay": 2})
    ins, outs = _inputs(a)
    xs = np.random.default_rng(6).normal(size=(12, len(ins)))

    def run(inst, k0):
        rows = []
        for k in range(k0, len(xs)):
            inst.set_many(ins, xs[k])
            rows.append(list(inst.values(outs).values()))
            assert inst.step(k * DT, DT) == OK
        return np.array(rows)

    run_to = 5
    for k in range(run_to):
        a.set_many(ins, xs[k])
        a.step(k * DT, DT)
    blob = a.fmu.serializeFMUstate(a.fmu.getFMUstate())
    ref = run(a, run_to)
    b = Inst(fmu, "b").init({"seed": 5, "noise.delay": 2})
    b.fmu.setFMUstate(b.fmu.deSerializeFMUstate(blob))
    assert np.array_equal(run(b, run_to), ref)      # the same implementation: bit for bit


@pytest.mark.parametrize("name, value, says", [
    ("seed", -1, "seed"), ("noise.delay", 101, "noise.delay"), ("noise.imu", 2, "noise.imu"),
    ("noise.gyro.arw", -1e-3, "noise.gyro.arw"), ("noise.scale", float("inf"), "noise.scale")])
def test_bad_parameters_are_refused_by_name(fmu, name, value, says):
    s = Inst(fmu, "bad")
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    s.set(name, value)
    status, msgs = s.call(s.fmu.exitInitializationMode)
    assert status == ERROR and any(says in m[2] for m in msgs), msgs


def test_every_declared_bound_is_accepted(fmu):
    """The declared min / max are not narrower than the core's checks: each parameter at either
    bound initialises (the magnitudes 0 when noise.scale is at its max: their products with it
    have the magnitudes' own limits); tests/test_conformance_ranges.py: not wider either."""
    from fmpy import read_model_description

    params = [v for v in read_model_description(str(fmu)).modelVariables
              if v.causality == "parameter"]
    magnitudes = {v.name: 0.0 for v in params if v.type == "Real" and v.name != "noise.scale"}
    for v in params:
        for bound in (v.min, v.max):
            values = {**(magnitudes if v.name == "noise.scale" else {}), v.name: bound}
            s = Inst(fmu, "bound")
            s.fmu.setupExperiment(startTime=0.0)
            s.fmu.enterInitializationMode()
            for name, x in values.items():
                assert s.set(name, x) == OK
            status, msgs = s.call(s.fmu.exitInitializationMode)
            assert status == OK, (v.name, bound, msgs)
            assert s.step(0.0, DT) == OK
            s.free()


def test_a_nan_input_is_passed_on_with_a_warning(fmu):
    s = Inst(fmu, "nan").init({"seed": 1})
    ins, outs = _inputs(s)
    x = np.zeros(len(ins))
    x[ins.index("true.base.r[2]")] = np.nan
    s.set_many(ins, x)
    assert np.isnan(s.values(["base.r[2]"])["base.r[2]"])
    status, msgs = s.call(s.step, 0.0, DT)
    # the step succeeds (the sample goes on for the estimator to reject); the log warns
    assert status == OK and any(m[0] == WARNING and "true.base.r[2]" in m[2] for m in msgs)
    s.set_many(ins, np.zeros(len(ins)))                  # the state stays usable
    assert np.all(np.isfinite(list(s.values(outs).values())))


def test_in_initialisation_mode_outputs_follow_the_inputs(fmu):
    """A master that settles initial values in initialisation mode reads the measurement of
    the inputs set so far (noise.scale = 0: the inputs themselves), not of earlier ones."""
    s = Inst(fmu, "init-feedthrough")
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    s.set("noise.scale", 0.0)
    for value in (1.0, 2.0):
        s.set("true.base.r[1]", value)
        assert s.values(["base.r[1]"])["base.r[1]"] == value
    s.fmu.exitInitializationMode()
    assert s.values(["base.r[1]"])["base.r[1]"] == 2.0
