"""Equation settings for noisy sensors (issue 14): the momentum window, the angular rows about
the base, the force window and the accelerometer bias estimated from the navigation velocity.
The native Identifier, except where noted: the rows are the NumPy oracle's (the native core's
reference), the accelerometer bias the oracle's (the native core refuses it, as it refuses the
force window, which is not kept).

* Momentum window and moving point: at the true parameters the (oracle's) rows equal the change of the
  bodies' momentum and of their angular momentum about the base's position at the newer sample,
  computed independently from the plant's total momenta minus the arm's (NumPy oracle), against
  the sample ``window`` seconds older (the first sample while the run is shorter).
* Noise-free, with the options on, the estimates are as exact as the paper's equations'.
* Accelerometer bias: the running line fit recovers a constant bias exactly when the
  accelerations are linear in time (the trapezoid is exact), and removes most of a bias's error
  from the force method.
* Defaults keep the paper's equations bit for bit; a restored identifier continues bit for bit.
* Calibration on a short noisy run: the momentum window with the moving point keeps at least
  90 % of the estimates within 2 sd and is far more accurate than the paper's equations.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from oracles import estimator as oracle
from oracles.kinematics import ArmKinematics, skew
from spacerobot.estimator import Identifier
from oracles.estimator import parameters as par
from oracles.estimator.accel_bias import BiasFit
from spacerobot.estimator.identifier import identifier_from_values
from oracles.estimator.noise_model import equation_error_sd
from spacerobot.interface import estimate_vector, relative_errors
from spacerobot.plant import Plant
from spacerobot.robots import scenario
from oracles.sensors import SensorSuite  # the NumPy sensor models: test data
from spacerobot.system.identify import estimator_parameters

SAMPLE = 0.1


def record(robot: str, seconds: float, excite: float = 0.0):
    sc = scenario(robot)
    p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
              excitation=sc.excitation)
    p.set_excitation(excite)
    out = [(0.0, p.outputs())]
    for k in range(1, int(round(seconds / SAMPLE)) + 1):
        p.advance(SAMPLE)
        out.append((k * SAMPLE, p.outputs()))
    return sc, out


@pytest.fixture(scope="module")
def spatial():
    return record("spatial", 12.0)


def _truth(sc):
    g = dataclasses.replace(sc.guess, base=sc.robot.base, target=sc.target)
    mu, theta = par.paper_vectors(g)
    return mu, theta, par.D_of_mu(mu)


def _bodies_momenta(sc, o):
    """The bodies' linear and angular momentum (about the origin): the plant's totals minus the
    arm's (oracle kinematics)."""
    links, _ = ArmKinematics(sc.robot).compute(o["r_S"], o["A"], o["v_S"], o["omega_B"],
                                               o["a_S"], o["alpha_B"], o["q"], o["qd"],
                                               o["qdd"])
    P_arm, L_arm = ArmKinematics(sc.robot).momentum(links)
    return o["P"] - P_arm, o["L"] - L_arm, P_arm, L_arm


@pytest.mark.parametrize("window", [0.0, 0.35, 2.0])
def test_momentum_window_rows_are_the_momentum_changes_about_the_base(spatial, window):
    sc, rec = spatial
    mu, theta, D = _truth(sc)
    # the oracle's rows (the native core's reference, tests/test_native_noise_options.py; the
    # native core does not expose its rows)
    ident = oracle.Identifier(sc.robot, sc.guess, "momentum", window=window, moving_point=True)
    times = np.array([t for t, _ in rec])
    P_scale = max(np.linalg.norm(o["P"]) for _, o in rec)
    L_scale = max(np.linalg.norm(o["L"]) for _, o in rec)
    n_rows = 0
    for k, (t, o) in enumerate(rec):
        eq = ident.rows(t, o)
        if k == 0:
            assert eq is None                       # the first sample: the reference
            continue
        A, b, phi, y, psi = eq
        # the reference: the newest sample at least `window` older, else the first
        if window == 0.0:
            r = 0
        else:
            older = np.nonzero(times[:k] <= t - window + 1e-9 * max(1.0, t))[0]
            r = older[-1] if len(older) else 0
        o_r = rec[r][1]
        p = o["r_S"]
        Pb, Lb, Pa, La = _bodies_momenta(sc, o)
        Pb_r, Lb_r, Pa_r, La_r = _bodies_momenta(sc, o_r)
        dP = Pb - Pb_r
        dL_p = (Lb - skew(p) @ Pb) - (Lb_r - skew(p) @ Pb_r)       # about p, both samples
        np.testing.assert_allclose(A @ mu, dP, rtol=0, atol=1e-9 * P_scale)
        np.testing.assert_allclose(phi @ theta - psi @ D, dL_p, rtol=0, atol=1e-9 * L_scale)
        # the right-hand sides: impulses minus the arm's momenta, about p
        dJ = o["J"] - o_r["J"]
        np.testing.assert_allclose(b, dJ - (Pa - Pa_r), rtol=0, atol=1e-9 * P_scale)
        dH_p = o["H"] - o_r["H"] - skew(p) @ dJ
        dLa_p = (La - skew(p) @ Pa) - (La_r - skew(p) @ Pa_r)
        np.testing.assert_allclose(y, dH_p - dLa_p, rtol=0, atol=1e-9 * L_scale)
        n_rows += 1
    assert n_rows == len(rec) - 1
    assert np.linalg.norm(rec[-1][1]["r_S"]) > 1.0          # the point is far from the origin


