"""The thrust errors' consider covariance (issue 14; the native Identifier, the NumPy oracle's
:mod:`oracles.estimator.consider`).

* Sensitivity: on a noise-free excited run, corrupting the thrust with the sensors model's own
  scale factor and misalignment (:class:`spacerobot.sensors.SensorSuite`, every other error
  off) moves the native estimates by what the oracle estimator's sensitivity predicts,
  ``J dz/dc c``, for
  both methods (the momentum method also with a 5 s window about the base) and both solvers;
  the corrupted run is a separate identification, not the linear model.
* Calibration: over 24 drawn thrust errors (nothing else wrong), at least 90 % of the
  estimates lie within 2 of their reported standard deviations and the root mean square of
  ``error / sd`` is at most 1.2; without the consider term it is at least 1.3 (the term is
  what calibrates them).
* The defaults (no consider term) give the estimates and standard deviations as before, bit
  for bit; the estimates never depend on the consider term; state round trip; bad values.
"""
from __future__ import annotations

import numpy as np
import pytest

from oracles import estimator as oracle
from oracles.estimator.consider import ThrustIntegrals, skew
from spacerobot.estimator import Identifier
from spacerobot.estimator.identifier import KEYS, identifier_from_values
from spacerobot.interface import estimate_vector
from spacerobot.robots import get_robot
from oracles.sensors import SensorSuite  # the NumPy sensor models: test data
from spacerobot.sensors.models import default_parameters
from spacerobot.system.identify import estimator_parameters
from test_moving_reference import record

THRUST_SD = (0.02, 8.7e-3)          # the sensors' realistic defaults (docs/sensors.md)
SETUPS = [("force", {}), ("momentum", {}), ("momentum", dict(window=5.0, moving_point=True))]


@pytest.fixture(scope="module")
def excited():
    sc, rec = record("spatial", 30.0, excite=1.0)
    return sc, [(t, {k: o[k] for k in KEYS}) for t, o in rec]


def thrust_corrupted(sc, data, seed: int):
    """The run as the sensors FMU measures it with only its thrust errors on, and the drawn
    consider parameters ``c = [s_F, phi_F, s_M, phi_M]`` read back from its error matrices
    ``(1 + s) R(phi) - 1``."""
    p = {k: 0.0 for k in default_parameters()}
    p["thrust.scale"], p["thrust.misalign"] = THRUST_SD
    suite = SensorSuite(sc.robot.n_joints, p, seed=seed)
    out = [(t, suite.update(o, 0.1)) for t, o in data]
    c = []
    for E in (suite.E_F, suite.E_M):
        S = E + np.eye(3)
        k = np.cbrt(np.linalg.det(S))                    # 1 + s
        R = S / k
        c += [k - 1.0, *(0.5 * np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]]))]
    return out, np.array(c)


def identify(sc, data, method, solver="paper", cls=Identifier, **kw):
    ident = cls(sc.robot, sc.guess, method, solver, **kw)
    for t, o in data:
        ident.update(t, o)
    return ident


@pytest.mark.parametrize("solver", ["paper", "joint"])
@pytest.mark.parametrize("method,kw", SETUPS)
@pytest.mark.slow
def test_thrust_errors_move_the_estimates_as_the_sensitivity_predicts(excited, method, kw, solver):
    sc, data = excited
    clean = identify(sc, data, method, solver, thrust_sd=THRUST_SD, **kw)
    # the sensitivity from the NumPy oracle's solver (the native core keeps it internal)
    s = identify(sc, data, method, solver, cls=oracle.Identifier, thrust_sd=THRUST_SD,
                 **kw).solver
    dx_dc = s.jacobian(s.z()) @ s.consider_shift()                     # (20, 8)
    scale = clean.layout.error_scale(clean.vector())
    for seed in (1, 2):
        bad, c = thrust_corrupted(sc, data, seed)
        moved = identify(sc, bad, method, solver, thrust_sd=THRUST_SD, **kw).vector()
        d, pred = (moved - clean.vector()) / scale, dx_dc @ c / scale
        assert np.linalg.norm(d) > 1e-4                                 # the errors matter
        # first order in c (2 %, 0.5 deg) and the integrals from the measured thrust
        assert np.linalg.norm(d - pred) <= 0.1 * np.linalg.norm(d), (seed, d, pred)


