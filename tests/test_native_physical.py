"""The native physical-consistency module (native/src/physical.c) against the Python/NumPy
reference (the oracle tests/oracles/estimator/physical.py: is_physical, the LAPACK-based projections
_project_body_numpy / _project_planar_body_numpy) and ParameterLayout.error_scale.

Tolerances: projected inertias to 1e-12 of the body's largest |entry| (two eigen-decompositions,
QL and LAPACK, each backward stable); the projection's output is physical; a physical body
comes back unchanged (exactly: the projection is the identity there by definition).
"""
from __future__ import annotations

import ctypes

import numpy as np
import pytest
from numpy.ctypeslib import ndpointer

from oracles.estimator import physical
from oracles.estimator import report_kernels as rk
from spacerobot.interface import COM_SCALE_MIN, LAYOUT
from test_native_linalg import build_core

D = ndpointer(np.float64, flags="C_CONTIGUOUS")
I = ndpointer(np.int32, flags="C_CONTIGUOUS")
c_int, c_double = ctypes.c_int, ctypes.c_double
DP, IP = ctypes.POINTER(c_double), ctypes.POINTER(c_int)
N_BODIES = 3000


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    L = build_core(tmp_path_factory.mktemp("core_physical"))
    sig = {
        "sr_second_moment": (None, [D, D]),
        "sr_is_physical": (c_int, [c_double, D, D]),
        "sr_both_physical": (None, [D, I]),
        "sr_error_scale": (None, [D, c_double, D]),
        "sr_identified_bodies": (None, [D, D, D, D, c_double, I, I]),
        "sr_report_flags": (c_int, [D, D, c_double, c_double, I, I]),
        "sr_project_body": (c_int, [c_double, D, D, c_double, c_double, DP, D, IP]),
        "sr_project_planar_body": (c_int, [c_double, D, D, c_double, c_double, DP, D, IP]),
    }
    for name, (res, args) in sig.items():
        f = getattr(L, name)
        f.restype, f.argtypes = res, args
    return L


def project(lib, fn, m, b, I6, m_scale=1.0):
    m_out, projected, I_out = c_double(), c_int(), np.empty(6)
    st = getattr(lib, fn)(float(m), np.ascontiguousarray(b, float),
                          np.ascontiguousarray(I6, float), physical.REL_MASS_MIN * abs(m_scale),
                          physical.REL_SIGMA_MIN, ctypes.byref(m_out), I_out,
                          ctypes.byref(projected))
    return st, m_out.value, I_out, bool(projected.value)


def six(S):
    return np.array([S[0, 0], S[1, 1], S[2, 2], S[0, 1], S[0, 2], S[1, 2]])


def random_rotation(rng):
    Q, R = np.linalg.qr(rng.standard_normal((3, 3)))
    return Q * np.sign(np.diag(R))


def bodies(rng, n):
    """(m, b, I6, kind): physical ones (Sigma_c > 0), non-physical ones of several kinds."""
    out = []
    for k in range(n):
        kind = k % 6
        m = rng.uniform(0.5, 500.0)
        b = rng.normal(0.0, 0.5, 3)
        R = random_rotation(rng)
        sig = rng.uniform(0.01, 10.0, 3) * 10.0 ** rng.uniform(-3, 2)
        if kind == 1:                                # one negative second moment
            sig[rng.integers(3)] *= -rng.uniform(1e-3, 1.0)
        elif kind == 2:                              # random symmetric, any signs
            X = rng.normal(0.0, 1.0, (3, 3))
            out.append((m * rng.choice([1.0, -1.0, 0.0]), b, six(X + X.T), kind))
            continue
        elif kind == 3:                              # a rod or a plate: on the boundary
            sig[rng.integers(3)] = 0.0
        elif kind == 4:                              # a negative or zero mass, else physical
            m = -m if rng.random() < 0.7 else 0.0
        S = (R * sig) @ R.T
        Ic = np.trace(S) * np.eye(3) - S
        out.append((m, b, six(Ic), kind))
    return out


