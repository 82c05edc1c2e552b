"""The modal columns inside the information filter: a batch study of that route to accurate
estimates of flexible spacecraft through the sensors; it is not shipped (the results say why:
benchmarks/FLEXIBLE.md, "What limits it"); writes benchmarks/MODAL_INFORMATION.md.

What it computes, per parameter set (`wings`, `slosh`: the issue's sizes on the spatial
robot) and sensors seed: the plant's samples every 0.1 s for 300 s through the realistic
sensors; the information filter of the tests' reference (tests/oracles/information.py) at
the truth's linearisation (every row weighted by its own noise covariance, the
errors-in-variables sums); beside its rows, the modal columns of the tests' reference
(tests/oracles/modal.py: est_modal.c's blocks, 165 unknowns per frequency; `G+C`: 57)
driven by the measured base motion, the frequencies given. One batch least squares over the
prior and all rows, compensated exactly for the errors in variables (Sagara-Wada, as the
shipped filter); the sds its bound times sqrt(max(1, chi2)). Variants:

* `rigid`: no columns, the thrust errors estimated (the filter as shipped, at the truth's
  linearisation);
* `modal`: the columns, the thrust errors estimated;
* `modal, held`: the thrust errors held at 0 (their prior rows made stiff);
* `modal, held, reweighted`: and the model error added to every row's noise covariance as
  white isotropic momentum noise (linear; angular about S) from the residuals, 4 iterations
  (not compensated: the sums are of the first weights);
* `noise-free rows` (wings only, seed-independent): the same rows from the true samples
  under the noise model's weights (nothing to compensate), the thrust errors estimated /
  held.

The worst error is over the 20 estimates, relative to the error scale (spacerobot.interface);
"within 2 sd" counts the 20.

Usage: ``python benchmarks/modal_information.py [--seeds 0 1 2] [--stop-time 300]
[--workers 2] [--out benchmarks/MODAL_INFORMATION.md]``
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

# the filter and the columns of this study are the tests' reference formulations
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from oracles.band import RowsFilter  # noqa: E402
from oracles.information import sensor_noise, z_of_reported  # noqa: E402
from oracles.modal import drive, filter_states, modal_columns  # noqa: E402
from oracles.samples import guess_of, parameter_set_samples, sensed  # noqa: E402

DT = 0.1
#: the cases: (label, parameter set, frequencies [Hz] with damping ratios, blocks)
CASES = [
    ("wings, the 4 frequencies the noise-free search finds", "wings",
     ((0.5, 0.005), (0.502, 0.005), (0.495, 0.005), (0.804, 0.01)), "GCDT"),
    ("wings, the panels' own 0.5 + 1.5 Hz", "wings", ((0.5, 0.005), (1.5, 0.01)), "GCDT"),
    ("slosh 0.30 / 0.35 Hz", "slosh", ((0.30, 0.01), (0.35, 0.01)), "GCDT"),
    ("slosh 0.30 / 0.35 Hz, G+C blocks only", "slosh", ((0.30, 0.01), (0.35, 0.01)), "GC"),
]


def record(set_name: str, seed: int, stop_time: float):
    """The plant's true and measured samples of the spatial robot's set (sensors seed)."""
    sc, XT, truth = parameter_set_samples("spatial", set_name, stop_time, DT)
    return sc, DT * np.arange(len(XT)), sensed(sc, XT, seed, DT), XT, truth


def filter_rows(sc, ts, X, z_lin, eiv: bool = True):
    """The reference filter over the samples X, its rows linearised at z_lin (reported, 20;
    this study: the truth) and kept; eiv: the errors-in-variables sums, else none (the
    noise-free rows need no compensation)."""
    from spacerobot.core import load_library
    from spacerobot.core.robot_record import c_robot
    from spacerobot.sensors import default_parameters
    L = load_library()
    sd, sd_c, sd_b = sensor_noise(default_parameters(), DT)
    g = sc.guess
    o = RowsFilter(L, c_robot(sc.robot, L), sc.robot.n_joints, False, sd, sd_c, g.P0_mu,
                   g.P0_theta, z_of_reported(guess_of(sc)), sd_gyro_bias=sd_b)
    o.eiv = eiv
    prior = (o.Rinfo.copy(), o.d.copy())
    zt = z_of_reported(z_lin)
    for t, x in zip(ts, X):
        o.add(t, x, zt)
    return o, prior


def modal_block(ts, X, weights, freqs, blocks: str) -> np.ndarray:
    """(K, 6, nf nc) the weighted modal columns of every sample, driven by X's base motion."""
    sig = [{"A": x[6:15].reshape(3, 3), "omega_B": x[15:18], "v_S": x[3:6], "r_S": x[0:3]}
           for x in X]
    u = np.array([drive(x[6:15].reshape(3, 3), x[18:21], x[21:24], x[15:18]) for x in X])
    out = []
    for f, zeta in freqs:
        st = filter_states(u, ts, 2.0 * np.pi * f, zeta)
        out.append(np.array([W @ modal_columns(st[k, 0], st[k, 1], sig[k], np.zeros(3),
                                               blocks)
                             for k, W in enumerate(weights)]))
    return np.concatenate(out, axis=2)


