/* The paper's solver (solver = 1): the modified RLS of eqs. 34-38 over mu = [m1, m1 b1, mn,
 * mn bn] (8) and theta = [I1#, In#] (12, eq. 21): mu by RLS on the linear rows A mu = b
 * (eq. 11 / 28), theta by RLS on phi theta = y + psi D(mu) (eq. 16 / 31) at the new mu, and
 * M = d theta / d D re-referencing theta as mu moves (eq. 36). With the new state: the
 * accelerations' noise compensated (est_eiv.h), the standard deviations (the data's scatter
 * from the Gram matrices, the prior's pull through the map to the estimates, the delta
 * method's Jacobian, the unobserved floor), the excitation diagnostics, the drift tracker's
 * lag (est_tracker.h) and the thrust's consider term (est_consider.h).
 *
 * Notation: z = [mu (8), theta (12)], D(mu) (20, eq. 23); p, r the identified entries of mu
 * and theta; the estimates (20) per body m, b (3), I (6).
 *
 * Once both information blocks are well conditioned (excitation diagnostic > EST_CHOL_RCOND,
 * resp. EST_LAG_RCOND for the lag) the solves take cheaper routes (the extremes of the
 * spectrum instead of the eigen-decomposition, solves by the Cholesky factor's inverse, the
 * lag by two one-column solves): the same numbers to round-off (measured: standard deviations
 * within 5.4e-10 relative over recorded runs, planar and spatial, momentum and force, with
 * the noise options; estimates unchanged).
 */
#include "est_paper.h"

#include <math.h>
#include <string.h>

#include "equations.h"
#include "est_consider.h"
#include "est_corr.h"
#include "est_eiv.h"
#include "est_rls.h"
#include "est_tracker.h"
#include "est_uncertainty.h"
#include "linalg.h"
#include "physical.h"
#include "standard_params.h"

/* -- the maps between z and the estimates ------------------------------------------------ */

/* per body: position of m in the estimates and in mu, of theta in z */
static const int EST0[2] = {0, 10}, MU0[2] = {0, 4}, ZTH0[2] = {8, 14};

/* dD/dmu (20 x 8): per body with c = m b, D = [m, c, c_i c_j / m],
 * d(c_i c_j / m) = -c_i c_j / m^2 dm + c_j / m dc_i + c_i / m dc_j */
static void D_jacobian(const double *mu, double *Jac)
{
    memset(Jac, 0, sizeof(double) * EST_ND * EST_NMU);
    for (int k = 0; k < 2; k++) {
        int e = EST0[k], u = MU0[k];
        double m = mu[u], m2 = m * m;
        Jac[e * EST_NMU + u] = 1.0;
        for (int i = 0; i < 3; i++)
            Jac[(e + 1 + i) * EST_NMU + u + 1 + i] = 1.0;
        for (int q = 0; q < 6; q++) {
            int i = SR_SHARP_I[q], j = SR_SHARP_J[q], row = e + 4 + q;
            double ci = mu[u + 1 + i], cj = mu[u + 1 + j];
            Jac[row * EST_NMU + u] = -ci * cj / m2;
            Jac[row * EST_NMU + u + 1 + i] += cj / m;
            Jac[row * EST_NMU + u + 1 + j] += ci / m;
        }
    }
}

/* T = M dD/dmu (r x 8): d theta / d mu, M (r x 20), Dj (20 x 8) from D_jacobian; the sums of
 * sr_matmul in the same order, over the entries of Dj that are not structurally 0 (the others
 * would add exact zeros): the rows l of dD/dmu that can be nonzero, per column of the base's
 * mu (the target's: rows + 10, columns + 4), are m -> {0, 4, 5, 6, 7, 8, 9} (D's m and its six
 * c_i c_j / m), c_1 -> {1, 4, 5, 6}, c_2 -> {2, 5, 7, 8}, c_3 -> {3, 6, 8, 9} (D's c_i and the
 * c_i c_j / m that contain it; D_jacobian) */
static void theta_of_mu(const double *M, const double *Dj, int r, double *T)
{
    /* the lists above written out (each sum from 0.0, in its list's order) */
#define EST_TM(l, j) (Mi[(l) + e] * Dj[((l) + e) * EST_NMU + (j) + u])
    for (int i = 0; i < r; i++) {
        const double *Mi = M + i * EST_ND;
        double *Ti = T + i * EST_NMU;
        for (int e = 0, u = 0; e < EST_ND; e += 10, u += 4) {
            double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
            s0 += EST_TM(0, 0);
            s1 += EST_TM(1, 1);
            s2 += EST_TM(2, 2);
            s3 += EST_TM(3, 3);
            s0 += EST_TM(4, 0);
            s1 += EST_TM(4, 1);
            s2 += EST_TM(5, 2);
            s3 += EST_TM(6, 3);
            s0 += EST_TM(5, 0);
            s1 += EST_TM(5, 1);
            s2 += EST_TM(7, 2);
            s3 += EST_TM(8, 3);
            s0 += EST_TM(6, 0);
            s1 += EST_TM(6, 1);
            s2 += EST_TM(8, 2);
            s3 += EST_TM(9, 3);
            s0 += EST_TM(7, 0);
            s0 += EST_TM(8, 0);
            s0 += EST_TM(9, 0);
            Ti[u] = s0;
            Ti[u + 1] = s1;
            Ti[u + 2] = s2;
            Ti[u + 3] = s3;
        }
    }
#undef EST_TM
}

/* the 20 estimates from z: m, b = c / m, I = I#[sharp_to_project] */
static void vector_of(const int *s2p, const double *z, double *out)
{
    for (int k = 0; k < 2; k++) {
        int e = EST0[k], u = MU0[k], t = ZTH0[k];
        double m = z[u];
        out[e] = m;
        for (int i = 0; i < 3; i++)
            out[e + 1 + i] = z[u + 1 + i] / m;
        for (int i = 0; i < 6; i++)
            out[e + 4 + i] = z[t + s2p[i]];
    }
}

