"""Modes at 0.2-0.3 Hz through the sensors: the rigid band with the found mode's columns (the
batch study the found modes' band, native/src/est_band.c, was shipped from; its reference);
writes benchmarks/LOW_BAND.md.

Why. Where a part's mode lies at 0.2-0.3 Hz the compliance band (benchmarks/band.py) hands back:
its low-pass at 0.15 Hz damps such a mode too little, and the mode's response is no longer
quasi-static, so its compliance block (two fast filters' G and C columns) leaves a misfit
(chi2 12-109 times the low-passed noise's at 0.3 Hz, 530-2900 at 0.2 Hz: native/src/band.h). The modal columns beside the profile
(ident.modes = 1, benchmarks/low_modes.py) report there instead, and ride on the joint
solver's noise floor: 1.95-12.4 % off, 6 of 32 runs within 3 %. This study asks whether the
band's rows (the information filter's, weighted by the sensors' noise) with the mode's own
columns, all four blocks of docs/identification.md section 8 (G, C, D, T: 165 unknowns per
frequency) at the part's frequency and damping, do better: the low-pass then has only to damp
what the columns' first order leaves of the mode (its second-order kinematics), not the mode.

What it computes, per robot (the spatial robot; the held-out servicer tests/data/arm5.urdf),
case (benchmarks/flexible.py's: the wings at 0.3 and 0.2 Hz, the slosh at 0.2 / 0.23 Hz) and
sensors seed: the plant's samples every 0.1 s for 300 s through the realistic sensors; the
information filter of the tests' reference (tests/oracles/information.py) linearised at the
truth, every row weighted by its own noise covariance, compensated for the errors in
variables; the columns of the tests' modal reference (tests/oracles/modal.py) driven by the
measured base motion; one causal Butterworth low-pass of order 6 (from rest at the first
sample, the first 3 / fc s left out, as the shipped bands); one batch least squares over the
prior and the rows, the thrust errors estimated (benchmarks/rigid_band.py's `solve`). Variants:

* `band`: the compliance band's model, the low-pass at 0.15 Hz and the compliance block (the 2
  and 1 Hz filters' G and C columns, 114 unknowns), always (the shipped band keeps the
  compliance only where it halves the low-pass's chi2: on the servicer's slosh it does not);
* `band + mode`: the low-pass at 0.15 Hz and the columns of each of the case's parts'
  cantilevered frequency and damping (the modal search found these frequencies to within
  0.5 % in LOW_MODES.md);
* `band + mode, fc 0.10 Hz`: the same with the low-pass at 0.10 Hz (further below the mode,
  closer to the excitation's 0.033-0.1 Hz);
* `band + mode off`: as `band + mode` with the frequency 2 % high and the damping doubled (a
  search's error, to see how much it costs);
* `band + mode, own`: as `band + mode`, the rows linearised at the guess, then twice at this
  variant's estimate (online the band is linearised at its own answer; the filter's point it
  starts from is far off where the rigid model does not hold).
* `band + found mode`: as `band + mode` with the modes the estimator's own search reports at
  300 s instead (`diag.mode_f`, `diag.mode_zeta`: the core as the FMU builds it over the same
  samples, the profile, the joint solver, ident.modes = 1): what the found modes' band has (it
  reports the lowest mode's columns alone where they fit; this study takes all found modes).

Each cell: the worst error over the 20 estimates against the composite rigid truth (relative
to the error scale, spacerobot.interface) / the estimates within 2 sd (the batch's bound times
sqrt(chi2 / gain) where that is above 1) / chi2 over the low-passed noise's (the gain: the
compliance band reports where this is at most 5, the found modes' band 2.5); "-" where the search found no mode. The
last column: the modes the search found. The rows linearised at the truth but for
`band + mode, own`. The summary counts the runs within 3 % over all runs of a case, the
estimates within 2 sd over the runs with an answer.

Usage: ``python benchmarks/low_band.py [--seeds 0 1 2 3] [--workers 2]
[--out benchmarks/LOW_BAND.md] [--cases CASE ...]`` (``--cases``: a subset of CASES, by name)
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

from band import by_case  # noqa: E402
from modal_information import DT, filter_rows, modal_block, unweighted  # noqa: E402
from rigid_band import QS, low_pass, solve  # noqa: E402

#: flexible.py's case names
CASES = ("wings 2 x 50 kg 0.3 Hz", "wings 2 x 50 kg 0.2 Hz", "slosh 2 x 25 kg 0.2/0.23 Hz")
#: variant -> (low-pass cut-off [Hz], columns: "compliance", "mode" or "mode off")
VARIANTS = {"band": (0.15, "compliance"), "band + mode": (0.15, "mode"),
            "band + mode, fc 0.10 Hz": (0.10, "mode"), "band + mode off": (0.15, "mode off"),
            "band + mode, own": (0.15, "mode"), "band + found mode": (0.15, "found mode")}
#: the own linearisation's passes (the guess, then the estimate twice)
OWN_PASSES = 3
#: the shipped bands' low-pass order
ORDER = 6
#: `mode off`: the frequency's and the damping's factors
F_OFF, ZETA_OFF = 1.02, 2.0
TITLE = "Modes at 0.2-0.3 Hz: the band with the mode's columns (a batch study)"


def modes_of(sc) -> list:
    """The distinct (frequency [Hz], damping) of the scenario's panels and slosh modes."""
    parts = list(sc.flex.panels[:sc.flex.n]) + list(sc.slosh.modes[:sc.slosh.n])
    return sorted({(float(p.f), float(p.zeta)) for p in parts})


