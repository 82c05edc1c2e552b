"""The compiled report (spacerobot.estimator.report_kernels: standard deviations with the
prior's pull, physical test, identified flags) against the NumPy formulation of the test oracle
tests/oracles/report.py, on identification runs and on random input.

The oracle uses LAPACK (``np.linalg.eigh``, ``np.linalg.solve``), the kernels their own
Householder-QL eigen-decomposition and LU solve, and the products sum in another order, so the
two agree to round-off, amplified by the conditioning of the information matrices: during the
first seconds of a run, when they are nearly singular (scaled eigenvalues down to 1e-12 of the
largest, just above the cut of REL_EIG_MIN), a one-ulp difference in the mass pull moves the
inertia pull by up to ~2e-3 relative, in either formulation. From the time the information is
well conditioned on, they agree to ~1e-9 beyond a few ulps of the estimate (the pull is a
difference of the map at two points).
"""
import numpy as np
import pytest

from oracles import report as orc
from spacerobot import interface, scenario
from spacerobot.estimator import Identifier, physical
from spacerobot.estimator import report_kernels as rk
from spacerobot.estimator.tracking import DriftTracker
from spacerobot.estimator.uncertainty import observed_solve
from spacerobot.plant import Plant

#: samples after which the run's information matrices are well conditioned (4 s at 0.1 s)
WELL_CONDITIONED = 40


@pytest.fixture(scope="module")
def runs():
    """Plant outputs every 0.1 s for 8 s, per robot."""
    out = {}
    for robot in ("planar", "spatial"):
        sc = scenario(robot)
        p = Plant(sc.robot, sc.robot.base, sc.target, sc.controller, sc.v0, sc.omega0, sc.h)
        outs = [p.outputs()]
        for _ in range(80):
            p.advance(0.1)
            outs.append(p.outputs())
        out[robot] = (sc, outs)
    return out


def oracle_report(ident, sd):
    """What Identifier.report() computes, from the oracle's projection and ``sd``."""
    L, ls = ident.layout, ident.vector()
    out, identified, physical_ = ls.copy(), {}, {}
    project = orc.project_planar_body if ident.robot.planar else orc.project_body
    for b, g in zip(L.bodies, (ident.guess.base, ident.guess.target)):
        m, com, I6, projected = project(ls[b.m], ls[b.first], ls[b.inertia], g.mass)
        out[b.m], out[b.first], out[b.inertia] = m, com, I6
        physical_[b.name] = not projected
    tol = ident.sd_rel * L.error_scale(out)
    ok = (sd <= tol) & (np.abs(out - ls) <= tol)
    for b in L.bodies:
        identified[b.name] = bool(ident.samples > 0 and ok[b.vec][L.identified[b.vec]].all())
    return out, identified, physical_


def joint_std(solver):
    """The joint solver's standard deviations, with the oracle's prior pull."""
    g, x, act = solver.gram, solver.rls.x, solver.layout.standard_active
    d, u = orc.prior_pull(g.decay * solver._W0, g.S[:len(x), :len(x)], x, solver._pi0)
    delta, unobs_z = np.zeros(20), np.zeros(20, bool)
    delta[act], unobs_z[act] = d, u
    z = solver.z()
    J = solver.jacobian(z)
    with np.errstate(all="ignore"):
        pull = solver.vector_of(z) - solver.vector_of(z - delta)
    if not np.all(np.isfinite(pull)):
        pull = J @ delta
    var = np.einsum("ij,jk,ik->i", J, solver.covariance(), J) + pull ** 2
    sd = np.sqrt(np.clip(var, 0.0, None))
    unobserved = (J[:, unobs_z] != 0.0).any(axis=1)
    if unobserved.any():
        floor = solver.layout.error_scale(solver.vector())
        sd[unobserved] = np.maximum(sd[unobserved], floor[unobserved])
    return sd


@pytest.mark.parametrize("robot", ["planar", "spatial"])
@pytest.mark.parametrize("solver,lam,lags", [("paper", 1.0, 0), ("paper", 0.995, 3),
                                             ("joint", 1.0, 0)])