/* d vector_of / d z (20 x 20): db/dc = 1 / m, db/dm = -c / m^2, the CoM inertia a (permuted)
 * parameter */
static void jacobian(const int *s2p, const double *z, double *J)
{
    memset(J, 0, sizeof(double) * EST_NZ * EST_NZ);
    for (int k = 0; k < 2; k++) {
        int e = EST0[k], u = MU0[k], t = ZTH0[k];
        double m = z[u];
        J[e * EST_NZ + u] = 1.0;
        for (int i = 0; i < 3; i++) {
            J[(e + 1 + i) * EST_NZ + u + 1 + i] = 1.0 / m;
            J[(e + 1 + i) * EST_NZ + u] = -z[u + 1 + i] / (m * m);
        }
        for (int i = 0; i < 6; i++)
            J[(e + 4 + i) * EST_NZ + t + s2p[i]] = 1.0;
    }
}

/* the full mu (8) and theta (12) of the state c: the guesses with the identified entries */
static void full_vectors(const sr_estimator_model *m, const est_core *c, double *mu_full,
                         double *theta_full)
{
    memcpy(mu_full, m->mu0_full, sizeof(double) * EST_NMU);
    memcpy(theta_full, m->th0_full, sizeof(double) * EST_NTH);
    for (int i = 0; i < m->p; i++)
        mu_full[m->mu_active[i]] = c->mu[i];
    for (int i = 0; i < m->r; i++)
        theta_full[m->theta_active[i]] = c->theta[i];
}

/* -- the standard deviations ------------------------------------------------------------- */

/* The prior's pull delta (20) on z and the unobserved entries of z (20):
 * mu: delta = -G^-1 W0 (mu - mu0); theta is affine in D, so
 * theta - theta_LS = G^-1 [-W0 (theta - theta0) + S_phi,psi (D(mu) - D(mu_LS))]. */
static void prior_pull(const sr_estimator_model *m, const est_core *c, const double *mu_full,
                       const double *Tm, double w_mu, double w_theta, const est_eigs *el,
                       const est_eigs *ea, double *delta, int *unobserved)
{
    int p = m->p, r = m->r, na = m->na;
    double rhs[EST_NTH], d_mu[EST_NMU], d_th[EST_NTH];
    int u_mu[EST_NMU], u_th[EST_NTH];
    for (int i = 0; i < p; i++)                              /* -W0 (x - x0) */
        rhs[i] = -(w_mu * (c->mu[i] - m->mu0[i]));
    est_eigs_solve(el, p, rhs, d_mu, u_mu);
    double mu_ls[EST_NMU], D_ls[EST_ND], dD[EST_ND];
    memcpy(mu_ls, mu_full, sizeof mu_ls);
    for (int i = 0; i < p; i++)
        mu_ls[m->mu_active[i]] -= d_mu[i];
    sr_D_of_mu(mu_ls, D_ls);
    for (int j = 0; j < EST_ND; j++)
        dD[j] = c->D[j] - D_ls[j];
    for (int i = 0; i < r; i++) {                            /* -W0 (th - th0) + S_phi,psi dD */
        double s = 0.0;
        for (int j = 0; j < EST_ND; j++)
            s += c->S_ang[i * na + r + 1 + j] * dD[j];
        rhs[i] = -(w_theta * (c->theta[i] - m->th0[i])) + s;
    }
    est_eigs_solve(ea, r, rhs, d_th, u_th);
    for (int i = 0; i < r; i++)                   /* theta touches an unobserved mu through T */
        for (int j = 0; j < p; j++)
            if (u_mu[j] && Tm[i * EST_NMU + m->mu_active[j]] != 0.0)
                u_th[i] = 1;
    memset(delta, 0, sizeof(double) * EST_NZ);
    memset(unobserved, 0, sizeof(int) * EST_NZ);
    for (int i = 0; i < p; i++) {
        delta[m->mu_active[i]] = d_mu[i];
        unobserved[m->mu_active[i]] = u_mu[i];
    }
    for (int i = 0; i < r; i++) {
        delta[EST_NMU + m->theta_active[i]] = d_th[i];
        unobserved[EST_NMU + m->theta_active[i]] = u_th[i];
    }
}

/* Covariance (20 x 20) of z: Cov(mu) = s2_lin P_mu;
 * Cov(theta) = s2_ang P_th + T Cov(mu) T^T, Cov(theta, mu) = T Cov(mu), T = M dD/dmu; the
 * parameters not identified keep their prior covariance. Of the theta block only the diagonal
 * is written (the rest is left as it is): the estimates' Jacobian (jacobian) maps each inertia
 * estimate to one entry of theta, so est_scatter_sd reads no other entry of it. */
