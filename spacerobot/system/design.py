"""Excitation chosen from the information (``spacerobot design-excitation``; issue #29, point 3).

The plant's excitation (:class:`spacerobot.robots.Excitation`) is a multi-sine on the base
attitude and on the arm's posture, each bounded by the plant's own limits. Which one buys the
most information is measured here, with the estimator's own bound: each candidate excitation
(the period of the slowest component, and the arm's share: its posture amplitude as a fraction
of what the joint bounds allow) runs plant -> sensors -> estimator in the closed excitation loop
(the estimator's noise profile and information filter, the ``realistic`` set's equations) on
random targets, and the Cramér-Rao bound (``crb.<body>.<param>``) at the horizon, divided by
each estimate's error scale (:func:`spacerobot.interface.error_scale`), is the candidate's
score. Two criteria on that scaled bound:

* ``largest`` (the default): the largest scaled bound over the identified estimates, the
  bound where it is largest; the candidate with the smallest mean over the cases wins (a
  minimax design: the flags and the 1 % target are set by the worst estimate);
* ``A``: the root mean square of the scaled bounds (A-optimal: the trace of the scaled
  covariance).

Every candidate keeps the plant's bounds on its references: the attitude amplitude stays
``excite.att_max``, the joints' posture references stay within ``excite.q_max``, ``qd_max``
and ``qdd_max`` (a faster excitation gets smaller joint amplitudes,
:meth:`Excitation.channels`), and the controller's bounds (``F_max``, ``M_max``, ``qdd_max``)
hold whatever the excitation asks. The joints also move to turn the base, beyond the posture
references' bounds, and nothing bounds the base's rate: the table prints the largest base rate
and joint rate each candidate produced (a spacecraft's slew-rate limit: ``omega_limit``).

The cases are random targets (the draws of ``spacerobot montecarlo``) or, with ``target``, one
named target of the robot's scenario under a different sensor seed each. The best excitation
depends on the target: docs/identification.md, "Excitation that buys information", has the
measured tables (on random spatial targets a 7.5 s period leaves a bound four times smaller
than the plant's default 30 s; on the paper's spatial target the default period is best), which is
why the parameter sets keep the plant's default and this tool is how to choose for a mission.
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, replace
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..interface import (ESTIMATE_NAMES, error_scale, estimator_parameter_values,
                         identified_estimates, plant_vars)
from ..robots import (REALISTIC_ESTIMATOR, Excitation, Scenario, check_robot, robot_label,
                      robot_spec, scenario)
from .montecarlo import SensorsCase

#: the criteria on the scaled bound b (identified estimates): name -> (description, function)
CRITERIA = {
    "largest": ("largest scaled bound", lambda b: float(np.max(b))),
    "A": ("RMS of the scaled bounds (A-optimal)", lambda b: float(np.sqrt(np.mean(b ** 2)))),
}


@dataclass(frozen=True)
class Candidate:
    """One excitation to try: ``period`` [s] of the slowest component, ``arm`` the share of the
    arm's posture excitation in [0, 1] (the joint bounds q_max, qd_max, qdd_max scaled by it,
    so its amplitudes scale by it); the attitude amplitude stays at ``att_max``."""

    period: float
    arm: float = 1.0

    def __post_init__(self):
        if not (math.isfinite(self.period) and self.period > 0.0):
            raise ValueError(f"excitation period must be a finite number > 0 s, got "
                             f"{self.period}")
        if not (0.0 <= self.arm <= 1.0):
            raise ValueError(f"arm share must be in [0, 1], got {self.arm}")

    def excitation(self, base: Excitation) -> Excitation:
        """``base`` with this period and the joint bounds scaled by the arm share."""
        return replace(base, period=float(self.period), q_max=base.q_max * self.arm,
                       qd_max=base.qd_max * self.arm, qdd_max=base.qdd_max * self.arm)


#: the motion is measured after this time [s] (or half the horizon if that is shorter): before,
#: the random initial tumbling (up to RANDOM_RANGES["omega0"]) dominates the rates
SETTLE = 60.0


@dataclass
class Outcome:
    """One candidate on one case: the scaled bound of every estimate (20; 0 where not
    identified), the largest base rate ``|omega_B|`` (the vector's norm) [rad/s] and joint rate
    ``|qd_i|`` [rad/s] the run produced after its settling time (:data:`SETTLE`: the initial
    tumbling damped)."""

    scaled_bound: np.ndarray
    omega_max: float
    qd_max: float


def sensor_magnitudes(noise: Optional[Mapping[str, float]] = None) -> Dict[str, float]:
    """The sensors' realistic magnitudes (docs/sensors.md; names without ``noise.``, e.g.
    ``nav.r``) with ``noise``'s values instead; ``ValueError`` naming an unknown one."""
    from ..sensors import default_parameters
    out = default_parameters()
    for name, value in (noise or {}).items():
        key = name.removeprefix("noise.")
        if key not in out:
            raise ValueError(f"unknown sensor magnitude {name!r}; choose from {sorted(out)}")
        if not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"sensor magnitude {name} must be a finite number >= 0, got "
                             f"{value}")
        out[key] = float(value)
    return out