def found_modes(sc, X) -> list:
    """The (frequency [Hz], damping) the estimator's search reports at the end of X (the core
    as the FMU builds it: the profile, the joint solver, ident.modes = 1)."""
    from oracles.samples import fmu_identifier
    ident = fmu_identifier(sc, DT, {"method": 1, "solver": 2, "ident.noise_profile": 1,
                                    "ident.modes": 1})
    for k, x in enumerate(X):
        ident.update_flat(DT * k, x)
    r = ident._report()
    return [(float(f), float(z)) for f, z in zip(r["mode_f"], r["mode_zeta"]) if f > 0]


def study(job):
    from flexible import scenario
    from oracles.samples import guess_of, scenario_samples, sensed
    robot, case, seed = job
    sc = scenario(case, robot)
    XT, truth = scenario_samples(sc, 300.0, DT)
    ts = DT * np.arange(len(XT))
    X = sensed(sc, XT, seed, DT)
    modes = modes_of(sc)
    found = found_modes(sc, X)
    freqs = {"compliance": QS, "mode": modes,
             "mode off": [(f * F_OFF, z * ZETA_OFF) for f, z in modes], "found mode": found}
    blocks = {"compliance": "GC", "mode": "GCDT", "mode off": "GCDT", "found mode": "GCDT"}
    columns = {k: modal_block(ts, X, [np.eye(6)] * len(X), freqs[k], blocks[k])
               for k in freqs if freqs[k]}    # they do not depend on the linearisation

    rows = {}                                 # the filter's rows per linearisation point

    def solve_band(z_lin, fc: float, kind: str):
        key = np.asarray(z_lin, float).tobytes()
        if key not in rows:
            o, prior = filter_rows(sc, ts, X, z_lin, eiv=True)
            rows[key] = (o, prior, *unweighted(o)[::2])                    # W, [H | y]
        o, prior, W, Hu = rows[key]
        Z = np.concatenate([Hu[:, :, :-1], columns[kind], Hu[:, :, -1:]], axis=2)
        Z, sl, gain = low_pass(Z, fc, ORDER, False)
        comp = gain * (sl.stop - sl.start) / len(X)
        worst, within, chi2, est = solve(o, prior, W, Z, sl, comp, truth, gain)
        return {"worst": worst, "within": within, "fit": chi2 / gain, "est": est}

    out = {}
    for label, (fc, kind) in VARIANTS.items():
        if kind not in columns:               # no mode found
            out[label] = {"worst": float("nan"), "within": 0, "fit": float("nan")}
        elif label.endswith(", own"):
            z = guess_of(sc)
            for _ in range(OWN_PASSES):
                out[label] = solve_band(z, fc, kind)
                z = out[label]["est"]
        else:
            out[label] = solve_band(truth, fc, kind)
    out["found"] = ", ".join(f"{f:.3f} Hz {z:.3g}" for f, z in found) or "-"
    print(f"{Path(robot).stem} {case} seed {seed}: " + "; ".join(
        f"{k} {v['worst']:.3g} % {v['within']}/20 fit {v['fit']:.3g}"
        for k, v in out.items() if k in VARIANTS) + f"; found {out['found']}", flush=True)
    return robot, case, seed, out


