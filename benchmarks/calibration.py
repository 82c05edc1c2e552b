"""Calibration of the reported standard deviations on the default target across sensor seeds,
with single sensor error sources switched off, the noise scaled or the initial motion changed:
the measurements behind benchmarks/CALIBRATION.md.

Each variant runs the sensors system's own scenario (``spacerobot run --robot spatial --sensors
--stop-time T --set sensors.seed=K``, K = 0 ... N-1, plus the variant's ``--set`` values) and
reports, over the identified estimates of all seeds, with z = (estimate - truth) / reported sd
(signed): the fraction with |z| <= 2, the RMS of z, the RMS over the estimates of the mean of z
across seeds (a bias common to the seeds; about 1 / sqrt(N) without one) and the RMS of z about
that mean. An error source switched off is switched off in the sensors FMU and in the
estimator's noise model alike (``noise.<name>`` of both), so the model stays right.

Nothing is asserted. Usage: ``python benchmarks/calibration.py [--seeds 20] [--stop-time 300]
[--procs 1] [VARIANT ...]`` (default: every variant of :data:`VARIANTS`).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from multiprocessing import Pool
from pathlib import Path
from typing import Dict

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from spacerobot.interface import ESTIMATE_NAMES, ParameterLayout  # noqa: E402
from spacerobot.robots import get_robot  # noqa: E402

#: the estimator FMU has no noise.<name> for these (the sensors' own processes)
SENSORS_ONLY = ("gyro.rrw", "accel.bias", "accel.brw")
ALL = ("gyro.arw", "gyro.bias", "gyro.rrw", "star.cross", "star.roll", "nav.r", "nav.v",
       "accel.vrw", "accel.bias", "accel.brw", "alpha", "enc.resolution", "enc.q", "enc.qd",
       "enc.qdd", "thrust.scale", "thrust.misalign")


def off(*names: str) -> Dict[str, float]:
    """The overrides that switch the error sources ``names`` off in both FMUs."""
    ov = {}
    for n in names:
        ov[f"sensors.noise.{n}"] = 0.0
        if n not in SENSORS_ONLY:
            ov[f"estimator.noise.{n}"] = 0.0
    return ov


def scale(s: float) -> Dict[str, float]:
    return {"sensors.noise.scale": s, "estimator.noise.scale": s}


VARIANTS = {
    "default": {},
    "noise.scale 0.5": scale(0.5),
    "noise.scale 2": scale(2.0),
    "nav off": off("nav.r", "nav.v"),
    "nav.r off": off("nav.r"),
    "nav.v off": off("nav.v"),
    "thrust off": off("thrust.scale", "thrust.misalign"),
    "gyro off": off("gyro.arw", "gyro.bias", "gyro.rrw"),
    "only nav": off(*[n for n in ALL if not n.startswith("nav.")]),
    "v0 = 0": {f"plant.base.v0[{i}]": 0.0 for i in (1, 2, 3)},
    "omega0 / 3.7": {"plant.base.omega0[1]": 0.033, "plant.base.omega0[2]": 0.067,
                     "plant.base.omega0[3]": 0.1},
}


def _run(args):
    from spacerobot.system.runner import run_ssp
    path, ov, stop = args
    res = run_ssp(path, stop_time=stop, overrides=ov, progress=False)
    est = np.array([res.data[f"estimator.{n}"][-1] for n in ESTIMATE_NAMES])
    truth = np.array([res.truth[n] for n in ESTIMATE_NAMES])
    sd = np.array([res.data[f"estimator.sd.{n}"][-1] for n in ESTIMATE_NAMES])
    return (est - truth) / sd


def measure(ssp: str, overrides: Dict[str, float], seeds: int, stop: float, procs: int):
    """z per seed (rows) and identified estimate (columns) and the four figures."""
    ident = ParameterLayout.for_robot(get_robot("spatial")).identified
    jobs = [(ssp, dict(overrides, **{"sensors.seed": k}), stop) for k in range(seeds)]
    if procs > 1:
        with Pool(procs) as p:
            z = np.array(p.map(_run, jobs))[:, ident]
    else:
        z = np.array([_run(j) for j in jobs])[:, ident]
    mean = z.mean(axis=0)
    return {"within 2 sd": float(np.mean(np.abs(z) <= 2.0)),
            "RMS z": float(np.sqrt(np.mean(z ** 2))),
            "RMS of the mean z": float(np.sqrt(np.mean(mean ** 2))),
            "RMS of z about the mean": float(np.sqrt(np.mean((z - mean) ** 2)))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("variants", nargs="*", help=f"of: {', '.join(VARIANTS)}")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--stop-time", dest="stop_time", type=float, default=300.0)
    ap.add_argument("--procs", type=int, default=1)
    args = ap.parse_args(argv)
    unknown = [v for v in args.variants if v not in VARIANTS]
    if unknown:
        ap.error(f"unknown variant(s) {unknown}; known: {list(VARIANTS)}")
    from spacerobot.system.montecarlo import build_sensors_system
    with tempfile.TemporaryDirectory() as build:
        ssp = str(build_sensors_system("spatial", build)["ssp"])
        print(f"| variant ({args.seeds} seeds, {args.stop_time:g} s) | within 2 sd | RMS z | "
              f"RMS of the mean z | RMS of z about the mean |")
        print("|---|---|---|---|---|")
        for name in args.variants or VARIANTS:
            f = measure(ssp, VARIANTS[name], args.seeds, args.stop_time, args.procs)
            print(f"| {name} | {100 * f['within 2 sd']:.1f} % | {f['RMS z']:.2f} | "
                  f"{f['RMS of the mean z']:.2f} | {f['RMS of z about the mean']:.2f} |",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