def test_report_equals_the_numpy_oracle(runs, robot, solver, lam, lags):
    sc, outs = runs[robot]
    ident = Identifier(sc.robot, sc.guess, "momentum", solver, lam=lam, corr_lags=lags)
    early = late = 0.0
    for k, o in enumerate(outs):
        ident.update(0.1 * k, o)
        rep = ident.report()
        sd = orc.paper_std(ident.solver) if solver == "paper" else joint_std(ident.solver)
        # the solver's sd (the compiled part); the report adds the tracker's lag term to it
        # beyond the resolution of the pull, a difference of the map at two points: a few
        # ulps of the estimate (the noise-free pull is down to 1e-8 of it)
        ulps = 4.0 * np.finfo(float).eps * np.abs(ident.vector())
        rel = np.max(np.maximum(np.abs(ident.solver.std() - sd) - ulps, 0.0) / np.abs(sd))
        if ident.samples >= WELL_CONDITIONED:
            late = max(late, rel)
        else:
            early = max(early, rel)
        out, identified, physical_ = oracle_report(ident, rep.std)
        assert np.array_equal(rep.vector == ident.vector(), out == ident.vector())
        scale = np.abs(out).reshape(2, -1).max(axis=1).repeat(10)
        assert np.all(np.abs(rep.vector - out) <= 1e-13 * scale), k
        assert rep.physical == physical_ and rep.identified == identified, k
    assert late <= 2e-9, late          # measured: up to 6.4e-10 (spatial, joint solver)
    assert early <= 1e-2, early        # measured: up to 1.7e-3 (spatial, paper, lam 0.995)


def test_paper_parts_equal_the_oracle(runs):
    sc, outs = runs["spatial"]
    ident = Identifier(sc.robot, sc.guess, "momentum")
    for k, o in enumerate(outs[:WELL_CONDITIONED + 10]):
        ident.update(0.1 * k, o)
    s = ident.solver
    z = s.z()
    assert np.array_equal(s.jacobian(z), orc.paper_jacobian(s, z))
    assert np.array_equal(s.vector_of(z), orc.paper_vector_of(s, z))
    C, C0 = s.covariance(), orc.paper_covariance(s)
    assert np.allclose(C, C0, rtol=1e-12, atol=1e-12 * np.abs(C0).max())
    (d, u), (d0, u0) = s.prior_pull(), orc.paper_prior_pull(s)
    assert np.array_equal(u, u0)
    assert np.allclose(d, d0, rtol=1e-9, atol=1e-12 * np.abs(d0).max())


def test_joint_map_and_jacobian_equal_the_oracle(runs):
    """The compiled map of the joint solver gives the estimates themselves: the same bit for
    bit as the NumPy formulation (same operations, same order); its Jacobian to round-off."""
    sc, outs = runs["spatial"]
    ident = Identifier(sc.robot, sc.guess, "momentum", "joint")
    rng = np.random.default_rng(5)
    zs = []
    for k, o in enumerate(outs):
        ident.update(0.1 * k, o)
        zs.append(ident.solver.z().copy())
    zs += [zs[-1] * (1.0 + 0.3 * rng.normal(size=20)) + rng.normal(size=20) for _ in range(500)]
    for z in zs:
        assert np.array_equal(ident.solver.vector_of(z), orc.joint_vector_of(z))
        J, J0 = ident.solver.jacobian(z), orc.joint_jacobian(z)
        assert np.allclose(J, J0, rtol=1e-14, atol=0.0)
        assert np.array_equal(J != 0.0, J0 != 0.0)


