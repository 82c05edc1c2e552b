"""Physical consistency of estimates: the test and the projection (spacerobot.estimator.physical,
the core's through its Python face).

Checked against independent computations: the triangle-inequality test of robots.check_body,
the pseudo-inertia's eigenvalues, brute-force nearest points of random feasible bodies, and the
oracle's NumPy/LAPACK projections (tests/oracles/estimator/physical.py).
"""
import numpy as np
import pytest

from oracles.estimator.physical import (_project_body_numpy, _project_planar_body_numpy,
                                        inertia_from_second_moment, pseudo_inertia)
from spacerobot.estimator.physical import (is_physical, project_body, project_planar_body,
                                           second_moment)
from spacerobot.robots import check_body



def random_rotation(rng):
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    return Q * np.sign(np.diag(R))


def random_body(rng):
    """A real body: a box of random proportions, random orientation, random CoM."""
    m = rng.uniform(50.0, 700.0)
    sx, sy, sz = rng.uniform(0.1, 2.0, size=3)
    D = m / 12.0 * np.diag([sy**2 + sz**2, sx**2 + sz**2, sx**2 + sy**2])
    R = random_rotation(rng)
    I = R @ D @ R.T
    return m, rng.uniform(-0.3, 0.3, size=3), np.array([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])


def physical_by_check_body(m, b, I6):
    try:
        check_body("x", m, b, I6)
        return True
    except ValueError:
        return False


def test_second_moment_round_trip_and_pseudo_inertia():
    RNG = np.random.default_rng(20261123)
    for _ in range(50):
        m, b, I6 = random_body(RNG)
        assert np.allclose(inertia_from_second_moment(second_moment(I6)), I6, rtol=0, atol=1e-12)
        J = pseudo_inertia(m, b, I6)
        # J is the second-moment matrix [x; 1][x; 1]^T dm of the body about O: its (4,4) entry
        # is m, its last column m b, and it is positive definite for a real body
        assert J[3, 3] == m and np.allclose(J[:3, 3], m * b)
        assert np.linalg.eigvalsh(J)[0] > 0


def test_is_physical_agrees_with_triangle_inequality_test():
    RNG = np.random.default_rng(20261123)
    agree = 0
    for _ in range(400):
        m, b, I6 = random_body(RNG)
        noisy = I6 + RNG.normal(scale=0.2 * np.abs(I6[:3]).max(), size=6)
        mm = m * RNG.choice([1.0, 1.0, 1.0, -0.1])
        expected = physical_by_check_body(mm, b, noisy)
        assert is_physical(mm, b, noisy) == expected
        agree += expected
    assert 20 < agree < 380          # both branches were exercised


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_is_not_physical(bad):
    RNG = np.random.default_rng(20261123)
    m, b, I6 = random_body(RNG)
    assert not is_physical(bad, b, I6)
    I6 = I6.copy()
    I6[2] = bad
    assert not is_physical(m, b, I6)


def test_projection_is_identity_on_physical_bodies_bit_for_bit():
    RNG = np.random.default_rng(20261123)
    for _ in range(100):
        m, b, I6 = random_body(RNG)
        m2, b2, I2, projected = project_body(m, b, I6, m_scale=m)
        assert not projected
        assert m2 == m and np.array_equal(b2, b) and np.array_equal(I2, I6)


def test_projection_output_is_always_physical_on_noisy_estimates():
    """Random noisy estimates, many of them impossible (negative masses and inertias,
    triangle inequality violated): the output is always a real body."""
    RNG = np.random.default_rng(20261123)
    n_projected = 0
    for _ in range(500):
        m, b, I6 = random_body(RNG)
        scale = RNG.choice([0.01, 0.3, 3.0])
        mm = m + RNG.normal(scale=scale * m)
        I_noisy = I6 + RNG.normal(scale=scale * np.abs(I6[:3]).max(), size=6)
        m2, b2, I2, projected = project_body(mm, b, I_noisy, m_scale=m)
        n_projected += projected
        assert is_physical(m2, b2, I2)
        assert physical_by_check_body(m2, b2, I2)
        assert np.array_equal(b2, b)                 # the CoM is never moved
        if mm > 0:
            assert m2 == mm                          # a positive mass is kept
        # idempotent
        m3, b3, I3, again = project_body(m2, b2, I2, m_scale=m)
        assert not again and m3 == m2 and np.array_equal(I3, I2)
    assert n_projected > 100


@pytest.mark.slow
def test_projection_is_the_nearest_real_body():
    """Optimality against brute force: no real body (random, and on the segment to the
    output) is nearer to the estimate in the Frobenius distance of Sigma_c."""
    RNG = np.random.default_rng(20261123)
    for _ in range(60):
        m, b, I6 = random_body(RNG)
        bad = I6 + RNG.normal(scale=2.0 * np.abs(I6[:3]).max(), size=6)
        _, _, I2, projected = project_body(m, b, bad)
        if not projected:
            continue
        S_bad, S_out = second_moment(bad), second_moment(I2)
        d_out = np.linalg.norm(S_out - S_bad)
        for _ in range(200):
            _, _, I_real = random_body(RNG)
            assert np.linalg.norm(second_moment(I_real) - S_bad) >= d_out - 1e-9
        # a nudge from the output towards the estimate leaves the feasible set (boundary point)
        nudged = I2 + 1e-3 * (bad - I2)
        assert np.linalg.eigvalsh(second_moment(nudged))[0] < np.linalg.eigvalsh(S_out)[0] + 1e-12