def closed_loop_bound(sc: Scenario, sensors_seed: int, stop_time: float,
                      noise_scale: float = 1.0,
                      noise: Optional[Mapping[str, float]] = None) -> Outcome:
    """Run ``sc`` (its excitation as given) through the sensors (their magnitudes,
    :func:`sensor_magnitudes` of ``noise``, times ``noise_scale``; seeded) into the estimator
    with the ``realistic`` set's settings and its noise profile told the same magnitudes, the
    estimator's request driving the plant's excitation level every sample; the bound at
    ``stop_time``."""
    from ..estimator.identifier import KEYS, identifier_from_values
    from ..plant import Plant
    from ..sensors import SensorSuite

    dt = sc.sample_time
    magnitudes = sensor_magnitudes(noise)
    values = estimator_parameter_values(sc.robot, sc)
    values.update(dict(REALISTIC_ESTIMATOR))
    values["noise.scale"] = float(noise_scale)
    values["ident.excite_adapt"] = 2         # the candidate as given: no rate of its own
    values.update({f"noise.{k}": v for k, v in magnitudes.items() if f"noise.{k}" in values})
    ident, request = identifier_from_values(sc.robot, values, dt)
    plant = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
                  excitation=sc.excitation)
    sensors = SensorSuite(sc.robot.n_joints, params=magnitudes, scale=noise_scale,
                          seed=sensors_seed, dt=dt)
    w_max = qd_max = 0.0
    level = request({"base": False, "target": False})
    settle = min(SETTLE, 0.5 * stop_time)
    for k in range(int(round(stop_time / dt))):     # the samples the SSP's estimator takes
        plant.set_excitation(level)
        y = plant.outputs()
        if k * dt >= settle:
            w_max = max(w_max, float(np.linalg.norm(y["omega_B"])))    # the slew rate
            qd_max = max(qd_max, float(np.max(np.abs(y["qd"]))))
        meas = sensors.update(y, dt)
        ident.update(k * dt, {key: meas[key] for key in KEYS})
        rep = ident.report()
        level = request(rep.identified)
        plant.advance(dt)
    start = {v.name: v.start for v in plant_vars(sc.robot, sc)}   # the truth, by name
    truth = np.array([start[n] for n in ESTIMATE_NAMES], float)
    mask = np.isin(ESTIMATE_NAMES, identified_estimates(sc.robot))
    if rep.crb is None or not np.all(np.isfinite(rep.crb[mask]) & (rep.crb[mask] > 0.0)):
        raise ValueError(f"{sc.name}: the estimator reported no Cramér-Rao bound (its "
                         f"information filter needs the sensors' white noise)")
    return Outcome(np.where(mask, rep.crb / error_scale(truth), 0.0), w_max, qd_max)


def case_scenario(robot: str, index: int, seed: int, target: Optional[str] = None) -> Scenario:
    """Case ``index``: the random draw ``(seed, index)`` of ``spacerobot montecarlo``, or the
    robot's scenario with the named ``target``."""
    if target is not None:
        return scenario(robot, target)
    return SensorsCase(robot, index, seed).scenario()


