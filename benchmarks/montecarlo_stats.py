"""Statistics with confidence intervals of identification through the sensors on random spatial
targets: writes benchmarks/MONTECARLO_STATS.md and its CSV table.

N random spatial cases (the draws of ``spacerobot montecarlo``, seed ``--seed``), each run
through plant -> sensors -> estimator (the system's ``realistic`` set: force method with
differenced accelerations, the estimator's noise profile and information filter, the excitation
loop closed) for ``--stop-time`` seconds on a Dask cluster (local by default, or
``--scheduler``), exactly as ``spacerobot montecarlo --sensors`` runs them. Reported, each with
a 95 % interval:

* the fraction of cases whose every estimate is within 1 % (and 0.1 %) of its error scale at
  the end (Wilson);
* calibration: the fraction of the estimates within 2 reported standard deviations (cases
  resampled whole: the estimates of one case share their errors), and per case;
* the identified flags: of the bodies flagged at the end, the fraction with an estimate off by
  more than the flag's threshold (``ident.sd_rel``), with its exact one-sided upper bound;
  the same for candidate flag rules evaluated on the reported standard deviations
  (:data:`RULES`);
* the efficiency against the information filter's Cramér-Rao bound (1 / RMS over the cases of
  error / that case's bound, per estimate, cases resampled);
* the times to identification and to 1 % (medians, order-statistics intervals; a case that
  never got there counts as later than any);
* the cost: wall time per case in its worker, and cases per minute per worker;

and, on the system's own scenario (the default target) across ``--seeds`` sensor seeds, the
same calibration and flags (the estimates of one seed share its sensors' errors).

Nothing is asserted. Usage: ``python benchmarks/montecarlo_stats.py [--cases 60] [--seed 0] [--seeds 20]
[--stop-time 300] [--workers 2 | --scheduler ADDRESS] [--resume] [--out FILE.md]``
"""
from __future__ import annotations

import argparse
import datetime as _dt
import math
import os
import platform
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Sequence

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from spacerobot import __version__  # noqa: E402
from spacerobot.interface import ESTIMATE_NAMES, identified_estimates  # noqa: E402
from spacerobot.robots import get_robot  # noqa: E402
from spacerobot.system.mc_stats import (bootstrap_ci, clopper_pearson, median_ci,  # noqa: E402
                                        normal_quantile, wilson)
from spacerobot.robots import scenario  # noqa: E402
from spacerobot.system.montecarlo import (CASE_COLUMNS, SENSORS_STUDY, case_row,  # noqa: E402
                                          make_cases, read_results,
                                          run_montecarlo)
from spacerobot.system.sweep.execute import Study, run_sweep  # noqa: E402
from spacerobot.system.sweep.run import DEFAULT_RUNNER, run_guarded  # noqa: E402

#: the estimator's flag threshold ``ident.sd_rel`` (its default: 0.1 % of the error scale)
THRESHOLD = 1e-3
BODIES = ("base", "target")


def _bonferroni(p: int, alpha: float) -> float:
    """The multiple of sd below which every one of p Gaussian errors lies with probability at
    least 1 - alpha whatever their correlation (Bonferroni: the estimator's rule,
    ``ident.flag_confidence`` = 1 - alpha)."""
    return normal_quantile(1.0 - alpha / p / 2.0)


#: flag rules on a body's reported sds (relative to the error scale), name -> the multiple c
#: of sd that must fit within the threshold: max_i c sd_i <= thr. The estimator's (default
#: ident.flag_confidence 0.99) and, for comparison, the per-estimate 2 sd rule and others.
RULES = {
    "2 sd per estimate (95 % each)": 2.0,
    "Bonferroni, 10 estimates, 5 %": _bonferroni(10, 0.05),
    "Bonferroni, 10 estimates, 1 % (the estimator's default)": _bonferroni(10, 0.01),
    "Bonferroni, 10 estimates, 0.1 %": _bonferroni(10, 0.001),
}


@dataclass(frozen=True)
class SeedCase:
    """The robot's own scenario through its sensors system (the ``realistic`` set, the
    default target) with the sensors seeded ``sensors_seed``."""

    sensors_seed: int
    stop_time: float = 300.0
    robot: str = "spatial"

    @property
    def id(self) -> str:
        return f"{self.robot}-default-{self.sensors_seed}-t{self.stop_time:g}"

    def scenario(self):
        return scenario(self.robot)

    def fmi_overrides(self) -> Dict[str, float]:
        return {"sensors.seed": self.sensors_seed}

    def columns(self) -> Dict[str, object]:
        return {"case_id": self.id, "robot": self.robot, "case": self.sensors_seed,
                "seed": "", "method": "force", "accel_source": "differenced", "solver": "paper",
                "excite": "closed", "stop_time": self.stop_time, "sensors_seed": self.sensors_seed,
                "noise_scale": 1.0}


