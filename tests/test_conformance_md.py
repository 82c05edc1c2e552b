"""Interface conformance: what the FMUs declare.

- fmpy's validator (API and ``python -m fmpy validate``) finds no problem in any of the FMUs,
  and it does find the problems we claim it checks when they are injected (so a pass means
  something);
- every variable has a description, every Real a unit defined in UnitDefinitions, and each unit's
  SI base exponents equal an independent decomposition of the Modelica unit string;
- the units follow the interface contract (docs/fmus.md), written here
  independently of spacerobot/interface.py;
- ModelStructure/Outputs and /InitialUnknowns list exactly the outputs, in ascending order, and at
  initialisation the outputs depend on the inputs the InitialUnknowns declare and on no other;
- the FMUs declare exactly the variables of the interface table and the capability flags and
  variables that docs/fmus.md documents.

``python tests/test_conformance_md.py`` prints the variable tables used in docs/fmus.md.
"""
from __future__ import annotations

import re
import subprocess
import sys
import zipfile
from itertools import product
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest

from test_conformance_util import free_instances  # noqa: F401  (autouse fixture)
from test_conformance_util import KINDS, ROBOTS, Inst, fmus_for

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs" / "fmus.md"
MODEL = {"plant": "SpaceRobotPlant", "estimator": "SpaceRobotEstimator",
         "sensors": "SpaceRobotSensors"}


def _xml(path: Path) -> ET.Element:
    with zipfile.ZipFile(path) as z:
        return ET.fromstring(z.read("modelDescription.xml"))


@pytest.fixture(params=[(r, k) for r in ROBOTS for k in KINDS], ids=lambda p: f"{p[0]}-{p[1]}")
def fmu(request):
    robot, kind = request.param
    return robot, kind, fmus_for(request, robot)[kind]


