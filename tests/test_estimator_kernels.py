"""The oracle estimator's equation kernels (tests/oracles/estimator/kernels.py, the reference
of the native equations in tests/test_native_equations.py) against the independent NumPy
reference of the same equations (tests/oracles/kinematics.py and regressors.py), at random,
non-physical inputs where no term vanishes; the native Identifier's one validation rule,
whether a sample comes as arrays or as lists, and its refusal of a sample of the wrong
shape."""
import numpy as np
import pytest

from oracles import regressors as rg
from oracles.kinematics import ArmKinematics
from oracles.estimator import Identifier as OracleIdentifier
from spacerobot.estimator import Identifier
from oracles.estimator import parameters as par
from spacerobot.estimator.identifier import KEYS, ROTATION_TOL
from spacerobot.robots import scenario


def random_sample(rng, n):
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    A = Q * np.sign(np.linalg.det(Q))
    s = {k: rng.normal(size=3) for k in ("r_S", "v_S", "omega_B", "a_S", "alpha_B", "F", "M",
                                          "J", "H")}
    s["A"] = A
    for k in ("q", "qd", "qdd"):
        s[k] = rng.normal(size=n)
    return s


def reference_equations(robot, s, method):
    """(A, b, phi, y, psi) of one sample, absolute (not differenced), from the NumPy code."""
    kin = ArmKinematics(robot)
    links, ee = kin.compute(s["r_S"], s["A"], s["v_S"], s["omega_B"], s["a_S"], s["alpha_B"],
                            s["q"], s["qd"], s["qdd"])
    A, w, beta = s["A"], s["A"] @ s["omega_B"], s["A"] @ s["alpha_B"]
    if method == "momentum":
        B1, D1, Psi1 = rg.momentum_terms(s["r_S"], A, s["v_S"], w)
        Bn, Dn, Psin = rg.momentum_terms(ee.r, ee.A, ee.v, ee.w)
        P_arm, L_arm = kin.momentum(links)
        return (np.hstack([B1, Bn]), s["J"] - P_arm, np.hstack([D1, Dn]), s["H"] - L_arm,
                -np.hstack([Psi1, Psin]))
    G1, Q1, S1 = rg.force_terms(np.zeros(3), A, s["a_S"], w, beta)
    Gn, Qn, Sn = rg.force_terms(ee.r - s["r_S"], ee.A, ee.a, ee.w, ee.beta)
    F_arm, M_arm = kin.rate_of_momentum(links, s["r_S"])
    return (np.hstack([G1, Gn]), s["F"] - F_arm, np.hstack([Q1, Qn]), s["M"] - M_arm,
            -np.hstack([S1, Sn]))


@pytest.mark.parametrize("robot", ["planar", "spatial"])
@pytest.mark.parametrize("method", ["momentum", "force"])
def test_oracle_equations_match_numpy_reference(robot, method):
    sc = scenario(robot)
    rng = np.random.default_rng(11)
    ident = OracleIdentifier(sc.robot, sc.guess, method)
    for _ in range(20):
        s0, s1 = random_sample(rng, sc.robot.n_joints), random_sample(rng, sc.robot.n_joints)
        if method == "momentum":
            ident.reference = None
            assert ident.equations(s0) is None                  # the reference sample
            got = ident.equations(s1)
            ref = [x1 - x0 for x1, x0 in zip(reference_equations(sc.robot, s1, method),
                                              reference_equations(sc.robot, s0, method))]
        else:
            got = ident.equations(s1)
            ref = reference_equations(sc.robot, s1, method)
        for name, g, r in zip(("A", "b", "phi", "y", "psi"), got, ref):
            np.testing.assert_allclose(g, r, rtol=0, atol=1e-12 * max(1.0, np.abs(r).max()),
                                       err_msg=name)


def test_D_of_mu_is_the_paper_map():
    mu = np.array([500.0, 50.0, -50.0, 25.0, 250.0, 62.5, 25.0, -12.5])
    D = par.D_of_mu(mu)
    for k in range(2):
        m, b = mu[4 * k], mu[4 * k + 1:4 * k + 4] / mu[4 * k]
        J = [1.0, *b, b[0] ** 2, b[0] * b[1], b[0] * b[2], b[1] ** 2, b[1] * b[2], b[2] ** 2]
        np.testing.assert_allclose(D[10 * k:10 * k + 10], m * np.array(J), rtol=1e-15)


def test_sample_of_wrong_shape_is_rejected_with_its_name():
    sc = scenario("spatial")
    ident = Identifier(sc.robot, sc.guess)
    s = random_sample(np.random.default_rng(2), sc.robot.n_joints)
    s["qd"] = np.zeros(sc.robot.n_joints + 1)
    s["q"] = np.zeros(sc.robot.n_joints - 1)                    # same total length
    assert ident.update(0.0, s) == 4
    assert "input q has shape" in ident.message
    assert ident.samples == 0 and ident.rejected == 1
    assert ident.update(0.1, random_sample(np.random.default_rng(2), sc.robot.n_joints)) == 1
    assert list(KEYS)[6] == "q"


def _dcm_with_error(err):
    """A DCM with ``max |A^T A - I| = err`` (one column stretched), det > 0."""
    A = np.eye(3)
    A[0, 0] = np.sqrt(1.0 + err)
    return A


@pytest.mark.parametrize("as_lists", [False, True])
def test_one_rotation_rule_on_both_validation_paths(as_lists):
    """|A^T A - I| <= ROTATION_TOL (1e-6) and det > 0: accepted just inside the tolerance,
    rejected just outside it and for a reflection, whether the sample comes as arrays (the fast
    path) or as lists (the careful path): the two paths give one verdict."""
    assert ROTATION_TOL == 1e-6
    sc = scenario("spatial")
    rng = np.random.default_rng(5)
    reflection = np.diag([1.0, 1.0, -1.0])
    cases = [(_dcm_with_error(0.9 * ROTATION_TOL), True),
             (_dcm_with_error(0.5 * ROTATION_TOL), True),
             (_dcm_with_error(1.1 * ROTATION_TOL), False), (_dcm_with_error(2e-6), False),
             (reflection, False)]
    for A, ok in cases:
        err = np.abs(A.T @ A - np.eye(3)).max()      # independent of the kernel
        assert (err <= 1e-6 and np.linalg.det(A) > 0) == ok
        ident = Identifier(sc.robot, sc.guess)
        s = random_sample(rng, sc.robot.n_joints)
        s["A"] = A
        if as_lists:
            s = {k: np.asarray(v).tolist() for k, v in s.items()}
        status = ident.update(0.0, s)
        if ok:
            assert status == 1 and ident.rejected == 0, (err, ident.message)
        else:
            assert status == 4 and ident.status == 4 and ident.rejected == 1, err
            assert "base.A is not a rotation matrix" in ident.message
    # lists are accepted as samples
    ident = Identifier(sc.robot, sc.guess)
    for t in (0.0, 0.1):
        s = {k: np.asarray(v).tolist() for k, v in random_sample(rng, sc.robot.n_joints).items()}
        ident.update(t, s)
    assert ident.samples == 1 and ident.status == 2, ident.message
