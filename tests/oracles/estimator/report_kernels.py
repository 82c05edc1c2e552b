"""The oracle's kernels of what the estimator reports at every sample (plain loops, run as
Python, ``_nonumba``): the prior's pull and
the covariance of the paper solver's parameters, the Jacobians of the maps to the estimates, the
lag of the estimates behind moving parameters (:mod:`.tracking`), the residual autocorrelation
(:class:`.uncertainty.Autocorrelation`), the physical-consistency test of an estimated body.

They implement :func:`.uncertainty.observed_solve` and :func:`.uncertainty.eig_scaled`, the
paper solver's ``covariance``, ``prior_pull``, ``jacobian``, ``vector_of``, ``uncertainty`` and
``drift_lag`` (:class:`.solvers.PaperSolver`), the joint solver's ``vector_of`` and ``jacobian``,
the arithmetic of :class:`.tracking.DriftTracker` and :func:`.physical.is_physical`: in NumPy
some hundreds of small-array operations per sample, whose call overhead was most of the cost of
``Identifier.update`` and ``Identifier.report()``. The NumPy formulation is the test oracle
``tests/oracles/report.py``.

No ``np.linalg`` and no ``np.dot`` here: Numba implements both with SciPy's LAPACK and BLAS,
and the FMUs need only NumPy and Numba. The small dense problems are written out instead: the
eigen-decompositions of the scale-free information (:func:`eigh`: Householder
tridiagonalisation and implicit QL, EISPACK's ``tred2`` / ``tql2``), the solves of the tracker
(:func:`lu_solve`: LU with partial pivoting) and the products (loops). They equal LAPACK's and
BLAS's results to round-off; where a matrix is nearly singular (the information of the first
seconds of a run) that round-off is amplified by its condition number, in either version.
The map of the joint solver's parameters to the estimates (:func:`joint_vector_of`) repeats
NumPy's operations in NumPy's order: the estimates are the same bit for bit.

Positions in the vectors are those of :class:`spacerobot.interface.ParameterLayout` (checked
against it by the tests): estimates per body ``m, b (3), I (6)`` at 0 and 10; the paper's
``mu = [m1, m1 b1, mn, mn bn]`` (8,), ``theta = [I1#, In#]`` (12,), ``z = [mu, theta]`` (20,);
``D(mu)`` (20,) as :func:`.kernels.D_of_mu`.
"""
from __future__ import annotations

import math

import numpy as np
from ._nonumba import njit

from .kernels import D_of_mu, modified_rls_update

# error_model="numpy": a division by zero gives inf / nan as in NumPy (the pull's map at a
# data-only mass of zero), instead of raising
_NB = dict(cache=True, nogil=True, error_model="numpy")

#: eigenvalues of the scaled information below this fraction of the largest count as
#: unobserved (also :data:`.uncertainty.REL_EIG_MIN`)
REL_EIG_MIN = 1e-12
#: |eigenvector component| above which a parameter touches an unobserved direction
UNOBSERVED_COMPONENT = 1e-6

#: per body: position of m in the estimates and in mu, of theta in z; sizes of mu, theta
EST0, MU0, ZTH0 = (0, 10), (0, 4), (8, 14)
N_MU, N_THETA = 8, 12
#: index pairs (i, j) of the entries of I# (eq. 21), row-major over i <= j
SHARP_I = (0, 0, 0, 1, 1, 2)
SHARP_J = (0, 1, 2, 1, 2, 2)


# -- small products (no BLAS) --------------------------------------------------------------------
@njit(**_NB)
def _matmul(A, B):
    """``A B`` (n, k) @ (k, m)."""
    n, k = A.shape
    m = B.shape[1]
    out = np.zeros((n, m))
    for i in range(n):
        for l in range(k):
            a = A[i, l]
            for j in range(m):
                out[i, j] += a * B[l, j]
    return out


@njit(**_NB)
def matvec(A, x):
    """``A x`` (n, k) @ (k,)."""
    n, k = A.shape
    out = np.zeros(n)
    for i in range(n):
        s = 0.0
        for l in range(k):
            s += A[i, l] * x[l]
        out[i] = s
    return out


# -- the prior's pull -------------------------------------------------------------------------
@njit(**_NB)
def scaled_information(G):
    """``(G_s, d, unobserved)``: the scale-free information ``G_s = G / (d d^T)``,
    ``d = sqrt(diag G)`` (1 where ``diag G`` is not > 0, and those rows and columns of ``G_s``
    set to 0) of the information ``G`` (p, p); ``G_s`` is what :func:`eig_solve` wants the
    eigen-decomposition of."""
    p = G.shape[0]
    unobserved = np.zeros(p, np.bool_)
    d = np.empty(p)
    for i in range(p):
        g = G[i, i]
        unobserved[i] = not g > 0.0
        d[i] = math.sqrt(1.0 if unobserved[i] else g)
    Gs = np.empty((p, p))
    for i in range(p):
        for j in range(p):
            Gs[i, j] = 0.0 if unobserved[i] or unobserved[j] else G[i, j] / (d[i] * d[j])
    return Gs, d, unobserved


@njit(**_NB)
def _tridiagonalize(V, d, e):
    """Householder reduction of the symmetric ``V`` (n, n) to tridiagonal form, in place:
    ``d`` the diagonal, ``e`` the sub-diagonal (``e[0] = 0``), ``V`` the accumulated
    orthogonal transformation (EISPACK ``tred2``, as in JAMA)."""
    n = V.shape[0]
    for j in range(n):
        d[j] = V[n - 1, j]
    for i in range(n - 1, 0, -1):
        scale, h = 0.0, 0.0
        for k in range(i):
            scale += abs(d[k])
        if scale == 0.0:
            e[i] = d[i - 1]
            for j in range(i):
                d[j] = V[i - 1, j]
                V[i, j] = 0.0
                V[j, i] = 0.0
        else:
            for k in range(i):                               # the Householder vector
                d[k] /= scale
                h += d[k] * d[k]
            f = d[i - 1]
            g = math.sqrt(h)
            if f > 0.0:
                g = -g
            e[i] = scale * g
            h -= f * g
            d[i - 1] = f - g
            for j in range(i):
                e[j] = 0.0
            for j in range(i):                               # the similarity transformation
                f = d[j]
                V[j, i] = f
                g = e[j] + V[j, j] * f
                for k in range(j + 1, i):
                    g += V[k, j] * d[k]
                    e[k] += V[k, j] * f
                e[j] = g
            f = 0.0
            for j in range(i):
                e[j] /= h
                f += e[j] * d[j]
            hh = f / (h + h)
            for j in range(i):
                e[j] -= hh * d[j]
            for j in range(i):
                f, g = d[j], e[j]
                for k in range(j, i):
                    V[k, j] -= f * e[k] + g * d[k]
                d[j] = V[i - 1, j]
                V[i, j] = 0.0
        d[i] = h
    for i in range(n - 1):                                   # accumulate the transformations
        V[n - 1, i] = V[i, i]
        V[i, i] = 1.0
        h = d[i + 1]
        if h != 0.0:
            for k in range(i + 1):
                d[k] = V[k, i + 1] / h
            for j in range(i + 1):
                g = 0.0
                for k in range(i + 1):
                    g += V[k, i + 1] * V[k, j]
                for k in range(i + 1):
                    V[k, j] -= g * d[k]
        for k in range(i + 1):
            V[k, i + 1] = 0.0
    for j in range(n):
        d[j] = V[n - 1, j]
        V[n - 1, j] = 0.0
    if n > 0:
        V[n - 1, n - 1] = 1.0
        e[0] = 0.0


