/* The joint solver (solver = 2): one RLS over the 20 standard parameters z = [m, m b, I_O#]
 * per body (Pinocchio's dynamic parameters; I_O the inertia about the body frame's origin, in
 * the paper's I# order), in which both identification equations are linear
 * (solvers.JointSolver; DESIGN.md section 4):
 *   linear rows   [B, 0]             (eq. 11 / 28: A mu = b, mu = [m, m b] per body)
 *   angular rows  [Psi[:, :4], Phi]  (eq. 16 / 31 with I_c = I_O - m (|b|^2 1 - b b^T): the
 *                                     quadratic columns of psi are the parallel-axis part)
 * The estimates: m, b = c / m, I_c = I_O - m (|b|^2 1 - b b^T) (parallel-axis theorem).
 * Uncertainty, tracker and report as the paper solver's (est_paper.c), with one information
 * block. Unidentified standard parameters (a planar robot's) stay at their guesses: their
 * columns move to the right-hand side.
 */
#include <math.h>
#include <string.h>

#include "equations.h"
#include "est_internal.h"
#include "linalg.h"
#include "physical.h"

/* index pairs (i, j) of the entries of I# (eq. 21) */
static const int SHARP_I[6] = {0, 0, 0, 1, 1, 2}, SHARP_J[6] = {0, 1, 2, 1, 2, 2};

const int EST_S2P[6] = {0, 3, 5, 1, 2, 4};

void est_standard_of_reported(const double *x, double *z)
{
    for (int k = 0; k < 2; k++) {
        const double *g = x + 10 * k;
        double mk = g[0], bb = g[1] * g[1] + g[2] * g[2] + g[3] * g[3];
        double Ic[9] = {g[4], g[7], g[8], g[7], g[5], g[9], g[8], g[9], g[6]};
        z[10 * k] = mk;
        for (int i = 0; i < 3; i++)
            z[10 * k + 1 + i] = mk * g[1 + i];
        for (int q = 0; q < 6; q++) {
            int i = SHARP_I[q], j = SHARP_J[q];
            double par = (i == j ? bb * 1.0 : bb * 0.0) - g[1 + i] * g[1 + j];
            z[10 * k + 4 + q] = Ic[3 * i + j] + mk * par;
        }
    }
}

/* The 20 estimates from the standard parameters z (report_kernels.joint_vector_of): b = c / m,
 * I_c = I_O - m (|b|^2 1 - b b^T), I = I_c#[sharp_to_project]. */
void est_joint_vector_of(const int *s2p, const double *z, double *out)
{
    for (int k = 0; k < 2; k++) {
        int e = 10 * k;
        double m = z[e], b[3], bb = 0.0;
        out[e] = m;
        for (int i = 0; i < 3; i++) {
            b[i] = z[e + 1 + i] / m;
            out[e + 1 + i] = b[i];
        }
        for (int i = 0; i < 3; i++)
            bb += b[i] * b[i];
        for (int jp = 0; jp < 6; jp++) {
            int p = s2p[jp], i = SHARP_I[p], j = SHARP_J[p];
            double eye = i == j ? 1.0 : 0.0;
            out[e + 4 + jp] = z[e + 4 + p] - m * (bb * eye - b[i] * b[j]);
        }
    }
}

/* d joint_vector_of / d z (20 x 20) (report_kernels.joint_jacobian): db/dc = 1 / m,
 * db/dm = -c / m^2; I_c = I_O - S(c) / m, S(c) = |c|^2 1 - c c^T: dI_c/dI_O = 1,
 * dI_c/dm = S / m^2, dI_c,ij/dc_k = -(2 c_k d_ij - d_ik c_j - c_i d_jk) / m */
void est_joint_jacobian(const int *s2p, const double *z, double *J)
{
    memset(J, 0, sizeof(double) * EST_NZ * EST_NZ);
    for (int k = 0; k < 2; k++) {
        int e = 10 * k;
        double m = z[e], cc = 0.0;
        J[e * EST_NZ + e] = 1.0;
        for (int i = 0; i < 3; i++) {
            J[(e + 1 + i) * EST_NZ + e + 1 + i] = 1.0 / m;
            J[(e + 1 + i) * EST_NZ + e] = -z[e + 1 + i] / (m * m);
        }
        for (int i = 0; i < 3; i++)
            cc += z[e + 1 + i] * z[e + 1 + i];
        for (int jp = 0; jp < 6; jp++) {
            int p = s2p[jp], row = e + 4 + jp, i = SHARP_I[p], j = SHARP_J[p];
            double ci = z[e + 1 + i], cj = z[e + 1 + j];
            double S_ij = (i == j ? cc : 0.0) - ci * cj;
            J[row * EST_NZ + e + 4 + p] = 1.0;
            J[row * EST_NZ + e] = S_ij / (m * m);
            for (int kk = 0; kk < 3; kk++) {
                double dS = (i == j ? 2.0 * z[e + 1 + kk] : 0.0) - (kk == i ? cj : 0.0)
                            - (kk == j ? ci : 0.0);
                J[row * EST_NZ + e + 1 + kk] = -dS / m;
            }
        }
    }
}

