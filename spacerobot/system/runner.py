"""A small co-simulation master for the SSP system that honours the SSD.

fmpy's :func:`fmpy.ssp.simulation.simulate_ssp` ignores ParameterBindings and DefaultExperiment
and starts every connector at 0.0. This master, built on fmpy's :class:`~fmpy.fmi2.FMU2Slave`:

1. reads ``SystemStructure.ssd`` from a ``.ssp`` archive or an extracted folder;
2. instantiates every FMU component and applies, before initialisation, the ParameterBindings
   (component level in element order, then system level, which takes precedence, as SSP 1.0
   specifies), or a named parameter set instead of the bound ``.ssv``, then explicit overrides;
3. takes start/stop time from ``DefaultExperiment`` and the communication step from the root
   System's ``oms:FixedStepMaster`` or DefaultExperiment's ``osp:FixedStepAlgorithm`` annotation;
4. steps all FMUs with a fixed step (Jacobi: at every communication point the outputs are copied
   to the connected inputs, the row is recorded, then every FMU steps);
5. records every connector and every output of every component (columns ``time``,
   ``<component>.<variable>``) and optionally writes them to CSV.

A row at time ``t`` holds the outputs at ``t`` and the inputs set at ``t``; the estimator
outputs in that row are computed from the samples before ``t`` (it consumes the sample at ``t``
during the step that starts at ``t``).

An FMI call that returns Discard, Error or Fatal raises :class:`SimulationError` naming the
component, the FMI function and the time, with the FMU's recent log messages. Every FMU instance
is terminated and freed, and temporary folders removed, also on error.
"""
from __future__ import annotations

import collections
import csv
import difflib
import math
import shutil
import sys
import tempfile
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
from lxml import etree

from ..interface import ESTIMATE_NAMES
from .ssd import NS, SSD_NAME

_STATUS = ["OK", "Warning", "Discard", "Error", "Fatal", "Pending"]


def estimate_names() -> List[str]:
    """The 20 estimate names, ``base.m``, ``base.b[1]`` ... ``base.Iyz``, ``target.m`` ...
    ``target.Iyz`` (the order of ``Identifier.vector()``; :data:`interface.ESTIMATE_NAMES`)."""
    return list(ESTIMATE_NAMES)


class SimulationError(RuntimeError):
    """An FMU returned Discard, Error or Fatal (or the system cannot be run)."""


# ----------------------------------------------------------------------------------------------
# SSD reading
# ----------------------------------------------------------------------------------------------

@dataclass
class Binding:
    """One ParameterBinding: its values and the prefix to prepend to their names."""

    source: Optional[str]                      # path inside the SSP, or None when inline
    prefix: str
    values: List[Tuple[str, str, str, Optional[str]]]  # (name, type, text value, unit)


@dataclass
class ComponentInfo:
    name: str
    source: str
    connectors: List[Tuple[str, str]]          # (name, kind)
    bindings: List[Binding]


@dataclass
class SystemInfo:
    """What the runner needs from ``SystemStructure.ssd``."""

    name: str
    components: Dict[str, ComponentInfo]
    connections: List[Tuple[str, str, str, str]]   # (start element, connector, end element, connector)
    system_bindings: List[Binding]
    start_time: float
    stop_time: Optional[float]
    step_size: Optional[float]
    parameter_sets: List[str]                      # names of resources/*.ssv in the package


def _read_ssv(path: Path) -> List[Tuple[str, str, str, Optional[str]]]:
    root = etree.parse(str(path)).getroot()
    return _parameters(root)


def _parameters(pset) -> List[Tuple[str, str, str, Optional[str]]]:
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
            values = _read_ssv(path)
        else:
            values = []
            for ps in b.findall("ssd:ParameterValues/ssv:ParameterSet", namespaces=NS):
                values += _parameters(ps)
        out.append(Binding(src, b.get("prefix") or "", values))
    return out


