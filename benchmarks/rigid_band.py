"""The rigid band: the information filter's rows low-passed below the flexible parts' modes,
with one quasi-static compliance block; the batch study the shipped band (native/src/band.c,
the estimator's ident.band: a causal Butterworth online, benchmarks/band.py measures it) came
from; writes benchmarks/RIGID_BAND.md.

Why it should work. The plant's excitation lies at 0.033-0.1 Hz (periods 10-30 s), the wings'
and the slosh's modes at 0.2 Hz and above. A part's momentum has two pieces: its free ringing
at its own frequency (lightly damped: it rings for minutes after each push), and its forced
response at the excitation's frequencies, which below the mode is quasi-static: the mode's
deflection follows the base's acceleration, ``eta ~ -u / w^2`` (``u`` the modal drive of
docs/identification.md section 8), so its momentum is the columns of section 8 with ``eta'``
replaced by ``-u' / w^2``. Hence:

* the momentum rows ``y(t) = H(t) u`` hold for any constant ``u``, so one linear filter applied
  in time to both sides keeps them exact; a low-pass below the modes removes the ringing;
* what is left of the parts in the band is quasi-static, and the sum over all modes of
  ``G / w^2`` (and the other blocks) is one set of unknowns whatever the frequencies: one
  well-damped fast filter (2 Hz, damping 0.7: quasi-static below 0.5 Hz) gives its columns.
  No frequency is searched, nor does the number of modes matter.

What it computes, per robot (the spatial robot; the held-out servicer tests/data/arm5.urdf),
case (the `wings` and `slosh` parameter sets at the issue's sizes, and `rigid`: the wings'
scenario without its panels, which the route must not spoil) and sensors seed (or the
noise-free samples): the plant's samples every 0.1 s for 300 s through the realistic sensors;
the information filter of the tests' reference (tests/oracles/information.py) linearised at
the truth, or with `--own` at the guess and then twice at the selected estimate (the
filter's rows are linear in the unknowns but for a second-order term in the mass and centre
of mass), every row weighted by its own noise covariance; beside its rows the modal
columns of the tests' reference (tests/oracles/modal.py) of that one fast filter, driven by
the measured base motion. One batch least squares over the prior and the rows, the thrust
errors estimated. Variants:

* `rows`: the filter's rows as they are, compensated for the errors in variables (Sagara-Wada,
  as the shipped filter): the shipped filter's answer at the truth's linearisation;
* `low-pass`: every row's columns and right-hand side through one Butterworth low-pass
  (`--fc`, `--order`), forward and backward (zero phase: online, such a filter runs with a
  delay of about 3 / fc; `--causal` forward only), the first and last 3 / fc seconds
  dropped (the filter's start and end); the errors-in-variables sums times the filter's
  white-noise gain (the sum of its impulse response's squares) over the samples kept. With
  `--fir TAPS` a linear-phase FIR instead (Hamming window, centred, the first and last
  (TAPS - 1) / 2 samples dropped): what an online filter delivers at the end of the run, its
  output lagging by (TAPS - 1) / 2 samples;
* `low-pass + compliance (G, C)`: and the compliance block's G and C parts (57 unknowns) of
  the 2 Hz filter;
* `low-pass + compliance (G, C), 2 orders`: and those of a second filter (1 Hz, damping 0.7;
  114 unknowns): below its frequency a filter's `eta` is `-u / w^2 + 2 zeta u' / w^3 + ...`,
  and the second term (its own damping's, about 7 % at the excitation's frequencies for the
  2 Hz filter; the lightly damped parts have next to none of it) is separated from the first
  by the two filters together; the gain is measured, not derived;
* `low-pass + compliance (4 blocks)`: all four blocks of the 2 Hz filter (165);
* `selected`: the 2 orders' compliance where it halves the low-pass's chi2 at least, else the
  low-pass alone (on a rigid spacecraft the block takes 14-20 % of the chi2 from the
  low-passed noise, whose effective number of samples is a few hundred);
* `selected, residual sds`: the same estimate, its sds derived from the residuals instead:
  the sandwich covariance S^-1 Omega S^-1 (S the compensated information, Omega the
  Newey-West sum, Bartlett weights, of the samples' scores A_k^T e_k and their products up
  to 2 / fc apart: the low-passed noise's memory), so that residuals correlated in time,
  the low-passed noise's and what the model leaves, count as they are.

The sds are the batch's least-squares ones under the unfiltered rows' weights, times
sqrt(chi2 / chi2_noise) where that is above 1; chi2_noise is the rows' chi2 under their noise
alone: 1 for the filter's rows, the low-pass's white-noise gain (about 0.03) for low-passed
ones. The low-passed noise is smaller but correlated over about 1 / fc, and under the
unfiltered weights the two roughly cancel; the study counts how often the sds cover the
error, it does not derive them. The errors-in-variables scaling assumes the rows' weights
and slopes change slowly over the filter's memory (about 7 s); the compliance columns' own
noise is not compensated.
The worst error is over the 20 estimates, relative to the error scale (spacerobot.interface).

Usage: ``python benchmarks/rigid_band.py [--robots spatial tests/data/arm5.urdf]
[--cases wings slosh rigid] [--seeds 0 1 2 3] [--fc 0.15] [--order 6] [--causal] [--fir TAPS]
[--own] [--stop-time 300] [--workers 2] [--out benchmarks/RIGID_BAND.md]`` (with ``--own``
or ``--fir`` ``--out`` is required: RIGID_BAND_OWN.md, RIGID_BAND_FIR.md)
"""
from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
from modal_information import DT, batch, filter_rows, modal_block, unweighted  # noqa: E402
from oracles.samples import guess_of, scenario_samples, sensed  # noqa: E402