static void covariance(const sr_estimator_model *m, const double *P_mu, const double *P_th,
                       const double *Tm_a, double s2_lin, double s2_ang, double *cov)
{
    int p = m->p, r = m->r;
    double Cmu[EST_NMU * EST_NMU] = {0}, Cth_diag[EST_NTH];
    double Tm[EST_NTH * EST_NMU] = {0}, TC[EST_NTH * EST_NMU];
    for (int i = 0; i < EST_NMU; i++)
        Cmu[i * EST_NMU + i] = m->opt.P0_mu;
    for (int i = 0; i < p; i++)
        for (int j = 0; j < p; j++)
            Cmu[m->mu_active[i] * EST_NMU + m->mu_active[j]] = P_mu[i * p + j] * s2_lin;
    for (int i = 0; i < r; i++)
        memcpy(Tm + m->theta_active[i] * EST_NMU, Tm_a + i * EST_NMU, sizeof(double) * EST_NMU);
    for (int i = 0; i < EST_NTH; i++)
        Cth_diag[i] = m->opt.P0_theta;
    for (int i = 0; i < r; i++)
        Cth_diag[m->theta_active[i]] = P_th[i * r + i] * s2_ang;
    for (int i = 0; i < EST_NTH; i++) {      /* TC = Tm Cmu: sr_matmul's sums, fixed sizes */
        double acc[EST_NMU] = {0.0};
        for (int l = 0; l < EST_NMU; l++) {
            const double a = Tm[i * EST_NMU + l];
            for (int j = 0; j < EST_NMU; j++)
                acc[j] += a * Cmu[l * EST_NMU + j];
        }
        memcpy(TC + i * EST_NMU, acc, sizeof acc);
    }
    for (int i = 0; i < EST_NMU; i++)
        for (int j = 0; j < EST_NMU; j++)
            cov[i * EST_NZ + j] = Cmu[i * EST_NMU + j];
    for (int i = 0; i < EST_NTH; i++) {
        for (int j = 0; j < EST_NMU; j++) {
            cov[(EST_NMU + i) * EST_NZ + j] = TC[i * EST_NMU + j];
            cov[j * EST_NZ + EST_NMU + i] = TC[i * EST_NMU + j];
        }
        const double *ti = TC + i * EST_NMU, *tj = Tm + i * EST_NMU;
        double s = 0.0;                      /* (T C T^T)[i][i]: the sum over l = 0..7 */
        s += ti[0] * tj[0];
        s += ti[1] * tj[1];
        s += ti[2] * tj[2];
        s += ti[3] * tj[3];
        s += ti[4] * tj[4];
        s += ti[5] * tj[5];
        s += ti[6] * tj[6];
        s += ti[7] * tj[7];
        cov[(EST_NMU + i) * EST_NZ + EST_NMU + i] = Cth_diag[i] + s;
    }
}

/* est_paper_std_parts (est_paper.h) with the block's decompositions into eig_out (2: the
 * tracker's lag and the consider term solve with them) and expect_rcond (2) the excitation
 * diagnostics of the state before, which say which work is likely needed */
static EST_NOINLINE int paper_std_parts(const sr_estimator_model *m, const est_core *c,
                                        double infl_lin, double infl_ang, double *sd,
                                        double *data_only, double *J, double *vec,
                                        double *rcond, est_eigs *eig_out,
                                        const double *expect_rcond)
{
    int p = m->p, r = m->r, nl = m->nl, na = m->na;
    double lam = m->opt.lambda;
    /* the RLS's full mu (its prior's pull), and what the estimates report: the same, or the
     * bias-compensated answers where the accelerations' noise is compensated (est_eiv.h) */
    double mu_rls[EST_NMU], mu_full[EST_NMU], th_full[EST_NTH], D_rep[EST_ND];
    const double *mu_rep = c->mu, *th_rep = c->theta, *P_lin = c->P_mu, *P_ang = c->P_th;
    double KPK_lin[EST_NMU * EST_NMU], KPK_ang[EST_NTH * EST_NTH];
    full_vectors(m, c, mu_rls, th_full);
    memcpy(mu_full, mu_rls, sizeof mu_full);
    memcpy(D_rep, c->D, sizeof D_rep);
    if (c->has_eiv) {
        mu_rep = c->mu_c;
        th_rep = c->th_c;
        for (int i = 0; i < p; i++)
            mu_full[m->mu_active[i]] = c->mu_c[i];
        for (int i = 0; i < r; i++)
            th_full[m->theta_active[i]] = c->th_c[i];
        sr_D_of_mu(mu_full, D_rep);
        est_compensated_covariance(c->S_lin, c->N_lin, nl, p, c->P_mu, KPK_lin);
        est_compensated_covariance(c->S_ang, c->N_ang, na, r, c->P_th, KPK_ang);
        P_lin = KPK_lin;
        P_ang = KPK_ang;
    }
    /* the a-posteriori residual variances from the Gram matrices, z = [mu, -1] and
     * [theta, -1, -D(mu)] */
    double z_lin[EST_NL], z_ang[EST_NA];
    memcpy(z_lin, mu_rep, sizeof(double) * p);
    z_lin[p] = -1.0;
    memcpy(z_ang, th_rep, sizeof(double) * r);
    z_ang[r] = -1.0;
    for (int i = 0; i < EST_ND; i++)
        z_ang[r + 1 + i] = -D_rep[i];
    double s2_lin = est_residual_variance(c->S_lin, z_lin, nl,
                                      est_gram_dof(lam, c->rows_lin, c->n1_lin, c->n2_lin, p))
                    * est_gram_var_scale(lam, c->n1_lin, c->n2_lin) * infl_lin;
    double s2_ang = est_residual_variance(c->S_ang, z_ang, na,
                                      est_gram_dof(lam, c->rows_ang, c->n1_ang, c->n2_ang, r))
                    * est_gram_var_scale(lam, c->n1_ang, c->n2_ang) * infl_ang;
    /* the scale-free spectra of the information of mu and theta */
    est_eigs *el = &eig_out[0], *ea = &eig_out[1];
    /* expect_rcond (2): the excitation diagnostics of the state before, which say which
     * work is likely needed (not what is computed) */
    int st_l = est_block_eigs(c->S_lin, nl, p, expect_rcond[0] > EST_CHOL_RCOND
                          ? EST_EIGS_CHOL_SPECTRUM_FIRST : EST_EIGS_CHOL_EIGEN_FIRST, el);
    int st_a = est_block_eigs(c->S_ang, na, r, expect_rcond[1] > EST_CHOL_RCOND
                          ? EST_EIGS_CHOL_SPECTRUM_FIRST : EST_EIGS_CHOL_EIGEN_FIRST, ea);
    double w_mu = c->decay_lin * (1.0 / m->opt.P0_mu);      /* the prior's remaining weight */
    double w_theta = c->decay_ang * (1.0 / m->opt.P0_theta);
    double z[EST_NZ], zd[EST_NZ], delta[EST_NZ], x[EST_NZ], xd[EST_NZ], pull[EST_NZ];
    int unobserved_z[EST_NZ];
    memcpy(z, mu_full, sizeof mu_full);
    memcpy(z + EST_NMU, th_full, sizeof th_full);
    jacobian(SR_SHARP_TO_PROJECT, z, J);
    double Dj[EST_ND * EST_NMU], Tm[EST_NTH * EST_NMU], Tm_rep[EST_NTH * EST_NMU];
    D_jacobian(mu_rls, Dj);
    theta_of_mu(c->M, Dj, r, Tm);                            /* d theta / d mu = M dD/dmu */
    prior_pull(m, c, mu_rls, Tm, w_mu, w_theta, el, ea, delta, unobserved_z);
    if (c->has_eiv) {                                        /* at the reported mu */
        D_jacobian(mu_full, Dj);
        theta_of_mu(c->M, Dj, r, Tm_rep);
    } else {
        memcpy(Tm_rep, Tm, sizeof Tm);
    }
    vector_of(SR_SHARP_TO_PROJECT, z, x);
    for (int i = 0; i < EST_NZ; i++)
        zd[i] = z[i] - delta[i];
    vector_of(SR_SHARP_TO_PROJECT, zd, xd);
    int finite = 1;
    for (int i = 0; i < EST_NZ; i++) {                       /* the pull through the map */
        pull[i] = x[i] - xd[i];
        if (!isfinite(pull[i]))
            finite = 0;
    }
    if (!finite)                                             /* the data-only mass <= 0 */
        sr_matvec(J, delta, EST_NZ, EST_NZ, pull);
    /* sd^2 = diag(J C J^T) + pull^2 */
    double C[EST_NZ * EST_NZ];
    covariance(m, P_lin, P_ang, Tm_rep, s2_lin, s2_ang, C);
    est_scatter_sd(J, C, pull, unobserved_z, x, 1, sd);
    for (int i = 0; i < EST_NZ; i++) {
        data_only[i] = x[i] - pull[i];
        vec[i] = x[i];
    }
    rcond[0] = sr_rcond_of_spectrum(el->lam, el->unobserved, p);
    rcond[1] = sr_rcond_of_spectrum(ea->lam, ea->unobserved, r);
    return (st_l != 0 || st_a != 0) ? 3 : 0;
}

