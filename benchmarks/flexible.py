"""The modal columns (ident.modes = 1) over wing and slosh size and frequency: the spatial
robot with two solar wings or two slosh modes (the `wings` / `slosh` parameter sets, their
masses halved and doubled, their frequencies moved), 300 s of the plant with its excitation on,
the momentum method (joint solver), noise-free and through the sensors' realistic defaults
(seed 0) with ident.noise_profile = 1. For each case and set-up: the worst error of the 20
estimates against the composite rigid truth (%), the estimates within 2 reported sd (of 20),
the time from which both bodies stay flagged identified (s; '-' never), and the modes in use at
300 s. Set-ups:

  rigid          ident.modes = 2 (what the estimator does without the columns)
  modal          ident.modes = 1, the modes found from the data
  sensors        the sensors, the noise profile: its information filter reports, and the
                 rigid band (ident.band, on by the profile) where the filter finds the
                 rigid model's misfit (coloured residuals)
  sensors, no band  the same with ident.band = 2: the information filter alone
  sensors rigid  the sensors, the profile, ident.information = 2 (the joint solver reports)
  sensors modal  the sensors, the profile, ident.information = 2, ident.modes = 1
  filter modal   the sensors, the profile (its information filter), ident.band = 2,
                 ident.modes = 1: the filter reports unless the rigid model does not fit
                 (coloured residuals) and the columns found a mode; then the joint solver
                 with the columns
  band modal     the sensors, the profile (its information filter and the rigid band,
                 automatic), ident.modes = 1: as "filter modal", but where the rigid model
                 does not fit the band reports first (its compliance where its rows fit,
                 else the found modes' band where its rows fit, diag.band 3)

Run: python benchmarks/flexible.py [--quick] [--jobs 2] [--robot URDF] [--setups S ...]
> benchmarks/FLEXIBLE.txt (--quick: the issue's sizes only; --setups: a subset of the set-ups,
by name; --robot: another spacecraft than the spatial robot, e.g. the
held-out tests/data/arm5.urdf, a 900 kg hub with a 5-joint arm, with the same wings and slosh
on its base). Every case is a separate process (--jobs at a time).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from functools import partial

os.environ.setdefault("OMP_NUM_THREADS", "1")     # one BLAS thread: thread_time is the CPU

import numpy as np

# the recording is the tests' (tests/oracles/samples.py)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

DT = 0.1
T_END = 300.0

#: case name -> (set, mass factor, frequency [Hz] of the first part: the others scaled alike)
CASES = {
    "wings 2 x 50 kg 0.5 Hz (issue)": ("wings", 1.0, 0.5),
    "wings 2 x 25 kg 0.5 Hz": ("wings", 0.5, 0.5),
    "wings 2 x 100 kg 0.5 Hz": ("wings", 2.0, 0.5),
    "wings 2 x 50 kg 0.3 Hz": ("wings", 1.0, 0.3),
    "wings 2 x 50 kg 0.2 Hz": ("wings", 1.0, 0.2),
    "slosh 2 x 25 kg 0.30/0.35 Hz (issue)": ("slosh", 1.0, 0.30),
    "slosh 2 x 12.5 kg 0.30/0.35 Hz": ("slosh", 0.5, 0.30),
    "slosh 2 x 50 kg 0.30/0.35 Hz": ("slosh", 2.0, 0.30),
    "slosh 2 x 25 kg 0.5/0.58 Hz": ("slosh", 1.0, 0.5),
    "slosh 2 x 25 kg 0.2/0.23 Hz": ("slosh", 1.0, 0.2),
    "slosh 2 x 25 kg 0.1/0.12 Hz": ("slosh", 1.0, 0.1),
}
QUICK = ("wings 2 x 50 kg 0.5 Hz (issue)", "slosh 2 x 25 kg 0.30/0.35 Hz (issue)")
SETUPS = ("rigid", "modal", "sensors", "sensors, no band", "sensors rigid", "sensors modal",
          "filter modal", "band modal")


def scenario(case: str, robot: str = "spatial"):
    """The scenario of a case on ``robot`` (a built-in name or a URDF file): the set's parts
    with the mass factor and the frequencies scaled (the first part's to the case's)."""
    from spacerobot.robots import parameter_set_scenario
    name, k_m, f = CASES[case]
    sc = parameter_set_scenario(robot, name)
    if name == "wings":
        f0 = sc.flex.panels[0].f
        panels = tuple(replace(p, m=p.m * k_m, Ixx=p.Ixx * k_m, Iyy=p.Iyy * k_m, Izz=p.Izz * k_m,
                               Ixy=p.Ixy * k_m, Ixz=p.Ixz * k_m, Iyz=p.Iyz * k_m,
                               f=p.f * f / f0) for p in sc.flex.panels)
        return replace(sc, flex=replace(sc.flex, panels=panels))
    f0 = sc.slosh.modes[0].f
    modes = tuple(replace(s, m=s.m * k_m, f=s.f * f / f0) for s in sc.slosh.modes)
    return replace(sc, slosh=replace(sc.slosh, modes=modes))


def record(sc):
    """The noise-free samples (flat, every DT) and the composite truth (20,)."""
    from oracles.samples import scenario_samples
    return scenario_samples(sc, T_END, DT)


def through_sensors(setup: str) -> bool:
    """The set-up's samples go through the sensors, with the noise profile."""
    return setup.startswith("sensors") or setup in ("filter modal", "band modal")


