"""Tracking a base that uses propellant (issue #17): estimate against truth of the base mass,
CoM and inertia over a depletion run, for several forgetting factors, noise-free and with
realistic sensor noise; writes benchmarks/DEPLETION.md, DEPLETION.csv, DEPLETION.png and
DEPLETION_NOISY.png.

The run is the spatial parameter set ``depletion`` (:data:`spacerobot.robots.PARAMETER_SETS`:
the paper's spatial robot and target, 80 kg of propellant in a tank off the base centre,
thrusters at their bounds for the whole run, excitation on). The estimator of that set asks for
excitation always (``ident.excite_mode = 2``), so the plant's excitation level is 1 from the
start whatever the estimates are, and one run of the plant serves every estimator:

* noise-free: the plant's core (:class:`spacerobot.plant.Plant`, sampled every 0.1 s as the
  SSP does);
* noisy: one run of the sensors SSP (``spacerobot build --sensors``: plant -> sensors ->
  estimator), parameter set ``depletion`` with the sensors' realistic defaults
  (``sensors.noise.scale`` = 1, the ``realistic`` set's level), recorded and replayed
  (``spacerobot identify``'s telemetry reader).

The same samples feed one estimator core (:class:`spacerobot.estimator.Identifier`) per
method, forgetting factor and noise model. Noisy runs use the estimator's noise model
(docs/identification.md, "Under noise"): the force method's row standard deviations of the
noise benchmark (:data:`ROW_SD_FORCE`) and ``ident.corr_lags`` = :data:`NOISY_LAGS`.
The momentum method runs as the paper's (differences against the first sample, which assume a
constant base) and with a reference window of :data:`WINDOW` s about the base
(``ident.momentum_window``, ``ident.momentum_point`` = 1), whose equations hold with the
current base up to its change over the window.

Error of a parameter at time t: ``|estimate(t) - truth(t)| / scale`` with the project's error
scale (:func:`spacerobot.interface.error_scale`: mass relative to the mass, CoM relative to
max(|b_i|, 5 cm), inertia relative to the moment, products to the largest moment) and the
truth the plant's current base (``truth.base.*``). Tracking error = the worst over the window
after the base is first reported identified (``diag.identified.base``; noisy runs, where the
base is never identified, after :data:`T_WARM`); CoM and inertia: the worst component.
Calibration over the same window: the share of the samples at which every base error is within
2 (3) reported standard deviations, and the mean over the ten base parameters of each one's
share within 2 sd.

Usage: ``python benchmarks/depletion.py [--stop-time 300] [--out-dir benchmarks]
[--build-dir build/spatial] [--no-noisy]``
"""
from __future__ import annotations

import argparse
import csv
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
if str(HERE.parent) not in sys.path:
    sys.path.insert(0, str(HERE.parent))

from spacerobot.estimator import Identifier  # noqa: E402
from spacerobot.interface import ESTIMATE_NAMES, LAYOUT, relative_errors  # noqa: E402
from spacerobot.plant import Plant  # noqa: E402
from spacerobot.robots import (DEPLETION_ESTIMATOR, PARAMETER_SETS, get_robot,  # noqa: E402
                               parameter_set_scenario)

SAMPLE = 0.1
CSV_EVERY = 10          # samples per CSV row (1 s)
LAMBDAS = (1.0, 0.999, 0.995, 0.99, 0.98, 0.95)
NOISY_LAMBDAS = (1.0, 0.995, 0.99, 0.98, 0.95)
METHODS = ("force", "momentum")
#: correlation lags of the noise-free runs (0: the set's estimator; the other: with the
#: residual-correlation correction of the scatter term, docs/identification.md section 6)
FREE_LAGS = (0, 50)
#: force method, measured accelerations: row standard deviations [N, N.m] of the equation
#: errors under the realistic sensors (benchmarks/NOISE.md's pilot run)
ROW_SD_FORCE = (4.19, 3.11)
#: momentum method (windowed): unit row weights; under the paper solver's weak prior the weights
#: hardly move the estimates (docs/identification.md, "Under noise")
ROW_SD_MOMENTUM = (0.0, 0.0)
#: correlation lags of the noisy runs
NOISY_LAGS = 200
#: momentum method: reference window [s] (``ident.momentum_window``; angular rows about the
#: base, ``ident.momentum_point`` = 1), so that its equations hold with the current base
WINDOW = 5.0
#: start of the evaluation window of runs whose base is never identified [s]
T_WARM = 30.0
#: sensors seed of the noisy run
SEED = 0
BASE = LAYOUT.base
GROUPS = {"mass": slice(BASE.m, BASE.m + 1), "CoM": BASE.first, "inertia": BASE.inertia}
SD_REL = 1e-3           # the estimator's default ident.sd_rel