def cell(r: dict) -> str:
    """A table's cell: worst error / within 2 sd / fit, or "-" where there is no answer."""
    if not np.isfinite(r["worst"]):
        return "-"
    return f"{r['worst']:.3g} % / {r['within']} / {r['fit']:.3g}"


def table(results) -> list:
    lines = ["| robot | case | seed | " + " | ".join(VARIANTS) + " | modes found [Hz, damping] |",
             "|---|---|---|" + "---|" * (len(VARIANTS) + 1)]
    for robot, case, seed, out in results:
        lines.append(f"| {Path(robot).stem} | {case} | {seed} | "
                     + " | ".join(cell(out[v]) for v in VARIANTS) + f" | {out['found']} |")
    return lines


def summary(results) -> str:
    """Per robot, case and variant: the range of the worst errors and of the estimates within
    2 sd, the runs within 3 %, the range of the fit (over the runs with an answer)."""
    parts = []
    for robot, case, rs in by_case(results, CASES):
        cells = []
        for v in VARIANTS:
            ok = [o[v] for o in rs if np.isfinite(o[v]["worst"])]
            if not ok:
                cells.append(f"{v}: no answer (no mode found)")
                continue
            w, n, fit = ([o[k] for o in ok] for k in ("worst", "within", "fit"))
            cells.append(f"{v} {min(w):.3g}-{max(w):.3g} % ({sum(x <= 3.0 for x in w)} of "
                         f"{len(rs)} within 3 %), {min(n)}-{max(n)} of 20 within 2 sd "
                         f"({sum(n)} of {20 * len(ok)}), fit {min(fit):.3g}-{max(fit):.3g}"
                         + (f", {len(rs) - len(ok)} without a mode" if len(ok) < len(rs)
                            else ""))
        parts.append(f"{Path(robot).stem} {case}: " + "; ".join(cells))
    return "Summary: " + ". ".join(parts) + "."


def main(argv=None) -> int:
    import argparse
    from band import seeds_study
    ap = argparse.ArgumentParser(add_help=False)
    ap.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    ap.add_argument("--out")
    ap.add_argument("-h", "--help", action="store_true")
    a, rest = ap.parse_known_args(argv)
    if a.help:
        print("--cases CASE [CASE ...]  a subset of: " + "; ".join(f"'{c}'" for c in CASES))
        rest.append("--help")
    cases = tuple(dict.fromkeys(a.cases))                 # in order, once each
    script = "low_band.py" + ("" if set(cases) == set(CASES) else
                              " --cases " + " ".join(f"'{c}'" for c in cases))
    if a.out:                                  # the header names the command that wrote it
        script += f" --out {a.out}"
        rest += ["--out", a.out]
    return seeds_study(study, script, TITLE, cases,
                       str(Path(__file__).with_name("LOW_BAND.md")), table, summary, rest)


if __name__ == "__main__":
    sys.exit(main())
