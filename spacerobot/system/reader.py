"""The system reader: ``SystemStructure.ssd`` (and the ``.ssv`` files it binds) -> :class:`SystemInfo`.

:func:`open_system` opens what the user gave (a ``.ssp`` archive or an extracted folder) and
reports every problem with that file (not a zip, a corrupt archive, no SSD, malformed XML) as
a :class:`~.errors.SimulationError` naming the user's file, never a temporary path.
:func:`system_of_fmus` describes a system of FMU files wired name to name instead, and
:func:`wired_system` one with the connections given, for runs without an SSD (the cross-check
references).
"""
from __future__ import annotations

import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Mapping, Optional, Tuple

from lxml import etree

from .errors import SimulationError
from .ssd import NS, SSD_NAME

#: (name, FMI type, value as text, unit or None)
ParameterValue = Tuple[str, str, str, Optional[str]]


@dataclass
class Binding:
    """One ParameterBinding: its values and the prefix to prepend to their names."""

    source: Optional[str]                      # path inside the SSP, or None when inline
    prefix: str
    values: List[ParameterValue]


@dataclass
class ComponentInfo:
    name: str
    source: str                                # FMU path, relative to the system folder
    connectors: List[Tuple[str, str]]          # (name, kind)
    bindings: List[Binding] = field(default_factory=list)


@dataclass
class SystemInfo:
    """What the runner needs from ``SystemStructure.ssd``."""

    name: str
    components: Dict[str, ComponentInfo]
    connections: List[Tuple[str, str, str, str]]   # (start element, connector, end element, connector)
    system_bindings: List[Binding] = field(default_factory=list)
    start_time: float = 0.0
    stop_time: Optional[float] = None
    step_size: Optional[float] = None
    parameter_sets: List[str] = field(default_factory=list)   # names of resources/*.ssv


def read_ssv(path: str | Path) -> List[ParameterValue]:
    """The parameters of an ``.ssv`` file."""
    return _parameters(etree.parse(str(path)).getroot())


def _parameters(pset) -> List[ParameterValue]:
    out = []
    for p in pset.findall("ssv:Parameters/ssv:Parameter", namespaces=NS):
        for typ in ("Real", "Integer", "Boolean", "String", "Enumeration"):
            e = p.find(f"ssv:{typ}", namespaces=NS)
            if e is not None:
                out.append((p.get("name"), typ, e.get("value"), e.get("unit")))
                break
    return out


def _bindings(elem, root_dir: Path) -> List[Binding]:
    out = []
    for b in elem.findall("ssd:ParameterBindings/ssd:ParameterBinding", namespaces=NS):
        src = b.get("source")
        if src is not None:
            path = root_dir / src
            if not path.exists():
                raise SimulationError(f"ParameterBinding source {src!r} of {elem.get('name')!r} "
                                      f"not found in the system package")
            values = read_ssv(path)
        else:
            values = []
            for ps in b.findall("ssd:ParameterValues/ssv:ParameterSet", namespaces=NS):
                values += _parameters(ps)
        out.append(Binding(src, b.get("prefix") or "", values))
    return out


def _step_size(root, system) -> Optional[float]:
    """The communication step from the root System's ``oms:FixedStepMaster`` or
    DefaultExperiment's ``osp:FixedStepAlgorithm`` annotation (they must agree)."""
    de = root.find("ssd:DefaultExperiment", namespaces=NS)
    oms = system.find("ssd:Annotations/ssc:Annotation/oms:Annotations/oms:SimulationInformation/"
                      "oms:FixedStepMaster", namespaces=NS)
    osp = None if de is None else de.find(
        "ssd:Annotations/ssc:Annotation/osp:Algorithm/osp:FixedStepAlgorithm", namespaces=NS)
    steps = {}
    if oms is not None and oms.get("stepSize"):
        steps["oms:FixedStepMaster"] = float(oms.get("stepSize"))
    if osp is not None and osp.get("baseStepSize"):
        steps["osp:FixedStepAlgorithm"] = float(osp.get("baseStepSize"))
    if len(set(steps.values())) > 1:
        raise SimulationError(f"the SSD gives different step sizes: {steps}")
    return next(iter(steps.values()), None)


