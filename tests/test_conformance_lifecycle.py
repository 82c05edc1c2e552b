"""Interface conformance: lifecycle through fmpy's low-level API (FMU2Slave).

- instantiate, setupExperiment, enter/exitInitializationMode, doStep, terminate, freeInstance
  all return OK, and the plant FMU's outputs equal the plant core (spacerobot.plant.Plant) run
  directly with the same parameters;
- fmi2Reset brings back the default parameters and t = 0: the re-run equals a fresh run bit for
  bit, even after a run with other parameters;
- two instances of one FMU in one process, with different parameters and interleaved calls,
  each equal their solo run, and differ from each other;
- variable communication steps (canHandleVariableCommunicationStepSize = true): plant steps
  0.05 + 0.15 s equal 0.1 + 0.1 s exactly (both are whole numbers of RK4 steps); steps that are
  not multiples of h are deterministic and within 1e-5 of the regular run; the estimator's
  estimates depend on the samples, not on the step sizes (momentum, force-measured, joint);
- a fixed parameter set after initialisation is refused (fmi2Error per the documented mapping,
  with a logged message naming the parameter), the value, the outputs and the continuation are
  unchanged.
"""
from __future__ import annotations

import numpy as np
import pytest

from test_conformance_util import free_instances  # noqa: F401  (autouse fixture)
from test_conformance_util import (DT, ERROR, OK, OTHER_PARAMETERS, ROBOTS, Inst, as_array,
                                   assert_same, fed_inputs, feed, fmus_for, plant_samples)

N = 10          # communication steps of 0.1 s per run (1 s simulated)


@pytest.fixture(params=ROBOTS)
def robot_fmus(request):
    return request.param, fmus_for(request, request.param)


def run_plant(path, params=None, steps=(DT,) * N, inst=None):
    p = inst or Inst(path, "plant")
    p.init(params)
    t = 0.0
    for dt in steps:
        assert p.step(t, dt) == OK
        t += dt
    out = p.outputs()
    p.fmu.terminate()
    p.free()
    return out


def run_estimator(fmus, params=None, n=N):
    names, samples = plant_samples(fmus, n)
    e = Inst(fmus["estimator"], "estimator").init(params)
    feed(e, names, samples[:n])
    out = e.outputs()
    e.fmu.terminate()
    e.free()
    return out


# -- full lifecycle -----------------------------------------------------------------------------
def test_plant_lifecycle_and_outputs_equal_the_core(robot_fmus):
    from spacerobot.plant import Plant
    from spacerobot.robots import scenario

    robot, fmus = robot_fmus
    p = Inst(fmus["plant"], "plant")
    assert p.fmu.setupExperiment(startTime=0.0, stopTime=N * DT) == OK
    assert p.fmu.enterInitializationMode() == OK
    assert p.set("target.m", 321.0) == OK
    assert p.fmu.exitInitializationMode() == OK
    for k in range(N):
        assert p.step(k * DT, DT) == OK
    fmu_out = p.outputs()
    assert p.fmu.terminate() == OK
    p.free()
    assert not [m for m in p.messages if m[0] > OK], p.messages

    sc = scenario(robot)
    target = type(sc.target)(321.0, sc.target.com, sc.target.inertia)
    core = Plant(sc.robot, sc.robot.base, target, sc.controller, sc.v0, sc.omega0, sc.h)
    for _ in range(N):
        core.advance(DT)
    out = core.outputs()
    n = sc.robot.n_joints
    expected = {}
    groups = {"base.r": "r_S", "base.v": "v_S", "base.omega": "omega_B", "base.a": "a_S",
              "base.alpha": "alpha_B", "thrust.F": "F", "thrust.M": "M", "thrust.J": "J",
              "thrust.H": "H", "system.P": "P", "system.L": "L"}
    for prefix, g in groups.items():
        for i in range(3):
            expected[f"{prefix}[{i + 1}]"] = out[g][i]
    for prefix, g in (("arm.q", "q"), ("arm.qd", "qd"), ("arm.qdd", "qdd"), ("arm.tau", "tau"),
                      ("excite.qd_ref", "qd_ref")):
        for i in range(n):
            expected[f"{prefix}[{i + 1}]"] = out[g][i]
    for i in range(3):
        for j in range(3):
            expected[f"base.A[{i + 1},{j + 1}]"] = out["A"][i][j]
    expected["excite.level"] = out["excite_level"][0]     # excitation off: 0
    expected["excite.rate"] = out["excite_rate"][0]       # the plant's own rate: 1
    for i in range(3):
        expected[f"excite.att_ref[{i + 1}]"] = out["att_ref"][i]
    # no propellant model: m = 0, nothing expelled, the base is the dry base
    expected["prop.m"] = out["m_p"][0]
    for i in range(3):
        expected[f"prop.P[{i + 1}]"] = out["P_x"][i]
        expected[f"prop.L[{i + 1}]"] = out["L_x"][i]
    for k, nm in enumerate(("m", "b[1]", "b[2]", "b[3]", "Ixx", "Iyy", "Izz", "Ixy", "Ixz",
                            "Iyz")):
        expected[f"truth.base.{nm}"] = out["base_now"][k]
    # no flexible parts: their momentum, deflections and strokes 0
    for prefix, g, count in (("flex.P", "flex_P", 3), ("flex.L", "flex_L", 3),
                             ("flex.q", "flex_q", 4), ("flex.qd", "flex_qd", 4),
                             ("slosh.x", "slosh_x", 4), ("slosh.v", "slosh_v", 4)):
        for i in range(count):
            expected[f"{prefix}[{i + 1}]"] = out[g][i]
    assert set(expected) == set(fmu_out)
    assert_same({k: fmu_out[k] for k in expected}, {k: float(v) for k, v in expected.items()},
                "FMU vs core")


