"""Test oracle: what the estimator reports (standard deviations with the prior's pull, the
physical projection), in NumPy, as the library computed it before it was compiled.

The former Python library computed these in :mod:`oracles.estimator.report_kernels` (then
Numba; the native core now); this module is the reference they were tested against (a test oracle, not part of the library: it does not ship
in the FMUs). Formulas: :mod:`oracles.estimator.uncertainty` (the prior's pull),
:class:`oracles.estimator.solvers.PaperSolver` (covariance, pull, Jacobian of the paper
solver) and :mod:`spacerobot.estimator.physical` (the projection onto real bodies).
"""
from __future__ import annotations

import numpy as np

from .estimator import parameters as par

REL_EIG_MIN = 1e-12
REL_SIGMA_MIN = 1e-6
REL_MASS_MIN = 1e-6


# -- the prior's pull ------------------------------------------------------------------------------
def observed_solve(G, r):
    """``(x, unobserved)``: ``G^-1 r`` in the observed directions of the information ``G``."""
    p = len(r)
    dg = np.diag(G).copy()
    unobserved = ~(dg > 0.0)
    d = np.sqrt(np.where(unobserved, 1.0, dg))
    Gs = G / np.outer(d, d)                                  # scale-free information
    Gs[unobserved, :] = 0.0
    Gs[:, unobserved] = 0.0
    lam, V = np.linalg.eigh(Gs)
    big = lam[-1] if p and lam[-1] > 0.0 else 0.0
    keep = lam > REL_EIG_MIN * big
    Vk = V[:, keep]
    x = (Vk / lam[keep]) @ (Vk.T @ (np.asarray(r, float) / d)) / d
    if not np.all(keep):
        unobserved = unobserved | (np.abs(V[:, ~keep]).max(axis=1) > 1e-6)
    return x, unobserved


def prior_pull(W0, G, x, x0):
    """``delta = -G^-1 W0 (x - x0)`` in the observed directions."""
    return observed_solve(G, -(W0 @ (np.asarray(x, float) - np.asarray(x0, float))))


def D_jacobian(mu):
    """``dD/dmu`` (20, 8)."""
    L = par.LAYOUT
    Jac = np.zeros((len(L.names), L.n_mu))
    for b in L.bodies:
        m, c = mu[b.mu_m], mu[b.mu_first]
        Jac[b.m, b.mu_m] = 1.0
        for i in range(3):
            Jac[b.first.start + i, b.mu_first.start + i] = 1.0
        for p, (i, j) in enumerate(par.SHARP_PAIRS):
            row = b.inertia.start + p
            Jac[row, b.mu_m] = -c[i] * c[j] / m**2
            Jac[row, b.mu_first.start + i] += c[j] / m
            Jac[row, b.mu_first.start + j] += c[i] / m
    return Jac


# -- the paper solver -------------------------------------------------------------------------------
def paper_vector_of(solver, z):
    out = np.empty(20)
    for b in solver.layout.bodies:
        zt = slice(solver.layout.n_mu + b.theta.start, solver.layout.n_mu + b.theta.stop)
        m = z[b.mu_m]
        out[b.m] = m
        out[b.first] = z[b.mu_first] / m
        out[b.inertia] = z[zt][par.SHARP_TO_PROJECT]
    return out


def paper_jacobian(solver, z):
    L = solver.layout
    J = np.zeros((20, 20))
    for b in L.bodies:
        m, c = z[b.mu_m], z[b.mu_first]
        J[b.m, b.mu_m] = 1.0
        for i in range(3):
            J[b.first.start + i, b.mu_first.start + i] = 1.0 / m
            J[b.first.start + i, b.mu_m] = -c[i] / m**2
        for jp, p in enumerate(par.SHARP_TO_PROJECT):
            J[b.inertia.start + jp, L.n_mu + b.theta.start + p] = 1.0
    return J


