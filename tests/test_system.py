"""The system layer: generated SSD/SSV, .ssp packaging, the SSD-honouring runner, fmpy interop."""
from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
from lxml import etree

import fmpy
import fmpy.ssp.ssd
from fmpy import read_model_description

from spacerobot import SimulationError, interface, read_csv, run_ssp
from spacerobot.robots import ROBOTS, TARGETS, scenario
from spacerobot.system import runner, ssd
from spacerobot.system.master import Master

NS = ssd.NS
SCHEMA_DIR = Path(fmpy.__file__).parent / "ssp" / "schema"
ROBOT_NAMES = sorted(ROBOTS)


@pytest.fixture(scope="session")
def systems(tmp_path_factory, planar_fmus, spatial_fmus) -> dict:
    """``{robot: build_system paths}``; the planar FMUs come from the shared session build, the
    spatial system is built from scratch (exercises the FMU build inside build_system)."""
    root = tmp_path_factory.mktemp("systems")
    return {"planar": ssd.build_system("planar", root / "planar", fmus=planar_fmus),
            "spatial": ssd.build_system("spatial", root / "spatial")}


@pytest.fixture(scope="session")
def planar_baseline(systems):
    """A 1 s planar run with the parameter set bound in the SSD."""
    return run_ssp(systems["planar"]["ssp"], stop_time=1.0, progress=False)


def _extract(ssp: Path, dest: Path) -> Path:
    with zipfile.ZipFile(ssp) as zf:
        zf.extractall(dest)
    return dest


def _fmu_unit(v):
    return v.unit or (v.declaredType.unit if v.declaredType is not None else None)


# ---------------------------------------------------------------------------------------------
# generated files
# ---------------------------------------------------------------------------------------------

@pytest.mark.parametrize("robot", ROBOT_NAMES)
def test_committed_ssp_files_equal_generator_output(robot):
    folder = ssd.SSP_SOURCE_DIR / robot
    generated = ssd.generate(robot)
    on_disk = {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()}
    assert on_disk == set(generated), "ssp/ is stale: run `python -m spacerobot.system.ssd`"
    for rel, text in generated.items():
        assert (folder / rel).read_text(encoding="utf-8") == text, \
            f"ssp/{robot}/{rel} differs from the generator: run `python -m spacerobot.system.ssd`"


@pytest.mark.slow
def test_write_ssp_sources_writes_every_robot(tmp_path):
    written = ssd.write_ssp_sources(tmp_path)
    assert {p.relative_to(tmp_path).parts[0] for p in written} == set(ROBOTS)
    for p in written:
        robot = p.relative_to(tmp_path).parts[0]
        assert p.read_text() == ssd.generate(robot)[p.relative_to(tmp_path / robot).as_posix()]


@pytest.mark.parametrize("robot", ROBOT_NAMES)
def test_ssd_and_ssv_validate_against_ssp_schemas(robot, systems):
    sd = etree.XMLSchema(file=str(SCHEMA_DIR / "SystemStructureDescription.xsd"))
    sv = etree.XMLSchema(file=str(SCHEMA_DIR / "SystemStructureParameterValues.xsd"))
    with zipfile.ZipFile(systems[robot]["ssp"]) as zf:
        members = zf.namelist()
        for name in members:
            if name.endswith((".ssd", ".ssv")):
                doc = etree.fromstring(zf.read(name))
                schema = sd if name.endswith(".ssd") else sv
                assert schema.validate(doc), f"{robot} {name}: {schema.error_log}"
    assert "SystemStructure.ssd" in members
    assert {"resources/SpaceRobotPlant.fmu", "resources/SpaceRobotEstimator.fmu"} <= set(members)
    assert {f"resources/{n}.ssv" for n in TARGETS[robot]} <= set(members)
    # fmpy's own reader validates too and sees the component-level binding
    desc = fmpy.ssp.ssd.read_ssd(str(systems[robot]["ssp"]), validate=True)
    plant = next(e for e in desc.system.elements if e.name == "plant")
    assert [b.source for b in plant.parameterBindings] == \
        [f"resources/{ssd.default_parameter_set(robot)}.ssv"]


