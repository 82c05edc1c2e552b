"""The SSP runner: a small co-simulation master that honours the SSD.

fmpy's :func:`fmpy.ssp.simulation.simulate_ssp` ignores ParameterBindings and DefaultExperiment
and starts every connector at 0.0. :func:`run_ssp` composes the named parts of this package:

1. :mod:`.reader` reads ``SystemStructure.ssd`` from a ``.ssp`` archive or an extracted folder
   (start/stop time from ``DefaultExperiment``, the communication step from the root System's
   ``oms:FixedStepMaster`` or DefaultExperiment's ``osp:FixedStepAlgorithm`` annotation);
2. every component becomes an :class:`~.instance.FMUInstance`; :mod:`.bindings` applies, before
   initialisation, the ParameterBindings (component level in element order, then system level,
   which takes precedence, as SSP 1.0 specifies), or a named parameter set instead of the bound
   ``.ssv``, then explicit overrides;
3. :class:`~.master.Master` steps all FMUs with a fixed step (at every communication point the
   connected outputs are read and the inputs set, source by source in the order of the
   connections, the row recorded, then every FMU steps), wiring every connection of the SSD
   whatever its direction;
4. :class:`~.recorder.Recorder` records every connector and every output of every component
   (columns ``time``, ``<component>.<variable>``), optionally written to CSV;
5. :mod:`.errors` turns an FMI call that returns Discard, Error or Fatal into a
   :class:`SimulationError` naming the component, the FMI function and the time, with the FMU's
   recent log messages. Every FMU instance is terminated and freed, and temporary folders
   removed, also on error (and on KeyboardInterrupt).

A row at time ``t`` holds the outputs at ``t`` and the inputs set at ``t``; the estimator
outputs in that row are computed from the samples before ``t`` (it consumes the sample at ``t``
during the step that starts at ``t``).

The runner knows no model: :attr:`RunResult.truth` and :attr:`RunResult.final` pair, by name,
every Real output of one component with the Real parameter of the same name of another (the
estimator's ``target.m`` output estimates the plant's ``target.m`` parameter); when that
component also outputs ``truth.<name>`` (a truth that changes during the run, e.g. the base as
propellant is used), the truth is that output's final value.
"""
from __future__ import annotations

import math
import shutil
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .bindings import (apply_component_bindings, apply_overrides, apply_system_bindings,
                       chosen_values, split_overrides)
from .errors import Calls, SimulationError, fmi_errors
from .instance import FMUInstance, FMULog
from .master import Master, initialize, time_grid
from .reader import ComponentInfo, SystemInfo, open_system
from .recorder import Recorder, check_writable, read_csv, write_csv  # noqa: F401
from .. import interface
from ..core.estimator import MISFIT_CAUSES

__all__ = ["run_ssp", "simulate", "RunResult", "SimulationError", "format_results",
           "read_csv", "write_csv"]


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
        Estimate name -> value of the parameter of that name as applied (parameter set and
        overrides), read back from the FMU that has it as a parameter (the plant).
    final : dict
        Estimate name -> output of that name at the last communication point (the estimator).
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
        """Estimate name -> ``|final - truth| / scale``
        (:func:`spacerobot.interface.relative_errors_by_name`, scales of
        :func:`spacerobot.interface.error_scale`)."""
        return interface.relative_errors_by_name(self.final, self.truth)

    def to_csv(self, path: str | Path) -> Path:
        """Write ``data`` as CSV (header: column names; quoted where they contain commas)."""
        return write_csv(path, self.data)


