"""The native estimator core's noise options against the former Python Identifier (an
independent implementation, the oracle tests/oracles/estimator): ``ident.momentum_window``
(the momentum equations differenced against the sample a window earlier,
Identifier._windowed), ``ident.sd_thrust.scale`` / ``ident.sd_thrust.misalign`` (the
thrust's consider covariance, tests/oracles/estimator/consider.py), ``ident.accel_bias`` (the
accelerometer bias fitted from the navigation velocity, accel_bias.py) and ``ident.noise.*``
(the accelerations' errors-in-variables compensation, eiv.py) with both solvers and the
differenced momentum equations, on noisy samples: the
plant's outputs (spatial default scenario, excitation 1, 30 s at 0.1 s) through the realistic
sensors model (tests/oracles/sensors.py SensorSuite, seed 3).

Agreement: estimates within 1e-6 of the error scale (spacerobot.interface.error_scale of the
oracle's estimate), standard deviations within 1e-5 of themselves from the first sample at
which both excitation diagnostics are >= 1e-6, and the consider term alone within 1e-9 of the
sd. Not bit equality, and looser than tests/test_native_estimator.py's 1e-7 / 1e-6 for its
noisy streams, for two measured reasons:
* the estimates: the core's joint sines and cosines are native/src/sr_math.c's (correctly
  rounded), the oracle's glibc's (1 ulp apart at times), and on these realistic-noise runs the
  estimates are sensitive to that over the first samples: a 1-ulp change of the inputs moves
  the oracle's own estimates by up to 1.0e-7 of the error scale (window 2 s about the base;
  5.4e-8 against the first sample), and a build of the core at -O1 (another rounding of its
  own intermediate results) measured 1.02e-7 where the -O2 one gives 5.7e-10 (Numba oracle):
  ten times the measured round-off sensitivity;
* the standard deviations: the oracle runs the paper solver's layered NumPy path (update,
  std_parts, track), the core the order of the former fused kernel
  (report_kernels.paper_step); the drift tracker's lag turns their round-off differences into
  sd differences of up to 1.0e-6 on these runs (the former Python package against itself,
  fused against layered, measured 1e-6): ten times that. The consider term itself is
  compared apart from the tracker (run_both), to 1e-9 (measured 1e-12).
Measured (installed -O2 library, the NumPy oracle): estimates 2e-10 .. 1.7e-7 of the error
scale (the joint solver's first 20 samples up to 7.6e-7), standard deviations 6e-8 .. 2.2e-6
(the joint solver's without the lag term 1e-10 .. 2e-8), the consider term 1.5e-14 .. 1.4e-12
of the sd.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import pytest

from oracles.estimator import Identifier, consider   # the former Python estimator: the oracle
from oracles.estimator.identifier import KEYS
from oracles.sensors import SensorSuite              # the NumPy sensor models: test data
from spacerobot import interface
from spacerobot.core.estimator import NativeEstimator
from spacerobot.plant import Plant
from spacerobot.robots import scenario

ROOT = Path(__file__).resolve().parents[1]
#: agreement of the estimates (x error scale) and of the standard deviations (x themselves);
#: the oracle runs the paper solver's layered NumPy path, the core the fused order (see the
#: module docstring)
X_TOL, SD_TOL = 1e-6, 1e-5
#: reciprocal condition number from which the standard deviations are compared
OBSERVED_RCOND = 1e-6
#: the consider term alone, relative to the sd
CONSIDER_TOL = 1e-9
#: the thrust's standard deviations (scale factor [1], misalignment [rad])
THRUST_SD = (0.01, 0.005)
DT = 0.1
#: samples of the momentum window runs (20 s: the 2 s window's ring refilled ten times)
N_WINDOW = 201
#: samples of the runs with the thrust's consider term (the oracle is plain NumPy, ~4 ms a
#: sample with the term, ~25 ms with the noise rows): 6 s, observed from about the 25th
N_SHORT = 61


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    """The library under test: $SPACEROBOT_CORE_LIB or the installed one if it has these
    options, else a fresh build of native/src."""
    from native_hosts import estimator_library
    return estimator_library(tmp_path_factory)


@pytest.fixture(scope="module")
def noisy_run():
    """``(scenario, [(t, flat sample)])``: the plant's outputs every 0.1 s for 30 s with
    excitation 1, measured by the realistic sensors (seed 3)."""
    sc = scenario("spatial", "default")
    p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
              excitation=sc.excitation)
    p.set_excitation(1.0)
    sensors = SensorSuite(sc.robot.n_joints, seed=3, dt=DT)
    rec = []
    for k in range(301):
        y = sensors.update(p.outputs(), DT)
        rec.append((k * DT, np.concatenate([np.ravel(y[key]) for key in KEYS]).astype(float)))
        p.advance(DT)
    return sc, rec


def run_both(lib, sc, rec, method="momentum", accel="measured", solver="paper", lam=1.0,
             py_kw=None, nat_kw=None, x_tol=X_TOL, sd_tol=SD_TOL, consider_tol=None,
             nolag_tol=None, early=None):
    """Both estimators on ``rec``; asserts the agreement of the module docstring at every
    sample (``sd_tol`` None: the total standard deviations not compared) and returns
    ``(python, native, native without the consider term (None without consider_tol), worst
    estimate difference, worst sd difference, worst consider difference)``.

    ``nolag_tol``: also the standard deviations without the drift tracker's lag
    (``sd_without_lag`` against the oracle's ``solver.std_parts().sd``), relative, from the
    observed sample on, every third sample and the last: the joint solver's comparable part
    (its lag term is not, see :func:`test_thrust_consider_term_matches_python`). ``early = (k, tol)``: the estimates of
    the first ``k`` samples within ``tol`` instead of ``x_tol`` (the joint solver's 20 x 20
    information is barely conditioned over its first samples, tests/test_native_estimator.py).

    ``consider_tol``: also the thrust's consider term alone. The native sd with the term is
    ``sqrt(sd0^2 + sd_c^2)``, ``sd0`` that of a native run without it (the same tracker:
    the tracker takes the sd without the term) and ``sd_c`` the consider sd; compared with
    ``sd_c`` from the Python solver's own sensitivities
    (``consider.consider_sd(J, solver.consider_shift(), sd_c)``), relative to the sd."""
    py = Identifier(sc.robot, sc.guess, method, solver, accel, lam, **(py_kw or {}))
    opts = {"guess": sc.guess, "method": 1 if method == "momentum" else 2,
            "solver": 1 if solver == "paper" else 2,
            "accel_source": 1 if accel == "measured" else 2, "lambda": lam,
            # the oracle's differenced rows are the velocities' form unless told otherwise
            "diff_momentum": 2, **(nat_kw or {})}
    nat = NativeEstimator(sc.robot, opts, lib=lib)
    base = None
    if consider_tol is not None:
        base = NativeEstimator(sc.robot, {**opts, "sd_thrust_scale": 0.0,
                                          "sd_thrust_misalign": 0.0}, lib=lib)
    observed, worst_x, worst_sd, worst_c = False, 0.0, 0.0, 0.0
    for k, (t, x) in enumerate(rec):
        s_py, s_nat = py.update_flat(t, x), nat.update(t, x)
        assert s_py == s_nat, (k, s_py, s_nat, py.message, nat.message)
        rep_py, rep = py.report(), nat.report()
        assert (rep["samples"], rep["rejected"]) == (py.samples, py.rejected), k
        vec, sd = nat.estimates()
        scale = interface.error_scale(py.vector())
        dx = max(np.max(np.abs(vec - py.vector()) / scale),
                 np.max(np.abs(rep["vector"] - rep_py.vector) / scale))
        assert dx <= (early[1] if early and k < early[0] else x_tol), (k, dx)
        if not early or k >= early[0]:
            worst_x = max(worst_x, dx)
        observed = observed or (py.samples > 0 and min(py.excitation()) >= OBSERVED_RCOND)
        if base is not None:
            base.update(t, x)
        if not observed:
            continue
        if nolag_tol is not None and (k % 3 == 0 or k == len(rec) - 1):   # (NumPy: slow)
            b = py.solver.std_parts().sd
            d = np.max(np.abs(nat.sd_without_lag() - b) / b)
            assert d <= nolag_tol, (k, d)
            worst_sd = max(worst_sd, d)
        if sd_tol is not None:
            for a, b in ((sd, py.std()), (rep["sd"], rep_py.std)):
                d = np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-300 + 1e-14 * scale))
                assert d <= sd_tol, (k, d, int(np.argmax(np.abs(a - b) / np.abs(b))))
                worst_sd = max(worst_sd, d)
        if base is not None:
            s = py.solver
            sd_c = consider.consider_sd(s.jacobian(s.z()), s.consider_shift(), py._sd_c)
            sd0 = base.estimates()[1]
            d = np.max(np.abs(sd - np.sqrt(sd0 * sd0 + sd_c * sd_c)) / sd)
            assert d <= consider_tol, (k, d)
            worst_c = max(worst_c, d)
    assert observed, "the run never got observed enough to compare the standard deviations"
    return py, nat, base, worst_x, worst_sd, worst_c


# -- ident.momentum_window ---------------------------------------------------------------------
@pytest.mark.parametrize("window", [0.5, 2.0])
@pytest.mark.parametrize("point", [0, 1])
@pytest.mark.slow
def test_momentum_window_matches_python(lib, noisy_run, window, point):
    """Each sample's momentum equations against the newest sample at least ``window`` s
    older (the first until then), about the origin or the base (ident.momentum_point): the
    estimates and standard deviations are the Python Identifier's; one reference sample."""
    sc, rec = noisy_run
    py, nat, _, dx, dsd, _ = run_both(lib, sc, rec[:N_WINDOW],
                                   py_kw={"window": window, "moving_point": point},
                                   nat_kw={"momentum_window": window, "momentum_point": point})
    assert nat.report()["samples"] == N_WINDOW - 1
    print(f"window {window} s, point {point}: estimates {dx:.2g} x scale, sd {dsd:.2g}")


def test_momentum_window_changes_the_estimates(lib, noisy_run):
    """The window is not ignored: against the first sample (window 0) the estimates of the
    noisy run differ (by far more than the agreement above)."""
    sc, rec = noisy_run
    a = NativeEstimator(sc.robot, {"guess": sc.guess, "momentum_window": 2.0}, lib=lib)
    b = NativeEstimator(sc.robot, {"guess": sc.guess}, lib=lib)
    for t, x in rec:
        a.update(t, x)
        b.update(t, x)
    va, vb = a.estimates()[0], b.estimates()[0]
    assert np.max(np.abs(va - vb) / interface.error_scale(vb)) > 1e-3


# -- ident.sd_thrust.* -------------------------------------------------------------------------
@pytest.mark.parametrize("method, accel, solver, extra", [
    ("momentum", "measured", "paper", {}),
    ("momentum", "measured", "paper", {"window": 2.0, "moving_point": 1}),
    ("momentum", "measured", "joint", {"window": 0.5}),
    ("force", "measured", "paper", {}),
    ("force", "measured", "joint", {}),
    ("force", "differenced", "paper", {"diff_half_window": 2}),
    ("force", "differenced", "paper", {"diff_half_window": 2, "diff_momentum": 1}),
    # with the accelerations' noise compensated (errors in variables: the shift at the
    # compensated mu), the noise benchmark's force set-ups' ident.noise.* values
    ("force", "measured", "paper",
     {"signal_sd": {"a_S": 1.58114e-3, "alpha_B": 2e-4, "qdd": 1e-3}}),
    ("force", "differenced", "paper",
     {"signal_sd": {"v_S": 1e-3, "omega_B": 6.32456e-5, "qd": 1e-4}}),
    # the joint solver's compensated answer, on the differenced momentum equations
    ("force", "differenced", "joint",
     {"diff_half_window": 2, "diff_momentum": 1,
      "signal_sd": {"v_S": 1e-3, "omega_B": 6.32456e-5, "qd": 1e-4}}),
])
@pytest.mark.slow
def test_thrust_consider_term_matches_python(lib, noisy_run, method, accel, solver, extra):
    """sd_thrust = (0.01, 0.005): the consider sums and the thrust integrals give the Python
    Identifier's consider standard deviations (the estimates are unchanged by the term), in
    every equation form that carries it: momentum (against the first sample, or a window,
    about the base), force with measured or differenced accelerations, the differenced
    momentum equations; paper and joint solver.

    The consider term alone (see run_both) within CONSIDER_TOL of the sd; the paper solver's
    totals within SD_TOL (the module docstring). The joint solver's lag term is not
    comparable at all (tests/test_native_estimator.py, joint solver test): its
    totals not compared there."""
    sc, rec = noisy_run
    nat_kw = {"sd_thrust_scale": THRUST_SD[0], "sd_thrust_misalign": THRUST_SD[1]}
    for key, name in (("window", "momentum_window"), ("moving_point", "momentum_point"),
                      ("diff_half_window", "diff_half_window"),
                      ("diff_momentum", "diff_momentum")):
        if key in extra:
            nat_kw[name] = extra[key]
    if "signal_sd" in extra:                 # the core's order: a_S, alpha_B, qdd, v_S, ...
        order = ("a_S", "alpha_B", "qdd", "v_S", "omega_B", "qd")
        nat_kw["signal_sd"] = [extra["signal_sd"].get(k, 0.0) for k in order]
    py, nat, base, dx, dsd, dc = run_both(lib, sc, rec[:N_SHORT], method, accel, solver,
                                          py_kw={"thrust_sd": THRUST_SD, **extra},
                                          nat_kw=nat_kw,
                                          sd_tol=SD_TOL if solver == "paper" else None,
                                          consider_tol=CONSIDER_TOL,
                                          early=JOINT_EARLY if solver == "joint"
                                          and "signal_sd" in extra else None)
    print(f"{method} {accel} {solver} {extra}: estimates {dx:.2g} x scale, sd {dsd:.2g}, "
          f"consider term {dc:.2g}")
    # the term is there (large enough for CONSIDER_TOL to mean something): the sd grew
    # against the same run without it by 0.01 % at least somewhere (1e5 times CONSIDER_TOL;
    # the compensated joint solver's term is the smallest, 0.056 % after 6 s: its
    # compensated covariance K P K^T is the larger); the estimates are those of the run
    # without it (the term only adds to the sd)
    vec, sd = nat.estimates()
    vec0, sd0 = base.estimates()
    ratio = sd / sd0
    assert np.min(ratio) >= 1.0 and np.max(ratio) > 1.0001, ratio
    np.testing.assert_array_equal(vec, vec0)


@pytest.mark.parametrize("lam", [0.98])
def test_thrust_consider_with_forgetting_and_lags(lib, noisy_run, lam):
    """With a forgetting factor (the consider sums decay as the Gram matrices) and the
    residual autocorrelation (corr_lags) on the momentum window, about the base: the noise
    benchmark's momentum set-up (benchmarks/NOISE.md) in small."""
    sc, rec = noisy_run
    run_both(lib, sc, rec[:N_SHORT], lam=lam, consider_tol=CONSIDER_TOL,
             py_kw={"thrust_sd": THRUST_SD, "window": 2.0, "moving_point": 1, "corr_lags": 5,
                    "row_sd": (2.0, 500.0)},
             nat_kw={"sd_thrust_scale": THRUST_SD[0], "sd_thrust_misalign": THRUST_SD[1],
                     "momentum_window": 2.0, "momentum_point": 1, "corr_lags": 5,
                     "ident.sd_row.momentum_lin": 2.0, "ident.sd_row.momentum_ang": 500.0})


# -- ident.accel_bias; ident.noise.* with the joint solver and with ident.diff_momentum -------
#: samples of these runs (6 s; observed from about the 25th): the oracle's noise rows are plain
#: NumPy (~25 ms a sample)
N_NOISE = 61
#: the noise benchmark's force set-ups' ident.noise.* (measured, differenced accelerations)
SD_MEASURED = {"a_S": 1.58114e-3, "alpha_B": 2e-4, "qdd": 1e-3}
SD_DIFFERENCED = {"v_S": 1e-3, "omega_B": 6.32456e-5, "qd": 1e-4}
#: the joint solver's first samples (its 20 x 20 information barely conditioned): estimates
#: within 1e-5 of the error scale there (measured 7.6e-7), X_TOL after (measured 3.6e-9)
JOINT_EARLY = (20, 1e-5)
#: the standard deviations without the tracker's lag (the joint solver's comparable part)
NOLAG_TOL = 1e-6


def native_kw(extra: dict) -> dict:
    """The NativeEstimator options of the Identifier keywords ``extra``."""
    out = {k: int(v) for k, v in extra.items() if k in ("accel_bias", "diff_momentum",
                                                         "diff_half_window")}
    if "signal_sd" in extra:                 # the core's order: a_S, alpha_B, qdd, v_S, ...
        order = ("a_S", "alpha_B", "qdd", "v_S", "omega_B", "qd")
        out["signal_sd"] = [extra["signal_sd"].get(k, 0.0) for k in order]
    return out


@pytest.mark.parametrize("accel, solver, extra", [
    ("measured", "paper", {"accel_bias": 1}),
    ("measured", "joint", {"accel_bias": 1}),
    ("measured", "paper", {"accel_bias": 1, "signal_sd": SD_MEASURED}),
    ("measured", "joint", {"signal_sd": SD_MEASURED}),
    ("differenced", "joint", {"diff_half_window": 2, "signal_sd": SD_DIFFERENCED}),
    ("differenced", "paper", {"diff_half_window": 1, "diff_momentum": 1,
                              "signal_sd": SD_DIFFERENCED}),
    ("differenced", "joint", {"diff_half_window": 2, "diff_momentum": 1,
                              "signal_sd": SD_DIFFERENCED}),
])
@pytest.mark.slow
def test_force_noise_options_match_python(lib, noisy_run, accel, solver, extra):
    """The force method's ident.accel_bias (a_S minus the accelerometer bias fitted online
    from the navigation velocity, accel_bias.BiasFit) and ident.noise.* (the errors-in-variables
    compensation, eiv.py) with either solver, the differenced accelerations and the
    differenced momentum equations (their noise rows combined by the derivative's and the
    displacement's weights): the Python Identifier's estimates and standard deviations.

    Tolerances: the paper solver's totals as the module docstring (X_TOL, SD_TOL; measured
    estimates 2.6e-9 .. 1.4e-7 of the error scale, sd 3.5e-8 .. 7.4e-8). The joint solver:
    the estimates JOINT_EARLY (measured up to 7.6e-7 over the first 20 samples, 1.2e-9 ..
    8.6e-9 after), the standard deviations without the lag term (its lag is not comparable)
    within NOLAG_TOL (measured 4e-11 .. 2e-8)."""
    sc, rec = noisy_run
    joint = solver == "joint"
    sd_tol = None if joint else SD_TOL
    py, nat, _, dx, dsd, _ = run_both(lib, sc, rec[:N_NOISE], "force", accel, solver,
                                      py_kw=extra, nat_kw=native_kw(extra), sd_tol=sd_tol,
                                      nolag_tol=NOLAG_TOL if joint else None,
                                      early=JOINT_EARLY if joint else None)
    half = extra.get("diff_half_window", 0)
    assert nat.report()["samples"] == py.samples == N_NOISE - 2 * half
    print(f"{accel} {solver} {extra}: estimates {dx:.2g} x scale, sd {dsd:.2g}")


def test_accel_bias_subtracts_the_bias_where_it_applies(lib, noisy_run):
    """ident.accel_bias = 1 on the realistic sensors' run (an accelerometer bias of 3e-3
    m/s2): the force method's masses with measured accelerations come closer to the truth
    (measured after 30 s: errors 18 / 17 kg without, 5 / 5 kg with, either solver); where it
    does not apply (momentum method, differenced accelerations) it is ignored, as the Python
    Identifier ignores it: the same state, bit for bit."""
    sc, rec = noisy_run
    truth = np.array([sc.robot.base.mass, sc.target.mass])
    for solver in (1, 2):
        err = []
        for bias in (0, 1):
            nat = NativeEstimator(sc.robot, {"guess": sc.guess, "method": 2, "solver": solver,
                                             "accel_bias": bias}, lib=lib)
            for t, x in rec:
                nat.update(t, x)
            err.append(np.abs(nat.estimates()[0][[0, 10]] - truth))
        assert np.all(err[1] < 0.5 * err[0]), (solver, err)
    for opts in ({"method": 1}, {"method": 2, "accel_source": 2},
                 {"method": 2, "accel_source": 2, "diff_momentum": 1}):
        a = NativeEstimator(sc.robot, {"guess": sc.guess, **opts, "accel_bias": 1}, lib=lib)
        b = NativeEstimator(sc.robot, {"guess": sc.guess, **opts}, lib=lib)
        for t, x in rec[:40]:
            assert a.update(t, x) == b.update(t, x)
        assert a.get_state() == b.get_state(), opts


@pytest.mark.slow
def test_planar_robot(lib):
    """A planar robot (the identified rows x, y and z; the consider columns selected with
    them), momentum window and consider term, on a noisy stream of the planar plant."""
    sc = scenario("planar", "medium")
    p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
              excitation=sc.excitation)
    p.set_excitation(1.0)
    rng = np.random.default_rng(4)
    rec = []
    for k in range(121):
        o = p.outputs()
        x = np.concatenate([np.ravel(o[key]) for key in KEYS]).astype(float)
        x[:6] += 1e-4 * rng.standard_normal(6)
        x[15:] += 1e-4 * rng.standard_normal(len(x) - 15)
        rec.append((k * DT, x))
        p.advance(DT)
    for method, window in (("momentum", 1.0), ("force", 0.0)):
        run_both(lib, sc, rec, method, py_kw={"thrust_sd": THRUST_SD, "window": window},
                 nat_kw={"sd_thrust_scale": THRUST_SD[0], "sd_thrust_misalign": THRUST_SD[1],
                         "momentum_window": window},
                 consider_tol=CONSIDER_TOL)