def _job(args) -> Tuple[int, int, Outcome]:
    robot, index, seed, ci, cand, stop_time, noise_scale, noise, base, target = args
    sc = case_scenario(robot, index, seed, target)
    sc = replace(sc, excitation=cand.excitation(base or sc.excitation))
    sensors_seed = SensorsCase(robot, index, seed).sensors_seed   # montecarlo's, per case
    return ci, index, closed_loop_bound(sc, sensors_seed, stop_time, noise_scale, noise)


@dataclass
class Design:
    """The outcomes of every candidate on every case, and the choice."""

    candidates: List[Candidate]
    outcomes: Dict[Tuple[int, int], Outcome]     # (candidate, case) -> outcome
    criterion: str
    omega_limit: float = math.inf                # base rate limit [rad/s]: faster ones lose

    def feasible(self, ci: int) -> bool:
        """Candidate ``ci`` kept the base rate within ``omega_limit`` in every case."""
        return all(o.omega_max <= self.omega_limit
                   for (i, _), o in self.outcomes.items() if i == ci)

    def of(self, ci: int) -> List[Outcome]:
        """The outcomes of candidate ``ci``, in the order of the cases (not of completion)."""
        return [self.outcomes[k] for k in sorted(k for k in self.outcomes if k[0] == ci)]

    def scores(self, ci: int) -> np.ndarray:
        """The criterion of candidate ``ci`` on each case."""
        f = CRITERIA[self.criterion][1]
        return np.array([f(o.scaled_bound[o.scaled_bound > 0]) for o in self.of(ci)])

    @property
    def best(self) -> Optional[int]:
        """The feasible candidate with the smallest mean criterion over the cases (None if
        none is feasible)."""
        ok = [i for i in range(len(self.candidates)) if self.feasible(i)]
        return min(ok, key=lambda i: self.scores(i).mean()) if ok else None

    def table(self) -> str:
        """The candidates, their criterion (mean and largest over the cases, in % of the
        error scale), the estimate the bound is largest on most often, and the motion."""
        head = (f"{'period [s]':>10} {'arm':>5} {'mean [%]':>9} {'largest [%]':>11} "
                f"{'worst estimate':>15} {'max |omega_B|':>14} {'max |qd|':>9}")
        lines = [f"criterion: {CRITERIA[self.criterion][0]} at the horizon, % of the "
                 f"error scale, over {len(self.scores(0))} case(s)", head]
        best = self.best
        for i, c in enumerate(self.candidates):
            s = 100.0 * self.scores(i)
            outs = self.of(i)
            worst = [int(np.argmax(o.scaled_bound)) for o in outs]
            common = ESTIMATE_NAMES[max(sorted(set(worst)), key=worst.count)]  # ties: first
            lines.append(f"{c.period:10.4g} {c.arm:5.2f} {s.mean():9.3f} {s.max():11.3f} "
                         f"{common:>15} {max(o.omega_max for o in outs):14.3f} "
                         f"{max(o.qd_max for o in outs):9.3f}"
                         + ("  <- best" if i == best else "" if self.feasible(i)
                            else "  (base rate above the limit)"))
        return "\n".join(lines)


def design(robot: str, candidates: Sequence[Candidate], cases: int = 4, seed: int = 0,
           stop_time: float = 300.0, criterion: str = "largest", noise_scale: float = 1.0,
           base: Optional[Excitation] = None, omega_limit: float = math.inf, workers: int = 2,
           progress=None, target: Optional[str] = None,
           noise: Optional[Mapping[str, float]] = None, scheduler: Optional[str] = None,
           client=None) -> Design:
    """Run every candidate on ``cases`` cases of ``robot`` (:func:`case_scenario`: random
    targets, or the named ``target``; each case its own sensor seed) and score them;
    ``noise``: sensor magnitudes other than the realistic defaults (:func:`sensor_magnitudes`),
    given to the sensors and to the estimator's noise profile alike.
    ``base``: the excitation whose bounds and ramp the candidates keep (default: each case's,
    the robot's scenario excitation). ``omega_limit`` [rad/s]: a candidate whose base rate
    exceeds it in any case is not chosen. ``progress(done, total)`` is called after each run.

    The runs go to ``workers`` local processes (1: this process), or to a Dask cluster: a
    ``client`` or the ``scheduler`` at that address. A run needs the installed package only
    (it builds its own plant, sensors and estimator from the core)."""
    robot = check_arguments(robot, candidates, cases, stop_time, criterion, noise_scale,
                            omega_limit, target, noise, workers)
    jobs = [(robot, i, seed, ci, c, float(stop_time), float(noise_scale), noise, base, target)
            for ci, c in enumerate(candidates) for i in range(cases)]
    out: Dict[Tuple[int, int], Outcome] = {}

    def collect(ci, index, o):
        out[(ci, index)] = o
        if progress is not None:
            progress(len(out), len(jobs))

    if scheduler is None and client is None:
        if workers == 1:
            results = map(_job, jobs)
        else:   # a process pool: a local cluster's start-up costs 2 s more (measured)
            from multiprocessing import get_context
            pool = get_context("spawn").Pool(min(workers, len(jobs)))
            results = pool.imap_unordered(_job, jobs)
        try:
            for r in results:
                collect(*r)
        finally:
            if workers != 1:
                pool.terminate()
        return Design(list(candidates), out, criterion, omega_limit)
    from distributed import as_completed

    from .sweep.execute import dask_client
    with dask_client(workers, scheduler, client) as c:
        futures = [c.submit(_job, job, pure=False) for job in jobs]
        try:
            for fut in as_completed(futures):
                collect(*fut.result())
        finally:
            c.cancel([f for f in futures if not f.done()])
    return Design(list(candidates), out, criterion, omega_limit)


