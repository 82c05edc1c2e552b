"""Monte Carlo study: identification on random real bases, targets and initial states.

Each *case* draws a base, a target and an initial tumbling with
:func:`spacerobot.robots.random_scenario` from the generator ``default_rng([seed, index])``
(the same bodies for every method and excitation mode of that index, so they compare on equal
terms), and runs the robot's SSP system for ``stop_time`` seconds with those plant parameters,
the estimator's defaults and the chosen method, the excitation loop closed (estimator
``ident.excite_mode`` = until identified) or off. The cases run on Dask through the sweep's
executor (:func:`spacerobot.system.sweep.execute.run_sweep` with :data:`STUDY`), one tidy row
per case (:data:`COLUMNS`), resumable.

Per case, from the recorded series (:func:`.mc_metrics.run_metrics`): the worst relative error
of the identified estimates at the end (``interface.relative_errors``), the times after which
it stays below 1 % and 0.1 %, the identified flags and when they rose, whether a flag was ever
1 while an estimate of its body was more than 1 % off, whether every reported estimate was a
real body (checked here with :func:`spacerobot.estimator.physical.is_physical`, independently of
the estimator's own flags), the excitation used, and the largest excitation references against
their bounds.
"""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .. import interface
from ..interface import ESTIMATE_NAMES, ExciteMode, ParameterLayout
from ..robots import (Scenario, check_robot, get_robot, random_scenario, robot_label,
                      robot_spec)
from .codes import estimator_overrides
from .mc_metrics import run_metrics
from .sweep.execute import Study, run_sweep
from .sweep.run import DEFAULT_RUNNER, run_guarded

__all__ = ["Case", "SensorsCase", "make_cases", "run_case", "run_montecarlo", "plot_montecarlo",
           "COLUMNS", "STUDY", "SENSORS_STUDY", "EXCITE"]

#: excitation modes of a case -> the estimator's ``ident.excite_mode``
EXCITE = {"closed": ExciteMode.UNTIL_IDENTIFIED, "off": ExciteMode.OFF}

#: plant parameters a case sets: the drawn bodies and initial state, and the excitation bounds
#: (set explicitly, so that the row can check the references against what was applied)
_CASE_PARAMS = ("base.", "target.", "excite.")

CASE_COLUMNS = ("case_id", "robot", "case", "seed", "method", "accel_source", "solver", "excite",
                "stop_time", "base_mass", "target_mass", "omega0_norm", "v0_norm")
METRIC_COLUMNS = ("worst_error", "worst_param", "within2sd", "t_1pct", "t_01pct",
                  "identified.base", "identified.target", "t_identified.base",
                  "t_identified.target", "false_identified.base", "false_identified.target",
                  "physical", "excite_mean", "t_excite_off", "max_att_ref", "att_max",
                  "max_qd_ref", "qd_max", "max_qd")
COLUMNS = (CASE_COLUMNS + ("status", "error", "wall_time", "worker") + METRIC_COLUMNS
           + tuple(f"relerr.{p}" for p in ESTIMATE_NAMES))


