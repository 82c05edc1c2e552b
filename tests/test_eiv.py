"""The force method's noisy accelerations, compensated (issue 14; the native Identifier, and the
NumPy oracle's :mod:`oracles.estimator.eiv`).

* The equations are affine in the accelerations (what the noise rows assume): a step of any
  size in one acceleration moves the equation array by that step times the unit step's change.
* On a synthetic errors-in-variables problem (independent of the spacecraft code) the
  compensated normal equations remove the attenuation that plain least squares shows.
* On an excited noise-free run with white noise added to the accelerations only (the sensors
  model, every other error off), the plain force method underestimates the masses; the
  compensated one does not, for both solvers (the native Identifier); with differenced accelerations the compensated
  estimate returns to the noise-free run's.
* Zero noise settings: bit for bit the plain estimator; state round trip; bad values refused.
"""
from __future__ import annotations

import numpy as np
import pytest

from oracles import estimator as oracle
from oracles.estimator import kernels
from spacerobot.estimator import Identifier
from oracles.estimator.eiv import accel_channels, compensation
from spacerobot.estimator.identifier import KEYS, identifier_from_values
from spacerobot.interface import estimate_vector
from oracles.kinematics import ArmGeometry
from spacerobot.robots import get_robot
from oracles.sensors import SensorSuite  # the NumPy sensor models: test data
from spacerobot.sensors import default_parameters, estimator_noise_settings
from spacerobot.system.identify import estimator_parameters
from test_moving_reference import record

MEASURED = ("accel.vrw", "alpha", "enc.qdd")        # the sensors' accelerations' white noise
DIFFERENCED = ("nav.v", "gyro.arw", "enc.qd")       # and the velocities'


@pytest.fixture(scope="module")
def excited():
    sc, rec = record("spatial", 40.0, excite=1.0)
    return sc, [(t, {k: o[k] for k in KEYS}) for t, o in rec]


def with_noise(sc, data, seed: int, keys):
    """The run as the sensors measure it with only the white noises ``keys`` on."""
    p = {k: 0.0 for k in default_parameters()}
    for k in keys:
        p[k] = default_parameters()[k]
    suite = SensorSuite(sc.robot.n_joints, p, seed=seed)
    return [(t, suite.update(o, 0.1)) for t, o in data]


def signal_sd(source: str) -> dict:
    """``Identifier(signal_sd=...)`` for the sensors' defaults (via the FMU parameter names)."""
    s = estimator_noise_settings()
    names = {"measured": {"a_S": "base.a", "alpha_B": "base.alpha", "qdd": "arm.qdd"},
             "differenced": {"v_S": "base.v", "omega_B": "base.omega", "qd": "arm.qd"}}[source]
    return {k: s[f"ident.noise.{n}"] for k, n in names.items()}


def identify(sc, data, solver="paper", cls=Identifier, **kw):
    ident = cls(sc.robot, sc.guess, "force", solver, **kw)
    for t, o in data:
        ident.update(t, o)
    return ident


def test_the_force_equations_are_affine_in_the_accelerations(excited):
    sc, data = excited
    geom = ArmGeometry(sc.robot).arrays()
    n = sc.robot.n_joints

    def E_of(x):
        E = np.empty((3, kernels.N_COLS))
        kernels.equations(True, x, n, *geom, E)
        return E

    x = np.concatenate([np.ravel(data[57][1][k]) for k in KEYS]).astype(float)
    E0 = E_of(x)
    for i in accel_channels(n):
        unit = x.copy()
        unit[i] += 1.0
        step = x.copy()
        step[i] += 0.37
        C = E_of(unit) - E0
        assert np.abs(C).max() > 0.0
        np.testing.assert_allclose(E_of(step) - E0, 0.37 * C, rtol=1e-9,
                                   atol=1e-12 * np.abs(E0).max())


def test_compensation_removes_the_attenuation_of_a_synthetic_problem():
    rng = np.random.default_rng(7)
    k, p, sigma = 20000, 3, 0.5
    X = rng.normal(size=(k, p))                      # true regressors, unit variance
    theta = np.array([2.0, -1.0, 0.5])
    y = X @ theta + 0.1 * rng.normal(size=k)
    Xn = X + sigma * rng.normal(size=(k, p))         # measured with noise
    R = np.column_stack([Xn, y])
    S = R.T @ R
    N = np.zeros((p + 1, p + 1))
    N[:p, :p] = k * sigma ** 2 * np.eye(p)           # E[noise^T noise]; y's noise independent
    plain = np.linalg.solve(S[:p, :p], S[:p, p])
    fixed = plain + compensation(S, N, plain)
    attenuation = 1.0 / (1.0 + sigma ** 2)
    np.testing.assert_allclose(plain, attenuation * theta, rtol=0.05)   # the textbook bias
    np.testing.assert_allclose(fixed, theta, rtol=0.03)


@pytest.mark.parametrize("solver", ["paper", "joint"])
@pytest.mark.slow
def test_noisy_accelerations_no_longer_bias_the_masses(excited, solver):
    sc, data = excited
    truth = estimate_vector(sc.robot.base, sc.target)
    plain, fixed = [], []
    for seed in range(4):
        noisy = with_noise(sc, data, seed, MEASURED)
        for out, kw in ((plain, {}), (fixed, {"signal_sd": signal_sd("measured")})):
            v = identify(sc, noisy, solver, **kw).vector()
            out.append([v[0] / truth[0] - 1.0, v[10] / truth[10] - 1.0])   # base, target mass
    plain, fixed = np.mean(plain, axis=0), np.mean(fixed, axis=0)
    assert np.all(plain < -2e-3), plain                       # attenuated: too light
    assert np.all(np.abs(fixed) < 0.4 * np.abs(plain)), (plain, fixed)


