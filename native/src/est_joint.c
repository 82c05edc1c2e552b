/* The joint solver (solver = 2): one RLS over the 20 standard parameters z = [m, m b, I_O#]
 * per body (standard_params.h), in which both identification equations are linear
 * (DESIGN.md section 4):
 *   linear rows   [B, 0]             (eq. 11 / 28: A mu = b, mu = [m, m b] per body)
 *   angular rows  [Psi[:, :4], Phi]  (eq. 16 / 31 with I_c = I_O - m (|b|^2 1 - b b^T): the
 *                                     quadratic columns of psi are the parallel-axis part)
 * The estimates: m, b = c / m, I_c = I_O - m (|b|^2 1 - b b^T) (parallel-axis theorem).
 * Uncertainty, tracker and consider term as the paper solver's (est_paper.c), with one
 * information block. Unidentified standard parameters (a planar robot's) stay at their
 * guesses: their columns move to the right-hand side.
 */
#include "est_joint.h"

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
     * bias-compensated answer where the accelerations' noise is compensated (est_eiv.h) */
    const double *pi_rep = c->has_eiv ? c->pi_c : c->pi;
    double x[EST_NZ + 1], x0[EST_NZ], G[EST_NZ * EST_NZ] = {0.0};
    for (int i = 0; i < q; i++) {
        x[i] = c->pi[m->std_active[i]];
        x0[i] = m->pi0_full[m->std_active[i]];
        for (int j = 0; j < q; j++)
            G[i * q + j] = c->S_pi[i * nj + j];
    }
    /* the prior's pull delta = -G^-1 W0 (x - x0), W0 = lam^N P0^-1 (G: in place its scaled
     * eigenvectors V) */
    double lam_e[EST_NZ], *V = G, d[EST_NZ], rhs[EST_NZ], dx[EST_NZ];
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
    sr_reported_jacobian(z, J);
    sr_reported_of_standard(z, xv);
    for (int i = 0; i < EST_NZ; i++)
        zd[i] = z[i] - delta[i];
    sr_reported_of_standard(zd, xd);
    int finite = 1;
    for (int i = 0; i < EST_NZ; i++) {                       /* the pull through the map */
        pull[i] = xv[i] - xd[i];
        if (!isfinite(pull[i]))
            finite = 0;
    }
    if (!finite)                                             /* the data-only mass <= 0 */
        sr_matvec(J, delta, EST_NZ, EST_NZ, pull);
    /* the covariance: the RLS's P times the residual variance, the rest the prior's; with
     * the noise compensated K P K^T and the residual variance at the compensated answer */
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
    est_scatter_sd(J, C, pull, unobserved_z, xv, 0, sd);
    for (int i = 0; i < EST_NZ; i++) {
        data_only[i] = xv[i] - pull[i];
        vec[i] = xv[i];
    }
    return st != 0 ? 3 : 0;
}

/* the lag (20) of the estimates behind parameters moving at the rate rate_x (20) (eq. 2 over
 * the standard parameters, mapped by J); 1 if finite */