void est_joint_init(const sr_estimator_model *m, est_core *c)
{
    memcpy(c->pi, m->pi0_full, sizeof c->pi);
    for (int i = 0; i < m->q; i++)
        c->P_pi[i * m->q + i] = m->prior[m->std_active[i]];
}

int est_joint_std_parts(const sr_estimator_model *m, const est_core *c, double infl,
                        double *sd, double *data_only, double *J, double *vec)
{
    int q = m->q, nj = q + 1;
    double lam = m->opt.lambda;
    /* the RLS's answer x (its prior's pull), and what the estimates report: the same, or the
     * bias-compensated answer where the accelerations' noise is compensated (eiv.py) */
    const double *pi_rep = c->has_eiv ? c->pi_c : c->pi;
    double x[EST_NZ + 1], x0[EST_NZ], G[EST_NZ * EST_NZ] = {0.0};
    for (int i = 0; i < q; i++) {
        x[i] = c->pi[m->std_active[i]];
        x0[i] = m->pi0_full[m->std_active[i]];
        for (int j = 0; j < q; j++)
            G[i * q + j] = c->S_pi[i * nj + j];
    }
    /* the prior's pull delta = -G^-1 W0 (x - x0), W0 = lam^N P0^-1 (uncertainty.prior_pull) */
    double lam_e[EST_NZ], V[EST_NZ * EST_NZ], d[EST_NZ], rhs[EST_NZ], dx[EST_NZ];
    int unobs[EST_NZ], u[EST_NZ];
    int st = sr_scaled_eigh(G, q, lam_e, V, d, unobs);
    for (int i = 0; i < q; i++)
        rhs[i] = -((c->decay_lin * (1.0 / m->prior[m->std_active[i]])) * (x[i] - x0[i]));
    sr_eig_solve(lam_e, V, d, unobs, rhs, q, dx, u);
    double delta[EST_NZ] = {0.0}, z[EST_NZ], zd[EST_NZ], xv[EST_NZ], xd[EST_NZ], pull[EST_NZ];
    int unobserved_z[EST_NZ] = {0};
    for (int i = 0; i < q; i++) {
        delta[m->std_active[i]] = dx[i];
        unobserved_z[m->std_active[i]] = u[i];
    }
    memcpy(z, pi_rep, sizeof z);
    est_joint_jacobian(m->sharp_to_project, z, J);
    est_joint_vector_of(m->sharp_to_project, z, xv);
    for (int i = 0; i < EST_NZ; i++)
        zd[i] = z[i] - delta[i];
    est_joint_vector_of(m->sharp_to_project, zd, xd);
    int finite = 1;
    for (int i = 0; i < EST_NZ; i++) {                       /* the pull through the map */
        pull[i] = xv[i] - xd[i];
        if (!isfinite(pull[i]))
            finite = 0;
    }
    if (!finite)                                             /* the data-only mass <= 0 */
        sr_matvec(J, delta, EST_NZ, EST_NZ, pull);
    /* the covariance: the RLS's P times the residual variance, the rest the prior's; with
     * the noise compensated K P K^T (solvers.compensation_gain) and the residual variance at
     * the compensated answer (JointSolver.covariance) */
    const double *P = c->P_pi;
    double KPK[EST_NZ * EST_NZ];
    if (c->has_eiv) {
        est_compensated_covariance(c->S_pi, c->N_pi, nj, q, c->P_pi, KPK);
        P = KPK;
        for (int i = 0; i < q; i++)
            x[i] = pi_rep[m->std_active[i]];
    }
    x[q] = -1.0;
    double s2 = est_residual_variance(c->S_pi, x, nj,
                                      est_gram_dof(lam, c->rows_lin, c->n1_lin, c->n2_lin, q));
    if (lam != 1.0)
        s2 *= est_gram_var_scale(lam, c->n1_lin, c->n2_lin);
    if (m->lags)
        s2 *= infl;
    double C[EST_NZ * EST_NZ] = {0.0};
    for (int i = 0; i < EST_NZ; i++)
        C[i * EST_NZ + i] = m->prior[i];
    for (int i = 0; i < q; i++)
        for (int j = 0; j < q; j++)
            C[m->std_active[i] * EST_NZ + m->std_active[j]] = P[i * q + j] * s2;
    est_scatter_sd(m, J, C, pull, unobserved_z, xv, 0, sd);
    for (int i = 0; i < EST_NZ; i++) {
        data_only[i] = xv[i] - pull[i];
        vec[i] = xv[i];
    }
    return st != 0 ? 3 : 0;
}