@njit(**_NB)
def _tridiagonal_ql(V, d, e):
    """Eigenvalues ``d`` and eigenvectors (columns of ``V``) of the tridiagonal form of
    :func:`_tridiagonalize` by the implicit QL method, in place (EISPACK ``tql2``, as in
    JAMA). False if an eigenvalue did not converge in 100 iterations (non-finite input)."""
    n = d.shape[0]
    for i in range(1, n):
        e[i - 1] = e[i]
    if n > 0:
        e[n - 1] = 0.0
    f, tst1, eps = 0.0, 0.0, 2.0 ** -52
    for l in range(n):
        tst1 = max(tst1, abs(d[l]) + abs(e[l]))
        m = l
        while m < n - 1 and not abs(e[m]) <= eps * tst1:     # a negligible sub-diagonal
            m += 1
        if m > l:
            for _it in range(101):
                if _it == 100:
                    return False
                g = d[l]                                     # the implicit shift
                p = (d[l + 1] - g) / (2.0 * e[l])
                r = math.hypot(p, 1.0)
                if p < 0.0:
                    r = -r
                d[l] = e[l] / (p + r)
                d[l + 1] = e[l] * (p + r)
                dl1 = d[l + 1]
                h = g - d[l]
                for i in range(l + 2, n):
                    d[i] -= h
                f += h
                p = d[m]                                     # the QL sweep
                c = c2 = c3 = 1.0
                el1 = e[l + 1]
                s = s2 = 0.0
                for i in range(m - 1, l - 1, -1):
                    c3, c2, s2 = c2, c, s
                    g = c * e[i]
                    h = c * p
                    r = math.hypot(p, e[i])
                    e[i + 1] = s * r
                    s = e[i] / r
                    c = p / r
                    p = c * d[i] - s * g
                    d[i + 1] = h + s * (c * g + s * d[i])
                    for k in range(n):
                        h = V[k, i + 1]
                        V[k, i + 1] = s * V[k, i] + c * h
                        V[k, i] = c * V[k, i] - s * h
                p = -s * s2 * c3 * el1 * e[l] / dl1
                e[l] = s * p
                d[l] = c * p
                if not abs(e[l]) > eps * tst1:
                    break
        d[l] += f
        e[l] = 0.0
    return True


@njit(**_NB)
def eigh(A):
    """``(lam, V, ok)``: the eigen-decomposition ``A = V diag(lam) V^T`` of the symmetric ``A``
    (p, p) with ``lam`` ascending and orthonormal eigenvectors ``V``, in place of
    ``np.linalg.eigh`` (whose LAPACK the FMUs do not have in compiled code): Householder
    tridiagonalisation, then the implicit QL method (EISPACK ``tred2`` / ``tql2``; absolute
    accuracy ``~eps |A|``, as LAPACK's). Eigenvectors of equal eigenvalues are an orthonormal
    basis of their space (as LAPACK's). ``ok`` False: no convergence (non-finite input)."""
    p = A.shape[0]
    V = A.copy()
    d, e = np.empty(p), np.empty(p)
    _tridiagonalize(V, d, e)
    ok = _tridiagonal_ql(V, d, e)
    order = np.argsort(d)
    lam, W = np.empty(p), np.empty((p, p))
    for k in range(p):
        lam[k] = d[order[k]]
        for i in range(p):
            W[i, k] = V[i, order[k]]
    return lam, W, ok


@njit(**_NB)
def eig_scaled(G):
    """``(lam, V, d, unobserved, ok)``: :func:`scaled_information` of ``G`` (p, p) and the
    eigen-decomposition ``G_s = V diag(lam) V^T`` (:func:`eigh`), as :func:`eig_solve` takes
    them; ``ok`` False if it did not converge."""
    Gs, d, unobserved = scaled_information(G)
    lam, V, ok = eigh(Gs)
    return lam, V, d, unobserved, ok


@njit(**_NB)
def rcond_scaled(G):
    """``(G_s, ok)``: the scale-free information ``G_s = G / (d d^T)`` of ``G`` (p, p)
    (:func:`scaled_information`) and whether every diagonal entry of ``G`` is > 0 and every
    entry of ``G_s`` finite: the case in which :func:`.identifier._rcond` hands ``G_s`` to
    LAPACK itself."""
    Gs, d, unobserved = scaled_information(G)
    p = G.shape[0]
    ok = True
    for i in range(p):
        if unobserved[i]:
            ok = False
        for j in range(p):
            if not math.isfinite(Gs[i, j]):
                ok = False
    return Gs, ok


@njit(**_NB)
def rcond_of_spectrum(lam, unobserved):
    """``max(lam_min, 0) / lam_max`` of the ascending spectrum ``lam`` (p,) of a scaled
    information (:func:`eig_scaled`), 0 where a parameter has no information (``unobserved``
    (p,) bool) or no eigenvalue is > 0: :func:`.identifier._rcond` of the unscaled matrix, to
    round-off (these eigenvalues are the QL iteration's, not LAPACK's)."""
    p = lam.shape[0]
    for i in range(p):
        if unobserved[i]:
            return 0.0
    if p == 0 or not lam[p - 1] > 0.0:
        return 0.0
    return max(lam[0], 0.0) / lam[p - 1]


@njit(**_NB)
def eig_solve(lam, V, d, unobserved, r):
    """``(x, unobserved)``: ``G^-1 r`` in the directions the information observes, from the
    eigen-decomposition ``G_s = V diag(lam) V^T`` (ascending ``lam``) of the scaled information
    and ``d``, ``unobserved`` of :func:`scaled_information`: ``x = V_k diag(1 / lam_k) V_k^T
    (r / d) / d`` over the eigenvalues above ``REL_EIG_MIN`` of the largest; ``unobserved``
    (a new array) adds the parameters with a component above ``UNOBSERVED_COMPONENT`` along
    one of the others (:func:`.uncertainty.observed_solve`)."""
    p = r.shape[0]
    x = np.zeros(p)
    unobserved = unobserved.copy()
    if p == 0:
        return x, unobserved
    big = lam[p - 1] if lam[p - 1] > 0.0 else 0.0
    keep = lam > REL_EIG_MIN * big
    c = np.zeros(p)                                          # V_k^T (r / d)
    for k in range(p):
        if keep[k]:
            s = 0.0
            for i in range(p):
                s += V[i, k] * (r[i] / d[i])
            c[k] = s
    for i in range(p):                                       # (V_k / lam_k) c / d
        s = 0.0
        for k in range(p):
            if keep[k]:
                s += V[i, k] / lam[k] * c[k]
        x[i] = s / d[i]
    for i in range(p):
        for k in range(p):
            if not keep[k] and abs(V[i, k]) > UNOBSERVED_COMPONENT:
                unobserved[i] = True
    return x, unobserved


@njit(**_NB)
def D_jacobian(mu):
    """``dD/dmu`` (20, 8) (:func:`.parameters.D_jacobian`): per body with ``c = m b``,
    ``D = [m, c, c_i c_j / m (i <= j)]``, ``d(c_i c_j / m) = -c_i c_j / m^2 dm + c_j / m dc_i
    + c_i / m dc_j``."""
    Jac = np.zeros((20, N_MU))
    for k in range(2):
        e, u = EST0[k], MU0[k]
        m = mu[u]
        Jac[e, u] = 1.0
        for i in range(3):
            Jac[e + 1 + i, u + 1 + i] = 1.0
        m2 = m**2
        for p in range(6):
            i, j = SHARP_I[p], SHARP_J[p]
            ci, cj = mu[u + 1 + i], mu[u + 1 + j]
            row = e + 4 + p
            Jac[row, u] = -ci * cj / m2
            Jac[row, u + 1 + i] += cj / m
            Jac[row, u + 1 + j] += ci / m
    return Jac