@pytest.mark.parametrize("method,kw", SETUPS[0::2])
@pytest.mark.slow
def test_thrust_errors_are_within_two_consider_standard_deviations(excited, method, kw):
    sc, data = excited
    truth = estimate_vector(sc.robot.base, sc.target)
    z_with, z_without = [], []
    for seed in range(24):
        bad, _ = thrust_corrupted(sc, data, 100 + seed)
        ident = identify(sc, bad, method, thrust_sd=THRUST_SD, **kw)
        without = identify(sc, bad, method, **kw)            # same estimates, scatter-only sd
        np.testing.assert_array_equal(without.vector(), ident.vector())
        err = ident.vector() - truth
        z_with.append(err / ident.std())
        z_without.append(err / without.std())
    z_with, z_without = np.abs(z_with), np.abs(z_without)
    assert np.mean(z_with <= 2.0) >= 0.9, np.mean(z_with <= 2.0)
    # conservative rather than tight: the errors' misfit also widens the scatter term
    assert np.sqrt(np.mean(z_with ** 2)) <= 1.2
    assert np.sqrt(np.mean(z_without ** 2)) >= 1.3          # the term does the calibrating


def test_defaults_unchanged_and_estimates_independent_of_the_term(excited):
    sc, data = excited
    for method, kw in SETUPS:
        plain = identify(sc, data, method, **kw)
        zero = identify(sc, data, method, thrust_sd=(0.0, 0.0), **kw)
        np.testing.assert_array_equal(zero.vector(), plain.vector())
        np.testing.assert_array_equal(zero.std(), plain.std())
        on = identify(sc, data, method, thrust_sd=THRUST_SD, **kw)
        np.testing.assert_array_equal(on.vector(), plain.vector())
        assert np.all(on.std() >= plain.std()) and np.any(on.std() > 1.5 * plain.std())


def test_thrust_integrals_hold_the_thrust_over_each_interval():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.05, 0.15, 50))
    r, F, M = rng.normal(size=(3, 50, 3))
    K = ThrustIntegrals()
    for k in range(50):
        K = K.add(t[k], r[k], F[k], M[k])
    dt = np.diff(t)[:, None]
    np.testing.assert_allclose(K.k_M, np.sum(dt * M[:-1], axis=0), rtol=1e-12)
    np.testing.assert_allclose(K.k_s, np.sum(dt * np.cross(r[:-1], F[:-1]), axis=0), rtol=1e-12)
    for i in range(3):                         # column i: int r x (e_i x F) dt
        e = np.eye(3)[i]
        ref = np.sum(dt * np.cross(r[:-1], np.cross(e, F[:-1])), axis=0)
        np.testing.assert_allclose(K.k_phi[:, i], ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(skew(F[0]) @ M[0], np.cross(F[0], M[0]), rtol=1e-14, atol=1e-15)


def test_state_round_trip_with_the_consider_term(excited):
    sc, data = excited
    for method, kw in SETUPS:
        a = identify(sc, data[:100], method, thrust_sd=THRUST_SD, **kw)
        state = a.get_state()
        for t, o in data[100:]:
            a.update(t, o)
        b = Identifier(sc.robot, sc.guess, method, thrust_sd=THRUST_SD, **kw)
        b.set_state(state)
        for t, o in data[100:]:
            b.update(t, o)
        np.testing.assert_array_equal(b.std(), a.std())


@pytest.mark.parametrize("value", [-0.1, float("nan"), 2.0, "x"])
def test_bad_thrust_sd_is_refused(value):
    robot = get_robot("spatial")
    for name in ("ident.sd_thrust.scale", "ident.sd_thrust.misalign"):
        with pytest.raises(ValueError, match=name.replace(".", r"\.")):
            identifier_from_values(robot, estimator_parameters("spatial", {name: value}))