def _fill_seed_case(row, case, res) -> None:
    row.update(case_row(case, res))


def run_seed_case(case: SeedCase, ssp_path: str, runner: str = DEFAULT_RUNNER):
    return run_guarded(case, ssp_path, runner, _fill_seed_case)


#: the default target across sensor seeds: the Monte Carlo table's columns
SEED_STUDY = Study(name="default-target", columns=SENSORS_STUDY.columns, key="case_id",
                   task=run_seed_case)
assert set(SeedCase(0).columns()) <= set(CASE_COLUMNS) | {"noise_scale", "sensors_seed"}


def _f(x) -> float:
    return float(x) if x not in (None, "") else math.nan


def estimate_errors(rows: Sequence[Dict[str, str]]) -> List[Dict[str, np.ndarray]]:
    """Per case, per body: ``{'base': (relerr, sd), ...}`` over the robot's identified
    estimates (relative to the error scale)."""
    out = []
    for r in rows:
        ident = set(identified_estimates(get_robot(r["robot"])))
        case = {}
        for b in BODIES:
            names = [p for p in ESTIMATE_NAMES if p.startswith(b + ".") and p in ident]
            case[b] = (np.array([_f(r[f"relerr.{p}"]) for p in names]),
                       np.array([_f(r[f"sd.{p}"]) for p in names]))
        out.append(case)
    return out


def calibration(rows, errs) -> Dict[str, object]:
    """The fraction of the estimates within 2 sd (the rows' ``within2sd``, pooled: every case
    has as many estimates) and the RMS of error / sd, with case-bootstrap intervals; the
    per-case fractions."""
    per_case = np.array([_f(r["within2sd"]) for r in rows])
    frac = bootstrap_ci(list(per_case), lambda xs: float(np.mean(xs)))
    z = [np.concatenate([e[b][0] / e[b][1] for b in BODIES]) for e in errs]
    rms = bootstrap_ci(z, lambda gs: float(np.sqrt(np.mean(np.concatenate(gs) ** 2))))
    return {"within": frac, "per_case": per_case, "rms_z": rms}


def _p_off(sd: np.ndarray, threshold: float) -> float:
    """At most the probability that an estimate of a body is off by more than the threshold,
    its errors Gaussian with these sds (calibrated), whatever their correlation (Sidak's
    inequality: P(all within) >= the product of P(each within))."""
    inside = [1.0 - math.erfc(threshold / (s * math.sqrt(2.0))) for s in sd]
    return 1.0 - float(np.prod(inside))


def flag_outcomes(rows, errs, threshold: float = THRESHOLD) -> Dict[str, tuple]:
    """For the estimator's own flags (``identified.<body>`` at the end) and for each rule of
    :data:`RULES` applied to the final sds: (bodies flagged, of them off by more than the
    threshold at the end, the one-sided 95 % upper bound of that fraction, the number off
    expected at most were the sds calibrated)."""
    out = {}

    def summarise(flagged):
        n = len(flagged)
        k = sum(bool(np.max(rel) > threshold) for rel, _ in flagged)
        up = clopper_pearson(k, n, one_sided=True)[1] if n else math.nan
        return n, k, up, sum(_p_off(sd, threshold) for _, sd in flagged)
    out["as flagged by the estimator"] = summarise(
        [e[b] for r, e in zip(rows, errs) for b in BODIES if r[f"identified.{b}"] == "1"])
    for name, c in RULES.items():
        out[name] = summarise([e[b] for e in errs for b in BODIES
                               if np.max(c * e[b][1]) <= threshold])
    return out


def flag_table(flags: Dict[str, tuple]) -> List[str]:
    """The Markdown table of :func:`flag_outcomes`."""
    lines = ["| rule | c | bodies flagged | off by more than the threshold | fraction | upper 95 % "
             "bound | expected off if the sds were calibrated (at most) |",
             "|---|---|---|---|---|---|---|"]
    for name, (nb, k, up, expect) in flags.items():
        cval = f"{RULES[name]:.2f}" if name in RULES else "-"
        frac = f"{_pct(k / nb)}" if nb else "-"
        lines.append(f"| {name} | {cval} | {nb} | {k} | {frac} | "
                     f"{_pct(up) if nb else '-'} | {expect:.2f} |")
    return lines