int est_paper_std_parts(const sr_estimator_model *m, const est_core *c, double infl_lin,
                        double infl_ang, double *sd, double *data_only, double *J, double *vec,
                        double *rcond)
{
    const double expect[2] = {c->rcond_mu, c->rcond_theta};
    est_eigs eg[2];
    return paper_std_parts(m, c, infl_lin, infl_ang, sd, data_only, J, vec, rcond, eg, expect);
}

/* -- the drift tracker's lag --------------------------------------------------------------- */

/* z = J^-1 x for the Jacobian J (20 x 20) of jacobian(), written out: the operations
 * est_sparse_lu_solve performs on that pattern, in its order, where its pivots are the
 * pattern's diagonal (each body's mass row pivots its mass column: |dx_b/dm| = |c_i| / m^2
 * <= 1 = dx_m/dm; finite nonzero 1 / m). Per body (rows e, columns u of m and c, t of
 * theta): z_m = x_m / 1, z_ci = (x_bi - f x_m) / (1 / m) with the multiplier f = J_bi,m / 1
 * (its update skipped for f = 0, as there), z_theta = x_I / 1. Returns 1 done, 0 where the
 * pattern's pivots would differ (z then not written: est_sparse_lu_solve's case). */
static int jacobian_solve(const int *s2p, const double *J, const double *x, double *z)
{
    for (int k = 0; k < 2; k++) {
        int e = EST0[k], u = MU0[k];
        if (J[e * EST_NZ + u] != 1.0)
            return 0;
        for (int i = 0; i < 3; i++) {
            const double f = J[(e + 1 + i) * EST_NZ + u], a = J[(e + 1 + i) * EST_NZ + u + 1 + i];
            if (!(fabs(f) <= 1.0) || !(fabs(a) > 0.0) || !isfinite(a))
                return 0;
        }
    }
    for (int k = 0; k < 2; k++) {
        int e = EST0[k], u = MU0[k], t = ZTH0[k];
        const double xm = x[e] / J[e * EST_NZ + u];
        z[u] = xm;
        for (int i = 0; i < 3; i++) {
            const double *Ji = J + (e + 1 + i) * EST_NZ;
            const double f = Ji[u] / J[e * EST_NZ + u];
            double b = x[e + 1 + i];
            if (Ji[u] != 0.0)
                b -= f * x[e];
            z[u + 1 + i] = b / Ji[u + 1 + i];
        }
        for (int i = 0; i < 6; i++)
            z[t + s2p[i]] = x[e + 4 + i] / J[(e + 4 + i) * EST_NZ + t + s2p[i]];
    }
    return 1;
}

/* The lag (20) of the estimates behind parameters moving at the rate rate_x (20) the
 * estimates show: J L(J^-1 rate_x) with L the lag of z (mu by eq. 2; theta, the batch
 * answer at the latest mu, by eq. 2 plus its response to mu's lag and rate,
 * G^-1 (S_phi,psi dD/dmu lag_mu - M_phi,psi dD/dmu r_mu)).
 * Returns 1 if finite (else no matrix lag). */
