"""The native FMUs: the C core's FMI 2.0 or FMI 3.0 binaries packaged with data from the
interface table.

A native FMU is a zip of

* ``modelDescription.xml``, generated here from :mod:`spacerobot.interface` (the one table of
  every variable: names, units, causality, start values) with ``needsExecutionTool="false"``
  and the ``<ModelStructure>`` dependencies of every output (``Outputs``: its
  direct-feedthrough inputs; ``InitialUnknowns``: the parameters and those inputs);
* ``binaries/<platform>/<model identifier>.{so,dll,dylib}``: the binaries the install step
  compiled (``native/build.py``; FMI 2.0: linux64 always, win64 where mingw was found; FMI 3.0:
  x86_64-linux, x86_64-windows; and the macOS / ARM Linux ones where ``native/build.py --zig``
  built them), robot-independent;
* ``resources/spacerobot_variables.txt``: the same table as data (value reference, type,
  causality, variability, exact start value, the core's key, the name), which the shared FMI
  layer reads at instantiation;
* ``resources/robot.txt``: the robot record (:mod:`spacerobot.core.robot_record`); the
  estimator's carries the known arm and, in place of the base body (which it estimates and
  never reads), a unit placeholder: an estimator FMU carries no truth; the sensors FMU
  carries no robot at all;
* ``resources/scenario.txt``: the scenario's constants a model reads (the sample time; the
  plant's: also the arm's home posture).

Building one needs no compiler: the binaries are the installed package's.

FMI 3.0 (``fmi_version=3``, :func:`model_description3`): the same variables, value references and
scalar names as FMI 2.0 (``Float64`` for Real, ``Int32`` for Integer; no arrays: SSP 1.0
connections and the tools wire scalars, and the two versions compare one to one), the same
binaries' source built with ``-DFMI_VERSION=3``, the instantiation token the GUID.
"""
from __future__ import annotations

import dataclasses
import hashlib
import math
import struct
import uuid
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path
from typing import Callable, Dict, List, NamedTuple, Optional, Sequence, Tuple

from .. import __version__
from ..core import LIB_DIR
from ..interface import (UNITS, Var, estimator_vars, plant_vars, sensors_dependencies,
                         sensors_vars)
from ..robots import RigidBody, Robot, Scenario

def _units_logs_experiment(root, variables, sc, extra_units=frozenset()) -> None:
    """The UnitDefinitions, LogCategories and DefaultExperiment elements (the same in FMI 2.0
    and 3.0 model descriptions)."""
    units = ET.SubElement(root, "UnitDefinitions")
    for u in sorted({v.unit for v in variables if v.unit and v.type == "Real"} | set(extra_units)):
        unit = ET.SubElement(units, "Unit", name=u)
        if UNITS[u]:
            ET.SubElement(unit, "BaseUnit", {k: str(e) for k, e in UNITS[u].items()})
    cats = ET.SubElement(root, "LogCategories")
    for name, what in LOG_CATEGORIES.items():
        ET.SubElement(cats, "Category", name=name, description=what)
    ET.SubElement(root, "DefaultExperiment", startTime="0.0", stopTime=repr(float(sc.stop_time)),
                  stepSize=repr(float(sc.sample_time)))


def _table_key(v: Var) -> str:
    """The core key of a variable in the variable table (the glue looks variables up by it)."""
    return key_string(v.key)


def _sensors_key(v: Var) -> str:
    """The sensors' keys: inputs and outputs share the signal's key, so the inputs carry the
    ``true.`` prefix; parameters go by their names."""
    if v.causality == "parameter":
        return v.name
    return ("true." if v.causality == "input" else "") + key_string(v.key)


class NativeModel(NamedTuple):
    """A model with a native FMU."""

    identifier: str                     #: model identifier (the binaries' file name)
    variables: Callable                 #: (robot, scenario) -> [Var] (spacerobot.interface)
    description: str
    robot: Optional[str]                #: what of the robot travels in resources/robot.txt:
                                        #: "arm" (the base a placeholder), "all", or None
    key: Callable[[Var], str] = _table_key
    #: [Var] -> {output index: [input indices]} (direct feedthrough); None: none
    dependencies: Optional[Callable] = None
    #: the core module ``spacerobot.core.<ranges>`` whose ``parameter_ranges()`` gives the
    #: ``(min, max)`` its checks accept for the parameters and inputs (declared in the model
    #: description); None: the model declares none
    ranges: Optional[str] = None