def test_planar_out_of_plane_adjustment_keeps_identified_izz():
    """A planar estimate whose identified Izz exceeds the guessed Ixx + Iyy: the projection
    keeps Izz and raises the unidentified Ixx, Iyy (diagonal tensor)."""
    I6 = np.array([10.0, 10.0, 25.0, 0.0, 0.0, 0.0])
    m2, _, I2, projected = project_body(250.0, [0.25, 0.1, 0.0], I6)
    assert projected and m2 == 250.0
    assert I2[2] == pytest.approx(25.0, rel=1e-12)
    assert I2[0] + I2[1] > I2[2] and I2[0] > 10.0 and I2[1] > 10.0
    assert physical_by_check_body(m2, [0.25, 0.1, 0.0], I2)


def test_planar_projection_keeps_the_identified_entries():
    """Random planar estimates whose unidentified entries make them unreal (any values): the
    output is real, m, b and Izz are kept exactly, and a real input is returned unchanged."""
    rng = np.random.default_rng(20261124)
    moved = 0
    for _ in range(300):
        m, b, I6 = random_body(rng)
        bad = I6.copy()
        bad[[0, 1, 3, 4, 5]] = rng.normal(scale=I6[2], size=5)     # unidentified entries
        m2, b2, I2, projected = project_planar_body(m, b, bad, m_scale=m)
        assert physical_by_check_body(m2, b2, I2)
        assert m2 == m and np.array_equal(b2, b)
        assert I2[2] == bad[2]
        moved += projected
        if not projected:
            assert np.array_equal(I2, bad)
    assert moved > 100
    m, b, I6 = random_body(rng)
    assert np.array_equal(project_planar_body(m, b, I6)[2], I6)


def test_negative_mass_is_clipped_to_the_mass_floor():
    RNG = np.random.default_rng(20261123)
    m, b, I6 = random_body(RNG)
    m2, _, _, projected = project_body(-3.0, b, I6, m_scale=100.0)
    assert projected and m2 == pytest.approx(1e-4) and m2 > 0


@pytest.mark.slow
def test_compiled_projection_equals_numpy():
    """project_body (the core's, one compiled call) against the oracle's NumPy/LAPACK
    formulation (_project_body_numpy) on random non-physical bodies of every kind (negative
    mass, one or two negative Sigma_c eigenvalues, near-flat, large and small scales): the same
    mass bit for bit, the inertia to round-off of the eigen-decomposition, a physical result;
    for a non-finite inertia NaN, as NumPy's."""
    rng = np.random.default_rng(11)
    n = 0
    for _ in range(3000):
        scale = 10.0 ** rng.uniform(-3, 3)
        m = rng.uniform(-1.0, 3.0) * scale
        b = rng.normal(0.0, 0.3, 3)
        I6 = np.concatenate([rng.uniform(-0.5, 2.0, 3), rng.normal(0.0, 0.5, 3)]) * scale
        got = project_body(m, b, I6, m_scale=scale)
        want = _project_body_numpy(m, b, I6, m_scale=scale)
        assert got[3] == want[3]
        assert got[0] == want[0] and np.array_equal(got[1], want[1])
        assert np.allclose(got[2], want[2], rtol=0.0, atol=1e-12 * np.abs(want[2]).max())
        if got[3]:
            n += 1
            assert is_physical(got[0], got[1], got[2])
    assert n > 1000
    bad = np.array([np.nan, 1.0, 1.0, 0.0, 0.0, 0.0])
    got, want = project_body(1.0, np.zeros(3), bad), _project_body_numpy(1.0, np.zeros(3), bad)
    assert got[0] == want[0] and got[3] == want[3]
    assert np.array_equal(got[2], want[2], equal_nan=True)


@pytest.mark.slow
def test_compiled_planar_projection_equals_numpy():
    """project_planar_body (compiled) against its NumPy formulation on random non-physical
    planar estimates (wrong out-of-plane guesses, negative or tiny Izz, negative mass): the same
    mass, the inertia to round-off, physical results; Izz moved only where no real body keeps
    it (both versions fall back to the full projection there)."""
    rng = np.random.default_rng(12)
    n = small = 0
    for _ in range(3000):
        scale = 10.0 ** rng.uniform(-3, 3)
        m = rng.uniform(-1.0, 3.0) * scale
        b = np.array([*rng.normal(0.0, 0.3, 2), 0.0])
        I6 = np.concatenate([rng.uniform(-0.5, 2.0, 3), rng.normal(0.0, 0.5, 3)]) * scale
        if rng.random() < 0.1:
            I6[2] = rng.uniform(-1e-7, 1e-7) * scale         # no real body keeps this Izz
        got = project_planar_body(m, b, I6, m_scale=scale)
        want = _project_planar_body_numpy(m, b, I6, m_scale=scale)
        assert got[3] == want[3] and got[0] == want[0]
        assert np.allclose(got[2], want[2], rtol=0.0, atol=1e-12 * np.abs(want[2]).max())
        if got[3]:
            n += 1
            assert is_physical(got[0], got[1], got[2])
            small += not got[2][2] == I6[2]
            assert (got[2][2] == I6[2]) == (want[2][2] == I6[2])
    assert n > 1000 and small > 10