def _efficiencies(rows) -> Dict[str, float]:
    """Per identified estimate: 1 / RMS over the cases of error / bound (the information
    filter's Cramér-Rao bound of that case): 1 where the errors are as small as any unbiased
    estimator's. Each case in units of its own bound, so that the few poorly excited cases
    with bounds of many times the scale (and errors kept small by the guess) do not decide the
    figure, as they do a ratio of RMS bound to RMS error over cases."""
    out = {}
    ident = {name: set(identified_estimates(get_robot(name)))
             for name in {r["robot"] for r in rows}}
    for p in ESTIMATE_NAMES:
        z = [_f(r[f"relerr.{p}"]) / _f(r[f"crb.{p}"]) for r in rows
             if p in ident[r["robot"]] and _f(r.get(f"crb.{p}", "")) > 0.0]
        rms = float(np.sqrt(np.mean(np.square(z)))) if z else 0.0
        if rms > 0.0:
            out[p] = 1.0 / rms
    return out


def efficiency(rows) -> Dict[str, tuple]:
    """Per estimate: :func:`_efficiencies` with its case-bootstrap interval."""
    names = list(_efficiencies(rows))
    if not names:
        return {}

    def each(rs):
        e = _efficiencies(rs)
        return np.array([e.get(p, math.nan) for p in names])
    value, lo, hi = bootstrap_ci(rows, each)
    return {p: (value[i], lo[i], hi[i]) for i, p in enumerate(names)}


def times(rows) -> Dict[str, tuple]:
    """Medians with their order-statistics intervals (never = inf)."""
    def col(name):
        return np.array([_f(r[name]) if not math.isnan(_f(r[name])) else math.inf
                         for r in rows])
    both = np.maximum(col("t_identified.base"), col("t_identified.target"))
    return {"target flagged": median_ci(col("t_identified.target")),
            "base flagged": median_ci(col("t_identified.base")),
            "both flagged": median_ci(both),
            "every estimate within 1 % for good": median_ci(col("t_1pct")),
            "every estimate within 0.1 % for good": median_ci(col("t_01pct"))}


def cost(rows, wall: float, workers: int, ran: int) -> Dict[str, float]:
    """Wall time per case in its worker (median, 10 % and 90 % quantiles) [s], and the
    throughput [cases per minute per worker] of this call's ``ran`` cases."""
    w = np.array([_f(r["wall_time"]) for r in rows])
    return {"median": float(np.median(w)), "q10": float(np.quantile(w, 0.1)),
            "q90": float(np.quantile(w, 0.9)), "mean": float(np.mean(w)),
            "per_worker_per_min": 60.0 / float(np.mean(w)),
            "run_per_worker_per_min": ran / (wall / 60.0) / workers if ran else math.nan}


def _pct(x: float) -> str:
    return f"{100 * x:.1f} %"


def _t(x: float) -> str:
    return "never" if math.isinf(x) else ("n too small" if math.isnan(x) else f"{x:.0f} s")


