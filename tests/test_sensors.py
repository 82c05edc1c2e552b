"""The sensor models (spacerobot.sensors.SensorSuite: the native core, no FMI): ideal sensors pass the true sample on bit
for bit, a seed fixes the run, the state round-trips exactly, and each sensor's error over a
long run has the configured mean, standard deviation and drift (statistical tolerances: 5
standard errors of the estimated quantity, or more where stated)."""
from __future__ import annotations

import numpy as np
import pytest

from spacerobot.interface import NOISE_PARAMETERS
from oracles.sensors import rotation_vector_to_matrix
from spacerobot.sensors import SIGNALS, SensorSuite, default_parameters

N_JOINTS, DT = 6, 0.1


def _rotation(rng) -> np.ndarray:
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def true_sample(rng, k: int = 0) -> dict:
    """A random true sample (values of every size and sign, exact zeros and -0.0 included)."""
    x = {g: rng.standard_normal(N_JOINTS if g in ("q", "qd", "qdd") else 3) * 10.0 ** rng.integers(-3, 3)
         for g in SIGNALS if g != "A"}
    x["A"] = _rotation(rng)
    x["F"][0], x["M"][1] = -0.0, 0.0
    return x


def zero_except(**kw):
    """Parameters all 0 but those given (one sensor effect at a time)."""
    p = {k: 0.0 for k in default_parameters()}
    p.update(kw)
    return p


def run(suite, x, n, dt=DT):
    """Measurements of the constant true sample ``x`` over ``n`` samples: {group: (n, ...)}."""
    ys = [suite.update(x, dt) for _ in range(n)]
    return {g: np.array([y[g] for y in ys]) for g in SIGNALS}


def _std_ok(sample_sd, expected, n, k=5.0):
    """Sample standard deviation of n normals within k standard errors (sd / sqrt(2n))."""
    return abs(sample_sd - expected) <= k * expected / np.sqrt(2 * n)


# -- ideal, determinism, state ------------------------------------------------------------------
def test_scale_zero_passes_the_true_sample_on_bit_for_bit():
    rng = np.random.default_rng(1)
    s = SensorSuite(N_JOINTS, scale=0.0, seed=3)
    for k in range(50):
        x = true_sample(rng, k)
        y = s.update(x, DT)
        for g in SIGNALS:
            assert np.asarray(x[g]).tobytes() == y[g].tobytes(), g   # -0.0 stays -0.0


def test_defaults_are_the_interface_table():
    assert default_parameters() == {k[6:]: v for k, (_, v, _) in NOISE_PARAMETERS.items()
                                    if k != "noise.scale"}


def test_same_seed_same_run_other_seed_other_run():
    rng = np.random.default_rng(2)
    xs = [true_sample(rng, k) for k in range(30)]
    a, b, c = (SensorSuite(N_JOINTS, seed=s) for s in (5, 5, 6))
    for x in xs:
        ya, yb, yc = a.update(x, DT), b.update(x, DT), c.update(x, DT)
        for g in SIGNALS:
            assert ya[g].tobytes() == yb[g].tobytes()
    assert not np.array_equal(ya["omega_B"], yc["omega_B"])


def test_state_round_trip_is_exact_and_matters():
    rng = np.random.default_rng(3)
    xs = [true_sample(rng, k) for k in range(40)]
    s = SensorSuite(N_JOINTS, seed=11, delay=2)
    for x in xs[:15]:
        s.update(x, DT)
    state = s.get_state()
    first = [s.update(x, DT) for x in xs[15:]]
    s.set_state(state)
    again = [s.update(x, DT) for x in xs[15:]]
    other = SensorSuite(N_JOINTS, seed=11, delay=2)     # a fresh suite takes the state over
    other.set_state(state)
    third = [other.update(x, DT) for x in xs[15:]]
    for y1, y2, y3 in zip(first, again, third):
        for g in SIGNALS:
            assert y1[g].tobytes() == y2[g].tobytes() == y3[g].tobytes()
    fresh = SensorSuite(N_JOINTS, seed=11, delay=2)     # negative control: the state matters
    assert not np.array_equal(fresh.update(xs[15], DT)["omega_B"], first[0]["omega_B"])


def test_measure_is_pure():
    x = true_sample(np.random.default_rng(4))
    s = SensorSuite(N_JOINTS, seed=1)
    assert all(np.array_equal(a, b) for a, b in zip(s.measure(x).values(), s.measure(x).values()))


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="gyro.arw"):
        SensorSuite(3, {"gyro.arw": -1.0})
    with pytest.raises(ValueError, match="unknown noise parameters"):
        SensorSuite(3, {"gyro.awr": 1.0})
    with pytest.raises(ValueError, match="noise.delay"):
        SensorSuite(3, delay=-1)
    with pytest.raises(ValueError, match="noise.scale"):
        SensorSuite(3, scale=float("nan"))


# -- statistics of each sensor ------------------------------------------------------------------
N = 20000


