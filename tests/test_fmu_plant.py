"""The plant FMU through fmpy: variables map to the core, partial steps, bad
parameters and bad steps.

* Every output of the FMU equals the core ``Plant`` run with the same (non-default)
  parameters; names are parsed here, independently of ``spacerobot.interface``.
* A communication step that is not a multiple of h ends with one shorter internal step.
* Each invalid parameter makes fmi2ExitInitializationMode fail (fmi2Error) with a readable
  message naming the parameter; the instance can be freed and a fresh one runs. Every field of
  the core's parameter structs reaches the field of its name.
* A bad communication step is discarded with the state unchanged.
* Excitation: ``ident.excite`` reaches the core (the FMU equals the core with the
  same level requests); a value outside [0, 1] is clipped with a warning; NaN discards the
  step with the state unchanged; a bad ``excite.*`` parameter fails initialisation by name.
"""
from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest
from fmpy.fmi1 import FMICallException
from conftest import assert_initialisation_fails, started_slave
from spacerobot.plant import Plant
from spacerobot.interface import plant_vars
from spacerobot.robots import (Propellant, RigidBody, inertia_matrix, parameter_set_scenario,
                               scenario)

FMI_DISCARD, FMI_WARNING = 2, 1



# ------------------------------------------------------------------------------------------------
# FMU outputs == core outputs, with non-default parameters
# ------------------------------------------------------------------------------------------------

#: FMI name prefix -> core output key (interface contract §3, written out independently)
OUTPUT_KEYS = {"base.r": "r_S", "base.v": "v_S", "base.A": "A", "base.omega": "omega_B",
               "base.a": "a_S", "base.alpha": "alpha_B", "arm.q": "q", "arm.qd": "qd",
               "arm.qdd": "qdd", "thrust.F": "F", "thrust.M": "M", "thrust.J": "J",
               "thrust.H": "H", "system.P": "P", "system.L": "L", "arm.tau": "tau",
               "excite.att_ref": "att_ref", "excite.qd_ref": "qd_ref", "prop.P": "P_x",
               "prop.L": "L_x", "flex.P": "flex_P", "flex.L": "flex_L", "flex.q": "flex_q",
               "flex.qd": "flex_qd", "slosh.x": "slosh_x", "slosh.v": "slosh_v"}
