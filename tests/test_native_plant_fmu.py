"""The native plant FMU (fmu_plant/plant.c over native/src/plant.c) through fmpy: what it
claims and carries, and the behaviour its glue adds to the core.

- the model description validates, needsExecutionTool is false, the binaries are the platforms
  it lists, outputs have no direct feedthrough (dependencies ""); resources: the whole robot
  (robot.txt, base and links as the URDF / built-in robot gives them) and the home posture;
- the initial outputs are the robot's home posture at rest and the parameters' initial
  velocities (independent: the scenario's definition);
- a communication step above 100 s is discarded with the outputs unchanged.
The inputs' clipping and NaN, invalid parameters, the FMU's outputs against the library's
Plant: tests/test_fmu_plant.py; lifecycle, reset, FMU state, two instances:
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
from test_conformance_util import DISCARD, Inst


@pytest.fixture(scope="module", params=["planar", "spatial"])
def fmu(request, tmp_path_factory):
    sc = scenario(request.param)
    return sc, build_native_fmu("plant", sc, tmp_path_factory.mktemp(f"nplant_{request.param}"))


@pytest.mark.slow
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


def test_a_communication_step_above_100_s_is_discarded(fmu):
    _, path = fmu
    p = Inst(path, "long").init()
    before = p.values(p.names("output"))
    status, msgs = p.call(p.step, 0.0, 100.5)
    assert status == DISCARD and any("100" in m[2] for m in msgs)
    assert p.values(p.names("output")) == before


