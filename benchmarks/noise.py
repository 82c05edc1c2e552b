"""Monte Carlo benchmark of identification under realistic sensor noise (issue 14); writes
benchmarks/NOISE.md, its CSV table and the worst-error plot.

Random spatial cases (``spacerobot.robots.random_scenario``, as benchmarks/montecarlo.py) run
through plant -> sensors -> estimator (``<robot>_sensors.ssp``, parameter set ``realistic``:
the sensors' realistic defaults, docs/sensors.md; sensors ``seed`` = the case index), the
excitation loop closed, for 300 s: the momentum method, and the force method with measured and
with differenced accelerations (the momentum method reads no acceleration, so its two
acceleration sources are one run). Every case uses the estimator's defaults: no noise-aware
weighting or filtering exists yet.

Per run, besides spacerobot.system.montecarlo's columns (at 300 s): the worst relative error
of the 20 estimates at 60 s and at 300 s, and the fraction of the 20 estimates within 2
reported standard deviations of the truth at 60 s and at 300 s (the calibration the issue asks
to lie in [0.90, 0.99]). Nothing is asserted here.

Usage: ``python benchmarks/noise.py [--cases 20] [--seed 2026] [--workers 2]
[--stop-time 300] [--out benchmarks/NOISE.md]``
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import hashlib
import os
import platform
import socket
import sys
import tempfile
import time
import traceback
from dataclasses import dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from spacerobot import __version__  # noqa: E402
from spacerobot.interface import ESTIMATE_NAMES, relative_errors  # noqa: E402
from spacerobot.system.montecarlo import COLUMNS, Case, case_row  # noqa: E402
from spacerobot.system.ssd import build_system  # noqa: E402
from spacerobot.system.sweep.execute import Study, run_sweep  # noqa: E402
from spacerobot.system.sweep.run import DEFAULT_RUNNER, _resolve  # noqa: E402
from spacerobot.system.sweep.table import read_table  # noqa: E402

#: the checkpoints of the benchmark [s]
CHECKPOINTS = (60.0, 300.0)
NOISE_COLUMNS = tuple(f"{what}_{int(t)}" for t in CHECKPOINTS
                      for what in ("worst", "within2sd"))


@dataclass(frozen=True)
class NoiseCase(Case):
    """A Monte Carlo case with the sensors FMU: its seed is the case index."""

    @property
    def id(self) -> str:
        return hashlib.sha256(json.dumps(["noise", super().id]).encode()).hexdigest()[:16]

    def fmi_overrides(self):
        ov = super().fmi_overrides()
        ov["sensors.seed"] = int(self.index)
        return ov


def noise_row(res):
    """Worst error and the fraction within 2 sd at each checkpoint."""
    truth = np.array([res.truth[n] for n in ESTIMATE_NAMES])
    est = np.column_stack([res.data[f"estimator.{n}"] for n in ESTIMATE_NAMES])
    sd = np.column_stack([res.data[f"estimator.sd.{n}"] for n in ESTIMATE_NAMES])
    row = {}
    for t in CHECKPOINTS:
        k = int(np.searchsorted(res.time, t - 1e-9))
        k = min(k, len(res.time) - 1)
        row[f"worst_{int(t)}"] = float(relative_errors(est[k], truth).max())
        row[f"within2sd_{int(t)}"] = float(np.mean(np.abs(est[k] - truth) <= 2.0 * sd[k]))
    return row


def run_noise_case(case: NoiseCase, ssp_path: str, runner: str = DEFAULT_RUNNER):
    """spacerobot.system.montecarlo.run_case plus :func:`noise_row`; never raises."""
    row = dict(case.columns())
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    t0 = time.perf_counter()
    try:
        res = _resolve(runner)(str(ssp_path), stop_time=case.stop_time,
                               overrides=case.fmi_overrides(), progress=False)
        row.update(case_row(case, res))
        row.update(noise_row(res))
        row["status"], row["error"] = "ok", ""
    except Exception as e:  # noqa: BLE001 -- report every failure in the table
        msg = str(e).strip() or traceback.format_exc(limit=1).strip().splitlines()[-1]
        row["status"], row["error"] = "failed", f"{type(e).__name__}: {msg}"
    row["wall_time"] = round(time.perf_counter() - t0, 3)
    return row


STUDY = Study(name="noise", columns=COLUMNS + NOISE_COLUMNS, key="case_id",
              task=run_noise_case)


def summary(rows) -> str:
    lines = ["| method | accelerations | runs | median worst error 60 s | largest 60 s | "
             "median worst error 300 s | largest 300 s | within 1 % at 300 s | "
             "mean fraction within 2 sd, 60 s | 300 s |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    groups = {}
    for r in rows:
        if r["status"] == "ok":
            groups.setdefault((r["method"], r["accel_source"]), []).append(r)
    for (method, accel), rs in sorted(groups.items()):
        w60 = np.array([float(r["worst_60"]) for r in rs])
        w300 = np.array([float(r["worst_300"]) for r in rs])
        c60 = np.mean([float(r["within2sd_60"]) for r in rs])
        c300 = np.mean([float(r["within2sd_300"]) for r in rs])
        acc = "-" if method == "momentum" else accel
        lines.append(f"| {method} | {acc} | {len(rs)} | {100 * np.median(w60):.3g} % | "
                     f"{100 * w60.max():.3g} % | {100 * np.median(w300):.3g} % | "
                     f"{100 * w300.max():.3g} % | {(w300 < 1e-2).sum()}/{len(rs)} | "
                     f"{c60:.2f} | {c300:.2f} |")
    return "\n".join(lines)


def plot(rows, out_png: Path) -> Path:
    """Distribution of the worst error at each checkpoint per method and acceleration source."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(CHECKPOINTS), figsize=(11, 4.2), sharey=True)
    groups = {}
    for r in rows:
        if r["status"] == "ok":
            groups.setdefault((r["method"], r["accel_source"]), []).append(r)
    for ax, t in zip(np.atleast_1d(axes), CHECKPOINTS):
        for (method, accel), rs in sorted(groups.items()):
            w = np.sort(np.maximum([100 * float(r[f"worst_{int(t)}"]) for r in rs], 1e-7))
            label = method if method == "momentum" else f"{method}, {accel}"
            ax.step(w, np.arange(1, len(w) + 1) / len(w), where="post",
                    label=f"{label} ({len(w)})")
        ax.axvline(1.0, color="grey", lw=0.8, ls=":")
        ax.set_xscale("log")
        ax.set_xlabel(f"worst relative error at {t:g} s [%]")
        ax.grid(True, which="both", alpha=0.3)
    np.atleast_1d(axes)[0].set_ylabel("fraction of cases")
    np.atleast_1d(axes)[0].legend(fontsize=8, loc="lower right")
    fig.suptitle("Random spatial cases, realistic sensor noise, excitation loop closed")
    fig.tight_layout()
    fig.savefig(out_png, dpi=120)
    plt.close(fig)
    return out_png


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=20)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--stop-time", type=float, default=300.0)
    ap.add_argument("--out", default=str(HERE / "NOISE.md"))
    args = ap.parse_args(argv)

    out = Path(args.out)
    csv = out.with_suffix(".csv")
    if csv.exists():
        csv.unlink()                              # measure the tree as it is, every case
    t0 = time.time()
    load0 = os.getloadavg()
    combos = (("momentum", "measured"), ("force", "measured"), ("force", "differenced"))
    cases = [NoiseCase("spatial", i, args.seed, m, "closed", args.stop_time, a)
             for i in range(args.cases) for m, a in combos]
    with tempfile.TemporaryDirectory() as tmp:
        ssp = build_system("spatial", Path(tmp) / "spatial", sensors=True)["ssp"]
        res = run_sweep(cases, csv, workers=args.workers, ssp={"spatial": str(ssp)},
                        progress=False, study=STUDY)
    wall = time.time() - t0
    rows = read_table(csv, STUDY.key)
    png = plot(rows, out.with_suffix(".png"))
    text = [
        "# Monte Carlo: identification under realistic sensor noise",
        "",
        f"Generated by `python benchmarks/noise.py --cases {args.cases} --seed {args.seed} "
        f"--stop-time {args.stop_time:g}` on {_dt.date.today()} (spacerobot {__version__}, "
        f"{platform.machine()}, {os.cpu_count()} cores, {args.workers} Dask workers, load "
        f"average {load0[0]:.2f} at start); {len(rows)} runs in {wall / 60:.1f} min. Table: "
        f"[{csv.name}]({csv.name}); plot (worst error at each checkpoint): "
        f"[{Path(png).name}]({Path(png).name}).",
        "",
        f"{args.cases} random spatial cases (`spacerobot.robots.random_scenario`, generator "
        f"`default_rng([{args.seed}, index])`), plant -> sensors -> estimator with the sensors' "
        "realistic defaults (docs/sensors.md, sensors seed = case index), excitation loop "
        "closed, the estimator's defaults. Errors: `interface.relative_errors`, worst of the "
        "20 estimates; calibration: the fraction of the 20 estimates within 2 reported "
        "standard deviations of the truth (calibrated: between 0.90 and 0.99).",
        "",
        summary(rows),
        "",
        f"Failed runs: {res.failed}." + "".join(f"\n- {i}: {e}" for i, e in res.failures),
        "",
    ]
    out.write_text("\n".join(text))
    print(out.read_text())
    return 0


if __name__ == "__main__":
    sys.exit(main())
