"""SSP 1.0 system structure of the plant + estimator pair, generated from one source.

Everything here is derived from :mod:`spacerobot.interface` (variables, units, connections) and
:mod:`spacerobot.robots` (robots, targets, scenarios); the files in the repository folder
``ssp/`` are the output of :func:`write_ssp_sources` and are never edited by hand (a test checks
that they equal the generator output).

Layout of a generated system (the same inside ``<robot>.ssp`` and under ``ssp/<robot>/``)::

    SystemStructure.ssd
    resources/SpaceRobotPlant.fmu          (only in the .ssp)
    resources/SpaceRobotEstimator.fmu      (only in the .ssp)
    resources/SpaceRobotSensors.fmu        (only in <robot>_sensors.ssp)
    resources/<set>.ssv                    one parameter set per scenario
                                           (robots.PARAMETER_SETS; planar: small, medium,
                                           large, paper, excited; spatial: paper, default,
                                           depletion)
    resources/estimator/<set>.ssv          the estimator settings of that set
                                           (ESTIMATOR_SET_PARAMETERS; e.g. depletion:
                                           lambda 0.98, ident.excite_mode 2)

The system with the sensors FMU (``sensors=True``, ``<robot>_sensors.ssp``, SSD name
``SpaceRobot_<robot>_sensors``) wires plant ``<name>`` -> sensors ``true.<name>``, sensors
``<name>`` -> estimator ``<name>``; its parameter sets add ``ideal`` and ``realistic`` (the
sensors' ``noise.scale`` 0 / 1; bound: ``realistic``): the plant's values of a set in
``resources/<set>.ssv``, the sensors' in ``resources/sensors/<set>.ssv``, so that each
component is bound only to variables it has. The two-FMU system stays the default and the one the
paper's parameter sets are made for. docs/sensors.md.

Tool compatibility (what OMSimulator and libcosim need to load the .ssp): ``version="1.0"``; namespace prefixes exactly ``ssd:``,
``ssc:``, ``ssv:``; one flat root System holding the two components; every connector typed
(``<ssc:Real unit="..."/>`` or ``<ssc:Integer/>``) with its unit declared in ``ssd:Units``; the
parameter set bound at component level (a ParameterBinding on the plant component, and one on
the estimator component to the set's ``resources/estimator/<set>.ssv``); the
communication step in the root System's ``oms:FixedStepMaster`` annotation (OMSimulator) and in
DefaultExperiment's ``osp:FixedStepAlgorithm`` annotation (libcosim / OSP).
"""
from __future__ import annotations

import zipfile
from pathlib import Path
from typing import Callable, Dict, List, Optional, Tuple
from xml.sax.saxutils import quoteattr

from ..interface import (ESTIMATE_NAMES, EXCITATION_DOC, PROPELLANT_DOC, UNITS, Var,
                         connections, estimator_vars, feedback_connections, plant_vars,
                         sensor_connections, sensors_vars)
from ..robots import (DEFAULT_TARGET, PARAMETER_SETS, ROBOTS, check_robot, get_robot,
                      parameter_set_scenario, robot_files, robot_kind, robot_label, scenario)

#: XML namespaces (prefixes are part of the contract: some tools match on them)
NS = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd",
    "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
}

#: component names in the root System, and the FMU files they reference
PLANT = "plant"
ESTIMATOR = "estimator"
SENSORS = "sensors"
SOURCES = {PLANT: "resources/SpaceRobotPlant.fmu", ESTIMATOR: "resources/SpaceRobotEstimator.fmu",
           SENSORS: "resources/SpaceRobotSensors.fmu"}
#: the parameter of the sensors FMU that the sensors parameter sets bind
SENSOR_SET_PARAMETERS: Tuple[str, ...] = ("noise.scale",)
#: the parameter set bound in the system with the sensors FMU
SENSORS_DEFAULT_SET = "realistic"
SSD_NAME = "SystemStructure.ssd"
GENERATOR = "spacerobot.system.ssd"