def simulate(stop_time: float):
    """Noise-free: ``(scenario, times (N,), samples [dict], truths (N, 20), m_p (N,))`` of the
    depletion set's plant core with the excitation on."""
    sc = parameter_set_scenario("spatial", "depletion")
    p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
              sc.excitation, sc.propellant)
    p.set_excitation(1.0)
    rec = [(0.0, p.outputs())]
    for k in range(1, int(round(stop_time / SAMPLE)) + 1):
        p.advance(SAMPLE)
        rec.append((k * SAMPLE, p.outputs()))
    times = np.array([t for t, _ in rec])
    truth = np.array([truth_vector(sc, o["base_now"]) for _, o in rec])
    m_p = np.array([o["m_p"][0] for _, o in rec])
    return sc, times, [o for _, o in rec], truth, m_p


def simulate_noisy(stop_time: float, build_dir: Path):
    """Noisy: the same, from one run of the sensors SSP (set ``depletion``, realistic sensors,
    seed :data:`SEED`) recorded and read back as telemetry."""
    from spacerobot.system.identify import read_telemetry
    from spacerobot.system.recorder import read_csv
    from spacerobot.system.runner import run_ssp
    from spacerobot.system.ssd import ensure_ssp

    sc = parameter_set_scenario("spatial", "depletion")
    ssp = ensure_ssp("spatial", build_dir, sensors=True)
    level = PARAMETER_SETS["spatial"]["realistic"].noise
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "depletion_noisy.csv"
        run_ssp(ssp, parameter_set="depletion", stop_time=stop_time, csv_path=path,
                overrides={"sensors.noise.scale": level, "sensors.seed": SEED,
                           "estimator.method": 2}, progress=False)
        times, groups = read_telemetry(path, get_robot("spatial").n_joints)
        data = read_csv(path)
    samples = [{g: a[k] for g, a in groups.items()} for k in range(len(times))]
    base = np.column_stack([data[f"plant.truth.{n}"] for n in ESTIMATE_NAMES[BASE.vec]])
    truth = np.array([truth_vector(sc, b) for b in base])
    return sc, times, samples, truth, data["plant.prop.m"]


def truth_vector(sc, base_now) -> np.ndarray:
    """(20,) truth now: the plant's current base and the (constant) target."""
    t = np.empty(len(ESTIMATE_NAMES))
    t[BASE.vec] = base_now
    t[LAYOUT.target.m] = sc.target.mass
    t[LAYOUT.target.first] = sc.target.com
    t[LAYOUT.target.inertia] = sc.target.inertia
    return t


def track(sc, samples, times, truth, method: str, lam: float, lags: int = 0,
          window: float = 0.0, row_sd=(0.0, 0.0)):
    """Estimates, reported standard deviations (N, 20) and the base's identified flag (N,)."""
    ident = Identifier(sc.robot, sc.guess, method=method, lam=lam, corr_lags=lags,
                       row_sd=row_sd, window=window, moving_point=window > 0.0)
    est, sd, ok = [], [], []
    for t, o in zip(times.tolist(), samples):
        ident.update(t, o)
        r = ident.report()
        est.append(r.vector)
        sd.append(r.std)
        ok.append(r.identified["base"])
    return np.array(est), np.array(sd), np.array(ok)