def _estimates(instances: Mapping[str, FMUInstance],
               data: Mapping[str, np.ndarray]) -> Tuple[Dict[str, float], Dict[str, float]]:
    """``(truth, final)``: every Real output of a component that another component has as a
    Real parameter, in the output's model-description order."""
    params = {}
    for name, inst in instances.items():
        for n, v in inst.vars.items():
            if v.causality == "parameter" and v.type == "Real":
                params.setdefault(n, (name, inst))
    truth, final = {}, {}
    for name, inst in instances.items():
        for n, v in inst.vars.items():
            if (v.causality == "output" and v.type == "Real" and n in params
                    and params[n][0] != name and n not in final
                    and f"{name}.{n}" in data):
                now = f"{params[n][0]}.truth.{n}"
                truth[n] = float(data[now][-1]) if now in data else float(params[n][1].get(n))
                final[n] = float(data[f"{name}.{n}"][-1])
    return truth, final


def _recorded(info: SystemInfo, instances: Mapping[str, FMUInstance]) -> Dict[str, List[str]]:
    """Per component: every connector and every output of its FMU."""
    out = {}
    for name, inst in instances.items():
        names = [n for n, _ in info.components[name].connectors]
        seen = set(names)
        out[name] = names + [n for n in inst.names("output") if n not in seen]
    return out


def _instance(comp: ComponentInfo, root_dir: Path, tmp: Path, log: FMULog) -> FMUInstance:
    """The (not yet instantiated) FMU of ``comp``; SimulationError for a missing or damaged
    FMU."""
    fmu_path = root_dir / comp.source
    if not fmu_path.exists():
        raise SimulationError(f"component {comp.name!r}: FMU {comp.source!r} not found")
    try:
        return FMUInstance(fmu_path, comp.name, callbacks=log.callbacks, logging_on=True,
                           unzipdir=tmp / comp.name, instantiate=False)
    except ValueError:
        raise SimulationError(f"component {comp.name!r}: {comp.source} is not an FMI 2.0 or "
                              f"3.0 co-simulation FMU") from None
    except Exception as e:            # zipfile.BadZipFile, a model description fmpy rejects
        raise SimulationError(f"component {comp.name!r}: {comp.source} is not a valid FMU "
                              f"({type(e).__name__}: {e})") from None


