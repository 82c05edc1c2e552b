"""The native differencing weights (native/src/differencing.c) against the Python functions
(oracles.estimator.differencing) and exact properties.

Tolerances: derivative weights to 1e-12 of the largest |weight| (a 3x3 well-scaled normal
system); displacement weights to round-off times the condition number of the Vandermonde
system both solve by LU (NumPy's LAPACK, C's sr_lu_solve): 1e-12 relative for half windows up
to 2, cond * 1e-15 above (cond ~3e4 at m = 5). At m = 10, the largest half window the
displacement weights take (SR_DIFF_MAX_DISPLACEMENT_HALF_WINDOW), that condition number is
~1e9, so there what a backward-stable solve guarantees is tested (a small residual of the
moment equations, sum u = sum w tau = 1 for derivative weights) and the accuracy
differencing.h states, against the weights solved exactly in rational arithmetic.
"""
from __future__ import annotations

import ctypes
from fractions import Fraction

import numpy as np
import pytest
from numpy.ctypeslib import ndpointer

from oracles.estimator import differencing as dif
from test_native_linalg import build_core

D = ndpointer(np.float64, flags="C_CONTIGUOUS")
I = ndpointer(np.int32, flags="C_CONTIGUOUS")
c_int, c_double = ctypes.c_int, ctypes.c_double
HALF_WINDOWS = (1, 2, 5, 50)
#: the displacement weights' half windows (they take at most 10)
DISPLACEMENT_HALF_WINDOWS = (1, 2, 5, 10)


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    L = build_core(tmp_path_factory.mktemp("core_differencing"))
    sig = {
        "sr_derivative_weights": (c_int, [D, c_int, c_int, D]),
        "sr_displacement_weights": (c_int, [D, c_int, c_int, D, D]),
        "sr_centre_derivative": (c_int, [D, D, c_int, c_int, I, I, c_int, D,
                                         ctypes.POINTER(c_double)]),
    }
    for name, (res, args) in sig.items():
        f = getattr(L, name)
        f.restype, f.argtypes = res, args
    return L


def deriv(lib, t, centre):
    t = np.ascontiguousarray(t, float)
    w = np.empty(len(t))
    st = lib.sr_derivative_weights(t, len(t), centre, w)
    return st, w


def disp(lib, t, centre, w):
    t = np.ascontiguousarray(t, float)
    u = np.empty(len(t))
    st = lib.sr_displacement_weights(t, len(t), centre, np.ascontiguousarray(w, float), u)
    return st, u


def times(rng, k, jitter, h=0.01, t0=123.4):
    t = t0 + h * np.arange(k)
    if jitter:
        t = t + rng.uniform(-0.3, 0.3, k) * h
    return t


def vandermonde_cond(t, centre):
    tau = t - t[centre]
    x = tau / np.abs(tau).max()
    return np.linalg.cond(x[:, None] ** np.arange(len(t)))


@pytest.mark.parametrize("m", HALF_WINDOWS)
@pytest.mark.parametrize("jitter", [False, True])
@pytest.mark.slow
def test_derivative_weights(lib, m, jitter):
    rng = np.random.default_rng(20 + m + 100 * jitter)
    k = 2 * m + 1
    for _ in range(20):
        t = times(rng, k, jitter, h=10.0 ** rng.uniform(-4, 0))
        for centre in {m, 0, k - 1, rng.integers(k)}:
            st, w = deriv(lib, t, centre)
            ref = dif.derivative_weights(t, centre)
            assert st == 0
            assert np.abs(w - ref).max() <= 1e-12 * np.abs(ref).max(), (m, centre)
            # exact for quadratics: x = a + b (t - t_c) + c (t - t_c)^2 has slope b at t_c
            a, b, c = rng.normal(size=3)
            tau = t - t[centre]
            x = a + b * tau + c * tau ** 2
            scale = np.abs(w).sum() * np.abs(x).max()
            assert abs(w @ x - b) <= 1e-12 * max(scale, 1.0), (m, centre)


@pytest.mark.parametrize("m", DISPLACEMENT_HALF_WINDOWS)
@pytest.mark.parametrize("jitter", [False, True])
@pytest.mark.slow
def test_displacement_weights(lib, m, jitter):
    rng = np.random.default_rng(40 + m + 100 * jitter)
    k = 2 * m + 1
    for _ in range(10):
        t = times(rng, k, jitter, h=10.0 ** rng.uniform(-3, 0))
        w = dif.derivative_weights(t, m)
        st, u = disp(lib, t, m, w)
        assert st == 0
        tau = t - t[m]
        # sum u = sum w tau (= 1 for derivative weights): the displacement of x = t
        assert abs(u.sum() - w @ tau) <= 1e-8
        # a small residual of the moment equations V^T u = W^T w (backward stable, any m)
        x = tau / np.abs(tau).max()
        Vt = (x[:, None] ** np.arange(k)).T
        g = (np.abs(tau).max() * x[:, None] ** np.arange(1, k + 1) / np.arange(1, k + 1)).T @ w
        assert np.abs(Vt @ u - g).max() <= 1e-13 * (np.abs(Vt) @ np.abs(u) + np.abs(g)).max()
        if m <= 5:
            ref = dif.displacement_weights(t, m, w)
            tol = 1e-12 if m <= 2 else 1e-15 * vandermonde_cond(t, m)
            assert np.abs(u - ref).max() <= tol * np.abs(ref).max(), m
            # exact for velocities polynomial of degree <= k - 1: v = sum c_p tau^p,
            # x(t) - x(t_c) = sum c_p tau^(p+1) / (p + 1)
            c = rng.normal(size=k) / np.abs(tau).max() ** np.arange(k)
            v = (tau[:, None] ** np.arange(k)) @ c
            dx = (tau[:, None] ** np.arange(1, k + 1) / np.arange(1, k + 1)) @ c
            scale = (np.abs(u) @ np.abs(v)) + np.abs(w) @ np.abs(dx)
            assert abs(u @ v - w @ dx) <= 1e-12 * scale