#: the plant parameters a parameter set binds (the scenario's truth, initial velocities,
#: excitation bounds, propellant and flexible parts: the counts flex.n, slosh.n and every
#: record of the panels and slosh modes)
SET_PARAMETERS: Tuple[str, ...] = (
    ESTIMATE_NAMES + tuple(f"base.v0[{i}]" for i in (1, 2, 3))
    + tuple(f"base.omega0[{i}]" for i in (1, 2, 3))
    + tuple(f"excite.{k}" for k in EXCITATION_DOC)
    + tuple(f"prop.{k}" for k in PROPELLANT_DOC) + tuple(f"prop.r[{i}]" for i in (1, 2, 3)))


def set_parameters(variables: List[Var]) -> Tuple[str, ...]:
    """The names of the plant parameters a parameter set binds: :data:`SET_PARAMETERS`, then
    those of the flexible parts (``flex.*``, ``slosh.*``) in the FMU's order."""
    return SET_PARAMETERS + tuple(
        v.name for v in variables if v.causality == "parameter"
        and v.name.split(".", 1)[0] in ("flex", "slosh"))

#: the estimator parameters a parameter set binds (``resources/estimator/<set>.ssv``): every
#: estimator setting any set has (:attr:`spacerobot.robots.ParameterSet.estimator`); a set
#: without one binds the estimator's default
ESTIMATOR_SET_PARAMETERS: Tuple[str, ...] = tuple(sorted(
    {k for sets in PARAMETER_SETS.values() for ps in sets.values() for k, _ in ps.estimator}))
#: folder (inside ``resources/``) of the estimator's files of the parameter sets
ESTIMATOR_SET_DIR = "estimator"
#: folder (inside ``resources/``) of the sensors' files of the parameter sets with a noise level
SENSORS_SET_DIR = "sensors"


def _check_robot(robot: str) -> None:
    """``robot``: a built-in name or a URDF robot key (:func:`spacerobot.robots.robot_spec`)."""
    check_robot(robot)


def parameter_set_names(robot: str, sensors: bool = False) -> List[str]:
    """Names of the parameter sets (.ssv) generated for ``robot``
    (:data:`spacerobot.robots.PARAMETER_SETS`); the sets with a noise level (``ideal``,
    ``realistic``) only for the system with the sensors FMU."""
    _check_robot(robot)
    sets = PARAMETER_SETS[robot_kind(robot)]
    return [n for n, ps in sets.items() if sensors or ps.noise is None]


def default_parameter_set(robot: str, sensors: bool = False) -> str:
    """The parameter set bound in the SSD: the robot's default target (e.g. planar: medium);
    with the sensors FMU ``realistic``."""
    _check_robot(robot)
    return SENSORS_DEFAULT_SET if sensors else DEFAULT_TARGET[robot_kind(robot)]


def system_name(robot: str, sensors: bool = False) -> str:
    """File stem of the packaged system: ``<robot>`` or ``<robot>_sensors``."""
    return f"{robot_label(robot)}_sensors" if sensors else robot_label(robot)


def _num(x: float) -> str:
    """Shortest exact text of a float (round-trips, deterministic)."""
    return repr(float(x))


def _check_set(robot: str, name: str) -> None:
    if name not in parameter_set_names(robot, sensors=True):
        raise ValueError(f"unknown parameter set {name!r} for robot {robot!r}; "
                         f"choose from {parameter_set_names(robot, sensors=True)}")


def parameter_set(robot: str, name: str) -> List[Tuple[str, str, float, Optional[str]]]:
    """``[(variable name, FMI type, value, unit or None), ...]`` of the plant's values of
    parameter set ``name`` of ``robot`` (:func:`set_parameters`)."""
    _check_set(robot, name)
    sc = parameter_set_scenario(robot, name)
    variables = plant_vars(sc.robot, sc)                  # starts = the scenario's values
    var = {v.name: v for v in variables}
    return [(n, var[n].type, float(var[n].start), var[n].unit)
            for n in set_parameters(variables)]


def sensors_parameter_set(robot: str, name: str) -> List[Tuple[str, float, str]]:
    """``[(variable name, value, unit), ...]`` of the sensors' values of parameter set ``name``:
    ``noise.scale`` for a set with a noise level, else none (the sensors FMU's defaults)."""
    _check_set(robot, name)
    noise = PARAMETER_SETS[robot_kind(robot)][name].noise
    return [] if noise is None else [("noise.scale", float(noise), "1")]