def unweighted(o):
    """(W, W^-1, the unweighted rows [H | y]) of the filter's kept rows, per sample."""
    W, Hu = o.unweighted()
    return W, np.linalg.inv(W), Hu


def _score(o, u, cov, chi2, truth, noise_chi2: float = 1.0):
    """(worst error %, within 2 sd, chi2, estimates): the sds the bound's, times
    sqrt(chi2 / noise_chi2) where that is above 1 (noise_chi2: the rows' chi2 under their
    noise alone)."""
    from spacerobot.interface import relative_errors
    o.cov = cov
    est, sd = o.estimate(u[:o.nu])
    sd = np.asarray(sd) * np.sqrt(max(1.0, chi2 / noise_chi2))
    return (100.0 * float(relative_errors(est, truth).max()),
            int(np.sum(np.abs(est - truth) <= 2.0 * sd)), float(chi2), est)


def _prior_rows(o, prior, hold: bool, nm: int):
    R, d = prior[0].copy(), prior[1].copy()
    if hold:                                   # the 8 thrust errors held at 0
        t0 = len(o.zi) + len(o.rows)
        for i in range(t0, t0 + 8):
            R[i, :] = 0.0
            R[i, i], d[i] = 1e8, 0.0
    N = o.nu + nm
    P = np.zeros((N, N + 1))
    P[:o.nu, :o.nu], P[:o.nu, N] = R, d
    P[o.nu:, o.nu:N] = 1e-6 * np.eye(nm)       # the modal unknowns' weak prior
    return P


def hac_cov(S, rows, u, block: int, lags: int):
    """The sandwich covariance S^-1 Omega S^-1 of the estimate u from the rows [A | b] (no
    prior), grouped by sample (``block`` rows each): Omega the Newey-West (Bartlett) sum of
    the samples' scores A_k^T e_k and their products up to ``lags`` samples apart, so that
    residuals correlated in time (low-passed noise, what the model leaves) count as they are."""
    N = len(u)
    e = rows[:, :N] @ u - rows[:, N]
    g = (rows[:, :N] * e[:, None]).reshape(-1, block, N).sum(axis=1)      # (K, N) scores
    Om = g.T @ g
    for lag in range(1, lags + 1):
        G = g[lag:].T @ g[:-lag]
        Om += (1.0 - lag / (lags + 1.0)) * (G + G.T)
    Si = np.linalg.inv(S)
    return Si @ Om @ Si.T


def batch(o, prior, rows, hold: bool, truth, compensate: float = 1.0, noise_chi2: float = 1.0,
          hac: tuple = ()):
    """The batch estimate over the prior and the weighted rows [H | columns | y] (one row
    each), the filter's errors-in-variables sums times ``compensate`` taken off: (worst
    error %, within 2 sd, chi2, the 20 estimates; :func:`_score`). hac = (rows per sample,
    lags): the sds from :func:`hac_cov` instead of the bound's times the chi2's inflation."""
    N = rows.shape[1] - 1
    rows = np.vstack([_prior_rows(o, prior, hold, N - o.nu), rows])
    R = np.linalg.qr(rows, mode="r")[:N]
    Rr, dvec = R[:, :N], R[:, N]
    S, s = Rr.T @ Rr, Rr.T @ dvec
    S[:o.nu, :o.nu] -= compensate * o.N_HH
    s[:o.nu] -= compensate * o.N_Hy
    uc = np.linalg.solve(S, s)
    res = rows[N:, :N] @ uc - rows[N:, N]
    chi2 = res @ res / (len(res) - N)
    if hac:
        C = hac_cov(S, rows[N:], uc, *hac)
        return _score(o, uc, C[:o.nu, :o.nu], chi2, truth, np.inf)      # not inflated
    Ri = np.linalg.inv(Rr)
    return _score(o, uc, (Ri @ Ri.T)[:o.nu, :o.nu], chi2, truth, noise_chi2)


def solve(o, prior, MC, hold: bool, truth):
    """The compensated batch estimate: (worst error %, within 2 sd, chi2)."""
    A = np.array(o.rows_w)
    nu, nm = o.nu, 0 if MC is None else MC.shape[2]
    return batch(o, prior, np.concatenate([A[:, :, :nu].reshape(-1, nu)]
                                          + ([MC.reshape(-1, nm)] if nm else [])
                                          + [A[:, :, nu].reshape(-1, 1)], axis=1), hold, truth)