def check_arguments(robot: str, candidates: Sequence[Candidate], cases: int, stop_time: float,
                    criterion: str = "largest", noise_scale: float = 1.0,
                    omega_limit: float = math.inf, target: Optional[str] = None,
                    noise: Optional[Mapping[str, float]] = None, workers: int = 1) -> str:
    """The robot key of :func:`design`'s arguments, or ``ValueError`` naming the first bad one,
    before any run; among them a candidate period the sample time cannot resolve (its fastest
    component, 3 x 2 pi / period, must stay below the sampling's pi / dt)."""
    check_robot(robot)
    robot = robot_spec(robot)
    if criterion not in CRITERIA:
        raise ValueError(f"criterion must be one of {sorted(CRITERIA)}, got {criterion!r}")
    if not candidates:
        raise ValueError("no candidate excitation to try")
    if cases < 1:
        raise ValueError(f"the number of cases must be >= 1, got {cases}")
    if workers < 1:
        raise ValueError(f"the number of workers must be >= 1, got {workers}")
    if not (math.isfinite(noise_scale) and noise_scale > 0.0):
        raise ValueError(f"noise scale must be a finite number > 0 (the bound comes from the "
                         f"sensors' noise), got {noise_scale}")
    if not omega_limit > 0.0:
        raise ValueError(f"base rate limit must be > 0 rad/s, got {omega_limit}")
    if not (math.isfinite(stop_time) and stop_time > 0.0):
        raise ValueError(f"stop time must be a finite number > 0 s, got {stop_time}")
    dt = case_scenario(robot, 0, 0, target).sample_time    # an unknown target named here
    sensor_magnitudes(noise)                               # an unknown magnitude named here
    for c in candidates:
        if not c.period > 6.0 * dt:
            raise ValueError(f"excitation period {c.period:g} s is too short for the sample "
                             f"time {dt:g} s: its fastest component (3 x 2 pi / period) must "
                             f"stay below pi / dt, so the period above {6.0 * dt:g} s")
    return robot


# ----------------------------------------------------------------------------------------------
# command line
# ----------------------------------------------------------------------------------------------

def _print_progress(done: int, total: int) -> None:
    print(f"\r  {done}/{total} runs", end="\n" if done == total else "", file=sys.stderr,
          flush=True)