def summary(times, est, sd, truth, ok) -> dict:
    """Worst errors, flags and calibration over the window after the first identification
    (after :data:`T_WARM` if the base is never identified: ``t_id`` NaN)."""
    err = np.array([relative_errors(e, t) for e, t in zip(est, truth)])
    idx = np.flatnonzero(ok)
    out = {"t_id": float(times[idx[0]]) if idx.size else math.nan}
    k = int(idx[0]) if idx.size else int(np.searchsorted(times, min(T_WARM, times[-1] / 2)))
    for g, sl in GROUPS.items():
        out[g] = float(err[k:, sl].max())
    out["final_mass"] = float(err[-1, BASE.m])
    dev = np.abs(est - truth)[k:, BASE.vec]
    s = sd[k:, BASE.vec]
    out["within2"] = float(np.all(dev <= 2.0 * s, axis=1).mean())
    out["within3"] = float(np.all(dev <= 3.0 * s, axis=1).mean())
    out["param2"] = float((dev <= 2.0 * s).mean())
    out["identified"] = float(ok[k:].mean())
    bad = err[k:, BASE.vec].max(axis=1) > SD_REL
    out["false_id"] = float((bad & ok[k:]).sum() / max(bad.sum(), 1))   # flagged though > 0.1 %
    out["missed_id"] = float((~bad & ~ok[k:]).sum() / max((~bad).sum(), 1))
    return out


def write_csv(path: Path, times, est, tru, m_p) -> None:
    names = [n for n in ESTIMATE_NAMES if n.startswith("base.")]
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["time", "prop.m"] + [f"truth.{n}" for n in names] + names)
        for k in range(0, len(times), CSV_EVERY):
            w.writerow([f"{times[k]:.1f}", f"{m_p[k]:.12g}"]
                       + [f"{x:.12g}" for x in tru[k, BASE.vec]]
                       + [f"{x:.12g}" for x in est[k, BASE.vec]])


