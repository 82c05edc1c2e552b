"""The native FMUs: the C core's FMI 2.0 binaries packaged with data from the interface table.

A native FMU is a zip of

* ``modelDescription.xml``, generated here from :mod:`spacerobot.interface` (the one table of
  every variable: names, units, causality, start values) with ``needsExecutionTool="false"``
  and ``<ModelStructure><Outputs>`` dependencies;
* ``binaries/<platform>/<model identifier>.{so,dll}``: the binaries the install step compiled
  (``native/build.py``; linux64 always, win64 where mingw was found), robot-independent;
* ``resources/spacerobot_variables.txt``: the same table as data (value reference, type,
  causality, variability, exact start value, the core's key, the name), which the shared FMI
  layer reads at instantiation;
* ``resources/robot.txt``: the robot record (:mod:`spacerobot.core.robot_record`); the
  estimator's carries the known arm and, in place of the base body (which it estimates and
  never reads), a unit placeholder: an estimator FMU carries no truth.

Building one needs no compiler: the binaries are the installed package's.
"""
from __future__ import annotations

import dataclasses
import hashlib
import struct
import uuid
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path
from typing import Dict, List, Sequence

from .. import __version__
from ..core import LIB_DIR
from ..interface import UNITS, Var, estimator_vars
from ..robots import RigidBody, Robot, Scenario

#: the models with a native FMU: kind -> (model identifier, variables of (robot, scenario),
#: description)
MODELS = {
    "estimator": ("SpaceRobotEstimator", estimator_vars,
                  "Online one-step identification of the mass, centre of mass and inertia of both "
                  "the base and the captured target of a space robot, from measurements alone "
                  "(momentum- or force-based equations, modified RLS; Zhang, Yue, Yuan 2020). "
                  "Native C core: needs nothing but the C runtime."),
}

#: FMI 2.0 platform folder -> binary suffix
PLATFORMS = {"linux64": ".so", "win64": ".dll"}
VARIABLES_FILE = "spacerobot_variables.txt"
ROBOT_FILE = "robot.txt"
LOG_CATEGORIES = {
    "logEvents": "Lifecycle: instantiation, initialisation",
    "logStatusWarning": "Samples skipped and other warnings",
    "logStatusDiscard": "Communication steps refused",
    "logStatusError": "Refused calls: invalid parameters, wrong phase, type or value reference",
    "logAll": "Everything",
}


#: the base body written into the estimator's robot record: the estimator reads only the arm
PLACEHOLDER_BODY = RigidBody(1.0, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0, 0.0, 0.0, 0.0))


def known_robot(kind: str, robot: Robot) -> Robot:
    """What the FMU ``kind`` may know of ``robot``: the estimator only the arm (the base body a
    placeholder), the plant everything."""
    return dataclasses.replace(robot, base=PLACEHOLDER_BODY) if kind == "estimator" else robot


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


def variable_table(variables: Sequence[Var], model_identifier: str, guid: str) -> str:
    """``resources/spacerobot_variables.txt``: one line per variable, in value-reference order."""
    lines = ["spacerobot-variables 1",
             "# vr type causality variability start(IEEE-754 bits) key name",
             f"model {model_identifier}", f"guid {guid}"]
    for vr, v in enumerate(variables):
        start = v.start if v.start is not None else 0.0
        lines.append(f"{vr} {v.type} {v.causality} {v.variability} {_hex(start)} "
                     f"{key_string(v.key)} {v.name}")
    return "\n".join(lines) + "\n"


def _start_text(v: Var) -> str:
    if v.type == "Integer":
        return str(int(v.start))
    return repr(float(v.start))


def model_description(variables: Sequence[Var], model_identifier: str, guid: str,
                      description: str, sc: Scenario) -> str:
    """The FMI 2.0 model description of a native co-simulation FMU."""
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
    units = ET.SubElement(root, "UnitDefinitions")
    for u in sorted({v.unit for v in variables if v.unit and v.type == "Real"}):
        unit = ET.SubElement(units, "Unit", name=u)
        if UNITS[u]:
            ET.SubElement(unit, "BaseUnit", {k: str(e) for k, e in UNITS[u].items()})
    cats = ET.SubElement(root, "LogCategories")
    for name, what in LOG_CATEGORIES.items():
        ET.SubElement(cats, "Category", name=name, description=what)
    ET.SubElement(root, "DefaultExperiment", startTime="0.0", stopTime=repr(float(sc.stop_time)),
                  stepSize=repr(float(sc.sample_time)))
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
        else:
            outputs.append(vr + 1)
        ET.SubElement(sv, v.type, t)
    ms = ET.SubElement(root, "ModelStructure")
    outs = ET.SubElement(ms, "Outputs")
    for i in outputs:                       # outputs change only in doStep: no direct feedthrough
        ET.SubElement(outs, "Unknown", index=str(i), dependencies="")
    init = ET.SubElement(ms, "InitialUnknowns")
    for i in outputs:
        ET.SubElement(init, "Unknown", index=str(i))
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def binaries(model_identifier: str, lib_dir: Path = LIB_DIR) -> Dict[str, Path]:
    """``{platform: path}`` of the model's binaries the install step built."""
    out = {}
    for plat, suffix in PLATFORMS.items():
        p = Path(lib_dir) / "fmu" / plat / f"{model_identifier}{suffix}"
        if p.is_file():
            out[plat] = p
    return out


def build_native_fmu(kind: str, sc: Scenario, out_dir: str | Path, lib_dir: Path = LIB_DIR) -> Path:
    """Build the native FMU ``kind`` for the scenario's robot into ``out_dir``; returns its path."""
    from ..core.robot_record import robot_record_text

    if kind not in MODELS:
        raise ValueError(f"no native FMU for {kind!r} yet; native: {sorted(MODELS)}")
    ident, variables_of, description = MODELS[kind]
    bins = binaries(ident, lib_dir)
    if "linux64" not in bins:
        raise NativeUnavailable(
            f"the native {kind} binary is not built ({Path(lib_dir) / 'fmu'} has no linux64/"
            f"{ident}.so): reinstall the package (pip install -e .), which compiles it")
    variables = variables_of(sc.robot, sc)
    robot_text = robot_record_text(known_robot(kind, sc.robot))
    table0 = variable_table(variables, ident, "")
    digest = hashlib.sha256((ident + table0 + robot_text).encode()).digest()
    guid = "{%s}" % uuid.UUID(bytes=digest[:16], version=4)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"{ident}.fmu"
    tmp = path.with_suffix(".fmu.part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr("modelDescription.xml",
                    model_description(variables, ident, guid, description, sc))
        for plat, p in sorted(bins.items()):
            zf.write(p, f"binaries/{plat}/{p.name}")
        zf.writestr(f"resources/{VARIABLES_FILE}", variable_table(variables, ident, guid))
        zf.writestr(f"resources/{ROBOT_FILE}", robot_text)
    tmp.replace(path)
    return path