def read_system(root_dir: str | Path) -> SystemInfo:
    """Parse ``SystemStructure.ssd`` in an extracted system folder ``root_dir``."""
    root_dir = Path(root_dir)
    ssd_path = root_dir / SSD_NAME
    if not ssd_path.exists():
        raise SimulationError(f"{ssd_path} not found: not an SSP system folder")
    root = etree.parse(str(ssd_path)).getroot()
    system = root.find("ssd:System", namespaces=NS)
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
    sets = sorted(p.stem for p in (root_dir / "resources").glob("*.ssv"))
    return SystemInfo(root.get("name"), comps, connections, _bindings(system, root_dir), start,
                      stop, next(iter(steps.values()), None), sets)


# ----------------------------------------------------------------------------------------------
# FMU instances
# ----------------------------------------------------------------------------------------------

class _Log:
    """Collects FMU log messages, the last ``maxlen`` per instance (through
    :func:`~spacerobot.system.instance.logger_callbacks`, which explains why the logger is
    called directly rather than through fmpy's logger proxy)."""

    def __init__(self, maxlen: int = 200):
        from .instance import logger_callbacks

        self.messages: Dict[str, collections.deque] = collections.defaultdict(
            lambda: collections.deque(maxlen=maxlen))
        self.all: List[Tuple[str, str, str, str]] = []

        def sink(inst: str, status: int, category: str, text: str) -> None:
            label = _STATUS[status] if 0 <= status < len(_STATUS) else str(status)
            rec = (inst, label, category, text)
            self.messages[inst].append(rec)
            if status >= 1 and len(self.all) < 10000:   # warnings and worse
                self.all.append(rec)

        self.callbacks = logger_callbacks(sink)

    def recent(self, instance: str, n: int = 10) -> str:
        msgs = list(self.messages.get(instance, []))[-n:]
        if not msgs:
            return "  (the FMU logged no messages)"
        return "\n".join(f"  [{s}] {c}: {m}" for _, s, c, m in msgs)


class _Instance:
    """One instantiated FMU component with name-based access."""

    def __init__(self, comp: ComponentInfo, root_dir: Path, tmp: Path):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        self.name = comp.name
        self.comp = comp
        fmu_path = root_dir / comp.source
        if not fmu_path.exists():
            raise SimulationError(f"component {comp.name!r}: FMU {comp.source!r} not found")
        self.md = read_model_description(str(fmu_path))
        if self.md.fmiVersion != "2.0" or self.md.coSimulation is None:
            raise SimulationError(f"component {comp.name!r}: only FMI 2.0 co-simulation FMUs "
                                  f"are supported")
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.dir = extract(str(fmu_path), unzipdir=str(tmp / comp.name))
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self.dir,
                             modelIdentifier=self.md.coSimulation.modelIdentifier,
                             instanceName=comp.name)
        self.instantiated = False
        self.initialized = False
        self.fatal = False

    def var(self, name: str):
        try:
            return self.vars[name]
        except KeyError:
            close = difflib.get_close_matches(name, list(self.vars), n=3)
            hint = f"; did you mean {', '.join(close)}?" if close else ""
            raise KeyError(f"component {self.name!r} has no variable {name!r}{hint}") from None

    def set(self, name: str, value) -> None:
        v = self.var(name)
        vr = [v.valueReference]
        if v.type == "Real":
            self.fmu.setReal(vr, [float(value)])
        elif v.type in ("Integer", "Enumeration"):
            fv = float(value)
            if fv != int(fv):
                raise ValueError(f"{self.name}.{name} is an {v.type}; got non-integer {value!r}")
            self.fmu.setInteger(vr, [int(fv)])
        elif v.type == "Boolean":
            b = value if isinstance(value, bool) else str(value).lower() in ("1", "true", "1.0")
            self.fmu.setBoolean(vr, [b])
        else:
            self.fmu.setString(vr, [str(value)])

    def free(self) -> None:
        if not self.instantiated:
            return
        try:
            if self.initialized and not self.fatal:
                self.fmu.terminate()
        except Exception:
            pass
        finally:
            try:
                self.fmu.freeInstance()
            except Exception:
                pass
            self.instantiated = False


