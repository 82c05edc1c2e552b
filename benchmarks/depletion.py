"""Tracking a base that uses propellant (issue #17): estimate against truth of the base mass,
CoM and inertia over a depletion run, for several forgetting factors; writes
benchmarks/DEPLETION.md, DEPLETION.csv and DEPLETION.png.

The run is the spatial parameter set ``depletion`` (:data:`spacerobot.robots.PARAMETER_SETS`:
the paper's spatial robot and target, 100 kg of propellant in a tank off the base centre,
thrusters at their bounds for the whole run, excitation on). The estimator of that set asks for
excitation always (``ident.excite_mode = 2``), so the plant's excitation level is 1 from the
start whatever the estimates are: the plant is simulated once (its core,
:class:`spacerobot.plant.Plant`, sampled every 0.1 s as the SSP does) and the same samples feed
one estimator core (:class:`spacerobot.estimator.Identifier`) per method and forgetting factor.
Noise-free: the sensors FMU (noisy runs) is not part of this tree yet.

Error of a parameter at time t: ``|estimate(t) - truth(t)| / scale`` with the project's error
scale (:func:`spacerobot.interface.error_scale`: mass relative to the mass, CoM relative to
max(|b_i|, 5 cm), inertia relative to the moment, products to the largest moment) and the
truth the plant's current base (``truth.base.*``). Tracking error = the worst over the time
after the base is first reported identified (``diag.identified.base``); CoM and inertia: the
worst component.

Usage: ``python benchmarks/depletion.py [--stop-time 300] [--out-dir benchmarks]``
"""
from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

import numpy as np

from spacerobot.estimator import Identifier
from spacerobot.interface import ESTIMATE_NAMES, LAYOUT, relative_errors
from spacerobot.plant import Plant
from spacerobot.robots import DEPLETION_ESTIMATOR, parameter_set_scenario

SAMPLE = 0.1
CSV_EVERY = 10          # samples per CSV row (1 s)
LAMBDAS = (1.0, 0.999, 0.995, 0.99, 0.98, 0.95)
METHODS = ("force", "momentum")
BASE = LAYOUT.base
GROUPS = {"mass": slice(BASE.m, BASE.m + 1), "CoM": BASE.first, "inertia": BASE.inertia}


def simulate(stop_time: float):
    """Samples ``[(t, outputs)]`` of the depletion set's plant with the excitation on."""
    sc = parameter_set_scenario("spatial", "depletion")
    p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
              sc.excitation, sc.propellant)
    p.set_excitation(1.0)
    rec = [(0.0, p.outputs())]
    for k in range(1, int(round(stop_time / SAMPLE)) + 1):
        p.advance(SAMPLE)
        rec.append((k * SAMPLE, p.outputs()))
    return sc, rec


def truth_vector(sc, out) -> np.ndarray:
    """(20,) truth now: the plant's current base and the (constant) target."""
    t = np.empty(len(ESTIMATE_NAMES))
    t[BASE.vec] = out["base_now"]
    t[LAYOUT.target.m] = sc.target.mass
    t[LAYOUT.target.first] = sc.target.com
    t[LAYOUT.target.inertia] = sc.target.inertia
    return t


def track(sc, rec, method: str, lam: float):
    """Estimates, truths, errors (N, 20) and the base's identified flag (N,) over the run."""
    ident = Identifier(sc.robot, sc.guess, method=method, lam=lam)
    est, tru, ok, sd = [], [], [], []
    for t, o in rec:
        ident.update(t, o)
        r = ident.report()
        est.append(r.vector)
        sd.append(r.std)
        tru.append(truth_vector(sc, o))
        ok.append(r.identified["base"])
    est, tru, sd = np.array(est), np.array(tru), np.array(sd)
    err = np.array([relative_errors(e, t) for e, t in zip(est, tru)])
    # the reported standard deviation covers the actual error (3 sigma), base parameters
    covered = np.all(np.abs(est - tru)[:, BASE.vec] <= 3.0 * sd[:, BASE.vec], axis=1)
    return est, tru, err, np.array(ok), covered