int est_joint_lag(const sr_estimator_model *m, const est_core *c, const double *J,
                  const double *rate_x, double growth, double *lag)
{
    int q = m->q;
    double Jc[EST_NZ * EST_NZ], rate_z[EST_NZ], rate_a[EST_NZ], lag_a[EST_NZ], r_a[EST_NZ];
    memcpy(Jc, J, sizeof Jc);
    memcpy(rate_z, rate_x, sizeof rate_z);
    est_sparse_lu_solve(Jc, EST_NZ, rate_z);                 /* J^-1 rate_x */
    for (int i = 0; i < q; i++)
        rate_a[i] = rate_z[m->std_active[i]];
    est_block_lag(c->S_pi, c->age_pi, q + 1, q, rate_a, growth, lag_a, r_a, NULL);
    double lag_z[EST_NZ] = {0.0};
    for (int i = 0; i < q; i++)
        lag_z[m->std_active[i]] = lag_a[i];
    sr_matvec(J, lag_z, EST_NZ, EST_NZ, lag);
    for (int i = 0; i < EST_NZ; i++)
        if (!isfinite(lag[i]))
            return 0;
    return 1;
}

/* info (n x n) = lam info + H^T H over the columns cols (n) of the rows H (k x q) */
static void info_add(const double *old, const double *H, int k, int q, const int *cols, int n,
                     double lam, double *out)
{
    for (int i = 0; i < n; i++)
        for (int j = 0; j < n; j++) {
            double s = 0.0;
            for (int a = 0; a < k; a++)
                s += H[a * q + cols[i]] * H[a * q + cols[j]];
            out[i * n + j] = (lam == 1.0 ? old[i * n + j] : lam * old[i * n + j]) + s;
        }
}

/* the excitation diagnostic of an information matrix (identifier._rcond) */
static double rcond_of(const double *info, int n)
{
    double G[EST_NZ * EST_NZ], w[EST_NZ], V[EST_NZ * EST_NZ], d[EST_NZ];
    int u[EST_NZ];
    if (n <= 0)
        return 0.0;
    memcpy(G, info, sizeof(double) * (size_t)n * (size_t)n);
    sr_scaled_eigh(G, n, w, V, d, u);
    return sr_rcond_of_spectrum(w, u, n);
}

void est_joint_rows(const sr_estimator_model *m, const est_core *c, const double *E,
                    double *H, double *yy, double *b)
{
    int k1 = m->k1, k2 = m->k2, k = k1 + k2, q = m->q;
    /* the identified rows, weighted (Identifier._identified_rows), over the standard
     * parameters (JointSolver._stack): linear [B, 0], angular [-psi[:, m, m b], phi] */
    double Y[EST_MAXK * EST_NZ] = {0.0};
    for (int a = 0; a < k1; a++) {
        const double *row = E + m->rows_lin[a] * SR_N_COLS;
        double w = m->w_lin;
        for (int body = 0; body < 2; body++)
            for (int i = 0; i < 4; i++)
                Y[a * EST_NZ + 10 * body + i] = w != 1.0 ? row[SR_COL_A + 4 * body + i] * w
                                                         : row[SR_COL_A + 4 * body + i];
        yy[a] = w != 1.0 ? row[SR_COL_B] * w : row[SR_COL_B];
        if (b)
            b[a] = yy[a];
    }
    for (int a = 0; a < k2; a++) {
        const double *row = E + m->rows_ang[a] * SR_N_COLS;
        double w = m->w_ang, *Ya = Y + (k1 + a) * EST_NZ;
        for (int body = 0; body < 2; body++) {
            for (int i = 0; i < 4; i++) {
                double v = row[SR_COL_PSI + 10 * body + i];
                Ya[10 * body + i] = -(w != 1.0 ? v * w : v);
            }
            for (int i = 0; i < 6; i++) {
                double v = row[SR_COL_PHI + 6 * body + i];
                Ya[10 * body + 4 + i] = w != 1.0 ? v * w : v;
            }
        }
        yy[k1 + a] = w != 1.0 ? row[SR_COL_Y] * w : row[SR_COL_Y];
    }
    if (m->n_std_out)                         /* the fixed parameters to the right-hand side */
        for (int a = 0; a < k; a++) {
            double s = 0.0;
            for (int o = 0; o < m->n_std_out; o++)
                s += Y[a * EST_NZ + m->std_out[o]] * c->pi[m->std_out[o]];
            yy[a] -= s;
        }
    for (int a = 0; a < k; a++)
        for (int i = 0; i < q; i++)
            H[a * q + i] = Y[a * EST_NZ + m->std_active[i]];
}

/* the bias-compensated standard parameters (JointSolver.update, eiv.compensation, eq. 2):
 * pi_c = x_r + dx, (S_HH - N_HH) dx = N_HH x_r - N_Hy in the directions S - N observes
 * (a direction the noise swamps is left uncorrected) */