@njit(**_NB)
def paper_prior_pull(mu_full, rls_mu, rls_theta, D_mu, M, S_ang, w_mu, w_theta, mu0, th0,
                     mu_active, theta_active, eig_lin, eig_ang):
    """``(delta (20,), unobserved (20,) bool)`` of the paper solver's ``z = [mu, theta]``
    (:meth:`.solvers.PaperSolver.prior_pull`).

    ``w_mu``, ``w_theta``: the prior's remaining weights ``decay / P0`` (``W0 = w 1``);
    ``eig_lin``, ``eig_ang``: ``(lam, V, d, unobserved)`` of the information of ``mu`` and of
    ``theta`` (:func:`eig_scaled`); the other arguments as
    the solver holds them (``mu_full`` the 8 mu with the fixed ones)."""
    p, r = rls_mu.shape[0], rls_theta.shape[0]
    rhs = np.empty(p)
    for i in range(p):                                       # -W0 (x - x0)
        rhs[i] = -(w_mu * (rls_mu[i] - mu0[i]))
    d_mu, u_mu = eig_solve(eig_lin[0], eig_lin[1], eig_lin[2], eig_lin[3], rhs)
    mu_ls = mu_full.copy()
    for i in range(p):
        mu_ls[mu_active[i]] -= d_mu[i]
    dD = D_mu - D_of_mu(mu_ls)
    rhs_th = np.empty(r)
    for i in range(r):                                       # -W0 (th - th0) + S_phi,psi dD
        s = 0.0
        for j in range(dD.shape[0]):
            s += S_ang[i, r + 1 + j] * dD[j]
        rhs_th[i] = -(w_theta * (rls_theta[i] - th0[i])) + s
    d_th, u_th = eig_solve(eig_ang[0], eig_ang[1], eig_ang[2], eig_ang[3], rhs_th)
    Tm = _matmul(M, D_jacobian(mu_full))                     # (r, 8)
    for i in range(r):
        for j in range(p):
            if u_mu[j] and Tm[i, mu_active[j]] != 0.0:
                u_th[i] = True
    delta = np.zeros(N_MU + N_THETA)
    unobserved = np.zeros(N_MU + N_THETA, np.bool_)
    for i in range(p):
        delta[mu_active[i]], unobserved[mu_active[i]] = d_mu[i], u_mu[i]
    for i in range(r):
        delta[N_MU + theta_active[i]], unobserved[N_MU + theta_active[i]] = d_th[i], u_th[i]
    return delta, unobserved


# -- the data's scatter ----------------------------------------------------------------------
@njit(**_NB)
def paper_covariance(P_lin, P_ang, M, mu_full, s2_lin, s2_ang, P0_mu, P0_theta, mu_active,
                     theta_active):
    """Covariance (20, 20) of ``z = [mu, theta]`` (:meth:`.solvers.PaperSolver.covariance`):
    ``Cov(mu) = s2_lin P_lin``; ``Cov(theta) = s2_ang P_ang + T Cov(mu) T^T`` and
    ``Cov(theta, mu) = T Cov(mu)`` with ``T = M dD/dmu``; the parameters that are not
    identified keep their prior covariance ``P0``."""
    p, r = mu_active.shape[0], theta_active.shape[0]
    Cmu = P0_mu * np.eye(N_MU)
    for i in range(p):
        for j in range(p):
            Cmu[mu_active[i], mu_active[j]] = P_lin[i, j] * s2_lin
    Tm_a = _matmul(M, D_jacobian(mu_full))                   # (r, 8)
    Tm = np.zeros((N_THETA, N_MU))
    for i in range(r):
        Tm[theta_active[i]] = Tm_a[i]
    Cth = P0_theta * np.eye(N_THETA)
    for i in range(r):
        for j in range(r):
            Cth[theta_active[i], theta_active[j]] = P_ang[i, j] * s2_ang
    cov = np.empty((N_MU + N_THETA, N_MU + N_THETA))
    TC = _matmul(Tm, Cmu)
    TCT = _matmul(TC, Tm.T)
    for i in range(N_MU):
        for j in range(N_MU):
            cov[i, j] = Cmu[i, j]
    for i in range(N_THETA):
        for j in range(N_MU):
            cov[N_MU + i, j] = TC[i, j]
            cov[j, N_MU + i] = TC[i, j]
        for j in range(N_THETA):
            cov[N_MU + i, N_MU + j] = Cth[i, j] + TCT[i, j]
    return cov


@njit(**_NB)
def _residual_variance(S, z, dof):
    """``max(z^T S z, 0) / dof``, 0 for ``dof <= 0`` (:func:`.uncertainty.residual_variance`)."""
    if dof <= 0:
        return 0.0
    Sz = matvec(S, z)
    q = 0.0
    for i in range(z.shape[0]):
        q += z[i] * Sz[i]
    return max(q, 0.0) / dof


@njit(**_NB)
def paper_residual_variances(rls_mu, rls_theta, D_mu, S_lin, S_ang, dof_lin, dof_ang,
                             scale_lin, inflation_lin, scale_ang, inflation_ang):
    """``(s2_lin, s2_ang)``: the a-posteriori residual variances of both equations at
    ``mu``, ``theta`` from the Gram matrices (``z = [mu, -1]``, ``[theta, -1, -D(mu)]``), times
    the forgetting's scale and the correlation's inflation (1: not applied)
    (:meth:`.solvers.PaperSolver._residual_variances`)."""
    p, r, nD = rls_mu.shape[0], rls_theta.shape[0], D_mu.shape[0]
    z_lin = np.empty(p + 1)
    z_lin[:p] = rls_mu
    z_lin[p] = -1.0
    z_ang = np.empty(r + 1 + nD)
    z_ang[:r] = rls_theta
    z_ang[r] = -1.0
    for i in range(nD):
        z_ang[r + 1 + i] = -D_mu[i]
    s2_lin = _residual_variance(S_lin, z_lin, dof_lin) * scale_lin * inflation_lin
    s2_ang = _residual_variance(S_ang, z_ang, dof_ang) * scale_ang * inflation_ang
    return s2_lin, s2_ang


# -- the map to the estimates ------------------------------------------------------------------
@njit(**_NB)
def paper_vector_of(z, sharp_to_project):
    """The 20 estimates from ``z = [mu, theta]``: ``m``, ``b = c / m``, ``I = I#[sharp_to_project]``."""
    out = np.empty(20)
    for k in range(2):
        e, u, t = EST0[k], MU0[k], ZTH0[k]
        m = z[u]
        out[e] = m
        for i in range(3):
            out[e + 1 + i] = z[u + 1 + i] / m
        for i in range(6):
            out[e + 4 + i] = z[t + sharp_to_project[i]]
    return out


@njit(**_NB)
def paper_jacobian(z, sharp_to_project):
    """``d paper_vector_of / d z`` (20, 20): ``db/dc = 1 / m``, ``db/dm = -c / m^2``, the CoM
    inertia a (permuted) parameter."""
    J = np.zeros((20, 20))
    for k in range(2):
        e, u, t = EST0[k], MU0[k], ZTH0[k]
        m = z[u]
        J[e, u] = 1.0
        for i in range(3):
            J[e + 1 + i, u + 1 + i] = 1.0 / m
            J[e + 1 + i, u] = -z[u + 1 + i] / m**2
        for i in range(6):
            J[e + 4 + i, t + sharp_to_project[i]] = 1.0
    return J


@njit(**_NB)
def joint_vector_of(z, sharp_to_project):
    """The 20 estimates from the joint solver's standard parameters ``z = [m, c = m b, I_O#]``
    per body (:meth:`.solvers.JointSolver.vector_of`): ``b = c / m``,
    ``I_c = I_O - m (|b|^2 1 - b b^T)`` (the parallel-axis theorem), ``I = I_c#[sharp_to_project]``
    (:func:`.parameters.physical_from_standard`, the same operations in the same order)."""
    out = np.empty(20)
    b = np.empty(3)
    for k in range(2):
        e = EST0[k]
        m = z[e]
        out[e] = m
        for i in range(3):
            b[i] = z[e + 1 + i] / m
            out[e + 1 + i] = b[i]
        bb = 0.0
        for i in range(3):
            bb += b[i] * b[i]
        for jp in range(6):
            p = sharp_to_project[jp]
            i, j = SHARP_I[p], SHARP_J[p]
            eye = 1.0 if i == j else 0.0
            out[e + 4 + jp] = z[e + 4 + p] - m * (bb * eye - b[i] * b[j])
    return out