# -- fmpy validate --------------------------------------------------------------------------------
def test_fmpy_validate_api_reports_no_problem(fmu):
    from fmpy.validation import validate_fmu

    robot, kind, path = fmu
    assert validate_fmu(str(path)) == []


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.slow
def test_fmpy_validate_command_line_reports_no_problem(request, robot):
    for kind in KINDS:
        path = fmus_for(request, robot)[kind]
        r = subprocess.run([sys.executable, "-m", "fmpy", "validate", str(path)],
                           capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stdout + r.stderr
        assert "No problems found." in r.stdout, r.stdout


def _mutated(path: Path, tmp: Path, edit) -> Path:
    """A copy of the FMU with modelDescription.xml changed by ``edit(root)``."""
    out = tmp / path.name
    root = _xml(path)
    edit(root)
    with zipfile.ZipFile(path) as zin, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            data = zin.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = ET.tostring(root, encoding="utf-8", xml_declaration=True)
            zout.writestr(item, data)
    return out


def _drop_unit_definition(root):
    units = root.find("UnitDefinitions")
    units.remove(units.find("Unit[@name='kg']"))


def _drop_initial_unknown(root):
    init = root.find("ModelStructure/InitialUnknowns")
    init.remove(init[0])


def _drop_output(root):
    outs = root.find("ModelStructure/Outputs")
    outs.remove(outs[-1])


@pytest.mark.parametrize("edit,expect", [
    (_drop_unit_definition, 'unit "kg"'),
    (_drop_initial_unknown, "InitialUnknowns"),
    (_drop_output, "Outputs"),
], ids=["unit", "initial-unknown", "output"])
@pytest.mark.slow
def test_fmpy_validate_detects_injected_defects(planar_fmus, tmp_path, edit, expect):
    """Negative control: the validator sees the defects our FMUs must not have."""
    from fmpy.validation import validate_fmu

    bad = _mutated(planar_fmus["estimator"], tmp_path, edit)
    problems = validate_fmu(str(bad))
    assert problems and any(expect in p for p in problems), problems


# -- descriptions and units -----------------------------------------------------------------------
_PRIMITIVE = {"m": {"m": 1}, "s": {"s": 1}, "kg": {"kg": 1}, "rad": {"rad": 1},
              "N": {"kg": 1, "m": 1, "s": -2}, "Hz": {"s": -1}}


def si_exponents(unit: str) -> dict:
    """Base-unit exponents of a Modelica unit string such as 'N.m.s', 'kg.m2', '1/s2'."""
    out: dict = {}
    num, _, den = unit.partition("/")
    for part, sign in ((num, 1), (den, -1)):
        for factor in filter(None, part.split(".")):
            if factor == "1":
                continue
            m = re.fullmatch(r"([A-Za-z]+)(-?\d*)", factor)
            assert m, f"cannot parse unit factor {factor!r} of {unit!r}"
            e = sign * int(m.group(2) or 1)
            for base, k in _PRIMITIVE[m.group(1)].items():
                out[base] = out.get(base, 0) + k * e
    return {k: v for k, v in out.items() if v}


def test_every_variable_described_and_every_real_has_a_defined_unit(fmu):
    robot, kind, path = fmu
    root = _xml(path)
    defined = {}
    for u in root.find("UnitDefinitions"):
        base = u.find("BaseUnit")
        defined[u.get("name")] = {k: int(v) for k, v in (base.attrib if base is not None else {}).items()
                                  if int(v)}
    for sv in root.find("ModelVariables"):
        name = sv.get("name")
        assert (sv.get("description") or "").strip(), f"{name} has no description"
        real = sv.find("Real")
        if real is not None:
            unit = real.get("unit")
            assert unit, f"Real {name} has no unit"
            assert unit in defined, f"unit {unit!r} of {name} not in UnitDefinitions"
    for name, exps in defined.items():
        assert exps == si_exponents(name), f"BaseUnit of {name!r}: {exps}"


#: the interface contract's units (docs/fmus.md), independent of spacerobot/interface.py
CONTRACT_UNITS = [
    (r"base\.r\[\d\]", "m"), (r"base\.v\[\d\]", "m/s"), (r"base\.A\[\d,\d\]", "1"),
    (r"base\.omega\[\d\]", "rad/s"), (r"base\.a\[\d\]", "m/s2"), (r"base\.alpha\[\d\]", "rad/s2"),
    (r"arm\.q\[\d\]", "rad"), (r"arm\.qd\[\d\]", "rad/s"), (r"arm\.qdd\[\d\]", "rad/s2"),
    (r"arm\.tau\[\d\]", "N.m"),
    (r"thrust\.F\[\d\]", "N"), (r"thrust\.M\[\d\]", "N.m"), (r"thrust\.J\[\d\]", "N.s"),
    (r"thrust\.H\[\d\]", "N.m.s"), (r"system\.P\[\d\]", "N.s"), (r"system\.L\[\d\]", "N.m.s"),
    (r"(sd\.|crb\.|guess\.|truth\.)?(base|target)\.m", "kg"),
    (r"(sd\.|crb\.|guess\.|truth\.)?(base|target)\.b\[\d\]", "m"),
    (r"(sd\.|crb\.|guess\.|truth\.)?(base|target)\.I(xx|yy|zz|xy|xz|yz)", "kg.m2"),
    (r"prop\.m0?", "kg"), (r"prop\.Isp", "s"), (r"prop\.(R|arm|r\[\d\])", "m"),
    (r"prop\.P\[\d\]", "N.s"), (r"prop\.L\[\d\]", "N.m.s"),
    # the flexible parts: panels (flex) and slosh modes (slosh), record i
    (r"(flex|slosh)\.m\[\d\]", "kg"), (r"(flex\.(com|hinge)|slosh\.r)\[\d,\d\]", "m"),
    (r"flex\.I(xx|yy|zz|xy|xz|yz)\[\d\]", "kg.m2"), (r"(flex|slosh)\.axis\[\d,\d\]", "1"),
    (r"(flex|slosh)\.f\[\d\]", "Hz"), (r"(flex|slosh)\.zeta\[\d\]", "1"),
    (r"flex\.q0?\[\d\]", "rad"), (r"flex\.qd0?\[\d\]", "rad/s"), (r"slosh\.x0?\[\d\]", "m"),
    (r"slosh\.v0?\[\d\]", "m/s"), (r"flex\.P\[\d\]", "N.s"), (r"flex\.L\[\d\]", "N.m.s"),
    (r"base\.v0\[\d\]", "m/s"), (r"base\.omega0\[\d\]", "rad/s"),
    (r"F_max", "N"), (r"M_max", "N.m"), (r"P_max", "N.s"), (r"L_max", "N.m.s"),
    (r"K_[FMD]|K_Dn", "1/s"), (r"K_Pn?", "1/s2"), (r"qdd_max", "rad/s2"), (r"h", "s"),
    (r"ident\.excite|excite\.level", "1"), (r"excite\.(att_max|q_max)", "rad"),
    (r"excite\.qd_max", "rad/s"), (r"excite\.qdd_max", "rad/s2"), (r"excite\.(period|ramp)", "s"),
    (r"lambda|P0_mu|P0_theta|diag\.(residual_lin|residual_ang|excitation_mu|excitation_theta"
     r"|info_chi2)", "1"),
    (r"ident\.(sd_rel|flag_confidence|excite_level)", "1"), (r"excite\.att_ref\[\d\]", "rad"),
    # the model-fit test: its window, its thresholds and factors, its statistic
    (r"ident\.fit_window", "s"),
    (r"ident\.fit_(rho_max|whiteness_max|chi2_max|thrust_max|bias_k|bias_k_info)"
     r"|diag\.model_fit", "1"),
    # the excitation's rate: a frequency multiplier; the choice's times and scores
    (r"ident\.excite_(rate|rate_try)|excite\.rate|diag\.excite_score\.rate_(1|try)", "1"),
    (r"ident\.excite_(window|settle|horizon)", "s"),
    # the modal columns: the modes' frequencies (given, in use) and damping ratios
    (r"(ident|diag)\.mode_f\[\d\]", "Hz"), (r"diag\.mode_zeta\[\d\]", "1"),
    # estimator noise model: row standard deviations in the units of each method's equations
    (r"ident\.sd_row\.momentum_lin", "N.s"), (r"ident\.sd_row\.momentum_ang", "N.m.s"),
    (r"ident\.sd_row\.force_lin", "N"), (r"ident\.sd_row\.force_ang", "N.m"),
    (r"ident\.(momentum|force)_window", "s"),
    (r"excite\.qd_ref\[\d\]", "rad/s"),
    # sensors FMU: white noise and random walks as their standard deviation over 1 s
    (r"noise\.(scale|thrust\.scale)", "1"), (r"noise\.gyro\.(arw|bias|rrw)", "rad/s"),
    (r"noise\.(star\.(cross|roll)|enc\.(resolution|q)|thrust\.misalign)", "rad"),
    (r"noise\.nav\.r", "m"), (r"noise\.nav\.v", "m/s"),
    (r"noise\.accel\.(vrw|bias|brw)", "m/s2"), (r"noise\.alpha", "rad/s2"),
    (r"noise\.enc\.qd", "rad/s"), (r"noise\.enc\.qdd", "rad/s2"),
    (r"ident\.(momentum|force)_window", "s"),      # reference windows (branch s14)
    # the thrust errors' consider term and the accelerations' noise (errors in variables)
    (r"ident\.sd_thrust\.scale", "1"), (r"ident\.sd_thrust\.misalign", "rad"),
    (r"ident\.noise\.base\.a", "m/s2"), (r"ident\.noise\.(base\.alpha|arm\.qdd)", "rad/s2"),
    (r"ident\.noise\.base\.v", "m/s"), (r"ident\.noise\.(base\.omega|arm\.qd)", "rad/s"),
    # the errors-in-variables correction's relative uncertainty
    (r"ident\.eiv_uncertainty", "1"),
]


def test_units_follow_the_interface_contract(fmu):
    from fmpy import read_model_description

    robot, kind, path = fmu
    for v in read_model_description(str(path)).modelVariables:
        if v.type != "Real":
            continue
        name = v.name.removeprefix("true.")          # sensors inputs: the true signals
        expected = [u for pat, u in CONTRACT_UNITS if u and re.fullmatch(pat, name)]
        assert expected, f"{v.name}: no unit in the contract table"
        assert v.unit == expected[0], f"{v.name}: unit {v.unit!r}, contract {expected[0]!r}"


def test_outputs_and_initial_unknowns_list_every_output(fmu):
    robot, kind, path = fmu
    root = _xml(path)
    variables = list(root.find("ModelVariables"))
    outputs = [i + 1 for i, sv in enumerate(variables) if sv.get("causality") == "output"]
    assert outputs
    for section in ("Outputs", "InitialUnknowns"):
        listed = [int(u.get("index")) for u in root.find(f"ModelStructure/{section}")]
        assert listed == outputs, f"ModelStructure/{section} != outputs (ascending)"



#: per kind, a parameter and a value that moves some output at initialisation
INITIAL_PARAMETER = {"plant": ("base.v0[1]", 0.3), "estimator": ("guess.target.m", 42.0),
                     "sensors": ("seed", 7)}


def test_initial_unknowns_depend_on_the_declared_inputs_only(fmu):
    """In initialisation mode (what a master reads before the first step) each output follows
    the parameters and, of the inputs, exactly those its InitialUnknowns entry declares: one
    input perturbed at a time changes exactly the outputs that declare it (none, for plant and
    estimator: so a master sees no algebraic loop at initialisation), and a parameter that
    changes outputs is declared by every one of them."""
    from fmpy import read_model_description

    robot, kind, path = fmu
    md = read_model_description(str(path))
    declared = {u.variable.name: {d.name for d in u.dependencies} for u in md.initialUnknowns}
    assert set(declared) == {v.name for v in md.modelVariables if v.causality == "output"}
    s = Inst(path, "initial-unknowns")
    s.fmu.setupExperiment(startTime=0.0)
    s.fmu.enterInitializationMode()
    ins, outs = s.names("input"), s.names("output")
    x = np.array([float(s.vars[n].start) for n in ins])
    rng = np.random.default_rng(5)
    if kind == "sensors":                              # any values: the sensors measure them
        x = x + rng.normal(size=len(ins))
    s.set_many(ins, x)
    y0 = s.values(outs)
    for i, name in enumerate(ins):
        s.set_many(ins, x + np.eye(len(ins))[i] * 0.01)
        y = s.values(outs)
        assert {o for o in outs if y[o] != y0[o]} == {o for o in outs if name in declared[o]}, name
    s.set_many(ins, x)
    param, value = INITIAL_PARAMETER[kind]
    s.set(param, value)
    y = s.values(outs)
    assert any(y[o] != y0[o] for o in outs), param
    assert all(param in declared[o] for o in outs), param

def test_variables_equal_the_interface_table(fmu):
    """Every variable of the interface table, with its causality, variability, unit and
    description, and nothing else, in the FMU that was built."""
    from fmpy import read_model_description

    from spacerobot.robots import scenario

    robot, kind, path = fmu
    sc = scenario(robot)
    table = _table_of(kind)(sc.robot, sc)
    md = {v.name: v for v in read_model_description(str(path)).modelVariables}
    assert list(md) == [v.name for v in table]
    for v in table:
        got = md[v.name]
        assert (got.causality, got.variability, got.type, got.unit, got.description) == (
            v.causality, v.variability, v.type, v.unit, v.description), v.name
        if v.causality in ("parameter", "input"):
            assert float(got.start) == float(v.start), v.name


# -- capability flags -----------------------------------------------------------------------------
EXPECTED_FLAGS = {
    "canHandleVariableCommunicationStepSize": "true",
    "canGetAndSetFMUstate": "true",
    "canSerializeFMUstate": "true",
    "canBeInstantiatedOnlyOncePerProcess": "false",
    "canInterpolateInputs": "false",
    "needsExecutionTool": "false",          # nothing but the C runtime
}


def test_capability_flags(fmu):
    robot, kind, path = fmu
    cs = _xml(path).find("CoSimulation")
    assert cs.get("modelIdentifier") == MODEL[kind]
    for flag, value in EXPECTED_FLAGS.items():
        assert cs.get(flag) == value, flag
    assert _xml(path).get("fmiVersion") == "2.0"


# -- log categories ------------------------------------------------------------------------------
def test_the_declared_log_categories_are_the_layers(fmu):
    """The model description's categories (spacerobot.fmi.native.LOG_CATEGORIES) are the FMI
    layer's (native/fmi/fmi_layer.c): fmi2SetDebugLogging accepts each and all of them, refuses
    one it does not declare; the categories the layer logs with are declared
    (tests/test_conformance_bad_input.py checks every message it sees)."""
    from fmpy import read_model_description
    from fmpy.fmi2 import fmi2String

    from test_conformance_util import ERROR, OK, Inst

    robot, kind, path = fmu
    declared = [c.name for c in read_model_description(str(path)).logCategories]
    assert declared == ["logEvents", "logStatusWarning", "logStatusDiscard", "logStatusError",
                        "logAll"]
    inst = Inst(path, "categories")
    try:
        for names in ([[c] for c in declared] + [declared]):
            arr = (fmi2String * len(names))(*(n.encode() for n in names))
            assert inst.fmu.fmi2SetDebugLogging(inst.fmu.component, 1, len(names), arr) == OK
        arr = (fmi2String * 1)(b"logNothingSuch")
        status, msgs = inst.call(inst.fmu.fmi2SetDebugLogging, inst.fmu.component, 1, 1, arr)
        assert status == ERROR and any("unknown category logNothingSuch" in m for _, _, m in msgs)
    finally:
        inst.free()


# -- docs/fmus.md ---------------------------------------------------------------------------------
def _expand(pattern: str, n: int):
    """`base.A[1..3,1..3]`, `arm.q[1..n]`, `base.{Ixx,Iyy}` -> the scalar names."""
    parts = re.split(r"(\{[^}]*\}|\[[^\]]*\])", pattern)
    choices = []
    for p in parts:
        if p.startswith("{"):
            choices.append(p[1:-1].split(","))
        elif p.startswith("[") and ".." in p:
            dims = []
            for d in p[1:-1].split(","):
                lo, hi = d.split("..")
                dims.append([str(i) for i in range(int(lo), (n if hi == "n" else int(hi)) + 1)])
            choices.append(["[" + ",".join(c) + "]" for c in product(*dims)])
        else:
            choices.append([p])
    return ["".join(c) for c in product(*choices)]


def docs_variables(kind: str, n: int) -> dict:
    """name -> (causality, variability, unit) from the variable table of ``kind`` in fmus.md."""
    text = DOCS.read_text()
    section = text.split(f"<!-- variables:{kind} -->", 1)[1].split("<!-- /variables -->", 1)[0]
    out = {}
    for line in section.splitlines():
        m = re.match(r"\|\s*`([^`]+)`\s*\|\s*(\w+)\s*\|\s*(\w+)\s*\|\s*([^|]*?)\s*\|", line)
        if not m:
            continue
        unit = m.group(4).strip("` ")
        for name in _expand(m.group(1), n):
            assert name not in out, f"{name} listed twice in docs/fmus.md"
            out[name] = (m.group(2), m.group(3), None if unit in ("", "-") else unit)
    return out


def test_docs_list_every_variable_with_causality_variability_and_unit(fmu):
    from fmpy import read_model_description

    robot, kind, path = fmu
    md = read_model_description(str(path)).modelVariables
    n = sum(1 for v in md if re.fullmatch(r"arm\.q\[\d+\]", v.name))
    documented = docs_variables(kind, n)
    declared = {v.name: (v.causality, v.variability, v.unit) for v in md}
    assert set(documented) == set(declared), (
        f"missing in docs: {sorted(set(declared) - set(documented))[:10]}; "
        f"not in FMU: {sorted(set(documented) - set(declared))[:10]}")
    wrong = {k: (documented[k], declared[k]) for k in declared if documented[k] != declared[k]}
    assert not wrong, wrong


def test_docs_capability_table_matches_the_model_description(planar_fmus, spatial_fmus):
    text = DOCS.read_text()
    for fmus in (planar_fmus, spatial_fmus):
        for kind in KINDS:
            cs = _xml(fmus[kind]).find("CoSimulation")
            for flag in EXPECTED_FLAGS:        # | flag | every FMU |
                m = re.search(rf"\|\s*`{flag}`\s*\|\s*(\w+)\s*\|", text)
                assert m, f"{flag} not in docs/fmus.md"
                assert m.group(1) == cs.get(flag), flag


# -- generator of the docs tables (run this file as a script) -------------------------------------
def _group(name: str) -> str:
    # the records of the panels and slosh modes (flex.m[i], flex.com[i,k], flex.q[i], ...)
    m = re.fullmatch(r"((?:flex|slosh)\.\w+)\[(\d+)(,\d+)?\]", name)
    if m and m.group(1) not in ("flex.P", "flex.L"):
        head = re.sub(r"\.(Ixx|Iyy|Izz|Ixy|Ixz|Iyz)$", ".{Ixx,Iyy,Izz,Ixy,Ixz,Iyz}", m.group(1))
        return f"{head}[1..4{',1..3' if m.group(3) else ''}]"
    name = re.sub(r"\[\d+,\d+\]$", "[1..3,1..3]", name)
    name = re.sub(r"^((?:true\.)?arm\.\w+|excite\.qd_ref)\[\d+\]$", r"\1[1..n]", name)
    name = re.sub(r"\[\d\]$", "[1..3]", name)
    return re.sub(r"\.(Ixx|Iyy|Izz|Ixy|Ixz|Iyz)$", ".{Ixx,Iyy,Izz,Ixy,Ixz,Iyz}", name)


def _short(desc: str) -> str:
    desc = re.sub(r", (panel|slosh mode) \d+$", "", desc)
    desc = re.sub(r", (x|y|z) component$", "", desc)
    desc = re.sub(r", joint \d+$", "", desc)
    desc = re.sub(r", element \(\d,\d\)$", "", desc)
    desc = re.sub(r" inertia tensor element I\w\w ", " inertia tensor element ", desc)
    return desc.replace("|", "/")


def _table_of(kind: str):
    from spacerobot.interface import estimator_vars, plant_vars, sensors_vars

    return {"plant": plant_vars, "estimator": estimator_vars, "sensors": sensors_vars}[kind]


def docs_table(kind: str) -> str:
    from spacerobot.robots import scenario

    sc = scenario("spatial")
    table = _table_of(kind)(sc.robot, sc)
    rows, seen = [], set()
    for v in table:
        g = _group(v.name)
        if g in seen:
            continue
        seen.add(g)
        rows.append(f"| `{g}` | {v.causality} | {v.variability} | {v.unit or '-'} | "
                    f"{_short(v.description)} |")
    head = "| variable | causality | variability | unit | meaning |\n|---|---|---|---|---|\n"
    return f"<!-- variables:{kind} -->\n" + head + "\n".join(rows) + "\n<!-- /variables -->"


if __name__ == "__main__":
    for k in KINDS:
        print(docs_table(k), end="\n\n")
