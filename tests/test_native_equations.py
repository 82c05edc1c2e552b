"""The equations of one sample in C (native/src/equations.c) against the NumPy test oracles
(tests/oracles/kinematics.py, regressors.py: an independent, vectorised formulation) and
against the former Python kernels (tests/oracles/estimator/kernels.py, now plain NumPy), for
the planar, spatial and servicer7 robots, at random states where no term vanishes; D(mu), the rotation error and
the sample check against kernels.py and NumPy."""
from __future__ import annotations

import ctypes

import numpy as np
import pytest

from spacerobot.core import robot_record as rr
from oracles.estimator import kernels
from spacerobot.estimator.identifier import INPUT_LIMIT, KEYS, ROTATION_TOL
from oracles.kinematics import ArmGeometry
from test_estimator_kernels import reference_equations
from test_robot_record import ROBOTS, core_library, robot_of

_DP = ctypes.POINTER(ctypes.c_double)
TOL = 1e-12


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    L = core_library(tmp_path_factory.mktemp("corelib"))
    L.sr_equations.argtypes = [ctypes.POINTER(rr.SrRobot), ctypes.c_int, _DP, _DP]
    L.sr_equations.restype = ctypes.c_int
    L.sr_D_of_mu.argtypes = [_DP, _DP]
    L.sr_D_of_mu.restype = None
    L.sr_rotation_error.argtypes = [_DP, _DP, _DP]
    L.sr_rotation_error.restype = None
    L.sr_sample_check.argtypes = [_DP, ctypes.c_int, ctypes.c_double, ctypes.c_double]
    L.sr_sample_check.restype = ctypes.c_int
    L.sr_sample_length.argtypes = [ctypes.c_int]
    L.sr_sample_length.restype = ctypes.c_int
    return L


def p(a):
    return a.ctypes.data_as(_DP)


def random_sample(rng, n):
    """A random state: rotation A, base motion, joints, thrust and momenta (non-physical:
    every term of the equations is non-zero)."""
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    s = {k: rng.normal(size=3) for k in ("r_S", "v_S", "omega_B", "a_S", "alpha_B", "F", "M",
                                          "J", "H")}
    s["A"] = Q * np.sign(np.linalg.det(Q))
    for k in ("q", "qd", "qdd"):
        s[k] = rng.normal(size=n) * 2.0
    return s


def flat(s):
    return np.ascontiguousarray(np.concatenate([np.asarray(s[k], float).ravel() for k in KEYS]))


def oracle_equations(robot, s, force):
    """(A, b, phi, y, psi) of one sample from the NumPy oracles (the construction of
    tests/test_estimator_kernels.py)."""
    return reference_equations(robot, s, "force" if force else "momentum")


def split(E):
    c = kernels
    return (E[:, c.COL_A:c.COL_B], E[:, c.COL_B], E[:, c.COL_PHI:c.COL_Y], E[:, c.COL_Y],
            E[:, c.COL_PSI:c.N_COLS])


def c_equations(lib, sr, force, x):
    E = np.full((3, kernels.N_COLS), np.nan)
    assert lib.sr_equations(ctypes.byref(sr), int(force), p(x), p(E)) == 0
    return E


def scaled_diff(got, ref):
    """max |got - ref| / max(1, |ref| of the column) over the columns (the row magnitude for
    the vectors b, y)."""
    got, ref = np.atleast_2d(np.asarray(got).T).T, np.atleast_2d(np.asarray(ref).T).T
    scale = np.maximum(1.0, np.abs(ref).max(axis=0))
    return float((np.abs(got - ref) / scale).max())


MEASURED: dict = {}


@pytest.mark.parametrize("robot_name", ROBOTS)
@pytest.mark.parametrize("force", [False, True], ids=["momentum", "force"])
def test_c_equations_match_the_numpy_oracles_and_the_compiled_kernels(lib, robot_name, force):
    robot = robot_of(robot_name)
    sr = rr.c_robot(robot, lib)
    geom = ArmGeometry(robot).arrays()
    n = robot.n_joints
    rng = np.random.default_rng(2024 + n + 100 * force)
    worst_oracle = worst_kernel = 0.0
    for _ in range(40):
        s = random_sample(rng, n)
        x = flat(s)
        assert x.size == lib.sr_sample_length(n) == 24 + 3 * n + 12
        E = c_equations(lib, sr, force, x)
        assert np.isfinite(E).all()                      # every one of the 42 columns written
        for name, g, r in zip(("A", "b", "phi", "y", "psi"), split(E),
                              oracle_equations(robot, s, force)):
            d = scaled_diff(g, r)
            assert d <= TOL, (name, d)
            worst_oracle = max(worst_oracle, d)
        Ek = np.empty((3, kernels.N_COLS))
        kernels.equations(force, x, n, *geom, Ek)
        d = scaled_diff(E, Ek)
        assert d <= TOL, d
        worst_kernel = max(worst_kernel, d)
    MEASURED[(robot_name, force)] = (worst_oracle, worst_kernel)
    print(f"{robot_name} {'force' if force else 'momentum'}: max scaled difference "
          f"oracle {worst_oracle:.3g}, kernels {worst_kernel:.3g}")