def _column_groups(inst: _Instance) -> Dict[str, Tuple[List[str], List[int]]]:
    """Names and value references of the recorded variables, per FMI type (Real, Integer,
    Boolean): every connector of the component and every output of its FMU."""
    names = [n for n, _ in inst.comp.connectors]
    seen = set(names)
    names += [v.name for v in inst.md.modelVariables if v.causality == "output"
              and v.name not in seen]
    groups: Dict[str, Tuple[List[str], List[int]]] = {"Real": ([], []), "Integer": ([], []),
                                                      "Boolean": ([], [])}
    for n in names:
        v = inst.var(n)
        typ = "Integer" if v.type == "Enumeration" else v.type
        if typ in groups:                 # String variables are not recorded
            groups[typ][0].append(n)
            groups[typ][1].append(v.valueReference)
    return groups


# ----------------------------------------------------------------------------------------------
# Results
# ----------------------------------------------------------------------------------------------

@dataclass
class RunResult:
    """Result of :func:`run_ssp`.

    Attributes
    ----------
    time : (N,) ndarray
        Communication points [s].
    data : dict
        Column name (``time``, ``<component>.<variable>``) -> (N,) array.
    truth : dict
        Estimate name -> value of the plant parameter of that name as applied (parameter set
        and overrides), read back from the plant FMU after initialisation.
    final : dict
        Estimate name -> estimator output at the last communication point.
    parameter_set : str or None
        The parameter set applied instead of the SSD binding (None: as bound in the SSD).
    start_time, stop_time, step_size : float
    csv_path : Path or None
    log : list
        ``(instance, status, category, message)`` of every FMU message of status Warning or
        worse.
    """

    time: np.ndarray
    data: Dict[str, np.ndarray]
    truth: Dict[str, float]
    final: Dict[str, float]
    parameter_set: Optional[str] = None
    start_time: float = 0.0
    stop_time: float = 0.0
    step_size: float = 0.0
    csv_path: Optional[Path] = None
    log: List[Tuple[str, str, str, str]] = field(default_factory=list)

    def relative_errors(self) -> Dict[str, float]:
        """Estimate name -> |final - truth| / |truth| (NaN where the truth is zero)."""
        return {n: (abs(self.final[n] - t) / abs(t) if t != 0.0 else math.nan)
                for n, t in self.truth.items() if n in self.final}

    def to_csv(self, path: str | Path) -> Path:
        """Write ``data`` as CSV (header: column names; quoted where they contain commas)."""
        return write_csv(path, self.data)


def write_csv(path: str | Path, data: Mapping[str, np.ndarray]) -> Path:
    """Write columns ``data`` (name -> 1-D array) to ``path``; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    names = list(data)
    cols = [np.asarray(data[n]) for n in names]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names)
        for i in range(len(cols[0]) if cols else 0):
            w.writerow([repr(float(c[i])) if c.dtype.kind == "f" else str(c[i]) for c in cols])
    return path


def read_csv(path: str | Path) -> Dict[str, np.ndarray]:
    """Read a CSV written by :func:`write_csv` (or any numeric CSV with a header row);
    non-numeric columns are returned as string arrays."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise ValueError(f"{path}: empty CSV file")
    header, body = rows[0], rows[1:]
    out = {}
    for j, n in enumerate(header):
        col = [r[j] for r in body]
        try:
            out[n] = np.array([float(x) for x in col])
        except ValueError:
            out[n] = np.array(col)
    return out


# ----------------------------------------------------------------------------------------------
# The master
# ----------------------------------------------------------------------------------------------

def _apply(inst: _Instance, name: str, typ: str, value, unit: Optional[str], where: str) -> bool:
    """Set one parameter value from a binding; returns False if the FMU has no such variable
    (SSP 1.0: such parameters are ignored)."""
    v = inst.vars.get(name)
    if v is None:
        return False
    if unit and v.type == "Real":
        fmu_unit = getattr(v, "unit", None) or (v.declaredType.unit if getattr(
            v, "declaredType", None) is not None else None)
        if fmu_unit and fmu_unit != unit:
            raise SimulationError(f"{where}: parameter {inst.name}.{name} has unit {unit!r} but "
                                  f"the FMU variable has unit {fmu_unit!r} (no unit conversion)")
    inst.set(name, value)
    return True