# -- defaults, state, refusals ----------------------------------------------------------------
def test_defaults_are_the_former_behaviour(lib):
    """sd_thrust (0, 0) and momentum_window 0 are the defaults: the options' struct says so,
    and an estimator given them explicitly has the same state size as one without."""
    from spacerobot.core.estimator import default_options
    d = default_options(lib)
    assert (d["sd_thrust_scale"], d["sd_thrust_misalign"], d["momentum_window"],
            d["momentum_window_samples"], d["accel_bias"]) == (0.0, 0.0, 0.0, 0, 0)
    sc = scenario("spatial", "default")
    a = NativeEstimator(sc.robot, {"guess": sc.guess}, lib=lib)
    b = NativeEstimator(sc.robot, {"guess": sc.guess, "sd_thrust_scale": 0.0,
                                   "momentum_window": 0.0}, lib=lib)
    assert a.size == b.size


def test_state_round_trip_and_check(lib, noisy_run):
    """The Data block (ring, thrust integrals, consider sums) is flat: a copy taken half way
    and restored into a fresh estimator continues the run to the same numbers (bit for bit:
    one implementation); a damaged ring count or thrust flag is refused by the check."""
    sc, rec = noisy_run
    opts = {"guess": sc.guess, "momentum_window": 2.0, "momentum_point": 1,
            "sd_thrust_scale": THRUST_SD[0], "sd_thrust_misalign": THRUST_SD[1]}
    a = NativeEstimator(sc.robot, opts, lib=lib)
    for t, x in rec[:120]:
        a.update(t, x)
    state = a.get_state()
    assert a.check_state() == ""
    b = NativeEstimator(sc.robot, opts, lib=lib)
    b.set_state(state)
    for t, x in rec[120:]:
        a.update(t, x)
        b.update(t, x)
    np.testing.assert_array_equal(a.estimates()[0], b.estimates()[0])
    np.testing.assert_array_equal(a.estimates()[1], b.estimates()[1])
    # a time that does not advance past the ring's newest sample is rejected, state untouched
    before = b.get_state()
    assert b.update(rec[-1][0], rec[-1][1]) == 4
    assert "increasing sample times" in b.message
    assert b.get_state()[b.head_size:] == before[b.head_size:]


