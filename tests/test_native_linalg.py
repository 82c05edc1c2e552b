"""The native core's small dense linear algebra (native/src/linalg.c) against LAPACK through
NumPy and the NumPy oracle of the estimator's observed-directions solve (tests/oracles/report.py).

The library under test is ``$SPACEROBOT_CORE_LIB`` when set, else a fresh build of the modules
this file needs (native/build.py, warnings as errors).

Tolerances: eigenvalues to 1e-12 of the largest |eigenvalue| (both are backward stable:
``~n eps |A|``); eigenvectors by their residual ``|A V - V diag(w)| <= 1e-13 |A|`` and
orthonormality ``|V^T V - 1| <= 1e-13`` (n <= 33); factorisations and solves of well-conditioned
matrices to 1e-12 relative.
"""
from __future__ import annotations

import ctypes
from pathlib import Path

import numpy as np
import pytest
from numpy.ctypeslib import ndpointer

import native_hosts
from oracles import report as orc
from oracles.estimator import report_kernels as rk

SOURCES = ["linalg.c", "physical.c", "differencing.c", "sr_math.c"]


def build_core(tmp_dir: Path) -> ctypes.CDLL:
    """``$SPACEROBOT_CORE_LIB``, else the modules of SOURCES built by native/build.py."""
    return native_hosts.build_core(tmp_dir, SOURCES)


D = ndpointer(np.float64, flags="C_CONTIGUOUS")
I = ndpointer(np.int32, flags="C_CONTIGUOUS")
c_int, c_double = ctypes.c_int, ctypes.c_double


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    L = build_core(tmp_path_factory.mktemp("core_linalg"))
    sig = {
        "sr_matmul": (None, [D, D, c_int, c_int, c_int, D]),
        "sr_matvec": (None, [D, D, c_int, c_int, D]),
        "sr_eigh": (c_int, [D, c_int, D, D]),
        "sr_cholesky": (c_int, [D, c_int]),
        "sr_cholesky_solve": (None, [D, c_int, D, c_int]),
        "sr_lu_solve": (c_int, [D, c_int, D, c_int]),
        "sr_scaled_information": (c_int, [D, c_int, D, D, I]),
        "sr_scaled_eigh": (c_int, [D, c_int, D, D, D, I]),
        "sr_rcond_scaled": (c_int, [D, c_int, D]),
        "sr_rcond_of_spectrum": (c_double, [D, I, c_int]),
        "sr_eig_solve": (c_int, [D, D, D, I, D, c_int, D, I]),
        "sr_eigvalsh_extremes": (c_int, [D, c_int, D, D]),
    }
    for name, (res, args) in sig.items():
        f = getattr(L, name)
        f.restype, f.argtypes = res, args
    return L


# -- wrappers ----------------------------------------------------------------------------------
def eigh(lib, A):
    A = np.ascontiguousarray(A, float)
    n = A.shape[0]
    w, V = np.empty(n), np.empty((n, n))
    st = lib.sr_eigh(A, n, w, V)
    return st, w, V


def scaled_eigh(lib, G):
    G = np.ascontiguousarray(G, float)
    p = G.shape[0]
    lam, V, d, u = np.empty(p), np.empty((p, p)), np.empty(p), np.empty(p, np.int32)
    st = lib.sr_scaled_eigh(G, p, lam, V, d, u)
    return st, lam, V, d, u


def eig_solve(lib, eig, r):
    lam, V, d, u = eig
    p = len(r)
    x, uo = np.empty(p), np.empty(p, np.int32)
    assert lib.sr_eig_solve(lam, V, d, u, np.ascontiguousarray(r, float), p, x, uo) == 0
    return x, uo.astype(bool)


# -- test matrices -----------------------------------------------------------------------------
def orthogonal(rng, n):
    Q, R = np.linalg.qr(rng.standard_normal((n, n)))
    return Q * np.sign(np.diag(R))