def paper_covariance(solver):
    L, g0, rls = solver.layout, solver.guess, solver.rls
    n_mu = L.n_mu
    s2_lin, s2_ang = solver._residual_variances()
    Cmu_a = rls.lin.P * s2_lin
    Tm_a = rls.M.dot(D_jacobian(solver.mu))
    Cmu = g0.P0_mu * np.eye(n_mu)
    Cmu[np.ix_(L.mu_active, L.mu_active)] = Cmu_a
    Tm = np.zeros((L.n_theta, n_mu))
    Tm[L.theta_active] = Tm_a
    Cth = g0.P0_theta * np.eye(L.n_theta)
    Cth[np.ix_(L.theta_active, L.theta_active)] = rls.ang.P * s2_ang
    cov = np.empty((20, 20))
    cov[:n_mu, :n_mu] = Cmu
    TC = Tm.dot(Cmu)
    cov[n_mu:, :n_mu] = TC
    cov[:n_mu, n_mu:] = TC.T
    cov[n_mu:, n_mu:] = Cth + TC.dot(Tm.T)
    return cov


def paper_prior_pull(solver):
    L, rls, gl, ga, g0 = solver.layout, solver.rls, solver.gram_lin, solver.gram_ang, solver.guess
    p, r = len(rls.mu), len(rls.theta)
    d_mu, u_mu = prior_pull(gl.decay * (np.eye(p) / g0.P0_mu), gl.S[:p, :p], rls.mu,
                            par.paper_vectors(g0)[0][L.mu_active])
    mu_ls = solver.mu.copy()
    mu_ls[L.mu_active] -= d_mu
    th0 = par.paper_vectors(g0)[1][L.theta_active]
    rhs = (-(ga.decay * (np.eye(r) / g0.P0_theta)) @ (rls.theta - th0)
           + ga.S[:r, r + 1:] @ (rls.D_mu - par.D_of_mu(mu_ls)))
    d_th, u_th = observed_solve(ga.S[:r, :r], rhs)
    Tm = rls.M.dot(D_jacobian(solver.mu))[:, L.mu_active]
    u_th = u_th | (Tm[:, u_mu] != 0.0).any(axis=1)
    delta, unobserved = np.zeros(20), np.zeros(20, bool)
    delta[L.mu_active], unobserved[L.mu_active] = d_mu, u_mu
    delta[L.n_mu + L.theta_active], unobserved[L.n_mu + L.theta_active] = d_th, u_th
    return delta, unobserved


def paper_std(solver):
    """``sd (20,)`` of the paper solver's estimates: ``sqrt(diag(J C J^T) + pull^2)``, an
    unobserved estimate at least its error scale."""
    z = np.concatenate([solver.mu, solver.theta])
    J = paper_jacobian(solver, z)
    delta, unobserved_z = paper_prior_pull(solver)
    with np.errstate(all="ignore"):
        pull = paper_vector_of(solver, z) - paper_vector_of(solver, z - delta)
    if not np.all(np.isfinite(pull)):
        pull = J @ delta
    var = np.einsum("ij,jk,ik->i", J, paper_covariance(solver), J) + pull ** 2
    unobserved = (J[:, unobserved_z] != 0.0).any(axis=1)
    sd = np.sqrt(np.clip(var, 0.0, None))
    if unobserved.any():
        floor = solver.layout.error_scale(paper_vector_of(solver, z))
        sd[unobserved] = np.maximum(sd[unobserved], floor[unobserved])
    return sd


# -- physical consistency ---------------------------------------------------------------------------
def second_moment(I6):
    Ixx, Iyy, Izz, Ixy, Ixz, Iyz = I6
    I = np.array([[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], [Ixz, Iyz, Izz]], dtype=float)
    return 0.5 * np.trace(I) * np.eye(3) - I


def inertia_from_second_moment(S):
    M = np.trace(S) * np.eye(3) - S
    return np.array([M[0, 0], M[1, 1], M[2, 2], M[0, 1], M[0, 2], M[1, 2]])


def is_physical(m, b, I6):
    vals = np.concatenate([[m], np.ravel(b), np.ravel(I6)]).astype(float)
    if not np.all(np.isfinite(vals)) or not m > 0.0:
        return False
    try:
        np.linalg.cholesky(second_moment(I6))
    except np.linalg.LinAlgError:
        return False
    return True


def project_body(m, b, I6, m_scale=1.0):
    b, I6 = np.array(b, float), np.array(I6, float)
    if is_physical(m, b, I6):
        return float(m), b, I6, False
    m_min = REL_MASS_MIN * abs(m_scale)
    lam, V = np.linalg.eigh(second_moment(I6))
    s_min = REL_SIGMA_MIN * max(float(np.max(np.abs(lam))), np.finfo(float).tiny)
    S = (V * np.maximum(lam, s_min)) @ V.T
    return (float(m) if m >= m_min else m_min), b, inertia_from_second_moment(0.5 * (S + S.T)), True