@pytest.mark.parametrize("n", [1, 3, 8, 12, 20])
def test_lu_solve_equals_lapack(n):
    scipy_linalg = pytest.importorskip("scipy.linalg")
    rng = np.random.default_rng(n)
    for trial in range(40):
        A = rng.normal(size=(n, n)) * np.geomspace(1.0, 1e-3, n)   # column scales 1 .. 1e-3
        if trial % 4 == 0 and n > 1:
            A[0, 0] = 0.0                                   # needs a row exchange
        B = rng.normal(size=(n, 1 + trial % 5))
        X, X0 = rk.lu_solve(A, B), scipy_linalg.solve(A, B)
        cond = np.linalg.cond(A)
        assert np.allclose(X, X0, rtol=0, atol=1e-14 * cond * np.abs(X0).max()), cond
        assert np.allclose(rk.lu_solve_vec(A, B[:, 0]), X0[:, 0], rtol=0,
                           atol=1e-14 * cond * np.abs(X0).max())
    S = rng.normal(size=(n, n))
    S[:, n // 2] = 0.0                                      # singular: LAPACK refuses, NaN here
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.solve(S, B[:, :1])
    assert np.isnan(rk.lu_solve(S, B)).all()


@pytest.mark.parametrize("n", [0, 1, 2, 8, 12, 20])
def test_eigh_equals_lapack(n):
    """The compiled eigen-decomposition: LAPACK's eigenvalues to round-off of the largest,
    orthonormal eigenvectors that rebuild the matrix, ascending order; for positive
    semi-definite (rank-deficient, a zero row) and indefinite matrices."""
    rng = np.random.default_rng(10 + n)
    for trial in range(60):
        if trial % 2:
            H = rng.normal(size=(rng.integers(1, 2 * n + 2), n)) * np.geomspace(1, 1e-3, n)
            A = H.T @ H
        else:
            B = rng.normal(size=(n, n))
            A = B + B.T
        if trial % 5 == 0 and n:
            A[:, n // 2] = A[n // 2, :] = 0.0
        lam, V, ok = rk.eigh(A)
        lam0 = np.linalg.eigvalsh(A)
        size = max(np.abs(lam0).max(), 1e-300) if n else 1.0
        assert ok and np.all(np.diff(lam) >= 0.0)
        assert np.allclose(lam, lam0, rtol=0, atol=1e-14 * size)
        assert np.allclose(V.T @ V, np.eye(n), rtol=0, atol=1e-14)
        assert np.allclose((V * lam) @ V.T, A, rtol=0, atol=1e-14 * size)
    A = np.eye(max(n, 1))
    A[0, 0] = np.nan
    assert not rk.eigh(A)[2] or np.isnan(rk.eigh(A)[0]).any()


@pytest.mark.parametrize("solver", ["paper", "joint"])
def test_drift_lag_equals_the_oracle(runs, solver):
    """The compiled lag of eq. (2) (spacerobot.estimator.tracking) equals the NumPy/LAPACK
    formulation, once the information is well conditioned, at the identifier's own ages and at
    random rates."""
    sc, outs = runs["spatial"]
    ident = Identifier(sc.robot, sc.guess, "momentum", solver, lam=0.995)
    rng = np.random.default_rng(6)
    worst = 0.0
    for k, o in enumerate(outs):
        ident.update(0.1 * k, o)
        if ident.samples < WELL_CONDITIONED:
            continue
        s, ages = ident.solver, ident.tracking.ages
        rate, growth = rng.normal(size=20) * np.abs(s.z()), rng.uniform(0.0, 0.02)
        lag = s.drift_lag(rate, growth, ages)
        if solver == "paper":
            lag0 = orc.paper_drift_lag(s, rate, growth, ages)
        else:
            lag0 = orc.block_lag(s.information()[0][:20, :20], ages[0][:20, :20], rate,
                                 growth)[0]
        worst = max(worst, np.max(np.abs(lag - lag0)) / np.max(np.abs(lag0)))
    assert worst <= 1e-10, worst


@pytest.mark.parametrize("robot", ["planar", "spatial"])
def test_estimates_lag_in_one_call_equals_the_composition(runs, robot):
    """The paper solver's lag of the estimates in one compiled call
    (report_kernels.paper_estimates_lag) equals tracking.matrix_lag with the solver's
    drift_lag (the three compiled calls it fuses) bit for bit, at the identifier's ages and
    Jacobians, from the first samples (singular blocks: both None) on, at the run's rates and
    random ones."""
    from spacerobot.estimator.tracking import matrix_lag
    sc, outs = runs[robot]
    ident = Identifier(sc.robot, sc.guess, "momentum", "paper", lam=0.995)
    rng = np.random.default_rng(8)
    compared = 0
    for k, o in enumerate(outs):
        ident.update(0.1 * k, o)
        s, tr = ident.solver, ident.tracking
        if not tr.ages:
            continue
        jac = s.jacobian(s.z())
        for rate in (np.asarray(tr.slope, float), rng.normal(size=20) * np.abs(s.z())):
            growth = rng.uniform(0.0, 0.02)
            got = s.estimates_lag(rate, growth, tr.ages, jac)
            want = matrix_lag(rate, growth, tr.ages, jac, s.drift_lag)
            assert (got is None) == (want is None)
            if want is not None:
                assert np.array_equal(got, want)
                compared += 1
    assert compared > 100


@pytest.mark.parametrize("robot,lam,lags", [("planar", 1.0, 0), ("spatial", 1.0, 0),
                                             ("spatial", 0.995, 3)])
def test_std_parts_in_one_call_equal_the_composition(runs, robot, lam, lags):
    """The paper solver's standard deviations in one compiled call (paper_std_parts) equal the
    composition it fuses (the residual variances, the pull's eigen-decompositions,
    paper_uncertainty: each compiled on its own) bit for bit, at every sample of a run."""
    sc, outs = runs[robot]
    ident = Identifier(sc.robot, sc.guess, "momentum", "paper", lam=lam, corr_lags=lags)
    for k, o in enumerate(outs):
        ident.update(0.1 * k, o)
        s, L, g0 = ident.solver, ident.layout, ident.guess
        s2_lin, s2_ang = s._residual_variances()
        w_mu, w_theta, eig_lin, eig_ang = s._pull_inputs()
        want = rk.paper_uncertainty(
            s.mu, s.theta, s.rls.mu, s.rls.theta, s.rls.D_mu, s.rls.M, s.rls.lin.P, s.rls.ang.P,
            s.gram_ang.S, s2_lin, s2_ang, g0.P0_mu, g0.P0_theta, w_mu, w_theta, s._mu0, s._th0,
            L.mu_active, L.theta_active, s._s2p, eig_lin, eig_ang, s._mu_rls_full())
        got = s.uncertainty_parts()
        for a, b in zip(got, want):
            assert np.array_equal(a, b)


@pytest.mark.parametrize("robot,lam", [("planar", 1.0), ("spatial", 1.0), ("spatial", 0.995)])
def test_tracker_in_one_call_equals_drift_tracker_add(runs, robot, lam):
    """The paper solver's tracker step in one compiled call (PaperSolver.track,
    report_kernels.paper_tracker_add) equals DriftTracker.add with the solver's drift_lag
    (NumPy glue around four compiled calls) in every field, bit for bit, at every sample of a
    run: the identifier's own tracker (made by the first) against one made by the second."""
    from spacerobot.estimator.solvers import ParameterSolver
    sc, outs = runs[robot]
    ident = Identifier(sc.robot, sc.guess, "momentum", "paper", lam=lam)
    mine = None
    for k, o in enumerate(outs):
        info = ident.solver.information()
        before = ident.tracking
        ident.update(0.1 * k, o)
        if ident.tracking is before:
            continue                                     # the reference sample
        u = ident.solver.std_parts()
        mine = ParameterSolver.track(ident.solver, before if mine is None else mine,
                                     float(ident.samples - 1), u.data_only, u.sd, info,
                                     u.jacobian)
        for name, a, b in zip(mine._fields, ident.tracking, mine):
            if isinstance(a, tuple):
                assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))
            elif a is None or b is None:
                assert a is None and b is None, name
            else:
                assert np.array_equal(a, b, equal_nan=True), name
    assert mine is not None and mine.mat_lag is not None


