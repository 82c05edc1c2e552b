"""The native plant FMU (fmu_plant/plant.c over native/src/plant.c) through fmpy: what it
claims and carries, and the behaviour its glue adds to the core.

- the model description validates, needsExecutionTool is false, the binaries are the platforms
  it lists, outputs have no direct feedthrough (dependencies ""); resources: the whole robot
  (robot.txt, base and links as the URDF / built-in robot gives them) and the home posture;
- the initial outputs are the robot's home posture at rest and the parameters' initial
  velocities (independent: the scenario's definition);
- ident.excite: NaN discards the step with the state unchanged (the following steps equal a
  run that never saw it), a value outside [0, 1] is clipped with a warning (equal to the
  clipped value's run); a communication step above 100 s is discarded;
- invalid parameters are refused at fmi2ExitInitializationMode with the parameter named.
The FMU's outputs against the library's Plant, lifecycle, reset, FMU state, two instances:
tests/test_conformance_*.py (they run on every FMU kind the default build makes).
"""
from __future__ import annotations

import zipfile

import numpy as np
import pytest

from spacerobot.core.robot_record import parse_robot_record
from spacerobot.fmi.native import build_native_fmu
from spacerobot.robots import scenario
from test_conformance_util import free_instances  # noqa: F401  (autouse fixture)
from test_conformance_util import DISCARD, DT, ERROR, OK, WARNING, Inst


@pytest.fixture(scope="module", params=["planar", "spatial"])
def fmu(request, tmp_path_factory):
    sc = scenario(request.param)
    return sc, build_native_fmu("plant", sc, tmp_path_factory.mktemp(f"nplant_{request.param}"))


def test_model_description_claims_what_it_carries(fmu):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    sc, path = fmu
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    assert md.coSimulation.needsExecutionTool is False
    assert all(o.dependencies == [] for o in md.outputs) and md.outputs
    with zipfile.ZipFile(path) as zf:
        names = zf.namelist()
        robot = parse_robot_record(zf.read("resources/robot.txt").decode())
        scen = zf.read("resources/scenario.txt").decode()
    plats = {n.split("/")[1] for n in names if n.startswith("binaries/")}
    assert "linux64" in plats and plats <= {"linux64", "win64"}
    b = sc.robot.base                 # the plant carries the real base (it is the truth)
    assert robot["base"]["mass"] == b.mass and list(robot["base"]["com"]) == list(b.com)
    assert robot["n"] == sc.robot.n_joints
    assert sum(line.startswith("q_home.") for line in scen.splitlines()) == sc.robot.n_joints


def test_initial_outputs_are_the_home_posture_at_rest(fmu):
    sc, path = fmu
    p = Inst(path, "init").init()
    n = sc.robot.n_joints
    out = p.values([f"arm.q[{i + 1}]" for i in range(n)] + [f"arm.qd[{i + 1}]" for i in range(n)]
                   + ["base.v[1]", "base.v[2]", "base.omega[3]"])
    assert np.array_equal([out[f"arm.q[{i + 1}]"] for i in range(n)], np.asarray(sc.robot.q0))
    assert all(out[f"arm.qd[{i + 1}]"] == 0.0 for i in range(n))
    assert [out["base.v[1]"], out["base.v[2]"]] == list(sc.v0[:2])
    assert out["base.omega[3]"] == sc.omega0[2]


def _run(path, levels, name="run"):
    """Outputs after each step, ident.excite = levels[k] before step k; (statuses, rows)."""
    p = Inst(path, name).init()
    outs = p.names("output")
    rows, statuses = [], []
    t = 0.0
    for u in levels:
        p.set("ident.excite", u)
        st, _ = p.call(p.step, t, DT)
        statuses.append(st)
        if st == OK:
            t += DT
        rows.append(list(p.values(outs).values()))
    return statuses, np.array(rows), p


def test_nan_excitation_discards_the_step_and_keeps_the_state(fmu):
    _, path = fmu
    ref_st, ref, _ = _run(path, [0.5, 0.5, 0.5])
    st, rows, p = _run(path, [0.5, float("nan"), 0.5, 0.5])
    assert st == [OK, DISCARD, OK, OK] and ref_st == [OK] * 3
    assert np.array_equal(rows[1], rows[0])           # outputs as before the refused step
    assert np.array_equal(rows[[0, 2, 3]], ref)       # and the run goes on as if never asked
    assert any("NaN" in m[2] for m in p.messages)


def test_excitation_outside_0_1_is_clipped_with_a_warning(fmu):
    _, path = fmu
    _, ref, _ = _run(path, [1.0, 0.0])
    st, rows, p = _run(path, [7.0, -3.0])
    assert st == [OK, OK] and np.array_equal(rows, ref)
    assert sum(m[0] == WARNING and "ident.excite" in m[2] for m in p.messages) == 2


def test_a_communication_step_above_100_s_is_discarded(fmu):
    _, path = fmu
    p = Inst(path, "long").init()
    before = p.values(p.names("output"))
    status, msgs = p.call(p.step, 0.0, 100.5)
    assert status == DISCARD and any("100" in m[2] for m in msgs)
    assert p.values(p.names("output")) == before


@pytest.mark.parametrize("name, value", [("target.m", -1.0), ("h", 0.0), ("F_max", -2.0),
                                         ("excite.ramp", 0.0), ("prop.Isp", -1.0),
                                         ("base.Ixx", 1e9)])
def test_invalid_parameters_are_refused_by_name(fmu, name, value):
    _, path = fmu
    p = Inst(path, "bad")
    p.fmu.setupExperiment(startTime=0.0)
    p.fmu.enterInitializationMode()
    assert p.set(name, value) == OK
    status, msgs = p.call(p.fmu.exitInitializationMode)
    stem = name.split(".")[0] if name.startswith("base.") else name
    assert status == ERROR and any(stem in m[2] for m in msgs), msgs