#: the models with a native FMU, by kind
MODELS: Dict[str, NativeModel] = {
    "estimator": NativeModel(
        "SpaceRobotEstimator", estimator_vars,
        "Online one-step identification of the mass, centre of mass and inertia of both "
        "the base and the captured target of a space robot, from measurements alone "
        "(momentum- or force-based equations, modified RLS; Zhang, Yue, Yuan 2020). "
        "Native C core: needs nothing but the C runtime.", robot="arm", ranges="estimator"),
    "sensors": NativeModel(
        "SpaceRobotSensors", sensors_vars,
        "Sensors of a space robot servicer: gyro (white noise, bias random walk), star "
        "tracker, relative navigation, accelerometer / IMU, joint encoders (quantisation), "
        "thrust knowledge (scale factor, misalignment), sample delay. noise.scale = 0: outputs "
        "equal inputs. Direct feedthrough: the outputs at t measure the inputs set at t. "
        "Native C core: needs nothing but the C runtime.", robot=None, key=_sensors_key,
        dependencies=sensors_dependencies, ranges="sensors"),
    "plant": NativeModel(
        "SpaceRobotPlant", plant_vars,
        "Free-floating space robot after capture: base, arm and target (articulated-body "
        "algorithm), RK4, bounded momentum controller on the base thrusters, arm motion that "
        "stabilises the base attitude, excitation, propellant depletion (Zhang, Yue, Yuan "
        "2020). Native C core: needs nothing but the C runtime.", robot="all", ranges="plant"),
}

#: FMI 2.0 platform folder -> binary suffix (the platforms every install should carry)
PLATFORMS = {"linux64": ".so", "win64": ".dll"}
#: FMI 3.0 platform folder -> binary suffix (the platforms every install should carry)
PLATFORMS3 = {"x86_64-linux": ".so", "x86_64-windows": ".dll"}
#: platforms packaged where their binaries were built (``native/build.py --zig``)
EXTRA_PLATFORMS = {2: {},
                   3: {"x86_64-darwin": ".dylib", "aarch64-darwin": ".dylib",
                       "aarch64-linux": ".so"}}
#: the FMI versions a native FMU is built for
FMI_VERSIONS = (2, 3)


def platforms(fmi_version: int = 2) -> Dict[str, str]:
    """``{folder: suffix}`` of the platforms every install should carry for ``fmi_version``."""
    return dict(PLATFORMS3 if fmi_version == 3 else PLATFORMS)
VARIABLES_FILE = "spacerobot_variables.txt"
ROBOT_FILE = "robot.txt"
#: the scenario's constants a model reads at instantiation (the sensors: the sample time)
SCENARIO_FILE = "scenario.txt"
LOG_CATEGORIES = {
    "logEvents": "Lifecycle: instantiation, initialisation; the estimator's model fit regained",
    "logStatusWarning": "Samples skipped, the estimator's model-fit test failing, other warnings",
    "logStatusDiscard": "Communication steps refused",
    "logStatusError": "Refused calls: invalid parameters, wrong phase, type or value reference",
    "logAll": "Everything",
}


#: the base body written into the estimator's robot record: the estimator reads only the arm
PLACEHOLDER_BODY = RigidBody(1.0, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0, 0.0, 0.0, 0.0))


def known_robot(kind: str, robot: Robot) -> Optional[Robot]:
    """What the FMU ``kind`` may know of ``robot``: the estimator only the arm (the base body a
    placeholder), the plant everything, the sensors nothing (None)."""
    what = MODELS[kind].robot
    if what is None:
        return None
    return dataclasses.replace(robot, base=PLACEHOLDER_BODY) if what == "arm" else robot


def scenario_text(sc: Scenario, home: bool) -> str:
    """``resources/scenario.txt``: the scenario's constants a model reads at instantiation
    (IEEE-754 bits: exact and locale-independent): the sample time and, with ``home``, the
    arm's home posture ``q_home.<i>`` [rad] (the plant's initial posture)."""
    lines = ["spacerobot-scenario 1", f"sample_time {_hex(sc.sample_time)}"]
    if home:
        lines += [f"q_home.{i} {_hex(q)}" for i, q in enumerate(sc.robot.q0)]
    return "\n".join(lines) + "\n"