def summary(times, err, ok, covered) -> dict:
    """First identification time and the worst error per group after it (NaN if never); the
    share of the samples after it at which every base error is within 3 reported standard
    deviations, and the share at which the base is reported identified."""
    out = {"t_id": math.nan, "covered": math.nan, "identified": math.nan}
    idx = np.flatnonzero(ok)
    for g, sl in GROUPS.items():
        out[g] = math.nan
    if idx.size:
        k = idx[0]
        out["t_id"] = float(times[k])
        for g, sl in GROUPS.items():
            out[g] = float(err[k:, sl].max())
        out["covered"] = float(covered[k:].mean())
        out["identified"] = float(ok[k:].mean())
    out["final_mass"] = float(err[-1, BASE.m])
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


def plot(path: Path, times, runs: dict, chosen) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [n for n in ESTIMATE_NAMES if n.startswith("base.")]
    fig, axes = plt.subplots(2, 5, figsize=(17, 6.5), sharex=True)
    tru0 = runs[chosen][1]
    for j, (ax, n) in enumerate(zip(axes.flat, names)):
        k = BASE.vec.start + j
        ax.plot(times, tru0[:, k], "k-", lw=2.0, label="truth (plant)")
        for key, style in ((chosen, "C0--"), (("force", 1.0), "C3:")):
            if key in runs:
                ax.plot(times, runs[key][0][:, k], style, lw=1.3,
                        label=f"{key[0]}, lambda = {key[1]:g}")
        lo, hi = tru0[:, k].min(), tru0[:, k].max()
        pad = max(hi - lo, 1e-3 * max(abs(hi), 0.05)) * 1.5
        ax.set_ylim(lo - pad, hi + pad)
        ax.set_title(n)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("time [s]")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Spatial parameter set 'depletion': base estimate against the current truth "
                 "(noise-free)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def report(sc, rec, table, chosen, wall) -> str:
    o0, o1 = rec[0][1], rec[-1][1]
    pr = sc.propellant
    lines = [
        "# Tracking a base that uses propellant (issue #17)",
        "",
        "Generated by `python benchmarks/depletion.py` (do not edit by hand). Noise-free: the "
        "sensors FMU of the noise issue is not in this tree yet, so the runs with realistic "
        "sensor noise are still to be made.",
        "",
        f"Run: spatial parameter set `depletion`, {rec[-1][0]:g} s sampled every {SAMPLE:g} s, "
        f"excitation level 1 throughout (estimator `ident.excite_mode = 2`). Propellant "
        f"{pr.m0:g} kg, Isp {pr.Isp:g} s, tank at {list(pr.r)} m (base frame), radius "
        f"{pr.R:g} m, couple arm {pr.arm:g} m. Propellant used: "
        f"{o0['m_p'][0] - o1['m_p'][0]:.2f} kg; base mass {o0['base_now'][0]:.2f} -> "
        f"{o1['base_now'][0]:.2f} kg, CoM {np.round(o0['base_now'][1:4], 4).tolist()} -> "
        f"{np.round(o1['base_now'][1:4], 4).tolist()} m, Ixx {o0['base_now'][4]:.2f} -> "
        f"{o1['base_now'][4]:.2f} kg.m2. Wall time {wall:.0f} s.",
        "",
        "Tracking error of the base = the worst over time, after the base is first reported "
        "identified, of |estimate - current truth| / error scale (mass: the mass; CoM: "
        "max(|b_i|, 5 cm); inertia: the moment, products: the largest moment); CoM and inertia: "
        "the worst component. `t_id`: first time `diag.identified.base` = 1. After `t_id`: "
        "`identified` = share of the samples at which the base is still reported identified, "
        "`within 3 sd` = share at which every base error is within three reported standard "
        "deviations (`sd.base.*`).",
        "",
        "| method | lambda | t_id [s] | mass [%] | CoM [%] | inertia [%] | mass at the end [%] "
        "| identified | within 3 sd |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for (method, lam), s in table.items():
        pct = lambda x: "never identified" if math.isnan(x) else f"{100 * x:.3f}"  # noqa: E731
        share = lambda x: "-" if math.isnan(x) else f"{100 * x:.0f} %"  # noqa: E731
        lines.append(f"| {method} | {lam:g} | "
                     f"{'-' if math.isnan(s['t_id']) else format(s['t_id'], '.1f')} | "
                     f"{pct(s['mass'])} | {pct(s['CoM'])} | {pct(s['inertia'])} | "
                     f"{100 * s['final_mass']:.3f} | {share(s['identified'])} | "
                     f"{share(s['covered'])} |")
    s = table[chosen]
    never = [k for k, v in table.items() if math.isnan(v["t_id"])]
    if never and all(m == "momentum" for m, _ in never):
        lines += ["", "The momentum-based equations refer every sample to the first one and assume "
                  "constant parameters (docs/models.md, \"Propellant\"): with a base that changes "
                  "they never settle, and the base is never reported identified. The force-based "
                  "equations hold at every instant with the current base; forgetting bounds the "
                  "lag behind it."]
    cov = [v["covered"] for v in table.values() if not math.isnan(v["covered"])]
    if cov and max(cov) < 0.5:
        lines += ["", "The reported standard deviations do not include the lag behind a moving "
                  "truth: after the first identification the base errors are within three "
                  f"reported standard deviations at {100 * max(cov):.0f} % of the samples at "
                  "best, and `diag.identified.base` stays 1 even where the error exceeds 0.1 %."]
    lines += [
        "",
        f"Chosen for the `depletion` set: method {chosen[0]}, lambda = {chosen[1]:g} "
        f"(`robots.DEPLETION_ESTIMATOR`): base mass within {100 * s['mass']:.3f} % of the "
        f"current truth after the first identification (issue #17 asks for 0.1 %).",
        "",
        "`DEPLETION.csv`: propellant mass, the base's current truth and the chosen estimator's "
        f"base estimates every {CSV_EVERY * SAMPLE:g} s. `DEPLETION.png`: estimate and truth "
        "of the ten base "
        "parameters against time, the chosen lambda beside lambda = 1 (no forgetting).",
        "",
        "![estimate and truth of the base against time](DEPLETION.png)",
        "",
    ]
    return "\n".join(lines)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stop-time", type=float, default=None,
                    help="length of the run [s] (default: the set's stop time)")
    ap.add_argument("--out-dir", default=str(Path(__file__).resolve().parent))
    args = ap.parse_args(argv)
    t0 = time.time()
    sc0 = parameter_set_scenario("spatial", "depletion")
    sc, rec = simulate(args.stop_time or sc0.stop_time)
    times = np.array([t for t, _ in rec])
    chosen = ("force", float(dict(DEPLETION_ESTIMATOR)["lambda"]))
    runs, table = {}, {}
    for method in METHODS:
        for lam in LAMBDAS:
            est, tru, err, ok, cov = track(sc, rec, method, lam)
            runs[(method, lam)] = (est, tru)
            table[(method, lam)] = summary(times, err, ok, cov)
            print(method, lam, table[(method, lam)], flush=True)
    if chosen not in runs:
        est, tru, err, ok, cov = track(sc, rec, *chosen)
        runs[chosen] = (est, tru)
        table[chosen] = summary(times, err, ok, cov)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    m_p = np.array([o["m_p"][0] for _, o in rec])
    write_csv(out / "DEPLETION.csv", times, runs[chosen][0], runs[chosen][1], m_p)
    plot(out / "DEPLETION.png", times, runs, chosen)
    (out / "DEPLETION.md").write_text(report(sc, rec, table, chosen, time.time() - t0))
    print(f"wrote {out / 'DEPLETION.md'}, DEPLETION.csv, DEPLETION.png")


if __name__ == "__main__":
    main()