def test_schema_rejects_a_broken_ssd():
    """The validation above can fail: an SSD without version is rejected."""
    sd = etree.XMLSchema(file=str(SCHEMA_DIR / "SystemStructureDescription.xsd"))
    doc = etree.fromstring(ssd.ssd_xml("planar").encode())
    del doc.attrib["version"]
    assert not sd.validate(doc)


@pytest.mark.parametrize("robot", ROBOT_NAMES)
def test_ssd_tool_conventions(robot):
    """Prefixes, flat root System, typed connectors with declared units, step size and
    default experiment where OMSimulator and libcosim look for them."""
    text = ssd.ssd_xml(robot)
    root = etree.fromstring(text.encode())
    sc = scenario(robot)
    assert root.get("version") == "1.0"
    for prefix in ("ssd", "ssc", "ssv"):
        assert root.nsmap[prefix] == NS[prefix]
    for el in root.iter():
        if isinstance(el.tag, str):
            uri = etree.QName(el).namespace
            assert el.prefix == {v: k for k, v in NS.items()}[uri]
    system = root.find("ssd:System", NS)
    assert system.find("ssd:Elements/ssd:System", NS) is None
    comps = system.findall("ssd:Elements/ssd:Component", NS)
    assert {c.get("name"): c.get("source") for c in comps} == {
        "plant": "resources/SpaceRobotPlant.fmu", "estimator": "resources/SpaceRobotEstimator.fmu"}
    units = {u.get("name") for u in root.findall("ssd:Units/ssc:Unit", NS)}
    for c in system.iter(f"{{{NS['ssd']}}}Connector"):
        types = list(c)
        assert len(types) == 1 and etree.QName(types[0]).localname in ("Real", "Integer")
        if etree.QName(types[0]).localname == "Real":
            assert types[0].get("unit") in units, c.get("name")
    oms = system.find("ssd:Annotations/ssc:Annotation[@type='org.openmodelica']/oms:Annotations/"
                      "oms:SimulationInformation/oms:FixedStepMaster", NS)
    assert float(oms.get("stepSize")) == sc.sample_time == 0.1
    de = root.find("ssd:DefaultExperiment", NS)
    assert float(de.get("startTime")) == 0.0
    assert float(de.get("stopTime")) == sc.stop_time
    osp = de.find("ssd:Annotations/ssc:Annotation[@type='com.opensimulationplatform']/"
                  "osp:Algorithm/osp:FixedStepAlgorithm", NS)
    assert float(osp.get("baseStepSize")) == sc.sample_time
    binding = system.find("ssd:Elements/ssd:Component[@name='plant']/ssd:ParameterBindings/"
                          "ssd:ParameterBinding", NS)
    assert binding.get("source") == f"resources/{ssd.default_parameter_set(robot)}.ssv"
    assert system.find("ssd:ParameterBindings", NS) is None      # component level only