class NativeUnavailable(RuntimeError):
    """The native binaries of a model are not built (an install without a C compiler)."""


def key_string(key) -> str:
    """The core key of a variable as the C glue looks it up: ``("A", (0, 2))`` -> ``A.0.2``."""
    parts: List[str] = []

    def walk(k):
        if isinstance(k, tuple):
            for x in k:
                walk(x)
        else:
            parts.append(str(k))
    walk(key)
    return ".".join(parts)


def _hex(x: float) -> str:
    """The IEEE-754 bits of ``x`` (exact, locale-independent)."""
    return "0x%016x" % struct.unpack("<Q", struct.pack("<d", float(x)))[0]


def variable_table(variables: Sequence[Var], model_identifier: str, guid: str,
                   key: Callable[[Var], str] = _table_key) -> str:
    """``resources/spacerobot_variables.txt``: one line per variable, in value-reference order."""
    lines = ["spacerobot-variables 1",
             "# vr type causality variability start(IEEE-754 bits) key name",
             f"model {model_identifier}", f"guid {guid}"]
    for vr, v in enumerate(variables):
        start = v.start if v.start is not None else 0.0
        lines.append(f"{vr} {v.type} {v.causality} {v.variability} {_hex(start)} "
                     f"{key(v)} {v.name}")
    return "\n".join(lines) + "\n"


def _start_text(v: Var) -> str:
    return _value_text(v, v.start)


def _value_text(v: Var, x: float) -> str:
    """A value of ``v`` as the model description writes it (exact: the shortest repr)."""
    return str(int(x)) if v.type == "Integer" else repr(float(x))


Ranges = Dict[str, Tuple[float, float]]


def variable_ranges(kind: str) -> Ranges:
    """``{name: (min, max)}`` of the FMU ``kind``'s parameters and inputs: what its core's checks
    accept (``spacerobot.core.<module>.parameter_ranges()``, :attr:`NativeModel.ranges`)."""
    module = MODELS[kind].ranges
    if module is None:
        return {}
    import importlib
    return importlib.import_module(f"{__package__.rsplit('.', 1)[0]}.core.{module}") \
        .parameter_ranges()


def _range_attributes(v: Var, ranges: Optional[Ranges]) -> Dict[str, str]:
    """``min`` / ``max`` of a parameter or input (finite bounds only), checked to hold its
    start value (FMI 2.0 / 3.0: min <= start <= max)."""
    if not ranges or v.name not in ranges or v.causality not in ("parameter", "input"):
        return {}
    lo, hi = ranges[v.name]
    if v.start is not None and not lo <= v.start <= hi:
        raise ValueError(f"{v.name}: the start value {v.start!r} is outside the range "
                         f"[{lo!r}, {hi!r}] the core accepts")
    return {k: _value_text(v, x) for k, x in (("min", lo), ("max", hi)) if math.isfinite(x)}


def _initial_dependencies(variables: Sequence[Var],
                          dependencies: Optional[Dict[int, List[int]]], vr: int) -> List[int]:
    """The knowns an output depends on in initialisation mode (FMI 2.0 ``InitialUnknowns``, FMI
    3.0 ``InitialUnknown``), as value references: every parameter (``initial="exact"``: the
    preview of the FMI layer, ``sr_model_preview``, builds the outputs from the parameters set
    so far) and, for a direct-feedthrough output, the inputs of its ``<Outputs>`` entry (the
    sensors' preview measures the inputs); no other input. Declared, a master sees no
    algebraic loop at initialisation that does not exist (without the attribute it must assume
    that every output depends on every input)."""
    feed = set((dependencies or {}).get(vr, []))
    return [j for j, v in enumerate(variables) if v.causality == "parameter" or j in feed]