#: the compliance blocks' filters [Hz, damping]: quasi-static below about a quarter of their
#: frequency; the second, with the first, separates their damping's term (2 zeta u' / w^3)
QS = ((2.0, 0.7), (1.0, 0.7))
#: variant -> (compliance blocks, number of filters of QS)
VARIANTS = {"rows": None, "low-pass": ("", 0), "low-pass + compliance (G, C)": ("GC", 1),
            "low-pass + compliance (G, C), 2 orders": ("GC", 2),
            "low-pass + compliance (4 blocks)": ("GCDT", 1)}
#: the selected variant: the 2 orders' compliance where the chi2 falls below CHI2_DROP times
#: the low-pass's, else the low-pass alone
SELECTED, CHI2_DROP = "selected", 0.5
#: the selected estimate with sds from the residuals (Newey-West), over lags up to
#: HAC_MEMORY / fc
SELECTED_HAC, HAC_MEMORY = "selected, residual sds", 2.0


def scenario_of(robot: str, case: str):
    """The case's scenario: a parameter set, or `rigid` (the wings' set without its panels)."""
    from spacerobot.robots import parameter_set_scenario
    if case == "rigid":
        sc = parameter_set_scenario(robot, "wings")
        return replace(sc, flex=replace(sc.flex, n=0))
    return parameter_set_scenario(robot, case)


def low_pass(Z: np.ndarray, fc: float, order: int, zero_phase: bool, taps: int = 0):
    """Z (K, ...) filtered along time, the slice of samples past the filter's start (and end),
    and the filter's white-noise gain: the sum of its impulse response's squares. taps > 0:
    a linear-phase FIR of that many taps (Hamming window) instead of the Butterworth, centred
    (what an online filter delivers (taps - 1) / 2 samples late)."""
    from scipy.signal import butter, firwin, sosfilt, sosfiltfilt
    if taps:
        h, D = firwin(taps, fc, window="hamming", fs=1.0 / DT), (taps - 1) // 2
        out = np.zeros_like(Z)
        for j, hj in enumerate(h):             # out[k] = sum_j h_j Z[k + D - j]
            out[D:len(Z) - D] += hj * Z[taps - 1 - j:len(Z) - j]
        return out, slice(D, len(Z) - D), float(np.sum(h ** 2))
    sos = butter(order, fc, fs=1.0 / DT, output="sos")
    cut = int(round(3.0 / fc / DT))
    impulse = np.zeros(8 * cut + 1)
    impulse[4 * cut] = 1.0
    run = sosfiltfilt if zero_phase else sosfilt
    gain = float(np.sum(run(sos, impulse) ** 2))
    if zero_phase:
        return sosfiltfilt(sos, Z, axis=0), slice(cut, len(Z) - cut), gain
    # from rest at the first sample's value: a step of the initial value is not a transient
    return sosfilt(sos, Z - Z[0], axis=0) + Z[0], slice(cut, len(Z)), gain