def test_differenced_accelerations_compensated_return_to_the_noise_free_estimate(excited):
    sc, data = excited
    kw = dict(accel_source="differenced", diff_half_window=1)
    clean = identify(sc, data, **kw).vector()
    noisy = with_noise(sc, data, 3, DIFFERENCED)
    plain = identify(sc, noisy, **kw).vector()
    fixed = identify(sc, noisy, signal_sd=signal_sd("differenced"), **kw).vector()
    for i in (0, 10):                                          # base and target mass
        assert abs(fixed[i] - clean[i]) < 0.3 * abs(plain[i] - clean[i]), (i, clean, plain, fixed)


def test_zero_noise_is_the_plain_estimator_and_the_state_round_trips(excited):
    sc, data = excited
    base = identify(sc, data[:150])
    zero = identify(sc, data[:150], signal_sd={"a_S": 0.0, "alpha_B": 0.0, "qdd": 0.0})
    np.testing.assert_array_equal(zero.vector(), base.vector())
    np.testing.assert_array_equal(zero.std(), base.std())
    for kw in ({"signal_sd": signal_sd("measured")},
               {"signal_sd": signal_sd("differenced"), "accel_source": "differenced"}):
        a = identify(sc, data[:150], **kw)
        state = a.get_state()
        for t, o in data[150:]:
            a.update(t, o)
        b = Identifier(sc.robot, sc.guess, "force", **kw)
        b.set_state(state)
        for t, o in data[150:]:
            b.update(t, o)
        np.testing.assert_array_equal(b.vector(), a.vector())
        np.testing.assert_array_equal(b.std(), a.std())


@pytest.mark.parametrize("bad,match", [({"a_S": -1.0}, "finite number >= 0"),
                                       ({"a_S": float("nan")}, "finite number >= 0"),
                                       ({"jerk": 1.0}, "unknown signal")])
def test_bad_noise_settings_are_refused(excited, bad, match):
    sc, _ = excited
    with pytest.raises(ValueError, match=match):
        Identifier(sc.robot, sc.guess, "force", signal_sd=bad)
    with pytest.raises(ValueError, match="momentum method's.*force method takes 0"):
        Identifier(sc.robot, sc.guess, "force", window=1.0, signal_sd={"a_S": 1e-3})


def test_bad_fmu_noise_parameter_is_refused():
    robot = get_robot("spatial")
    with pytest.raises(ValueError, match=r"ident\.noise\.base\.a"):
        identifier_from_values(robot, estimator_parameters("spatial", {"ident.noise.base.a": -2.0}))


@pytest.mark.parametrize("sensor,key,setting", [("accel.vrw", "a_S", "base.a"),
                                                ("alpha", "alpha_B", "base.alpha"),
                                                ("enc.qdd", "qdd", "arm.qdd"),
                                                ("nav.v", "v_S", "base.v"),
                                                ("gyro.arw", "omega_B", "base.omega"),
                                                ("enc.qd", "qd", "arm.qd")])
def test_noise_settings_are_the_sensors_per_sample_noise(excited, sensor, key, setting):
    """``estimator_noise_settings`` against the standard deviation of the sensors' own draws."""
    sc, data = excited
    p = {k: 0.0 for k in default_parameters()}
    p[sensor] = default_parameters()[sensor]
    suite = SensorSuite(sc.robot.n_joints, p, seed=11)
    t, x = data[0]
    err = np.array([suite.update(x, 0.1)[key] - x[key] for _ in range(4000)]).ravel()
    expected = estimator_noise_settings()[f"ident.noise.{setting}"]
    assert abs(err.std() / expected - 1.0) < 0.05                 # 4000+ draws: ~1 % error


@pytest.mark.slow
def test_the_prior_pull_is_the_rls_own_with_compensation(excited):
    """The compensated estimate moves ``mu``; the prior's pull (part of the sd) stays the RLS's
    distance to its data-only answer, not that shift (the oracle's solver: the native core
    keeps these parts internal)."""
    sc, data = excited
    noisy = with_noise(sc, data[:200], 1, MEASURED)
    o = oracle.Identifier
    plain_solver = identify(sc, noisy, cls=o).solver
    plain = plain_solver.prior_pull()[0]
    fixed = identify(sc, noisy, cls=o, signal_sd=signal_sd("measured")).solver
    pull = fixed.prior_pull()[0]
    shift = np.abs(fixed.mu - plain_solver.mu).max()
    assert shift > 1e-3                                          # the compensation moved mu
    assert np.abs(pull).max() <= 10.0 * np.abs(plain).max() + 1e-9, (pull, plain)


def test_non_increasing_times_are_refused_with_the_thrust_integrals(excited):
    sc, data = excited
    ident = Identifier(sc.robot, sc.guess, "momentum", thrust_sd=(0.02, 8.7e-3))
    for t, o in data[:5]:
        ident.update(t, o)
    before = ident.std().copy()
    from spacerobot.estimator.identifier import REJECT_INCONSISTENT
    assert ident.update(data[3][0], data[5][1]) == REJECT_INCONSISTENT
    assert "increasing sample times" in ident.message
    np.testing.assert_array_equal(ident.std(), before)