@pytest.mark.slow
def test_second_moment(lib):
    rng = np.random.default_rng(10)
    for _ in range(100):
        I6 = rng.normal(0.0, 3.0, 6)
        S = np.empty((3, 3))
        lib.sr_second_moment(I6, S)
        ref = physical.second_moment(I6)
        assert np.abs(S - ref).max() <= 1e-15 * np.abs(ref).max()
        # Sigma_c = tr(I)/2 1 - I  <=>  I = tr(Sigma) 1 - Sigma
        assert np.abs(physical.inertia_from_second_moment(S) - I6).max() <= 1e-14 * np.abs(I6).max()


@pytest.mark.slow
def test_is_physical(lib):
    rng = np.random.default_rng(11)
    counts = [0, 0]
    for m, b, I6, kind in bodies(rng, N_BODIES):
        got = bool(lib.sr_is_physical(m, b, I6))
        assert got == physical.is_physical(m, b, I6), (m, b, I6)
        # independent: m > 0 and the smallest eigenvalue of Sigma_c > 0 (clear cases only)
        lam = np.linalg.eigvalsh(physical.second_moment(I6))
        if abs(lam[0]) > 1e-9 * np.abs(lam).max():
            assert got == (m > 0.0 and lam[0] > 0.0)
        counts[got] += 1
    assert min(counts) > N_BODIES // 10                 # both kinds were tested
    b, I6 = np.zeros(3), np.array([2.0, 2.0, 2.0, 0.0, 0.0, 0.0])
    assert lib.sr_is_physical(1.0, b, I6) == 1
    for bad in (np.nan, np.inf):
        assert lib.sr_is_physical(bad, b, I6) == 0
        assert lib.sr_is_physical(1.0, np.array([0.0, bad, 0.0]), I6) == 0
        I6b = I6.copy()
        I6b[4] = bad
        assert lib.sr_is_physical(1.0, b, I6b) == 0


@pytest.mark.parametrize("fn,ref", [("sr_project_body", physical._project_body_numpy),
                                    ("sr_project_planar_body",
                                     physical._project_planar_body_numpy)])
@pytest.mark.slow
def test_projection_against_numpy(lib, fn, ref):
    rng = np.random.default_rng(12 if fn == "sr_project_body" else 13)
    worst, n_projected = 0.0, 0
    for m, b, I6, kind in bodies(rng, N_BODIES):
        m_scale = rng.uniform(1.0, 100.0)
        st, m_out, I_out, projected = project(lib, fn, m, b, I6, m_scale)
        m_ref, b_ref, I_ref, projected_ref = ref(m, b, I6, m_scale)
        assert st == 0
        assert projected == projected_ref
        if not projected:
            assert m_out == m and np.array_equal(I_out, I6)       # unchanged
            continue
        n_projected += 1
        assert abs(m_out - m_ref) <= 1e-15 * abs(m_ref)
        err = np.abs(I_out - I_ref).max() / np.abs(I6).max()
        worst = max(worst, err)
        assert err <= 1e-12, (m, b, I6, I_out, I_ref)
        assert lib.sr_is_physical(m_out, b, I_out) == 1, (I6, I_out)
        assert physical.is_physical(m_out, b, I_out)
    assert n_projected > N_BODIES // 3
    print(fn, "worst |I - I_numpy| / |I|:", worst)


@pytest.mark.slow
def test_planar_keeps_izz(lib):
    """A planar estimate with a reasonable Izz keeps m, b and Izz exactly."""
    rng = np.random.default_rng(14)
    for _ in range(500):
        izz = rng.uniform(0.5, 50.0)
        I6 = np.concatenate([rng.normal(0.0, 5.0, 2), [izz], rng.normal(0.0, 2.0, 3)])
        m, b = rng.uniform(1.0, 100.0), rng.normal(0.0, 0.3, 3)
        st, m_out, I_out, projected = project(lib, "sr_project_planar_body", m, b, I6)
        if projected:
            assert st == 0 and m_out == m and I_out[2] == izz
            assert lib.sr_is_physical(m_out, b, I_out) == 1