def symmetric_cases(rng, n):
    """(label, A): random, condition 1e12, rank-deficient, repeated eigenvalues, indefinite."""
    Q = orthogonal(rng, n)
    X = rng.standard_normal((n, n))
    out = [("random", X + X.T)]
    out.append(("cond1e12", (Q * np.logspace(0, -12, n)) @ Q.T))
    lam = rng.uniform(1, 2, n)
    lam[: n // 2] = 0.0
    out.append(("rank-deficient", (Q * lam) @ Q.T))
    lam = np.repeat([3.0, -1.0, 0.5], (n + 2) // 3)[:n]
    out.append(("repeated", (Q * lam) @ Q.T))
    out.append(("diagonal-repeated", np.diag(np.repeat([2.0, 1.0], n)[:n])))
    return out


@pytest.mark.slow
def test_eigh_against_lapack(lib):
    rng = np.random.default_rng(1)
    worst = dict(val=0.0, res=0.0, orth=0.0)
    for n in range(1, 34):
        for label, A in symmetric_cases(rng, n):
            A = 0.5 * (A + A.T)
            st, w, V = eigh(lib, A)
            assert st == 0, (n, label)
            ref = np.linalg.eigvalsh(A)
            scale = max(np.abs(ref).max(), 1e-300)
            assert np.all(np.diff(w) >= 0.0), (n, label)
            val = np.abs(w - ref).max() / scale
            res = np.abs(A @ V - V * w).max() / scale
            orth = np.abs(V.T @ V - np.eye(n)).max()
            worst = {k: max(worst[k], v) for k, v in zip(worst, (val, res, orth))}
            assert val <= 1e-12, (n, label, val)
            assert res <= 1e-13, (n, label, res)
            assert orth <= 1e-13, (n, label, orth)
    print("eigh worst:", worst)


@pytest.mark.slow
def test_eigh_matches_compiled_python(lib):
    """Same algorithm as report_kernels.eigh (Numba): eigenvalues and eigenvectors agree to
    round-off (eigenvectors up to sign, of well-separated eigenvalues)."""
    rng = np.random.default_rng(2)
    for n in (1, 2, 3, 6, 12, 20):
        X = rng.standard_normal((n, n))
        A = X + X.T
        st, w, V = eigh(lib, A)
        lam, W, ok = rk.eigh(A)
        assert st == 0 and ok
        assert np.abs(w - lam).max() <= 1e-13 * np.abs(lam).max()
        assert np.abs(np.abs(V) - np.abs(W)).max() <= 1e-11


def test_eigh_reads_lower_triangle_and_in_place(lib):
    rng = np.random.default_rng(3)
    X = rng.standard_normal((7, 7))
    A = X + X.T
    B = np.tril(A) + np.triu(rng.standard_normal((7, 7)), 1)      # junk above the diagonal
    st, w, V = eigh(lib, B)
    assert st == 0
    assert np.abs(w - np.linalg.eigvalsh(A)).max() <= 1e-12 * np.abs(w).max()
    Vi = A.copy()                                                  # A and V the same array
    wi = np.empty(7)
    assert lib.sr_eigh(Vi, 7, wi, Vi) == 0
    assert np.abs(wi - w).max() <= 1e-14 * np.abs(w).max()
    assert np.abs(A @ Vi - Vi * wi).max() <= 1e-13 * np.abs(w).max()


def extremes(lib, A):
    lo, hi = np.empty(1), np.empty(1)
    st = lib.sr_eigvalsh_extremes(np.ascontiguousarray(A, dtype=float).copy(), A.shape[0], lo, hi)
    return st, lo[0], hi[0]


def test_eigvalsh_extremes_against_lapack(lib):
    """The smallest and largest eigenvalue alone (the estimator's information spectra, n 1..20)
    against LAPACK's eigvalsh: within 1e-13 of |A| (documented ~eps |A|; near-multiple extreme
    eigenvalues 1e-11), or status 1 (the caller then falls back to sr_eigh) where an extreme
    eigenvalue is multiple (the repeated and rank-deficient cases), never for distinct ones."""
    rng = np.random.default_rng(7)
    worst, fallbacks, cases = 0.0, [], 0
    for n in range(1, 21):
        for label, A in symmetric_cases(rng, n):
            A = 0.5 * (A + A.T)
            st, lo, hi = extremes(lib, A)
            assert st in (0, 1), (n, label, st)
            cases += 1
            if st == 1:
                fallbacks.append((n, label))
                continue
            ref = np.linalg.eigvalsh(A)
            scale = max(np.abs(ref).max(), 1e-300)
            gap = min(np.diff(ref[:2]).min(initial=np.inf), np.diff(ref[-2:]).min(initial=np.inf))
            tol = 1e-13 if gap > 1e-8 * scale else 1e-11
            err = max(abs(lo - ref[0]), abs(hi - ref[-1])) / scale
            assert lo <= hi and err <= tol, (n, label, err)
            worst = max(worst, err)
    assert all(label in ("repeated", "rank-deficient", "diagonal-repeated")
               for _, label in fallbacks), fallbacks
    print(f"extremes worst {worst:.2g} x |A|, {len(fallbacks)} fallbacks in {cases} cases")


def test_eigvalsh_extremes_bad_input(lib):
    A = np.eye(3)
    A[0, 1] = A[1, 0] = np.nan
    assert extremes(lib, A)[0] == 1
    assert lib.sr_eigvalsh_extremes(np.eye(2), 0, np.empty(1), np.empty(1)) == 2
    assert lib.sr_eigvalsh_extremes(np.eye(65), 65, np.empty(1), np.empty(1)) == 2


def test_eigh_bad_input(lib):
    A = np.eye(3)
    A[1, 0] = A[0, 1] = np.nan
    st, w, V = eigh(lib, A)
    assert st == 1
    A = np.eye(4)
    A[2, 2] = np.inf
    assert eigh(lib, A)[0] == 1
    assert lib.sr_eigh(np.eye(65), 65, np.empty(65), np.empty((65, 65))) == 2
    assert lib.sr_eigh(np.eye(1), -1, np.empty(1), np.empty((1, 1))) == 2
    assert lib.sr_eigh(np.empty(1), 0, np.empty(1), np.empty(1)) == 0
    st, w, V = eigh(lib, np.eye(64) * 2.0)                          # the largest n
    assert st == 0 and np.all(w == 2.0)


def test_cholesky_and_solve(lib):
    rng = np.random.default_rng(4)
    for n in range(1, 25):
        X = rng.standard_normal((n + 3, n))
        S = X.T @ X + 0.1 * np.eye(n)
        L = S.copy()
        assert lib.sr_cholesky(L, n) == 0
        ref = np.linalg.cholesky(S)
        assert np.abs(L - ref).max() <= 1e-12 * np.abs(ref).max()
        assert np.all(np.triu(L, 1) == 0.0)
        B = rng.standard_normal((n, 3))
        X_ = B.copy()
        lib.sr_cholesky_solve(L, n, X_, 3)
        Xref = np.linalg.solve(S, B)
        assert np.abs(X_ - Xref).max() <= 1e-11 * np.abs(Xref).max()


def test_cholesky_bad_input(lib):
    S = np.array([[1.0, 2.0], [2.0, 1.0]])                           # indefinite
    assert lib.sr_cholesky(S.copy(), 2) == 1
    assert lib.sr_cholesky(-np.eye(3), 3) == 1
    assert lib.sr_cholesky(np.zeros((3, 3)), 3) == 1
    S = np.eye(3)
    S[1, 1] = np.nan
    assert lib.sr_cholesky(S, 3) == 2
    S = np.eye(3)
    S[2, 0] = np.nan                                                 # NaN reaches a pivot
    assert lib.sr_cholesky(S, 3) == 2
    S = np.eye(2)
    S[1, 1] = np.inf
    assert lib.sr_cholesky(S, 2) == 2
    assert lib.sr_cholesky(np.empty(1), 0) == 0


def test_cholesky_status_as_rls_update(lib):
    """The statuses of the Cholesky of kernels.rls_update's S: 1 not positive definite, 2 NaN."""
    from oracles.estimator.kernels import rls_update
    for S, want in ((np.array([[1.0, 2.0], [2.0, 1.0]]), 1), (np.diag([1.0, np.nan]), 2)):
        k = S.shape[0]
        # rls_update's S = lam 1 + H P H^T is P itself for H = 1, lam = 0
        py = rls_update(np.zeros(k), np.ascontiguousarray(S), np.eye(k), np.zeros(k), 0.0)[5]
        assert lib.sr_cholesky(S.copy(), k) == py == want


def test_lu_solve(lib):
    rng = np.random.default_rng(5)
    for n in range(1, 34):
        A = rng.standard_normal((n, n))
        B = rng.standard_normal((n, 4))
        LU, X = A.copy(), B.copy()
        assert lib.sr_lu_solve(LU, n, X, 4) == 0
        Xref = np.linalg.solve(A, B)
        cond = np.linalg.cond(A)
        assert np.abs(X - Xref).max() <= 1e-14 * cond * np.abs(Xref).max(), n
        # against the compiled Python LU (same algorithm): round-off
        assert np.abs(X - rk.lu_solve(A, B)).max() <= 1e-14 * cond * np.abs(Xref).max()
        x = B[:, 0].copy()
        assert lib.sr_lu_solve(A.copy(), n, x, 1) == 0                # a vector right side
        assert np.abs(x - Xref[:, 0]).max() <= 1e-14 * cond * np.abs(Xref).max()


def test_lu_solve_singular(lib):
    A = np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 0.0]])
    A[:, 0] = 0.0                                                    # a zero pivot column
    B = np.ones((3, 2))
    assert lib.sr_lu_solve(A, 3, B, 2) == 1
    assert np.all(np.isnan(B))
    assert np.all(np.isnan(rk.lu_solve(np.zeros((3, 3)), np.ones((3, 2)))))
    A = np.eye(2)
    A[0, 0] = np.nan
    assert lib.sr_lu_solve(A, 2, np.ones(2), 1) == 1
    assert lib.sr_lu_solve(np.eye(2), -1, np.ones(2), 1) == 2