def test_layout_constants_of_the_kernels():
    L = interface.LAYOUT
    for k, b in enumerate(L.bodies):
        assert (rk.EST0[k], rk.MU0[k], rk.ZTH0[k]) == (b.m, b.mu_m, L.n_mu + b.theta.start)
        assert b.first.start == b.m + 1 and b.inertia == slice(b.m + 4, b.m + 10)
    assert (rk.N_MU, rk.N_THETA) == (L.n_mu, L.n_theta)
    from spacerobot.estimator.parameters import SHARP_PAIRS
    assert list(zip(rk.SHARP_I, rk.SHARP_J)) == list(SHARP_PAIRS)


def test_observed_solve_equals_the_oracle_on_rank_deficient_information():
    rng = np.random.default_rng(3)
    for p in (3, 8, 12):
        for _ in range(50):
            H = rng.normal(size=(rng.integers(1, 2 * p), p)) * np.geomspace(1, 1e-2, p)
            if rng.random() < 0.3:
                H[:, rng.integers(p)] = 0.0                  # a parameter never seen
            G, r = H.T @ H, rng.normal(size=p)
            (x, u), (x0, u0) = observed_solve(G, r), orc.observed_solve(G, r)
            assert np.array_equal(u, u0)
            assert np.allclose(x, x0, rtol=0, atol=1e-10 * np.abs(x0).max())