@njit(**_NB)
def joint_jacobian(z, sharp_to_project):
    """``d joint_vector_of / d z`` (20, 20) (:meth:`.solvers.JointSolver.jacobian`): per body
    ``db/dc = 1 / m``, ``db/dm = -c / m^2``; ``I_c = I_O - S(c) / m`` with
    ``S(c) = |c|^2 1 - c c^T``: ``dI_c/dI_O = 1``, ``dI_c/dm = S / m^2``,
    ``dI_c,ij/dc_k = -(2 c_k d_ij - d_ik c_j - c_i d_jk) / m``."""
    J = np.zeros((20, 20))
    for k in range(2):
        e = EST0[k]
        m = z[e]
        J[e, e] = 1.0
        for i in range(3):
            J[e + 1 + i, e + 1 + i] = 1.0 / m
            J[e + 1 + i, e] = -z[e + 1 + i] / m**2
        cc = 0.0
        for i in range(3):
            cc += z[e + 1 + i] * z[e + 1 + i]
        for jp in range(6):
            p = sharp_to_project[jp]
            row = e + 4 + jp
            J[row, e + 4 + p] = 1.0
            i, j = SHARP_I[p], SHARP_J[p]
            ci, cj = z[e + 1 + i], z[e + 1 + j]
            S_ij = (cc if i == j else 0.0) - ci * cj
            J[row, e] = S_ij / m**2
            for kk in range(3):
                dS = (2.0 * z[e + 1 + kk] if i == j else 0.0) - (cj if kk == i else 0.0) \
                    - (ci if kk == j else 0.0)
                J[row, e + 1 + kk] = -dS / m
    return J


@njit(**_NB)
def scatter_and_pull(J, C, pull, unobserved_z):
    """``(var (20,), unobserved (20,) bool)``: ``diag(J C J^T) + pull^2`` and the estimates
    whose Jacobian row touches an unobserved parameter (:meth:`.solvers.ParameterSolver.uncertainty`)."""
    n, q = J.shape
    JC = _matmul(J, C)
    var = np.empty(n)
    unobserved = np.zeros(n, np.bool_)
    for i in range(n):
        s = 0.0
        for k in range(q):
            s += JC[i, k] * J[i, k]
            if unobserved_z[k] and J[i, k] != 0.0:
                unobserved[i] = True
        var[i] = s + pull[i] ** 2
    return var, unobserved


@njit(**_NB)
def paper_uncertainty(mu_full, theta_full, rls_mu, rls_theta, D_mu, M, P_lin, P_ang, S_ang,
                      s2_lin, s2_ang, P0_mu, P0_theta, w_mu, w_theta, mu0, th0, mu_active,
                      theta_active, sharp_to_project, eig_lin, eig_ang, mu_rls_full):
    """``(sd (20,), unobserved (20,) bool, data-only answer (20,), J (20, 20))`` of the paper
    solver's estimates, the whole of :meth:`.solvers.ParameterSolver.uncertainty_parts` for
    :class:`.solvers.PaperSolver` in one call:
    ``sd^2 = diag(J C J^T) + (v(z) - v(z - delta))^2`` (``J delta`` where ``z - delta`` has no
    positive mass), with :func:`paper_jacobian`, :func:`paper_covariance`,
    :func:`paper_prior_pull` and :func:`paper_vector_of`. ``mu_full``, ``theta_full``: the
    reported ``z`` (bias-compensated where the solver compensates, :mod:`.eiv`);
    ``mu_rls_full``: the 8 mu of the RLS itself, whose prior pull ``delta`` is."""
    z = np.concatenate((mu_full, theta_full))
    J = paper_jacobian(z, sharp_to_project)
    delta, unobserved_z = paper_prior_pull(mu_rls_full, rls_mu, rls_theta, D_mu, M, S_ang, w_mu,
                                           w_theta, mu0, th0, mu_active, theta_active,
                                           eig_lin, eig_ang)
    x = paper_vector_of(z, sharp_to_project)
    pull = x - paper_vector_of(z - delta, sharp_to_project)
    if not np.all(np.isfinite(pull)):                        # the data-only mass <= 0
        pull = matvec(J, delta)
    C = paper_covariance(P_lin, P_ang, M, mu_full, s2_lin, s2_ang, P0_mu, P0_theta, mu_active,
                         theta_active)
    var, unobserved = scatter_and_pull(J, C, pull, unobserved_z)
    sd = np.empty(var.shape[0])
    for i in range(var.shape[0]):
        sd[i] = math.sqrt(var[i]) if var[i] > 0.0 else 0.0
    return sd, unobserved, x - pull, J


@njit(**_NB)
def paper_std_parts(mu_full, theta_full, rls_mu, rls_theta, D_mu, M, P_lin, P_ang, S_lin, S_ang,
                    dof_lin, dof_ang, scale_lin, inflation_lin, scale_ang, inflation_ang,
                    P0_mu, P0_theta, w_mu, w_theta, mu0, th0, mu_active, theta_active,
                    sharp_to_project, mu_rls_full):
    """``(sd, unobserved, data-only answer, J, rcond, ok)``: :func:`paper_uncertainty` with
    its inputs computed in the same call, as :meth:`.solvers.PaperSolver.uncertainty_parts`
    takes them: the residual variances (:func:`paper_residual_variances` of the Gram matrices
    ``S_lin``, ``S_ang`` with the degrees of freedom, scales and inflations given) and the
    eigen-decompositions (:func:`eig_scaled`) of the parameters' blocks of ``S_lin`` and
    ``S_ang``; ``rcond`` (2,): those blocks' reciprocal condition numbers
    (:func:`rcond_of_spectrum`, the excitation diagnostics); ``ok`` False if one of the
    decompositions did not converge (the caller raises, as :func:`.uncertainty.eig_scaled`
    does)."""
    s2_lin, s2_ang = paper_residual_variances(rls_mu, rls_theta, D_mu, S_lin, S_ang, dof_lin,
                                              dof_ang, scale_lin, inflation_lin, scale_ang,
                                              inflation_ang)
    p, r = rls_mu.shape[0], rls_theta.shape[0]
    lam_l, V_l, d_l, u_l, ok_l = eig_scaled(S_lin[:p, :p].copy())
    lam_a, V_a, d_a, u_a, ok_a = eig_scaled(S_ang[:r, :r].copy())
    sd, unobserved, data_only, J = paper_uncertainty(
        mu_full, theta_full, rls_mu, rls_theta, D_mu, M, P_lin, P_ang, S_ang, s2_lin, s2_ang,
        P0_mu, P0_theta, w_mu, w_theta, mu0, th0, mu_active, theta_active, sharp_to_project,
        (lam_l, V_l, d_l, u_l), (lam_a, V_a, d_a, u_a), mu_rls_full)
    # the excitation diagnostics from the same spectra (S's parameter blocks are the
    # identifier's information matrices)
    rcond = np.array([rcond_of_spectrum(lam_l, u_l), rcond_of_spectrum(lam_a, u_a)])
    return sd, unobserved, data_only, J, rcond, ok_l and ok_a


# -- small dense solves (no LAPACK in the FMUs) -------------------------------------------------
@njit(**_NB)
def lu_solve(A, B):
    """``A^-1 B`` for ``A`` (n, n) and ``B`` (n, k): LU factorisation with partial (row)
    pivoting, as LAPACK's ``gesv`` (``np.linalg.solve``), to round-off. All NaN where a pivot is
    exactly 0 (where ``np.linalg.solve`` raises ``LinAlgError``); inputs kept."""
    n, k = B.shape
    LU = A.copy()
    X = B.copy()
    for j in range(n):
        piv, big = j, abs(LU[j, j])                          # the largest |entry| of column j
        for i in range(j + 1, n):
            if abs(LU[i, j]) > big:
                piv, big = i, abs(LU[i, j])
        if big == 0.0 or big != big:
            X[:, :] = np.nan
            return X
        if piv != j:                                         # swap rows of LU and of X
            for c in range(n):
                LU[j, c], LU[piv, c] = LU[piv, c], LU[j, c]
            for c in range(k):
                X[j, c], X[piv, c] = X[piv, c], X[j, c]
        for i in range(j + 1, n):                            # eliminate below the pivot
            f = LU[i, j] / LU[j, j]
            LU[i, j] = f
            for c in range(j + 1, n):
                LU[i, c] -= f * LU[j, c]
            for c in range(k):
                X[i, c] -= f * X[j, c]
    for j in range(n - 1, -1, -1):                           # back substitution, U X = L^-1 B
        for c in range(k):
            s = X[j, c]
            for l in range(j + 1, n):
                s -= LU[j, l] * X[l, c]
            X[j, c] = s / LU[j, j]
    return X