def read_system(root_dir: str | Path) -> SystemInfo:
    """Parse ``SystemStructure.ssd`` in an extracted system folder ``root_dir``."""
    root_dir = Path(root_dir)
    ssd_path = root_dir / SSD_NAME
    if not ssd_path.exists():
        raise SimulationError(f"{ssd_path} not found: not an SSP system folder")
    root = etree.parse(str(ssd_path)).getroot()
    system = root.find("ssd:System", namespaces=NS)
    if system is None:
        raise SimulationError(f"{SSD_NAME} has no System element")
    comps: Dict[str, ComponentInfo] = {}
    for c in system.findall("ssd:Elements/ssd:Component", namespaces=NS):
        conns = [(k.get("name"), k.get("kind"))
                 for k in c.findall("ssd:Connectors/ssd:Connector", namespaces=NS)]
        comps[c.get("name")] = ComponentInfo(c.get("name"), c.get("source"), conns,
                                             _bindings(c, root_dir))
    if system.find("ssd:Elements/ssd:System", namespaces=NS) is not None:
        raise SimulationError("nested systems are not supported by this runner (flat root "
                              "System expected)")
    connections = [(k.get("startElement"), k.get("startConnector"), k.get("endElement"),
                    k.get("endConnector"))
                   for k in system.findall("ssd:Connections/ssd:Connection", namespaces=NS)]
    for a, ac, b, bc in connections:
        if a not in comps or b not in comps:
            raise SimulationError(f"connection {a}.{ac} -> {b}.{bc}: only connections between "
                                  f"components of the root System are supported")
    de = root.find("ssd:DefaultExperiment", namespaces=NS)
    start = float(de.get("startTime", 0.0)) if de is not None else 0.0
    stop = float(de.get("stopTime")) if de is not None and de.get("stopTime") else None
    sets = sorted(p.stem for p in (root_dir / "resources").glob("*.ssv"))
    return SystemInfo(root.get("name"), comps, connections, _bindings(system, root_dir), start,
                      stop, _step_size(root, system), sets)


def open_system(path: str | Path, tmp: Path) -> Tuple[Path, SystemInfo]:
    """``(system folder, SystemInfo)`` of a ``.ssp`` archive (extracted into ``tmp``) or an
    extracted folder; every failure is a SimulationError (FileNotFoundError for a missing
    file) whose message names ``path``."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path} does not exist")
    if path.is_dir():
        root_dir = path
    else:
        if not zipfile.is_zipfile(path):
            raise SimulationError(f"{path} is neither a folder nor a .ssp (zip) archive")
        root_dir = tmp / "ssp"
        try:
            with zipfile.ZipFile(path) as zf:
                if SSD_NAME not in zf.namelist():
                    raise SimulationError(f"{path} has no {SSD_NAME}: not an SSP package")
                zf.extractall(root_dir)
        except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError) as e:
            raise SimulationError(f"{path} is a damaged zip archive ({e})") from None
    if not (root_dir / SSD_NAME).exists():
        raise SimulationError(f"{path} has no {SSD_NAME}: not an SSP system folder")
    try:
        return root_dir, read_system(root_dir)
    except etree.XMLSyntaxError as e:
        raise SimulationError(f"{path}: {SSD_NAME} or a parameter set in it is not well-formed "
                              f"XML ({e})") from None
    except SimulationError as e:
        raise SimulationError(f"{path}: {e}") from None


def system_of_fmus(fmus: Mapping[str, str | Path], step_size: float, stop_time: float,
                   start_time: float = 0.0, name: str = "system") -> SystemInfo:
    """A system of the FMU files ``fmus`` (``{component: path}``, in stepping order), every
    input wired to the output of the same name of another component, in both directions.

    Raises
    ------
    SimulationError
        An input that two other components provide.
    """
    from fmpy import read_model_description

    causal = {}
    for comp, path in fmus.items():
        md = read_model_description(str(path))
        causal[comp] = {v.name: v.causality for v in md.modelVariables}
    connections = []
    for b, variables in causal.items():
        for n, kind in variables.items():
            if kind != "input":
                continue
            sources = [a for a in causal if a != b and causal[a].get(n) == "output"]
            if len(sources) > 1:
                raise SimulationError(f"input {b}.{n} is an output of {sources}: ambiguous")
            if sources:
                connections.append((sources[0], n, b, n))
    return wired_system(fmus, connections, step_size, stop_time, start_time, name)


def wired_system(fmus: Mapping[str, str | Path], connections: List[Tuple[str, str, str, str]],
                 step_size: float, stop_time: float, start_time: float = 0.0,
                 name: str = "system") -> SystemInfo:
    """A system of the FMU files ``fmus`` (``{component: path}``, in stepping order) with the
    ``connections`` given (``(output component, output, input component, input)``)."""
    connectors: Dict[str, List[Tuple[str, str]]] = {c: [] for c in fmus}
    for a, ac, b, bc in connections:
        connectors[a].append((ac, "output"))
        connectors[b].append((bc, "input"))
    comps = {c: ComponentInfo(c, str(Path(p).resolve()), connectors[c]) for c, p in fmus.items()}
    return SystemInfo(name, comps, list(connections), start_time=start_time, stop_time=stop_time,
                      step_size=step_size)