@pytest.mark.slow
def test_gyro_white_noise_and_bias_random_walk():
    x = true_sample(np.random.default_rng(5))
    arw, rrw = 2e-4, 3e-5
    e = run(SensorSuite(N_JOINTS, zero_except(**{"gyro.arw": arw}), seed=1), x, N)["omega_B"] - x["omega_B"]
    sd = arw / np.sqrt(DT)                                    # white noise sampled at DT
    assert np.all(np.abs(e.mean(0)) < 5 * sd / np.sqrt(N))
    assert all(_std_ok(e[:, i].std(), sd, N) for i in range(3))
    # bias random walk only: the error is the bias; its increments have sd rrw sqrt(DT)
    b = run(SensorSuite(N_JOINTS, zero_except(**{"gyro.rrw": rrw}), seed=2), x, N)["omega_B"] - x["omega_B"]
    inc = np.diff(b, axis=0)
    assert all(_std_ok(inc[:, i].std(), rrw * np.sqrt(DT), N) for i in range(3))
    # drift: Var(b(T) - b(0)) = rrw^2 T, over many suites
    T, runs = 50, 400
    drift = np.array([run(SensorSuite(N_JOINTS, zero_except(**{"gyro.rrw": rrw}), seed=s), x, T)
                      ["omega_B"][-1] - x["omega_B"] for s in range(runs)])
    expected = rrw * np.sqrt((T - 1) * DT)
    assert _std_ok(drift.std(), expected, 3 * runs)


def test_gyro_and_accelerometer_initial_bias_over_seeds():
    x = true_sample(np.random.default_rng(6))
    runs = 2000
    e = np.array([[y["omega_B"] - x["omega_B"], y["a_S"] - x["a_S"]] for y in (
        SensorSuite(N_JOINTS, zero_except(**{"gyro.bias": 1e-4, "accel.bias": 2e-3}),
                    seed=s).measure(x) for s in range(runs))])
    assert _std_ok(e[:, 0].std(), 1e-4, 3 * runs) and _std_ok(e[:, 1].std(), 2e-3, 3 * runs)
    assert abs(e[:, 0].mean()) < 5e-4 / np.sqrt(3 * runs) and abs(e[:, 1].mean()) < 1e-2 / np.sqrt(3 * runs)


@pytest.mark.slow
def test_star_tracker_noise_per_axis_and_rotation():
    x = true_sample(np.random.default_rng(7))
    cross, roll = 1e-4, 5e-4
    A = run(SensorSuite(N_JOINTS, zero_except(**{"star.cross": cross, "star.roll": roll}),
                        seed=3), x, N)["A"]
    eye = np.eye(3)
    assert max(np.abs(a.T @ a - eye).max() for a in A[::100]) < 1e-14
    assert all(np.linalg.det(a) > 0 for a in A[::100])
    # the error rotation in the base frame: A_true^T A_meas = exp([phi]x), phi small
    E = np.einsum("ji,njk->nik", x["A"], A)
    phi = np.stack([E[:, 2, 1], E[:, 0, 2], E[:, 1, 0]], axis=1)
    for i, sd in enumerate((cross, cross, roll)):
        assert _std_ok(phi[:, i].std(), sd, N), (i, phi[:, i].std(), sd)
        assert abs(phi[:, i].mean()) < 5 * sd / np.sqrt(N)


def test_rotation_vector_to_matrix_against_axis_angle():
    ax = np.array([1.0, 2.0, -2.0]) / 3.0
    for angle in (1e-9, 1e-3, 0.7, 3.0):
        R = rotation_vector_to_matrix(angle * ax)
        v = np.cross(ax, [1.0, 0.0, 0.0])
        assert np.allclose(R @ ax, ax, atol=1e-15)
        assert np.isclose(np.dot(R @ v, v) / np.dot(v, v), np.cos(angle), atol=1e-14)


@pytest.mark.slow
def test_navigation_accelerometer_alpha_and_joint_rate_noise():
    x = true_sample(np.random.default_rng(8))
    p = {"nav.r": 0.02, "nav.v": 3e-3, "accel.vrw": 1e-3, "alpha": 4e-4, "enc.qd": 2e-4,
         "enc.qdd": 2e-3}
    y = run(SensorSuite(N_JOINTS, zero_except(**p), seed=4), x, N)
    expect = {"r_S": p["nav.r"], "v_S": p["nav.v"], "a_S": p["accel.vrw"] / np.sqrt(DT),
              "alpha_B": p["alpha"], "qd": p["enc.qd"], "qdd": p["enc.qdd"]}
    for g, sd in expect.items():
        e = y[g] - x[g]
        assert np.all(np.abs(e.mean(0)) < 5 * sd / np.sqrt(N)), g
        assert all(_std_ok(e[:, i].std(), sd, N) for i in range(e.shape[1])), g