def solve_reweighted(o, prior, MC, X, truth, iterations: int = 4):
    """The thrust errors held, the model error in the rows' noise covariance, iterated."""
    W, Winv, Hu = unweighted(o)
    nu, nm = o.nu, MC.shape[2]
    N = nu + nm
    Mu = np.einsum("kij,kjl->kil", Winv, MC)
    Rk = np.einsum("kij,klj->kil", Winv, Winv)              # the rows' noise covariance
    rS = X[:, 0:3]
    T = np.zeros((len(X), 6, 6))                            # [P; L_S] -> [P; L_O]
    T[:, :3, :3] = T[:, 3:, 3:] = np.eye(3)
    T[:, 3, 1], T[:, 3, 2] = -rS[:, 2], rS[:, 1]
    T[:, 4, 0], T[:, 4, 2] = rS[:, 2], -rS[:, 0]
    T[:, 5, 0], T[:, 5, 1] = -rS[:, 1], rS[:, 0]
    me = np.zeros(2)
    P = _prior_rows(o, prior, True, nm)
    for _ in range(iterations):
        C = Rk + np.einsum("kij,j,klj->kil", T, np.r_[np.full(3, me[0]), np.full(3, me[1])], T)
        Wn = np.linalg.inv(np.linalg.cholesky(C))
        rows = np.vstack([P, np.concatenate(
            [np.einsum("kij,kjl->kil", Wn, Hu[:, :, :nu]).reshape(-1, nu),
             np.einsum("kij,kjl->kil", Wn, Mu).reshape(-1, nm),
             np.einsum("kij,kj->ki", Wn, Hu[:, :, nu]).reshape(-1, 1)], axis=1)])
        u = np.linalg.lstsq(rows[:, :N], rows[:, N], rcond=None)[0]
        e = Hu[:, :, :nu] @ u[:nu] - Hu[:, :, nu] + Mu @ u[nu:]
        p = e[:, :3]
        lS = e[:, 3:] - np.cross(rS, p)
        me = np.array([np.mean(p ** 2), np.mean(lS ** 2)])
        res = rows[N:, :N] @ u - rows[N:, N]
        chi2 = res @ res / (len(res) - N)
    Ri = np.linalg.inv(np.linalg.qr(rows[:, :N], mode="r"))
    return _score(o, u, (Ri @ Ri.T)[:nu, :nu], chi2, truth)


def study(job):
    """One parameter set and seed (seed None: the noise-free rows): {case label: results}."""
    set_name, seed, stop_time = job
    sc, ts, X, XT, truth = record(set_name, 0 if seed is None else seed, stop_time)
    used = XT if seed is None else X
    o, prior = filter_rows(sc, ts, used, truth, eiv=seed is not None)
    out = {}
    for label, s, freqs, blocks in CASES:
        if s != set_name or (seed is None and label != CASES[0][0]):
            continue
        MC = modal_block(ts, used, o.weights, freqs, blocks)
        r = {"modal": solve(o, prior, MC, False, truth),
             "modal, held": solve(o, prior, MC, True, truth)}
        if seed is not None:
            r["rigid"] = solve(o, prior, None, False, truth)
            r["modal, held, reweighted"] = solve_reweighted(o, prior, MC, used, truth)
        out[label] = r
        print(f"{set_name} seed {seed}: {label}: " + "; ".join(
            f"{k} {v[0]:.3g} % {v[1]}/20" for k, v in r.items()), flush=True)
    return set_name, seed, out


def main(argv=None) -> int:
    import argparse
    import datetime as _dt
    import platform
    import time
    from multiprocessing import Pool
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--stop-time", type=float, default=300.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(Path(__file__).with_name("MODAL_INFORMATION.md")))
    a = ap.parse_args(argv)
    jobs = [(s, seed, a.stop_time) for seed in a.seeds for s in ("wings", "slosh")]
    jobs.append(("wings", None, a.stop_time))
    t0 = time.perf_counter()
    with Pool(a.workers) as pool:
        results = pool.map(study, jobs)
    wall = time.perf_counter() - t0
    variants = ["rigid", "modal", "modal, held", "modal, held, reweighted"]
    lines = ["# The modal columns inside the information filter (a batch study)", "",
             f"`python benchmarks/modal_information.py --seeds {' '.join(map(str, a.seeds))} "
             f"--stop-time {a.stop_time:g}`, {_dt.date.today()}, {platform.machine()}, "
             f"{wall / 60:.1f} min with {a.workers} workers. What it computes: the module's "
             "docstring. Each cell: worst error over the 20 estimates (relative to the error "
             "scale) / estimates within 2 reported sd; one line per sensors seed.", "",
             "| case | seed | " + " | ".join(variants) + " |",
             "|---|---|" + "---|" * len(variants)]
    for label, *_ in CASES:
        for set_name, seed, out in sorted((r for r in results if r[1] is not None),
                                          key=lambda r: r[1]):
            if label in out:
                lines.append(f"| {label} | {seed} | " + " | ".join(
                    f"{out[label][v][0]:.3g} % / {out[label][v][1]}" for v in variants) + " |")
    for set_name, seed, out in results:
        if seed is None:
            for label, r in out.items():
                lines += ["", f"Noise-free rows under the noise model's weights, {label}: "
                          f"the thrust errors estimated {r['modal'][0]:.3g} % "
                          f"({r['modal'][1]}/20 within 2 sd), held {r['modal, held'][0]:.3g} % "
                          f"({r['modal, held'][1]}/20)."]
    Path(a.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
