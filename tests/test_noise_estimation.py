"""The estimator under noise (issue 14): row weighting, filtered differenced accelerations with
their delay compensated, forgetting with the excitation always on, calibrated standard
deviations.

* Savitzky-Golay derivative weights are exact for quadratics at uneven sample times and equal
  the textbook coefficients at an even step.
* Delay compensation: with velocities quadratic in time, the force method on differenced
  accelerations (half window 1 and 3) gives the estimates of the force method fed the exact
  accelerations of the window's centre sample: every row belongs to one instant.
* Row weights: the joint solver's estimate with row standard deviations equals an independent
  batch weighted least-squares answer (prior included) on the unweighted rows recorded from an
  identifier without weights; the paper solver's mass estimate likewise.
* Forgetting: the weighted row counts (n1, n2) equal their direct sums, and the reported
  variance ``var_scale sigma^2 P`` matches the scatter of the forgetting estimate over
  repetitions (without ``var_scale`` it would be twice too large).
* Correlated residuals: the autocorrelation inflation of an MA(1) and an AR(1) sequence equals
  the long-run variance ratio of the theory.
* With the excitation always on and forgetting (lambda < 1) the estimator identifies a random
  spatial case without noise.
* Calibration on a short noisy run (plant, realistic sensor models, estimator core; force
  method): with the residual correlation correction at least 90 % of the estimates lie within
  2 sd of the truth, without it fewer.
"""
from __future__ import annotations

import numpy as np
import pytest

from oracles import estimator as oracle
from spacerobot.estimator import Identifier
from oracles.estimator.differencing import derivative_weights
from oracles.estimator.noise_model import equation_error_sd
from oracles.estimator.rls import RLS
from oracles.estimator.uncertainty import Autocorrelation, Gram
from spacerobot.interface import ExciteMode, estimate_vector, relative_errors
from spacerobot.plant import Plant
from spacerobot.robots import random_scenario, scenario
from spacerobot.sensors import SensorSuite

SAMPLE = 0.1


def plant_of(sc, excitation=None) -> Plant:
    args = (sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h)
    return Plant(*args) if excitation is None else Plant(*args, excitation)


@pytest.fixture(scope="module")
def planar_samples():
    """The paper's planar run, 0.1 s samples for 10 s."""
    sc = scenario("planar")
    p = plant_of(sc)
    out = [(0.0, p.outputs())]
    for k in range(1, 101):
        p.advance(SAMPLE)
        out.append((k * SAMPLE, p.outputs()))
    return sc, out


# ------------------------------------------------------------------------------------------------
# differenced accelerations: Savitzky-Golay weights, delay compensation
# ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("m", [1, 2, 3, 5])
def test_derivative_weights_are_exact_for_quadratics_at_uneven_times(m):
    rng = np.random.default_rng(m)
    t = np.cumsum(rng.uniform(0.05, 0.15, 2 * m + 1))
    c = rng.normal(size=3)
    x = c[0] + c[1] * t + c[2] * t ** 2
    w = derivative_weights(t, m)
    assert w @ x == pytest.approx(c[1] + 2 * c[2] * t[m], rel=1e-10, abs=1e-10)


def test_derivative_weights_at_an_even_step_are_the_textbook_ones():
    h = 0.1
    t = h * np.arange(5)
    # Savitzky-Golay first derivative, quadratic, 5 points: (-2, -1, 0, 1, 2) / (10 h)
    np.testing.assert_allclose(derivative_weights(t, 2), np.arange(-2, 3) / (10 * h), atol=1e-12)
    np.testing.assert_allclose(derivative_weights(t[:3], 1), [-0.5 / h, 0.0, 0.5 / h], atol=1e-12)


def _polynomial_velocities(samples):
    """The samples with v_S, omega_B, qd quadratic in t and a_S, alpha_B, qdd their exact
    derivatives (the other signals as recorded)."""
    rng = np.random.default_rng(7)
    out = []
    n = len(samples[0][1]["qd"])
    coef = {k: rng.normal(size=(3, size)) for k, size in (("v_S", 3), ("omega_B", 3), ("qd", n))}
    for t, s in samples:
        s = dict(s)
        for vel, acc in (("v_S", "a_S"), ("omega_B", "alpha_B"), ("qd", "qdd")):
            c = coef[vel]
            s[vel] = c[0] + c[1] * t + c[2] * t * t
            s[acc] = c[1] + 2 * c[2] * t
        out.append((t, s))
    return out