#: the base's current truth: core ``base_now`` = [m, b (3), Ixx .. Iyz]
TRUTH_BASE = ("m", "b[1]", "b[2]", "b[3]", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")


def core_value(out: dict, name: str) -> float:
    if name == "excite.level":
        return float(out["excite_level"][0])
    if name == "excite.rate":
        return float(out["excite_rate"][0])
    if name == "prop.m":
        return float(out["m_p"][0])
    if name.startswith("truth.base."):
        return float(out["base_now"][TRUTH_BASE.index(name[len("truth.base."):])])
    m = re.fullmatch(r"([a-z]+\.[A-Za-z_]+)\[(\d+)(?:,(\d+))?\]", name)
    assert m, name
    arr = out[OUTPUT_KEYS[m.group(1)]]
    if m.group(3):
        return float(arr[int(m.group(2)) - 1, int(m.group(3)) - 1])
    return float(arr[int(m.group(2)) - 1])


def _spatial_case():
    """Non-default truth: target with products of inertia and a full CoM offset, other v0."""
    I = inertia_matrix((30.0, 25.0, 20.0, 1.5, -2.0, 0.8))
    assert np.all(np.linalg.eigvalsh(I) > 0)
    target = RigidBody(320.0, (0.12, -0.07, 0.31), (30.0, 25.0, 20.0, 1.5, -2.0, 0.8))
    base = RigidBody(480.0, (0.05, 0.02, -0.04), (80.0, 90.0, 85.0, -1.0, 0.5, 2.0))
    return dict(base=base, target=target, v0=(1.0, -2.0, 0.5), omega0=(0.05, -0.1, 0.2),
                F_max=7.0, M_max=6.0, K_D=0.8, K_P=0.3,
                prop=Propellant(m0=40.0, Isp=200.0, r=(0.25, -0.1, 0.3), R=0.2, arm=0.8))


def _params(case) -> dict:
    p = {}
    for who in ("base", "target"):
        body = case[who]
        p[f"{who}.m"] = body.mass
        for i in range(3):
            p[f"{who}.b[{i + 1}]"] = body.com[i]
        for k, n in enumerate(("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")):
            p[f"{who}.{n}"] = body.inertia[k]
    for i in range(3):
        p[f"base.v0[{i + 1}]"] = case["v0"][i]
        p[f"base.omega0[{i + 1}]"] = case["omega0"][i]
    for k in ("F_max", "M_max", "K_D", "K_P"):
        p[k] = case[k]
    if "prop" in case:
        pr = case["prop"]
        p.update({"prop.m0": pr.m0, "prop.Isp": pr.Isp, "prop.R": pr.R, "prop.arm": pr.arm})
        p.update({f"prop.r[{i + 1}]": pr.r[i] for i in range(3)})
    return p




def test_fmu_outputs_equal_core(spatial_fmus):
    case = _spatial_case()
    sc = scenario("spatial")
    ctrl = dataclasses.replace(sc.controller, F_max=case["F_max"], M_max=case["M_max"],
                               K_D=case["K_D"], K_P=case["K_P"])
    core = Plant(sc.robot, case["base"], case["target"], ctrl, case["v0"], case["omega0"], sc.h,
                 propellant=case["prop"])
    s = started_slave(spatial_fmus["plant"], _params(case), "plant")
    outs = s.names("output")
    # 16 three-vectors (r v omega a alpha F M J H P L att_ref, prop.P prop.L, flex.P flex.L),
    # the DCM, q qd qdd tau qd_ref, excite.level, excite.rate, prop.m, the 10 truth.base
    # parameters, the 4 deflections, rates, strokes and stroke rates of the flexible parts
    assert len(outs) == 16 * 3 + 9 + 5 * sc.robot.n_joints + 1 + 1 + 1 + 10 + 4 * 4
    t = 0.0
    try:
        for dt in (None, 0.1005, 0.2995, 0.1):
            if dt is not None:
                s.fmu.doStep(t, dt)
                core.advance(dt)
                t += dt
            o = core.outputs()
            got = np.array(s.fmu.getReal([s.vars[n].valueReference for n in outs]))
            want = np.array([core_value(o, n) for n in outs])
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12,
                                       err_msg=f"t = {t}: " + ", ".join(
                                           n for n, a, b in zip(outs, got, want)
                                           if not np.isclose(a, b, rtol=1e-12, atol=1e-12)))
        assert abs(core.t - 0.5) < 1e-12
        assert s.get("prop.m") < case["prop"].m0 - 0.01       # the propellant was used
        # the non-default parameters did reach the core: the default run differs
        default = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h)
        assert np.abs(default.outputs()["P"] - o["P"]).max() > 1.0
        assert not [m for m in s.messages if m[0] >= FMI_WARNING], s.messages
    finally:
        s.free()


def test_partial_step_through_fmu(planar_fmus):
    """doStep(0.1005) = 100 steps of h + one of 0.0005: the same as the core's advance(0.1)
    then advance(0.0005)."""
    sc = scenario("planar")
    s = started_slave(planar_fmus["plant"], {}, "plant")
    try:
        s.fmu.doStep(0.0, 0.1005)
        core = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h)
        core.advance(0.1)                                  # 100 steps of h
        core.advance(0.0005)                               # one of 0.0005
        o = core.outputs()
        for n in s.names("output"):
            assert s.get(n) == pytest.approx(core_value(o, n), rel=1e-13, abs=1e-13), n
        # and a following step from the right communication point raises no warning
        s.fmu.doStep(0.1005, 0.1)
        assert not [m for m in s.messages if m[0] >= FMI_WARNING], s.messages
    finally:
        s.free()