@dataclass(frozen=True)
class Case:
    """One random case: robot, index and seed of the draw, identification set-up, excitation."""

    robot: str = "spatial"
    index: int = 0
    seed: int = 0
    method: str = "momentum"
    excite: str = "closed"
    stop_time: float = 60.0
    accel_source: str = "measured"
    solver: str = "paper"
    #: FMU parameter overrides over the drawn case's (``("plant.excite.period", 7.5)``, ...;
    #: the ``--set NAME=VALUE`` of the command; names a case sets itself: CASE_OWNED, refused)
    overrides: Tuple[Tuple[str, float], ...] = ()

    def __post_init__(self):
        check_robot(self.robot)          # a built-in name or a URDF robot key (made absolute)
        object.__setattr__(self, "robot", robot_spec(self.robot))
        if self.excite not in EXCITE:
            raise ValueError(f"excite must be one of {sorted(EXCITE)}, got {self.excite!r}")
        if not (self.stop_time > 0.0 and math.isfinite(self.stop_time)):
            raise ValueError(f"stop time must be a finite number > 0, got {self.stop_time}")
        estimator_overrides(self.method, self.accel_source, self.solver)   # checks the labels

    @property
    def id(self) -> str:
        """Stable 16-hex-digit hash of the case's parameters."""
        key = [self.robot, self.index, self.seed, self.method, self.excite,
               repr(float(self.stop_time)), self.accel_source, self.solver]
        if self.overrides:            # without: the ids (and resumable tables) of before
            key.append(sorted([k, repr(float(v))] for k, v in self.overrides))
        text = json.dumps(key)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def scenario(self) -> Scenario:
        """The drawn bodies and initial state (the same for every method and excitation)."""
        return random_scenario(self.robot, np.random.default_rng([self.seed, self.index]),
                               name=f"{robot_label(self.robot)}-random-{self.seed}-{self.index}")

    def fmi_overrides(self) -> Dict[str, float]:
        """SSP runner overrides: the drawn plant parameters and the estimator set-up."""
        sc = self.scenario()
        ov: Dict[str, float] = {f"plant.{v.name}": float(v.start)
                                for v in interface.plant_vars(sc.robot, sc)
                                if v.causality == "parameter" and v.name.startswith(_CASE_PARAMS)}
        ov.update(estimator_overrides(self.method, self.accel_source, self.solver))
        ov["estimator.ident.excite_mode"] = int(EXCITE[self.excite])
        ov.update(self.overrides)
        return ov

    def columns(self) -> Dict[str, object]:
        sc = self.scenario()
        return {"case_id": self.id, "robot": self.robot, "case": self.index, "seed": self.seed,
                "method": self.method, "accel_source": self.accel_source, "solver": self.solver,
                "excite": self.excite, "stop_time": self.stop_time,
                "base_mass": sc.robot.base.mass, "target_mass": sc.target.mass,
                "omega0_norm": float(np.linalg.norm(sc.omega0)),
                "v0_norm": float(np.linalg.norm(sc.v0))}


@dataclass(frozen=True)
class SensorsCase(Case):
    """A case through plant -> sensors -> estimator (the robot's ``<robot>_sensors.ssp`` with
    its default parameter set ``realistic``: the sensors' realistic defaults times
    ``noise_scale``, the estimator's noise profile, ``ident.noise_profile`` = 1, with the same
    ``noise.scale``), the sensors seeded per case from ``(seed, index)``."""

    noise_scale: float = 1.0

    def __post_init__(self):
        super().__post_init__()
        if not (math.isfinite(self.noise_scale) and self.noise_scale >= 0.0):
            raise ValueError(f"noise scale must be a finite number >= 0, got {self.noise_scale}")

    @property
    def id(self) -> str:
        return hashlib.sha256(json.dumps(["sensors", super().id, repr(float(self.noise_scale))]
                                         ).encode()).hexdigest()[:16]

    @property
    def sensors_seed(self) -> int:
        """The sensors FMU's ``seed`` of this case (drawn from ``(seed, index)``)."""
        return int(np.random.default_rng([self.seed, self.index, 1]).integers(0, 2 ** 31 - 1))

    def fmi_overrides(self) -> Dict[str, float]:
        ov = super().fmi_overrides()
        ov["sensors.seed"] = self.sensors_seed
        ov["sensors.noise.scale"] = float(self.noise_scale)
        ov["estimator.noise.scale"] = float(self.noise_scale)
        return ov

    def columns(self) -> Dict[str, object]:
        return {**super().columns(), "noise_scale": float(self.noise_scale),
                "sensors_seed": self.sensors_seed}