def estimator_parameter_set(robot: str, name: str) -> List[Tuple[str, str, float, Optional[str]]]:
    """``[(variable name, FMI type, value, unit or None), ...]`` of the estimator's file of
    parameter set ``name`` (:data:`ESTIMATOR_SET_PARAMETERS`): the set's estimator settings,
    the estimator FMU's defaults for the others."""
    _check_set(robot, name)
    sc = parameter_set_scenario(robot, name)
    var = {v.name: v for v in estimator_vars(sc.robot, sc)}
    chosen = dict(PARAMETER_SETS[robot_kind(robot)][name].estimator)
    return [(n, var[n].type, float(chosen.get(n, var[n].start)), var[n].unit)
            for n in ESTIMATOR_SET_PARAMETERS]


def _units_xml(units, indent: str, prefix: str) -> List[str]:
    out = [f"{indent}<{prefix}:Units>"]
    for u in sorted(units):
        exps = UNITS[u]
        attrs = "".join(f" {k}={quoteattr(str(e))}" for k, e in exps.items())
        out.append(f"{indent}  <ssc:Unit name={quoteattr(u)}>")
        out.append(f"{indent}    <ssc:BaseUnit{attrs}/>")
        out.append(f"{indent}  </ssc:Unit>")
    out.append(f"{indent}</{prefix}:Units>")
    return out


def _ssv_text(name: str, desc: str, params: List[Tuple[str, str, float, Optional[str]]]) -> str:
    """An SSP 1.0 parameter values file: ``params`` = ``[(name, FMI type, value, unit)]``."""
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<ssv:ParameterSet xmlns:ssv="{NS["ssv"]}" xmlns:ssc="{NS["ssc"]}"',
             f'    version="1.0" name={quoteattr(name)} generationTool="{GENERATOR}"',
             f'    description={quoteattr(desc)}>',
             "  <ssv:Parameters>"]
    for pname, typ, value, unit in params:
        lines.append(f"    <ssv:Parameter name={quoteattr(pname)}>")
        if typ == "Integer":
            lines.append(f"      <ssv:Integer value=\"{int(value)}\"/>")
        else:
            u = f" unit={quoteattr(unit)}" if unit else ""
            lines.append(f"      <ssv:Real value=\"{_num(value)}\"{u}/>")
        lines.append("    </ssv:Parameter>")
    lines.append("  </ssv:Parameters>")
    units = {u for _, typ, _, u in params if typ == "Real" and u}
    if units:
        lines += _units_xml(units, "  ", "ssv")
    lines.append("</ssv:ParameterSet>")
    return "\n".join(lines) + "\n"


def ssv_xml(robot: str, name: str) -> str:
    """Text of the SSP 1.0 parameter values file ``resources/<name>.ssv`` (the plant's)."""
    pset = PARAMETER_SETS[robot_kind(robot)][name]
    desc = (f"{robot_label(robot)}-{name}: {pset.description}; plant truth (base, "
            f"target), initial velocities, excitation bounds, propellant and flexible parts")
    return _ssv_text(name, desc, parameter_set(robot, name))


def sensors_ssv_xml(robot: str, name: str) -> str:
    """Text of ``resources/sensors/<name>.ssv``: the sensors' values of parameter set ``name``."""
    pset = PARAMETER_SETS[robot_kind(robot)][name]
    desc = f"{robot_label(robot)}-{name}: {pset.description}; sensors noise level"
    return _ssv_text(name, desc,
                     [(n, "Real", v, u) for n, v, u in sensors_parameter_set(robot, name)])


def estimator_ssv_xml(robot: str, name: str) -> str:
    """Text of ``resources/estimator/<name>.ssv``: the estimator settings of parameter set
    ``name`` (:func:`estimator_parameter_set`), bound to the estimator component."""
    params = estimator_parameter_set(robot, name)
    desc = (f"{robot_label(robot)}-{name}: estimator settings of the set "
            f"({', '.join(n for n, _, _, _ in params)})")
    return _ssv_text(name, desc, params)