@njit(**_NB)
def lu_solve_vec(A, b):
    """``A^-1 b`` (n,) for ``A`` (n, n), ``b`` (n,) (:func:`lu_solve`; all NaN if singular)."""
    B = np.empty((b.shape[0], 1))
    B[:, 0] = b
    return lu_solve(A, B)[:, 0].copy()


# -- the estimates' lag behind moving parameters (:mod:`.tracking`) --------------------------------
@njit(**_NB)
def block_lag(G, M, rate, growth):
    """``(A r, r)`` of one least-squares problem (:mod:`.tracking`, eq. 2): ``A = G^-1 M``
    (the information-weighted mean age), ``r = (1 - growth A)^-1 rate`` (the truth's rate from
    the estimate's); ``G``, ``M`` (p, p), ``rate`` (p,). NaN where ``G`` or ``1 - growth A`` is
    singular (:func:`lu_solve`)."""
    p = rate.shape[0]
    A = lu_solve(G, M)
    R = np.empty((p, p))                                     # 1 - growth A
    for i in range(p):
        for j in range(p):
            R[i, j] = (1.0 if i == j else 0.0) - growth * A[i, j]
    r = lu_solve_vec(R, rate)
    return matvec(A, r), r


@njit(**_NB)
def paper_drift_lag(S_lin, S_ang, M_lin, M_ang, rate_z, growth, mu_full, mu_active,
                    theta_active):
    """The lag (20,) of the paper solver's ``z = [mu, theta]`` behind parameters moving at
    ``rate_z`` (20,) (:meth:`.solvers.PaperSolver.drift_lag`): :func:`block_lag` of ``mu`` and
    of ``theta`` in the Gram matrices ``S`` and age-weighted Gram matrices ``M`` of the rows
    ``[A | b]`` and ``[phi | y | psi]``, and ``theta``'s response to ``mu``'s lag and rate,
    ``G^-1 (S_phi,psi dD/dmu lag_mu - M_phi,psi dD/dmu r_mu)``. NaN where a block is
    singular."""
    p, r = mu_active.shape[0], theta_active.shape[0]
    rate_mu, rate_th = np.empty(p), np.empty(r)
    for i in range(p):
        rate_mu[i] = rate_z[mu_active[i]]
    for i in range(r):
        rate_th[i] = rate_z[N_MU + theta_active[i]]
    lag_mu, r_mu = block_lag(S_lin[:p, :p].copy(), M_lin[:p, :p].copy(), rate_mu, growth)
    G = S_ang[:r, :r].copy()
    lag_th, _ = block_lag(G, M_ang[:r, :r].copy(), rate_th, growth)
    dD_full = D_jacobian(mu_full)                             # (20, 8)
    nD = dD_full.shape[0]
    dD_lag, dD_r = np.zeros(nD), np.zeros(nD)                # dD/dmu lag_mu, dD/dmu r_mu
    for a in range(nD):
        for i in range(p):
            dD_lag[a] += dD_full[a, mu_active[i]] * lag_mu[i]
            dD_r[a] += dD_full[a, mu_active[i]] * r_mu[i]
    rhs = np.empty(r)
    for i in range(r):
        s1, s2 = 0.0, 0.0
        for a in range(nD):
            s1 += S_ang[i, r + 1 + a] * dD_lag[a]
            s2 += M_ang[i, r + 1 + a] * dD_r[a]
        rhs[i] = s1 - s2
    lag_th = lag_th + lu_solve_vec(G, rhs)
    lag = np.zeros(N_MU + N_THETA)
    for i in range(p):
        lag[mu_active[i]] = lag_mu[i]
    for i in range(r):
        lag[N_MU + theta_active[i]] = lag_th[i]
    return lag


@njit(**_NB)
def paper_estimates_lag(jac, rate_x, growth, S_lin, S_ang, M_lin, M_ang, mu_full, mu_active,
                        theta_active):
    """``(lag (20,), finite)``: the lag of the paper solver's estimates, ``J L(J^-1 rate_x)``
    with ``L`` = :func:`paper_drift_lag` and ``J`` = ``jac`` (20, 20) the Jacobian of the
    estimates in ``z`` (:func:`.tracking.matrix_lag` with the solver's ``drift_lag``: the same
    calls in one); ``finite`` False if an entry is not finite (a singular block)."""
    rate_z = lu_solve_vec(jac, rate_x)
    lag_z = paper_drift_lag(S_lin, S_ang, M_lin, M_ang, rate_z, growth, mu_full, mu_active,
                            theta_active)
    lag = matvec(jac, lag_z)
    finite = True
    for i in range(lag.shape[0]):
        if not math.isfinite(lag[i]):
            finite = False
    return lag, finite


@njit(**_NB)
def paper_tracker_add(lam, s0, s1, t_ref, t_prev, a_bar_prev, w, mt, mx, ctt, ctx, t, x, sd,
                      rate_memory, M_lin, M_ang, G_lin, G_ang, jac, S_lin, S_ang, mu_full,
                      mu_active, theta_active):
    """:meth:`.tracking.DriftTracker.add` of the paper solver's estimates in one call: the
    regression (:func:`drift_regression`), the age-weighted Gram matrices ``M_lin``, ``M_ang``
    stepped with the Gram matrices before the sample ``G_lin``, ``G_ang`` (:func:`age_step`),
    and where every ``ctt > 0`` the estimates' lag (:func:`paper_estimates_lag` with the Gram
    matrices after it, ``S_lin``, ``S_ang``). The same operations in the same order.

    Returns ``(s0, s1, t_ref, a_bar, da_dt, w, mt, mx, ctt, ctx, rate, gain, M_lin, M_ang,
    lag, has_lag)``; ``has_lag`` False: no matrix lag (a ``ctt`` not > 0, or a singular
    block)."""
    (s0, s1, t_ref, a_bar, da_dt, step, w, mt, mx, ctt, ctx, rate, gain
     ) = drift_regression(lam, s0, s1, t_ref, t_prev, a_bar_prev, w, mt, mx, ctt, ctx, t, x, sd,
                          rate_memory)
    M_lin = age_step(M_lin, G_lin, lam, step)
    M_ang = age_step(M_ang, G_ang, lam, step)
    all_positive = True
    for i in range(ctt.shape[0]):
        if not ctt[i] > 0.0:
            all_positive = False
    lag, has_lag = np.zeros(x.shape[0]), False
    if all_positive:
        growth = da_dt / a_bar if a_bar > 0.0 else 0.0
        lag, has_lag = paper_estimates_lag(jac, rate, growth, S_lin, S_ang, M_lin, M_ang,
                                           mu_full, mu_active, theta_active)
    return (s0, s1, t_ref, a_bar, da_dt, w, mt, mx, ctt, ctx, rate, gain, M_lin, M_ang, lag,
            has_lag)


@njit(**_NB)
def gram_add(S, R, lam):
    """``lam S + R^T R`` (a new array) of the Gram matrix ``S`` (n, n) and the augmented rows
    ``R`` (k, n) of one more sample (:meth:`.uncertainty.Gram.add`; ``S + R^T R`` for
    ``lam = 1``)."""
    n = S.shape[0]
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for l in range(R.shape[0]):
                acc += R[l, i] * R[l, j]
            out[i, j] = (S[i, j] if lam == 1.0 else lam * S[i, j]) + acc
    return out


@njit(**_NB)
def _relative_norm(e, rhs):
    """``|e| / |rhs|`` (``|rhs|`` floored at 1e-300), as the identifier's residual outputs."""
    se, sr = 0.0, 0.0
    for i in range(e.shape[0]):
        se += e[i] * e[i]
    for i in range(rhs.shape[0]):
        sr += rhs[i] * rhs[i]
    return math.sqrt(se) / max(math.sqrt(sr), 1e-300)