def test_noise_options_state_round_trip_and_check(lib, noisy_run):
    """The new Data of ident.accel_bias (the bias fit and its flag) and of the noise
    compensation (the noise Gram matrices, the compensated answers; with diff_momentum the
    window's noise rows in the history ring) is flat: a copy taken mid-run continues in a
    fresh estimator to the same numbers (bit for bit: one implementation). Every 4-byte word
    of the joint solver's state damaged in turn: sr_estimator_data_check refuses the damaged
    bias and noise flags (an update then refuses the block, status 3, nothing written); a
    sample of the other words steps to finite numbers or is rejected (status 1..4)."""
    import struct
    sc, rec = noisy_run
    joint = {"guess": sc.guess, "method": 2, "solver": 2, "accel_bias": 1,
             "signal_sd": [1.58114e-3, 2e-4, 1e-3, 0.0, 0.0, 0.0]}
    diffmom = {"guess": sc.guess, "method": 2, "accel_source": 2, "diff_half_window": 2,
               "diff_momentum": 1, "sd_thrust_scale": 0.01,
               "signal_sd": [0.0, 0.0, 0.0, 1e-3, 6.32456e-5, 1e-4]}
    for opts in (joint, diffmom):
        a = NativeEstimator(sc.robot, opts, lib=lib)
        for t, x in rec[:30]:
            a.update(t, x)
        assert a.check_state() == ""
        b = NativeEstimator(sc.robot, opts, lib=lib)
        b.set_state(a.get_state())
        for t, x in rec[30:50]:
            assert a.update(t, x) == b.update(t, x) == 2
        np.testing.assert_array_equal(a.estimates()[0], b.estimates()[0])
        np.testing.assert_array_equal(a.estimates()[1], b.estimates()[1])
    nat = NativeEstimator(sc.robot, joint, lib=lib)
    for t, x in rec[:12]:
        nat.update(t, x)
    clean = nat.get_state()
    t_next, x_next = rec[12]
    reasons, stepped = set(), 0
    for off in range(0, len(clean) - 3, 4):
        bad = bytearray(clean)
        struct.pack_into("<I", bad, off, (0x7FFFFFFF, 0xFFFFFFFF, 0x10000)[(off // 4) % 3])
        nat.set_state(bytes(bad))
        why = nat.check_state()
        if why:
            reasons.add(why.split(" = ")[0])
            assert nat.update(t_next, x_next) == 3 and nat.get_state() == bytes(bad), off
        elif (off // 4) % 16 == 0:                       # a sample of the others: stepped
            stepped += 1
            st = nat.update(t_next, x_next)
            assert st in (1, 2, 3, 4), (off, st)
            if st == 2:
                assert np.all(np.isfinite(np.concatenate(nat.estimates()))), off
    assert stepped > 100
    for name in ("the accelerometer bias fit's flag", "the noise compensation flag"):
        assert any(name in r for r in reasons), sorted(reasons)


@pytest.mark.slow
def test_damaged_state_words_refused_or_stepped_finite(lib, noisy_run):
    """Every 4-byte word of a real state with the window's ring (wrapped round) and the
    thrust integrals damaged in turn (as tests/test_native_estimator.py does for the other
    rings): sr_estimator_data_check refuses it with a reason (an update then refuses it too,
    status 3, the block not written), or the update runs (status 1..4; where a sample was used
    every estimate and sd finite). The new counts and flags are among the refused words."""
    import struct
    sc, rec = noisy_run
    nat = NativeEstimator(sc.robot, {"guess": sc.guess, "momentum_window": 1.0,
                                     "momentum_point": 1, "momentum_window_samples": 14,
                                     "sd_thrust_scale": THRUST_SD[0],
                                     "sd_thrust_misalign": THRUST_SD[1]}, lib=lib)
    for t, x in rec[:25]:
        nat.update(t, x)
    clean = nat.get_state()
    assert nat.check_state() == "" and nat.report()["samples"] == 24
    t_next, x_next = rec[25]
    reasons, stepped = set(), 0
    for off in range(0, len(clean) - 3, 4):
        bad = bytearray(clean)
        struct.pack_into("<I", bad, off, (0x7FFFFFFF, 0xFFFFFFFF, 0x10000)[(off // 4) % 3])
        nat.set_state(bytes(bad))
        why = nat.check_state()
        st = nat.update(t_next, x_next)
        if why:
            reasons.add(why.split(" = ")[0])
            assert st == 3 and nat.get_state() == bytes(bad), (off, why)
        else:
            stepped += 1
            assert st in (1, 2, 3, 4), (off, st)
            if st == 2:
                assert np.all(np.isfinite(np.concatenate(nat.estimates()))), off
    for name in ("the momentum window's count", "the momentum window's head",
                 "the thrust integrals' flag"):
        assert any(name in r for r in reasons), sorted(reasons)


def test_a_full_ring_rejects_the_sample(lib, noisy_run):
    """A ring too small for the samples of one window (momentum_window_samples) rejects a
    sample that would overfill it, with the reason; the samples it accepts give the Python
    Identifier's estimates on those samples (the reference is always the right one)."""
    sc, rec = noisy_run
    nat = NativeEstimator(sc.robot, {"guess": sc.guess, "momentum_window": 2.0,
                                     "momentum_window_samples": 8}, lib=lib)
    py = Identifier(sc.robot, sc.guess, window=2.0)
    for t, x in rec:
        if nat.update(t, x) == 4:
            assert "momentum window's ring is full" in nat.message
            continue
        py.update_flat(t, x)
    assert 0 < nat.report()["rejected"] < len(rec) and nat.report()["samples"] == py.samples
    vec = nat.estimates()[0]
    assert np.max(np.abs(vec - py.vector()) / interface.error_scale(py.vector())) <= X_TOL


def test_bad_values_are_refused_with_the_parameter_name(lib):
    sc = scenario("spatial", "default")
    for opts, words in (({"sd_thrust_scale": -0.1}, "ident.sd_thrust.scale must be a number "
                                                    "from 0 to 1, got -0.1"),
                        ({"sd_thrust_misalign": 2.0}, "ident.sd_thrust.misalign must be a "
                                                      "number from 0 to 1, got 2.0"),
                        ({"sd_thrust_scale": float("nan")}, "ident.sd_thrust.scale"),
                        ({"momentum_window": -1.0}, "ident.momentum_window must be a number"),
                        ({"momentum_window": 1.0, "momentum_window_samples": 1},
                         "momentum_window_samples"),
                        ({"accel_bias": 2}, "ident.accel_bias must be 0 or 1, got 2")):
        with pytest.raises(ValueError) as e:
            NativeEstimator(sc.robot, opts, lib=lib)
        assert words in str(e.value)


# -- the native FMU ----------------------------------------------------------------------------
def _fmu_keys(fmu: Path) -> dict:
    """``{core key: value reference}`` from the FMU's resources/spacerobot_variables.txt."""
    import zipfile
    with zipfile.ZipFile(fmu) as z:
        text = z.read("resources/spacerobot_variables.txt").decode()
    out = {}
    for line in text.splitlines():
        f = line.split()
        if f and f[0].isdigit():
            out[f[5]] = (int(f[0]), f[1])
    return out


def _run_fmu(fmu: Path, n: int, rec, params: dict):
    """The FMU (fmpy's FMU2Slave) fed the flat samples ``rec`` with the parameters ``params``
    (core keys); ``[(estimates (20,), sd (20,))]`` after each step."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    md = read_model_description(str(fmu))
    keys = _fmu_keys(fmu)
    sizes = {"r_S": 3, "v_S": 3, "A": 9, "omega_B": 3, "a_S": 3, "alpha_B": 3, "q": n,
             "qd": n, "qdd": n, "F": 3, "M": 3, "J": 3, "H": 3}
    inputs = []
    for key in KEYS:
        for i in range(sizes[key]):
            inputs.append(keys[f"A.{i // 3}.{i % 3}" if key == "A" else f"{key}.{i}"][0])
    body = ["m", "b.0", "b.1", "b.2"] + [f"I.{i}" for i in range(6)]
    est = [keys[f"est_{b}.{e}"][0] for b in ("base", "target") for e in body]
    sd = [keys[f"sd_{b}.{e}"][0] for b in ("base", "target") for e in body]
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="est")
    slave.instantiate()
    try:
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        for key, value in params.items():
            vr, kind = keys[key]
            if kind == "Integer":
                slave.setInteger([vr], [int(value)])
            else:
                slave.setReal([vr], [float(value)])
        slave.exitInitializationMode()
        out = []
        for t, x in rec:
            slave.setReal(inputs, [float(v) for v in x])
            slave.doStep(currentCommunicationPoint=t, communicationStepSize=DT)
            out.append((np.array(slave.getReal(est)), np.array(slave.getReal(sd))))
        slave.terminate()
    finally:
        slave.freeInstance()
    return out


@pytest.mark.slow
def test_native_fmu_takes_the_options(lib, noisy_run, tmp_path):
    """The native estimator FMU (this tree's glue and core, built as build_native_fmu packs
    it) accepts ident.momentum_window = 2 with the thrust's sd, and the force method's
    ident.accel_bias = 1 with ident.noise.* and the joint solver, and gives NativeEstimator's
    estimates and standard deviations (the same core, one step per sample: 1e-12). Nothing is
    refused for want of the core any more: ident.force_window is gone from the FMU, and only
    invalid values (ident.accel_bias = 2) are refused at initialisation."""
    pytest.importorskip("fmpy")
    sys.path.insert(0, str(ROOT / "tests"))
    from native_hosts import native_build
    from spacerobot.fmi.native import build_native_fmu
    sc, rec = noisy_run
    lib_dir = tmp_path / "lib"
    native_build().build_fmu_binary("estimator", "linux64", lib_dir / "fmu")
    fmu = build_native_fmu("estimator", sc, tmp_path / "fmu", lib_dir=lib_dir)
    assert "window.force" not in _fmu_keys(fmu)
    sd = dict(zip(("a_S", "alpha_B", "qdd"), (1.58114e-3, 2e-4, 1e-3)))
    for n, params, opts in (
            (80, {"window.momentum": 2.0, "momentum_point": 1,
                  "sd_thrust.scale": THRUST_SD[0], "sd_thrust.misalign": THRUST_SD[1]},
             {"momentum_window": 2.0, "momentum_point": 1, "sd_thrust_scale": THRUST_SD[0],
              "sd_thrust_misalign": THRUST_SD[1]}),
            (40, {"method": 2, "solver": 2, "accel_bias": 1,
                  **{f"signal_sd.{k}": v for k, v in sd.items()}},
             {"method": 2, "solver": 2, "accel_bias": 1,
              "signal_sd": [*sd.values(), 0.0, 0.0, 0.0]})):
        res = _run_fmu(fmu, sc.robot.n_joints, rec[:n], params)
        nat = NativeEstimator(sc.robot, {"guess": sc.guess, **opts}, lib=lib)
        worst = 0.0
        for k, (t, x) in enumerate(rec[:n]):
            nat.update(t, x)
            rep = nat.report()
            scale = interface.error_scale(rep["vector"])
            d = max(np.max(np.abs(res[k][0] - rep["vector"]) / scale),
                    np.max(np.abs(res[k][1] - rep["sd"]) / rep["sd"]))
            assert d <= 1e-12, (k, d)
            worst = max(worst, d)
        assert rep["samples"] == n - (1 if opts.get("momentum_window") else 0)
        print(f"FMU against NativeEstimator ({params}): {worst:.2g}")
    from fmpy.fmi1 import FMICallException
    with pytest.raises(FMICallException):
        _run_fmu(fmu, sc.robot.n_joints, rec[:2], {"method": 2, "accel_bias": 2})