#: what a case sets from its own fields (its draw, method, excitation mode, sensors' seed and
#: scale): a ``--set`` of these would contradict the table's columns, so it is refused
CASE_OWNED = ("plant.base.", "plant.target.", "estimator.method", "estimator.accel_source",
              "estimator.solver", "estimator.ident.excite_mode", "sensors.seed",
              "sensors.noise.scale", "estimator.noise.scale")


def check_overrides(robot: str, overrides: Dict[str, float], sensors: bool = False) -> None:
    """``ValueError`` naming the first override that is not ``<component>.<parameter>`` of the
    system's FMUs (plant, estimator; sensors with ``sensors``) or that a case sets itself
    (:data:`CASE_OWNED`), before any case runs."""
    sc = random_scenario(robot, np.random.default_rng(0))
    params = {"plant": interface.plant_vars(sc.robot, sc),
              "estimator": interface.estimator_vars(sc.robot, sc)}
    if sensors:
        params["sensors"] = interface.sensors_vars(sc.robot, sc)
    names = {f"{c}.{v.name}" for c, vs in params.items() for v in vs
             if v.causality == "parameter"}
    for name, value in overrides.items():
        if name not in names:
            raise ValueError(f"--set {name}: not a parameter of the system's FMUs (names are "
                             f"<component>.<parameter>, components {', '.join(params)})")
        if name.startswith(CASE_OWNED):
            raise ValueError(f"--set {name}: each case sets it itself (its draw, --method, "
                             f"--excite, --noise-scale, its sensors' seed)")
        if not math.isfinite(value):
            raise ValueError(f"--set {name}: the value must be a finite number, got {value}")


def make_cases(robot: str = "spatial", cases: int = 20, seed: int = 0,
               methods: Sequence[str] = ("momentum", "force"),
               excite: Sequence[str] = ("closed",), stop_time: float = 60.0,
               noise_scale: Optional[float] = None,
               accel_source: str = "measured",
               overrides: Optional[Dict[str, float]] = None) -> List[Case]:
    """Every index ``0 .. cases-1`` with every method and excitation mode; with a
    ``noise_scale``, :class:`SensorsCase` s (through the sensors) instead; ``overrides``: FMU
    parameter values every case sets last (``{"plant.excite.period": 7.5}``)."""
    if cases < 1:
        raise ValueError(f"the number of cases must be >= 1, got {cases}")
    ov = tuple(sorted((str(k), float(v)) for k, v in (overrides or {}).items()))
    check_overrides(robot, dict(ov), sensors=noise_scale is not None)
    if noise_scale is None:
        return [Case(robot, i, seed, m, e, stop_time, accel_source, overrides=ov)
                for i in range(cases) for m in methods for e in excite]
    return [SensorsCase(robot, i, seed, m, e, stop_time, accel_source, overrides=ov,
                        noise_scale=noise_scale)
            for i in range(cases) for m in methods for e in excite]


def _series(res, names: Sequence[str], component: str) -> np.ndarray:
    try:
        return np.column_stack([res.data[f"{component}.{n}"] for n in names])
    except KeyError as e:
        raise RuntimeError(f"the run recorded no column {e.args[0]}: is {component!r} the "
                           f"project's FMU with the closed excitation loop?") from None