def report(rows, args, wall: float, load0: float, summary) -> str:
    n = len(rows)
    errs = estimate_errors(rows)
    w1 = sum(_f(r["worst_error"]) < 1e-2 for r in rows)
    w01 = sum(_f(r["worst_error"]) < 1e-3 for r in rows)
    cal = calibration(rows, errs)
    flags = flag_outcomes(rows, errs)
    eff = efficiency(rows)
    tm = times(rows)
    c = cost(rows, wall, args.workers, summary.submitted)
    failed = summary.failed
    lo1, hi1 = wilson(w1, n)
    lo01, hi01 = wilson(w01, n)
    per = cal["per_case"]
    e_med = float(np.median([v[0] for v in eff.values()])) if eff else math.nan
    low = min(eff.items(), key=lambda kv: kv[1][0]) if eff else None
    where = (f"the Dask scheduler {args.scheduler}" if args.scheduler
             else f"{args.workers} local Dask workers")
    lines = [
        "# Monte Carlo statistics: random spatial targets through the sensors",
        "",
        f"Generated by `python benchmarks/montecarlo_stats.py --cases {args.cases} --seed "
        f"{args.seed} --seeds {args.seeds} --stop-time {args.stop_time:g}"
        f"{' --resume' if args.resume else ''}` on {_dt.date.today()} (spacerobot "
        f"{__version__}, {platform.machine()}, {os.cpu_count()} cores, {where}, load average "
        f"{load0:.2f} at start): {n} cases finished, {failed} failed; this call ran "
        f"{summary.submitted} of them in {wall / 60:.1f} min"
        + (" (the others in an earlier call, kept by --resume). " if summary.submitted < n
           else ". ") +
        f"Table: [{Path(args.csv).name}]({Path(args.csv).name}).",
        "",
        f"Each case: a random spatial base and target (`spacerobot.robots.random_scenario`, "
        f"generator `default_rng([{args.seed}, index])`) run for {args.stop_time:g} s through "
        f"plant -> sensors -> estimator with the system's `realistic` set (realistic sensor "
        f"noise drawn per case, the force method with differenced accelerations, the "
        f"estimator's noise profile and information filter), the excitation loop closed: "
        f"`spacerobot montecarlo --robot spatial --sensors --cases {args.cases} --seed "
        f"{args.seed} --stop-time {args.stop_time:g}`. Errors are relative to each estimate's "
        f"error scale (`interface.error_scale`). Intervals are 95 %.",
        "",
        "| figure | value | 95 % interval | method |",
        "|---|---|---|---|",
        f"| cases with every estimate within 1 % | {w1}/{n} ({_pct(w1 / n)}) | "
        f"{_pct(lo1)} - {_pct(hi1)} | Wilson |",
        f"| cases with every estimate within 0.1 % | {w01}/{n} ({_pct(w01 / n)}) | "
        f"{_pct(lo01)} - {_pct(hi01)} | Wilson |",
        f"| estimates within 2 reported sd (calibrated: 90-99 %) | {_pct(cal['within'][0])} | "
        f"{_pct(cal['within'][1])} - {_pct(cal['within'][2])} | cases resampled |",
        f"| RMS of error / sd (calibrated: 1) | {cal['rms_z'][0]:.2f} | {cal['rms_z'][1]:.2f}"
        f" - {cal['rms_z'][2]:.2f} | cases resampled |",
        f"| efficiency, 1 / RMS of error / bound (median over the estimates) | {e_med:.2f} | "
        f"lowest: {low[0]} {low[1][0]:.2f} ({low[1][1]:.2f} - {low[1][2]:.2f}) | cases "
        f"resampled |" if low else "| efficiency | - | | |",
    ]
    for name, (med, lo, hi) in tm.items():
        lines.append(f"| median time: {name} | {_t(med)} | {_t(lo)} - {_t(hi)} | order "
                     f"statistics |")
    lines += [
        "",
        f"Per case, the fraction of its 20 estimates within 2 sd: median {np.median(per):.2f}, "
        f"lowest {per.min():.2f}; cases with at least 90 %: {int((per >= 0.9).sum())}/{n}, "
        f"with at most 70 %: {int((per <= 0.7).sum())}/{n} (the estimates of a case share the "
        f"errors of its sensors, so a case's misses come together).",
        "",
        f"**Flags.** A body flagged identified should have every estimate within the threshold "
        f"`ident.sd_rel` = {100 * THRESHOLD:g} % of its scale. Of the bodies flagged at the end "
        f"(as the estimator flagged them, and as each candidate rule on the reported sds would: "
        f"`max_i c sd_i <= threshold` over the body's 10 estimates), how many had an estimate "
        f"off by more than the threshold at the end (the target: at most 1 %, upper 95 % "
        f"bound):",
        "",
    ] + flag_table(flags)
    during = {b: sum(r[f"false_identified.{b}"] == "1" for r in rows) for b in BODIES}
    ever = {b: sum(_f(r[f"t_identified.{b}"]) < math.inf for r in rows) for b in BODIES}
    n_ever, n_off = sum(ever.values()), sum(during.values())
    lines += [
        "",
        f"During the runs (not only at the end): {n_ever} bodies were flagged at some time "
        f"(base {ever['base']}, target {ever['target']}); {n_off} of them while an estimate "
        f"of the body was more than 1 % off (the table's `false_identified` columns"
        + (f"; upper 95 % bound {_pct(clopper_pearson(n_off, n_ever, one_sided=True)[1])}"
           if n_ever else "") + ").",
    ]
    lines += [
        "",
        "Efficiency per estimate (1 / RMS over the cases of error / that case's bound, 1 = as good "
        "as any unbiased estimator; "
        "cases resampled):",
        "",
        "| estimate | efficiency | 95 % interval |",
        "|---|---|---|",
    ]
    lines += [f"| {p} | {v[0]:.2f} | {v[1]:.2f} - {v[2]:.2f} |" for p, v in eff.items()]
    lines += [
        "",
        f"**Cost.** Wall time of a case in its worker: median {c['median']:.1f} s (10-90 %: "
        f"{c['q10']:.1f}-{c['q90']:.1f} s, mean {c['mean']:.1f} s), i.e. "
        f"{c['per_worker_per_min']:.1f} cases per minute per worker from the mean"
        + (f"; this call's {summary.submitted} cases, start-up and the build included: "
           f"{c['run_per_worker_per_min']:.1f} cases per minute per worker." if summary.submitted
           else " (a resumed table: no case ran in this call)."),
        "",
    ]
    return "\n".join(lines)