@pytest.mark.parametrize("planar", [False, True])
def test_projection_equals_the_oracle(planar):
    rng = np.random.default_rng(4)
    ours = physical.project_planar_body if planar else physical.project_body
    theirs = orc.project_planar_body if planar else orc.project_body
    moved = 0
    for _ in range(500):
        m = rng.uniform(-10, 100)
        b = rng.normal(size=3)
        I6 = np.concatenate([rng.uniform(-5, 50, 3), rng.normal(size=3) * 5])
        got, want = ours(m, b, I6, 50.0), theirs(m, b, I6, 50.0)
        assert got[3] == want[3] and got[0] == want[0]
        assert np.array_equal(got[1], want[1])
        assert np.allclose(got[2], want[2], rtol=0, atol=1e-13 * np.abs(want[2]).max())
        assert physical.is_physical(m, b, I6) == orc.is_physical(m, b, I6)
        moved += got[3]
    assert 50 < moved < 500                     # both kinds of body were met


def test_report_flags_equal_the_separate_kernels():
    """report_flags (one call) against both_physical, error_scale and identified_bodies: the
    physical flags always, the identified ones where both bodies are physical (else it
    returns False and the caller projects), on random estimates, some not physical."""
    rng = np.random.default_rng(7)
    ident = interface.LAYOUT.identified
    both = projected = 0
    for k in range(3000):
        ls = np.empty(20)
        for e in (0, 10):
            ls[e] = rng.uniform(-5.0, 100.0)
            ls[e + 1:e + 4] = rng.normal(0.0, 0.3, 3)
            ls[e + 4:e + 7] = rng.uniform(1.0, 20.0, 3)
            ls[e + 7:e + 10] = rng.normal(0.0, 1.0, 3)
        sd = np.abs(ls) * 10.0 ** rng.uniform(-6, 0, 20)
        sd_rel = 10.0 ** rng.uniform(-3, -1)
        flags = np.empty(4, bool)
        got = rk.report_flags(ls, sd, interface.COM_SCALE_MIN, sd_rel, ident, flags)
        physical, ok = np.empty(2, bool), np.empty(2, bool)
        rk.both_physical(ls, physical)
        assert got == bool(physical.all()) and np.array_equal(flags[:2], physical)
        if got:
            scale = rk.error_scale(ls, interface.COM_SCALE_MIN)
            rk.identified_bodies(sd, ls, ls, scale, sd_rel, ident, ok)
            assert np.array_equal(flags[2:], ok)
            both += ok.any()
        projected += not got
    assert both > 50 and projected > 50