# ------------------------------------------------------------------------------------------------
# invalid parameters -> fmi2Error at exitInitializationMode with a readable message
# ------------------------------------------------------------------------------------------------

BAD_PARAMETERS = [
    # (parameters, words the logged message must contain)
    ({"base.m": 0.0}, ["base.m must be > 0 kg, got 0.0"]),
    ({"target.m": -250.0}, ["target.m must be > 0 kg, got -250.0"]),
    ({"target.m": 1e308}, ["target.m must be within [1e-06, 1e+15] kg"]),
    ({"base.Ixx": -1.0}, ["base", "inertia", "positive definite"]),
    ({"target.Ixy": 20.0}, ["target", "inertia", "positive definite"]),      # |Ixy| > Ixx, Iyy
    ({"target.Izz": 30.0}, ["target", "inertia", "triangle"]),                # 30 > 10.41 + 10.41
    ({"h": 0.0}, ["h must be within [1e-06, 1] s, got 0.0"]),
    ({"h": -1e-3}, ["h must be within [1e-06, 1] s, got -0.001"]),
    ({"h": 5e-324}, ["h must be within [1e-06, 1] s, got "]),
    ({"base.b[1]": math.nan}, ["base.b[1]", "nan"]),
    ({"target.Iyy": math.inf}, ["target.Iyy", "inf"]),
    ({"base.v0[2]": math.nan}, ["base.v0[2]", "nan"]),
    ({"excite.period": 0.0}, ["excite.period must be within [0.001, 1e+09] s"]),
    ({"excite.qd_max": -0.1}, ["excite.qd_max must be within [0, 1000] rad/s"]),
    ({"prop.m0": -1.0}, ["prop.m0 must be within [0, 1e+09] kg"]),
    ({"prop.m0": 10.0, "prop.Isp": 0.0}, ["prop.Isp must be within [0.001, 1e+09] s"]),
    ({"prop.R": -0.1}, ["prop.R must be within [0, 1000] m"]),
    ({"K_Pn": -1e308}, ["K_Pn must be within [-1e+09, 1e+09] 1/s2, got -1e+308"]),
    ({"base.v0[1]": 1e308}, ["base.v0[1] must be within [-1e+06, 1e+06] m/s"]),
    # the flexible parts (planar defaults: hinged along z; slosh in the plane)
    ({"flex.n": 1, "flex.axis[1,1]": 0.0, "flex.axis[1,2]": 0.0, "flex.axis[1,3]": 0.0},
     ["flex.axis[1] must not be zero"]),
    ({"flex.n": 2, "flex.axis[2,1]": 1.0}, ["flex.axis[2]: a planar robot's panels turn in its "
                                             "plane"]),
    ({"slosh.n": 1, "slosh.axis[1,3]": 0.5}, ["slosh.axis[1]: a planar robot's slosh masses"]),
    ({"flex.n": 1, "flex.f[1]": 80.0}, ["flex.f[1] = 80.0 Hz is too fast for the step"]),
    ({"flex.n": 1, "flex.Izz[1]": 200.0}, ["flex[1] inertia violates the triangle inequality"]),
    ({"slosh.n": 2, "prop.m0": 30.0}, ["slosh.m: the slosh masses in use total 50 kg, more than "
                                       "the propellant prop.m0 = 30 kg"]),
    ({"slosh.m[3]": 0.0}, ["slosh.m[3] must be within [1e-06, 1e+15] kg, got 0.0"]),
]


@pytest.mark.parametrize("params,words", BAD_PARAMETERS,
                         ids=[",".join(f"{k}={v}" for k, v in p.items()) for p, _ in BAD_PARAMETERS])
def test_bad_parameter_fails_initialisation_with_message(planar_fmus, params, words):
    path = planar_fmus["plant"]
    assert_initialisation_fails(path, params, words)
    # a fresh instance with good parameters runs
    good = started_slave(path, {}, "good")
    try:
        good.fmu.doStep(0.0, 0.1)
        assert math.isfinite(good.get("base.v[1]"))
        assert good.get("thrust.J[1]") == pytest.approx(-10.0 * 0.1, rel=1e-12)  # F saturated
    finally:
        good.free()


