"""What the noise profile's information filter and rigid band cost per sample
(docs/identification.md, "The information filter and the bound"): the spatial robot's own
scenario, 120 s of samples every 0.1 s through the sensors' realistic defaults (seed 0, the
recording of tests/oracles/samples.py), fed to the library's estimator (the core the FMU
builds) with the profile as shipped (the band from the replay on), with the band off
(`ident.band = 2`) and with the profile's equations alone (`ident.information = 2`).

Reported per configuration: the calling thread's CPU time per sample over the run (thread
time: numpy's BLAS threads, idle here, are not the estimator's) and the largest single step
(the replay's), the range over 9 runs in 3 interleaved rounds (the configurations in turn in
each round). Nothing is asserted.

Usage: ``python benchmarks/filter_cost.py``
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

DT, STOP, ROUNDS, RUNS = 0.1, 120.0, 3, 3
CONFIGS = {"profile (band on)": {},
           "band off (ident.band = 2)": {"ident.band": 2},
           "equations alone (ident.information = 2)": {"ident.information": 2}}


def one_run(sc, X, options) -> tuple[float, float]:
    """CPU per sample [us] and the largest step [ms] of one run over the samples X."""
    from oracles.samples import fmu_identifier
    ident = fmu_identifier(sc, DT, {"ident.noise_profile": 1, **options})
    total, largest = 0.0, 0.0
    for k, x in enumerate(X):
        t0 = time.thread_time()
        ident.update_flat(DT * k, x)
        step = time.thread_time() - t0
        total += step
        largest = max(largest, step)
    return 1e6 * total / len(X), 1e3 * largest


def main() -> int:
    from oracles.samples import scenario_samples, sensed
    from spacerobot.robots import scenario
    sc = scenario("spatial")
    XT, _ = scenario_samples(sc, STOP, DT)
    X = sensed(sc, XT, 0, DT)
    per, big = {k: [] for k in CONFIGS}, {k: [] for k in CONFIGS}
    for _ in range(ROUNDS):
        for name, options in CONFIGS.items():
            for _ in range(RUNS):
                us, ms = one_run(sc, X, options)
                per[name].append(us)
                big[name].append(ms)
    print("| configuration | CPU per sample [us] | largest step [ms] |\n|---|---|---|")
    for name in CONFIGS:
        print(f"| {name} | {min(per[name]):.0f}-{max(per[name]):.0f} | "
              f"{min(big[name]):.1f}-{max(big[name]):.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