def cmd_design(args) -> int:
    from .bindings import parse_assignments
    from .cli import robot_key
    args.robot = robot_key(args)
    try:
        noise = parse_assignments(args.noise)
    except ValueError as e:
        raise ValueError(str(e).replace("--set", "--noise")) from None
    if args.cases is None:
        args.cases = 4 if args.target is None else 1
    cands = [Candidate(p, a) for p in args.periods for a in args.arm]
    check_arguments(args.robot, cands, args.cases, args.stop_time, args.criterion,
                    args.noise_scale, args.omega_limit, args.target, noise, args.workers)
    t0 = time.time()
    what = ("random targets" if args.target is None
            else f"runs of the target {args.target!r}")
    print(f"{robot_label(args.robot)}: {len(cands)} candidate(s) x {args.cases} {what}, "
          f"{args.stop_time:g} s each, plant -> sensors (noise.scale "
          f"{args.noise_scale:g}) -> estimator (realistic set)", file=sys.stderr)
    d = design(args.robot, cands, args.cases, args.seed, args.stop_time, args.criterion,
               args.noise_scale, omega_limit=args.omega_limit, workers=args.workers,
               progress=None if args.no_progress else _print_progress, target=args.target,
               noise=noise, scheduler=args.scheduler)
    print(d.table())
    if d.best is None:
        print(f"no candidate kept the base rate within {args.omega_limit:g} rad/s")
        return 1
    b = cands[d.best]
    ex = b.excitation(case_scenario(args.robot, 0, args.seed, args.target).excitation)
    sets = [("period", ex.period)] + ([] if b.arm == 1.0 else
                                      [(k, getattr(ex, k)) for k in ("q_max", "qd_max",
                                                                     "qdd_max")])
    print(f"best: period {b.period:g} s, arm share {b.arm:g}: "
          + " ".join(f"--set plant.excite.{k}={v:g}" for k, v in sets)
          + f" ({time.time() - t0:.0f} s)")
    return 0


def register(subparsers):
    """Add the ``design-excitation`` subcommand to an argparse ``subparsers`` object."""
    from .cli import add_robot_arguments, fail_on_errors

    p = subparsers.add_parser(
        "design-excitation", help="choose the plant's excitation from the estimator's bound",
        description="Run plant -> sensors -> estimator (the realistic set) for each candidate "
                    "excitation (period x arm share) on random targets (or the scenario's "
                    "target with --target) and print the "
                    "Cramer-Rao bound each leaves at the horizon, scaled by the error scale; "
                    "the candidate with the smallest mean criterion is marked best.")
    add_robot_arguments(p, default="spatial")
    p.add_argument("--periods", type=float, nargs="+", default=[30.0, 15.0, 7.5, 3.75],
                   metavar="S", help="candidate periods of the slowest excitation component "
                                     "[s] (default 30 15 7.5 3.75)")
    p.add_argument("--arm", type=float, nargs="+", default=[1.0], metavar="F",
                   help="candidate arm shares in [0, 1] (the joints' posture amplitude as a "
                        "fraction of what their bounds allow; default 1 only: at share 0 the "
                        "bound looked as good, the errors were not, docs/identification.md)")
    p.add_argument("--criterion", choices=list(CRITERIA), default="largest",
                   help="largest (default): the largest scaled bound; A: their RMS")
    p.add_argument("--cases", type=int, help="random targets (default 4); with --target, "
                                              "sensor seeds (default 1: the bound hardly "
                                              "depends on the noise drawn)")
    p.add_argument("--target", help="the robot's scenario with this target (e.g. default, "
                                    "medium) instead of random targets")
    p.add_argument("--seed", type=int, default=0, help="seed of the draws (as montecarlo)")
    p.add_argument("--stop-time", type=float, default=300.0, metavar="T",
                   help="horizon at which the bound is read [s] (default 300; at least 60 s: "
                        "before, the information filter's first linearisation still stands)")
    p.add_argument("--noise-scale", type=float, default=1.0, metavar="S",
                   help="noise.scale of the sensors and of the estimator's profile")
    p.add_argument("--noise", action="append", metavar="NAME=VALUE",
                   help="a sensor magnitude of your devices (docs/sensors.md names, e.g. "
                        "nav.r=0.002), for the sensors and the estimator's profile alike "
                        "(repeatable; default: the realistic defaults)")
    p.add_argument("--omega-limit", type=float, default=math.inf, metavar="RAD/S",
                   help="the spacecraft's base rate limit: candidates exceeding it are not "
                        "chosen (default: none)")
    p.add_argument("--workers", type=int, default=2,
                   help="local worker processes (1: in this process)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="an existing Dask scheduler (e.g. tcp://host:8786) instead of local "
                        "workers; the workers need only this package installed")
    p.add_argument("--no-progress", action="store_true", help="no progress line")
    p.set_defaults(func=fail_on_errors("design-excitation")(cmd_design))