@pytest.mark.parametrize("table", ["controller", "excitation", "propellant", "flex", "slosh"])
def test_glue_sets_every_parameter_field_by_its_name(planar_fmus, table):
    """Each field of the core's parameter structs (plant.h's tables), alone out of its range
    through its FMU variable: the core names that field (the glue set the variable's value
    into the field of that name, not into another); the panels' and slosh modes': every
    record's."""
    from spacerobot.core.plant import fields, records
    count = records(table)
    for f in fields(table):
        for i in range(count):
            for k in range(f.size):
                if count == 1:
                    name = f.fmi if f.size == 1 else f"{f.fmi}[{k + 1}]"
                else:
                    name = f"{f.fmi}[{i + 1}]" if f.size == 1 else f"{f.fmi}[{i + 1},{k + 1}]"
                assert_initialisation_fails(planar_fmus["plant"],
                                            {name: f.max + 1.0 + abs(f.max)},
                                            [f"{name} must be within ["])


def _set_params(sc) -> dict:
    """The FMU's parameters of a parameter set's scenario (the SSP's binding of the set)."""
    from spacerobot.system.ssd import set_parameters
    variables = plant_vars(sc.robot, sc)
    var = {v.name: v for v in variables}
    return {n: var[n].start for n in set_parameters(variables)}


def test_fmu_with_flexible_parts_equals_the_core_and_restores_its_state(spatial_fmus):
    """The spatial FMU with the `flexible` set's parameters (two wings, two slosh modes) and
    the excitation requested: every output equals the core's plant of that set to 1e-12 over
    steps of several lengths; a serialised state restored into a fresh instance continues bit
    for bit."""
    sc = parameter_set_scenario("spatial", "flexible")
    core = Plant.of(sc)
    a = started_slave(spatial_fmus["plant"], _set_params(sc), "flex_a")
    b = started_slave(spatial_fmus["plant"], _set_params(sc), "flex_b")
    try:
        outs = a.names("output")
        a.set("ident.excite", 1.0)
        core.set_excitation(1.0)
        t, data, ref = 0.0, None, None
        for k, dt in enumerate((0.1005, 2.2995, 0.1, 3.0, 0.5, 0.5)):
            a.fmu.doStep(t, dt)
            core.advance(dt)
            t += dt
            o = core.outputs()
            got = np.array([a.get(n) for n in outs])
            want = np.array([core_value(o, n) for n in outs])
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
            if k == 2:
                st = a.fmu.getFMUstate()
                data, t_saved = a.fmu.serializeFMUstate(st), t
                a.fmu.freeFMUstate(st)
        ref = got
        assert abs(a.get("flex.q[1]")) > 1e-4 and abs(a.get("slosh.x[2]")) > 1e-3
        assert a.get("truth.base.m") == pytest.approx(500.0 + 100.0 + 50.0, rel=1e-15)
        s = b.fmu.deSerializeFMUstate(data)
        b.fmu.setFMUstate(s)
        b.fmu.freeFMUstate(s)
        for dt in (3.0, 0.5, 0.5):
            b.fmu.doStep(t_saved, dt)
            t_saved += dt
        assert np.array_equal(np.array([b.get(n) for n in outs]), ref)
        assert not [m for m in a.messages + b.messages if m[0] >= FMI_WARNING]
    finally:
        a.free()
        b.free()