def test_matmul_matvec(lib):
    rng = np.random.default_rng(6)
    A, B, x = rng.standard_normal((4, 7)), rng.standard_normal((7, 3)), rng.standard_normal(7)
    C, y = np.empty((4, 3)), np.empty(4)
    lib.sr_matmul(A, B, 4, 7, 3, C)
    lib.sr_matvec(A, x, 4, 7, y)
    assert np.abs(C - A @ B).max() <= 1e-14 * np.abs(A @ B).max()
    assert np.abs(y - A @ x).max() <= 1e-14 * np.abs(A @ x).max()


# -- the scale-free information and the observed-directions solve -------------------------------
def information_cases(rng, p):
    """Information matrices G (p, p): well excited, condition 1e8 of the scaled matrix, a
    parameter without information (zero row and column), rank-deficient (an unobserved
    combination), wildly different scales of the parameters."""
    X = rng.standard_normal((3 * p, p))
    out = [("excited", X.T @ X)]
    Q = orthogonal(rng, p)
    out.append(("cond1e8", (Q * np.logspace(0, -8, p)) @ Q.T))
    G = X.T @ X
    G[1, :] = G[:, 1] = 0.0
    out.append(("no-information", G))
    Xr = X[:, : p - 2] @ rng.standard_normal((p - 2, p))
    out.append(("rank-deficient", Xr.T @ Xr))
    s = np.logspace(-3, 4, p)
    out.append(("scales", (X.T @ X) * np.outer(s, s)))
    return out