def estimator_ssv_path(name: str) -> str:
    """Path inside the system of the estimator's file of parameter set ``name``."""
    return f"resources/{ESTIMATOR_SET_DIR}/{name}.ssv"


def sensors_ssv_path(name: str) -> str:
    """Path inside the system of the sensors' file of parameter set ``name``."""
    return f"resources/{SENSORS_SET_DIR}/{name}.ssv"


def _connector(var: Var, kind: str, indent: str) -> List[str]:
    if var.type == "Real":
        typ = f"<ssc:Real unit={quoteattr(var.unit)}/>" if var.unit else "<ssc:Real/>"
    else:
        typ = f"<ssc:{var.type}/>"
    return [f"{indent}<ssd:Connector name={quoteattr(var.name)} kind=\"{kind}\">",
            f"{indent}  {typ}",
            f"{indent}</ssd:Connector>"]


def component_connectors(robot: str, sensors: bool = False
                         ) -> Dict[str, List[Tuple[str, str, Var]]]:
    """``{component: [(connector name, kind, Var), ...]}`` as declared in the SSD.

    The plant exposes every output, its input ``ident.excite`` (the excitation loop) and the
    parameters that the parameter sets bind; the estimator exposes every input (all
    connected), every output and the parameters the sets bind
    (:data:`ESTIMATOR_SET_PARAMETERS`); the sensors FMU (``sensors=True``) every input and output and
    ``noise.scale``.
    """
    _check_robot(robot)
    sc = scenario(robot)
    pv = plant_vars(sc.robot, sc)
    ev = estimator_vars(sc.robot, sc)
    plant = [(v.name, v.causality, v) for v in pv if v.causality in ("input", "output")]
    by_name = {v.name: v for v in pv}
    plant += [(n, "parameter", by_name[n]) for n in SET_PARAMETERS]
    est = [(v.name, v.causality, v) for v in ev if v.causality in ("input", "output")]
    by_name = {v.name: v for v in ev}
    est += [(n, "parameter", by_name[n]) for n in ESTIMATOR_SET_PARAMETERS]
    if not sensors:
        return {PLANT: plant, ESTIMATOR: est}
    sv = sensors_vars(sc.robot, sc)
    sens = [(v.name, v.causality, v) for v in sv if v.causality in ("input", "output")]
    sens += [(v.name, "parameter", v) for v in sv if v.name in SENSOR_SET_PARAMETERS]
    return {PLANT: plant, SENSORS: sens, ESTIMATOR: est}


def system_connections(robot: str, sensors: bool = False) -> List[Tuple[str, str, str, str]]:
    """Every ``(start component, start connector, end component, end connector)`` of the
    SSD, in the order the master serves them: plant -> estimator (or plant -> sensors ->
    estimator: the sensors are a direct feedthrough), then the excitation loop estimator ->
    plant."""
    _check_robot(robot)
    rb = get_robot(robot)
    if sensors:
        out = [(PLANT, a, SENSORS, b) for a, b in sensor_connections(rb)]
        out += [(SENSORS, n, ESTIMATOR, n) for n in connections(rb)]
    else:
        out = [(PLANT, n, ESTIMATOR, n) for n in connections(rb)]
    out += [(ESTIMATOR, n, PLANT, n) for n in feedback_connections()]
    return out