def solve(o, prior, W, Hc, sl, compensate: float, truth, noise_chi2: float = 1.0,
          hac_lags: int = 0):
    """The batch estimate of rows Hc = [H | columns | y] (unweighted) over the samples sl,
    weighted by W, the thrust errors estimated, the filter's errors-in-variables sums times
    ``compensate`` taken off: (worst error %, within 2 sd, chi2, estimates; the sds inflated
    where chi2 is above noise_chi2, the rows' chi2 under their noise alone)."""
    rows = np.einsum("kij,kjl->kil", W[sl], Hc[sl]).reshape(-1, Hc.shape[2])
    return batch(o, prior, rows, False, truth, compensate, noise_chi2,
                 (Hc.shape[1], hac_lags) if hac_lags else ())


def variants(sc, ts, X, z_lin, noisy: bool, band: tuple, columns: dict, truth) -> dict:
    """{variant: (worst error %, within 2 sd, chi2, estimates)} of the samples X, the rows
    linearised at z_lin (20), the low-pass band = (fc, order, zero_phase, FIR taps or 0);
    columns caches the compliance blocks' columns (they do not depend on the linearisation)."""
    o, prior = filter_rows(sc, ts, X, z_lin, eiv=noisy)
    W, _, Hu = unweighted(o)                                               # [H | y]
    out = {"rows": solve(o, prior, W, Hu, slice(0, len(X)), float(noisy), truth)}
    lowpassed = {}
    for label, spec in VARIANTS.items():
        if spec is None:
            continue
        blocks, n_qs = spec
        if n_qs and spec not in columns:
            columns[spec] = modal_block(ts, X, [np.eye(6)] * len(X), QS[:n_qs], blocks)
        parts = [Hu[:, :, :-1]] + ([columns[spec]] if n_qs else [])
        Z, sl, gain = low_pass(np.concatenate(parts + [Hu[:, :, -1:]], axis=2), *band)
        # the low-passed noise's products: its gain times theirs over the samples kept
        comp = float(noisy) * gain * (sl.stop - sl.start) / len(X)
        # under the unfiltered rows' weights the low-passed noise's chi2 is the gain
        out[label] = solve(o, prior, W, Z, sl, comp, truth, gain)
        lowpassed[label] = (Z, sl, comp)
    # the compliance block where it explains much of what the low-passed rigid rows leave:
    # the residual's chi2 halved at least (the block's 114 unknowns take 14-20 % of it from
    # the low-passed noise alone, whose effective number of samples is a few hundred)
    lp, qs = out["low-pass"], out["low-pass + compliance (G, C), 2 orders"]
    pick = "low-pass + compliance (G, C), 2 orders" if qs[2] < CHI2_DROP * lp[2] else "low-pass"
    out[SELECTED] = out[pick]
    # the same estimate, its sds from the residuals' own correlation in time (Newey-West over
    # HAC_MEMORY / fc: the low-pass's memory) instead of the inflated bound
    Z, sl, comp = lowpassed[pick]
    out[SELECTED_HAC] = solve(o, prior, W, Z, sl, comp, truth,
                              hac_lags=int(round(HAC_MEMORY / band[0] / DT)))
    return out


def study(job):
    """One robot, case and seed (None: the noise-free samples): {variant: result}. With
    ``own`` the rows are linearised at the guess, then twice at the selected estimate; else
    at the truth."""
    robot, case, seed, stop_time, band, own = job
    sc = scenario_of(robot, case)
    XT, truth = scenario_samples(sc, stop_time, DT)
    ts = DT * np.arange(len(XT))
    X = XT if seed is None else sensed(sc, XT, seed, DT)
    z_lin, columns = (guess_of(sc) if own else truth), {}
    for _ in range(3 if own else 1):
        out = variants(sc, ts, X, z_lin, seed is not None, band, columns, truth)
        z_lin = out[SELECTED][3]
    print(f"{robot} {case} seed {seed}: " + "; ".join(
        f"{k} {v[0]:.3g} % {v[1]}/20 chi2 {v[2]:.4g}" for k, v in out.items()), flush=True)
    return robot, case, seed, out