static EST_NOINLINE int paper_lag(const sr_estimator_model *m, const est_core *c, const double *J,
                     const double *rate_x, double growth, const double *mu_full, double *lag,
                     const est_eigs *eg)
{
    int p = m->p, r = m->r, nl = m->nl, na = m->na;
    double Jc[EST_NZ * EST_NZ], rate_z[EST_NZ];
    if (!jacobian_solve(SR_SHARP_TO_PROJECT, J, rate_x, rate_z)) {    /* J^-1 rate_x */
        memcpy(Jc, J, sizeof Jc);
        memcpy(rate_z, rate_x, sizeof rate_z);
        est_sparse_lu_solve(Jc, EST_NZ, rate_z);
    }
    double rate_mu[EST_NMU], rate_th[EST_NTH], lag_mu[EST_NMU], r_mu[EST_NMU];
    double lag_th[EST_NTH], r_th[EST_NTH];
    for (int i = 0; i < p; i++)
        rate_mu[i] = rate_z[m->mu_active[i]];
    for (int i = 0; i < r; i++)
        rate_th[i] = rate_z[EST_NMU + m->theta_active[i]];
    /* c's excitation diagnostics (the step wrote them before the tracker) */
    int two_solves = c->rcond_mu > EST_LAG_RCOND && c->rcond_theta > EST_LAG_RCOND;
    if (two_solves)
        est_block_lag_two_solves(c->S_lin, c->age_lin, nl, p, rate_mu, growth, lag_mu, r_mu,
                                 NULL, eg ? &eg[0] : NULL);
    else
        est_block_lag(c->S_lin, c->age_lin, nl, p, rate_mu, growth, lag_mu, r_mu, NULL);
    double Dj[EST_ND * EST_NMU], dD_lag[EST_ND] = {0}, dD_r[EST_ND] = {0};
    D_jacobian(mu_full, Dj);
    for (int a = 0; a < EST_ND; a++)
        for (int i = 0; i < p; i++) {
            dD_lag[a] += Dj[a * EST_NMU + m->mu_active[i]] * lag_mu[i];
            dD_r[a] += Dj[a * EST_NMU + m->mu_active[i]] * r_mu[i];
        }
    double rhs[EST_NTH];
    for (int i = 0; i < r; i++) {
        double s1 = 0.0, s2 = 0.0;
        for (int a = 0; a < EST_ND; a++) {
            s1 += c->S_ang[i * na + r + 1 + a] * dD_lag[a];
            s2 += c->age_ang[i * na + r + 1 + a] * dD_r[a];
        }
        rhs[i] = s1 - s2;
    }
    /* theta: eq. 2 and G^-1 rhs in one solve */
    if (two_solves)
        est_block_lag_two_solves(c->S_ang, c->age_ang, na, r, rate_th, growth, lag_th, r_th,
                                 rhs, eg ? &eg[1] : NULL);
    else
        est_block_lag(c->S_ang, c->age_ang, na, r, rate_th, growth, lag_th, r_th, rhs);
    double lag_z[EST_NZ] = {0};
    for (int i = 0; i < p; i++)
        lag_z[m->mu_active[i]] = lag_mu[i];
    for (int i = 0; i < r; i++)
        lag_z[EST_NMU + m->theta_active[i]] = lag_th[i] + rhs[i];
    sr_matvec(J, lag_z, EST_NZ, EST_NZ, lag);
    for (int i = 0; i < EST_NZ; i++)
        if (!isfinite(lag[i]))
            return 0;
    return 1;
}

/* -- one step ------------------------------------------------------------------------------ */

/* the identified rows of k rows blocks of 3 x 42 (weighted, the planar rows selected, the
 * parameters not identified moved to the right-hand sides) as the augmented rows
 * [A | b] (nblocks k1 x nl) and [phi | y | psi] (nblocks k2 x na) */
static void identified_rows(const sr_estimator_model *m, const double *E, int nblocks,
                            const double *mu_full, const double *th_full, double *R_lin,
                            double *R_ang)
{
    int p = m->p, r = m->r, k1 = m->k1, k2 = m->k2, nl = m->nl, na = m->na;
    double rowf[SR_N_COLS];
    for (int blk = 0; blk < nblocks; blk++) {
        const double *Eb = E + 3 * blk * SR_N_COLS;
        for (int a = 0; a < k1; a++) {
            const double *row = Eb + m->rows_lin[a] * SR_N_COLS;
            double *R = R_lin + (blk * k1 + a) * nl;
            for (int j = 0; j <= SR_COL_B; j++)
                rowf[j] = m->w_lin != 1.0 ? row[j] * m->w_lin : row[j];
            double s = 0.0;
            for (int o = 0; o < m->n_mu_out; o++)
                s += rowf[SR_COL_A + m->mu_out[o]] * mu_full[m->mu_out[o]];
            R[p] = m->n_mu_out ? rowf[SR_COL_B] - s : rowf[SR_COL_B];
            for (int i = 0; i < p; i++)
                R[i] = rowf[SR_COL_A + m->mu_active[i]];
        }
        for (int a = 0; a < k2; a++) {
            const double *row = Eb + m->rows_ang[a] * SR_N_COLS;
            double *R = R_ang + (blk * k2 + a) * na;
            for (int j = SR_COL_PHI; j < SR_N_COLS; j++)
                rowf[j] = m->w_ang != 1.0 ? row[j] * m->w_ang : row[j];
            double s = 0.0;
            for (int o = 0; o < m->n_th_out; o++)
                s += rowf[SR_COL_PHI + m->th_out[o]] * th_full[m->th_out[o]];
            R[r] = m->n_th_out ? rowf[SR_COL_Y] - s : rowf[SR_COL_Y];
            for (int i = 0; i < r; i++)
                R[i] = rowf[SR_COL_PHI + m->theta_active[i]];
            memcpy(R + r + 1, rowf + SR_COL_PSI, sizeof(double) * EST_ND);
        }
    }
}