static void compensate(const sr_estimator_model *m, est_core *nw)
{
    int q = m->q, nj = q + 1;
    double G[EST_NZ * EST_NZ] = {0.0}, rhs[EST_NZ], dx[EST_NZ], lam_e[EST_NZ];
    double V[EST_NZ * EST_NZ], d[EST_NZ];
    int un[EST_NZ], u[EST_NZ];
    for (int i = 0; i < q; i++) {
        double s = 0.0;
        for (int j = 0; j < q; j++) {
            G[i * q + j] = nw->S_pi[i * nj + j] - nw->N_pi[i * nj + j];
            s += nw->N_pi[i * nj + j] * nw->pi[m->std_active[j]];
        }
        rhs[i] = s - nw->N_pi[i * nj + q];
    }
    sr_scaled_eigh(G, q, lam_e, V, d, un);
    sr_eig_solve(lam_e, V, d, un, rhs, q, dx, u);
    memcpy(nw->pi_c, nw->pi, sizeof nw->pi_c);
    for (int i = 0; i < q; i++)
        nw->pi_c[m->std_active[i]] = nw->pi[m->std_active[i]] + dx[i];
}

int est_joint_step(const sr_estimator_model *m, const void *data, const est_core *old,
                   est_core *nw, const double *E, const double *Ec, const double *N_pi,
                   double clock, double *e)
{
    int q = m->q, k1 = m->k1, k2 = m->k2, k = k1 + k2, nj = q + 1;
    double lam = m->opt.lambda;
    double H[EST_MAXK * EST_NZ], x[EST_NZ], K[EST_NZ * EST_MAXK], yy[EST_MAXK], b[3];
    est_joint_rows(m, old, E, H, yy, b);
    for (int i = 0; i < q; i++)
        x[i] = old->pi[m->std_active[i]];
    /* one RLS step on H z = yy (eqs. 11/16 or 28/31 over the standard parameters) */
    int st = est_rls_step(x, old->P_pi, H, yy, q, k, lam, x, nw->P_pi, e, K);
    if (st != 0)
        return st;
    memcpy(nw->pi, old->pi, sizeof nw->pi);
    for (int i = 0; i < q; i++)
        nw->pi[m->std_active[i]] = x[i];
    /* the Gram matrix of [H | yy], the counts, the information blocks */
    double R[EST_MAXK * EST_NJ];
    for (int a = 0; a < k; a++) {
        memcpy(R + a * nj, H + a * q, sizeof(double) * q);
        R[a * nj + q] = yy[a];
    }
    est_gram_add(old->S_pi, nj, R, k, lam, nw->S_pi);
    nw->rows_lin = old->rows_lin;
    nw->decay_lin = old->decay_lin;
    nw->n1_lin = old->n1_lin;
    nw->n2_lin = old->n2_lin;
    est_gram_count(lam, k, &nw->rows_lin, &nw->decay_lin, &nw->n1_lin, &nw->n2_lin);
    info_add(old->info_lin, H, k1, q, m->lin_cols, m->n_lin_cols, lam, nw->info_lin);
    info_add(old->info_ang, H + k1 * q, k2, q, m->ang_cols, m->n_ang_cols, lam, nw->info_ang);
    nw->residual_lin = est_relative_norm(e, b, k1);
    nw->residual_ang = est_relative_norm(e + k1, yy + k1, k2);
    /* the accelerations' noise: its expected part of the Gram matrix, the compensated
     * answer (eiv.py) */
    nw->has_eiv = old->has_eiv;
    if (N_pi) {
        memcpy(nw->N_pi, N_pi, sizeof(double) * nj * nj);
        nw->has_eiv = 1;
        compensate(m, nw);
    } else if (old->has_eiv) {               /* (a sample without noise rows: none come) */
        memcpy(nw->N_pi, old->N_pi, sizeof(double) * nj * nj);
        compensate(m, nw);
    }
    double infl = m->lags > 0 ? est_corr_inflation(m, data, old, 0, e, k) : 1.0;
    double sd[EST_NZ], data_only[EST_NZ], J[EST_NZ * EST_NZ];
    if (est_joint_std_parts(m, nw, infl, sd, data_only, J, nw->vec) != 0)
        return 3;
    nw->rcond_mu = rcond_of(nw->info_lin, m->n_lin_cols);
    nw->rcond_theta = rcond_of(nw->info_ang, m->n_ang_cols);
    est_tracker_add(m, old, nw, clock, data_only, sd, J, NULL);
    if (m->consider) {                       /* the thrust's consider term (consider.py) */
        est_consider_sums(m, old, nw, Ec, NULL, NULL, H);
        est_consider_sd(m, nw, J);
    }
    return 0;
}