@njit(**_NB)
def paper_step(rls_state, rows, lam, mu_fixed, mu_active, theta_active, S_lin, S_ang, info_lin,
               info_ang, mu_prev, theta_prev, gram_scalars, prior, s2p, com_min, tracker,
               tracker_sums, M_lin, M_ang):
    """One sample of the paper solver and what the identifier computes after it, in one call:
    :func:`.kernels.modified_rls_update`, both Gram matrices and information matrices stepped
    (:func:`gram_add`), the relative residuals, :func:`paper_std_parts` at the new answers
    (its ``sd`` floored at the error scale of the estimates where unobserved, as
    :meth:`.solvers.ParameterSolver.std_parts`) and :func:`paper_tracker_add` with it. The
    same operations in the same order as :meth:`.identifier.Identifier._accept` through the
    solver's layers, for the configurations it is used for: no consider columns, no noise
    rows, no residual autocorrelation (:meth:`.solvers.PaperSolver.fused`).

    Parameters
    ----------
    rls_state : tuple ``(lin_x (p,), lin_P (p, p), ang_x (r,), ang_P (r, r), M (r, 20),
        D_mu (20,))`` of :class:`.rls.ModifiedRLS`
    rows : tuple ``(A (k1, p), b (k1,), phi (k2, r), y (k2,), psi (k2, 20))``, the identified
        rows with the fixed parameters' columns moved to the right-hand sides
    lam : float, forgetting factor;  mu_fixed (8,), mu_active (p,), theta_active (r,) int
    S_lin (p + 1, p + 1), S_ang (r + 21, r + 21) : Gram matrices before the sample
    info_lin (p, p), info_ang (r, r) : the identifier's information before the sample
    mu_prev (8,), theta_prev (12,) : the solver's full vectors before (their fixed entries)
    gram_scalars : (6,) ``[dof_lin, dof_ang, var_scale_lin, var_scale_ang, decay_lin,
        decay_ang]`` of the Gram matrices after the sample (:class:`.uncertainty.Gram`)
    prior : tuple ``(P0_mu, P0_theta, mu0 (p,), th0 (r,))``
    s2p : (6,) int, ``par.SHARP_TO_PROJECT``;  com_min : float, ``COM_SCALE_MIN``
    tracker : (6,) ``[lam, s0, s1, t_ref, t_prev, a_bar]`` of the :class:`.tracking.DriftTracker`
        and ``[clock t, rate_memory, noise_lag]`` appended: (9,)
    tracker_sums : tuple ``(w, mt, mx, ctt, ctx)`` (20,) each (``regression_sums``)
    M_lin, M_ang : its age-weighted Gram matrices before the sample

    Returns
    -------
    status : int, :func:`.kernels.modified_rls_update`'s (nothing else is valid unless 0), or
        3 where an eigen-decomposition did not converge
    rls_new : ``(lin_x, lin_P, ang_x, ang_P, M, D_mu)``
    grams : ``(S_lin, S_ang, info_lin, info_ang)`` after the sample
    scalars : ``(residual_lin, residual_ang, rcond_lin, rcond_ang)``: the relative residuals
        and the excitation diagnostics
    tracker_scalars : ``(s0, s1, t_ref, a_bar, da_dt, has_lag)`` of :func:`paper_tracker_add`
    pack : (11, 20) its vectors ``w, mt, mx, ctt, ctx, rate, gain, lag``, the standard
        deviations (floored where unobserved), and what the report reads after the sample:
        the estimates (:func:`paper_vector_of`) and their total standard deviations
        (:func:`total_sd` with the tracker's lag), one per row
    M_lin, M_ang : its age-weighted Gram matrices after the sample

    The solver's full vectors after the sample are ``mu_prev``, ``theta_prev`` with the RLS's
    entries ``mu_active``, ``theta_active`` (the caller assembles them).
    """
    lin_x, lin_P, ang_x, ang_P, M, D_mu = rls_state
    A, b, phi, y, psi = rows
    (x1, P1, x2, P2, M2, D2, e1, e2, q1, q2, rhs, st) = modified_rls_update(
        lin_x, lin_P, ang_x, ang_P, M, D_mu, A, b, phi, y, psi, lam, mu_fixed, mu_active)
    p, r = x1.shape[0], x2.shape[0]
    k1, k2 = A.shape[0], phi.shape[0]
    # the augmented rows [A | b] and [phi | y | psi]
    R_lin = np.empty((k1, p + 1))
    for i in range(k1):
        for j in range(p):
            R_lin[i, j] = A[i, j]
        R_lin[i, p] = b[i]
    nD = psi.shape[1]
    R_ang = np.empty((k2, r + 1 + nD))
    for i in range(k2):
        for j in range(r):
            R_ang[i, j] = phi[i, j]
        R_ang[i, r] = y[i]
        for j in range(nD):
            R_ang[i, r + 1 + j] = psi[i, j]
    S_lin2, S_ang2 = gram_add(S_lin, R_lin, lam), gram_add(S_ang, R_ang, lam)
    info_lin2, info_ang2 = gram_add(info_lin, A, lam), gram_add(info_ang, phi, lam)
    residuals = np.array([_relative_norm(e1, b), _relative_norm(e2, rhs)])
    mu, theta = mu_prev.copy(), theta_prev.copy()
    for i in range(p):
        mu[mu_active[i]] = x1[i]
    for i in range(r):
        theta[theta_active[i]] = x2[i]
    dof_lin, dof_ang, vs_lin, vs_ang, decay_lin, decay_ang = (
        gram_scalars[0], gram_scalars[1], gram_scalars[2], gram_scalars[3], gram_scalars[4],
        gram_scalars[5])
    P0_mu, P0_theta, mu0, th0 = prior
    sd, unobserved, data_only, J, rcond, ok = paper_std_parts(
        mu, theta, x1, x2, D2, M2, P1, P2, S_lin2, S_ang2, dof_lin, dof_ang, vs_lin, 1.0,
        vs_ang, 1.0, P0_mu, P0_theta, decay_lin * (1.0 / P0_mu), decay_ang * (1.0 / P0_theta),
        mu0, th0, mu_active, theta_active, s2p, mu)
    if st == 0 and not ok:
        st = 3
    # the estimates after the sample (reported below; the floor of unobserved ones)
    z = np.empty(mu.shape[0] + theta.shape[0])
    z[:mu.shape[0]] = mu
    z[mu.shape[0]:] = theta
    vec = paper_vector_of(z, s2p)
    any_unobserved = False
    for i in range(unobserved.shape[0]):
        if unobserved[i]:
            any_unobserved = True
    if any_unobserved:                      # at least the error scale (a 100 % sd)
        floor = error_scale(vec, com_min)
        for i in range(sd.shape[0]):
            if unobserved[i]:                # np.maximum: NaN if either is NaN
                a, f = sd[i], floor[i]
                sd[i] = a if (a != a or a >= f) else f
    w, mt, mx, ctt, ctx = tracker_sums
    (s0, s1, t_ref, a_bar, da_dt, w, mt, mx, ctt, ctx, rate, gain, M_lin2, M_ang2, lag,
     has_lag) = paper_tracker_add(tracker[0], tracker[1], tracker[2], tracker[3], tracker[4],
                                  tracker[5], w, mt, mx, ctt, ctx, tracker[6], data_only, sd,
                                  tracker[7], M_lin, M_ang, S_lin, S_ang, J, S_lin2, S_ang2, mu,
                                  mu_active, theta_active)
    # what the report reads: the estimates (vec) and their total standard deviations
    # (DriftTracker.lag: the matrix lag, else rate * a_bar / max(1 - da_dt, 0.1))
    factor = a_bar / max(1.0 - da_dt, 0.1)
    lag_now = np.empty(sd.shape[0])
    for i in range(sd.shape[0]):
        lag_now[i] = lag[i] if has_lag else rate[i] * factor
    total = total_sd(sd, lag_now, gain, tracker[8])
    # the tracker's vectors as the rows of one array (one array handed back to Python, not 11)
    pack = np.empty((11, sd.shape[0]))
    for i in range(sd.shape[0]):
        pack[0, i], pack[1, i], pack[2, i], pack[3, i], pack[4, i] = (w[i], mt[i], mx[i],
                                                                      ctt[i], ctx[i])
        pack[5, i], pack[6, i], pack[7, i], pack[8, i] = rate[i], gain[i], lag[i], sd[i]
        pack[9, i], pack[10, i] = vec[i], total[i]
    return (st, (x1, P1, x2, P2, M2, D2), (S_lin2, S_ang2, info_lin2, info_ang2),
            (residuals[0], residuals[1], rcond[0], rcond[1]),
            (s0, s1, t_ref, a_bar, da_dt, has_lag), pack, M_lin2, M_ang2)