def case_row(case: Case, res) -> Dict[str, object]:
    """The metric columns of one finished run (:class:`~spacerobot.system.runner.RunResult`)."""
    from ..estimator.physical import is_physical

    robot = get_robot(case.robot)
    layout = ParameterLayout.for_robot(robot)
    est = _series(res, ESTIMATE_NAMES, "estimator")
    truth = np.array([res.truth[n] for n in ESTIMATE_NAMES])
    flags = _series(res, ("diag.identified.base", "diag.identified.target"), "estimator")
    physical = np.array([all(is_physical(e[b.m], e[b.first], e[b.inertia])
                             for b in layout.bodies) for e in est])
    excite = res.data["plant.ident.excite"]
    bodies = {b.name: np.flatnonzero(layout.identified & (np.arange(20) >= b.vec.start)
                                     & (np.arange(20) < b.vec.stop)) for b in layout.bodies}
    row: Dict[str, object] = run_metrics(res.time, est, truth, interface.error_scale(truth),
                                         flags, physical, excite, bodies)
    row["worst_param"] = ESTIMATE_NAMES[row["worst_param"]]
    n = robot.n_joints
    qd = _series(res, [f"arm.qd[{k + 1}]" for k in range(n)], "plant")
    row["max_qd"] = float(np.abs(qd).max())
    row["max_qd_ref"] = float(np.abs(_series(res, [f"excite.qd_ref[{k + 1}]" for k in range(n)],
                                              "plant")).max())
    row["max_att_ref"] = float(np.abs(_series(res, [f"excite.att_ref[{k + 1}]" for k in range(3)],
                                               "plant")).max())
    ex, ov = case.scenario().excitation, case.fmi_overrides()     # bounds as run (--set too)
    row["qd_max"] = ov.get("plant.excite.qd_max", ex.qd_max)
    row["att_max"] = ov.get("plant.excite.att_max", ex.att_max)
    rel = interface.relative_errors(est[-1], truth)
    row.update({f"relerr.{p}": float(r) for p, r in zip(ESTIMATE_NAMES, rel)})
    sd = _series(res, [f"sd.{p}" for p in ESTIMATE_NAMES], "estimator")[-1]
    ident = layout.identified
    row["within2sd"] = float(np.mean(np.abs(est[-1] - truth)[ident] <= 2.0 * sd[ident]))
    row.update({f"sd.{p}": float(s) for p, s in
                zip(ESTIMATE_NAMES, sd / interface.error_scale(truth))})
    if f"estimator.crb.{ESTIMATE_NAMES[0]}" in res.data:      # the information filter's bound
        crb = _series(res, [f"crb.{p}" for p in ESTIMATE_NAMES], "estimator")[-1]
        row.update({f"crb.{p}": float(c) for p, c in
                    zip(ESTIMATE_NAMES, crb / interface.error_scale(truth))})
    score = res.data.get("estimator.diag.excite_score.rate_1")
    if score is not None and len(score) and score[-1] > 0:   # the estimator chose the rate
        row["excite_rate"] = float(res.data["estimator.ident.excite_rate"][-1])
    return row


def _fill_case(row: Dict[str, object], case: Case, res) -> None:
    row.update(case_row(case, res))


def run_case(case: Case, ssp_path: str, runner: str = DEFAULT_RUNNER) -> Dict[str, object]:
    """Run one case; never raises: a failure becomes a row with ``status = failed``."""
    return run_guarded(case, ssp_path, runner, _fill_case)


#: the Monte Carlo study for the sweep's executor
STUDY = Study(name="montecarlo", columns=COLUMNS, key="case_id", task=run_case)
#: the study through the sensors (:class:`SensorsCase`): the sensors' scale and seed too
#: (and the information filter's Cramér-Rao bound per estimate, relative to its error scale as
#: the ``relerr`` columns: the efficiency's denominator; the excitation rate the estimator
#: chose, ``ident.excite_rate``, empty where it made no choice; the reported standard
#: deviation per estimate at the end, relative to the error scale: ``relerr / sd`` is the
#: error in standard deviations, what calibration and the flags are checked on)
SENSORS_STUDY = Study(name="montecarlo-sensors",
                      columns=COLUMNS[:len(CASE_COLUMNS)] + ("noise_scale", "sensors_seed")
                      + COLUMNS[len(CASE_COLUMNS):] + tuple(f"crb.{p}" for p in ESTIMATE_NAMES)
                      + ("excite_rate",) + tuple(f"sd.{p}" for p in ESTIMATE_NAMES),
                      key="case_id", task=run_case)