def test_projection_non_finite(lib):
    b = np.zeros(3)
    for fn in ("sr_project_body", "sr_project_planar_body"):
        I6 = np.array([1.0, np.nan, 1.0, 0.0, 0.0, 0.0])
        st, m_out, I_out, projected = project(lib, fn, 1.0, b, I6)
        assert st == 1 and projected
        st, m_out, I_out, projected = project(lib, fn, np.nan, b, np.array([2.0, 2, 2, 0, 0, 0]))
        assert st == 0 and projected and m_out == physical.REL_MASS_MIN    # the mass floor


def test_projection_in_place(lib):
    I6 = np.array([1.0, 1.0, 5.0, 0.3, 0.0, 0.0])                  # triangle violated
    ref = physical._project_body_numpy(2.0, np.zeros(3), I6)[2]
    m_out, projected = c_double(), c_int()
    st = lib.sr_project_body(2.0, np.zeros(3), I6, 1e-6, physical.REL_SIGMA_MIN,
                             ctypes.byref(m_out), I6, ctypes.byref(projected))
    assert st == 0 and projected.value == 1
    assert np.abs(I6 - ref).max() <= 1e-12 * np.abs(ref).max()


def error_scale_cases(rng):
    for k in range(300):
        v = rng.normal(0.0, 5.0, 20) * 10.0 ** rng.uniform(-3, 3, 20)
        if k % 3 == 1:                               # zeros: mass, CoM, moments, all moments
            v[rng.choice(20, 6, replace=False)] = 0.0
        if k % 7 == 2:
            v[10 + 4:10 + 7] = 0.0
        if k % 11 == 3:
            v[rng.integers(20)] = np.nan
        yield v


def test_error_scale(lib):
    rng = np.random.default_rng(15)
    for v in error_scale_cases(rng):
        scale = np.empty(20)
        lib.sr_error_scale(v, COM_SCALE_MIN, scale)
        ref = LAYOUT.error_scale(v)
        np.testing.assert_allclose(scale, ref, rtol=1e-15, atol=0.0, equal_nan=True)
        assert np.all(scale[~np.isnan(scale)] > 0.0)


@pytest.mark.slow
def test_identified_and_report_flags(lib):
    rng = np.random.default_rng(16)
    sd_rel = 1e-3
    n_ok = 0
    for k in range(400):
        phys = bodies(rng, 2) if k % 2 else [b for b in bodies(rng, 12) if b[3] == 0][:2]
        ls = np.concatenate([np.concatenate([[m], b, I6]) for m, b, I6, _ in phys])
        scale = LAYOUT.error_scale(ls)
        sd = scale * sd_rel * rng.uniform(0.0, 1.3, 20)
        identified = rng.random(20) < 0.8
        ident = identified.astype(np.int32)
        out = ls + scale * sd_rel * rng.uniform(-1.3, 1.3, 20) * (rng.random(20) < 0.3)
        ok_body = np.empty(2, np.int32)
        lib.sr_identified_bodies(sd, out, ls, scale, sd_rel, ident, ok_body)
        tol = sd_rel * scale
        ok = (sd <= tol) & (np.abs(out - ls) <= tol)
        ref = [bool(ok[s][identified[s]].all()) for s in (slice(0, 10), slice(10, 20))]
        assert list(ok_body.astype(bool)) == ref
        flags = np.zeros(4, np.int32)
        done = lib.sr_report_flags(ls, sd, COM_SCALE_MIN, sd_rel, ident, flags)
        both = [physical.is_physical(ls[0], ls[1:4], ls[4:10]),
                physical.is_physical(ls[10], ls[11:14], ls[14:20])]
        assert list(flags[:2].astype(bool)) == both
        assert bool(done) == all(both)
        if done:
            okl = sd <= tol                                          # out = ls
            want = [bool(okl[s][identified[s]].all()) for s in (slice(0, 10), slice(10, 20))]
            assert list(flags[2:].astype(bool)) == want
            n_ok += any(want)
        fl = np.zeros(4, bool)
        assert rk.report_flags(ls, sd, COM_SCALE_MIN, sd_rel, identified, fl) == bool(done)
    assert n_ok > 10
