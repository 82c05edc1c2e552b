"""Identification from recorded telemetry: the estimator core run on the samples of a CSV file
(``spacerobot identify TELEMETRY.csv --robot ...``; docs/telemetry.md).

Telemetry format: a header row, then one row per sample, comma separated, SI units:

* a time column ``time`` [s] (strictly increasing);
* one column per interface signal, named as the estimator's input (``base.r[1]``,
  ``base.A[2,3]``, ``arm.q[4]``, ``thrust.H[3]`` ...; :func:`spacerobot.interface.
  measurement_vars`). ``base.a``, ``base.alpha`` and ``arm.qdd`` may be left out (then 0:
  enough for the momentum method and for differenced accelerations).

What ``spacerobot run --out`` writes is accepted as it is: a signal is looked up as
``<name>``, then ``estimator.<name>`` (what the estimator read: the measurements when the
sensors FMU was in the loop), ``sensors.<name>``, ``plant.<name>``. Truth columns
``plant.<estimate>`` (the plant's parameters, recorded by ``run``) or ``truth.<estimate>``,
if present, give the table's truth.

The result has one row per sample: ``time``, the 20 estimates, their standard deviations
``sd.<estimate>`` and the estimator's diagnostics, with the names of the estimator FMU's
outputs, and, where the telemetry has a truth, ``truth.<estimate>`` (the truth at that
sample, so that ``spacerobot plot`` compares with it); the row of time ``t`` holds the
estimates after the sample of ``t``. (The FMU
consumes the sample of ``t`` in its step from ``t``: its outputs at ``t + dt`` equal this
row.)
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import Dict, List, Mapping, Optional, Tuple

import numpy as np

from ..core.estimator import output_names
from ..estimator import Identifier
from ..estimator.identifier import identifier_from_values
from ..interface import (ESTIMATE_NAMES, Var, estimator_parameter_values, estimator_vars,
                         identified_estimates, measurement_vars)
from ..robots import check_robot, get_robot, robot_label, scenario
from .recorder import read_csv, write_csv
from .runner import RunResult, format_results

#: where a signal ``<name>`` is looked up in a telemetry file, in this order
PREFIXES = ("", "estimator.", "sensors.", "plant.")
#: signals that may be missing from a telemetry file (then 0)
OPTIONAL_GROUPS = ("a_S", "alpha_B", "qdd")
#: where the truth of an estimate is looked up (optional)
TRUTH_PREFIXES = ("truth.", "plant.truth.", "plant.")


def _column(data: Mapping[str, np.ndarray], name: str, prefixes) -> Optional[np.ndarray]:
    for p in prefixes:
        col = data.get(p + name)
        if col is not None:
            return col
    return None


def read_telemetry(path: str | Path, n_joints: int) -> Tuple[np.ndarray, Dict[str, np.ndarray]]:
    """``(time (N,), {group: (N, ...) array})`` of a telemetry CSV (module docstring), the
    groups of :func:`spacerobot.interface.measurement_vars` (``A`` as (N, 3, 3)).

    Raises
    ------
    ValueError
        No time column, a time that is not strictly increasing, a missing signal column, a
        non-numeric value.
    """
    data = read_csv(path)
    time = data.get("time")
    if time is None:
        raise ValueError(f"{path}: no 'time' column (header: {', '.join(list(data)[:8])} ...)")
    if time.dtype.kind != "f" or len(time) == 0:
        raise ValueError(f"{path}: the 'time' column is empty or not numeric")
    if not np.all(np.diff(time) > 0.0):
        k = int(np.argmin(np.diff(time) > 0.0)) + 1
        raise ValueError(f"{path}: time must be strictly increasing (row {k + 1}: "
                         f"{time[k - 1]!r} -> {time[k]!r})")
    n = len(time)
    shapes = {"A": (3, 3), "q": (n_joints,), "qd": (n_joints,), "qdd": (n_joints,)}
    groups: Dict[str, np.ndarray] = {}
    missing: List[str] = []
    for v in measurement_vars(n_joints, "input"):
        group, idx = v.key
        arr = groups.setdefault(group, np.zeros((n,) + shapes.get(group, (3,))))
        col = _column(data, v.name, PREFIXES)
        if col is None:
            if group not in OPTIONAL_GROUPS:
                missing.append(v.name)
            continue
        if col.dtype.kind != "f":
            raise ValueError(f"{path}: column {v.name} is not numeric")
        arr[(slice(None),) + (idx if isinstance(idx, tuple) else (idx,))] = col
    if missing:
        raise ValueError(f"{path}: no column for {', '.join(missing[:6])}"
                         + (f" and {len(missing) - 6} more" if len(missing) > 6 else "")
                         + f" (looked up as <name>, {', '.join(p + '<name>' for p in PREFIXES[1:])})")
    return time, groups


def truth_columns(data: Mapping[str, np.ndarray], names=ESTIMATE_NAMES
                  ) -> Dict[str, np.ndarray]:
    """``{'truth.<name>': (N,) array}``: the truth of each estimate at every sample, looked up
    as :func:`read_truth` does (``truth.``, ``plant.truth.``, ``plant.``); empty if none."""
    out = {}
    for n in names:
        col = _column(data, n, TRUTH_PREFIXES)
        if col is not None and col.dtype.kind == "f" and len(col):
            out["truth." + n] = np.asarray(col, float)
    return out


def read_truth(path_or_data, names=ESTIMATE_NAMES) -> Dict[str, float]:
    """The truth of each estimate that a telemetry file carries (``truth.<name>``, the plant's
    current truth ``plant.truth.<name>`` or its parameter ``plant.<name>``, at the last row, as
    the runner compares); empty if none."""
    data = read_csv(path_or_data) if isinstance(path_or_data, (str, Path)) else path_or_data
    out = {}
    for n in names:
        col = _column(data, n, TRUTH_PREFIXES)
        if col is not None and col.dtype.kind == "f" and len(col):
            out[n] = float(col[-1])
    return out


def estimator_parameters(robot: str, overrides: Optional[Mapping[str, float]] = None
                         ) -> Dict[str, float]:
    """The estimator FMU's parameters (its defaults for ``robot``) with ``overrides``
    (``name`` or ``estimator.name``); KeyError for a name the estimator does not have. The
    choice of the excitation's rate is off (``ident.excite_adapt`` = 2): recorded telemetry
    cannot follow it (an override turns it on, e.g. to see what it would have asked for)."""
    sc = scenario(robot)
    values = estimator_parameter_values(sc.robot, sc)
    values["ident.excite_adapt"] = 2
    for key, val in (overrides or {}).items():
        name = key.removeprefix("estimator.")
        if name not in values:
            raise KeyError(f"{key!r} is not an estimator parameter (e.g. method, solver, "
                           f"accel_source, lambda, P0_mu, guess.target.m)")
        values[name] = val
    return values


def identifier_of(robot: str, values: Mapping[str, float], sample_time: float = 0.1
                  ) -> Identifier:
    """The estimator core as the FMU builds it from its parameters
    (:func:`estimator_parameters`; :func:`.estimator.identifier.identifier_from_values`;
    ``sample_time`` [s]: the telemetry's, for the noise profile's per-sample densities)."""
    return identifier_from_values(get_robot(robot), values, sample_time)[0]


def _output_vars(robot: str) -> List[Var]:
    sc = scenario(robot)
    return [v for v in estimator_vars(sc.robot, sc) if v.causality == "output"]


def identify(time: np.ndarray, groups: Mapping[str, np.ndarray], robot: str,
             parameters: Optional[Mapping[str, float]] = None) -> Dict[str, np.ndarray]:
    """Run the estimator core over recorded samples.

    Parameters
    ----------
    time : (N,) sample times [s]
    groups : {group: (N, ...)} the samples (:func:`read_telemetry`)
    robot : str
        A built-in name or a URDF robot key (:func:`spacerobot.robots.robot_spec`).
    parameters : the estimator's parameters (:func:`estimator_parameters`; default: its
        defaults)

    Returns
    -------
    dict
        ``time`` and every estimator output name -> (N,) array; row k after sample k.
    """
    values = dict(parameters) if parameters is not None else estimator_parameters(robot)
    steps = np.diff(np.asarray(time, float))
    steps = steps[np.isfinite(steps) & (steps > 0)]
    # the nominal sample time: the median step to 12 digits (recorded times k h carry the
    # round-off of their sums; the FMU takes its scenario's h exactly)
    ident = identifier_of(robot, values, float(f"{np.median(steps):.12g}") if len(steps) else 0.1)
    outs = _output_vars(robot)
    # the FMU's outputs in the core's order (its table), taken in the variables' order
    where = {name: i for i, name in enumerate(output_names())}
    columns = np.array([where[v.name] for v in outs])
    rows = np.empty((len(time), len(outs)))
    for k, t in enumerate(np.asarray(time, float).tolist()):
        ident.update(t, {g: a[k] for g, a in groups.items()})     # never raises on bad data
        rows[k] = ident.core.outputs()[columns]
    data = {"time": np.asarray(time, float)}
    for j, v in enumerate(outs):
        data[v.name] = rows[:, j]
    return data


def identify_csv(telemetry: str | Path, robot: str, out: Optional[str | Path] = None,
                 overrides: Optional[Mapping[str, float]] = None) -> RunResult:
    """Read a telemetry CSV, identify, write the result CSV (default
    ``<telemetry stem>-identified.csv`` beside it; the command line names it by its settings,
    :func:`default_output`); a :class:`RunResult` whose ``final`` are the last estimates and
    ``truth`` the telemetry's truth columns, if any (also written, as ``truth.<name>``, beside
    the estimates)."""
    check_robot(robot)
    telemetry = Path(telemetry)
    parameters = estimator_parameters(robot, overrides)
    raw = read_csv(telemetry)
    time, groups = read_telemetry(telemetry, get_robot(robot).n_joints)
    data = identify(time, groups, robot, parameters)
    out = Path(out) if out else telemetry.with_name(telemetry.stem + "-identified.csv")
    truth = read_truth(raw)
    data.update(truth_columns(raw))
    final = {n: float(data[n][-1]) for n in ESTIMATE_NAMES}
    res = RunResult(time=data["time"], data=data, truth=truth, final=final,
                    start_time=float(time[0]), stop_time=float(time[-1]),
                    step_size=float(np.median(np.diff(time))) if len(time) > 1 else math.nan)
    res.csv_path = write_csv(out, data)
    return res


def default_output(telemetry: str | Path, args) -> Path:
    """The command line's default result file: ``<telemetry stem>-identified-<method>-<accel>-
    <solver>[-<settings>].csv`` beside the telemetry, ``<settings>`` the ``--set`` overrides
    (:func:`spacerobot.system.cli.settings_tag`, names without the ``estimator.`` prefix), so
    that identifications with other settings do not overwrite each other."""
    from .cli import settings_tag
    telemetry = Path(telemetry)
    tag = settings_tag(args.set, strip="estimator.")
    return telemetry.with_name(f"{telemetry.stem}-identified-{args.method}-{args.accel}-"
                               f"{args.solver}" + (f"-{tag}" if tag else "") + ".csv")


def register(subparsers):
    """Add the ``identify`` subcommand to an argparse ``subparsers`` object."""
    from .bindings import parse_assignments
    from .cli import add_robot_arguments, fail_on_errors, robot_key
    from .codes import ACCEL_CODES, METHOD_CODES, SOLVER_CODES

    p = subparsers.add_parser(
        "identify", help="identify from recorded telemetry (a CSV file)",
        description="Run the estimator on recorded samples: a CSV with a 'time' column and "
                    "one column per interface signal in SI units (or what 'spacerobot run "
                    "--out' writes); writes the estimates, standard deviations and "
                    "diagnostics at every sample as CSV and prints the final estimates.")
    p.add_argument("telemetry", metavar="TELEMETRY.csv")
    add_robot_arguments(p, required=True)
    p.add_argument("--method", choices=list(METHOD_CODES), default="momentum")
    p.add_argument("--accel", choices=list(ACCEL_CODES), default="measured")
    p.add_argument("--solver", choices=list(SOLVER_CODES), default="paper")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="estimator parameter, e.g. guess.target.m=300 or lambda=0.999 "
                        "(repeatable)")
    p.add_argument("--out", metavar="CSV", help="result CSV (default "
                   "<TELEMETRY>-identified-<method>-<accel>-<solver>[-<settings>].csv beside "
                   "it, <settings> the --set overrides; an existing file is replaced, with a "
                   "note on stderr)")

    @fail_on_errors("identify")
    def cmd_identify(args) -> int:
        from .cli import announce_replace
        overrides = {"method": METHOD_CODES[args.method], "accel_source": ACCEL_CODES[args.accel],
                     "solver": SOLVER_CODES[args.solver]}
        overrides.update(parse_assignments(args.set))
        robot = robot_key(args)
        out = Path(args.out) if args.out else default_output(args.telemetry, args)
        announce_replace("identify", out)
        res = identify_csv(args.telemetry, robot, out, overrides)
        print(f"{args.telemetry}: robot {robot_label(robot)}, method {args.method}, solver "
              f"{args.solver}, accelerations {args.accel}; {len(res.time)} samples, "
              f"t = {res.start_time:g} .. {res.stop_time:g} s")
        print(format_results(res, None, identified_estimates(get_robot(robot))))
        print(f"CSV: {res.csv_path}")
        return 0

    p.set_defaults(func=cmd_identify)