def model_description(variables: Sequence[Var], model_identifier: str, guid: str,
                      description: str, sc: Scenario,
                      dependencies: Optional[Dict[int, List[int]]] = None,
                      ranges: Optional[Ranges] = None) -> str:
    """The FMI 2.0 model description of a native co-simulation FMU; ``dependencies``: ``{output
    index: [input indices]}`` of a model with direct feedthrough (None: outputs change only in
    doStep); ``ranges``: ``{name: (min, max)}`` of parameters and inputs
    (:func:`variable_ranges`)."""
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": model_identifier, "guid": guid,
        "description": description, "author": "spacerobot developers",
        "version": __version__, "license": "MIT",
        "generationTool": f"spacerobot {__version__}",
        "variableNamingConvention": "structured", "numberOfEventIndicators": "0"})
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": model_identifier, "needsExecutionTool": "false",
        "canHandleVariableCommunicationStepSize": "true", "canInterpolateInputs": "false",
        "maxOutputDerivativeOrder": "0", "canRunAsynchronuously": "false",
        "canBeInstantiatedOnlyOncePerProcess": "false",
        "canNotUseMemoryManagementFunctions": "true",
        "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true",
        "providesDirectionalDerivative": "false"})
    _units_logs_experiment(root, variables, sc)
    mv = ET.SubElement(root, "ModelVariables")
    outputs = []
    for vr, v in enumerate(variables):
        attrs = {"name": v.name, "valueReference": str(vr), "description": v.description,
                 "causality": v.causality, "variability": v.variability}
        sv = ET.SubElement(mv, "ScalarVariable", attrs)
        t = {}
        if v.unit and v.type == "Real":
            t["unit"] = v.unit
        if v.causality in ("parameter", "input"):
            t["start"] = _start_text(v)
            t.update(_range_attributes(v, ranges))
        else:
            outputs.append(vr + 1)
        ET.SubElement(sv, v.type, t)
    ms = ET.SubElement(root, "ModelStructure")
    outs = ET.SubElement(ms, "Outputs")
    for i in outputs:                       # without feedthrough, outputs change only in doStep
        deps = (dependencies or {}).get(i - 1, [])
        ET.SubElement(outs, "Unknown", index=str(i),
                      dependencies=" ".join(str(j + 1) for j in deps))
    init = ET.SubElement(ms, "InitialUnknowns")
    for i in outputs:
        deps = _initial_dependencies(variables, dependencies, i - 1)
        ET.SubElement(init, "Unknown", index=str(i),
                      dependencies=" ".join(str(j + 1) for j in deps))
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def model_description3(variables: Sequence[Var], model_identifier: str, token: str,
                       description: str, sc: Scenario,
                       dependencies: Optional[Dict[int, List[int]]] = None,
                       ranges: Optional[Ranges] = None) -> str:
    """The FMI 3.0 model description of a native co-simulation FMU: the variables of
    :func:`model_description` (same names and value references; ``Float64`` / ``Int32``
    scalars), ``<Output>`` dependencies by value reference (``dependencies``: ``{output index:
    [input indices]}``; None: outputs change only in doStep), ``min`` / ``max`` of ``ranges``, the
    capabilities the FMI layer delivers (``native/fmi/fmi3_api.c``) and no other."""
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": model_identifier, "instantiationToken": token,
        "description": description, "author": "spacerobot developers",
        "version": __version__, "license": "MIT",
        "generationTool": f"spacerobot {__version__}",
        "variableNamingConvention": "structured"})
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": model_identifier, "needsExecutionTool": "false",
        "canBeInstantiatedOnlyOncePerProcess": "false",
        "canGetAndSetFMUState": "true", "canSerializeFMUState": "true",
        "providesDirectionalDerivatives": "false", "providesAdjointDerivatives": "false",
        "providesPerElementDependencies": "false",
        "canHandleVariableCommunicationStepSize": "true", "maxOutputDerivativeOrder": "0",
        "providesIntermediateUpdate": "false", "mightReturnEarlyFromDoStep": "false",
        "canReturnEarlyAfterIntermediateUpdate": "false", "hasEventMode": "false",
        "providesEvaluateDiscreteStates": "false"})
    _units_logs_experiment(root, variables, sc, extra_units={"s"})
    mv = ET.SubElement(root, "ModelVariables")
    # FMI 3.0 asks for exactly one independent variable: time, after the table's variables (the
    # layer serves its value reference, len(variables), from the instance's time)
    ET.SubElement(mv, "Float64", {"name": "time", "valueReference": str(len(variables)),
                                  "description": "Simulation time", "causality": "independent",
                                  "variability": "continuous", "unit": "s"})
    outputs = []
    for vr, v in enumerate(variables):
        attrs = {"name": v.name, "valueReference": str(vr), "description": v.description,
                 "causality": v.causality, "variability": v.variability}
        if v.causality in ("parameter", "input"):
            attrs["start"] = _start_text(v)
            attrs.update(_range_attributes(v, ranges))
        else:
            outputs.append(vr)
        if v.unit and v.type == "Real":
            attrs["unit"] = v.unit
        ET.SubElement(mv, FMI3_TYPES[v.type], attrs)
    ms = ET.SubElement(root, "ModelStructure")
    for vr in outputs:                      # without feedthrough, outputs change only in doStep
        deps = (dependencies or {}).get(vr, [])
        ET.SubElement(ms, "Output", valueReference=str(vr),
                      dependencies=" ".join(str(j) for j in deps))
    for vr in outputs:
        ET.SubElement(ms, "InitialUnknown", valueReference=str(vr), dependencies=" ".join(
            str(j) for j in _initial_dependencies(variables, dependencies, vr)))
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