@pytest.mark.parametrize("robot", ROBOT_NAMES)
def test_connections_match_interface_and_built_fmus(robot, systems):
    root = etree.parse(str(systems[robot]["ssd"])).getroot()
    md = {"plant": read_model_description(str(systems[robot]["plant"])),
          "estimator": read_model_description(str(systems[robot]["estimator"]))}
    mv = {k: {v.name: v for v in m.modelVariables} for k, m in md.items()}
    conns = root.findall("ssd:System/ssd:Connections/ssd:Connection", NS)
    names = [c.get("startConnector") for c in conns]
    assert names == interface.connections(ROBOTS[robot]) + interface.feedback_connections()
    for dest in ("plant", "estimator"):
        inputs = {n for n, v in mv[dest].items() if v.causality == "input"}
        assert {c.get("endConnector") for c in conns if c.get("endElement") == dest} == inputs, \
            f"every {dest} input must be connected"
    for c in conns:
        ends = (c.get("startElement"), c.get("endElement"))
        feedback = c.get("startConnector") in interface.feedback_connections()
        assert ends == (("estimator", "plant") if feedback else ("plant", "estimator"))
        assert c.get("startConnector") == c.get("endConnector")
        a = mv[ends[0]][c.get("startConnector")]
        b = mv[ends[1]][c.get("endConnector")]
        assert (a.causality, b.causality) == ("output", "input")
        assert a.type == b.type
        assert _fmu_unit(a) == _fmu_unit(b) is not None
    # every declared connector exists in its FMU with matching causality, type and unit
    kind_ok = {"output": "output", "input": "input", "parameter": "parameter"}
    for comp in root.findall("ssd:System/ssd:Elements/ssd:Component", NS):
        for k in comp.findall("ssd:Connectors/ssd:Connector", NS):
            v = mv[comp.get("name")][k.get("name")]
            assert v.causality == kind_ok[k.get("kind")], (comp.get("name"), k.get("name"))
            typ = list(k)[0]
            assert etree.QName(typ).localname == v.type
            assert typ.get("unit") == _fmu_unit(v)


@pytest.mark.parametrize("robot", ROBOT_NAMES)
def test_ssv_values_are_the_scenario_truth(robot, systems):
    for name, target in TARGETS[robot].items():
        doc = etree.parse(str(systems[robot][f"ssv:{name}"])).getroot()
        vals = {p.get("name"): float(list(p)[0].get("value"))
                for p in doc.findall("ssv:Parameters/ssv:Parameter", NS)}
        sc = scenario(robot, name)
        assert vals["flex.n"] == vals["slosh.n"] == 0            # the rigid spacecraft
        assert vals["target.m"] == target.mass
        assert [vals[f"target.b[{i}]"] for i in (1, 2, 3)] == list(target.com)
        assert [vals[f"target.{n}"] for n in ("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")] == \
            list(target.inertia)
        assert vals["base.m"] == ROBOTS[robot].base.mass
        assert [vals[f"base.v0[{i}]"] for i in (1, 2, 3)] == list(sc.v0)
        assert [vals[f"base.omega0[{i}]"] for i in (1, 2, 3)] == list(sc.omega0)


def test_run_pairs_estimates_with_truths_by_name(planar_baseline):
    """The runner knows no estimator names: it pairs every estimator output with the plant
    parameter of the same name, which gives exactly the 20 estimates of the interface."""
    sc = scenario("planar")
    est_out = [v.name for v in interface.estimator_vars(sc.robot, sc)
               if v.causality == "output" and v.key[0] in ("est_base", "est_target")]
    res = planar_baseline
    assert list(res.final) == list(res.truth) == est_out == list(interface.ESTIMATE_NAMES)
    for n in est_out:
        assert res.final[n] == res.data[f"estimator.{n}"][-1]
        assert res.truth[n] == res.data[f"plant.{n}"][-1]
    # relative errors: finite everywhere, also where the truth is zero (scale COM_SCALE_MIN for b)
    rel = res.relative_errors()
    assert list(rel) == est_out and all(np.isfinite(list(rel.values())))
    zero = [n for n in est_out if res.truth[n] == 0.0 and ".b[" in n]
    assert zero, "the planar scenario has a zero CoM component"
    for n in zero:
        assert rel[n] == abs(res.final[n]) / interface.COM_SCALE_MIN
    assert rel["target.m"] == abs(res.final["target.m"] - 250.0) / 250.0


class _FakeVar:
    def __init__(self, vr, type_="Real"):
        self.valueReference, self.type = vr, type_