def seed_report(rows, args) -> str:
    """Calibration and flags of the default target across sensor seeds."""
    n = len(rows)
    if not n:
        return ""
    errs = estimate_errors(rows)
    cal = calibration(rows, errs)
    flags = flag_outcomes(rows, errs)
    per = cal["per_case"]
    w1 = sum(_f(r["worst_error"]) < 1e-2 for r in rows)
    lines = [
        f"## The default target across {n} sensor seeds",
        "",
        f"The sensors system's own scenario (`spacerobot run --robot spatial --sensors "
        f"--stop-time {args.stop_time:g} --set sensors.seed=K`, K = 0 ... {n - 1}): the same "
        f"bodies every run, only the sensors' noise drawn anew. Table: "
        f"[{Path(args.seed_csv).name}]({Path(args.seed_csv).name}). What made this target's "
        f"sds too small (the navigation noises' product in the angular rows) and its fix, "
        f"measured: [CALIBRATION.md](CALIBRATION.md).",
        "",
        "| figure | value | 95 % interval |",
        "|---|---|---|",
        f"| runs with every estimate within 1 % | {w1}/{n} | "
        f"{_pct(wilson(w1, n)[0])} - {_pct(wilson(w1, n)[1])} |",
        f"| estimates within 2 reported sd (calibrated: 90-99 %) | {_pct(cal['within'][0])} | "
        f"{_pct(cal['within'][1])} - {_pct(cal['within'][2])} (seeds resampled) |",
        f"| RMS of error / sd (calibrated: 1) | {cal['rms_z'][0]:.2f} | {cal['rms_z'][1]:.2f} - "
        f"{cal['rms_z'][2]:.2f} |",
        "",
        f"Per seed, the fraction within 2 sd: median {np.median(per):.2f}, lowest "
        f"{per.min():.2f}; seeds with at most 70 %: {int((per <= 0.7).sum())}/{n}.",
        "",
    ] + flag_table(flags)
    return "\n".join(lines + [""])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--seeds", type=int, default=20,
                    help="sensor seeds of the default target (0: none)")
    ap.add_argument("--stop-time", dest="stop_time", type=float, default=300.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scheduler", help="an existing Dask scheduler instead of local workers")
    ap.add_argument("--resume", action="store_true",
                    help="keep the rows of an earlier run in the table (default: start afresh, "
                         "so that every figure is of the tree as it is)")
    ap.add_argument("--out", default=str(HERE / "MONTECARLO_STATS.md"))
    args = ap.parse_args(argv)
    out = Path(args.out)
    args.csv = str(out.with_suffix(".csv"))
    args.seed_csv = str(out.with_name(out.stem + "_SEEDS.csv"))
    for table in (args.csv, args.seed_csv):
        if Path(table).exists() and not args.resume:
            Path(table).unlink()
    cases = make_cases("spatial", args.cases, args.seed, ("force",), ("closed",),
                       args.stop_time, noise_scale=1.0, accel_source="differenced")
    load0 = os.getloadavg()[0]
    t0 = time.time()
    seeds = [SeedCase(k, args.stop_time) for k in range(args.seeds)]
    with tempfile.TemporaryDirectory() as build:
        summary = run_montecarlo(cases, args.csv, workers=args.workers, build_dir=build,
                                 scheduler=args.scheduler, progress=sys.stderr.isatty())
        wall = time.time() - t0
        if seeds:
            run_sweep(seeds, args.seed_csv, workers=args.workers, scheduler=args.scheduler,
                      build_dir=build, builder="spacerobot.system.montecarlo:"
                      "build_sensors_system", study=SEED_STUDY, progress=sys.stderr.isatty())
    ids = {c.id for c in cases}
    rows = [r for r in read_results(args.csv) if r["case_id"] in ids and r["status"] == "ok"]
    rows.sort(key=lambda r: r["case_id"])
    seed_ids = {c.id for c in seeds}
    seed_rows = sorted((r for r in read_results(args.seed_csv)
                        if r["case_id"] in seed_ids and r["status"] == "ok"),
                       key=lambda r: int(r["sensors_seed"]))
    text = report(rows, args, wall, load0, summary) + "\n" + seed_report(seed_rows, args)
    out.write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