/* The noise Gram matrices after this sample (est_eiv.h, eq. 1): lam times old's, plus the
 * identified rows of the noise blocks, n_chunks chunks of m->n_used blocks (3 x 42 each,
 * est_rows.h), each chunk's rows added as one; N_lin (nl x nl) of [A | b], N_ang (na x na) of
 * [phi | y | psi]; scratch EST_NOISE_SCRATCH doubles */
static void noise_grams(const sr_estimator_model *m, const est_core *old, const double *noise,
                        int n_chunks, double *N_lin, double *N_ang, double *scratch)
{
    double mu_full[EST_NMU], th_full[EST_NTH];
    double *Rn_lin = scratch, *Rn_ang = scratch + 3 * EST_MAXCH * EST_NL;
    int nb = m->n_used;
    est_noise_begin(m->opt.lambda, old->has_eiv, old->N_lin, m->nl, N_lin);
    est_noise_begin(m->opt.lambda, old->has_eiv, old->N_ang, m->na, N_ang);
    full_vectors(m, old, mu_full, th_full);
    for (int c = 0; c < n_chunks; c++) {
        identified_rows(m, noise + (size_t)c * nb * EST_NB, nb, mu_full, th_full, Rn_lin,
                        Rn_ang);
        est_gram_add(N_lin, m->nl, Rn_lin, nb * m->k1, 1.0, N_lin);   /* (in place) */
        est_gram_add(N_ang, m->na, Rn_ang, nb * m->k2, 1.0, N_ang);
    }
}

/* the bias-compensated answers (est_eiv.h):
 * (S_AA - N_AA) dmu = N_AA mu_r - N_Ab,
 * (S_pp - N_pp) dtheta = N_pp theta_r - N_py - N_ppsi D(mu_c) + S_ppsi (D(mu_c) - D(mu_r)),
 * each in the directions S - N observes; from nw's RLS answers, S and N */
static void compensate(const sr_estimator_model *m, est_core *nw)
{
    int p = m->p, r = m->r, nl = m->nl, na = m->na;
    double G[EST_NTH * EST_NTH] = {0.0}, rhs[EST_NTH] = {0.0}, dx[EST_NTH];
    for (int i = 0; i < p; i++) {
        double s = 0.0;
        for (int j = 0; j < p; j++) {
            G[i * p + j] = nw->S_lin[i * nl + j] - nw->N_lin[i * nl + j];
            s += nw->N_lin[i * nl + j] * nw->mu[j];
        }
        rhs[i] = s - nw->N_lin[i * nl + p];
    }
    est_observed_solve(G, p, rhs, dx);
    double full[EST_NMU], D_c[EST_ND];
    memcpy(full, m->mu0_full, sizeof full);
    for (int i = 0; i < p; i++) {
        nw->mu_c[i] = nw->mu[i] + dx[i];
        full[m->mu_active[i]] = nw->mu_c[i];
    }
    sr_D_of_mu(full, D_c);
    for (int i = 0; i < r; i++) {
        double s = 0.0, sx = 0.0, sn = 0.0;
        for (int j = 0; j < r; j++) {
            G[i * r + j] = nw->S_ang[i * na + j] - nw->N_ang[i * na + j];
            s += nw->N_ang[i * na + j] * nw->theta[j];
        }
        for (int a = 0; a < EST_ND; a++) {
            sx += nw->S_ang[i * na + r + 1 + a] * (D_c[a] - nw->D[a]);
            sn += nw->N_ang[i * na + r + 1 + a] * D_c[a];
        }
        rhs[i] = (s - nw->N_ang[i * na + r]) + (sx - sn);
    }
    est_observed_solve(G, r, rhs, dx);
    for (int i = 0; i < r; i++)
        nw->th_c[i] = nw->theta[i] + dx[i];
}

/* M+ = M + K (psi - phi M) = (1 - K phi) M + K psi (eq. 36: theta's dependence on D(mu))
 * from old's M, the theta step's gain K2 (r x k2) and the rows phi (k2 x r), psi (k2 x 20)
 * into nw->M; 0, or 1 where it is not finite */
static int update_M(const sr_estimator_model *m, const est_core *old, est_core *nw,
                    const double *K2, const double *phi, const double *psi)
{
    int r = m->r, k2 = m->k2;
    double W[3 * EST_ND], total = 0.0;
    for (int a = 0; a < k2; a++) {          /* psi - phi M (each entry's sum in the order of q;
                                               the loop over j innermost: contiguous rows) */
        double *Wa = W + a * EST_ND;
        memcpy(Wa, psi + a * EST_ND, sizeof(double) * EST_ND);
        for (int q = 0; q < r; q++) {
            const double f = phi[a * r + q], *Mq = old->M + q * EST_ND;
            for (int j = 0; j < EST_ND; j++)
                Wa[j] -= f * Mq[j];
        }
    }
    for (int i = 0; i < r; i++) {
        const double *Ki = K2 + i * k2, *restrict Mo = old->M + i * EST_ND;
        double *restrict Mn = nw->M + i * EST_ND;    /* (old and nw are distinct states) */
        if (k2 == 3) {                       /* the sum below written out: the same order,
                                                two entries a step (EST_ND even) */
            const double k0 = Ki[0], k1_ = Ki[1], k2_ = Ki[2];
            for (int j = 0; j < EST_ND; j += 2) {
                double s0 = 0.0, s1 = 0.0;
                s0 += k0 * W[j];
                s1 += k0 * W[j + 1];
                s0 += k1_ * W[EST_ND + j];
                s1 += k1_ * W[EST_ND + j + 1];
                s0 += k2_ * W[2 * EST_ND + j];
                s1 += k2_ * W[2 * EST_ND + j + 1];
                Mn[j] = Mo[j] + s0;
                Mn[j + 1] = Mo[j + 1] + s1;
            }
        } else {
            for (int j = 0; j < EST_ND; j++) {
                double s = 0.0;
                for (int a = 0; a < k2; a++)
                    s += Ki[a] * W[a * EST_ND + j];
                Mn[j] = Mo[j] + s;
            }
        }
    }
    for (int i = 0; i < r * EST_ND; i++)     /* (apart: the loop above then vectorises) */
        total += nw->M[i];
    return isfinite(total) ? 0 : 1;
}