@pytest.mark.parametrize("kw", [dict(method="momentum", window=5.0, moving_point=True)])
@pytest.mark.parametrize("solver", ["paper", "joint"])
def test_noise_free_estimates_stay_exact_with_the_options(kw, solver):
    """The options only combine valid equations: without noise the estimates converge as the
    paper's equations do (a weak prior, so that its pull does not hide the data; every
    sample taken: issue #26, tests/test_native_estimator.py
    test_weak_prior_noise_free_run_keeps_every_sample)."""
    sc, rec = record("spatial", 30.0)
    g = dataclasses.replace(sc.guess, P0_mu=1e8, P0_theta=1e8)
    truth = estimate_vector(sc.robot.base, sc.target)
    errs = {}
    for name, opts in (("paper", dict(method=kw["method"])), ("options", kw)):
        ident = Identifier(sc.robot, g, solver=solver, **opts)
        for t, o in rec:
            assert ident.update(t, o) in (1, 2)
        errs[name] = relative_errors(ident.vector(), truth).max()
    # the plant's own integration limits the momentum equations to ~4e-7 (paper's rows)
    assert errs["options"] <= max(errs["paper"], 1e-9), errs
    assert errs["options"] < 1e-6, errs


def test_defaults_are_the_paper_equations_bit_for_bit(spatial):
    sc, rec = spatial
    for method in ("momentum", "force"):
        a = Identifier(sc.robot, sc.guess, method)
        b = Identifier(sc.robot, sc.guess, method, window=0.0, moving_point=False,
                       accel_bias=False)
        c = Identifier(sc.robot, sc.guess, method, **(
            dict(window=2.0, moving_point=True) if method == "momentum"
            else dict(accel_source="differenced")))
        for t, o in rec:
            a.update(t, o)
            b.update(t, o)
            c.update(t, o)
        np.testing.assert_array_equal(a.vector(), b.vector())
        np.testing.assert_array_equal(a.std(), b.std())
        assert not np.array_equal(a.vector(), c.vector())          # negative control


def test_fmu_parameters_reach_the_identifier():
    v = estimator_parameters("spatial", {"ident.momentum_window": 5.0,
                                         "ident.momentum_point": 1, "ident.accel_bias": 1})
    sc = scenario("spatial")
    ident, _ = identifier_from_values(sc.robot, v)                  # momentum by default
    assert (ident.window, ident.moving_point, ident.accel_bias) == (5.0, True, False)
    v["method"] = 2
    ident, _ = identifier_from_values(sc.robot, v)   # force, measured: the bias fit on
    assert (ident.window, ident.moving_point, ident.accel_bias) == (0.0, False, True)
    assert ident.core.options.accel_bias == 1
    # a reference window is the momentum method's (the force method's high-pass is not kept)
    with pytest.raises(ValueError, match="momentum method's.*force method takes 0"):
        Identifier(sc.robot, sc.guess, "force", window=2.0)
    ident, _ = identifier_from_values(sc.robot, dict(v, **{"ident.accel_bias": 0}))
    assert (ident.window, ident.moving_point, ident.accel_bias) == (0.0, False, False)
    for name, bad in (("ident.momentum_point", 2), ("ident.accel_bias", -1),
                      ("ident.momentum_window", -1.0)):
        with pytest.raises(ValueError, match=name.split(".")[1].split("_")[0]):
            identifier_from_values(sc.robot, dict(v, **{name: bad}))


def test_a_time_that_does_not_advance_is_refused_with_a_window(spatial):
    sc, rec = spatial
    ident = Identifier(sc.robot, sc.guess, "momentum", window=1.0)
    for t, o in rec[:5]:
        ident.update(t, o)
    before = ident.vector().copy()
    assert ident.update(rec[4][0], rec[5][1]) == 4
    assert "increasing sample times" in ident.message
    np.testing.assert_array_equal(ident.vector(), before)


