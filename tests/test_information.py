"""The information filter and its Cramér-Rao bound (native/src/information.c, issue #29).

* Against the NumPy oracle (:mod:`oracles.information`: the same square-root information filter
  with a dense LAPACK QR per sample, and the same noise model), fed the same noisy run (the
  sensors' realistic models, seed 1) and linearised at the same fixed point (the truth): the
  estimates (errors-in-variables compensated and not) within 1e-4 of the bound's standard
  deviation, the bound within 1e-4 relative; a planar robot's out-of-plane entries have no
  bound (0) in both.
* The bound against a brute-force Monte Carlo of a small linear case (the issue's "Validate the
  bound against a brute-force Monte Carlo"): one noise-free trajectory, then independent draws
  of everything the model calls random, each fed to a fresh filter: the estimates' scatter is the
  bound (see :func:`test_bound_matches_monte_carlo` for the set-up and the tolerances).
* Bad input: refused with status 1, the state untouched.
* Through the estimator (``ident.information``): the estimator's ``crb`` and estimates are those
  of a filter driven separately with the estimator's own linearisation point; off, no bound and
  the equations' own estimates.
"""
from __future__ import annotations

import ctypes
import struct
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from oracles.information import (InformationFilter, com_of_origin, noise_vector, origin_of_com,
                                 reported_of_z, sensor_noise, z_of_reported)
from oracles.samples import flat, guess_of, truth_of
from spacerobot.core.robot_record import SrRobot, c_robot
from spacerobot.plant import Plant
from spacerobot.robots import scenario
from spacerobot.sensors import SensorSuite, default_parameters

ROOT = Path(__file__).resolve().parents[1]
_DP = ctypes.POINTER(ctypes.c_double)
#: sr_info_noise: 17 doubles
N_NOISE = 17
#: SR_INFO_REFRESH (native/src/information.h): the samples the rows' weight is held over, the
#: oracle's too (part of the filter's definition: change both together)
REFRESH = 1


def _p(a: np.ndarray):
    return a.ctypes.data_as(_DP)


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    """The library under test: $SPACEROBOT_CORE_LIB, or the installed one if it has the
    information filter, else a fresh build of native/src."""
    from spacerobot.core import CoreUnavailable, load_library
    from spacerobot.core.estimator import _bind
    try:
        L = load_library()
        L.sr_info_add
    except (CoreUnavailable, AttributeError, OSError):
        if os.environ.get("SPACEROBOT_CORE_LIB"):
            raise
        out = tmp_path_factory.mktemp("core")
        subprocess.run([sys.executable, str(ROOT / "native" / "build.py"), "--out", str(out)],
                       check=True, capture_output=True)
        L = load_library(next(out.glob("libspacerobot.*")))
    vp = ctypes.c_void_p
    L.sr_info_model_init.argtypes = [vp, vp, _DP, _DP, ctypes.c_double, ctypes.c_double]
    L.sr_info_model_init.restype = ctypes.c_int
    L.sr_info_data_init.argtypes = [vp, vp]
    L.sr_info_data_init.restype = None
    L.sr_info_add.argtypes = [vp, vp, ctypes.c_double, _DP, _DP, vp]
    L.sr_info_add.restype = ctypes.c_int
    L.sr_info_estimate.argtypes = [vp, vp, ctypes.c_int, _DP, _DP, _DP]
    L.sr_info_estimate.restype = ctypes.c_int
    for name in ("sr_info_model_size", "sr_info_data_size", "sr_info_work_size"):
        getattr(L, name).argtypes = []
        getattr(L, name).restype = ctypes.c_size_t
    return _bind(L)


class CFilter:
    """The native filter through ctypes: one Model and one Data block."""

    def __init__(self, L, robot: SrRobot, noise, z0, P0_mu: float, P0_theta: float):
        self.L, self.robot = L, robot
        self.model = ctypes.create_string_buffer(L.sr_info_model_size())
        self.data = ctypes.create_string_buffer(L.sr_info_data_size())
        self.work = ctypes.create_string_buffer(L.sr_info_work_size())
        self.status = self.init(noise, z0, P0_mu, P0_theta)
        L.sr_info_data_init(self.model, self.data)

    def init(self, noise, z0, P0_mu, P0_theta) -> int:
        nv = np.ascontiguousarray(noise, float)
        z = np.ascontiguousarray(z0, float)
        assert nv.shape == (N_NOISE,) and z.shape == (20,)
        return self.L.sr_info_model_init(self.model, ctypes.byref(self.robot), _p(nv), _p(z),
                                         float(P0_mu), float(P0_theta))

    def reset(self) -> None:
        self.L.sr_info_data_init(self.model, self.data)

    def add(self, t: float, x, z_lin) -> int:
        x = np.ascontiguousarray(x, float)
        z = np.ascontiguousarray(z_lin, float)
        return self.L.sr_info_add(self.model, self.data, float(t), _p(x), _p(z), self.work)

    def estimate(self, compensated: bool):
        """(status, estimates (20), bound (20), chi2)."""
        vec, bound, chi2 = np.zeros(20), np.zeros(20), np.zeros(1)
        st = self.L.sr_info_estimate(self.model, self.data, int(compensated), _p(vec),
                                     _p(bound), _p(chi2))
        return st, vec, bound, float(chi2[0])


def record(sc, dt: float, stop_time: float, sensors_seed=None) -> tuple:
    """``(t (K,), X (K, len))``: the open-loop plant (excitation level 1) sampled every dt,
    as measured by the sensors' realistic models (seed ``sensors_seed``) or noise-free."""
    plant = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
                  excitation=sc.excitation)
    plant.set_excitation(1.0)
    sensors = None if sensors_seed is None else SensorSuite(sc.robot.n_joints,
                                                            seed=sensors_seed, dt=dt)
    ts, X = [], []
    for k in range(int(round(stop_time / dt)) + 1):
        o = plant.outputs()
        X.append(flat(sensors.update(o, dt) if sensors else o))
        ts.append(k * dt)
        plant.advance(dt)
    return np.array(ts), np.array(X)


# ------------------------------------------------------------------------------------------
# a. the native filter against the NumPy oracle
# ------------------------------------------------------------------------------------------