def ssd_xml(robot: str, bound_set: Optional[str] = None, sensors: bool = False) -> str:
    """Text of ``SystemStructure.ssd`` for ``robot`` with parameter set ``bound_set`` bound.

    Parameters
    ----------
    robot : str
        'planar', 'spatial' or a URDF robot key (:func:`spacerobot.robots.robot_spec`)
    bound_set : str, optional
        Parameter set bound to the plant component (and to the sensors component) (default:
        :func:`default_parameter_set`).
    sensors : bool
        Put the sensors FMU between plant and estimator (system ``SpaceRobot_<robot>_sensors``).
    """
    _check_robot(robot)
    bound_set = bound_set or default_parameter_set(robot, sensors)
    if bound_set not in parameter_set_names(robot, sensors):
        raise ValueError(f"unknown parameter set {bound_set!r} for robot {robot!r}; "
                         f"choose from {parameter_set_names(robot, sensors)}")
    sc = parameter_set_scenario(robot, bound_set)
    step = _num(sc.sample_time)
    conns = component_connectors(robot, sensors)
    units = {v.unit for c in conns.values() for _, _, v in c if v.type == "Real" and v.unit}
    robot_desc = get_robot(robot).description
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             "<ssd:SystemStructureDescription"
             + "".join(f'\n    xmlns:{p}="{u}"' for p, u in NS.items()),
             f'    version="1.0" name={quoteattr("SpaceRobot_" + system_name(robot, sensors))} '
             f'generationTool="{GENERATOR}"',
             f"    description={quoteattr(_SYSTEM_DESC[sensors] + robot_desc)}>",
             f'  <ssd:System name="root" description={quoteattr(_ROOT_DESC[sensors])}>',
             "    <ssd:Elements>"]
    for comp in conns:
        lines.append(f'      <ssd:Component name="{comp}" type="application/x-fmu-sharedlibrary" '
                     f'source="{SOURCES[comp]}">')
        lines.append("        <ssd:Connectors>")
        for _, kind, var in conns[comp]:
            lines += _connector(var, kind, "          ")
        lines.append("        </ssd:Connectors>")
        source = {PLANT: f"resources/{bound_set}.ssv",
                  SENSORS: (sensors_ssv_path(bound_set)
                            if sensors_parameter_set(robot, bound_set) else None),
                  ESTIMATOR: estimator_ssv_path(bound_set) if ESTIMATOR_SET_PARAMETERS else None
                  }[comp]
        if source:
            lines += ["        <ssd:ParameterBindings>",
                      f'          <ssd:ParameterBinding type="application/x-ssp-parameter-set" '
                      f'source="{source}"/>',
                      "        </ssd:ParameterBindings>"]
        lines.append("      </ssd:Component>")
    lines.append("    </ssd:Elements>")
    lines.append("    <ssd:Connections>")
    for a, ac, b, bc in system_connections(robot, sensors):
        lines.append(f'      <ssd:Connection startElement="{a}" startConnector={quoteattr(ac)} '
                     f'endElement="{b}" endConnector={quoteattr(bc)}/>')
    lines.append("    </ssd:Connections>")
    lines += ["    <ssd:Annotations>",
              '      <ssc:Annotation type="org.openmodelica">',
              "        <oms:Annotations>",
              "          <oms:SimulationInformation>",
              f'            <oms:FixedStepMaster description="oms-ma" stepSize="{step}"/>',
              "          </oms:SimulationInformation>",
              "        </oms:Annotations>",
              "      </ssc:Annotation>",
              "    </ssd:Annotations>",
              "  </ssd:System>"]
    lines += _units_xml(units, "  ", "ssd")
    lines += [f'  <ssd:DefaultExperiment startTime="0.0" stopTime="{_num(sc.stop_time)}">',
              "    <ssd:Annotations>",
              '      <ssc:Annotation type="com.opensimulationplatform">',
              "        <osp:Algorithm>",
              f'          <osp:FixedStepAlgorithm baseStepSize="{step}"/>',
              "        </osp:Algorithm>",
              "      </ssc:Annotation>",
              "    </ssd:Annotations>",
              "  </ssd:DefaultExperiment>",
              "</ssd:SystemStructureDescription>"]
    return "\n".join(lines) + "\n"


_SYSTEM_DESC = {
    False: "Space robot after capture: plant and inertial-parameter estimator. ",
    True: "Space robot after capture: plant, sensors and inertial-parameter estimator. ",
}
_ROOT_DESC = {
    False: "Plant outputs wired to the estimator inputs of the same name; the estimator's "
           "excitation request wired back to the plant",
    True: "Plant outputs wired to the sensors inputs true.<name>, sensors outputs to the "
          "estimator inputs of the same name; the estimator's excitation request wired back "
          "to the plant",
}


