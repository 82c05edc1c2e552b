"""SpaceRobotSensors.fmu in a co-simulation: ideal sensors change nothing (outputs equal
inputs bit for bit, estimates equal the two-FMU run's, in the loop-closed spatial case), a seed
fixes the run, and the SSP with the sensors component runs with its parameter sets."""
from __future__ import annotations

import zipfile

import numpy as np
import pytest
from lxml import etree

from spacerobot import Master
from spacerobot.robots import scenario
from spacerobot.sensors import SensorSuite
from spacerobot.system import ssd
from spacerobot.system.runner import run_ssp
from test_conformance_util import free_instances  # noqa: F401  (autouse fixture)
from test_conformance_util import DT, Inst, plant_samples

N = 30


def _sensors(fmus, params=None):
    return Inst(fmus["sensors"], "sensors").init(params)


def _feed(inst, names, samples):
    """Set each sample as true.<name>, read the outputs <name>, step; (n, len(names))."""
    true = ["true." + n for n in names]
    out = []
    for k, s in enumerate(samples):
        inst.set_many(true, s)
        out.append(list(inst.values(names).values()))
        assert inst.step(k * DT, DT) == 0
    return np.array(out)


def test_ideal_sensors_output_their_inputs_bit_for_bit(spatial_fmus):
    names, samples = plant_samples(spatial_fmus, N)
    samples[3, names.index("thrust.F[1]")] = -0.0            # the sign of a zero survives too
    out = _feed(_sensors(spatial_fmus, {"noise.scale": 0.0}), names, samples)
    assert out.tobytes() == samples.tobytes()


def test_fmu_equals_the_core_and_the_seed_fixes_the_run(planar_fmus):
    names, samples = plant_samples(planar_fmus, N)
    a = _feed(_sensors(planar_fmus, {"seed": 4}), names, samples)
    b = _feed(_sensors(planar_fmus, {"seed": 4}), names, samples)
    c = _feed(_sensors(planar_fmus, {"seed": 5}), names, samples)
    assert a.tobytes() == b.tobytes() and not np.array_equal(a, c)
    # the FMU maps variables to its core: the core (no FMI) on the same samples gives the same
    # bits
    sc = scenario("planar")
    core = SensorSuite(sc.robot.n_joints, seed=4, dt=sc.sample_time)
    from spacerobot.interface import measurement_vars
    keys = {v.name: v.key for v in measurement_vars(sc.robot.n_joints, "input")}
    shapes = {"A": (3, 3), "q": (3,), "qd": (3,), "qdd": (3,)}
    for k, s in enumerate(samples):
        x = {}
        for name, v in zip(names, s):
            g, i = keys[name]
            x.setdefault(g, np.zeros(shapes.get(g, (3,))))[i] = v
        y = core.update(x, DT)
        assert np.array_equal(a[k], [y[keys[n][0]][keys[n][1]] for n in names])


def _pair_run(fmus, robot, sensors_params=None, n=N):
    """Plant -> [sensors ->] estimator with the excitation loop closed, wired as the SSD
    (ssd.system_connections); the estimator outputs at every point."""
    comps = {"plant": Inst(fmus["plant"], "plant").init()}
    if sensors_params is not None:
        comps["sensors"] = Inst(fmus["sensors"], "sensors").init(sensors_params)
    comps["estimator"] = Inst(fmus["estimator"], "estimator").init()
    m = Master(comps, ssd.system_connections(robot, sensors_params is not None))
    est = comps["estimator"]
    names = est.names("output")
    rows = []
    for k in range(n):
        m.step(k * DT, DT)
        rows.append(list(est.values(names).values()))
    return np.array(rows)


def test_estimates_with_ideal_sensors_equal_the_two_fmu_run(spatial_fmus):
    two = _pair_run(spatial_fmus, "spatial")
    ideal = _pair_run(spatial_fmus, "spatial", {"noise.scale": 0.0})
    assert ideal.tobytes() == two.tobytes()
    noisy = _pair_run(spatial_fmus, "spatial", {"noise.scale": 1.0})
    assert not np.array_equal(noisy, two)                     # negative control