def build_sensors_system(robot: str, out_dir):
    """The sweep's builder of the system with the sensors FMU (``<robot>_sensors.ssp``)."""
    from .ssd import build_system
    return build_system(robot, out_dir, sensors=True)


def run_montecarlo(cases: Sequence[Case], out_csv, **kwargs):
    """Run every case not yet in ``out_csv`` on Dask (keywords of
    :func:`spacerobot.system.sweep.execute.run_sweep`: ``workers``, ``scheduler``, ``client``,
    ``build_dir``, ``ssp``, ``progress``). Returns the :class:`SweepSummary`. Cases of one
    kind: :class:`SensorsCase` s run the system with the sensors FMU."""
    kinds = {isinstance(c, SensorsCase) for c in cases}
    if len(kinds) > 1:
        raise ValueError("cases with and without sensors cannot share one table")
    if kinds == {True}:
        kwargs.setdefault("builder", "spacerobot.system.montecarlo:build_sensors_system")
        return run_sweep(cases, out_csv, study=SENSORS_STUDY, **kwargs)
    return run_sweep(cases, out_csv, study=STUDY, **kwargs)


def _canonical(rows: Sequence[Dict[str, str]]) -> List[Dict[str, str]]:
    from .sweep.table import canonical
    return canonical(rows, STUDY.key)


def read_results(csv_path) -> List[Dict[str, str]]:
    """The rows of a Monte Carlo table (complete lines), with or without sensors."""
    from .sweep.table import read_table
    return read_table(csv_path, STUDY.key)