def test_bad_communication_step_is_discarded(planar_fmus):
    """step <= 0 or non-finite: Discard, message logged, state unchanged; stepping goes on."""
    sc = scenario("planar")
    s = started_slave(planar_fmus["plant"], {}, "plant")
    try:
        s.fmu.doStep(0.0, 0.1)
        outs = s.names("output")
        before = [s.get(n) for n in outs]
        for bad in (0.0, -0.1, math.nan, math.inf):
            n_msgs = len(s.messages)
            with pytest.raises(FMICallException) as exc:
                s.fmu.doStep(0.1, bad)
            assert exc.value.status == FMI_DISCARD
            assert len(s.messages) > n_msgs
            assert [s.get(n) for n in outs] == before
        s.fmu.doStep(0.1, 0.1)
        core = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h)
        core.advance(0.1)
        core.advance(0.1)
        o = core.outputs()
        for n in outs:
            assert s.get(n) == pytest.approx(core_value(o, n), rel=1e-12, abs=1e-12), n
    finally:
        s.free()


# ------------------------------------------------------------------------------------------------
# excitation input
# ------------------------------------------------------------------------------------------------

def test_excite_input_reaches_the_core_clipped_and_nan_discarded(planar_fmus):
    sc = scenario("planar")
    s = started_slave(planar_fmus["plant"], {"excite.ramp": 2.0, "excite.att_max": 0.2}, "plant")
    core = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
                 dataclasses.replace(sc.excitation, ramp=2.0, att_max=0.2))
    outs = s.names("output")
    assert s.get("ident.excite") == 0.0
    t = 0.0

    def step(u_fmu, u_core):
        nonlocal t
        s.set("ident.excite", u_fmu)
        s.fmu.doStep(t, 0.5)
        core.set_excitation(u_core)
        core.advance(0.5)
        t += 0.5
        o = core.outputs()
        for n in outs:
            assert s.get(n) == pytest.approx(core_value(o, n), rel=1e-12, abs=1e-12), (t, n)

    try:
        step(1.0, 1.0)
        assert 0.0 < s.get("excite.level") < 1.0                    # ramping up
        n_msgs = len(s.messages)
        step(1.7, 1.0)                                               # clipped, with a warning
        warn = [m for st, _, m in s.messages[n_msgs:] if st == FMI_WARNING]
        assert any("ident.excite" in m and "1.7" in m for m in warn), s.messages
        step(0.5, 0.5)
        step(-3.0, 0.0)
        before = [s.get(n) for n in outs]
        s.set("ident.excite", math.nan)
        with pytest.raises(FMICallException) as exc:
            s.fmu.doStep(t, 0.5)
        assert exc.value.status == FMI_DISCARD
        assert any("ident.excite" in m and "NaN" in m for _, _, m in s.messages)
        assert [s.get(n) for n in outs] == before
        step(0.0, 0.0)                                               # and it goes on
    finally:
        s.free()


def test_fmu_state_carries_the_excitation_ramp(planar_fmus):
    """A state serialised in the middle of a ramp, restored into another instance (whose input
    was never set), continues bit for bit; the level and the input come with it."""
    params = {"excite.ramp": 2.0}
    a = started_slave(planar_fmus["plant"], params, "a")
    b = started_slave(planar_fmus["plant"], params, "b")
    try:
        outs = a.names("output")
        a.set("ident.excite", 1.0)
        a.fmu.doStep(0.0, 0.5)
        a.fmu.doStep(0.5, 0.5)
        level = a.get("excite.level")
        assert 0.0 < level < 1.0                                     # mid-ramp
        st = a.fmu.getFMUstate()
        data = a.fmu.serializeFMUstate(st)
        a.fmu.freeFMUstate(st)
        for t in (1.0, 1.5):
            a.fmu.doStep(t, 0.5)
        ref = [a.get(n) for n in outs]
        s = b.fmu.deSerializeFMUstate(data)
        b.fmu.setFMUstate(s)
        b.fmu.freeFMUstate(s)
        assert b.get("ident.excite") == 1.0 and b.get("excite.level") == level
        for t in (1.0, 1.5):
            b.fmu.doStep(t, 0.5)
        assert [b.get(n) for n in outs] == ref
        assert b.get("excite.level") == pytest.approx(1.0, abs=1e-12)   # the ramp went on
    finally:
        a.free()
        b.free()