def identifier(sc, setup: str):
    """The estimator core as the FMU builds it, with the set-up's parameters."""
    from oracles.samples import fmu_identifier
    v = {"method": 1, "solver": 2, "ident.excite_adapt": 2,
         "ident.modes": 1 if setup.endswith("modal") else 2}
    if through_sensors(setup):
        v.update({"ident.noise_profile": 1, "noise.scale": 1.0})
        if setup in ("sensors rigid", "sensors modal"):
            v["ident.information"] = 2
        if setup in ("sensors, no band", "filter modal"):
            v["ident.band"] = 2
    return fmu_identifier(sc, DT, v)


def run_case(case: str, setups=SETUPS, robot: str = "spatial") -> list:
    from spacerobot.interface import relative_errors
    from spacerobot.sensors import SensorSuite
    sc = scenario(case, robot)
    xs, truth = record(sc)
    n = sc.robot.n_joints
    rows = []
    for setup in setups:
        suite = SensorSuite(n, scale=1.0, seed=0, dt=DT) if through_sensors(setup) else None
        sensed = None if suite is None else [suite.update(suite.sample(x), DT) for x in xs]
        t0 = time.thread_time()
        ident = identifier(sc, setup)
        since = None
        for k, x in enumerate(xs):
            if sensed is None:
                ident.update_flat(k * DT, x)
            else:
                ident.update(k * DT, sensed[k])
            rep = ident.core.report()
            both = rep["identified"]["base"] and rep["identified"]["target"]
            since = (since if since is not None else k * DT) if both else None
        rep = ident.core.report()
        est = np.asarray(ident.vector())
        sd = np.asarray(ident.std())
        err = relative_errors(est, truth)
        within = int(np.sum(np.abs(est - truth) <= 2.0 * sd))
        modes = ", ".join(f"{f:.3f}" for f in rep["mode_f"] if f > 0) or "-"
        rows.append((case, setup, 100.0 * float(err.max()), within,
                     "-" if since is None else f"{since:.0f}", modes,
                     time.thread_time() - t0))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the issue's sizes only")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--robot", default="spatial",
                    help="the spacecraft: a built-in robot name or a URDF file (default spatial)")
    ap.add_argument("--setups", nargs="+", choices=SETUPS, default=list(SETUPS),
                    help="the set-ups to run (default all)")
    args = ap.parse_args(argv)
    cases = QUICK if args.quick else tuple(CASES)
    setups = tuple(s for s in SETUPS if s in args.setups)      # in the table's order
    t0 = time.time()
    with ProcessPoolExecutor(max_workers=args.jobs) as ex:
        results = list(ex.map(partial(run_case, setups=setups, robot=args.robot), cases))
    print(f"Robot: {args.robot}\n")
    print("| case | set-up | worst error % | within 2 sd (of 20) | both flagged from [s] "
          "| modes at 300 s [Hz] | CPU [s] |")
    print("|---|---|---|---|---|---|---|")
    for rows in results:
        for case, setup, worst, within, since, modes, cpu in rows:
            print(f"| {case} | {setup} | {worst:.3g} | {within} | {since} | {modes} "
                  f"| {cpu:.1f} |")
    print(f"\n{len(cases)} cases in {time.time() - t0:.0f} s wall", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