/* dz/dc (20 x 8) of the paper solver: mu = G_lin^-1 sum A^T b,
 * theta = G_ang^-1 sum phi^T (y + psi D(mu)), so dmu/dc = G_lin^-1 C_lin and
 * dtheta/dc = G_ang^-1 (C_ang + S_phi,psi dD/dmu dmu/dc), at the reported mu; el, ea the
 * scaled eigen-decompositions of G_lin, G_ang (the p x p, r x r blocks of S_lin, S_ang) */
static void paper_consider_shift(const sr_estimator_model *m, const est_core *nw,
                                 const est_eigs *el, const est_eigs *ea, double *shift)
{
    const int nc = SR_N_CONSIDER, p = m->p, r = m->r, na = m->na;
    double dmu[EST_NMU * SR_N_CONSIDER], dth[EST_NTH * SR_N_CONSIDER];
    double rhs[EST_NTH * SR_N_CONSIDER] = {0.0}, dDdc[EST_ND * SR_N_CONSIDER];
    double mu_full[EST_NMU], th_full[EST_NTH], Dj[EST_ND * EST_NMU];
    memset(shift, 0, sizeof(double) * EST_NZ * SR_N_CONSIDER);
    est_eigs_solve_columns(el, p, nw->cons_lin, nc, dmu);
    full_vectors(m, nw, mu_full, th_full);
    if (nw->has_eiv)
        for (int i = 0; i < p; i++)
            mu_full[m->mu_active[i]] = nw->mu_c[i];
    D_jacobian(mu_full, Dj);
    for (int l = 0; l < EST_ND; l++)                         /* dD/dmu dmu/dc */
        for (int c = 0; c < nc; c++) {
            double s = 0.0;
            for (int i = 0; i < p; i++)
                s += Dj[l * EST_NMU + m->mu_active[i]] * dmu[i * nc + c];
            dDdc[l * nc + c] = s;
        }
    for (int i = 0; i < r; i++)                              /* C_ang + S_phi,psi dD/dc */
        for (int c = 0; c < nc; c++) {
            double s = 0.0;
            for (int l = 0; l < EST_ND; l++)
                s += nw->S_ang[i * na + r + 1 + l] * dDdc[l * nc + c];
            rhs[i * nc + c] = nw->cons_ang[i * nc + c] + s;
        }
    est_eigs_solve_columns(ea, r, rhs, nc, dth);
    for (int i = 0; i < p; i++)
        memcpy(shift + m->mu_active[i] * nc, dmu + i * nc, sizeof(double) * nc);
    for (int i = 0; i < r; i++)
        memcpy(shift + (EST_NMU + m->theta_active[i]) * nc, dth + i * nc, sizeof(double) * nc);
}

/* The identified rows of one sample (3 x 42) as the augmented rows [A | b] (k1 x nl),
 * [phi | y | psi] (k2 x na), and their parts A (k1 x p), b, phi (k2 x r), y, psi (k2 x 20) */
typedef struct paper_rows {
    double R_lin[3 * EST_NL], R_ang[3 * EST_NA];
    double A[3 * EST_NMU], b[3], phi[3 * EST_NTH], y[3], psi[3 * EST_ND];
} paper_rows;

/* The uncertainty of the new state nw after the step (pr its rows, e_lin, e_ang the a-priori
 * residuals, Ec the consider columns): the standard deviations and excitation diagnostics,
 * the drift tracker's total sd at clock, the thrust's consider term. 0, or 3 where an
 * eigen-decomposition did not converge. A frame of its own. */
static EST_NOINLINE int paper_uncertainty(const sr_estimator_model *m, const void *data,
                                          const est_core *old, est_core *nw,
                                          const paper_rows *pr, const double *Ec,
                                          const double *e_lin, const double *e_ang,
                                          double clock)
{
    int p = m->p;
    double infl_lin = 1.0, infl_ang = 1.0;
    if (m->lags > 0) {
        infl_lin = est_corr_inflation(m, data, old, 0, e_lin, m->k1);
        infl_ang = est_corr_inflation(m, data, old, 1, e_ang, m->k2);
    }
    double sd[EST_NZ], data_only[EST_NZ], J[EST_NZ * EST_NZ], rcond[2];
    est_eigs eg[2];
    const double expect[2] = {old->rcond_mu, old->rcond_theta};
    if (paper_std_parts(m, nw, infl_lin, infl_ang, sd, data_only, J, nw->vec, rcond, eg,
                        expect) != 0)
        return 3;
    nw->rcond_mu = rcond[0];
    nw->rcond_theta = rcond[1];
    double mu_new[EST_NMU], th_new[EST_NTH];
    full_vectors(m, nw, mu_new, th_new);
    if (nw->has_eiv)                         /* the tracker's lag at the reported mu */
        for (int i = 0; i < p; i++)
            mu_new[m->mu_active[i]] = nw->mu_c[i];
    est_tracker_step ts;
    double lag[EST_NZ];
    est_tracker_begin(m, old, nw, clock, data_only, sd, &ts);
    int has_lag = ts.all_positive && paper_lag(m, nw, J, ts.rate, ts.growth, mu_new, lag, eg);
    est_tracker_end(nw, sd, has_lag ? lag : NULL, &ts);
    if (m->consider) {                       /* the thrust's consider term (est_consider.h) */
        double shift[EST_NZ * SR_N_CONSIDER];
        est_consider_sums(m, old, nw, Ec, pr->A, pr->phi, NULL);
        paper_consider_shift(m, nw, &eg[0], &eg[1], shift);   /* the spectra just taken */
        est_consider_add(m, nw, J, shift);
    }
    return 0;
}