#: the FMI 3.0 element of each interface type
FMI3_TYPES = {"Real": "Float64", "Integer": "Int32"}


def binaries(model_identifier: str, lib_dir: Path = LIB_DIR, fmi_version: int = 2
             ) -> Dict[str, Path]:
    """``{platform folder: path}`` of the model's FMI ``fmi_version`` binaries the install step
    (or ``native/build.py``) built."""
    out = {}
    for plat, suffix in {**platforms(fmi_version), **EXTRA_PLATFORMS[fmi_version]}.items():
        p = Path(lib_dir) / "fmu" / plat / f"{model_identifier}{suffix}"
        if p.is_file():
            out[plat] = p
    return out


def build_native_fmu(kind: str, sc: Scenario, out_dir: str | Path, lib_dir: Path = LIB_DIR,
                     fmi_version: int = 2) -> Path:
    """Build the native FMI ``fmi_version`` (2 or 3) FMU ``kind`` for the scenario's robot into
    ``out_dir``; returns its path."""
    from ..core.robot_record import robot_record_text

    if kind not in MODELS:
        raise ValueError(f"no native FMU for {kind!r} yet; native: {sorted(MODELS)}")
    if fmi_version not in FMI_VERSIONS:
        raise ValueError(f"fmi_version must be one of {FMI_VERSIONS}, got {fmi_version!r}")
    model = MODELS[kind]
    ident = model.identifier
    bins = binaries(ident, lib_dir, fmi_version)
    host = "x86_64-linux" if fmi_version == 3 else "linux64"
    if host not in bins:
        raise NativeUnavailable(
            f"the native FMI {fmi_version}.0 {kind} binary is not built ({Path(lib_dir) / 'fmu'} "
            f"has no {host}/{ident}.so): reinstall the package (pip install -e .), which "
            f"compiles it")
    variables = model.variables(sc.robot, sc)
    robot = known_robot(kind, sc.robot)
    resources = {SCENARIO_FILE: scenario_text(sc, home=model.robot == "all")}
    if robot is not None:
        resources[ROBOT_FILE] = robot_record_text(robot)
    table0 = variable_table(variables, ident, "", model.key)
    # FMI 2.0's GUID as before; FMI 3.0's token differs (another model description)
    digest = hashlib.sha256(((ident if fmi_version == 2 else ident + " FMI 3.0") + table0
                             + "".join(resources.values())).encode()).digest()
    guid = "{%s}" % uuid.UUID(bytes=digest[:16], version=4)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{ident}.fmu"
    tmp = path.with_suffix(".fmu.part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        describe = model_description3 if fmi_version == 3 else model_description
        zf.writestr("modelDescription.xml",
                    describe(variables, ident, guid, model.description, sc,
                             model.dependencies and model.dependencies(variables),
                             variable_ranges(kind)))
        for plat, p in sorted(bins.items()):
            zf.write(p, f"binaries/{plat}/{p.name}")
        zf.writestr(f"resources/{VARIABLES_FILE}", variable_table(variables, ident, guid, model.key))
        for name, text in resources.items():
            zf.writestr(f"resources/{name}", text)
    tmp.replace(path)
    return path