@pytest.mark.parametrize("m", [1, 3])
@pytest.mark.parametrize("solver", ["paper", "joint"])
def test_differenced_rows_belong_to_the_window_centre(planar_samples, m, solver):
    sc, samples = planar_samples
    samples = _polynomial_velocities(samples)
    diff = Identifier(sc.robot, sc.guess, "force", solver, "differenced", diff_half_window=m,
                      diff_momentum=False)          # the velocities' derivative at the centre
    exact = Identifier(sc.robot, sc.guess, "force", solver, "measured")
    for t, s in samples:
        garbled = dict(s, a_S=np.zeros(3), alpha_B=np.zeros(3), qdd=np.zeros_like(s["qdd"]))
        diff.update(t, garbled)                 # reads velocities only
    for t, s in samples[m:len(samples) - m]:    # the centres of the full windows
        exact.update(t, s)
    assert diff.samples == exact.samples == len(samples) - 2 * m
    # equal to round-off (the derivative weights of float times, amplified by the RLS)
    np.testing.assert_allclose(diff.vector(), exact.vector(), rtol=1e-6, atol=1e-10)
    np.testing.assert_allclose(diff.std(), exact.std(), rtol=1e-5, atol=1e-10)
    # negative control: the rows one sample later than the centre are a different answer
    late = Identifier(sc.robot, sc.guess, "force", solver, "measured")
    for t, s in samples[m + 1:len(samples) - m + 1]:
        late.update(t, s)
    assert not np.allclose(diff.vector(), late.vector(), rtol=1e-4)


def test_a_wider_window_divides_the_derivative_noise():
    """White velocity noise: the derivative noise falls as sqrt(3 / (m (m+1) (2m+1))) / h."""
    h, rng = 0.1, np.random.default_rng(1)
    x = rng.normal(size=20000)
    for m in (1, 5):
        w = derivative_weights(h * np.arange(2 * m + 1), m)
        d = np.convolve(x, w[::-1], mode="valid")
        theory = np.sqrt(3 / (m * (m + 1) * (2 * m + 1))) / h       # m = 1: 1 / (sqrt 2 h)
        assert np.std(d) == pytest.approx(theory, rel=0.03)


# ------------------------------------------------------------------------------------------------
# row weights against batch weighted least squares
# ------------------------------------------------------------------------------------------------

def _record_rows(rls):
    """The rows ``(H, y)`` an :class:`RLS` is updated with, from now on."""
    rows = []
    update = rls.update

    def recording(H, y):
        rows.append((np.array(H), np.array(y)))
        return update(H, y)

    rls.update = recording
    return rows


def _batch(rows, weights, x0, P0):
    """argmin sum_k |W_k (H_k x - y_k)|^2 + (x - x0)^T P0^-1 (x - x0)."""
    G = np.linalg.inv(P0)
    g = G @ x0
    for (H, y), w in zip(rows, weights):
        Hw, yw = H * w[:, None], y * w
        G = G + Hw.T @ Hw
        g = g + Hw.T @ yw
    return np.linalg.solve(G, g)


def _estimates_of_standard(pi):
    """The 20 estimates (m, b, I_c per body) of a standard parameter vector (20,)."""
    from oracles.estimator import parameters as par
    from spacerobot.interface import LAYOUT
    out = np.empty(20)
    for b in LAYOUT.bodies:
        m, com, Ic = par.physical_from_standard(pi[b.vec])
        out[b.m], out[b.first] = m, com
        out[b.inertia] = [Ic[0, 0], Ic[1, 1], Ic[2, 2], Ic[0, 1], Ic[0, 2], Ic[1, 2]]
    return out