def test_estimator_lifecycle(robot_fmus):
    robot, fmus = robot_fmus
    names, samples = plant_samples(fmus, N)
    e = Inst(fmus["estimator"], "estimator")
    assert e.fmu.setupExperiment(startTime=0.0) == OK
    assert e.fmu.enterInitializationMode() == OK
    assert e.fmu.exitInitializationMode() == OK
    guess = e.values([n for n in e.names("output") if not n.startswith(("sd.", "diag."))])
    feed(e, names, samples[:N])
    out = e.outputs()
    assert e.fmu.terminate() == OK
    e.free()
    assert out["diag.status"] == 2 and out["diag.samples"] == N - 1 and out["diag.rejected"] == 0
    assert all(np.isfinite(list(out.values())))
    assert any(out[k] != v for k, v in guess.items()), "estimates never left the guess"


# -- reset ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["plant", "estimator", "sensors"])
def test_reset_then_rerun_is_identical(robot_fmus, kind):
    robot, fmus = robot_fmus
    names, samples = plant_samples(fmus, N)
    other = OTHER_PARAMETERS[kind]
    fed = fed_inputs(kind, names)

    def run(inst, params):
        inst.init(params)
        if fed is None:
            for k in range(N):
                assert inst.step(k * DT, DT) == OK
        else:
            feed(inst, fed, samples[:N])
        return inst.values()            # every variable: parameters too

    fresh = Inst(fmus[kind], "fresh")
    reference = run(fresh, None)
    fresh.fmu.terminate()
    fresh.free()

    inst = Inst(fmus[kind], "reused")
    first = run(inst, other)
    assert as_array(first).tolist() != as_array(reference).tolist()
    inst.fmu.terminate()
    assert inst.fmu.reset() == OK
    again = run(inst, None)             # defaults again, t = 0 again
    inst.fmu.terminate()
    assert inst.fmu.reset() == OK       # reset straight after a run, without terminate, too
    inst.init(None)
    inst.fmu.reset()
    third = run(inst, None)
    inst.fmu.terminate()
    inst.free()
    assert_same(again, reference, "after reset")
    assert_same(third, reference, "after second reset")