class _FakeFMU:
    """Output value reference 0 = 10 * (instance number) + steps taken; input vr 1."""

    def __init__(self, base, log):
        self.base, self.k, self.u, self.log = base, 0, None, log

    def getReal(self, vrs):
        self.log.append(("get", self.base))
        return [float(self.base + self.k) for _ in vrs]

    def setReal(self, vrs, values):
        self.log.append(("set", self.base))
        self.u = list(values)

    def doStep(self, currentCommunicationPoint, communicationStepSize):
        self.k += 1


class _Fake:
    def __init__(self, base, log):
        self.fmu = _FakeFMU(base, log)
        self.vars = {"y": _FakeVar(0), "u": _FakeVar(1)}

    def var(self, n):
        return self.vars[n]


def test_master_wires_connections_in_both_directions():
    """a.y -> b.u and b.y -> a.u (a feedback loop): outputs change only in doStep, so each
    input gets its source's value at t, whatever the component order."""
    log = []
    a, b = _Fake(10, log), _Fake(20, log)
    m = Master({"a": a, "b": b}, [("a", "y", "b", "u"), ("b", "y", "a", "u")])
    for k in range(3):
        m.step(0.1 * k, 0.1)
        assert b.fmu.u == [10.0 + k] and a.fmu.u == [20.0 + k]
    assert (a.fmu.k, b.fmu.k) == (3, 3)
    assert log[:4] == [("get", 10), ("set", 20), ("get", 20), ("set", 10)]
    with pytest.raises(SimulationError, match="types differ"):
        a.vars["i"] = _FakeVar(2, "Integer")
        Master({"a": a, "b": b}, [("a", "i", "b", "u")])


class _Feedthrough(_Fake):
    """Output = the input set last (a direct feedthrough, like the sensors FMU)."""

    def __init__(self, log):
        super().__init__(0, log)
        self.fmu.getReal = lambda vrs: list(self.fmu.u or [0.0]) * len(vrs)


def test_master_passes_a_feedthrough_on_within_the_point():
    """a.y -> f.u, f.y -> b.u in that order: b gets a's value at t at the same point."""
    log = []
    a, f, b = _Fake(10, log), _Feedthrough(log), _Fake(20, log)
    m = Master({"a": a, "f": f, "b": b}, [("a", "y", "f", "u"), ("f", "y", "b", "u")])
    for k in range(3):
        m.step(0.1 * k, 0.1)
        assert b.fmu.u == [10.0 + k]


# ---------------------------------------------------------------------------------------------
# the runner
# ---------------------------------------------------------------------------------------------

def test_run_applies_bound_set_and_records_everything(systems, planar_baseline):
    res = planar_baseline
    sc = scenario("planar", ssd.default_parameter_set("planar"))
    np.testing.assert_allclose(res.time, np.arange(11) * 0.1, atol=1e-12)
    assert res.truth["target.m"] == sc.target.mass == 250.0
    assert res.truth["base.Izz"] == sc.robot.base.inertia[2]
    assert res.data["plant.base.v[1]"][0] == pytest.approx(sc.v0[0])
    assert res.data["plant.base.omega[3]"][0] == pytest.approx(sc.omega0[2])
    # every connector and every estimator output is a column
    root = etree.parse(str(systems["planar"]["ssd"])).getroot()
    for comp in root.findall("ssd:System/ssd:Elements/ssd:Component", NS):
        for k in comp.findall("ssd:Connectors/ssd:Connector", NS):
            assert f"{comp.get('name')}.{k.get('name')}" in res.data
    md = read_model_description(str(systems["planar"]["estimator"]))
    for v in md.modelVariables:
        if v.causality == "output":
            assert f"estimator.{v.name}" in res.data
    # wiring: the estimator input equals the plant output at every communication point
    for n in interface.connections(ROBOTS["planar"]):
        np.testing.assert_array_equal(res.data[f"estimator.{n}"], res.data[f"plant.{n}"])
    # the estimator consumed one sample per step (the first one is the momentum reference)
    assert res.data["estimator.diag.status"][-1] == 2
    assert np.all(np.diff(res.data["estimator.diag.samples"][1:]) == 1)
    assert set(res.final) == set(interface.ESTIMATE_NAMES)
    assert res.final["target.m"] == res.data["estimator.target.m"][-1]


