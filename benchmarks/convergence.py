"""The README's accuracy figures, measured: for the paper's noise-free scenarios, the time after
which every identified estimate stays within 0.1 % of the truth (the error metric of
``spacerobot.error_scale``) and the largest error at the stop time, per method and
acceleration source. The runs are deterministic (no noise, no random draw): a second run gives
the same digits, so there is no spread to report.

    python benchmarks/convergence.py [--build-dir DIR]      # about 10 s; prints a Markdown table
"""
import argparse
import tempfile
from pathlib import Path

import numpy as np

from spacerobot import (ESTIMATE_NAMES, build_system, error_scale, identified_estimates,
                        run_ssp, scenario)

CASES = [  # robot, parameter set, estimator overrides, label
    ("planar", "medium", {"estimator.method": 1}, "momentum"),
    ("planar", "medium", {"estimator.method": 2}, "force, measured accelerations"),
    ("planar", "medium", {"estimator.method": 2, "estimator.accel_source": 2},
     "force, differenced accelerations"),
    ("spatial", "paper", {"estimator.method": 1}, "momentum"),
    ("spatial", "paper", {"estimator.method": 2}, "force, measured accelerations"),
]


def settle_time(time, errors, tol=1e-3):
    """First time from which every error stays below tol (inf if never)."""
    bad = np.flatnonzero((errors >= tol).any(axis=0))
    if bad.size == 0:
        return float(time[0])
    return float(time[bad[-1] + 1]) if bad[-1] + 1 < time.size else float("inf")


def measure(build_dir: Path, robot: str, pset: str, overrides: dict, stop_time=60.0):
    ssp = build_dir / robot / f"{robot}.ssp"
    if not ssp.is_file():
        build_system(robot, build_dir / robot)
    res = run_ssp(ssp, parameter_set=pset, stop_time=stop_time, overrides=overrides,
                  progress=False)
    names = identified_estimates(scenario(robot).robot)
    truth = np.array([res.truth[n] for n in ESTIMATE_NAMES])
    scale = dict(zip(ESTIMATE_NAMES, error_scale(truth)))
    err = np.array([np.abs(res.data[f"estimator.{n}"] - res.truth[n]) / scale[n]
                    for n in names])
    # the estimator's outputs at t + dt are the estimates after the sample of t
    return settle_time(res.time, err), float(err[:, -1].max()), names[int(err[:, -1].argmax())]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--build-dir", type=Path, default=None)
    args = ap.parse_args()
    build = args.build_dir or Path(tempfile.mkdtemp(prefix="convergence-"))
    print("| robot, set | method | within 0.1 % from | largest error at 60 s |")
    print("|---|---|---|---|")
    for robot, pset, overrides, label in CASES:
        t01, last, worst = measure(build, robot, pset, overrides)
        when = f"{t01:.1f} s" if t01 < float("inf") else "not by 60 s"
        print(f"| {robot} {pset} | {label} | {when} | {100 * last:.3g} % ({worst}) |")


if __name__ == "__main__":
    main()
