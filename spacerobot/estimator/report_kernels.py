"""Compiled (Numba) kernels of what the estimator reports at every sample: the prior's pull and
the covariance of the paper solver's parameters, the Jacobian of the map to the estimates, the
physical-consistency test of an estimated body.

They implement :func:`.uncertainty.observed_solve`, the paper solver's ``covariance``,
``prior_pull``, ``jacobian``, ``vector_of`` and ``uncertainty`` (:class:`.solvers.PaperSolver`)
and :func:`.physical.is_physical`: in NumPy some hundred and fifty small-array operations per
sample, whose call overhead was most of the ~0.6 ms of ``Identifier.report()``. The NumPy
formulation is the test oracle ``tests/oracles/report.py``.

No ``np.linalg`` and no ``np.dot`` here: Numba implements both with SciPy's LAPACK and BLAS,
and the FMUs need only NumPy and Numba. The eigen-decompositions of the scale-free information
(:func:`scaled_information`) are NumPy's ``np.linalg.eigh``, called by the solver between two
kernel calls (the same LAPACK routine as before, so the same eigenvectors); the products are
loops, equal to NumPy's BLAS products to round-off.

Positions in the vectors are those of :class:`spacerobot.interface.ParameterLayout` (checked
against it by the tests): estimates per body ``m, b (3), I (6)`` at 0 and 10; the paper's
``mu = [m1, m1 b1, mn, mn bn]`` (8,), ``theta = [I1#, In#]`` (12,), ``z = [mu, theta]`` (20,);
``D(mu)`` (20,) as :func:`.kernels.D_of_mu`.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .kernels import D_of_mu

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
def _matvec(A, x):
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
    ``theta`` (:func:`scaled_information`, then ``np.linalg.eigh``); the other arguments as
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
    Sz = _matvec(S, z)
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
                      theta_active, sharp_to_project, eig_lin, eig_ang):
    """``(sd (20,), unobserved (20,) bool, data-only answer (20,), J (20, 20))`` of the paper
    solver's estimates, the whole of :meth:`.solvers.ParameterSolver.uncertainty_parts` for
    :class:`.solvers.PaperSolver` in one call:
    ``sd^2 = diag(J C J^T) + (v(z) - v(z - delta))^2`` (``J delta`` where ``z - delta`` has no
    positive mass), with :func:`paper_jacobian`, :func:`paper_covariance`,
    :func:`paper_prior_pull` and :func:`paper_vector_of`."""
    z = np.concatenate((mu_full, theta_full))
    J = paper_jacobian(z, sharp_to_project)
    delta, unobserved_z = paper_prior_pull(mu_full, rls_mu, rls_theta, D_mu, M, S_ang, w_mu,
                                           w_theta, mu0, th0, mu_active, theta_active,
                                           eig_lin, eig_ang)
    x = paper_vector_of(z, sharp_to_project)
    pull = x - paper_vector_of(z - delta, sharp_to_project)
    if not np.all(np.isfinite(pull)):                        # the data-only mass <= 0
        pull = _matvec(J, delta)
    C = paper_covariance(P_lin, P_ang, M, mu_full, s2_lin, s2_ang, P0_mu, P0_theta, mu_active,
                         theta_active)
    var, unobserved = scatter_and_pull(J, C, pull, unobserved_z)
    sd = np.empty(var.shape[0])
    for i in range(var.shape[0]):
        sd[i] = math.sqrt(var[i]) if var[i] > 0.0 else 0.0
    return sd, unobserved, x - pull, J


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