def simulate(info: SystemInfo, root_dir: str | Path, parameter_set: Optional[str] = None,
             stop_time: Optional[float] = None, overrides: Optional[Mapping[str, object]] = None,
             progress: Optional[bool] = None, tmp: Optional[Path] = None) -> RunResult:
    """Run the system ``info`` (read from, or with FMU sources relative to, ``root_dir``).

    See :func:`run_ssp` for the parameters; ``tmp`` is where the FMUs are extracted (default:
    a temporary folder removed at the end).
    """
    root_dir = Path(root_dir)
    if info.step_size is None:
        raise SimulationError("no step size in the SSD (oms:FixedStepMaster or "
                              "osp:FixedStepAlgorithm annotation)")
    t0, h = info.start_time, info.step_size
    t_end = info.stop_time if stop_time is None else float(stop_time)
    if t_end is None:
        raise ValueError("the SSD has no DefaultExperiment stopTime; give stop_time")
    points = time_grid(t0, t_end, h)
    set_name, chosen = chosen_values(info, root_dir, parameter_set)
    by_comp = split_overrides(overrides, list(info.components))

    own_tmp = tmp is None
    tmp = Path(tempfile.mkdtemp(prefix="spacerobot_run_")) if own_tmp else Path(tmp)
    insts: Dict[str, FMUInstance] = {}
    log, calls = FMULog(), Calls()
    try:
        with fmi_errors(calls, log, insts):
            for name, comp in info.components.items():
                insts[name] = _instance(comp, root_dir, tmp, log)
                calls(name, "fmi2Instantiate")
                insts[name].instantiate()
                apply_component_bindings(insts[name], comp, chosen, calls)
            apply_system_bindings(insts, info, calls)
            apply_overrides(insts, by_comp, calls)
            initialize(insts, t0, t_end, calls)
            master = Master(insts, info.connections, calls)
            recorder = Recorder(insts, _recorded(info, insts), len(points), calls)
            master.run(points, recorder, progress, desc=f"{info.name} {t0:g}-{t_end:g} s")
            data = recorder.data()
            truth, final = _estimates(insts, data)
        return RunResult(time=data["time"], data=data, truth=truth, final=final,
                         parameter_set=set_name, start_time=t0, stop_time=t_end, step_size=h,
                         log=list(log.all))
    finally:
        for inst in insts.values():
            inst.free()
        if own_tmp:
            shutil.rmtree(tmp, ignore_errors=True)


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
        Write the recorded columns to this CSV file (checked to be writable before the run).
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
        the time and the FMU's last log messages) or the system cannot be run (a damaged
        archive or FMU, malformed XML, no SSD: the message names ``ssp_path``).
    FileNotFoundError
        ``ssp_path`` does not exist.
    OSError
        ``csv_path`` cannot be written (a folder, no permission), raised before the run.
    KeyError, ValueError
        Unknown override name, component or parameter set; invalid stop time.
    """
    ssp_path = Path(ssp_path)
    if csv_path is not None:
        check_writable(csv_path)
    tmp = Path(tempfile.mkdtemp(prefix="spacerobot_run_"))
    try:
        root_dir, info = open_system(ssp_path, tmp)
        try:
            result = simulate(info, root_dir, parameter_set, stop_time, overrides, progress, tmp)
        except SimulationError as e:
            raise SimulationError(f"{ssp_path}: {e}") from e.__cause__
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if csv_path is not None:
        result.csv_path = result.to_csv(csv_path)
    return result


#: the header of the error column of :func:`format_results`, and the line that defines it
ERROR_HEADER = "error/scale"
ERROR_NOTE = ("error/scale = |estimate - truth| / error_scale(truth), the metric of the identified "
              "flags and the Monte Carlo study;\nscale: mass |m|, centre of mass max(|b_i|, 5 cm), "
              "moments |I_ii|, products of inertia the body's largest moment")


def format_results(result: RunResult, paper: Optional[Mapping[str, float]] = None,
                   identified_only: Optional[Sequence[str]] = None) -> str:
    """Text table of every estimate: final value, truth, error, and the paper's value; then
    the estimator's verdict (identified, physical) at the end, when recorded.

    Parameters
    ----------
    result : RunResult
    paper : mapping, optional
        Estimate name -> the value the paper reports (e.g.
        ``spacerobot.robots.PAPER_PLANAR_MEDIUM['momentum']``).
    identified_only : sequence of str, optional
        The parameters the model identifies; the others are marked ``not identified``
        (e.g. the planar model identifies only m, b[1], b[2], Izz of each body).

    The error of every row is the one metric the estimator's flags and the Monte Carlo study
    use, :func:`spacerobot.interface.relative_errors` (``|est - truth| / error_scale(truth)``,
    in %; also for a zero truth), named in the header and defined in a line below the table.
    """
    paper = paper or {}
    rel = interface.relative_errors_by_name(
        result.final, {n: v for n, v in result.truth.items() if not math.isnan(v)})
    head = (f"{'parameter':<12} {'estimate':>14} {'truth':>12} {ERROR_HEADER:>14} "
            f"{'paper':>9}  note")
    lines = [head, "-" * len(head)]
    for n, est in result.final.items():
        err = f"{100.0 * rel[n]:.5f} %" if n in rel else "n/a"
        tru = result.truth.get(n, math.nan)
        pv = f"{paper[n]:.2f}" if n in paper else ""
        note = ""
        if identified_only is not None and n not in identified_only:
            note = "not identified"
        lines.append(f"{n:<12} {est:>14.6f} {tru:>12.6g} {err:>14} {pv:>9}  {note}".rstrip())
    lines.append(ERROR_NOTE)
    lines += _flag_lines(result.data)
    return "\n".join(lines)


#: diag.misfit_cause's values (spacerobot.core.estimator.MISFIT_CAUSES) as the verdict tells them
_MISFIT_TOLD = {
    "model": "the rigid model does not fit (flexible parts, sloshing propellant: the sds carry "
             "a model-error term; the rigid band's estimates where diag.band > 0, else they "
             "can be far off)",
    "noise": "the noise.* values are too small (the estimates kept, their sds widened)",
    "thrust": "a thrust scale beyond its prior (a miscalibration or slosh: the sds cover the "
              "estimates with the thrust held)",
}


def _flag_lines(data: Mapping[str, np.ndarray]) -> List[str]:
    """The estimator's verdict at the end: ``diag.identified.*`` and ``diag.physical.*``, from
    the columns of a run (``estimator.diag.*``) or of ``spacerobot identify`` (``diag.*``)."""
    out = []
    for flag, text in (("identified", "identified (sd below ident.sd_rel)"),
                       ("physical", "real body as estimated (no projection)")):
        for prefix in ("estimator.", ""):
            cols = [(b, data.get(f"{prefix}diag.{flag}.{b}")) for b in ("base", "target")]
            if all(c is not None and len(c) for _, c in cols):
                out.append(f"{text}: " + ", ".join(f"{b} {'yes' if c[-1] > 0.5 else 'no'}"
                                                   for b, c in cols))
                break
    for prefix in ("estimator.", ""):
        chi2 = data.get(f"{prefix}diag.info_chi2")
        if chi2 is not None and len(chi2) and chi2[-1] > 0:
            out.append(f"the information filter reported (ident.information): diag.info_chi2 "
                       f"{chi2[-1]:.3g} (from its 600th sample on about 1 where the noise.* "
                       f"values fit the sensors); its flags need every sd below ident.sd_rel / z "
                       f"(ident.flag_confidence), the filter replayed and the estimates steady "
                       f"over ident.fit_window (docs/identification.md, 'Flags'); its "
                       f"Cramer-Rao bound: the crb.* columns")
            break
    for prefix in ("estimator.", ""):
        misfit, time = data.get(f"{prefix}diag.misfit"), data.get("time")
        if misfit is not None and len(misfit) and misfit[-1] > 0.5:
            since = ""
            if time is not None and len(time) == len(misfit):
                fits = np.flatnonzero(np.asarray(misfit) < 0.5)
                start = fits[-1] + 1 if len(fits) else 0
                since = f" from t = {time[start]:g} s"
            cause = data.get(f"{prefix}diag.misfit_cause")
            last = cause[-1] if cause is not None and len(cause) else math.nan
            name = MISFIT_CAUSES.get(int(round(last))) if math.isfinite(last) else None
            told = (f"its cause (diag.misfit_cause): {_MISFIT_TOLD[name]}" if name else
                    "its cause: " + "; or ".join(_MISFIT_TOLD.values()))
            out.append(f"the model-fit test failed (diag.misfit 1{since}): no body is "
                       f"flagged; {told}; docs/identification.md, 'When the rigid model does "
                       f"not fit'")
            break
    for prefix in ("estimator.", ""):
        rate = data.get(f"{prefix}ident.excite_rate")
        score = [data.get(f"{prefix}diag.excite_score.{k}") for k in interface.EXCITE_SCORES]
        if rate is not None and len(rate) and all(s is not None and len(s) for s in score):
            if score[0][-1] > 0:
                out.append(f"the excitation rate the estimator chose (ident.excite_adapt): "
                           f"{rate[-1]:g} (predicted largest bound at ident.excite_horizon: "
                           f"rate 1 {100 * score[0][-1]:.3g} %, rate_try "
                           f"{100 * score[1][-1]:.3g} % of the scale)")
            elif rate[-1] != 1.0:
                out.append(f"the excitation rate the estimator asks for (ident.excite_adapt): "
                           f"{rate[-1]:g}, on trial (no choice yet)")
            break
    return out