def test_c_equations_refuse_a_bad_robot_and_leave_E_untouched(lib):
    sr = rr.c_robot(robot_of("planar"), lib)
    x = flat(random_sample(np.random.default_rng(1), 3))
    E = np.full((3, kernels.N_COLS), 7.0)
    for n in (0, -1, 13, 1 << 30):
        sr.n = n
        assert lib.sr_equations(ctypes.byref(sr), 0, p(x), p(E)) == 1
    assert lib.sr_equations(None, 0, p(x), p(E)) == 1
    assert (E == 7.0).all()


def test_moving_the_target_frame_changes_only_the_target_columns(lib):
    """An independent property: ee.xyz moves E (the target's frame) along the last link, so the
    base's columns of A, phi, psi and the arm's b, y stay; the target's change."""
    robot = robot_of("spatial")
    sr = rr.c_robot(robot, lib)
    x = flat(random_sample(np.random.default_rng(3), robot.n_joints))
    for force in (0, 1):
        E0 = c_equations(lib, sr, force, x)
        sr.ee_xyz[0] += 0.3
        E1 = c_equations(lib, sr, force, x)
        sr.ee_xyz[0] -= 0.3
        base = [*range(0, 4), 8, *range(9, 15), 21, *range(22, 32)]
        target = [c for c in range(42) if c not in base]
        np.testing.assert_array_equal(E1[:, base], E0[:, base])
        assert np.abs(E1[:, target] - E0[:, target]).max() > 1e-3


def test_D_of_mu_matches_the_kernel_and_the_paper_map(lib):
    rng = np.random.default_rng(5)
    worst = 0.0
    for _ in range(200):
        mu = rng.normal(size=8) * 50.0
        mu[0], mu[4] = rng.uniform(1.0, 700.0, size=2)
        D = np.empty(20)
        lib.sr_D_of_mu(p(mu), p(D))
        Dk = kernels.D_of_mu(mu)
        worst = max(worst, float(np.abs(D - Dk).max() / np.abs(Dk).max()))
        for k in range(2):                                        # eq. 23, written out
            m, b = mu[4 * k], mu[4 * k + 1:4 * k + 4] / mu[4 * k]
            J = [1.0, *b, b[0] ** 2, b[0] * b[1], b[0] * b[2], b[1] ** 2, b[1] * b[2], b[2] ** 2]
            np.testing.assert_allclose(D[10 * k:10 * k + 10], m * np.array(J), rtol=1e-14,
                                       atol=1e-14 * m)
    assert worst <= 1e-15, worst
    print(f"D_of_mu: max relative difference to kernels {worst:.3g}")


def _dcm_with_error(err):
    A = np.eye(3)
    A[0, 0] = np.sqrt(1.0 + err)
    return A


def test_rotation_error_and_sample_check_match_the_kernels(lib):
    rng = np.random.default_rng(9)
    n = 7
    cases = []
    for _ in range(50):
        cases.append(flat(random_sample(rng, n)))
    good = cases[0]
    for A in (_dcm_with_error(0.9 * ROTATION_TOL), _dcm_with_error(1.1 * ROTATION_TOL),
              np.diag([1.0, 1.0, -1.0]), np.zeros((3, 3)), 2.0 * np.eye(3)):
        x = good.copy()
        x[kernels.A_B:kernels.A_B + 9] = A.ravel()
        cases.append(x)
    for pos, val in ((0, np.nan), (30, np.inf), (40, -np.inf), (-1, 2e15), (7, np.nan),
                     (10, -1e16), (-1, -INPUT_LIMIT)):
        x = good.copy()
        x[pos] = val
        cases.append(x)
    verdicts = set()
    for x in cases:
        x = np.ascontiguousarray(x)
        want = kernels.sample_check(x, INPUT_LIMIT, ROTATION_TOL)
        got = lib.sr_sample_check(p(x), x.size, INPUT_LIMIT, ROTATION_TOL)
        assert got == want, (got, want, x[:15])
        verdicts.add(got)
        A = np.ascontiguousarray(x[kernels.A_B:kernels.A_B + 9])
        err, det = ctypes.c_double(), ctypes.c_double()
        lib.sr_rotation_error(p(A), ctypes.byref(err), ctypes.byref(det))
        if np.isfinite(A).all():
            Am = A.reshape(3, 3)
            assert abs(err.value - np.abs(Am.T @ Am - np.eye(3)).max()) <= 4e-16 * max(1, err.value)
            assert abs(det.value - np.linalg.det(Am)) <= 1e-14 * max(1.0, abs(det.value))
            assert (err.value, det.value) == pytest.approx(kernels.rotation_error(x, kernels.A_B),
                                                           rel=1e-15, abs=1e-300)
    assert verdicts == {0, 1, 2}
    # too short to hold the DCM: refused, never read past len
    assert lib.sr_sample_check(p(good), 14, INPUT_LIMIT, ROTATION_TOL) == 3
    assert lib.sr_sample_check(None, 60, INPUT_LIMIT, ROTATION_TOL) == 3