def test_observed_solve_against_oracle(lib):
    rng = np.random.default_rng(7)
    worst = 0.0
    for p in (3, 4, 8, 12, 20):
        for label, G in information_cases(rng, p):
            r = rng.standard_normal(p) * np.sqrt(np.abs(np.diag(G)) + 1.0)
            st, lam, V, d, u = scaled_eigh(lib, G)
            assert st == 0
            # the scaled matrix and its spectrum against NumPy's
            dg = np.diag(G)
            unobs = ~(dg > 0.0)
            dd = np.sqrt(np.where(unobs, 1.0, dg))
            Gs = G / np.outer(dd, dd)
            Gs[unobs, :] = 0.0
            Gs[:, unobs] = 0.0
            assert np.array_equal(u.astype(bool), unobs)
            assert np.abs(d - dd).max() <= 1e-15 * dd.max()
            assert np.abs(lam - np.linalg.eigvalsh(Gs)).max() <= 1e-12 * np.abs(lam).max()
            x, uo = eig_solve(lib, (lam, V, d, u), r)
            xr, ur = orc.observed_solve(G, r)
            assert np.array_equal(uo, ur), (p, label)
            # the solution in the observed directions: relative to its size, times the kept
            # condition number (the cut at REL_EIG_MIN keeps up to 1e12 in principle; these
            # cases keep <= 1e8)
            kept = lam[lam > orc.REL_EIG_MIN * lam[-1]]
            err = np.abs(x - xr).max() / max(np.abs(xr).max(), 1e-300)
            worst = max(worst, err / (kept[-1] / kept[0]))
            assert err <= 1e-14 * kept[-1] / kept[0] + 1e-13, (p, label, err)
    print("eig_solve worst error / condition:", worst)