def _resolve_set(info: SystemInfo, root_dir: Path, parameter_set: str) -> Tuple[str, Path]:
    p = Path(parameter_set)
    if p.suffix == ".ssv" and p.exists():
        return p.stem, p
    path = root_dir / "resources" / f"{parameter_set}.ssv"
    if not path.exists():
        raise ValueError(f"unknown parameter set {parameter_set!r}; this system has "
                         f"{info.parameter_sets or 'none'} (or give the path of an .ssv file)")
    return parameter_set, path


def _use_progress(progress: Optional[bool]) -> bool:
    if progress is not None:
        return bool(progress)
    try:
        return sys.stderr.isatty()
    except Exception:
        return False


def run_ssp(ssp_path: str | Path, parameter_set: Optional[str] = None,
            stop_time: Optional[float] = None, overrides: Optional[Mapping[str, object]] = None,
            csv_path: Optional[str | Path] = None, progress: Optional[bool] = None) -> RunResult:
    """Run an SSP system with the SSD's parameter bindings, default experiment and step size.

    Parameters
    ----------
    ssp_path : path
        ``.ssp`` archive or a folder with ``SystemStructure.ssd`` and ``resources/``.
    parameter_set : str, optional
        Name of a parameter set in ``resources/<name>.ssv`` (e.g. ``'small'``) or the path of an
        ``.ssv`` file; it replaces the ``.ssv`` bound to the component(s) in the SSD. Default:
        the binding in the SSD.
    stop_time : float, optional
        Stop time [s]; default: DefaultExperiment ``stopTime``.
    overrides : mapping, optional
        ``{'<component>.<variable>': value}`` applied after the parameter sets, e.g.
        ``{'plant.base.v0[1]': 5.0, 'estimator.method': 2}``.
    csv_path : path, optional
        Write the recorded columns to this CSV file.
    progress : bool, optional
        Show a tqdm progress bar (default: only on a terminal, and only once the run has
        lasted 2 s).

    Returns
    -------
    RunResult

    Raises
    ------
    SimulationError
        An FMU call returned Discard/Error/Fatal (message names the component, the function,
        the time and the FMU's last log messages) or the system cannot be run.
    KeyError, ValueError
        Unknown override name, component or parameter set; invalid stop time.
    """
    from fmpy.fmi1 import FMICallException

    ssp_path = Path(ssp_path)
    if not ssp_path.exists():
        raise FileNotFoundError(f"{ssp_path} does not exist")
    tmp = Path(tempfile.mkdtemp(prefix="spacerobot_run_"))
    insts: Dict[str, _Instance] = {}
    log = _Log()
    t = math.nan
    phase = "instantiation"
    current = ("", "")       # (component, FMI function) of the call in progress
    try:
        if ssp_path.is_dir():
            root_dir = ssp_path
        else:
            if not zipfile.is_zipfile(ssp_path):
                raise SimulationError(f"{ssp_path} is neither a folder nor a .ssp (zip) archive")
            root_dir = tmp / "ssp"
            with zipfile.ZipFile(ssp_path) as zf:
                zf.extractall(root_dir)
        info = read_system(root_dir)
        if info.step_size is None:
            raise SimulationError(f"{ssp_path}: no step size in the SSD (oms:FixedStepMaster "
                                  f"or osp:FixedStepAlgorithm annotation)")
        h = info.step_size
        t0 = info.start_time
        t_end = info.stop_time if stop_time is None else float(stop_time)
        if t_end is None:
            raise ValueError(f"{ssp_path}: the SSD has no DefaultExperiment stopTime; give "
                             f"stop_time")
        if not (math.isfinite(t_end) and t_end > t0):
            raise ValueError(f"stop_time must be finite and > start time {t0}, got {t_end}")
        # communication points t0 + k h; a stop time that is not on that grid gets a shorter
        # last step, so that the run ends exactly at the stop time
        n_steps = max(1, int(math.ceil((t_end - t0) / h - 1e-9)))
        points = [min(t0 + k * h, t_end) for k in range(n_steps)] + [t_end]

        chosen: Dict[str, List] = {}
        set_name = None
        if parameter_set is not None:
            set_name, set_path = _resolve_set(info, root_dir, parameter_set)
            values = _read_ssv(set_path)
            targets = [c for c in info.components.values()
                       if any(b.source and b.source.endswith(".ssv") for b in c.bindings)]
            if not targets:
                raise SimulationError("the SSD binds no .ssv file to a component, so a named "
                                      "parameter set has nothing to replace")
            for c in targets:
                chosen[c.name] = values

        ov = dict(overrides or {})
        by_comp: Dict[str, List[Tuple[str, object]]] = collections.defaultdict(list)
        for key, value in ov.items():
            comp, _, var = key.partition(".")
            if comp not in info.components or not var:
                raise KeyError(f"override {key!r}: expected '<component>.<variable>' with "
                               f"component one of {sorted(info.components)}")
            by_comp[comp].append((var, value))

        # instantiate, parameterise (before initialisation, as SSP 1.0 prescribes), initialise
        for name, comp in info.components.items():
            inst = _Instance(comp, root_dir, tmp)
            insts[name] = inst
            current = (name, "fmi2Instantiate")
            inst.fmu.instantiate(callbacks=log.callbacks, loggingOn=True)
            inst.instantiated = True
            current = (name, "setting parameters")
            for b in comp.bindings:
                vals = chosen[name] if (name in chosen and b.source and
                                        b.source.endswith(".ssv")) else b.values
                for pname, typ, val, unit in vals:
                    _apply(inst, b.prefix + pname, typ, val, unit, f"binding {b.source or 'inline'}")
        for b in info.system_bindings:   # system level takes precedence over component level
            for pname, typ, val, unit in b.values:
                comp, _, var = (b.prefix + pname).partition(".")
                if comp in insts:
                    _apply(insts[comp], var, typ, val, unit, f"system binding {b.source or 'inline'}")
        for comp, items in by_comp.items():
            for var, value in items:
                insts[comp].var(var)          # KeyError with suggestions if unknown
                current = (comp, f"setting override {var}")
                insts[comp].set(var, value)
        t = t0
        phase = "initialisation"
        for name, inst in insts.items():
            current = (name, "fmi2SetupExperiment")
            inst.fmu.setupExperiment(startTime=t0, stopTime=t_end)
            current = (name, "fmi2EnterInitializationMode")
            inst.fmu.enterInitializationMode()
            current = (name, "fmi2ExitInitializationMode")
            inst.fmu.exitInitializationMode()
            inst.initialized = True

        # wiring: batched getReal/setReal per (source, destination) pair
        wires = collections.defaultdict(lambda: ([], [], []))   # (src, dst) -> (src vr, dst vr, type)
        for a, ac, b, bc in info.connections:
            va, vb = insts[a].var(ac), insts[b].var(bc)
            if va.type != vb.type:
                raise SimulationError(f"connection {a}.{ac} ({va.type}) -> {b}.{bc} ({vb.type}): "
                                      f"types differ")
            kind = {"Real": "Real", "Boolean": "Boolean"}.get(va.type, "Integer")
            key = (a, b, kind)
            wires[key][0].append(va.valueReference)
            wires[key][1].append(vb.valueReference)

        def exchange():
            nonlocal current
            for (a, b, typ), (svr, dvr, _) in wires.items():
                current = (a, f"fmi2Get{typ}")
                vals = getattr(insts[a].fmu, f"get{typ}")(svr)
                current = (b, f"fmi2Set{typ}")
                getattr(insts[b].fmu, f"set{typ}")(dvr, list(vals))

        groups = {n: _column_groups(i) for n, i in insts.items()}
        columns = ["time"]
        for n, g in groups.items():
            for typ in ("Real", "Integer", "Boolean"):
                columns += [f"{n}.{v}" for v in g[typ][0]]
        buf = np.empty((n_steps + 1, len(columns)))

        def record(k: int, tk: float):
            nonlocal current
            row = [tk]
            for n, g in groups.items():
                for typ in ("Real", "Integer", "Boolean"):
                    vrs = g[typ][1]
                    if vrs:
                        current = (n, f"fmi2Get{typ}")
                        row += [float(x) for x in getattr(insts[n].fmu, f"get{typ}")(vrs)]
            buf[k] = row

        from tqdm import tqdm

        phase = "stepping"
        bar = tqdm(total=n_steps, disable=not _use_progress(progress), unit="step",
                   desc=f"{info.name} {t0:g}-{t_end:g} s", delay=0.0 if progress else 2.0,
                   leave=False)
        try:
            for k, t in enumerate(points):
                exchange()
                record(k, t)
                if k == n_steps:
                    break
                dt = points[k + 1] - t
                for name, inst in insts.items():
                    current = (name, "fmi2DoStep")
                    inst.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=dt)
                bar.update(1)
        finally:
            bar.close()

        # truth: the plant parameters as applied; final: the estimator outputs
        truth, final = {}, {}
        for n in estimate_names():
            for name, inst in insts.items():
                v = inst.vars.get(n)
                if v is None or v.type != "Real":
                    continue
                if v.causality == "parameter" and n not in truth:
                    current = (name, "fmi2GetReal")
                    truth[n] = float(inst.fmu.getReal([v.valueReference])[0])
                elif v.causality == "output" and n not in final:
                    final[n] = float(buf[-1, columns.index(f"{name}.{n}")])
        data = {c: buf[:, j].copy() for j, c in enumerate(columns)}
        for n, g in groups.items():   # integer and boolean columns back to their type
            for v in g["Integer"][0]:
                data[f"{n}.{v}"] = data[f"{n}.{v}"].astype(np.int64)
            for v in g["Boolean"][0]:
                data[f"{n}.{v}"] = data[f"{n}.{v}"].astype(bool)
        result = RunResult(time=data["time"], data=data, truth=truth, final=final,
                           parameter_set=set_name, start_time=t0, stop_time=t_end,
                           step_size=h, log=list(log.all))
        if csv_path is not None:
            result.csv_path = result.to_csv(csv_path)
        return result
    except FMICallException as e:
        comp, func = current
        if comp in insts and e.status >= 4:
            insts[comp].fatal = True
        label = {2: "Discard", 3: "Error", 4: "Fatal"}.get(e.status, f"status {e.status}")
        raise SimulationError(
            f"component {comp!r} returned {label} from {func} "
            + (f"at t = {t:.6g} s" if phase == "stepping" else f"during {phase}")
            + ".\n"
            f"Last messages of {comp!r}:\n{log.recent(comp)}") from e
    finally:
        for inst in insts.values():
            inst.free()
        shutil.rmtree(tmp, ignore_errors=True)