def _both(L, robot_name: str, stop_time: float):
    """Both filters over the same realistic run, linearised at the truth; the scenario's
    guesses and P0 as the prior."""
    dt = 0.1
    sc = scenario(robot_name)
    n, planar = sc.robot.n_joints, sc.robot.planar
    ts, X = record(sc, dt, stop_time, sensors_seed=1)
    sd, sd_c, sd_b = sensor_noise(default_parameters(), dt)
    rob = c_robot(sc.robot, L)
    g, truth = sc.guess, truth_of(sc)
    c = CFilter(L, rob, noise_vector(sd, sd_c, sd_b), guess_of(sc), g.P0_mu, g.P0_theta)
    assert c.status == 0
    o = InformationFilter(L, rob, n, planar, sd, sd_c, g.P0_mu, g.P0_theta,
                          z_of_reported(guess_of(sc)), sd_gyro_bias=sd_b, refresh=REFRESH)
    o.eiv = True
    z_truth = z_of_reported(truth)
    for t, x in zip(ts, X):
        assert c.add(t, x, truth) == 0
        o.add(t, x, z_truth)
    return sc, c, o


@pytest.mark.parametrize("robot_name, stop_time", [("spatial", 25.0), ("planar", 20.0)])
@pytest.mark.slow
def test_matches_the_oracle(lib, robot_name, stop_time):
    """The estimates within 1e-4 of the bound's sd of the oracle's (measured: spatial, 25 s:
    9e-7, planar 20 s: 2e-11, uncompensated and compensated), the bound within 1e-4 relative
    (measured 7e-8 and 1e-9). A planar robot: exactly the out-of-plane entries b_z, Ixz, Iyz
    of both bodies have bound 0 in both (no in-plane unknown moves them with the guesses'
    c_z = 0; Ixx, Iyy, Ixy about the com move with m, c_x, c_y through the parallel axes) and
    the same values (the guesses' carried through the same map) within 1e-9 of their size.
    chi2 (the realistic sensors have more than white noise) only finite and positive
    (measured 1.29 and 0.86)."""
    sc, c, o = _both(lib, robot_name, stop_time)
    for comp in (0, 1, 2):                    # none, first order, exact (the estimator's)
        st, vec, bound, chi2 = c.estimate(comp)
        x_o, b_o = o.result(comp)
        assert st == 0
        on = b_o > 0
        assert np.all(np.abs(vec - x_o)[on] <= 1e-4 * b_o[on]), (comp, np.max(
            np.abs(vec - x_o)[on] / b_o[on]))
        assert np.all(np.abs(bound - b_o)[on] <= 1e-4 * b_o[on]), np.max(
            np.abs(bound - b_o)[on] / b_o[on])
        assert np.all(bound[~on] == 0.0)
        assert np.all(np.abs(vec - x_o)[~on] <= 1e-9 * np.maximum(1.0, np.abs(x_o[~on])))
        assert np.isfinite(chi2) and chi2 > 0
    off = [i for i in range(20) if not on[i]]
    assert off == ([3, 8, 9, 13, 18, 19] if sc.robot.planar else [])   # b_z, Ixz, Iyz


# ------------------------------------------------------------------------------------------
# b. the bound against a brute-force Monte Carlo
# ------------------------------------------------------------------------------------------