static int joint_lag(const sr_estimator_model *m, const est_core *c, const double *J,
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

static void joint_rows(const sr_estimator_model *m, const est_core *c, const double *E,
                       double *H, double *yy, double *b);

void est_joint_rows(const sr_estimator_model *m, const est_core *c, const double *E, double *H,
                    double *yy)
{
    joint_rows(m, c, E, H, yy, NULL);
}

void est_joint_rows_hy(const sr_estimator_model *m, const est_core *c, const double *E,
                       double *Hy)
{
    int q = m->q, nj = q + 1, k = m->k1 + m->k2;
    double H[EST_MAXK * EST_NZ], yy[EST_MAXK];
    joint_rows(m, c, E, H, yy, NULL);
    for (int a = 0; a < k; a++) {
        memcpy(Hy + a * nj, H + a * q, sizeof(double) * q);
        Hy[a * nj + q] = yy[a];
    }
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

/* the excitation diagnostic of an information matrix: the reciprocal condition number of its
 * scaled form */
static double rcond_of(const double *info, int n)
{
    double G[EST_NZ * EST_NZ], w[EST_NZ], *V = G, d[EST_NZ];
    int u[EST_NZ];
    if (n <= 0)
        return 0.0;
    memcpy(G, info, sizeof(double) * (size_t)n * (size_t)n);
    sr_scaled_eigh(G, n, w, V, d, u);
    return sr_rcond_of_spectrum(w, u, n);
}

/* The rows of one block E (3 x 42, full 3D rows) over the identified standard parameters: H
 * (k1 + k2 x q), yy (k1 + k2) the right-hand sides (the fixed parameters' columns moved there
 * at c's pi); b (k1, may be NULL) the weighted linear right-hand sides before that. */
static void joint_rows(const sr_estimator_model *m, const est_core *c, const double *E,
                       double *H, double *yy, double *b)
{
    int k1 = m->k1, k2 = m->k2, k = k1 + k2, q = m->q;
    /* the identified rows, weighted, over the standard parameters: linear [B, 0], angular
     * [-psi[:, m, m b], phi] */
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

/* The noise Gram matrix of [H | yy] after this sample (est_eiv.h, eq. 1): lam times old's,
 * plus the rows of the noise blocks, n_chunks chunks of m->n_used blocks (3 x 42 each), each
 * chunk's rows added as one, into N ((q + 1) x (q + 1)); scratch EST_NOISE_SCRATCH doubles */
static void noise_gram(const sr_estimator_model *m, const est_core *old, const double *noise,
                       int n_chunks, double *N, double *scratch)
{
    int nj = m->q + 1, k = m->k1 + m->k2, nb = m->n_used;
    double *R = scratch;
    est_noise_begin(m->opt.lambda, old->has_eiv, old->N_pi, nj, N);
    for (int c = 0; c < n_chunks; c++) {
        const double *chunk = noise + (size_t)c * nb * EST_NB;
        for (int blk = 0; blk < nb; blk++)
            est_joint_rows_hy(m, old, chunk + blk * EST_NB, R + blk * k * nj);
        est_gram_add(N, nj, R, nb * k, 1.0, N);
    }
}

/* the bias-compensated standard parameters (est_eiv.h, eq. 2) */
static void compensate(const sr_estimator_model *m, est_core *nw)
{
    int q = m->q;
    double x[EST_NZ], xc[EST_NZ];
    for (int i = 0; i < q; i++)
        x[i] = nw->pi[m->std_active[i]];
    est_compensate(nw->S_pi, nw->N_pi, q + 1, q, x, xc);
    memcpy(nw->pi_c, nw->pi, sizeof nw->pi_c);
    for (int i = 0; i < q; i++)
        nw->pi_c[m->std_active[i]] = xc[i];
}

/* nw->sd with the thrust's consider variance (est_consider.h): d pi / d c = G^-1 C, G the
 * information of the standard parameters, C the consider sums; J (20 x 20) the Jacobian of
 * the estimates in pi */
static void joint_consider(const sr_estimator_model *m, est_core *nw, const double *J)
{
    double shift[EST_NZ * SR_N_CONSIDER];
    int q = m->q, nj = q + 1;
    double G[EST_NZ * EST_NZ] = {0.0}, lam[EST_NZ], *V = G, d[EST_NZ];   /* (in place) */
    double dpi[EST_NZ * SR_N_CONSIDER];
    int un[EST_NZ];
    for (int i = 0; i < q; i++)
        for (int j = 0; j < q; j++)
            G[i * q + j] = nw->S_pi[i * nj + j];
    sr_scaled_eigh(G, q, lam, V, d, un);
    est_solve_columns(lam, V, d, un, q, nw->cons_lin, SR_N_CONSIDER, dpi);
    memset(shift, 0, sizeof shift);
    for (int i = 0; i < q; i++)
        memcpy(shift + m->std_active[i] * SR_N_CONSIDER, dpi + i * SR_N_CONSIDER,
               sizeof(double) * SR_N_CONSIDER);
    est_consider_add(m, nw, J, shift);
}

/* The uncertainty of the new state nw after the step (H its rows, e the a-priori residuals,
 * Ec the consider columns): the standard deviations and excitation diagnostics, the drift
 * tracker's total sd at clock, the thrust's consider term. 0, or 3 where an
 * eigen-decomposition did not converge. A frame of its own. */
static EST_NOINLINE int joint_uncertainty(const sr_estimator_model *m, const void *data,
                                          const est_core *old, est_core *nw, const double *H,
                                          const double *Ec, const double *e, double clock)
{
    int k = m->k1 + m->k2;
    double infl = m->lags > 0 ? est_corr_inflation(m, data, old, 0, e, k) : 1.0;
    double sd[EST_NZ], data_only[EST_NZ], J[EST_NZ * EST_NZ];
    if (est_joint_std_parts(m, nw, infl, sd, data_only, J, nw->vec) != 0)
        return 3;
    nw->rcond_mu = rcond_of(nw->info_lin, m->n_lin_cols);
    nw->rcond_theta = rcond_of(nw->info_ang, m->n_ang_cols);
    est_tracker_step ts;
    double lag[EST_NZ];
    est_tracker_begin(m, old, nw, clock, data_only, sd, &ts);
    int has_lag = ts.all_positive && joint_lag(m, nw, J, ts.rate, ts.growth, lag);
    est_tracker_end(nw, sd, has_lag ? lag : NULL, &ts);
    if (m->consider) {                       /* the thrust's consider term (est_consider.h) */
        est_consider_sums(m, old, nw, Ec, NULL, NULL, H);
        joint_consider(m, nw, J);
    }
    return 0;
}

int est_joint_step(const sr_estimator_model *m, const void *data, const est_core *old,
                   const est_rows *rows, const double *noise, double *scratch, est_core *nw,
                   double clock, double *e)
{
    int q = m->q, k1 = m->k1, k2 = m->k2, k = k1 + k2, nj = q + 1;
    double lam = m->opt.lambda;
    double H[EST_MAXK * EST_NZ] = {0.0}, x[EST_NZ] = {0.0}, K[EST_NZ * EST_MAXK];
    double yy[EST_MAXK], b[3];
    joint_rows(m, old, rows->E, H, yy, b);
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
    nw->rows_ang = old->rows_ang;            /* (one Gram matrix: the angular counts stay) */
    nw->decay_ang = old->decay_ang;
    nw->n1_ang = old->n1_ang;
    nw->n2_ang = old->n2_ang;
    info_add(old->info_lin, H, k1, q, m->lin_cols, m->n_lin_cols, lam, nw->info_lin);
    info_add(old->info_ang, H + k1 * q, k2, q, m->ang_cols, m->n_ang_cols, lam, nw->info_ang);
    nw->residual_lin = est_relative_norm(e, b, k1);
    nw->residual_ang = est_relative_norm(e + k1, yy + k1, k2);
    est_fit_sums(H, yy, x, k1, q, nw->fit_now);
    est_fit_sums(H + k1 * q, yy + k1, x, k2, q, nw->fit_now + 2);
    /* the accelerations' noise: its expected part of the Gram matrix, the compensated
     * answer (est_eiv.h) */
    nw->has_eiv = old->has_eiv;
    if (rows->n_chunks > 0) {
        noise_gram(m, old, noise, rows->n_chunks, nw->N_pi, scratch);
        nw->has_eiv = 1;
        compensate(m, nw);
    } else if (old->has_eiv) {               /* (a sample without noise rows: none come) */
        memcpy(nw->N_pi, old->N_pi, sizeof(double) * nj * nj);
        compensate(m, nw);
    }
    /* the standard deviations, the excitation diagnostics, the tracker, the consider term */
    return joint_uncertainty(m, data, old, nw, H, rows->Ec, e, clock);
}