def test_error_scale_equals_the_layouts():
    """The compiled error scale (Identifier.report's) equals ParameterLayout.error_scale bit for
    bit: random estimates with zeros, CoM offsets around COM_SCALE_MIN, negative entries, NaN
    and infinities in every position."""
    rng = np.random.default_rng(7)
    specials = [0.0, -0.0, np.nan, np.inf, -np.inf, interface.COM_SCALE_MIN, -1e-3, 1e300]
    for _ in range(2000):
        v = rng.normal(0.0, 10.0, 20) * rng.choice([1e-3, 1.0, 1e3], 20)
        for i in rng.choice(20, rng.integers(0, 8), replace=False):
            v[i] = specials[rng.integers(len(specials))]
        want = interface.LAYOUT.error_scale(v)
        got = rk.error_scale(v, interface.COM_SCALE_MIN)
        assert np.array_equal(got, want, equal_nan=True), v


def test_rcond_short_path_equals_numpy(runs):
    """The excitation diagnostics' short path (compiled scaling, NumPy's eigvalsh gufunc) gives
    the NumPy formulation's reciprocal condition numbers bit for bit, on the information of a
    run and on random matrices, and the same answer where it falls back (a zero diagonal
    entry, NaN)."""
    from spacerobot.estimator import identifier as idm
    sc, outs = runs["spatial"]
    ident = Identifier(sc.robot, sc.guess)
    mats = []
    for k, o in enumerate(outs[:40]):
        ident.update(0.1 * k, o)
        mats += [ident.info_lin.copy(), ident.info_ang.copy()]
    rng = np.random.default_rng(3)
    for n in (1, 3, 8, 12):
        H = rng.normal(size=(2 * n, n)) * rng.choice([1e-6, 1.0, 1e6], n)
        mats.append(H.T @ H)
    singular = mats[-1].copy()
    singular[2, :] = singular[:, 2] = 0.0
    mats.append(singular)
    for G in mats:
        assert idm._rcond(G) == idm._rcond_numpy(G)
    assert idm._rcond(singular) == 0.0
    bad = mats[-2].copy()
    bad[0, 1] = bad[1, 0] = np.nan
    with pytest.raises(np.linalg.LinAlgError):
        idm._rcond_numpy(bad)
    with pytest.raises(np.linalg.LinAlgError):
        idm._rcond(bad)


@pytest.mark.parametrize("robot,kw", [("planar", {}), ("spatial", {}),
                                      ("spatial", {"lam": 0.995}),
                                      ("spatial", {"method": "force", "accel_sd": 1e-3})])
def test_excitation_from_the_update_equals_numpy_on_the_information(runs, robot, kw,
                                                                   monkeypatch):
    """The excitation diagnostics the paper solver's update computes from the spectra of its
    standard deviations (report_kernels.rcond_of_spectrum on the Gram matrices' parameter
    blocks) equal NumPy's eigvalsh of the identifier's own information matrices (scaled to unit
    diagonal; _rcond_numpy) at every sample, to round-off (bias-compensated path included)."""
    from spacerobot.estimator import identifier as idm
    sc, outs = runs[robot]
    kw = dict(kw)
    sd = kw.pop("accel_sd", None)
    if sd is not None:                           # the bias-compensated (eiv) path
        kw["signal_sd"] = {"a_S": sd}
    ident = Identifier(sc.robot, sc.guess, solver="paper", **kw)
    with monkeypatch.context() as mp:            # the update's values, never the lazy path's
        mp.setattr(idm, "_rcond", lambda G: pytest.fail("excitation computed lazily"))
        got_all = []
        for k, o in enumerate(outs):
            ident.update(0.1 * k, o)
            if ident.samples:                    # (none before the momentum reference)
                got_all.append((k, ident.excitation(), ident.info_lin.copy(),
                                ident.info_ang.copy()))
    for k, got, info_lin, info_ang in got_all:
        want = (idm._rcond_numpy(info_lin), idm._rcond_numpy(info_ang))
        for g, w in zip(got, want):
            assert g == pytest.approx(w, rel=1e-8, abs=1e-13), (k, got, want)
    assert len(got_all) > 50 and got_all[-1][1][0] > 1e-6


@pytest.mark.parametrize("robot,kw", [("planar", {}), ("spatial", {}),
                                      ("spatial", {"lam": 0.995}),
                                      ("spatial", {"method": "force", "window": 0.0}),
                                      ("spatial", {"window": 2.0, "moving_point": True}),
                                      ("planar", {"row_sd": (1e-3, 1e-2)})])