def generate(robot: str, sensors: bool = False) -> Dict[str, str]:
    """``{relative path: text}`` of every generated file of ``robot``'s system (SSD + SSVs);
    ``sensors``: the system with the sensors FMU."""
    files = {SSD_NAME: ssd_xml(robot, sensors=sensors)}
    for name in parameter_set_names(robot, sensors):
        files[f"resources/{name}.ssv"] = ssv_xml(robot, name)
        if ESTIMATOR_SET_PARAMETERS:
            files[estimator_ssv_path(name)] = estimator_ssv_xml(robot, name)
        if sensors and sensors_parameter_set(robot, name):
            files[sensors_ssv_path(name)] = sensors_ssv_xml(robot, name)
    return files


#: the repository folder holding the committed, generated files
SSP_SOURCE_DIR = Path(__file__).resolve().parents[2] / "ssp"


def write_ssp_sources(dest: str | Path = SSP_SOURCE_DIR) -> List[Path]:
    """Write the generated .ssd/.ssv of every robot to ``dest/<robot>/`` (default: repo ``ssp/``).

    Returns the written paths. Run ``python -m spacerobot.system.ssd`` after changing
    :mod:`spacerobot.interface` or :mod:`spacerobot.robots`, and commit the result.
    """
    dest = Path(dest)
    written = []
    for robot in ROBOTS:
        for rel, text in generate(robot).items():
            p = dest / robot / rel
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_text(text, encoding="utf-8")
            written.append(p)
    return written