def main(argv=None) -> int:
    import argparse
    import datetime as _dt
    import platform
    import time
    from multiprocessing import Pool
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robots", nargs="+",
                    default=["spatial", str(Path(__file__).resolve().parents[1]
                                            / "tests" / "data" / "arm5.urdf")])
    ap.add_argument("--cases", nargs="+", default=["wings", "slosh", "rigid"])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    ap.add_argument("--no-noise-free", action="store_true", help="skip the noise-free rows")
    ap.add_argument("--fc", type=float, default=0.15, help="low-pass cut-off [Hz]")
    ap.add_argument("--order", type=int, default=6, help="Butterworth order")
    ap.add_argument("--causal", action="store_true",
                    help="forward only (default: forward-backward, online with a delay)")
    ap.add_argument("--fir", type=int, default=0, metavar="TAPS",
                    help="a linear-phase FIR low-pass of TAPS taps (odd; Hamming window) "
                         "instead of the Butterworth: what an online filter delivers with a "
                         "delay of (TAPS - 1) / 2 samples")
    ap.add_argument("--own", action="store_true",
                    help="linearise at the guess, then twice at the selected estimate "
                         "(default: at the truth)")
    ap.add_argument("--stop-time", type=float, default=300.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", help="the table (default: benchmarks/RIGID_BAND.md, the default "
                                  "run's; with --own or --fir, required)")
    a = ap.parse_args(argv)
    seeds = ([] if a.no_noise_free else [None]) + a.seeds
    if a.fir < 0 or (a.fir and a.fir % 2 == 0):
        ap.error("--fir takes an odd number of taps (a whole-sample delay)")
    if a.fir and a.causal:
        ap.error("--fir is a linear-phase FIR, centred; --causal is the Butterworth's")
    if a.out is None:
        if a.own or a.fir:
            ap.error("--own and --fir write other tables than RIGID_BAND.md: give --out")
        a.out = str(Path(__file__).with_name("RIGID_BAND.md"))
    jobs = [(r, c, s, a.stop_time, (a.fc, a.order, not a.causal, a.fir), a.own)
            for r in a.robots for c in a.cases for s in seeds]
    t0 = time.perf_counter()
    with Pool(a.workers) as pool:
        results = pool.map(study, jobs)
    wall = time.perf_counter() - t0
    args = " ".join(argv if argv is not None else sys.argv[1:])
    kind = ("causal" if a.causal else "zero-phase") + f" Butterworth of order {a.order}"
    if a.fir:
        kind = (f"linear-phase FIR of {a.fir} taps (Hamming window; online it lags by "
                f"{(a.fir - 1) // 2 * DT:g} s)")
    lines = ["# The rigid band (a batch study)", "",
             f"`{' '.join(['python benchmarks/rigid_band.py', args]).strip()}`, "
             f"{_dt.date.today()}, {platform.machine()}, {wall / 60:.1f} min with "
             f"{a.workers} workers; low-pass: {kind} at "
             f"{a.fc:g} Hz. What it computes: the module's docstring. Each cell: worst error "
             "over the 20 estimates against the composite rigid truth (relative to the error "
             "scale) / estimates within 2 reported sd; the thrust errors estimated; the rows "
             + ("linearised at the guess, then twice at the selected estimate."
                if a.own else "linearised at the truth."), "",
             "| robot | case | sensors seed | "
             + " | ".join([*VARIANTS, SELECTED, SELECTED_HAC]) + " |",
             "|---|---|---|" + "---|" * (len(VARIANTS) + 2)]
    for robot, case, seed, out in results:
        cells = [out[v] for v in [*VARIANTS, SELECTED, SELECTED_HAC]]
        name = Path(robot).stem if robot.endswith(".urdf") else robot
        lines.append(f"| {name} | {case} | {'noise-free' if seed is None else seed} | "
                     + " | ".join(f"{c[0]:.3g} % / {c[1]}" for c in cells)
                     + " |")
    Path(a.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