def _rotations(w: np.ndarray) -> np.ndarray:
    """R(w) (K, 3, 3) of rotation vectors w (K, 3) (Rodrigues)."""
    th = np.linalg.norm(w, axis=1)[:, None, None]
    k = np.zeros((len(w), 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -w[:, 2], w[:, 1], -w[:, 0]
    k -= k.transpose(0, 2, 1)
    k /= np.where(th > 0, th, 1.0)
    return np.eye(3) + np.sin(th) * k + (1 - np.cos(th)) * k @ k


def _draw(rng, X0: np.ndarray, n: int, dt: float, sd: dict, sd_c, sd_b: float) -> np.ndarray:
    """One noisy copy of the noise-free samples X0 (K, len), corrupted as the filter's model
    says: white noise of the filter's sds on r_S, v_S, omega_B, q, qd; the star tracker as
    A R(w), w white about the base axes; a constant gyro bias (drawn from its prior) on
    omega_B; the thrust's scale factor and misalignment c = [s_F, phi_F, s_M, phi_M] (drawn
    from their priors) to first order on F, M, on J = int F dt (J + s_F J + phi_F x J) and on
    H = int (M + r_S x F) dt (the errors integrated with the held thrust, as the sensors do)."""
    K = len(X0)
    X = X0.copy()
    X[:, 0:3] += sd["r"] * rng.standard_normal((K, 3))
    X[:, 3:6] += sd["v"] * rng.standard_normal((K, 3))
    w = rng.standard_normal((K, 3)) * np.asarray(sd["att"])
    X[:, 6:15] = (X0[:, 6:15].reshape(K, 3, 3) @ _rotations(w)).reshape(K, 9)
    X[:, 15:18] += sd_b * rng.standard_normal(3) + sd["omega"] * rng.standard_normal((K, 3))
    X[:, 24:24 + n] += sd["q"] * rng.standard_normal((K, n))
    X[:, 24 + n:24 + 2 * n] += sd["qd"] * rng.standard_normal((K, n))
    c = np.asarray(sd_c) * rng.standard_normal(8)
    f = 24 + 3 * n                                   # F, M, J, H
    F, M, J = X0[:, f:f + 3], X0[:, f + 3:f + 6], X0[:, f + 6:f + 9]
    eF, eM = c[0] * F + np.cross(c[1:4], F), c[4] * M + np.cross(c[5:8], M)
    X[:, f:f + 3] += eF
    X[:, f + 3:f + 6] += eM
    X[:, f + 6:f + 9] += c[0] * J + np.cross(c[1:4], J)
    dH = dt * (eM + np.cross(X0[:, 0:3], eF))
    X[:, f + 9:f + 12] += np.vstack([np.zeros(3), np.cumsum(dH, axis=0)[:-1]])
    return X


def _monte_carlo(L, dt: float, stop_time: float, draws: int, scale: float, P0: float,
                 seed: int = 2029, params=None):
    """The spatial default scenario's noise-free run, then ``draws`` runs of a fresh filter
    linearised at the truth over independent noisy copies of it; the prior's mean drawn from
    the prior itself (z_O ~ N(z_O,true, P0)) every draw. Returns (bound at the truth (20),
    errors (draws, 20) uncompensated, compensated, bounds (draws, 20), chi2 (draws,), the
    oracle's correlation matrix of the estimates (20 x 20))."""
    sc = scenario("spatial")
    n = sc.robot.n_joints
    ts, X0 = record(sc, dt, stop_time)
    sd, sd_c, sd_b = sensor_noise(default_parameters() if params is None else params, dt, scale)
    nv = noise_vector(sd, sd_c, sd_b)
    truth = truth_of(sc)
    filt = CFilter(L, c_robot(sc.robot, L), nv, truth, P0, P0)
    assert filt.status == 0

    def run(X):
        filt.reset()
        for t, x in zip(ts, X):
            assert filt.add(t, x, truth) == 0
        (s0, v0, b0, chi2), (s1, v1, _, _) = filt.estimate(False), filt.estimate(True)
        assert s0 == 0 and s1 == 0
        return v0, v1, b0, chi2

    v0, _, bound, _ = run(X0)
    # noise-free: the rows hold exactly at the truth (the compensation, an expected noise
    # share subtracted from data without noise, moves it: not checked here)
    assert np.all(np.abs(v0 - truth) <= 1e-3 * bound)
    # the oracle's whole covariance there (the C filter reports the sds only)
    o = InformationFilter(L, c_robot(sc.robot, L), n, False, sd, sd_c, P0, P0,
                          z_of_reported(truth), sd_gyro_bias=sd_b, refresh=REFRESH)
    for t, x in zip(ts, X0):
        o.add(t, x, z_of_reported(truth))
    _, b_o = o.result(False)
    assert np.all(np.abs(b_o / bound - 1) <= 1e-4)
    corr = o.cov_reported / np.outer(b_o, b_o)
    rng = np.random.default_rng(seed)
    zo_truth = origin_of_com(z_of_reported(truth))
    e0, e1, bs, chis = [], [], [], []
    for _ in range(draws):
        z0 = reported_of_z(com_of_origin(zo_truth + math.sqrt(P0) * rng.standard_normal(20)))
        assert filt.init(nv, z0, P0, P0) == 0
        v0, v1, b, chi2 = run(_draw(rng, X0, n, dt, sd, sd_c, sd_b))
        e0.append(v0 - truth)
        e1.append(v1 - truth)
        bs.append(b)
        chis.append(chi2)
    return bound, np.array(e0), np.array(e1), np.array(bs), np.array(chis), corr


#: draws of the Monte Carlo
DRAWS = 150


@pytest.mark.slow
def test_bound_matches_monte_carlo(lib):
    """The bound is the estimates' scatter: the spatial default scenario, 2 s sampled every
    10 ms (201 samples), every random input drawn from the filter's own model (the white noise
    of the sensors' realistic sds, the gyro bias and thrust errors from their priors, the prior
    mean of the inertial parameters from N(truth, P0), P0 = 25 so that every draw has
    positive masses), all noise magnitudes times 1e-5 (first order: the errors in variables
    bias the uncompensated estimate by many bounds at the realistic level and this sample rate
    and leave a second-order remainder in the compensated one; measured largest |mean error|
    in bound/sqrt(N), uncompensated and compensated: 7.6 and 1.7 at 1e-3, 3.1 and 2.2 at
    1e-4, 2.4 and 2.3 at 1e-5; sample sd / bound 0.93 to 1.15, chi2 1.027); a fresh filter per
    draw linearised at the truth. With the inputs Gaussian and the model linear in them to
    first order, each estimate's error is N(0, bound^2), so over N draws

    * sample sd / bound in 1 +- 4/sqrt(2N) (the sample sd's relative sd is 1/sqrt(2(N-1)));
    * |mean error| <= 4 bound / sqrt(N);
    * the whole covariance (the correlations from the oracle's inverse information, whose sds
      agree with the C bound's within 1e-9 here): the errors' squared Mahalanobis length is
      chi-square with 20 degrees of freedom, its mean over the draws 20 within
      4 sqrt(40/N) (measured 20.15; the correlation matrix's condition number is 1e10, so
      this also weighs the nearly unidentified combinations);
    * the weighted residual sum of squares is chi-square with rows - 6 degrees of freedom (the
      priors' means drawn from the priors count as observations of all unknowns but the
      momentum c0, whose prior carries no information): sr_info_estimate's chi2 (that sum
      over rows - nu) averages (rows - 6) / (rows - nu) = 1.027 within 4 sqrt(2/rows)/sqrt(N)
      (measured 1.027);

    for the uncompensated and the compensated estimates. The sample interval: 10 ms (the
    scenario's 0.1 s: :func:`test_bound_monte_carlo_at_a_tenth_of_a_second`)."""
    _check_monte_carlo(*_monte_carlo(lib, 0.01, 2.0, DRAWS, 1e-5, 25.0), rows=201 * 6)


def _check_monte_carlo(bound, e0, e1, bs, chis, corr, rows: int) -> None:
    N = len(e0)
    assert np.all(np.abs(bs / bound - 1) < 1e-2)           # the bound hardly moves with noise
    tol = 4 / math.sqrt(2 * N)
    for name, e in (("uncompensated", e0), ("compensated", e1)):
        ratio = e.std(axis=0, ddof=1) / bound
        mean = e.mean(axis=0) / (bound / math.sqrt(N))
        assert np.all(np.abs(ratio - 1) <= tol), (name, ratio)
        assert np.all(np.abs(mean) <= 4), (name, mean)
        z = e / bound
        d2 = np.einsum("ij,ij->i", z, np.linalg.solve(corr, z.T).T)
        assert abs(d2.mean() - 20) <= 4 * math.sqrt(40 / N), (name, d2.mean())
    nu = 20 + 6 + 8 + 3
    expected = (rows - 6) / (rows - nu)
    assert abs(chis.mean() - expected) <= 4 * math.sqrt(2 / rows) / math.sqrt(N), chis.mean()


@pytest.mark.slow
def test_bound_monte_carlo_at_a_tenth_of_a_second(lib):
    """As :func:`test_bound_matches_monte_carlo` at the scenario's own sample interval (0.1 s,
    15 s: 151 samples). The rows' noise covariance R_k is ill-conditioned (eigenvalues over 7
    decades: the angular rows' noise from r_S x the momentum dwarfs the rest) and moves from
    sample to sample: held over 10 samples (the first version) the weights went stale and the
    bound was optimistic (sample sd / bound 1.07 to 1.47, chi2 1.11); recomputed every sample
    (SR_INFO_REFRESH = 1) measured 0.90 to 1.05 and chi2 1.036 (expected 1.036)."""
    _check_monte_carlo(*_monte_carlo(lib, 0.1, 15.0, DRAWS, 1e-4, 25.0), rows=151 * 6)


def test_bound_covers_the_navigation_noises_product(lib):
    """Navigation noise alone at the realistic level (1 cm, 1 mm/s per sample; every other
    source 0), the spatial default scenario's 15 s at 0.1 s: its angular rows about the
    inertial origin hold M r_S x v_S, whose first-order noise (dr x M v, r x M dv) leaves the
    rows along the drift almost noise-free, while the product dr x M dv is not (zero mean,
    sd sd_r sd_v M per axis). Without that term in R_k (the first-order model alone) the bound
    was far too small here (measured sample sd / bound 16 to 39 uncompensated, 400 and more
    compensated, chi2 211 against 1.023); with it the errors' scatter is the bound: sample sd /
    bound within 1 +- 4/sqrt(2N) for the uncompensated and the compensated estimates (measured
    0.93 to 1.14 and 0.97 to 1.21), the chi2 as in :func:`test_bound_matches_monte_carlo`
    (measured 1.029). The mean is not checked: at this level the errors-in-variables
    compensation leaves a second-order remainder (see :func:`test_bound_matches_monte_carlo`)."""
    nav = {k: 0.0 for k in default_parameters()}
    nav["nav.r"], nav["nav.v"] = default_parameters()["nav.r"], default_parameters()["nav.v"]
    bound, e0, e1, bs, chis, _ = _monte_carlo(lib, 0.1, 15.0, DRAWS, 1.0, 25.0, params=nav)
    N = len(e0)
    tol = 4 / math.sqrt(2 * N)
    for name, e in (("uncompensated", e0), ("compensated", e1)):
        ratio = e.std(axis=0, ddof=1) / bound
        assert np.all(np.abs(ratio - 1) <= tol), (name, ratio)
    rows = 151 * 6
    nu = 20 + 6
    expected = (rows - 6) / (rows - nu)
    assert abs(chis.mean() - expected) <= 4 * math.sqrt(2 / rows) / math.sqrt(N), chis.mean()


@pytest.mark.slow
def test_compensation_bias_small_under_a_fast_drift(lib):
    """The errors-in-variables compensation where it is largest: the spatial robot with the
    flexible sets' motion (0.37 m/s drift, 0.06 rad/s; no wings or slosh) at 0.2 rad, 300 s at
    0.1 s, 12 draws of every random input from the filter's own model at the realistic level
    (white noise, the gyro bias and the thrust errors from their priors), a fresh filter
    linearised at the truth, the exact compensation (the estimator's). The uncompensated
    estimate is 33-36 bounds off here (the rows' r_S x M v_S about the origin, over 100 m away
    by the end). Over the draws each estimate's mean error within 1.5 bounds (its own sampling
    sd is about 0.25 bound) and at least 90 % of all within 2 bounds: measured 0.74 and 95.8 %.
    Counting the navigation noises' product twice in N (the slopes in r_S taken at the
    measured v_S and the other way round; before the fix) the masses were 3.0 bounds high and
    55 % within 2."""
    from dataclasses import replace
    from spacerobot.robots import Excitation, parameter_set_scenario
    sc = parameter_set_scenario("spatial", "wings")
    sc = replace(sc, flex=replace(sc.flex, n=0), excitation=Excitation(att_max=0.2, q_max=0.2))
    n, dt = sc.robot.n_joints, 0.1
    ts, X0 = record(sc, dt, 300.0)
    sd, sd_c, sd_b = sensor_noise(default_parameters(), dt)
    truth = truth_of(sc)
    filt = CFilter(lib, c_robot(sc.robot, lib), noise_vector(sd, sd_c, sd_b), guess_of(sc),
                   sc.guess.P0_mu, sc.guess.P0_theta)
    assert filt.status == 0
    rng = np.random.default_rng(7)
    z = []
    for _ in range(12):
        filt.reset()
        for t, x in zip(ts, _draw(rng, X0, n, dt, sd, sd_c, sd_b)):
            assert filt.add(t, x, truth) == 0
        st, vec, bound, _ = filt.estimate(2)
        assert st == 0 and np.all(bound > 0)
        z.append((vec - truth) / bound)
    z = np.array(z)
    assert np.max(np.abs(z.mean(axis=0))) <= 1.5, z.mean(axis=0)
    assert np.mean(np.abs(z) <= 2.0) >= 0.9, np.mean(np.abs(z) <= 2.0)


# ------------------------------------------------------------------------------------------
# c. bad input
# ------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def small(lib):
    """The spatial default scenario's first 3 s (realistic sensors), the C filter's inputs."""
    sc = scenario("spatial")
    ts, X = record(sc, 0.1, 3.0, sensors_seed=1)
    sd, sd_c, sd_b = sensor_noise(default_parameters(), 0.1)
    return sc, c_robot(sc.robot, lib), noise_vector(sd, sd_c, sd_b), ts, X


def test_model_init_refuses_bad_input(lib, small):
    """Negative or non-finite sds, no white noise at all (nothing to weigh the rows by), a
    guess mass <= 0 or non-finite guess, P0 <= 0 or non-finite, n out of range: status 1; the
    good inputs: 0."""
    sc, rob, nv, _, _ = small
    g, z0 = sc.guess, guess_of(sc)
    f = CFilter(lib, rob, nv, z0, g.P0_mu, g.P0_theta)
    assert f.status == 0
    assert f.init(np.zeros(N_NOISE), z0, 1.0, 1.0) == 1       # no white noise: refused
    one = np.zeros(N_NOISE)
    one[0] = 0.01                                           # navigation position only
    assert f.init(one, z0, 1.0, 1.0) == 0                   # noise-free channels allowed
    for i in range(N_NOISE):
        for bad in (-1e-9, -1.0, math.nan, math.inf):
            v = nv.copy()
            v[i] = bad
            assert f.init(v, z0, g.P0_mu, g.P0_theta) == 1, (i, bad)
    for i in (0, 10):
        for bad in (0.0, -500.0, math.nan):
            z = z0.copy()
            z[i] = bad
            assert f.init(nv, z, g.P0_mu, g.P0_theta) == 1, (i, bad)
    for i in (1, 4, 14, 19):
        z = z0.copy()
        z[i] = math.inf
        assert f.init(nv, z, g.P0_mu, g.P0_theta) == 1, i
    for bad in (0.0, -1.0, math.nan, math.inf):
        assert f.init(nv, z0, bad, g.P0_theta) == 1, bad
        assert f.init(nv, z0, g.P0_mu, bad) == 1, bad
    empty = SrRobot()                                       # n = 0
    ctypes.memmove(ctypes.byref(empty), ctypes.byref(rob), ctypes.sizeof(SrRobot))
    for n_bad in (0, -1, 10 ** 6):
        empty.n = n_bad
        m = ctypes.create_string_buffer(lib.sr_info_model_size())
        assert lib.sr_info_model_init(m, ctypes.byref(empty), _p(nv), _p(z0), 1.0, 1.0) == 1
    m = ctypes.create_string_buffer(lib.sr_info_model_size())
    assert lib.sr_info_model_init(None, ctypes.byref(rob), _p(nv), _p(z0), 1.0, 1.0) == 1
    assert lib.sr_info_model_init(m, None, _p(nv), _p(z0), 1.0, 1.0) == 1
    assert lib.sr_info_model_init(m, ctypes.byref(rob), None, _p(z0), 1.0, 1.0) == 1
    assert lib.sr_info_model_init(m, ctypes.byref(rob), _p(nv), None, 1.0, 1.0) == 1


#: the tail of sr_info_data (information.h): int misfit, its padding, double me_var[2], int
#: noise_misfit, int scale_misfit, in the last MISFIT_TAIL bytes
MISFIT_TAIL_FORMAT, MISFIT_TAIL = "<i4xddii", 32


def test_state_check_refuses_inconsistent_misfit_flags(lib, small):
    """sr_info_data_finite on a state before the replay: clean, accepted; each word of the
    Data's tail written as the integer 1 (the tail is int misfit, its padding, double
    me_var[2], int noise_misfit, int scale_misfit: information.h) is refused where it is a
    field (a misfit or a model-error variance before any replay: 7 of the 8 words) and
    accepted in the padding; the word 2 in a flag is refused too (out of 0..1)."""
    sc, rob, nv, ts, X = small
    g = sc.guess
    f = CFilter(lib, rob, nv, guess_of(sc), g.P0_mu, g.P0_theta)
    for t, x in zip(ts[:20], X[:20]):
        assert f.add(t, x, guess_of(sc)) == 0
    lib.sr_info_data_finite.argtypes = [ctypes.c_void_p, ctypes.c_void_p]
    lib.sr_info_data_finite.restype = ctypes.c_int
    clean = f.data.raw
    assert lib.sr_info_data_finite(f.model, f.data) == 1
    size = len(clean)
    refused = []
    for off in range(size - MISFIT_TAIL, size, 4):
        bad = bytearray(clean)
        struct.pack_into("<i", bad, off, 1)
        ctypes.memmove(f.data, bytes(bad), size)
        if lib.sr_info_data_finite(f.model, f.data) == 0:
            refused.append(off - (size - MISFIT_TAIL))
    assert refused == [0, 8, 12, 16, 20, 24, 28], refused
    for off in (size - MISFIT_TAIL, size - 8, size - 4):
        bad = bytearray(clean)
        struct.pack_into("<i", bad, off, 2)
        ctypes.memmove(f.data, bytes(bad), size)
        assert lib.sr_info_data_finite(f.model, f.data) == 0, off
    ctypes.memmove(f.data, clean, size)
    assert lib.sr_info_data_finite(f.model, f.data) == 1


@pytest.mark.slow
def test_state_check_after_the_replay_allows_one_cause(lib):
    """sr_info_data_finite on a state after the replay (SR_INFO_REPLAY samples through
    sr_info_step; 61 s of the rigid default scenario, realistic sensors): accepted with the
    misfit flags as the replay set them and with them cleared; each cause alone (model with
    its model-error variances, noise, thrust scale) accepted, as the replay may set it; any two
    causes together refused (the fit test gives one cause), and model-error variances without
    the model cause refused."""
    sc = scenario("spatial")
    ts, X = record(sc, 0.1, 61.0, sensors_seed=3)
    sd, sd_c, sd_b = sensor_noise(default_parameters(), 0.1)
    rob = c_robot(sc.robot, lib)
    g = sc.guess
    f = CFilter(lib, rob, noise_vector(sd, sd_c, sd_b), guess_of(sc), g.P0_mu, g.P0_theta)
    vp = ctypes.c_void_p
    lib.sr_info_step.argtypes = [vp, vp, vp, _DP, ctypes.c_double, _DP, _DP, vp]
    lib.sr_info_step.restype = ctypes.c_int
    lib.sr_info_buffer_length.argtypes = [ctypes.c_int]
    lib.sr_info_buffer_length.restype = ctypes.c_size_t
    lib.sr_info_data_finite.argtypes = [vp, vp]
    lib.sr_info_data_finite.restype = ctypes.c_int
    buffer = np.zeros(lib.sr_info_buffer_length(sc.robot.n_joints))
    nxt = ctypes.create_string_buffer(len(f.data.raw))
    z = np.ascontiguousarray(guess_of(sc))
    for t, x in zip(ts, X):
        x = np.ascontiguousarray(x, float)
        assert lib.sr_info_step(f.model, f.data, nxt, _p(buffer), float(t), _p(x), _p(z),
                                f.work) == 0
        ctypes.memmove(f.data, nxt, len(nxt.raw))
    size = len(f.data.raw)
    assert len(ts) > REPLAY_SAMPLES                  # the replay is behind this state
    tail = size - MISFIT_TAIL
    misfit, v0, v1, noise, scale = struct.unpack_from(MISFIT_TAIL_FORMAT, f.data.raw, tail)
    assert misfit + noise + scale <= 1 and lib.sr_info_data_finite(f.model, f.data) == 1
    clean = bytearray(f.data.raw)                    # the replayed state without a misfit
    struct.pack_into(MISFIT_TAIL_FORMAT, clean, tail, 0, 0.0, 0.0, 0, 0)
    clean = bytes(clean)

    def verdict(misfit, me_var, noise, scale) -> int:
        bad = bytearray(clean)
        struct.pack_into(MISFIT_TAIL_FORMAT, bad, tail, misfit, me_var, me_var, noise, scale)
        ctypes.memmove(f.data, bytes(bad), size)
        return lib.sr_info_data_finite(f.model, f.data)
    assert verdict(1, 1e-4, 0, 0) == 1 and verdict(0, 0.0, 1, 0) == 1
    assert verdict(0, 0.0, 0, 1) == 1
    assert verdict(1, 1e-4, 1, 0) == 0 and verdict(1, 1e-4, 0, 1) == 0
    assert verdict(0, 0.0, 1, 1) == 0 and verdict(0, 1e-4, 0, 0) == 0
    ctypes.memmove(f.data, clean, size)
    assert lib.sr_info_data_finite(f.model, f.data) == 1


def test_prior_before_any_sample(lib, small):
    """Before any sample: the guesses, each mass's bound sqrt(P0_mu) (the mass is an unknown
    itself), chi2 0."""
    sc, rob, nv, _, _ = small
    g = sc.guess
    f = CFilter(lib, rob, nv, guess_of(sc), g.P0_mu, g.P0_theta)
    st, vec, bound, chi2 = f.estimate(False)
    assert st == 0 and chi2 == 0.0
    assert np.allclose(vec, guess_of(sc), rtol=1e-9, atol=1e-9)
    assert np.allclose(bound[[0, 10]], math.sqrt(g.P0_mu), rtol=1e-6)


def test_add_refuses_bad_input_and_keeps_the_state(lib, small):
    """A linearisation point with a mass <= 0 or non-finite numbers, a sample with a NaN or an
    infinity in any channel the rows read, a time not after the last one's: status 1 and the
    Data bytes unchanged; the run then
    goes on as if those calls had not been made (the same bytes as a run without them)."""
    sc, rob, nv, ts, X = small
    g, truth = sc.guess, truth_of(sc)
    f = CFilter(lib, rob, nv, guess_of(sc), g.P0_mu, g.P0_theta)
    ref = CFilter(lib, rob, nv, guess_of(sc), g.P0_mu, g.P0_theta)
    n = sc.robot.n_joints
    f0 = 24 + 3 * n
    read = [0, 4, 8, 16, 24, 24 + n + 2, f0, f0 + 4, f0 + 7, f0 + 11]   # r, v, A, w, q, qd, F..H
    for k, (t, x) in enumerate(zip(ts, X)):
        if k in (0, 5, 17):
            before = f.data.raw
            for i in (0, 10):
                for bad in (0.0, -1.0, math.nan):
                    z = truth.copy()
                    z[i] = bad
                    assert f.add(t, x, z) == 1, (k, i, bad)
                    assert f.data.raw == before
            for i in (1, 5, 15):
                z = truth.copy()
                z[i] = math.nan
                assert f.add(t, x, z) == 1, (k, i)
                assert f.data.raw == before
            for i in read:
                for bad in (math.nan, math.inf):
                    xb = x.copy()
                    xb[i] = bad
                    assert f.add(t, xb, truth) == 1, (k, i, bad)
                    assert f.data.raw == before
            # a time not after the last sample's (the thrust integrals' step), or not finite
            for bad_t in ((math.nan, math.inf) if k == 0 else (ts[k - 1], ts[k - 1] - 1.0,
                                                                math.nan)):
                assert f.add(bad_t, x, truth) == 1, (k, bad_t)
                assert f.data.raw == before
        assert f.add(t, x, truth) == 0
        assert ref.add(t, x, truth) == 0
    assert f.data.raw == ref.data.raw
    assert lib.sr_info_add(None, f.data, 0.0, _p(X[0]), _p(truth), f.work) == 1
    assert lib.sr_info_add(f.model, None, 0.0, _p(X[0]), _p(truth), f.work) == 1
    assert lib.sr_info_add(f.model, f.data, 0.0, None, _p(truth), f.work) == 1
    assert lib.sr_info_add(f.model, f.data, 0.0, _p(X[0]), None, f.work) == 1
    assert lib.sr_info_add(f.model, f.data, 0.0, _p(X[0]), _p(truth), None) == 1
    v = np.zeros(20)
    assert lib.sr_info_estimate(f.model, None, 1, _p(v), _p(v), None) == 1
    assert lib.sr_info_estimate(f.model, f.data, 1, None, _p(v), None) == 1


# ------------------------------------------------------------------------------------------
# d. through the estimator
# ------------------------------------------------------------------------------------------

def _estimator_values(sc, **extra) -> dict:
    from spacerobot.interface import estimator_parameter_values
    vals = estimator_parameter_values(sc.robot, sc)
    vals.update({"ident.noise_profile": 1, "method": 2, "accel_source": 2}, **extra)
    return vals


def _on_off_and_twin(lib, sc, dt: float):
    """The estimator's options with the noise profile (the filter automatic), the guesses
    (20), the estimator with the filter (on) and off (``ident.information`` = 2), and a native
    filter with the noise model those options imply (computed here from the sensor
    magnitudes, noise.scale and the sample interval) to drive by hand (twin)."""
    from spacerobot.core.estimator import NativeEstimator, options_from_values
    from spacerobot.interface import SENSOR_MAGNITUDES
    opts = {**options_from_values(_estimator_values(sc)), "noise_dt": dt}
    off_opts = {**options_from_values(_estimator_values(sc, **{"ident.information": 2})),
                "noise_dt": dt}
    on = NativeEstimator(sc.robot, opts, lib=lib)
    off = NativeEstimator(sc.robot, off_opts, lib=lib)
    mags = {name[len("noise."):]: v for name, v in zip(SENSOR_MAGNITUDES, opts["noise"])}
    sd, sd_c, sd_b = sensor_noise(mags, dt, opts["noise_scale"])
    guess = np.array(opts["guess_base"] + opts["guess_target"])
    twin = CFilter(lib, c_robot(sc.robot, lib), noise_vector(sd, sd_c, sd_b), guess,
                   opts["P0_mu"], opts["P0_theta"])
    assert twin.status == 0
    return opts, guess, on, off, twin


def test_estimator_reports_the_filter(lib):
    """``ident.information`` automatic (on with the noise profile and white noise): the
    estimator's ``crb`` is the bound of a native filter driven beside it with the noise model
    the estimator's options imply (computed here from the sensor magnitudes, noise.scale and
    the sample interval) and linearised where the estimator says it linearises (its own
    equations' physical estimates before each sample: those an estimator with the filter off
    reports), within 1e-9 relative; its least-squares estimates the filter's compensated ones
    within 1e-9 of the bound; its sd the bound times sqrt(max(1, chi2)) with ident.eiv_uncertainty's
    share of the errors-in-variables correction (the filter's compensated less its
    uncompensated estimates). Off
    (``ident.information`` = 2): crb and info_chi2 0, and the estimates those of an estimator
    without the profile given the profile's options explicitly (the equations' own)."""
    from spacerobot.core.estimator import NativeEstimator, options_from_values, profile_values
    dt = 0.1
    sc = scenario("spatial")
    ts, X = record(sc, dt, 8.0, sensors_seed=1)
    opts, guess, on, off, twin = _on_off_and_twin(lib, sc, dt)
    # the equations' own estimator: the profile's options given explicitly, no profile
    plain_vals = {**_estimator_values(sc), **profile_values(_estimator_values(sc), dt, lib),
                  "ident.noise_profile": 0, "ident.information": 0}   # (the filter needs it)
    plain = NativeEstimator(sc.robot, {**options_from_values(plain_vals), "noise_dt": dt},
                            lib=lib)
    for t, x in zip(ts, X):
        z_lin = off.report()["vector"]
        if not (z_lin[0] > 0 and z_lin[10] > 0):
            z_lin = guess
        assert twin.add(t, x, z_lin) == 0
        for e in (on, off, plain):
            assert e.update(t, x) in (1, 2), e.message      # accepted
    r_on, r_off, r_plain = on.report(), off.report(), plain.report()
    st, vec, bound, chi2 = twin.estimate(2)              # exactly compensated, as reported
    assert st == 0 and np.all(bound > 0)
    assert np.all(np.abs(r_on["crb"] - bound) <= 1e-9 * bound), np.max(
        np.abs(r_on["crb"] / bound - 1))
    assert abs(r_on["info_chi2"] - chi2) <= 1e-9 * chi2
    ls, sd_on = on.estimates()
    assert np.all(np.abs(ls - vec) <= 1e-9 * bound), np.max(np.abs(ls - vec) / bound)
    # the sd: the bound times sqrt(max(1, chi2)) and ident.eiv_uncertainty (0.05) of the
    # errors-in-variables correction (the compensated less the uncompensated estimate)
    st0, vec0, _, _ = twin.estimate(0)
    assert st0 == 0
    want = np.hypot(bound * math.sqrt(max(1.0, chi2)), 0.05 * (vec - vec0))
    assert np.allclose(sd_on, want, rtol=1e-9, atol=0)
    assert np.max(np.abs(vec - vec0) * 0.05 / bound) > 0.01      # the term is exercised
    assert np.allclose(r_on["sd"], sd_on, rtol=1e-12, atol=0)
    # off: no bound, the equations' own estimates (not the filter's)
    assert np.all(r_off["crb"] == 0) and r_off["info_chi2"] == 0
    ls_off, sd_off = off.estimates()
    ls_plain, sd_plain = plain.estimates()
    assert np.allclose(ls_off, ls_plain, rtol=1e-9, atol=1e-12)
    assert np.allclose(sd_off, sd_plain, rtol=1e-9, atol=1e-15)
    assert np.all(r_plain["crb"] == 0)
    assert np.max(np.abs(ls_off - ls) / bound) > 1.0


@pytest.mark.slow
def test_the_replay_relinearises_the_first_samples(lib):
    """``sr_info_step`` inside the estimator (SR_INFO_REPLAY = 600 samples): the first 600
    samples linearised at the estimator's own equations' estimates, then, at sample 600, the
    filter restarted from its prior and those samples with this one added again at its own
    exactly compensated estimate, and from then on its own estimate refreshed every 10
    samples (SR_INFO_RELIN). Driven here by hand with ``sr_info_add`` on a twin filter over
    65 s of the default scenario with realistic sensors: the estimator's bound and estimates
    equal the twin's within 1e-9 (relative; of the bound)."""
    dt, replay, relin = 0.1, 600, 10
    sc = scenario("spatial")
    ts, X = record(sc, dt, 65.0, sensors_seed=2)
    opts, guess, on, off, twin = _on_off_and_twin(lib, sc, dt)
    kept, z_lin = [], None
    for k, (t, x) in enumerate(zip(ts, X)):
        if k < replay:
            z = off.report()["vector"]
            z = z if (z[0] > 0 and z[10] > 0) else guess
            kept.append((t, x))
            assert twin.add(t, x, z) == 0
        else:
            if k % relin == 0:                        # the filter's sample count is k then
                st, own, _, _ = twin.estimate(2)      # (at the replay: its estimate before)
                assert st == 0 and own[0] > 0 and own[10] > 0
                z_lin = own
            if k == replay:
                twin.reset()
                for tk, xk in kept:
                    assert twin.add(tk, xk, z_lin) == 0
            assert twin.add(t, x, z_lin) == 0
        for e in (on, off):
            assert e.update(t, x) in (1, 2), e.message
    r = on.report()
    st, vec, bound, chi2 = twin.estimate(2)
    assert st == 0 and len(ts) > replay + 3 * relin
    assert np.all(np.abs(r["crb"] - bound) <= 1e-9 * bound), np.max(np.abs(r["crb"] / bound - 1))
    ls, _ = on.estimates()
    assert np.all(np.abs(ls - vec) <= 1e-9 * bound), np.max(np.abs(ls - vec) / bound)


def test_information_on_needs_white_noise():
    """ident.information = 1 with the sensors' noise scaled to 0: refused at creation with the
    reason (every sample would otherwise be rejected: no noise to weigh the rows by)."""
    from spacerobot.core.estimator import NativeEstimator, options_from_values
    sc = scenario("spatial")
    opts = options_from_values(_estimator_values(sc, **{"ident.information": 1,
                                                        "noise.scale": 0.0}))
    with pytest.raises(ValueError, match="ident.information = 1 needs white sensor noise"):
        NativeEstimator(sc.robot, opts)


@pytest.mark.slow
def test_a_corrupted_replay_buffer_costs_the_replay_not_the_filter(lib):
    """A restored state whose kept samples hold a NaN (the buffer is not checked sample by
    sample): the replaying sample is accepted without the replay (the filter goes on from its
    state before), and so are the samples after it; their bound stays finite."""
    from spacerobot.core.estimator import NativeEstimator, options_from_values
    dt = 0.1
    sc = scenario("spatial")
    ts, X = record(sc, dt, 61.0, sensors_seed=4)
    est = NativeEstimator(sc.robot, {**options_from_values(_estimator_values(sc)),
                                     "noise_dt": dt}, lib=lib)
    for t, x in zip(ts[:600], X[:600]):
        assert est.update(t, x) in (1, 2), est.message
    state = bytearray(est.get_state())
    kept = np.concatenate([[ts[5]], X[5]]).tobytes()       # the kept sample 5: [t, x]
    at = bytes(state).find(kept)
    assert at >= 0 and bytes(state).find(kept, at + 1) < 0
    state[at + 8:at + 16] = np.array([math.nan]).tobytes()   # its r_S[0]
    est.set_state(bytes(state))
    for t, x in zip(ts[600:], X[600:]):
        assert est.update(t, x) in (1, 2), est.message
    assert np.all(np.isfinite(est.report()["crb"])) and np.all(est.report()["crb"] > 0)


#: SR_INFO_REPLAY (native/src/information.h): the filter relinearises at its own estimate
#: with this many samples (docs/identification.md: the flags wait for it)
REPLAY_SAMPLES = 600


def test_flags_follow_the_bonferroni_rule_and_the_hold(lib):
    """With the filter a body is flagged when (1) each of its 10 estimates has
    sd <= sd_rel * scale / z, z the two-sided normal quantile (SciPy's, an independent
    algorithm) of (1 - ident.flag_confidence) / 10, scale the error scale of the reported
    estimate (the report is then the least-squares estimate: no projection), (2) the filter has
    replayed (its 600th sample) and (3) the hold: since a reference sample r at least
    ident.fit_window T old (the newest of the snapshots taken every T / 4: r is between T and
    T + T / 4 + dt old) each estimate moved by at most z sqrt(sd_r^2 - sd^2) (+ 1 % of the
    threshold). Checked at every sample of an 80 s run with a 0.13 % threshold and T = 5 s: a
    flag implies (1), (2) and (3) against some sample of that age; where (1), (2) hold and (3)
    holds against every sample of that age, the flag is up. The threshold lies between the two
    confidences' z times the sds after the replay: 0.6 flags from 65 s, 0.99 not by 80 s."""
    from scipy.stats import norm
    from spacerobot.core.estimator import NativeEstimator, options_from_values
    from spacerobot.interface import error_scale
    dt, sd_rel, T = 0.1, 0.0013, 5.0
    sc = scenario("spatial")
    ts, X = record(sc, dt, 80.0, sensors_seed=2)
    first = {}
    for conf in (0.99, 0.6):
        z = norm.isf((1.0 - conf) / 10 / 2)
        vals = _estimator_values(sc, **{"ident.sd_rel": sd_rel, "ident.flag_confidence": conf,
                                        "ident.fit_window": T})
        est = NativeEstimator(sc.robot, {**options_from_values(vals), "noise_dt": dt}, lib=lib)
        hist, up, must = [], 0, 0
        for i, (t, x) in enumerate(zip(ts, X)):
            assert est.update(t, x) in (1, 2), est.message
            r = est.report()
            ls, sd = est.estimates()
            hist.append((t, ls, sd))
            if i < REPLAY_SAMPLES:      # the first sample is the reference: 600 filter samples
                assert not any(r["identified"].values()), (conf, t)
                continue
            if not np.array_equal(r["vector"], ls):
                assert not any(r["identified"].values())  # projected: the flags stay down
                continue
            scale = error_scale(r["vector"])
            ratio = sd / (sd_rel * scale)
            refs = [(l0, s0) for t0, l0, s0 in hist      # the snapshots start at the replay
                    if T - 1e-9 <= t - t0 <= 1.25 * T + dt + 1e-9 and t0 >= ts[REPLAY_SAMPLES]]
            for k, who in enumerate(("base", "target")):
                b = slice(10 * k, 10 * k + 10)
                worst = ratio[b].max()
                if abs(worst * z - 1.0) < 1e-9:
                    continue                             # on the edge: round-off decides
                holds = [np.max(np.abs(ls[b] - l0[b])
                                - z * np.sqrt(np.maximum(s0[b] ** 2 - sd[b] ** 2, 0.0))
                                - 0.01 * sd_rel * scale[b]) for l0, s0 in refs]
                if r["identified"][who]:
                    assert worst * z < 1.0, (conf, t, who, worst * z)
                    assert refs and min(holds) <= 1e-12 * scale[b].max(), (conf, t, who)
                    first.setdefault((conf, who), t)
                    up += 1
                if (worst * z < 1.0 and refs and max(holds) < -1e-9 * scale[b].max()
                        and t - ts[REPLAY_SAMPLES] >= 1.25 * T + dt):
                    assert r["identified"][who], (conf, t, who)
                    must += 1
        if conf == 0.6:
            assert up > 100 and must > 100, (up, must)
    assert first[(0.6, "target")] < first.get((0.99, "target"), math.inf), first