@njit(**_NB)
def age_step(M, G, lam, dt):
    """``lam (M + dt G)`` (a new array): the age-weighted Gram matrix after a step ``dt``, every
    old row ``dt`` older (:mod:`.tracking`, eq. 2)."""
    out = np.empty_like(M)
    n, m = M.shape
    for i in range(n):
        for j in range(m):
            out[i, j] = lam * (M[i, j] + dt * G[i, j])
    return out


@njit(**_NB)
def drift_regression(lam, s0, s1, t_ref, t_prev, a_bar_prev, w, mt, mx, ctt, ctx, t, x, sd,
                     rate_memory):
    """One sample of :meth:`.tracking.DriftTracker.add` without the matrix lag: the data's
    weight ``s0``, ``s1``, mean age ``a_bar`` and its rate ``da_dt``, and the weighted
    exponentially forgetting line through ``(t, x)`` (weights ``1 / sd^2``, forgetting
    ``lam_r = 1 - 1 / (rate_memory s0)``; ``w``, ``mt``, ``mx``, ``ctt``, ``ctx`` (p,)).

    Returns ``(s0, s1, t_ref, a_bar, da_dt, step, w, mt, mx, ctt, ctx, rate, gain)`` with
    ``step`` the clock step to age the Gram matrices by (0 at the first sample), ``rate`` the
    slope ``ctx / ctt`` (0 where ``ctt`` is not > 0) and ``gain`` the noise gain
    (:meth:`.tracking.DriftTracker.noise_gain`); new arrays.
    """
    first = s0 == 0.0
    if first:
        t_ref = t
    s0 = lam * s0 + 1.0                                      # sum w,  w = lam^(N-k)
    s1 = lam * s1 + (t - t_ref)                              # sum w (t_k - t_ref)
    a_bar = (t - t_ref) - s1 / s0                            # sum w (t - t_k) / sum w
    step = t - t_prev
    da_dt = (a_bar - a_bar_prev) / step if not first and step > 0.0 else 0.0
    lam_r = 1.0 - 1.0 / (rate_memory * s0)
    p = x.shape[0]
    w_n, mt_n, mx_n = np.empty(p), np.empty(p), np.empty(p)
    ctt_n, ctx_n, rate, gain = np.empty(p), np.empty(p), np.empty(p), np.empty(p)
    lag_factor = a_bar / max(1.0 - da_dt, 0.1)
    for i in range(p):
        v = 1.0 / max(sd[i] * sd[i], 1e-300)
        w_old = lam_r * w[i]
        wi = w_old + v
        d_t, d_x = t - mt[i], x[i] - mx[i]
        f = v * w_old / wi                                   # weighted Welford update
        ctt_n[i] = lam_r * ctt[i] + f * d_t * d_t
        ctx_n[i] = lam_r * ctx[i] + f * d_t * d_x
        w_n[i] = wi
        mt_n[i] = mt[i] + v * d_t / wi
        mx_n[i] = mx[i] + v * d_x / wi
        rate[i] = ctx_n[i] / ctt_n[i] if ctt_n[i] > 0.0 else 0.0
        spread = math.sqrt(ctt_n[i] / wi)
        gain[i] = max(lag_factor / spread, 1.0) if spread > 0.0 else 1.0
    step = step if not first and step > 0.0 else 0.0
    return s0, s1, t_ref, a_bar, da_dt, step, w_n, mt_n, mx_n, ctt_n, ctx_n, rate, gain


@njit(**_NB)
def total_sd(sd, lag, gain, noise_lag):
    """``sqrt(sd^2 + max(0, lag^2 - (noise_lag gain sd)^2))`` (p,) (:func:`.tracking.total_sd`)."""
    p = sd.shape[0]
    out = np.empty(p)
    for i in range(p):
        sd2 = sd[i] * sd[i]
        g = noise_lag * gain[i]
        excess = max(lag[i] * lag[i] - (g * g) * sd2, 0.0)
        out[i] = math.sqrt(sd2 + excess)
    return out


# -- residual autocorrelation (:class:`.uncertainty.Autocorrelation`) ------------------------------
@njit(**_NB)
def autocorrelation_add(c, lam, ring, sizes, head, count, e):
    """``(c, ring, sizes, inflation)`` after the residual vector ``e`` (k,) (new arrays; inputs
    kept): ``c[j] <- lam c[j] + e . e_(t-j)`` for the stored residuals of the same size,
    ``j = 0..L``, and ``e`` stored in the ring ``ring`` (L, width) at row ``head`` (``sizes``
    (L,) the stored lengths; ``count`` rows stored, the newest at ``head - 1``);
    ``inflation = max(1, 1 + 2 sum_j (1 - j/(L+1)) c_j / c_0)`` of the new sums (1 while
    ``c_0`` is not > 0; :meth:`.uncertainty.Autocorrelation.inflation`)."""
    L, k = c.shape[0] - 1, e.shape[0]
    c = c * lam if lam != 1.0 else c.copy()
    s = 0.0
    for a in range(k):
        s += e[a] * e[a]
    c[0] += s
    row = head
    for j in range(1, count + 1):                            # lag j: the row j back
        row = row - 1 if row > 0 else L - 1
        if sizes[row] == k:
            s = 0.0
            for a in range(k):
                s += e[a] * ring[row, a]
            c[j] += s
    ring = ring.copy()
    sizes = sizes.copy()
    for a in range(k):
        ring[head, a] = e[a]
    sizes[head] = k
    inflation = 1.0
    if c[0] > 0.0:
        s = 0.0
        for j in range(1, L + 1):
            s += (1.0 - j / (L + 1.0)) * c[j]
        f = 1.0 + 2.0 * (s / c[0])
        inflation = f if f > 1.0 else 1.0
    return c, ring, sizes, inflation


# -- physical consistency ----------------------------------------------------------------------
@njit(**_NB)
def second_moment(I6):
    """``Sigma_c = tr(I_c)/2 * 1 - I_c`` (3, 3) from ``(Ixx, Iyy, Izz, Ixy, Ixz, Iyz)``."""
    Ixx, Iyy, Izz, Ixy, Ixz, Iyz = I6[0], I6[1], I6[2], I6[3], I6[4], I6[5]
    h = 0.5 * (Ixx + Iyy + Izz)
    S = np.empty((3, 3))
    S[0, 0], S[1, 1], S[2, 2] = h - Ixx, h - Iyy, h - Izz
    S[0, 1], S[0, 2], S[1, 2] = -Ixy, -Ixz, -Iyz
    S[1, 0], S[2, 0], S[2, 1] = -Ixy, -Ixz, -Iyz
    return S