def plot(path: Path, times, truth, runs: dict, keys, title: str) -> None:
    """Estimate and truth of the ten base parameters; the first of ``keys`` with its 2 sd
    band."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [n for n in ESTIMATE_NAMES if n.startswith("base.")]
    fig, axes = plt.subplots(2, 5, figsize=(17, 6.5), sharex=True)
    for j, (ax, n) in enumerate(zip(axes.flat, names)):
        k = BASE.vec.start + j
        ax.plot(times, truth[:, k], "k-", lw=2.0, label="truth (plant)")
        for i, (key, style) in enumerate(zip(keys, ("C0-", "C3:"))):
            est, sd = runs[key][0][:, k], runs[key][1][:, k]
            ax.plot(times, est, style, lw=1.1, label=f"{key[0]}, lambda = {key[1]:g}"
                    + (f", lags {key[2]}" if key[2] else "")
                    + (f", window {key[3]:g} s" if key[3] else ""))
            if i == 0:
                ax.fill_between(times, est - 2 * sd, est + 2 * sd, color="C0", alpha=0.2,
                                lw=0, label="+- 2 reported sd")
        lo, hi = truth[:, k].min(), truth[:, k].max()
        pad = max(hi - lo, 1e-3 * max(abs(hi), 0.05)) * 1.5
        ax.set_ylim(lo - pad, hi + pad)
        ax.set_title(n)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("time [s]")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _table(table: dict, window: str) -> list:
    pct = lambda x: f"{100 * x:.3f}"  # noqa: E731
    share = lambda x: f"{100 * x:.0f} %"  # noqa: E731
    lines = [f"| method | window [s] | lambda | lags | t_id [s] | mass [%] | CoM [%] | inertia [%] | "
             f"mass at the end [%] | identified | flag up though > 0.1 % | all within 2 sd | "
             f"all within 3 sd | per parameter within 2 sd |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for (method, lam, lags, window), s in table.items():
        lines.append(f"| {method} | {window:g} | {lam:g} | {lags} | "
                     f"{'-' if math.isnan(s['t_id']) else format(s['t_id'], '.1f')} | "
                     f"{pct(s['mass'])} | {pct(s['CoM'])} | {pct(s['inertia'])} | "
                     f"{pct(s['final_mass'])} | {share(s['identified'])} | "
                     f"{share(s['false_id'])} | {share(s['within2'])} | {share(s['within3'])} | "
                     f"{share(s['param2'])} |")
    return lines


def report(sc, free, noisy, chosen, wall) -> str:
    times, m_p, truth = free["times"], free["m_p"], free["truth"]
    pr = sc.propellant
    b0, b1 = truth[0, BASE.vec], truth[-1, BASE.vec]
    lines = [
        "# Tracking a base that uses propellant (issue #17)",
        "",
        "Generated by `python benchmarks/depletion.py` (do not edit by hand).",
        "",
        f"Run: spatial parameter set `depletion`, {times[-1]:g} s sampled every {SAMPLE:g} s, "
        f"excitation level 1 throughout (estimator `ident.excite_mode = 2`). Propellant "
        f"{pr.m0:g} kg, Isp {pr.Isp:g} s, tank at {list(pr.r)} m (base frame), radius "
        f"{pr.R:g} m, couple arm {pr.arm:g} m. Propellant used: {m_p[0] - m_p[-1]:.2f} kg; "
        f"base mass {b0[0]:.2f} -> {b1[0]:.2f} kg, CoM {np.round(b0[1:4], 4).tolist()} -> "
        f"{np.round(b1[1:4], 4).tolist()} m, Ixx {b0[4]:.2f} -> {b1[4]:.2f} kg.m2. "
        f"Wall time {wall:.0f} s.",
        "",
        "Tracking error of the base = the worst over the window, of |estimate - current truth| "
        "/ error scale (mass: the mass; CoM: max(|b_i|, 5 cm); inertia: the moment, products: "
        "the largest moment); CoM and inertia: the worst component. Window: from `t_id`, the "
        "first time `diag.identified.base` = 1 (where the base is never identified, from "
        f"{T_WARM:g} s). Over the window: `identified` = share of the samples at which the "
        "base is reported identified; `flag up though > 0.1 %` = share of the samples with a "
        "base error above 0.1 % at which it is (0 % is honest); `all within k sd` = share "
        "of the samples at which every base error is within k reported standard deviations "
        "(`sd.base.*`); `per parameter` = the same for each base parameter, averaged over the "
        "ten. `lags` = `ident.corr_lags`. The standard deviations include the lag term of "
        "docs/identification.md, \"Tracking\".",
        "",
        "## Noise-free",
        "",
    ]
    lines += _table(free["table"], "t_id")
    if noisy is not None:
        lines += [
            "",
            "## Realistic sensor noise",
            "",
            f"One run of the sensors SSP (`spatial_sensors.ssp`, set `depletion`, "
            f"`sensors.noise.scale` = {PARAMETER_SETS['spatial']['realistic'].noise:g} as the "
            f"`realistic` set, `sensors.seed` = {SEED}), replayed through the estimator core "
            f"with its noise model: force method, measured accelerations, row standard "
            f"deviations {ROW_SD_FORCE[0]:g} N / {ROW_SD_FORCE[1]:g} N.m (the noise "
            f"benchmark's pilot run), `ident.corr_lags` = {NOISY_LAGS}; the momentum method "
            f"with a {WINDOW:g} s reference window about the base, unit row weights.",
            "",
        ]
        lines += _table(noisy["table"], "30 s")
    s = free["table"][chosen]
    lines += [
        "",
        f"Chosen for the `depletion` set: method {chosen[0]}, lambda = {chosen[1]:g}, "
        f"`ident.corr_lags` = {chosen[2]} (`robots.DEPLETION_ESTIMATOR`, bound to the "
        f"estimator in the SSP): noise-free, base mass within {100 * s['mass']:.3f} % of the "
        f"current truth after the first identification (issue #17 asks for 0.1 %); each base "
        f"parameter within 2 reported sd at {100 * s['param2']:.0f} % of the samples, the flag "
        f"up at {100 * s['false_id']:.0f} % of the samples where the base is off by more "
        f"than 0.1 %. Under the realistic sensors the noise error dominates the drift: "
        f"docs/identification.md, section 7.",
        "",
        "`DEPLETION.csv`: propellant mass, the base's current truth and the chosen estimator's "
        f"base estimates every {CSV_EVERY * SAMPLE:g} s (noise-free). `DEPLETION.png`: "
        "estimate (with its 2 sd band) and truth of the ten base parameters against time, "
        "noise-free, the chosen lambda beside lambda = 1 (no forgetting). "
        "`DEPLETION_NOISY.png`: with the realistic sensors, the momentum method with a "
        f"{WINDOW:g} s window (with its 2 sd band) beside the force method, both without "
        "forgetting (under this noise forgetting only adds error).",
        "",
        "![estimate and truth of the base against time](DEPLETION.png)",
        "",
    ]
    if noisy is not None:
        lines += ["![the same under realistic sensor noise](DEPLETION_NOISY.png)", ""]
    return "\n".join(lines)


def sweep(sc, times, samples, truth, combos, row_sds=None):
    runs, table = {}, {}
    for key in combos:
        method, lam, lags, window = key
        row_sd = (row_sds or {}).get(method, (0.0, 0.0))
        est, sd, ok = track(sc, samples, times, truth, method, lam, lags, window, row_sd)
        runs[key] = (est, sd)
        table[key] = summary(times, est, sd, truth, ok)
        print(key, {k: round(v, 5) for k, v in table[key].items()}, flush=True)
    return runs, table


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stop-time", type=float, default=None,
                    help="length of the run [s] (default: the set's stop time)")
    ap.add_argument("--out-dir", default=str(HERE))
    ap.add_argument("--build-dir", default=str(HERE.parent / "build" / "spatial"),
                    help="where the sensors SSP is built (reused when up to date)")
    ap.add_argument("--no-noisy", action="store_true", help="noise-free runs only")
    args = ap.parse_args(argv)
    t0 = time.time()
    sc0 = parameter_set_scenario("spatial", "depletion")
    stop = args.stop_time or sc0.stop_time
    est = dict(DEPLETION_ESTIMATOR)
    chosen = ("force", float(est["lambda"]), int(est["ident.corr_lags"]), 0.0)
    sc, times, samples, truth, m_p = simulate(stop)
    combos = [("force", lam, lags, 0.0) for lags in FREE_LAGS for lam in LAMBDAS]
    combos += [("momentum", lam, 0, w) for w in (0.0, WINDOW) for lam in LAMBDAS]
    runs, table = sweep(sc, times, samples, truth, combos)
    free = {"times": times, "m_p": m_p, "truth": truth, "table": table}
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "DEPLETION.csv", times, runs[chosen][0], truth, m_p)
    plot(out / "DEPLETION.png", times, truth, runs, [chosen, ("force", 1.0, 0, 0.0)],
         "Spatial parameter set 'depletion': base estimate against the current truth "
         "(noise-free)")
    noisy = None
    if not args.no_noisy:
        scn, tn, sn, trn, mpn = simulate_noisy(stop, Path(args.build_dir))
        combos = [("force", lam, NOISY_LAGS, 0.0) for lam in NOISY_LAMBDAS]
        combos += [("momentum", lam, NOISY_LAGS, WINDOW) for lam in NOISY_LAMBDAS]
        nruns, ntable = sweep(scn, tn, sn, trn, combos,
                              {"force": ROW_SD_FORCE, "momentum": ROW_SD_MOMENTUM})
        noisy = {"table": ntable}
        plot(out / "DEPLETION_NOISY.png", tn, trn, nruns,
             [("momentum", 1.0, NOISY_LAGS, WINDOW), ("force", 1.0, NOISY_LAGS, 0.0)],
             "Spatial parameter set 'depletion': base estimate against the current truth "
             "(realistic sensors)")
    (out / "DEPLETION.md").write_text(report(sc, free, noisy, chosen, time.time() - t0))
    print(f"wrote {out / 'DEPLETION.md'}")


if __name__ == "__main__":
    main()