@pytest.mark.slow
def test_accelerometer_bias_random_walk():
    x = true_sample(np.random.default_rng(9))
    brw = 1e-4
    b = run(SensorSuite(N_JOINTS, zero_except(**{"accel.brw": brw}), seed=5), x, N)["a_S"] - x["a_S"]
    inc = np.diff(b, axis=0)
    assert all(_std_ok(inc[:, i].std(), brw * np.sqrt(DT), N) for i in range(3))


@pytest.mark.slow
def test_encoder_noise_and_quantisation():
    x = true_sample(np.random.default_rng(10))
    e = run(SensorSuite(N_JOINTS, zero_except(**{"enc.q": 1e-4}), seed=6), x, N)["q"] - x["q"]
    assert all(_std_ok(e[:, i].std(), 1e-4, N) for i in range(N_JOINTS))
    res = 1e-3
    rng = np.random.default_rng(11)
    s = SensorSuite(N_JOINTS, zero_except(**{"enc.resolution": res}), seed=7)
    qs = rng.uniform(-3, 3, (N, N_JOINTS))
    out = []
    for q in qs:
        x["q"] = q
        out.append(s.update(x, DT)["q"])
    out = np.array(out)
    steps = out / res
    assert np.abs(steps - np.round(steps)).max() < 1e-9          # on the grid
    err = out - qs
    assert np.abs(err).max() <= res / 2 * (1 + 1e-9)             # to the nearest step
    assert _std_ok(err.std(), res / np.sqrt(12), N * N_JOINTS, k=8)   # uniform on the step


@pytest.mark.slow
def test_thrust_scale_factor_and_misalignment_over_seeds():
    runs = 3000
    scale, mis = 0.03, 0.01
    ks, ss, phis = [], [], []
    for seed in range(runs):
        s = SensorSuite(N_JOINTS, zero_except(**{"thrust.scale": scale, "thrust.misalign": mis}),
                        seed=seed)
        K = np.empty((3, 3))
        for j in range(3):                            # the map of the force, column by column
            x = {g: np.zeros(N_JOINTS if g in ("q", "qd", "qdd") else 3) for g in SIGNALS}
            x["A"] = np.eye(3)
            x["F"][j] = 1.0
            K[:, j] = s.measure(x)["F"]
        k = np.cbrt(np.linalg.det(K))                 # K = (1 + s) R
        R = K / k
        ks.append(np.abs(R.T @ R - np.eye(3)).max())
        ss.append(k - 1.0)
        phis.append([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    assert max(ks) < 1e-13                            # a rotation times a scale
    phis = np.array(phis) / 2.0                       # sin(phi) ~ phi for phi ~ 0.01
    assert _std_ok(np.std(ss), scale, runs)
    assert all(_std_ok(phis[:, i].std(), mis, runs, k=6) for i in range(3))


def test_delay_returns_the_measurement_of_earlier_samples():
    rng = np.random.default_rng(13)
    xs = [true_sample(rng, k) for k in range(20)]
    a, b = SensorSuite(N_JOINTS, seed=9), SensorSuite(N_JOINTS, seed=9, delay=3)
    ya = [a.update(x, DT) for x in xs]
    yb = [b.update(x, DT) for x in xs]
    for k in range(20):
        for g in SIGNALS:
            assert np.array_equal(yb[k][g], ya[max(0, k - 3)][g])


def test_no_imu_outputs_zero_accelerations():
    x = true_sample(np.random.default_rng(14))
    for scale in (0.0, 1.0):
        y = SensorSuite(N_JOINTS, scale=scale, imu=False).measure(x)
        assert not y["a_S"].any() and not y["alpha_B"].any()
        assert np.array_equal(y["q"], x["q"]) or scale


@pytest.mark.parametrize("n", [1, 3, 12])
def test_the_sample_layout_is_the_core_table_and_the_fmu_variables(n):
    """spacerobot.core.sample reads the core's table (sample.h): the FMU variables of a sample
    (spacerobot.interface.measurement_vars) come in its order, with its units and sizes, and
    the flat sample is 24 + 3 n + 12 values long; SensorSuite splits it the same way."""
    from spacerobot.core import sample
    from spacerobot.interface import measurement_vars

    variables = measurement_vars(n, "input")
    groups = list(dict.fromkeys(v.key[0] for v in variables))
    sizes = [(s.key, s.size) for s in sample.signals(n)]
    assert list(sample.keys()) == groups == list(SIGNALS)
    assert [s.unit for s in sample.signals(n)] == [next(v.unit for v in variables
                                                         if v.key[0] == g) for g in groups]
    assert sizes == [(g, sum(v.key[0] == g for v in variables)) for g in groups]
    assert sample.sample_length(n) == len(variables) == 24 + 3 * n + 12
    x = {g: np.arange(k, dtype=float).reshape((3, 3) if g == "A" else (k,)) for g, k in sizes}
    y = SensorSuite(n, scale=0.0).measure(x)
    assert all(np.array_equal(y[g], x[g]) for g in groups)
