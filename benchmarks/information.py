"""The information limit under realistic sensors, and an estimator that approaches it (issue
#29, the research that led to the shipped information filter, native/src/information.c; its
NumPy prototype, with the rows' weight held over 10 samples as first measured, is the tests'
reference, tests/oracles/information.py); writes benchmarks/INFORMATION.md.

The measurement model, the bound and the filter: the docstring of
tests/oracles/information.py (and docs/identification.md, "The information filter and the
bound"). This study runs that prototype beside the native estimator's own equations (the
weights linearised at their estimate, errors in variables to first order, no replay: the
shipped filter's later improvements are not in INFORMATION.md's figures).

Usage: ``python benchmarks/information.py [--seeds 4] [--cases 4] [--stop-time 60]
[--random-stop-time 300] [--out benchmarks/INFORMATION.md]``
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

# the filter of this study is the tests' reference formulation of the shipped one
# (native/src/information.c, ident.information): one copy, tests/oracles/information.py
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from oracles.information import InformationFilter, z_of_reported  # noqa: E402
from oracles.samples import flat  # noqa: E402


# ----------------------------------------------------------------------------------------------
# the benchmark
# ----------------------------------------------------------------------------------------------

def _case(args):
    """One run: (label, truth, preset estimate, preset sd, filter estimate, bound sd)."""
    import math
    from spacerobot.core import load_library
    from spacerobot.core.estimator import NativeEstimator, options_from_values
    from spacerobot.core.robot_record import c_robot
    from spacerobot.interface import estimator_parameter_values
    from spacerobot.plant import Plant
    from spacerobot.robots import random_scenario, scenario
    from spacerobot.sensors import SensorSuite, default_parameters
    label, index, sensors_seed, stop_time = args
    sc = (scenario("spatial", "default") if index is None
          else random_scenario("spatial", np.random.default_rng([2026, index])))
    L = load_library()
    d = default_parameters()
    rt = math.sqrt(DT)
    sd = {"r": d["nav.r"], "v": d["nav.v"], "omega": d["gyro.arw"] / rt, "qd": d["enc.qd"],
          "q": math.sqrt(d["enc.q"] ** 2 + d["enc.resolution"] ** 2 / 12),
          "att": [d["star.cross"], d["star.cross"], d["star.roll"]]}
    sd_c = [d["thrust.scale"], *[d["thrust.misalign"]] * 3] * 2
    g = sc.guess
    guess = [g.base.mass, *g.base.com, *g.base.inertia, g.target.mass, *g.target.com,
             *g.target.inertia]
    filt = InformationFilter(L, c_robot(sc.robot), sc.robot.n_joints, sc.robot.planar, sd, sd_c,
                             g.P0_mu, g.P0_theta, z_of_reported(guess),
                             sd_gyro_bias=d["gyro.bias"])
    filt.eiv = True
    vals = estimator_parameter_values(sc.robot, sc)
    # the preset: the profile's own equations (the shipped filter off: this study compares them)
    vals.update({"ident.noise_profile": 1, "method": 2, "accel_source": 2,
                 "ident.information": 2})
    opts = options_from_values(vals)
    opts["noise_dt"] = DT
    est = NativeEstimator(sc.robot, opts)
    plant = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
                  excitation=sc.excitation)
    plant.set_excitation(1.0)
    sensors = SensorSuite(sc.robot.n_joints, seed=sensors_seed, dt=DT)
    for k in range(int(round(stop_time / DT)) + 1):
        x = flat(sensors.update(plant.outputs(), DT))
        est.update(k * DT, x)
        rep = est.report()
        filt.add(k * DT, x, z_of_reported(rep["vector"]))
        plant.advance(DT)
    filt.solve()
    _, bound = filt.estimate()
    filt.u = filt.compensated()
    x_filter, _ = filt.estimate()
    truth = np.array([sc.robot.base.mass, *sc.robot.base.com, *sc.robot.base.inertia,
                      sc.target.mass, *sc.target.com, *sc.target.inertia])
    return label, truth, rep["vector"], rep["sd"], x_filter, bound


#: the sample interval [s]
DT = 0.1


def main(argv=None) -> int:
    import argparse
    import datetime as _dt
    import os
    import platform
    import sys
    import time
    from multiprocessing import Pool
    from pathlib import Path

    here = Path(__file__).resolve().parent
    sys.path.insert(0, str(here.parent))
    from spacerobot import __version__
    from spacerobot.interface import ESTIMATE_NAMES, error_scale

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=4, help="sensor seeds on the default scenario")
    ap.add_argument("--cases", type=int, default=4, help="random spatial cases (seed 2026)")
    ap.add_argument("--stop-time", type=float, default=60.0, help="default scenario [s]")
    ap.add_argument("--random-stop-time", type=float, default=300.0, help="random cases [s]")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(here / "INFORMATION.md"))
    a = ap.parse_args(argv)
    jobs = ([(f"default, sensors seed {s}", None, s, a.stop_time) for s in range(1, a.seeds + 1)]
            + [(f"random case {i}", i, i, a.random_stop_time) for i in range(a.cases)])
    t0 = time.time()
    with Pool(a.workers) as pool:
        rows = pool.map(_case, jobs)
    wall = time.time() - t0
    names = ESTIMATE_NAMES
    lines = ["| run | preset: worst error | within 2 sd | filter: worst error | largest bound | "
             "filter error / bound, RMS |", "|---|---|---|---|---|---|"]
    z_pre, z_fil, b_rel = [], [], []
    for label, truth, xp, sp, xf, bd in rows:
        s = error_scale(truth)
        e_p, e_f = np.abs(xp - truth) / s, np.abs(xf - truth) / s
        zf = (xf - truth) / bd
        z_pre.append((xp - truth) / bd)
        z_fil.append(zf)
        b_rel.append(bd / s)
        lines.append(f"| {label} | {100 * e_p.max():.3g} % ({names[e_p.argmax()]}) | "
                     f"{np.mean(np.abs(xp - truth) <= 2 * sp):.2f} | {100 * e_f.max():.3g} % "
                     f"({names[e_f.argmax()]}) | {100 * (bd / s).max():.3g} % | "
                     f"{np.sqrt(np.mean(zf ** 2)):.2f} |")
    z_pre, z_fil, b_rel = map(np.array, (z_pre, z_fil, b_rel))
    per = ["| parameter | bound (median over runs, of its scale) | filter: RMS error / bound | "
           "efficiency (bound / RMS error) | preset: RMS error / bound |", "|---|---|---|---|---|"]
    for i, n in enumerate(names):
        rf, rp = np.sqrt(np.mean(z_fil[:, i] ** 2)), np.sqrt(np.mean(z_pre[:, i] ** 2))
        per.append(f"| {n} | {100 * np.median(b_rel[:, i]):.2g} % | {rf:.2f} | {1 / rf:.2f} | "
                   f"{rp:.3g} |")
    text = "\n".join([
        "# The information limit under realistic sensors (issue #29, research)", "",
        "(The research before the shipped information filter: its figures are those of the "
        "prototype,\nwithout the replay and the exact compensation; the shipped filter's are in\n"
        "[docs/identification.md](../docs/identification.md#the-information-filter-and-the-bound).)",
        "",
        f"Generated by `python benchmarks/information.py --seeds {a.seeds} --cases {a.cases} "
        f"--stop-time {a.stop_time:g} --random-stop-time {a.random_stop_time:g}` on "
        f"{_dt.date.today()} (spacerobot {__version__}, {platform.machine()}, "
        f"{os.cpu_count()} cores); {len(rows)} runs in {wall / 60:.1f} min. What it computes: "
        "the module docstring of [information.py](information.py).", "",
        "Open loop (the plant's excitation at level 1, as the estimator requests it under noise), "
        "the sensors FMU's models with their realistic defaults. The preset: the native "
        "estimator with `ident.noise_profile` = 1, force method, differenced accelerations (the "
        "realistic set's), its own equations (`ident.information` = 2). The filter: the "
        "prototype of the square-root information filter of the momentum "
        "equations with the system's momentum, the thrust errors and the gyro bias as unknowns. "
        "Errors: `error/scale`; the bound: the first-order Cramér-Rao bound of the filter's "
        "model, at the end of each run.", "",
        "\n".join(lines), "", "\n".join(per), ""])
    Path(a.out).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