@pytest.fixture(scope="module")
def sensors_system(tmp_path_factory, planar_fmus):
    return ssd.build_system("planar", tmp_path_factory.mktemp("sens"), fmus=planar_fmus,
                            sensors=True)


def test_sensors_ssd_validates_and_wires_through_the_sensors(sensors_system):
    from test_system import SCHEMA_DIR
    sd = etree.XMLSchema(file=str(SCHEMA_DIR / "SystemStructureDescription.xsd"))
    sv = etree.XMLSchema(file=str(SCHEMA_DIR / "SystemStructureParameterValues.xsd"))
    with zipfile.ZipFile(sensors_system["ssp"]) as zf:
        members = set(zf.namelist())
        for name in members:
            if name.endswith((".ssd", ".ssv")):
                schema = sd if name.endswith(".ssd") else sv
                assert schema.validate(etree.fromstring(zf.read(name))), name
    assert "resources/SpaceRobotSensors.fmu" in members
    assert {"resources/ideal.ssv", "resources/realistic.ssv", "resources/medium.ssv",
            "resources/sensors/ideal.ssv", "resources/sensors/realistic.ssv"} <= members
    # each component is bound only to variables it has (OMSimulator: "Unknown signal")
    from spacerobot.interface import plant_vars, sensors_vars
    sc = scenario("planar")
    has = {"resources": {v.name for v in plant_vars(sc.robot, sc)},
           "sensors": {v.name for v in sensors_vars(sc.robot, sc)}}
    with zipfile.ZipFile(sensors_system["ssp"]) as zf:
        for name in members:
            folder = (["", *name.split("/")])[-2]
            if name.endswith(".ssv") and folder in has:
                bound = {p.get("name") for p in etree.fromstring(zf.read(name)).iter(
                    "{*}Parameter")}
                assert bound and bound <= has[folder], (name, bound - has[folder])
    assert ssd.robot_of(sensors_system["ssp"]) == "planar"
    conns = ssd.system_connections("planar", sensors=True)
    est_inputs = {b for _, _, c, b in conns if c == "estimator"}
    assert all(a == "sensors" for a, _, c, _ in conns if c == "estimator")
    assert {f"true.{n}" for n in est_inputs} == {b for a, _, c, b in conns if c == "sensors"}
    # the two-FMU system has no noise sets
    assert "ideal" not in ssd.parameter_set_names("planar")


@pytest.mark.slow
def test_sensors_system_parameter_sets(sensors_system, planar_fmus, tmp_path):
    two = ssd.build_system("planar", tmp_path / "two", fmus=planar_fmus)
    ref = run_ssp(two["ssp"], parameter_set="excited", stop_time=2.0, progress=False)
    ideal = run_ssp(sensors_system["ssp"], parameter_set="ideal", stop_time=2.0, progress=False)
    real = run_ssp(sensors_system["ssp"], stop_time=2.0, progress=False)   # bound: realistic
    assert ideal.final == ref.final and ideal.truth == ref.truth
    for col in ref.data:
        if col.startswith("estimator."):
            assert np.array_equal(ideal.data[col], ref.data[col]), col
    assert real.parameter_set is None and real.final != ref.final
    # the noise level reached the sensors: realistic gyro errors of the configured size
    err = real.data["sensors.base.omega[3]"] - real.data["plant.base.omega[3]"]
    assert 0 < np.abs(err).max() < 1e-3


def test_command_line_runs_the_sensors_system(tmp_path, capsys):
    from spacerobot.system.cli import main
    from spacerobot.system.recorder import read_csv

    csv = tmp_path / "run.csv"
    assert main(["run", "--robot", "planar", "--sensors", "--target", "ideal", "--stop-time",
                 "1", "--build-dir", str(tmp_path / "build"), "--out", str(csv),
                 "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "planar_sensors.ssp" in out and "parameter set ideal" in out
    data = read_csv(csv)
    assert np.array_equal(data["sensors.base.v[1]"], data["plant.base.v[1]"])   # ideal
    assert np.array_equal(data["estimator.base.v[1]"], data["sensors.base.v[1]"])