def test_run_honours_default_experiment_and_step_size_of_an_extracted_dir(systems, tmp_path):
    d = _extract(systems["planar"]["ssp"], tmp_path / "sys")
    p = d / "SystemStructure.ssd"
    text = p.read_text()
    text = text.replace('stopTime="30.0"', 'stopTime="0.75"')
    text = text.replace('stepSize="0.1"', 'stepSize="0.25"')
    text = text.replace('baseStepSize="0.1"', 'baseStepSize="0.25"')
    p.write_text(text)
    res = run_ssp(d, progress=False)
    np.testing.assert_allclose(res.time, [0.0, 0.25, 0.5, 0.75])
    assert res.step_size == 0.25 and res.stop_time == 0.75


def test_stop_time_off_the_grid_gets_a_shorter_last_step(systems):
    res = run_ssp(systems["planar"]["ssp"], stop_time=0.25, progress=False)
    np.testing.assert_allclose(res.time, [0.0, 0.1, 0.2, 0.25], atol=1e-12)
    assert res.stop_time == 0.25
    assert np.all(np.diff(res.data["plant.base.r[1]"]) > 0)      # the plant moved on each step
    with pytest.raises(ValueError, match="stop_time"):
        run_ssp(systems["planar"]["ssp"], stop_time=-1.0)


def test_editing_an_ssv_changes_the_plant_truth(systems, planar_baseline, tmp_path):
    d = _extract(systems["planar"]["ssp"], tmp_path / "sys")
    ssv = d / "resources" / f"{ssd.default_parameter_set('planar')}.ssv"
    text = ssv.read_text()
    old = '<ssv:Parameter name="target.m">\n      <ssv:Real value="250.0"'
    assert old in text
    ssv.write_text(text.replace(old, old.replace("250.0", "300.0")))
    res = run_ssp(d, stop_time=1.0, progress=False)
    assert res.truth["target.m"] == 300.0
    assert np.all(res.data["plant.target.m"] == 300.0)
    # the total linear momentum depends on the target mass
    P0 = res.data["plant.system.P[1]"][0]
    assert abs(P0 - planar_baseline.data["plant.system.P[1]"][0]) > 1.0


def test_named_parameter_set_replaces_the_bound_one(systems, planar_baseline):
    res = run_ssp(systems["planar"]["ssp"], parameter_set="large", stop_time=0.5, progress=False)
    large = TARGETS["planar"]["large"]
    assert res.parameter_set == "large"
    assert res.truth["target.m"] == large.mass == 500.0
    assert res.truth["target.Izz"] == pytest.approx(large.inertia[2])
    assert res.data["plant.system.P[1]"][0] != pytest.approx(
        planar_baseline.data["plant.system.P[1]"][0])
    with pytest.raises(ValueError, match=r"unknown parameter set 'huge'.*large.*medium.*small"):
        run_ssp(systems["planar"]["ssp"], parameter_set="huge", stop_time=0.5)


def test_depletion_set_runs_and_its_truth_is_the_current_base(systems):
    """Spatial set ``depletion`` (issue #17) through the SSP: the plant uses propellant, and the
    run's truth of a base parameter is the plant's current ``truth.base.*`` output, not the
    dry-base parameter of the same name."""
    res = run_ssp(systems["spatial"]["ssp"], parameter_set="depletion", stop_time=1.0,
                  progress=False)
    d = res.data
    dry = ROBOTS["spatial"].base.mass
    assert d["plant.prop.m"][0] == 80.0 and d["plant.prop.m"][-1] < 80.0 - 0.01
    assert d["plant.truth.base.m"][-1] == pytest.approx(dry + d["plant.prop.m"][-1], rel=1e-15)
    assert res.truth["base.m"] == d["plant.truth.base.m"][-1] != dry
    assert res.truth["base.b[1]"] == d["plant.truth.base.b[1]"][-1]
    assert res.truth["target.m"] == TARGETS["spatial"]["default"].mass