# -- two instances ----------------------------------------------------------------------------------
@pytest.mark.parametrize("kind", ["estimator", "plant"])
def test_two_instances_in_one_process_are_independent(robot_fmus, kind):
    robot, fmus = robot_fmus
    names, samples = plant_samples(fmus, N)
    if kind == "estimator":
        pa, pb = {}, {"method": 2, "guess.target.m": 200.0}
    else:
        pa, pb = {}, {"target.m": 150.0, "base.omega0[3]": -0.05}

    def solo(params):
        if kind == "plant":
            return run_plant(fmus["plant"], params)
        return run_estimator(fmus, params)

    a_solo, b_solo = solo(pa), solo(pb)
    a, b = Inst(fmus[kind], "A"), Inst(fmus[kind], "B")
    a.init(pa)
    b.init(pb)
    for k in range(N):                  # interleaved: A, B, A, B ...
        for inst in (a, b):
            if kind == "estimator":
                inst.set_many(names, samples[k])
            assert inst.step(k * DT, DT) == OK
    a_out, b_out = a.outputs(), b.outputs()
    for inst in (a, b):
        inst.fmu.terminate()
        inst.free()
    assert_same(a_out, a_solo, "instance A vs its solo run")
    assert_same(b_out, b_solo, "instance B vs its solo run")
    diff = np.abs(as_array(a_out) - as_array(b_out))
    assert np.nanmax(diff) > 1e-3, "different parameters gave the same results"


# -- variable communication step sizes ---------------------------------------------------------------
def test_plant_variable_step_sizes(robot_fmus):
    robot, fmus = robot_fmus
    path = fmus["plant"]
    regular = as_array(run_plant(path, steps=[0.1, 0.1]))
    multiples = as_array(run_plant(path, steps=[0.05, 0.15]))
    # whole numbers of RK4 steps (h = 1 ms): the same steps in a different grouping; the joint
    # sines are evaluated afresh at the start of each call and rotated between (plant.c), so the
    # groupings agree to round-off (measured 2e-11 on accelerations), not bit for bit
    scale = np.maximum(np.abs(regular), 1.0)
    assert np.max(np.abs(multiples - regular) / scale) < 1e-9
    irregular = [0.0375, 0.1625]
    x = as_array(run_plant(path, steps=irregular))
    y = as_array(run_plant(path, steps=irregular))
    assert np.array_equal(x, y), "same irregular steps must give the same result"
    # a step that is not a multiple of h ends with one shorter RK4 step; the controller's
    # zero-order hold then samples at other instants (< h apart): a small, bounded difference
    rel = np.max(np.abs(x - regular) / scale)
    assert 0.0 < rel < 1e-5, rel


@pytest.mark.parametrize("params", [{}, {"method": 2}, {"solver": 2}],
                         ids=["momentum", "force", "joint"])
def test_estimator_result_does_not_depend_on_step_sizes(robot_fmus, params):
    robot, fmus = robot_fmus
    names, samples = plant_samples(fmus, N)

    def run(steps):
        e = Inst(fmus["estimator"], "e").init(params)
        t = 0.0
        for k, dt in enumerate(steps):
            e.set_many(names, samples[k])
            assert e.step(t, dt) == OK
            t += dt
        out = e.outputs()
        e.free()
        return out

    assert_same(run([0.05, 0.15] * (N // 2)), run([DT] * N), "irregular vs regular steps")


# -- fixed parameter after initialisation -----------------------------------------------------------
@pytest.mark.parametrize("kind,name,value", [
    ("plant", "base.m", 1.0), ("plant", "h", 0.01), ("estimator", "guess.target.m", 1.0),
    ("estimator", "method", 2), ("estimator", "lambda", 0.5)])
def test_fixed_parameter_after_initialisation_is_refused(robot_fmus, kind, name, value):
    robot, fmus = robot_fmus
    names, samples = plant_samples(fmus, N)
    inst = Inst(fmus[kind], "x").init()

    def advance(k0, k1):
        for k in range(k0, k1):
            if kind == "estimator":
                inst.set_many(names, samples[k])
            assert inst.step(k * DT, DT) == OK

    advance(0, N // 2)
    before_value, before = inst.get(name), inst.outputs()
    status, msgs = inst.call(inst.set, name, value)
    assert status == ERROR
    assert any(name in m and "fixed parameter" in m and "cannot be changed" in m
               for _, _, m in msgs), msgs
    assert inst.get(name) == before_value
    assert_same(inst.outputs(), before, "outputs after the refused set")
    advance(N // 2, N)                  # and nothing was lost: the run continues as if untouched
    after = inst.outputs()
    inst.free()
    reference = run_plant(fmus["plant"]) if kind == "plant" else run_estimator(fmus)
    assert_same(after, reference, "continuation after the refused set")
