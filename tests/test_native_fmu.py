"""The estimator FMU (C core, shared FMI 2.0 layer; spacerobot/fmi/native.py) in fmpy: its model
description, what it carries (no truth), its results against the truth in the project's own
co-simulation loop, and its state through bytes into another instance."""
from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, supported_platforms
from fmpy.validation import validate_fmu

from spacerobot import interface
from spacerobot.fmi.build import build_fmu
from spacerobot.fmi.native import PLACEHOLDER_BODY, binaries
from spacerobot.robots import scenario

from conftest import Slave, logged_slave, relative_errors, truth_vector

ESTIMATES = list(interface.ESTIMATE_NAMES)
SDS = [f"sd.{n}" for n in ESTIMATES]


@pytest.fixture(scope="module")
def native_fmus(tmp_path_factory):
    out = tmp_path_factory.mktemp("native")
    return {r: build_fmu("estimator", scenario(r), out / r)
            for r in ("planar", "spatial")}


@pytest.mark.parametrize("robot", ["planar", "spatial"])
@pytest.mark.slow
def test_model_description_is_valid_and_claims_what_it_carries(native_fmus, robot):
    path = native_fmus[robot]
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    assert md.coSimulation.needsExecutionTool is False
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    # the platforms it claims are exactly the binaries it carries, those the install built
    carried = {n.split("/")[1] for n in zipfile.ZipFile(path).namelist() if n.startswith("binaries/")}
    assert set(supported_platforms(str(path))) == carried == set(binaries("SpaceRobotEstimator"))
    assert "linux64" in carried
    # the same variables as the interface table, in the same order, names, units, causality
    sc = scenario(robot)
    table = interface.estimator_vars(sc.robot, sc)
    assert [(v.name, v.causality, v.variability, v.type) for v in md.modelVariables] == \
        [(v.name, v.causality, v.variability, v.type) for v in table]
    assert [v.unit for v in md.modelVariables if v.type == "Real"] == \
        [v.unit for v in table if v.type == "Real"]
    # every output declared, none depending on an input (no direct feedthrough)
    outs = [v for v in md.modelVariables if v.causality == "output"]
    assert [u.variable for u in md.outputs] == outs
    assert all(u.dependencies == [] for u in md.outputs)


def test_the_estimator_carries_no_truth(native_fmus):
    """Its robot record has the known arm and a placeholder base; the truth of the base (the
    URDF's base body) and of the target appear nowhere in the FMU's files."""
    from spacerobot.core.robot_record import hex_double, parse_robot_record

    sc = scenario("spatial")
    with zipfile.ZipFile(native_fmus["spatial"]) as z:
        record = parse_robot_record(z.read("resources/robot.txt").decode())
        texts = [z.read(n).decode() for n in z.namelist() if not n.startswith("binaries/")]
    assert record["base"]["mass"] == PLACEHOLDER_BODY.mass
    for truth in (sc.robot.base.mass, sc.target.mass, sc.robot.base.inertia[0], sc.target.inertia[0]):
        assert not any(hex_double(truth) in t or repr(float(truth)) in t for t in texts), truth


def _run(plant_fmus, estimator_path, stop, params=None):
    """The plant FMU wired to the estimator FMU (which closes the excitation loop); returns the
    estimator's outputs after each step and its messages."""
    from spacerobot import Master

    plant = Slave(plant_fmus["plant"], "plant").init()
    est = logged_slave(estimator_path, "estimator").init(params)
    conns = [("plant", n, "estimator", n) for n in est.names("input")]
    conns.append(("estimator", "ident.excite", "plant", "ident.excite"))
    master = Master({"plant": plant, "estimator": est}, conns)
    rec = []
    t, dt = 0.0, 0.1
    for _ in range(int(round(stop / dt))):
        master.exchange()
        master.do_step(t, dt)
        t += dt
        rec.append([est.get(n) for n in ESTIMATES])
    messages = est.messages
    for s in (plant, est):
        s.free()
    return rec, messages


def test_native_identifies_the_paper_scenario(planar_fmus, native_fmus):
    """Noise-free, planar medium target, momentum: every identified estimate within 0.1 % of the
    truth after 20 s (the paper: within 0.1 % in under 20 s)."""
    rec, msgs = _run(planar_fmus, native_fmus["planar"], 20.0)
    est = np.array(rec[-1])
    sc = scenario("planar")
    err = relative_errors(est, truth_vector(sc))
    ident = [ESTIMATES.index(n) for n in interface.identified_estimates(sc.robot)]
    assert err[ident].max() < 1e-3, dict(zip(np.array(ESTIMATES)[ident], err[ident]))
    assert not [m for st, _, m in msgs if st >= 2], msgs


def test_state_round_trip_through_bytes_into_another_instance(native_fmus):
    """Serialised at t = 3 s, restored into a second instance: both continue identically (the
    same binary and state: bit for bit)."""
    path = native_fmus["planar"]
    a, b = (logged_slave(path, n).init() for n in ("a", "b"))
    rng = np.random.default_rng(1)
    inputs = a.names("input")
    A_pos = [inputs.index(f"base.A[{i},{i}]") for i in (1, 2, 3)]

    def sample():
        x = rng.normal(size=len(inputs))
        x[[inputs.index(n) for n in inputs if n.startswith("base.A")]] = 0.0
        x[A_pos] = 1.0
        return x

    t = 0.0
    for _ in range(30):
        a.set_many(inputs, sample())
        a.fmu.doStep(t, 0.1)
        t += 0.1
    state = a.fmu.getFMUstate()
    data = a.fmu.serializeFMUstate(state)
    a.fmu.freeFMUstate(state)
    st_b = b.fmu.deSerializeFMUstate(data)
    b.fmu.setFMUstate(st_b)
    b.fmu.freeFMUstate(st_b)
    for _ in range(20):
        x = sample()
        for s in (a, b):
            s.set_many(inputs, x)
            s.fmu.doStep(t, 0.1)
        t += 0.1
    outs = a.names("output")
    assert [a.get(n) for n in outs] == [b.get(n) for n in outs]
    a.free()
    b.free()