@pytest.mark.parametrize("method", ["momentum", "force"])
@pytest.mark.slow
def test_row_weights_equal_batch_weighted_least_squares(planar_samples, method):
    """The native Identifier with row weights against batch weighted least squares over the
    rows the NumPy oracle's solvers are updated with (recorded), with the oracle's prior:
    the joint solver's standard parameters, the paper solver's masses and first moments."""
    sc, samples = planar_samples
    sd = (0.02, 3.0)                         # linear rows weigh 150 x more than angular ones
    plain = oracle.Identifier(sc.robot, sc.guess, method, "joint")
    rows = _record_rows(plain.solver.rls)
    plain_mu = oracle.Identifier(sc.robot, sc.guess, method, "paper")
    rows_mu = []
    update = plain_mu.solver.rls.update

    def recording(A, b, *angular):              # the modified RLS: record the linear rows
        rows_mu.append((np.array(A), np.array(b)))
        return update(A, b, *angular)

    plain_mu.solver.rls.update = recording
    weighted = Identifier(sc.robot, sc.guess, method, "joint", row_sd=sd)
    weighted_mu = Identifier(sc.robot, sc.guess, method, "paper", row_sd=sd)
    prior = oracle.Identifier(sc.robot, sc.guess, method, "joint").solver   # pi0, P0
    prior_mu = oracle.Identifier(sc.robot, sc.guess, method, "paper").solver
    for t, s in samples:
        for ident in (plain, plain_mu, weighted, weighted_mu):
            ident.update(t, s)
    L = plain.layout
    nl = len(L.rows_lin)
    w = [np.r_[np.full(nl, 1 / sd[0]), np.full(len(y) - nl, 1 / sd[1])] for _, y in rows]
    act = L.standard_active

    def estimates(ws):
        pi = np.array(prior.pi, dtype=float)             # the prior's standard parameters
        pi[act] = _batch(rows, ws, prior._pi0, np.diag(prior.prior()[act]))
        return _estimates_of_standard(pi)

    got, want = weighted.vector(), estimates(w)
    idf = L.identified
    scale = L.error_scale(want)
    np.testing.assert_array_less(np.abs(got - want)[idf] / scale[idf], 1e-7)
    unweighted = estimates([np.ones_like(y) for _, y in rows])
    assert np.max(np.abs(unweighted - want)[idf] / scale[idf]) > 1e-6     # the weights matter
    # paper solver, masses and first moments: weight 1 / sd_lin on every row
    p = len(L.mu_active)
    mu = _batch(rows_mu, [np.full(len(y), 1 / sd[0]) for _, y in rows_mu],
                prior_mu._mu0, sc.guess.P0_mu * np.eye(p))
    v = weighted_mu.vector()
    mu_native = np.concatenate([[v[b.m], *(v[b.m] * v[b.first])] for b in L.bodies])
    np.testing.assert_allclose(mu_native[L.mu_active], mu, rtol=1e-7,
                               atol=1e-9 * np.abs(mu).max())


def test_bad_noise_parameters_are_refused():
    sc = scenario("planar")
    for kw in ({"row_sd": (-1.0, 0.0)}, {"row_sd": (np.nan, 1.0)}, {"row_sd": (1.0,)},
               {"diff_half_window": 0}, {"diff_half_window": 1.5}, {"corr_lags": -1}):
        with pytest.raises(ValueError):
            Identifier(sc.robot, sc.guess, "force", **kw)


def test_equation_error_sd_is_zero_without_noise_and_the_noise_level_with_it(planar_samples):
    sc, samples = planar_samples
    b, g = sc.robot.base, sc.target
    for method in ("momentum", "force"):
        sd = equation_error_sd(sc.robot, b, g, samples, method)
        assert max(sd) < 1e-6, (method, sd)
    # white force noise of 0.3 N per axis: the force rows carry exactly that error
    rng = np.random.default_rng(0)
    noisy = [(t, dict(s, F=s["F"] + 0.3 * rng.normal(size=3))) for t, s in samples]
    planar_rows = len(Identifier(sc.robot, sc.guess).layout.rows_lin)
    sd_lin, _ = equation_error_sd(sc.robot, b, g, noisy, "force")
    assert sd_lin == pytest.approx(0.3, rel=3 / np.sqrt(planar_rows * len(samples)))


# ------------------------------------------------------------------------------------------------
# forgetting: weighted row counts and the estimate's variance
# ------------------------------------------------------------------------------------------------