def summary_table(rows: Sequence[Dict[str, str]]) -> str:
    """A Markdown table per (method, excitation): cases, within 1 % / 0.1 % at the end, median
    and largest worst error (``error/scale``: :func:`spacerobot.interface.relative_errors`, the
    metric of every table), median time to 1 % and 0.1 %, identified, false flags, impossible
    estimates; from the rows in the order of their ids (the same digits whatever order the
    cases finished in)."""
    groups: Dict[tuple, List[Dict[str, str]]] = {}
    for r in _canonical(rows):
        if r["status"] == "ok":
            groups.setdefault((r["robot"], r["method"], r["excite"]), []).append(r)
    lines = ["| robot | method | excitation | cases | within 1 % | within 0.1 % | median worst "
             "error/scale | largest worst error/scale | median time to 1 % [s] | median time "
             "to 0.1 % [s] "
             "| both identified | false flags | impossible estimates | within 2 sd "
             "| efficiency (median, lowest) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for (robot, method, excite), rs in sorted(groups.items()):
        w = np.array([float(r["worst_error"]) for r in rs])
        t1 = np.array([float(r["t_1pct"]) for r in rs])
        t01 = np.array([float(r["t_01pct"]) for r in rs])
        both = sum(r["identified.base"] == "1" and r["identified.target"] == "1" for r in rs)
        false = sum(r["false_identified.base"] == "1" or r["false_identified.target"] == "1"
                    for r in rs)
        bad = sum(r["physical"] != "1" for r in rs)
        n = len(rs)

        def med(t):   # NaN = never settled, i.e. later than the end
            t = np.where(np.isnan(t), np.inf, t)
            return f"{np.median(t):.1f}" if np.isfinite(t).sum() * 2 > n else "> end"
        lines.append(f"| {robot} | {method} | {excite} | {n} | {(w < 1e-2).sum()}/{n} | "
                     f"{(w < 1e-3).sum()}/{n} | {100 * np.median(w):.3g} % | "
                     f"{100 * w.max():.3g} % | {med(t1)} | {med(t01)} | {both}/{n} | {false} | "
                     f"{bad} | {calibration(rs)} | {efficiency_text(rs)} |")
    return "\n".join(lines)


def efficiency_text(rows: Sequence[Dict[str, str]]) -> str:
    """"median, lowest" of :func:`efficiencies` over the estimates, or "-" without the bound."""
    e = list(efficiencies(rows).values())
    return f"{np.median(e):.2f}, {min(e):.2f}" if e else "-"


def bound_stats(rows: Sequence[Dict[str, str]]) -> Dict[str, tuple]:
    """Per estimate, over the rows that carry the information filter's bound: (the bound's RMS
    ``sqrt(mean crb^2)``, the RMS error ``sqrt(mean error^2)``, the efficiency, their ratio), all
    relative to the error scale (efficiency 1: as good as any unbiased estimator can be);
    empty for rows without the bound, and no entry where an estimate is not identified
    (:func:`spacerobot.interface.identified_estimates` of the row's robot)."""
    out: Dict[str, tuple] = {}
    rows = _canonical(rows)
    identified = {name: set(interface.identified_estimates(get_robot(name)))
                  for name in {r["robot"] for r in rows}}
    for p in ESTIMATE_NAMES:
        # a planar robot's out-of-plane entries keep their guesses: bound > 0 through the
        # parallel axes, but no estimate of theirs to be efficient
        have = [r for r in rows if r.get(f"crb.{p}") not in (None, "")
                and p in identified[r["robot"]]]
        c = np.array([float(r[f"crb.{p}"]) for r in have])
        e = np.array([float(r[f"relerr.{p}"]) for r in have])
        if len(c) and c.max() > 0 and e.max() > 0:
            bound, rms = float(np.sqrt(np.mean(c ** 2))), float(np.sqrt(np.mean(e ** 2)))
            out[p] = (bound, rms, bound / rms)
    return out


def efficiencies(rows: Sequence[Dict[str, str]]) -> Dict[str, float]:
    """Per estimate, the efficiency of :func:`bound_stats`."""
    return {p: v[2] for p, v in bound_stats(rows).items()}


def efficiency_table(rows: Sequence[Dict[str, str]]) -> str:
    """A Markdown table of :func:`bound_stats` over the finished rows, or "" without the
    bound."""
    stats = bound_stats([r for r in rows if r["status"] == "ok"])
    if not stats:
        return ""
    lines = ["| estimate | bound, RMS over cases (of its scale) | RMS error (of its scale) | "
             "efficiency (bound / RMS error) |", "|---|---|---|---|"]
    for p, (c, rms, e) in stats.items():
        lines.append(f"| {p} | {100 * c:.2g} % | {100 * rms:.2g} % | {e:.2f} |")
    return "\n".join(lines)


def rate_text(rows: Sequence[Dict[str, str]]) -> str:
    """How often the estimator chose each excitation rate (``ident.excite_rate`` where it made
    the choice: docs/identification.md, 'Excitation that buys information'), or "" where it
    chose in no case (the choice off, or a table without the column)."""
    ok = [x for x in rows if x["status"] == "ok"]
    r = [float(x["excite_rate"]) for x in ok if x.get("excite_rate") not in (None, "")]
    if not r:
        return ""
    counts = ", ".join(f"{v:g}: {r.count(v)}" for v in sorted(set(r)))
    none = f" (no choice made in {len(ok) - len(r)})" if len(ok) > len(r) else ""
    return (f"the excitation rate the estimator chose (rate: cases): {counts} of "
            f"{len(ok)}{none}")


def calibration(rows: Sequence[Dict[str, str]]) -> str:
    """The mean fraction of the identified estimates within 2 reported standard deviations of
    the truth at the end (calibrated: 0.90-0.99), or "-" for a table without the column."""
    x = [float(r["within2sd"]) for r in _canonical(rows)
         if r.get("within2sd") not in (None, "")]
    return f"{np.mean(x):.3f}" if x else "-"


def plot_montecarlo(csv_path, out_png: Optional[str] = None,
                    ids: Optional[Sequence[str]] = None) -> Path:
    """Distribution of the worst error per method and excitation: the fraction of cases whose
    worst error at the end is below x, with the 1 % and 0.1 % lines (``ids``: only the rows
    of these case ids)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in _canonical(read_results(csv_path)) if r["status"] == "ok"
            and (ids is None or r["case_id"] in ids)]
    if not rows:
        raise ValueError(f"{csv_path} has no finished case to plot")
    groups: Dict[tuple, List[float]] = {}
    for r in rows:
        groups.setdefault((r["method"], r["excite"]), []).append(float(r["worst_error"]))
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for (method, excite), w in sorted(groups.items()):
        w = np.sort(np.maximum(np.array(w) * 100, 1e-7))
        frac = np.arange(1, len(w) + 1) / len(w)
        ax.step(w, frac, where="post", label=f"{method}, excitation {excite} ({len(w)} cases)",
                ls="-" if excite == "closed" else "--")
    for x, lab in ((1.0, "1 %"), (0.1, "0.1 %")):
        ax.axvline(x, color="grey", lw=0.8, ls=":")
        ax.text(x, 0.02, f" {lab}", color="grey", fontsize=8)
    ax.set_xscale("log")
    ax.set_xlabel("worst error/scale of the identified estimates at the end [%]")
    ax.set_ylabel("fraction of cases")
    ax.set_ylim(0, 1.02)
    ax.set_title(f"Monte Carlo: {rows[0]['robot']} robot, random bases and targets, "
                 f"{float(rows[0]['stop_time']):g} s")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    out = Path(out_png) if out_png else Path(csv_path).with_suffix(".png")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return out


# ----------------------------------------------------------------------------------------------
# command line: spacerobot montecarlo
# ----------------------------------------------------------------------------------------------

def register(subparsers):
    """Add the ``montecarlo`` subcommand to an argparse ``subparsers`` object."""
    import argparse

    from .cli import add_robot_arguments, fail_on_errors

    p = subparsers.add_parser(
        "montecarlo", help="identification on random real bases and targets, on Dask",
        description="Draw random real bases, targets and initial states, run each case through "
                    "the SSP system on a Dask cluster (local by default) and write one row per "
                    "case (worst error, times to 1 % and 0.1 %, identified flags, physical "
                    "flag, excitation used) to a resumable CSV, a summary table and a plot of "
                    "the worst-error distribution.",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    add_robot_arguments(p, default="spatial")
    p.add_argument("--cases", type=int, default=20, help="number of random cases")
    p.add_argument("--seed", type=int, default=0, help="seed of the draws")
    p.add_argument("--method", nargs="+", choices=["momentum", "force"],
                   help="identification equations (default: momentum and force; with "
                        "--sensors: force, the realistic set's)")
    p.add_argument("--sensors", action="store_true",
                   help="through the sensors FMU (its realistic defaults, a random seed per "
                        "case) with the estimator's noise profile: the system's realistic set")
    p.add_argument("--noise-scale", dest="noise_scale", type=float, default=1.0, metavar="S",
                   help="with --sensors: noise.scale of the sensors and of the estimator's "
                        "noise profile (0 = ideal sensors)")
    p.add_argument("--excite", nargs="+", default=["closed"], choices=sorted(EXCITE),
                   help="closed: the estimator requests excitation until both bodies are "
                        "identified; off: no excitation (the paper's behaviour)")
    p.add_argument("--stop-time", dest="stop_time", type=float, metavar="T",
                   help="duration of each run [s] (default 60; an explicit one is in the "
                        "default results name)")
    p.add_argument("--set", action="append", metavar="NAME=VALUE",
                   help="FMU parameter every case sets last, e.g. plant.excite.period=7.5 "
                        "(repeatable; not the case's own draw or options; in the default "
                        "results name, not in the table's rows: one table per setting)")
    p.add_argument("--workers", type=int, default=2, help="local cluster worker processes")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="an existing Dask scheduler (e.g. tcp://host:8786) instead of local "
                        "workers; its workers need only this package installed (the .ssp is "
                        "sent to them, no shared file system)")
    p.add_argument("--build-dir", dest="build_dir", metavar="DIR",
                   help="where the .ssp is built on this machine (default <out>.build/)")
    p.add_argument("--ssp", metavar="SSP_FILE", help="run this .ssp archive of the robot "
                   "instead of building one (read here and sent to the workers)")
    p.add_argument("--out", metavar="CSV", help="results table (default "
                   "results/montecarlo-<robot>[-sensors[<S>]][-<settings>]-seed<S>.csv, "
                   "<settings> the --set overrides and an explicit --stop-time; resumed if it "
                   "exists, the summary over this command's cases only)")
    p.add_argument("--plot", metavar="PNG", help="plot (default: the CSV with .png)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=fail_on_errors("montecarlo")(cli_montecarlo))
    return p


def cli_montecarlo(args) -> int:
    """The ``spacerobot montecarlo`` command; exit status 1 if a case failed."""
    from .bindings import parse_assignments
    from .cli import notice, robot_key, settings_tag
    from .recorder import check_writable
    from .sweep.table import SweepLocked

    robot = robot_key(args)
    overrides = parse_assignments(args.set)
    tag = (f"-sensors{'' if args.noise_scale == 1.0 else f'{args.noise_scale:g}'}"
           if args.sensors else "")
    settings = settings_tag(args.set, args.stop_time)
    tag += f"-{settings}" if settings else ""
    if args.stop_time is None:
        args.stop_time = 60.0
    out = Path(args.out or f"results/montecarlo-{robot_label(robot)}{tag}-seed{args.seed}.csv")
    methods = args.method or (["force"] if args.sensors else ["momentum", "force"])
    check_writable(out)
    ssp = None
    if args.ssp:
        if not Path(args.ssp).exists():
            raise ValueError(f"{args.ssp} does not exist")
        if not Path(args.ssp).is_file():
            raise ValueError(f"{args.ssp} is a folder: give the .ssp archive (it is sent to "
                             f"the workers as one file)")
        ssp = {robot: str(Path(args.ssp).resolve())}
    # through the sensors: the realistic set's accelerations (differenced, the noise profile's
    # 9-sample derivative in the momentum equations)
    cases = make_cases(robot, args.cases, args.seed, methods, args.excite, args.stop_time,
                       noise_scale=args.noise_scale if args.sensors else None,
                       accel_source="differenced" if args.sensors else "measured",
                       overrides=overrides)
    notice("montecarlo", f"{len(cases)} runs of {args.stop_time:g} s ({args.cases} random "
           f"cases x {len(methods)} methods x {len(args.excite)} excitation modes"
           + (f", through the sensors (noise.scale {args.noise_scale:g})" if args.sensors else "")
           + ") on "
           + (f"the Dask scheduler {args.scheduler}" if args.scheduler else
              f"{args.workers} local Dask workers")
           + (", building the SSP first" if not ssp else "") + f"; results -> {out} ...")
    try:
        summary = run_montecarlo(cases, out, workers=args.workers, scheduler=args.scheduler,
                                 build_dir=args.build_dir, ssp=ssp,
                                 progress=not args.no_progress)
    except SweepLocked as e:
        raise ValueError(str(e)) from None
    print(summary)
    ids = {c.id for c in cases}           # this command's cases: not other rows of the file
    rows = [r for r in read_results(out) if r["case_id"] in ids]
    print(summary_table(rows))
    rates = rate_text(rows)
    if rates:
        print(rates)
    eff = efficiency_table(rows)
    if eff:
        print("the information filter's Cramér-Rao bound against the observed scatter:")
        print(eff)
    if not any(r["status"] == "ok" for r in rows):
        raise ValueError(f"no case finished (the first failure: "
                         f"{next((r['error'] for r in rows if r['error']), 'unknown')})")
    print("plot:", plot_montecarlo(out, args.plot, ids))
    return 1 if summary.failed else 0