@njit(**_NB)
def is_physical(m, b, I6):
    """True iff finite, ``m > 0`` and ``Sigma_c`` positive definite (a Cholesky factorisation
    that meets no pivot <= 0; :func:`.physical.is_physical`)."""
    if not math.isfinite(m) or not m > 0.0:
        return False
    for i in range(3):
        if not math.isfinite(b[i]):
            return False
    for i in range(6):
        if not math.isfinite(I6[i]):
            return False
    S = second_moment(I6)
    L = np.zeros((3, 3))
    for j in range(3):
        s = S[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:
            return False
        L[j, j] = math.sqrt(s)
        for i in range(j + 1, 3):
            t = S[i, j]
            for k in range(j):
                t -= L[i, k] * L[j, k]
            L[i, j] = t / L[j, j]
    return True


@njit(**_NB)
def both_physical(ls, physical):
    """``physical`` (2,) bool: :func:`is_physical` of both bodies of the estimates ``ls`` (20,)."""
    for k in range(2):
        e = EST0[k]
        physical[k] = is_physical(ls[e], ls[e + 1:e + 4], ls[e + 4:e + 10])


@njit(**_NB)
def error_scale(vec, com_min):
    """Scale (20,) of the relative error of each entry of the estimates ``vec`` (20,)
    (:meth:`spacerobot.interface.ParameterLayout.error_scale`, whose NumPy operations it
    repeats per body, NaN included): ``|m|`` (1 if 0), ``max(|b_i|, com_min)``, ``|I_ii|`` (the
    body's largest ``|I_ii|`` if 0) and for the products the largest ``|I_ii|`` (1 if that
    is not > 0). Compiled because :meth:`.identifier.Identifier.report` needs it at every
    sample."""
    scale = np.empty(20)
    for k in range(2):
        e = EST0[k]
        for i in range(10):
            scale[e + i] = abs(vec[e + i])
        imax = scale[e + 4]                                  # NaN propagates, as np.max
        for i in range(5, 7):
            v = scale[e + i]
            if v > imax or v != v:
                imax = v
        if not imax > 0.0:
            imax = 1.0
        if scale[e] == 0.0:
            scale[e] = 1.0
        for i in range(1, 4):                                # np.maximum: NaN propagates
            v = scale[e + i]
            if not (v > com_min or v != v):
                scale[e + i] = com_min
        for i in range(4, 7):
            if scale[e + i] == 0.0:
                scale[e + i] = imax
        for i in range(7, 10):
            scale[e + i] = imax
    return scale


@njit(**_NB)
def identified_bodies(sd, out, ls, scale, sd_rel, identified, ok_body):
    """``ok_body`` (2,) bool: every identified entry of the body (``identified`` (20,) bool)
    has ``sd <= tol`` and ``|out - ls| <= tol``, ``tol = sd_rel * scale`` (the reported value
    is the estimate's; :meth:`.identifier.Identifier.report`)."""
    for k in range(2):
        ok = True
        for i in range(EST0[k], EST0[k] + 10):
            tol = sd_rel * scale[i]
            if identified[i] and not (sd[i] <= tol and abs(out[i] - ls[i]) <= tol):
                ok = False
        ok_body[k] = ok


@njit(**_NB)
def report_flags(ls, sd, com_min, sd_rel, identified, flags):
    """The flags of :meth:`.identifier.Identifier.report` in one call where both bodies of
    the estimates ``ls`` (20,) are physical: ``flags`` (4,) bool = :func:`both_physical`, then
    :func:`identified_bodies` of ``ls`` reported as it is (``out = ls``, the scale
    :func:`error_scale` of it). Returns False, with only ``flags[:2]`` written, where a body
    needs its projection (the caller then goes on with the projected estimates)."""
    physical = flags[:2]
    both_physical(ls, physical)
    if not (physical[0] and physical[1]):
        return False
    identified_bodies(sd, ls, ls, error_scale(ls, com_min), sd_rel, identified, flags[2:])
    return True


@njit(**_NB)
def project_body(m, b, I6, m_min, rel_sigma_min):
    """``(m, I6, projected, ok)``: :func:`.physical.project_body` of the body ``(m, b, I6)``
    with the mass floor ``m_min`` and the relative eigenvalue floor ``rel_sigma_min``: the
    mass clipped at ``m_min``, the eigenvalues of ``Sigma_c`` clipped at ``rel_sigma_min``
    times the largest ``|eigenvalue|`` (:func:`eigh`), ``I_c = tr(Sigma_c) 1 - Sigma_c`` of
    the symmetrised result. ``projected`` False: the body is physical (``m``, ``I6`` returned
    as given, a copy); ``ok`` False: the eigen-decomposition did not converge (non-finite
    input; the caller decides)."""
    if is_physical(m, b, I6):
        return m, I6.copy(), False, True
    m_out = m if m >= m_min else m_min
    lam, V, ok = eigh(second_moment(I6))
    big = 0.0
    for k in range(3):
        big = max(big, abs(lam[k]))
    s_min = rel_sigma_min * max(big, 2.2250738585072014e-308)      # finfo(float).tiny
    S = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += V[i, k] * max(lam[k], s_min) * V[j, k]
            S[i, j] = acc
    for i in range(3):                                       # 0.5 (S + S^T)
        for j in range(i + 1, 3):
            S[i, j] = S[j, i] = 0.5 * (S[i, j] + S[j, i])
    tr = S[0, 0] + S[1, 1] + S[2, 2]
    out = np.array([tr - S[0, 0], tr - S[1, 1], tr - S[2, 2], -S[0, 1], -S[0, 2], -S[1, 2]])
    return m_out, out, True, ok


@njit(**_NB)
def project_planar_body(m, b, I6, m_min, rel_sigma_min):
    """``(m, I6, projected, ok)``: :func:`.physical.project_planar_body`: ``Izz`` (the trace of
    the in-plane block of ``Sigma_c``) kept, that block's eigenvalues clipped at ``s_min`` with
    their sum kept, the out-of-plane couplings dropped, ``Sigma_zz`` clipped; ``s_min`` as
    :func:`project_body`'s. Where ``Izz <= 2 s_min`` no real body keeps it:
    :func:`project_body`. ``ok`` as there."""
    if is_physical(m, b, I6):
        return m, I6.copy(), False, True
    S = second_moment(I6)
    lam, V, ok = eigh(S[:2, :2].copy())
    lam3, _, ok3 = eigh(S)
    izz = I6[2]
    big = 0.0
    for k in range(3):
        big = max(big, abs(lam3[k]))
    s_min = rel_sigma_min * max(big, 2.2250738585072014e-308)
    if not izz > 2.0 * s_min:
        return project_body(m, b, I6, m_min, rel_sigma_min)
    if lam[0] < s_min:                                       # clip with the sum kept
        lam[0], lam[1] = s_min, izz - s_min
    P = np.zeros((3, 3))
    for i in range(2):
        for j in range(2):
            P[i, j] = V[i, 0] * lam[0] * V[j, 0] + V[i, 1] * lam[1] * V[j, 1]
    P[2, 2] = max(S[2, 2], s_min)
    P[0, 1] = P[1, 0] = 0.5 * (P[0, 1] + P[1, 0])
    tr = P[0, 0] + P[1, 1] + P[2, 2]
    out = np.array([tr - P[0, 0], tr - P[1, 1], izz, -P[0, 1], -P[0, 2], -P[1, 2]])
    return (m if m >= m_min else m_min), out, True, ok and ok3


# -- the oracle: NumPy / LAPACK in place of the hand-written loops above (same contracts) -----------
def _matmul(A, B):  # noqa: F811
    """``A B`` (NumPy)."""
    return np.asarray(A) @ np.asarray(B)


def matvec(A, x):  # noqa: F811
    """``A x`` (NumPy)."""
    return np.asarray(A) @ np.asarray(x)


def eigh(A):  # noqa: F811
    """``(lam, V, ok)`` by LAPACK (``np.linalg.eigh``: ascending, orthonormal); ok False for a
    non-finite ``A`` (NaN outputs)."""
    p = A.shape[0]
    if not np.all(np.isfinite(A)):
        return np.full(p, np.nan), np.full((p, p), np.nan), False
    lam, V = np.linalg.eigh(A)
    return lam, V, True


def lu_solve(A, B):  # noqa: F811
    """``A^-1 B`` by LAPACK's ``gesv`` (``np.linalg.solve``); all NaN where it is singular."""
    try:
        X = np.linalg.solve(A, B)
    except np.linalg.LinAlgError:
        return np.full(np.shape(B), np.nan)
    return X


def age_step(M, G, lam, dt):  # noqa: F811
    """``lam (M + dt G)`` (NumPy)."""
    return lam * (M + dt * G)