def test_weighted_row_counts_are_the_direct_sums():
    lam, k = 0.97, [3, 2, 3, 3, 1]
    g = Gram.empty(2, lam)
    for kk in k:
        g = g.add(np.ones((kk, 2)))
    N = len(k)
    assert g.n1 == pytest.approx(sum(lam ** (N - 1 - i) * kk for i, kk in enumerate(k)))
    assert g.n2 == pytest.approx(sum(lam ** (2 * (N - 1 - i)) * kk for i, kk in enumerate(k)))
    assert g.dof(1) == pytest.approx(g.n1 - g.n2 / g.n1)
    g1 = Gram.empty(2).add(np.ones((3, 2))).add(np.ones((2, 2)))
    assert (g1.dof(1), g1.var_scale) == (4.0, 1.0)


@pytest.mark.slow
def test_forgetting_variance_matches_the_scatter_of_the_estimate():
    rng = np.random.default_rng(5)
    lam, p, sigma, N = 0.97, 3, 0.5, 150     # N: ~5 memories of lam (steady state)
    x_true = np.array([1.0, -2.0, 0.5])
    est, var = [], []
    for _ in range(300):
        rls, gram = RLS(np.zeros(p), 1e6 * np.eye(p), lam), Gram.empty(p + 1, lam)
        for _ in range(N):
            H = rng.normal(size=(2, p))
            y = H @ x_true + sigma * rng.normal(size=2)
            rls.update(H, y)
            gram = gram.add(np.column_stack([H, y]))
        s2 = gram.residual_variance(np.append(rls.x, -1.0), p)
        est.append(rls.x)
        var.append(np.diag(rls.P) * s2 * gram.var_scale)
    ratio = np.mean(var, axis=0) / np.var(est, axis=0)
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio       # without var_scale: ~ 1 + lam


# ------------------------------------------------------------------------------------------------
# correlated residuals
# ------------------------------------------------------------------------------------------------

def _inflation(e, lags):
    a = Autocorrelation.empty(lags)
    for x in e:
        a = a.add(np.atleast_1d(x))
    return a.inflation()


@pytest.mark.parametrize("lam", [1.0, 0.97])
def test_autocorrelation_sums_equal_the_direct_sums(lam):
    """The ring's sums ``c[j] = sum_t lam^(N-t) e_t . e_(t-j)`` equal the direct sums over the
    whole sequence (pairs of different lengths left out), after every sample; an update leaves
    the one it started from unchanged (snapshots are references); the inflation is the
    Bartlett-weighted ratio of the direct sums."""
    rng = np.random.default_rng(8)
    L, N = 7, 40
    es = [rng.normal(size=2 if t in (0, 5, 17) else 3) for t in range(N)]   # the ring widens
    a = Autocorrelation.empty(L, lam)
    for n in range(N):
        before, c_before, ring_before = a, a.c.copy(), a.ring.copy()
        a = a.add(es[n])
        np.testing.assert_array_equal(before.c, c_before)
        np.testing.assert_array_equal(before.ring, ring_before)
        want = np.zeros(L + 1)
        for t in range(n + 1):
            for j in range(min(L, t) + 1):
                if len(es[t]) == len(es[t - j]):
                    want[j] += lam ** (n - t) * (es[t] @ es[t - j])
        np.testing.assert_allclose(a.c, want, rtol=1e-13, atol=1e-13 * want[0])
        j = np.arange(1, L + 1)
        f = 1.0 + 2.0 * np.sum((1.0 - j / (L + 1.0)) * want[1:]) / want[0]
        assert a.inflation() == pytest.approx(max(f, 1.0), rel=1e-12)


@pytest.mark.slow
def test_autocorrelation_inflation_is_the_long_run_variance_ratio():
    """Bartlett-weighted sums: ``1 + 2 sum_j (1 - j/(L+1)) rho_j`` (tolerances ~ 3 standard
    errors of the estimate, ``sqrt(4 L / 3 N)`` relative)."""
    rng = np.random.default_rng(2)
    u = rng.normal(size=20001)
    ma1 = u[1:] + u[:-1]                       # rho_1 = 0.5, rho_j = 0 beyond
    L = 20
    assert _inflation(ma1, L) == pytest.approx(1 + 2 * (1 - 1 / (L + 1)) * 0.5, rel=0.1)
    assert _inflation(u, L) == pytest.approx(1.0, abs=0.1)
    assert _inflation(ma1, 0) == 1.0
    ar = np.empty(20000)                       # AR(1), rho_j = 0.9^j
    ar[0] = 0.0
    for k in range(1, len(ar)):
        ar[k] = 0.9 * ar[k - 1] + u[k]
    j = np.arange(1, 51)
    expected = 1 + 2 * np.sum((1 - j / 51) * 0.9 ** j)          # 15.5 (all lags: 19)
    assert _inflation(ar, 50) == pytest.approx(expected, rel=0.2)
    # the rows of a sample are pooled: two independent copies give the same ratio
    pair = np.column_stack([ma1[:10000], ma1[10000:20000]])
    assert _inflation(pair, L) == pytest.approx(1 + 2 * (1 - 1 / (L + 1)) * 0.5, rel=0.1)