def test_state_round_trip_with_the_window_and_the_bias_fit(spatial):
    sc, rec = spatial
    for kw in (dict(method="momentum", window=0.5, moving_point=True),
               dict(method="force", accel_source="differenced", diff_half_window=2)):
        a = Identifier(sc.robot, sc.guess, **kw)
        for t, o in rec[:30]:
            a.update(t, o)
        state = a.get_state()
        for t, o in rec[30:]:
            a.update(t, o)
        c = Identifier(sc.robot, sc.guess, **kw)
        c.set_state(state)
        for t, o in rec[30:]:
            c.update(t, o)
        np.testing.assert_array_equal(c.vector(), a.vector())
        np.testing.assert_array_equal(c.std(), a.std())          # the tracker's state too
        fresh = Identifier(sc.robot, sc.guess, **kw)             # negative control
        for t, o in rec[30:]:
            fresh.update(t, o)
        assert not np.array_equal(fresh.vector(), a.vector())


# ------------------------------------------------------------------------------------------------
# accelerometer bias
# ------------------------------------------------------------------------------------------------

def test_bias_fit_recovers_a_constant_bias_exactly_for_linear_accelerations():
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(0.05, 0.15, 200))              # uneven sample times
    a0, a1, v0 = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3)
    bias = np.array([3e-3, -1e-3, 2e-3])
    fit = BiasFit()
    for tk in t:
        tau = tk - t[0]
        a = a0 + a1 * tau                                    # linear: the trapezoid is exact
        v = v0 + a0 * tau + 0.5 * a1 * tau ** 2
        fit = fit.add(tk, v, a + bias)
    np.testing.assert_allclose(fit.bias(), bias, rtol=0, atol=1e-12)
    assert np.all(BiasFit().bias() == 0.0)
    assert np.all(BiasFit().add(1.0, v0, a0).bias() == 0.0)    # one sample: no slope yet


@pytest.mark.slow
def test_estimated_bias_removes_most_of_an_accelerometer_bias(spatial):
    """The accelerometer bias fit removes most of a constant accelerometer bias: the native
    Identifier and the oracle's."""
    sc, rec = record("spatial", 30.0)
    truth = estimate_vector(sc.robot.base, sc.target)
    biased = [(t, dict(o, a_S=o["a_S"] + np.array([0.02, -0.01, 0.015]))) for t, o in rec]
    for make in (Identifier, oracle.Identifier):
        errs = {}
        for on in (False, True):
            ident = make(sc.robot, sc.guess, "force", accel_bias=on)
            for t, o in biased:
                ident.update(t, o)
            errs[on] = relative_errors(ident.vector(), truth).max()
        assert errs[True] < 0.1 * errs[False], (make, errs)


# ------------------------------------------------------------------------------------------------
# calibration and accuracy on a short noisy run
# ------------------------------------------------------------------------------------------------

@pytest.mark.slow
def test_momentum_window_is_accurate_and_calibrated_on_a_short_noisy_run():
    sc = scenario("spatial")
    runs = {}
    for seed in (11, 4):                                  # pilot (row sd), then the run
        p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h,
                  excitation=sc.excitation)
        p.set_excitation(1.0)
        sensors = SensorSuite(sc.robot.n_joints, seed=seed)
        out = []
        for k in range(601):
            if k:
                p.advance(sc.sample_time)
            out.append((p.t, sensors.update(p.outputs(), sc.sample_time)))
        runs[seed] = out
    opts = dict(window=5.0, moving_point=True)
    sd = equation_error_sd(sc.robot, sc.robot.base, sc.target, runs[11], "momentum", **opts)
    sd_paper = equation_error_sd(sc.robot, sc.robot.base, sc.target, runs[11], "momentum")
    truth = estimate_vector(sc.robot.base, sc.target)
    res = {}
    for name, kw, s in (("window", opts, sd), ("paper", {}, sd_paper)):
        ident = Identifier(sc.robot, sc.guess, "momentum", row_sd=s, corr_lags=200, **kw)
        for t, y in runs[4]:
            ident.update(t, y)
        res[name] = (relative_errors(ident.vector(), truth).max(),
                     np.mean(np.abs(ident.vector() - truth) <= 2 * ident.std()))
    assert res["window"][1] >= 0.9, res
    assert res["window"][0] < 0.1 * res["paper"][0], res


@pytest.mark.parametrize("kw", [dict(window=None), dict(window="5"), dict(window=float("nan")),
                                dict(window=-1.0), dict(moving_point="no"), dict(accel_bias=2)])
def test_bad_equation_settings_are_refused(spatial, kw):
    sc, _ = spatial
    with pytest.raises(ValueError, match="window|momentum_point|accel_bias"):
        Identifier(sc.robot, sc.guess, "momentum", **kw)