def test_fused_step_equals_the_layers(runs, robot, kw):
    """The paper solver's fused step (PaperSolver.step: one compiled call per sample) against the
    same identifier run through the layers (update, std_parts, track; solver.fused = False),
    side by side at every sample: the RLS state and the estimates bit for bit, the Gram and
    information matrices to round-off (their sums are written out instead of BLAS's), and the
    fused run's reported standard deviations and tracker equal to what the layers compute from
    the fused run's own state (std_parts, DriftTracker.add through ParameterSolver.track) bit
    for bit."""
    from spacerobot.estimator.solvers import ParameterSolver
    sc, outs = runs[robot]
    fused = Identifier(sc.robot, sc.guess, solver="paper", **kw)
    layered = Identifier(sc.robot, sc.guess, solver="paper", **kw)
    layered.solver.fused = False
    assert fused.solver.fuses(None, None) and not layered.solver.fuses(None, None)
    checked = 0
    for k, o in enumerate(outs):
        info, before = fused.solver.information(), fused.tracking
        fused.update(0.1 * k, o)
        layered.update(0.1 * k, o)
        a, b = fused.solver, layered.solver
        for x, y in ((a.rls.mu, b.rls.mu), (a.rls.theta, b.rls.theta), (a.rls.lin.P, b.rls.lin.P),
                     (a.rls.ang.P, b.rls.ang.P), (a.rls.M, b.rls.M), (fused.vector(),
                                                                       layered.vector())):
            assert np.array_equal(x, y)
        for x, y in ((a.gram_lin.S, b.gram_lin.S), (a.gram_ang.S, b.gram_ang.S),
                     (fused.info_lin, layered.info_lin), (fused.info_ang, layered.info_ang)):
            assert np.allclose(x, y, rtol=1e-13, atol=1e-13 * np.abs(y).max())
        assert (a.gram_lin.rows, a.gram_lin.decay, a.gram_ang.n1) == (
            b.gram_lin.rows, b.gram_lin.decay, b.gram_ang.n1)
        assert fused.residual_lin == pytest.approx(layered.residual_lin, rel=1e-12, abs=1e-300)
        if fused.tracking is before:
            continue                                     # the momentum reference sample
        u = a.std_parts()                                # the layers on the fused state
        assert np.array_equal(fused.tracking.sd, u.sd)
        # what the report reads, as the fused step computed it (no call of the tracker's
        # total_sd), against the layers on the fused state: the estimates and the tracker's
        # total standard deviations
        calls = []
        total_sd = DriftTracker.total_sd
        DriftTracker.total_sd = lambda self: calls.append(1) or total_sd(self)
        try:
            rep, vec, sd = fused.report(), fused.vector(), fused.std()
        finally:
            DriftTracker.total_sd = total_sd
        assert not calls
        assert np.array_equal(vec, a.vector())
        assert np.array_equal(sd, fused.tracking.total_sd())
        assert np.array_equal(rep.std, sd)
        vec[:] = sd[:] = rep.std[:] = rep.vector[:] = -1.0        # copies: nothing kept changes
        assert np.array_equal(fused.vector(), a.vector())
        assert np.array_equal(fused.std(), fused.tracking.total_sd())
        want = ParameterSolver.track(a, before, float(fused.samples - 1), u.data_only, u.sd,
                                     info, u.jacobian)
        for name, x, y in zip(want._fields, fused.tracking, want):
            if isinstance(x, tuple):
                assert all(np.array_equal(p, q) for p, q in zip(x, y)), name
            elif x is None or y is None:
                assert x is None and y is None, name
            else:
                assert np.array_equal(x, y, equal_nan=True), name
        checked += 1
    assert checked > 50
    # a copy of the state computes them afresh (nothing kept): the same numbers
    copy = Identifier(sc.robot, sc.guess, solver="paper", **kw)
    copy.set_state(fused.get_state())
    assert np.array_equal(copy.vector(), fused.vector())
    assert np.array_equal(copy.std(), fused.std())