def format_results(result: RunResult, paper: Optional[Mapping[str, float]] = None,
                   identified_only: Optional[Sequence[str]] = None) -> str:
    """Text table of every estimate: final value, truth, relative error, and the paper's value.

    Parameters
    ----------
    result : RunResult
    paper : mapping, optional
        Estimate name -> the value the paper reports (e.g.
        ``spacerobot.robots.PAPER_PLANAR_MEDIUM['momentum']``).
    identified_only : sequence of str, optional
        The parameters the model identifies; the others are marked ``not identified``
        (e.g. the planar model identifies only m, b[1], b[2], Izz of each body).

    For a zero truth the absolute error is shown instead of the relative one.
    """
    paper = paper or {}
    head = f"{'parameter':<12} {'estimate':>14} {'truth':>12} {'error':>16} {'paper':>9}  note"
    lines = [head, "-" * len(head)]
    for n in estimate_names():
        if n not in result.final:
            continue
        est = result.final[n]
        tru = result.truth.get(n, math.nan)
        if math.isnan(tru):
            err = "n/a"
        elif tru == 0.0:
            err = f"abs {abs(est - tru):.2e}"
        else:
            err = f"{100.0 * abs(est - tru) / abs(tru):.5f} %"
        pv = f"{paper[n]:.2f}" if n in paper else ""
        note = ""
        if identified_only is not None and n not in identified_only:
            note = "not identified (initial guess)"
        lines.append(f"{n:<12} {est:>14.6f} {tru:>12.6g} {err:>16} {pv:>9}  {note}".rstrip())
    return "\n".join(lines)