def build_system(robot: str, out_dir: str | Path, fmus: Optional[Dict[str, Path]] = None,
                 sensors: bool = False, fmi_version: int = 2) -> Dict[str, Path]:
    """Build the FMUs, the SSD, the SSVs and the packaged ``<robot>.ssp`` into ``out_dir``.

    Parameters
    ----------
    robot : str
        'planar', 'spatial' or a URDF robot key (:func:`spacerobot.robots.robot_spec`)
    out_dir : path
        Output folder (created).
    fmus : dict, optional
        Already built ``{'plant': path, 'estimator': path[, 'sensors': path]}`` for this
        robot, to package instead of building them again (a missing one is built).
    sensors : bool
        The system with the sensors FMU between plant and estimator: ``<robot>_sensors.ssp``
        (its SSD and parameter sets go to ``out_dir/<robot>_sensors/``).
    fmi_version : int
        2 (default) or 3: FMI 3.0 FMUs, with the same variable names, so that the SSD and its
        parameter sets are the same text (docs/fmus.md).

    Returns
    -------
    dict
        ``{'plant': .fmu, 'estimator': .fmu[, 'sensors': .fmu], 'ssd': SystemStructure.ssd,
        'ssv:<set>': .ssv ..., 'ssp': <robot>[_sensors].ssp}`` (``<robot>``:
        :func:`spacerobot.robots.robot_label`).
    """
    from ..fmi.build import build_fmu

    _check_robot(robot)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    kinds = (PLANT, SENSORS, ESTIMATOR) if sensors else (PLANT, ESTIMATOR)
    fmus = dict(fmus or {})
    for kind in kinds:
        if kind not in fmus:
            fmus[kind] = build_fmu(kind, scenario(robot), out, fmi_version)
    paths: Dict[str, Path] = {k: Path(fmus[k]) for k in kinds}
    files = generate(robot, sensors)
    src_dir = out / system_name(robot, True) if sensors else out
    for rel, text in files.items():
        p = src_dir / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text, encoding="utf-8")
        key = ("ssd" if rel == SSD_NAME else "ssv:" + Path(rel).stem if Path(rel).parent.name
               != ESTIMATOR_SET_DIR else f"ssv:{ESTIMATOR}:" + Path(rel).stem)
        paths[key] = p
    ssp = out / f"{system_name(robot, sensors)}.ssp"
    tmp = ssp.with_suffix(".ssp.part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as zf:
        zf.writestr(SSD_NAME, files[SSD_NAME])
        for kind in kinds:
            zf.write(paths[kind], SOURCES[kind])
        for rel, text in files.items():
            if rel != SSD_NAME:
                zf.writestr(rel, text)
    tmp.replace(ssp)
    paths["ssp"] = ssp
    return paths


def _system_name(ssp: str | Path) -> str:
    """The SSD's system name of a .ssp archive or its extracted folder ("" if unreadable)."""
    from lxml import etree

    ssp = Path(ssp)
    try:
        if ssp.is_dir():
            text = (ssp / SSD_NAME).read_bytes()
        else:
            with zipfile.ZipFile(ssp) as zf:
                text = zf.read(SSD_NAME)
        return etree.fromstring(text).get("name") or ""
    except (OSError, KeyError, zipfile.BadZipFile, etree.XMLSyntaxError):
        return ""


def robot_of(ssp: str | Path) -> Optional[str]:
    """Robot name of a system built by :func:`build_system` (a .ssp archive or its extracted
    folder), from the SSD name ``SpaceRobot_<robot>``; None if it is not one of ours."""
    robot = _system_name(ssp).removeprefix("SpaceRobot_").removesuffix("_sensors")
    return robot if robot in ROBOTS else None


def has_sensors(ssp: str | Path) -> bool:
    """Whether a system built by :func:`build_system` has the sensors FMU (SSD name
    ``SpaceRobot_<robot>_sensors``)."""
    return _system_name(ssp).endswith("_sensors")


def _newest_source_mtime(robot: Optional[str] = None) -> float:
    """Newest modification time of the files the FMUs and the SSD are built from: the library's
    Python sources, the native binaries, the URDF of ``robot``."""
    lib = Path(__file__).resolve().parents[1]              # the spacerobot package
    paths = [*lib.rglob("*.py"), *(lib / "core" / "lib").rglob("*.*"),
             *(robot_files(robot) if robot else ())]
    return max(p.stat().st_mtime for p in paths if p.exists())


def default_build_dir(robot: str, fmi_version: int = 2) -> Path:
    """``build/<robot>/`` (FMI 2.0) or ``build/<robot>-fmi3/`` (FMI 3.0), in the current
    directory (``<robot>``: :func:`spacerobot.robots.robot_label`)."""
    return Path("build") / (robot_label(robot) + ("-fmi3" if fmi_version == 3 else ""))


def _fmi_version_of(fmu: bytes) -> Optional[str]:
    """The ``fmiVersion`` of an FMU's model description (its bytes), None if it is not one of
    the native FMUs (no variable table)."""
    import io

    from lxml import etree

    from ..fmi.native import VARIABLES_FILE
    with zipfile.ZipFile(io.BytesIO(fmu)) as zf:
        if f"resources/{VARIABLES_FILE}" not in zf.namelist():
            return None
        return etree.fromstring(zf.read("modelDescription.xml")).get("fmiVersion")


def ensure_ssp(robot: str, out_dir: Optional[str | Path] = None, sensors: bool = False,
               on_build: Optional[Callable[[Path], None]] = None,
               fmi_version: int = 2) -> Path:
    """Path of ``<out_dir>/<robot>[_sensors].ssp``, (re)built with :func:`build_system` if it
    is missing, older than any library source it is built from, its SSD differs from the
    generator's, or its FMUs are not native FMI ``fmi_version`` ones.

    ``out_dir`` defaults to :func:`default_build_dir`. ``on_build(out_dir)`` is called just
    before a (re)build (the command line says so).
    """
    _check_robot(robot)
    out = Path(out_dir) if out_dir is not None else default_build_dir(robot, fmi_version)
    ssp = out / f"{system_name(robot, sensors)}.ssp"
    fresh = False
    if ssp.exists() and ssp.stat().st_mtime >= _newest_source_mtime(robot):
        try:
            with zipfile.ZipFile(ssp) as zf:
                fresh = (zf.read(SSD_NAME).decode("utf-8") == ssd_xml(robot, sensors=sensors)
                         and _fmi_version_of(zf.read(SOURCES[ESTIMATOR]))
                         == f"{fmi_version}.0")
        except (zipfile.BadZipFile, KeyError):
            fresh = False
    if not fresh:
        if on_build is not None:
            on_build(out)
        build_system(robot, out, sensors=sensors, fmi_version=fmi_version)
    return ssp


if __name__ == "__main__":  # regenerate the committed files
    for path in write_ssp_sources():
        print(path)