def test_eig_solve_matches_compiled_python(lib):
    rng = np.random.default_rng(8)
    for p in (4, 12):
        for label, G in information_cases(rng, p):
            r = rng.standard_normal(p)
            eig = scaled_eigh(lib, G)[1:]
            x, uo = eig_solve(lib, eig, r)
            lam, V, d, u, ok = rk.eig_scaled(G)
            xp, up = rk.eig_solve(lam, V, d, u, r)
            kept = lam[lam > rk.REL_EIG_MIN * lam[-1]]
            assert ok and np.array_equal(uo, up), label
            assert np.abs(x - xp).max() <= (1e-13 * kept[-1] / kept[0]) * np.abs(xp).max(), label


def test_eig_solve_bad_size(lib):
    z = np.zeros(1)
    zi = np.zeros(1, np.int32)
    assert lib.sr_eig_solve(z, z, z, zi, z, 65, z, zi) == 2
    assert lib.sr_eig_solve(z, z, z, zi, z, 0, z, zi) == 0


def test_rcond(lib):
    """rcond_of_spectrum = max(lam_min, 0) / lam_max of NumPy's eigenvalues of the scaled
    information (identifier._rcond_numpy's definition), 0 with a zero diagonal entry;
    rcond_scaled = the scaled matrix and whether it is usable as it is."""
    from oracles.estimator.identifier import _rcond_numpy
    rng = np.random.default_rng(9)
    for p in (3, 8, 12):
        for label, G in information_cases(rng, p):
            st, lam, V, d, u = scaled_eigh(lib, G)
            rc = lib.sr_rcond_of_spectrum(lam, u, p)
            ref = _rcond_numpy(G)
            # absolute: an eigenvalue ~0 is ~eps either way
            assert abs(rc - ref) <= 1e-14 + 1e-10 * ref, (p, label, rc, ref)
            Gs = np.empty((p, p))
            ok = lib.sr_rcond_scaled(G, p, Gs)
            Gs_ref, ok_ref = rk.rcond_scaled(G)
            assert (ok == 0) == ok_ref, label
            assert np.abs(Gs - Gs_ref).max() <= 1e-15 * np.abs(Gs_ref).max()
    assert lib.sr_rcond_of_spectrum(np.array([1.0, 2.0]), np.zeros(2, np.int32), 2) == 0.5
    assert lib.sr_rcond_of_spectrum(np.array([-1.0, 2.0]), np.zeros(2, np.int32), 2) == 0.0
    assert lib.sr_rcond_of_spectrum(np.array([-1.0, 0.0]), np.zeros(2, np.int32), 2) == 0.0
    assert lib.sr_rcond_of_spectrum(np.array([1.0, 2.0]), np.array([0, 1], np.int32), 2) == 0.0
    G = np.eye(3)
    G[0, 1] = np.inf
    assert lib.sr_rcond_scaled(G, 3, np.empty((3, 3))) == 1