int est_paper_step(const sr_estimator_model *m, const void *data, const est_core *old,
                   const est_rows *rows, const double *noise, double *scratch, est_core *nw,
                   double clock, double *e_lin, double *e_ang)
{
    int p = m->p, r = m->r, k1 = m->k1, k2 = m->k2, nl = m->nl, na = m->na;
    double lam = m->opt.lambda;
    double mu_full[EST_NMU], th_full[EST_NTH];
    full_vectors(m, old, mu_full, th_full);
    /* the identified rows, weighted by their noise (1 / row_sd), the parameters that are not
     * identified moved to the right-hand sides: A mu = b (eq. 11 / 28),
     * phi theta = y + psi D(mu) (eq. 16 / 31), as the augmented rows [A | b], [phi | y | psi] */
    paper_rows pr;
    double *A = pr.A, *b = pr.b, *phi = pr.phi, *y = pr.y, *psi = pr.psi;
    identified_rows(m, rows->E, 1, mu_full, th_full, pr.R_lin, pr.R_ang);
    for (int a = 0; a < k1; a++) {
        memcpy(A + a * p, pr.R_lin + a * nl, sizeof(double) * p);
        b[a] = pr.R_lin[a * nl + p];
    }
    for (int a = 0; a < k2; a++) {
        memcpy(phi + a * r, pr.R_ang + a * na, sizeof(double) * r);
        y[a] = pr.R_ang[a * na + r];
        memcpy(psi + a * EST_ND, pr.R_ang + a * na + r + 1, sizeof(double) * EST_ND);
    }
    /* the modified RLS (eqs. 34-38) */
    double K1[EST_NMU * 3], K2[EST_NTH * 3];
    int st1 = est_rls_step(old->mu, old->P_mu, A, b, p, k1, lam, nw->mu, nw->P_mu, e_lin, K1);
    if (st1 != 0)                                            /* eq. 34: mu by RLS on A mu = b */
        return st1;
    double mu_new[EST_NMU], D_new[EST_ND], th[EST_NTH], rhs[3] = {0.0, 0.0, 0.0};
    memcpy(mu_new, m->mu0_full, sizeof mu_new);
    for (int i = 0; i < p; i++)
        mu_new[m->mu_active[i]] = nw->mu[i];
    sr_D_of_mu(mu_new, D_new);                               /* eq. 23 at the new mu */
    for (int i = 0; i < r; i++) {          /* theta += M (D(mu+) - D(mu)): re-referenced */
        double s = 0.0;
        for (int j = 0; j < EST_ND; j++)
            s += old->M[i * EST_ND + j] * (D_new[j] - old->D[j]);
        th[i] = old->theta[i] + s;
    }
    for (int a = 0; a < k2; a++) {                           /* y + psi D(mu+) */
        double s = y[a];
        for (int j = 0; j < EST_ND; j++)
            s += psi[a * EST_ND + j] * D_new[j];
        rhs[a] = s;
    }
    int st2 = est_rls_step(th, old->P_th, phi, rhs, r, k2, lam, nw->theta, nw->P_th, e_ang, K2);
    if (st2 != 0)                            /* eq. 35: theta by RLS on phi theta = rhs */
        return st2;
    if (update_M(m, old, nw, K2, phi, psi) != 0)
        return 2;
    memcpy(nw->D, D_new, sizeof D_new);

    /* the Gram matrices of the augmented rows and their counts */
    est_gram_add(old->S_lin, nl, pr.R_lin, k1, lam, nw->S_lin);
    est_gram_add(old->S_ang, na, pr.R_ang, k2, lam, nw->S_ang);
    nw->rows_lin = old->rows_lin;
    nw->decay_lin = old->decay_lin;
    nw->n1_lin = old->n1_lin;
    nw->n2_lin = old->n2_lin;
    est_gram_count(lam, k1, &nw->rows_lin, &nw->decay_lin, &nw->n1_lin, &nw->n2_lin);
    nw->rows_ang = old->rows_ang;
    nw->decay_ang = old->decay_ang;
    nw->n1_ang = old->n1_ang;
    nw->n2_ang = old->n2_ang;
    est_gram_count(lam, k2, &nw->rows_ang, &nw->decay_ang, &nw->n1_ang, &nw->n2_ang);
    nw->residual_lin = est_relative_norm(e_lin, b, k1);
    nw->residual_ang = est_relative_norm(e_ang, rhs, k2);
    est_fit_sums(A, b, nw->mu, k1, p, nw->fit_now);
    est_fit_sums(phi, rhs, nw->theta, k2, r, nw->fit_now + 2);

    /* the accelerations' noise: its expected part of the Gram matrices, the compensated
     * answers (est_eiv.h) */
    nw->has_eiv = old->has_eiv;
    if (rows->n_chunks > 0) {                /* eq. 1 with this sample's noise rows */
        noise_grams(m, old, noise, rows->n_chunks, nw->N_lin, nw->N_ang, scratch);
        nw->has_eiv = 1;
        compensate(m, nw);
    } else if (old->has_eiv) {               /* (a sample without noise rows: none come) */
        memcpy(nw->N_lin, old->N_lin, sizeof nw->N_lin);
        memcpy(nw->N_ang, old->N_ang, sizeof nw->N_ang);
        compensate(m, nw);
    }
    /* the standard deviations, the excitation diagnostics, the tracker, the consider term */
    return paper_uncertainty(m, data, old, nw, &pr, rows->Ec, e_lin, e_ang, clock);
}