def project_planar_body(m, b, I6, m_scale=1.0):
    b, I6 = np.array(b, float), np.array(I6, float)
    if is_physical(m, b, I6):
        return float(m), b, I6, False
    S = second_moment(I6)
    lam, V = np.linalg.eigh(S[:2, :2])
    izz = float(I6[2])
    s_min = REL_SIGMA_MIN * max(float(np.max(np.abs(np.linalg.eigvalsh(S)))),
                                np.finfo(float).tiny)
    if not izz > 2.0 * s_min:
        return project_body(m, b, I6, m_scale)
    if lam[0] < s_min:
        lam = np.array([s_min, izz - s_min])
    P = np.zeros((3, 3))
    P[:2, :2] = (V * lam) @ V.T
    P[2, 2] = max(float(S[2, 2]), s_min)
    m_min = REL_MASS_MIN * abs(m_scale)
    I_out = inertia_from_second_moment(0.5 * (P + P.T))
    I_out[2] = izz
    return (float(m) if m >= m_min else m_min), b, I_out, True


# -- the joint solver's map and Jacobian ------------------------------------------------------------
def joint_vector_of(z):
    """The 20 estimates from the standard parameters ``z`` (per body ``[m, m b, I_O#]``)."""
    out = np.empty(20)
    for b in par.LAYOUT.bodies:
        m, com, I_c = par.physical_from_standard(z[b.vec])
        out[b.m], out[b.first] = m, com
        out[b.inertia] = par.sharp_vector(I_c)[par.SHARP_TO_PROJECT]
    return out


def joint_jacobian(z):
    """``d joint_vector_of / d z`` (20, 20), entry by entry."""
    J = np.zeros((20, 20))
    for b in par.LAYOUT.bodies:
        m, c = z[b.m], z[b.first]
        J[b.m, b.m] = 1.0
        for i in range(3):
            J[b.first.start + i, b.first.start + i] = 1.0 / m
            J[b.first.start + i, b.m] = -c[i] / m**2
        for jp, p in enumerate(par.SHARP_TO_PROJECT):
            row = b.inertia.start + jp
            J[row, b.inertia.start + p] = 1.0
            i, j = par.SHARP_PAIRS[p]
            J[row, b.m] = ((c @ c if i == j else 0.0) - c[i] * c[j]) / m**2
            for k in range(3):
                dS = (2.0 * c[k] if i == j else 0.0) - (c[j] if k == i else 0.0) \
                    - (c[i] if k == j else 0.0)
                J[row, b.first.start + k] = -dS / m
    return J


# -- the tracker's lag (oracles.estimator.tracking, eq. 2) -------------------------------------
def block_lag(G, M, rate, growth):
    """``(A r, r)``, ``A = G^-1 M``, ``r = (1 - growth A)^-1 rate`` (LAPACK solves)."""
    A = np.linalg.solve(G, M)
    r = np.linalg.solve(np.eye(len(rate)) - growth * A, rate)
    return A @ r, r


def paper_drift_lag(solver, rate_z, growth, ages):
    """The paper solver's lag (20,): both blocks, and theta's response to mu's lag and rate."""
    L = solver.layout
    p, r = len(L.mu_active), len(L.theta_active)
    (Sl, Sa), (Ml, Ma) = solver.information(), ages
    lag = np.zeros(L.n_mu + L.n_theta)
    th = L.n_mu + L.theta_active
    lag_mu, r_mu = block_lag(Sl[:p, :p], Ml[:p, :p], rate_z[L.mu_active], growth)
    lag_th, _ = block_lag(Sa[:r, :r], Ma[:r, :r], rate_z[th], growth)
    dD = D_jacobian(solver.mu)[:, L.mu_active]
    lag_th = lag_th + np.linalg.solve(
        Sa[:r, :r], Sa[:r, r + 1:] @ (dD @ lag_mu) - Ma[:r, r + 1:] @ (dD @ r_mu))
    lag[L.mu_active], lag[th] = lag_mu, lag_th
    return lag