def exact_displacement_weights(t, centre, w):
    """u = V^-T W^T w (differencing.h) in rational arithmetic: t, w taken as the exact values
    of their doubles; Gaussian elimination without round-off."""
    k = len(t)
    tau = [Fraction(x) - Fraction(t[centre]) for x in t]
    s = max(abs(x) for x in tau)
    x = [v / s for v in tau]
    wf = [Fraction(v) for v in w]
    A = [[x[i] ** p for i in range(k)] for p in range(k)]
    b = [sum(s * x[i] ** (p + 1) / (p + 1) * wf[i] for i in range(k)) for p in range(k)]
    for j in range(k):
        piv = next(i for i in range(j, k) if A[i][j] != 0)
        A[j], A[piv], b[j], b[piv] = A[piv], A[j], b[piv], b[j]
        for i in range(j + 1, k):
            f = A[i][j] / A[j][j]
            if f:
                A[i][j:] = [a - f * c for a, c in zip(A[i][j:], A[j][j:])]
                b[i] -= f * b[j]
    u = [Fraction(0)] * k
    for j in range(k - 1, -1, -1):
        u[j] = (b[j] - sum(A[j][c] * u[c] for c in range(j + 1, k))) / A[j][j]
    return np.array([float(v) for v in u])


@pytest.mark.parametrize("m,rel", [(4, 1e-13), (10, 1e-7)])
@pytest.mark.parametrize("jitter", [False, True])
def test_displacement_weights_exact(lib, m, rel, jitter):
    """The accuracy differencing.h states (measured 1e-15 relative at m <= 4, 7e-9 at
    m = 10; the limits here 1e-13 and 1e-7), against the exact weights; and the refusal of a
    larger window, whose weights would have lost their digits (3e-4 at m = 15)."""
    rng = np.random.default_rng(60 + m + 100 * jitter)
    k = 2 * m + 1
    for _ in range(3):
        t = times(rng, k, jitter, h=0.1)
        st, w = deriv(lib, t, m)
        st_u, u = disp(lib, t, m, w)
        exact = exact_displacement_weights(t, m, w)
        assert st == 0 and st_u == 0
        assert np.abs(u - exact).max() <= rel * np.abs(exact).max()
    t = times(rng, 23, jitter)
    assert disp(lib, t, 11, deriv(lib, t, 11)[1])[0] == 1


def test_displacement_simpson(lib):
    """k = 3 at an even step: w the central difference, u = Simpson's (1/6, 2/3, 1/6)."""
    t = np.array([0.0, 0.5, 1.0])
    st, w = deriv(lib, t, 1)
    assert st == 0 and np.abs(w - [-1.0, 0.0, 1.0]).max() <= 1e-15
    st, u = disp(lib, t, 1, w)
    assert st == 0 and np.abs(u - [1 / 6, 2 / 3, 1 / 6]).max() <= 1e-15


def test_bad_input(lib):
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    w = np.zeros(5)
    assert deriv(lib, t[:2], 1)[0] == 1                         # k < 3
    assert lib.sr_derivative_weights(np.zeros(102), 102, 50, np.empty(102)) == 1
    assert deriv(lib, t, 5)[0] == 1 and deriv(lib, t, -1)[0] == 1
    assert deriv(lib, np.array([0.0, 0.0, 1.0]), 1)[0] == 2     # repeated time
    assert deriv(lib, np.array([1.0, 1.0, 1.0, 1.0, 1.0]), 2)[0] == 2
    assert deriv(lib, np.array([0.0, np.nan, 1.0, 2.0, 3.0]), 2)[0] == 2
    assert disp(lib, np.array([0.0, 1.0, 1.0, 2.0, 3.0]), 2, w)[0] == 2
    assert disp(lib, t, 7, w)[0] == 1
    out, tc = np.empty(2), c_double()
    X = np.zeros((3, 2))
    bad = np.array([5], np.int32)
    ok = np.array([0], np.int32)
    assert lib.sr_centre_derivative(t[:3].copy(), X, 3, 2, bad, ok, 1, out, ctypes.byref(tc)) == 1
    assert lib.sr_centre_derivative(t[:4].copy(), np.zeros((4, 2)), 4, 2, ok, ok, 1, out,
                                    ctypes.byref(tc)) == 1     # even window


@pytest.mark.parametrize("m", (1, 2, 5))
def test_centre_derivative(lib, m):
    """The centre sample with its accelerations replaced (differencing.centre_derivative)."""
    rng = np.random.default_rng(60 + m)
    k, n = 2 * m + 1, 9
    t = times(rng, k, True)
    X = rng.normal(size=(k, n))
    history = [(float(ti), X[i].copy()) for i, ti in enumerate(t)]
    pairs = [(slice(0, 3), slice(3, 6)), (slice(7, 8), slice(8, 9))]
    tc_ref, ref = dif.centre_derivative(history, pairs)
    acc = np.array([0, 1, 2, 7], np.int32)
    vel = np.array([3, 4, 5, 8], np.int32)
    out, tc = np.empty(n), c_double()
    assert lib.sr_centre_derivative(t, X, k, n, acc, vel, 4, out, ctypes.byref(tc)) == 0
    assert tc.value == tc_ref
    assert np.abs(out - ref).max() <= 1e-12 * np.abs(ref).max()
    untouched = [6]
    assert out[untouched] == X[m, untouched]