def test_flexible_set_runs_and_its_truth_is_the_composite_rigid_base(systems):
    """Spatial set ``flexible`` through the SSP: the wings and the slosh masses move, and the
    run's truth of a base parameter is the composite rigid base (the base with the wings at
    rest and the slosh masses at their equilibrium: Pinocchio's sum of the inertias,
    tests/oracles/flexible_pinocchio.py), not the base parameter of the same name."""
    from oracles import flexible_pinocchio as fp
    from spacerobot.robots import parameter_set_scenario

    res = run_ssp(systems["spatial"]["ssp"], parameter_set="flexible", stop_time=2.0,
                  progress=False)
    d = res.data
    assert np.abs(d["plant.flex.q[1]"]).max() > 1e-5 and np.abs(d["plant.slosh.x[1]"]).max() > 1e-4
    sc = parameter_set_scenario("spatial", "flexible")
    fm = fp.build(sc.robot, sc.robot.base, sc.target, sc.flex.active, sc.slosh.active)
    composite = fp.composite(fm)
    names = ("m", "b[1]", "b[2]", "b[3]", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")
    for k, n in enumerate(names):
        assert res.truth[f"base.{n}"] == d[f"plant.truth.base.{n}"][-1]
        assert res.truth[f"base.{n}"] == pytest.approx(composite[k], rel=1e-12, abs=1e-12), n
    assert res.truth["base.m"] == 650.0 != ROBOTS["spatial"].base.mass


def test_overrides_reach_both_components(systems, planar_baseline):
    res = run_ssp(systems["planar"]["ssp"], stop_time=1.0, progress=False,
                  overrides={"plant.base.v0[1]": 5.0, "estimator.method": 2})
    assert res.data["plant.base.v[1]"][0] == pytest.approx(5.0)
    assert res.data["plant.base.v0[1]"][0] == 5.0
    # force-based estimates differ from the momentum-based baseline
    assert res.final["target.m"] != pytest.approx(planar_baseline.final["target.m"], rel=1e-9)
    with pytest.raises(KeyError, match=r"no variable 'base\.mass'.*base\.m"):
        run_ssp(systems["planar"]["ssp"], stop_time=0.5, overrides={"plant.base.mass": 1.0})
    with pytest.raises(KeyError, match="component"):
        run_ssp(systems["planar"]["ssp"], stop_time=0.5, overrides={"robot.base.m": 1.0})


def test_csv_round_trip(systems, tmp_path):
    out = tmp_path / "run.csv"
    res = run_ssp(systems["planar"]["ssp"], stop_time=0.3, csv_path=out, progress=False)
    assert res.csv_path == out
    back = read_csv(out)
    assert list(back) == list(res.data)
    assert list(back)[0] == "time"
    assert all(c == "time" or c.startswith(("plant.", "estimator.")) for c in back)
    for k, v in res.data.items():
        np.testing.assert_array_equal(back[k], v)


class _FreeCounter:
    def __init__(self, monkeypatch):
        from fmpy.fmi2 import FMU2Slave
        self.calls = []
        orig = FMU2Slave.freeInstance

        def free(slave):
            self.calls.append(slave.instanceName)
            return orig(slave)
        monkeypatch.setattr(FMU2Slave, "freeInstance", free)


def test_error_at_initialisation_is_reported_and_instances_freed(systems, monkeypatch, tmp_path):
    monkeypatch.setattr(runner.tempfile, "tempdir", str(tmp_path))
    freed = _FreeCounter(monkeypatch)
    with pytest.raises(SimulationError) as e:
        run_ssp(systems["planar"]["ssp"], stop_time=1.0, overrides={"plant.base.m": -1.0})
    msg = str(e.value)
    assert "'plant'" in msg and "Error" in msg and "fmi2ExitInitializationMode" in msg
    assert "base.m must be > 0 kg, got -1.0" in msg   # the FMU's own log message
    assert sorted(freed.calls) == ["estimator", "plant"]
    assert list(tmp_path.iterdir()) == []          # temporary folders removed


def test_discard_during_stepping_names_component_and_time(systems, monkeypatch):
    freed = _FreeCounter(monkeypatch)
    with pytest.raises(SimulationError) as e:
        run_ssp(systems["planar"]["ssp"], stop_time=1.0,
                overrides={"plant.K_F": 1e9, "plant.F_max": 1e9, "plant.P_max": 1e9})
    msg = str(e.value)
    assert "'plant'" in msg and "Discard" in msg and "fmi2DoStep" in msg and "t = 0 s" in msg
    assert "non-finite" in msg
    assert sorted(freed.calls) == ["estimator", "plant"]


def test_progress_bar_only_when_asked_or_on_a_terminal(systems, capsys):
    run_ssp(systems["planar"]["ssp"], stop_time=0.3, progress=True)
    assert "step" in capsys.readouterr().err
    run_ssp(systems["planar"]["ssp"], stop_time=0.3)          # stderr is not a TTY here
    assert capsys.readouterr().err == ""


def test_spatial_system_runs_with_its_default_set(systems):
    res = run_ssp(systems["spatial"]["ssp"], stop_time=0.5, progress=False)
    t = TARGETS["spatial"]["default"]
    assert res.truth["target.m"] == t.mass
    assert res.truth["target.b[3]"] == t.com[2]
    assert res.data["plant.base.omega[2]"][0] == pytest.approx(scenario("spatial").omega0[1])
    assert len(res.time) == 6 and np.all(np.isfinite(res.data["estimator.target.m"]))


# ---------------------------------------------------------------------------------------------
# fmpy's own SSP simulation
# ---------------------------------------------------------------------------------------------

def test_fmpy_simulate_ssp_runs_the_package_with_a_parameter_set(systems):
    from fmpy.ssp.simulation import simulate_ssp
    from fmpy.ssp.ssd import Parameter, ParameterSet, read_ssv

    small = read_ssv(str(systems["planar"]["ssv:small"]))
    params = [Parameter(name="plant." + p.name, type=p.type, value=p.value, unit=p.unit)
              for p in small.parameters if p.name != "base.v0[1]"]
    params.append(Parameter(name="plant.base.v0[1]", type="Real", value="5.0"))
    res = simulate_ssp(str(systems["planar"]["ssp"]), stop_time=0.5, step_size=0.1,
                       parameter_set=ParameterSet(name="small", parameters=params))
    assert len(res) == 5
    assert "plant.base.v[1]" in res.dtype.names and "estimator.target.m" in res.dtype.names
    # fmpy applied the parameter set: the base starts at 5 m/s, not the bound 1 m/s
    assert abs(res["plant.base.v[1]"][0] - 5.0) < 0.05
    assert np.all(np.isfinite(res["estimator.base.m"]))


def test_system_of_fmus_wires_every_input_by_name(planar_fmus):
    from spacerobot.system.reader import system_of_fmus

    info = system_of_fmus({k: planar_fmus[k] for k in ("plant", "estimator")}, 0.1, 1.0)
    assert sorted(info.connections) == sorted(
        [("plant", n, "estimator", n) for n in interface.connections(ROBOTS["planar"])]
        + [("estimator", n, "plant", n) for n in interface.feedback_connections()])
    # the other way round too: a component listed first may be the destination
    back = system_of_fmus({"estimator": planar_fmus["estimator"], "plant": planar_fmus["plant"]},
                          0.1, 1.0)
    assert sorted(back.connections) == sorted(info.connections)