# ------------------------------------------------------------------------------------------------
# forgetting with the excitation always on; calibration under noise
# ------------------------------------------------------------------------------------------------

@pytest.mark.slow
def test_forgetting_with_excitation_always_on_identifies_a_spatial_case():
    sc = random_scenario("spatial", np.random.default_rng(3))
    p = plant_of(sc, sc.excitation)
    ident = Identifier(sc.robot, sc.guess, "force", lam=0.995,
                       excite={"excite_mode": ExciteMode.ALWAYS, "excite_level": 1.0})
    request = ident.excite_request
    truth = estimate_vector(sc.robot.base, sc.target)
    levels = []
    for k in range(601):
        if k:
            p.advance(sc.sample_time)
        ident.update(p.t, p.outputs())
        level = request(ident.report().identified)
        p.set_excitation(level)
        levels.append(level)
    assert set(levels) == {1.0}                 # ALWAYS: excited also once identified
    err = relative_errors(ident.vector(), truth)
    assert err.max() < 1e-3, err.max()
    assert all(ident.report().identified.values())
    assert np.all(np.isfinite(ident.std()))


@pytest.mark.slow
def test_standard_deviations_are_calibrated_on_a_short_noisy_run():
    sc = scenario("spatial")
    p = plant_of(sc, sc.excitation)
    p.set_excitation(1.0)
    sensors = SensorSuite(sc.robot.n_joints, seed=4)
    kw = dict(method="force", row_sd=(5.0, 5.0))
    idents = {lags: Identifier(sc.robot, sc.guess, corr_lags=lags, **kw) for lags in (0, 200)}
    for k in range(601):
        if k:
            p.advance(sc.sample_time)
        y = sensors.update(p.outputs(), sc.sample_time)
        for ident in idents.values():
            ident.update(p.t, y)
    truth = estimate_vector(sc.robot.base, sc.target)
    within = {lags: np.mean(np.abs(i.vector() - truth) <= 2 * i.std())
              for lags, i in idents.items()}
    assert within[200] >= 0.9, within
    assert within[0] < within[200], within


def test_state_round_trip_and_rejected_samples_with_the_noise_model(planar_samples):
    """The window, the residual correlation sums and the weights are state: a restored
    identifier continues bit for bit, and a rejected sample leaves no trace."""
    sc, samples = planar_samples
    kw = dict(method="force", accel_source="differenced", row_sd=(0.5, 2.0),
              diff_half_window=3, corr_lags=10)
    a, b = Identifier(sc.robot, sc.guess, **kw), Identifier(sc.robot, sc.guess, **kw)
    for t, s in samples[:40]:
        a.update(t, s)
        b.update(t, s)
    state = a.get_state()
    bad = dict(samples[40][1], v_S=np.array([np.nan, 0.0, 0.0]))
    assert a.update(samples[40][0], bad) == 3                   # rejected: non-finite
    for t, s in samples[40:]:
        a.update(t, s)
        b.update(t, s)
    first = (a.vector().copy(), a.std().copy())
    np.testing.assert_array_equal(first[0], b.vector())          # the rejected sample: no trace
    np.testing.assert_array_equal(first[1], b.std())
    c = Identifier(sc.robot, sc.guess, **kw)
    c.set_state(state)
    for t, s in samples[40:]:
        c.update(t, s)
    np.testing.assert_array_equal(c.vector(), first[0])
    np.testing.assert_array_equal(c.std(), first[1])
    fresh = Identifier(sc.robot, sc.guess, **kw)                 # negative control
    for t, s in samples[40:]:
        fresh.update(t, s)
    assert not np.array_equal(fresh.vector(), first[0])
