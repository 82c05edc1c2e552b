/* The information filter and the bound (information.h). */
#include "information.h"

#include "linalg.h"
#include "sr_math.h"
#include "standard_params.h"

#include <limits.h>
#include <math.h>
#include <string.h>

#define MU SR_INFO_MAX_U             /* row stride of R, N_HH */
/* a function kept out of its caller's frame: two of the large temporaries never share one */
#if defined(__GNUC__)
#define INFO_NOINLINE __attribute__((noinline))
#else
#define INFO_NOINLINE
#endif
#define HS (MU + 1)                  /* row stride of a block of rows [H | y] */

/* The unknowns' z part is in the standard layout of standard_params.h: per body m, c = m b (3),
 * I_O# (6, about the body frame's origin); sr_standard_of_reported / sr_reported_of_standard
 * map it from / to the reported parameters. */

/* the white-noise sds of n (8), the channels the rows are weighed by */
static void white_sds(const sr_info_noise *n, double *w)
{
    const double v[8] = {n->r, n->v, n->omega, n->att[0], n->att[1], n->att[2], n->q, n->qd};
    memcpy(w, v, sizeof v);
}

int sr_info_noise_white(const sr_info_noise *n)
{
    double w[8];
    int white = 0;
    white_sds(n, w);
    for (int i = 0; i < 8; i++)
        white = white || w[i] > 0.0;
    return white;
}

/* 1 if every sd of n is finite and >= 0 */
static int noise_valid(const sr_info_noise *n)
{
    double w[8];
    int ok = isfinite(n->gyro_bias) && n->gyro_bias >= 0.0;
    white_sds(n, w);
    for (int i = 0; i < 8; i++)
        ok = ok && isfinite(w[i]) && w[i] >= 0.0;
    for (int i = 0; i < SR_N_CONSIDER; i++)
        ok = ok && isfinite(n->thrust[i]) && n->thrust[i] >= 0.0;
    return ok;
}

int sr_info_model_init(sr_info_model *m, const sr_robot *robot, const sr_info_noise *noise,
                       const double *z0, double P0_mu, double P0_theta)
{
    if (!m || !robot || !noise || !z0 || robot->n < 1 || robot->n > SR_MAX_JOINTS)
        return 1;
    if (!(P0_mu > 0.0 && P0_theta > 0.0 && isfinite(P0_mu) && isfinite(P0_theta)))
        return 1;
    if (!noise_valid(noise) || !sr_info_noise_white(noise))   /* nothing to weigh by */
        return 1;
    for (int i = 0; i < 20; i++)
        if (!isfinite(z0[i]))
            return 1;
    if (!(z0[0] > 0.0 && z0[10] > 0.0))
        return 1;
    memset(m, 0, sizeof *m);
    m->robot = *robot;
    m->n = robot->n;
    m->planar = robot->planar;
    m->noise = *noise;
    m->nz = 0;                        /* planar: m, c_x, c_y, I_zz of each body */
    for (int k = 0; k < 2; k++)
        for (int i = 0; i < 10; i++)
            if (!m->planar || i == 0 || i == 1 || i == 2 || i == 9)
                m->zi[m->nz++] = 10 * k + i;
    static const int planar_rows[3] = {0, 1, 5};
    m->nr = m->planar ? 3 : 6;
    for (int i = 0; i < m->nr; i++)
        m->rows[i] = m->planar ? planar_rows[i] : i;
    m->nb = noise->gyro_bias > 0.0 ? 3 : 0;
    m->nu = m->nz + m->nr + SR_N_CONSIDER + m->nb;
    sr_standard_of_reported(z0, m->zO0);
    /* the prior: P0 on z_O, none on c0 (1e-12 keeps R invertible before the first rows: the
       momentum is unknown), the thrust errors' and gyro bias' own sds (an sd of 0: the
       unknown held at 0 by a prior information of 1e150) */
    int at = 0;
    for (int q = 0; q < m->nz; q++, at++) {
        m->prior_sqrt[at] = 1.0 / sqrt(m->zi[q] % 10 < 4 ? P0_mu : P0_theta);
        m->u0[at] = m->zO0[m->zi[q]];
    }
    for (int q = 0; q < m->nr; q++, at++)
        m->prior_sqrt[at] = 1e-12;
    for (int q = 0; q < SR_N_CONSIDER; q++, at++)
        m->prior_sqrt[at] = noise->thrust[q] > 0.0 ? 1.0 / noise->thrust[q] : 1e150;
    for (int q = 0; q < m->nb; q++, at++)
        m->prior_sqrt[at] = 1.0 / noise->gyro_bias;
    m->fit.lags = 50;
    m->fit.whiteness_max = 30.0;
    m->fit.chi2_max = 2.0;
    m->fit.thrust_max = 3.0;
    return 0;
}

void sr_info_data_init(const sr_info_model *m, sr_info_data *d)
{
    if (!m || !d)
        return;
    memset(d, 0, sizeof *d);
    for (int i = 0; i < m->nu; i++) {
        d->R[i * MU + i] = m->prior_sqrt[i];
        d->d[i] = m->prior_sqrt[i] * m->u0[i];
    }
}

/* The momentum equations of x as rows linear in the standard parameters z_O (20): full
   (6 x 20) z_O = y (6), exactly. Linear rows A mu = b; angular rows phi theta_O - psi_lin
   [m, c] = y: the quadratic part of psi D(mu) is -phi P times c_i c_j / m (the parallel-axis
   terms), which the inertias about the frames' origins absorb. */
static void rows_full(const sr_info_model *m, const double *x, double full[6][20], double *y)
{
    double E[3 * SR_N_COLS];
    sr_equations(&m->robot, 0, x, E);
    memset(full, 0, sizeof(double) * 6 * 20);
    for (int i = 0; i < 3; i++) {
        const double *e = E + i * SR_N_COLS;
        for (int k = 0; k < 2; k++) {
            for (int j = 0; j < 4; j++) {
                full[i][10 * k + j] = e[SR_COL_A + 4 * k + j];
                full[3 + i][10 * k + j] = -e[SR_COL_PSI + 10 * k + j];
            }
            for (int j = 0; j < 6; j++)
                full[3 + i][10 * k + 4 + j] = e[SR_COL_PHI + 6 * k + j];
        }
        y[i] = e[SR_COL_B];
        y[3 + i] = e[SR_COL_Y];
    }
}

/* the used rows' residuals full z_O - y of x at z_O (20) */
static void rows_at(const sr_info_model *m, const double *x, const double *zO, double *r)
{
    double full[6][20], y[6];
    rows_full(m, x, full, y);
    for (int a = 0; a < m->nr; a++) {
        int row = m->rows[a];
        double v = -y[row];
        for (int j = 0; j < 20; j++)
            v += full[row][j] * zO[j];
        r[a] = v;
    }
}

/* The rows H u = y of x exactly (H: nr x nu, row stride HS; the gyro bias columns not
   written): rows_full's, minus c0 and the thrust errors' sensitivities on the left; the
   unidentified z (planar) at their guesses move to y. k: the thrust integrals (15). */
static void linear_rows(const sr_info_model *m, const double *x, const double *k, double *H,
                        double *y)
{
    double full[6][20], yf[6], S[3 * SR_N_CCOLS];
    rows_full(m, x, full, yf);
    sr_thrust_sensitivity(0, x, m->n, k, S);
    int used[20] = {0};
    for (int q = 0; q < m->nz; q++)
        used[m->zi[q]] = 1;
    for (int a = 0; a < m->nr; a++) {
        int row = m->rows[a];
        double *h = H + a * HS;
        memset(h, 0, sizeof(double) * m->nu);
        for (int q = 0; q < m->nz; q++)
            h[q] = full[row][m->zi[q]];
        h[m->nz + a] = -1.0;                                  /* c0 */
        const double *s = S + (row % 3) * SR_N_CCOLS + (row < 3 ? 0 : SR_N_CONSIDER);
        for (int j = 0; j < SR_N_CONSIDER; j++)
            h[m->nz + m->nr + j] = -s[j];                      /* d (b, y) / d c */
        double v = yf[row];
        for (int j = 0; j < 20; j++)
            if (!used[j])
                v -= full[row][j] * m->zO0[j];
        y[a] = v;
    }
}

/* the channels whose white noise enters the rows linearly (not the attitude): index, sd */
static int channels(const sr_info_model *m, int *idx, double *sd)
{
    int c = 0, n = m->n;
    const struct { int at, count; double sd; } g[5] = {
        {SR_X_R_S, 3, m->noise.r}, {SR_X_V_S, 3, m->noise.v}, {SR_X_OMEGA_B, 3, m->noise.omega},
        {SR_X_QD(n), n, m->noise.qd}, {SR_X_Q, n, m->noise.q}};
    for (int k = 0; k < 5; k++)
        for (int i = 0; i < g[k].count && g[k].sd > 0.0; i++) {
            idx[c] = g[k].at + i;
            sd[c++] = g[k].sd;
        }
    return c;
}

/* The model error as noise of the rows (where the replay found a misfit): momentum the rigid
   model lacks, P_f (linear, variance me_var[0] per axis) and L_f (angular about the base point,
   me_var[1]), white and isotropic, enters the rows about the origin as [P_f; L_f + r_S x P_f]:
   Rk += [[s_P I, s_P [r]x^T], [s_P [r]x, s_L I + s_P [r]x [r]x^T]] (the used rows) */
static void add_model_error(const sr_info_model *m, const double *x, const double *me_var,
                            double *Rk)
{
    if (!(me_var[0] > 0.0 || me_var[1] > 0.0))
        return;
    const double *r = x + SR_X_R_S;
    double Rx[9] = {0, -r[2], r[1], r[2], 0, -r[0], -r[1], r[0], 0}, C[36];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double rr = 0.0;
            for (int k = 0; k < 3; k++)
                rr += Rx[i * 3 + k] * Rx[j * 3 + k];
            C[i * 6 + j] = i == j ? me_var[0] : 0.0;
            C[(3 + i) * 6 + j] = me_var[0] * Rx[i * 3 + j];
            C[i * 6 + 3 + j] = me_var[0] * Rx[j * 3 + i];
            C[(3 + i) * 6 + 3 + j] = (i == j ? me_var[1] : 0.0) + me_var[0] * rr;
        }
    for (int a = 0; a < m->nr; a++)
        for (int b = 0; b < m->nr; b++)
            Rk[a * 6 + b] += C[m->rows[a] * 6 + m->rows[b]];
}

/* Rk (stride 6) += the covariance of the navigation noises' product. The angular rows hold
   r_S x m v_S, bilinear in (r_S, v_S): beside the first-order terms they carry dr x m dv, of
   zero mean (dr, dv independent) and covariance sd_r^2 sd_v^2 sum_ij g_ij g_ij^T with g_ij
   the mixed difference of the rows in r_i, v_j (exact with unit steps: bilinear). The
   first-order terms leave the angular rows almost noise-free across r and v, where this term
   is of the gyro's size: without it a fast-tumbling target's sds were too small
   (benchmarks/CALIBRATION.md). xs: a copy of x, restored on return. */
static void product_noise(const sr_info_model *m, const double *x, const double *z, double *xs,
                          double *Rk)
{
    const double s2 = m->noise.r * m->noise.r * m->noise.v * m->noise.v;
    if (!(s2 > 0.0))
        return;
    int nr = m->nr;
    double r0[6], ri[3][6], vj[3][6], rij[6];
    rows_at(m, x, z, r0);
    for (int i = 0; i < 3; i++) {
        xs[SR_X_R_S + i] = x[SR_X_R_S + i] + 1.0;
        rows_at(m, xs, z, ri[i]);
        xs[SR_X_R_S + i] = x[SR_X_R_S + i];
        xs[SR_X_V_S + i] = x[SR_X_V_S + i] + 1.0;
        rows_at(m, xs, z, vj[i]);
        xs[SR_X_V_S + i] = x[SR_X_V_S + i];
    }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double g[6];
            xs[SR_X_R_S + i] = x[SR_X_R_S + i] + 1.0;
            xs[SR_X_V_S + j] = x[SR_X_V_S + j] + 1.0;
            rows_at(m, xs, z, rij);
            xs[SR_X_R_S + i] = x[SR_X_R_S + i];
            xs[SR_X_V_S + j] = x[SR_X_V_S + j];
            for (int a = 0; a < nr; a++)
                g[a] = rij[a] - ri[i][a] - vj[j][a] + r0[a];
            for (int a = 0; a < nr; a++)
                for (int b = 0; b < nr; b++)
                    Rk[a * 6 + b] += s2 * g[a] * g[b];
        }
}

/* R_k^-1/2 (lower triangular nr x nr) of the rows' noise covariance at x, z: the channels'
   white noise through central differences of the rows, the attitude's as small rotations
   about the base axes; 0, or 1 when R_k is not positive definite */
static int noise_weight(const sr_info_model *m, const double *x, const double *z,
                        const double *me_var, double *W)
{
    int nr = m->nr, idx[12 + 2 * SR_MAX_JOINTS];
    double sd[12 + 2 * SR_MAX_JOINTS], Rk[36] = {0}, xs[SR_X_LEN(SR_MAX_JOINTS)];
    double rp[6], rm[6], g[6];
    int nx = SR_X_LEN(m->n);
    memcpy(xs, x, sizeof(double) * nx);
    int nc = channels(m, idx, sd);
    for (int c = 0; c < nc; c++) {
        const double h = 1e-4;
        int i = idx[c];
        xs[i] = x[i] + h;
        rows_at(m, xs, z, rp);
        xs[i] = x[i] - h;
        rows_at(m, xs, z, rm);
        xs[i] = x[i];
        for (int a = 0; a < nr; a++)
            g[a] = (rp[a] - rm[a]) / (2 * h);
        for (int a = 0; a < nr; a++)
            for (int b = 0; b < nr; b++)
                Rk[a * 6 + b] += sd[c] * sd[c] * g[a] * g[b];
    }
    for (int i = 0; i < 3; i++) {                   /* the star tracker: A R(w) */
        if (!(m->noise.att[i] > 0.0))
            continue;
        const double h = 1e-5;
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            /* R(w) for w = sgn h e_i: rotation by sgn h about axis i */
            double Rw[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, c, s;
            sr_sincos(h, &s, &c);                   /* the portable one: same bits anywhere */
            s *= sgn;
            int j = (i + 1) % 3, k = (i + 2) % 3;
            Rw[j * 3 + j] = c;
            Rw[k * 3 + k] = c;
            Rw[k * 3 + j] = s;
            Rw[j * 3 + k] = -s;
            for (int r = 0; r < 3; r++)
                for (int col = 0; col < 3; col++) {
                    double v = 0.0;
                    for (int l = 0; l < 3; l++)
                        v += x[SR_X_A_B + 3 * r + l] * Rw[3 * l + col];
                    xs[SR_X_A_B + 3 * r + col] = v;
                }
            rows_at(m, xs, z, sgn > 0 ? rp : rm);
        }
        memcpy(xs + SR_X_A_B, x + SR_X_A_B, sizeof(double) * 9);
        double s2 = m->noise.att[i] * m->noise.att[i];
        for (int a = 0; a < nr; a++)
            g[a] = (rp[a] - rm[a]) / (2 * h);
        for (int a = 0; a < nr; a++)
            for (int b = 0; b < nr; b++)
                Rk[a * 6 + b] += s2 * g[a] * g[b];
    }
    product_noise(m, x, z, xs, Rk);
    add_model_error(m, x, me_var, Rk);
    double tr = 0.0;
    for (int a = 0; a < nr; a++)
        tr += Rk[a * 6 + a];
    if (!(tr > 0.0) || !isfinite(tr))
        return 1;
    /* a floor for rows the noise misses: tiny, since the near-null directions of R_k are real
       information (a floor of 1e-6 of the trace instead made the errors several times worse) */
    for (int a = 0; a < nr; a++)
        Rk[a * 6 + a] += 1e-12 * tr / nr;
    /* Cholesky L L^T = Rk (linalg), then W = L^-1 (lower triangular) */
    double L[36];
    for (int a = 0; a < nr; a++)
        for (int b = 0; b < nr; b++)
            L[a * nr + b] = Rk[a * 6 + b];
    if (sr_cholesky(L, nr) != 0)
        return 1;
    memset(W, 0, sizeof(double) * 36);
    for (int col = 0; col < nr; col++) {
        W[col * nr + col] = 1.0 / L[col * nr + col];
        for (int a = col + 1; a < nr; a++) {
            double s = 0.0;
            for (int l = col; l < a; l++)
                s += L[a * nr + l] * W[l * nr + col];
            W[a * nr + col] = -s / L[a * nr + a];
        }
    }
    return 0;
}

/* the sum of the filter's numbers (R, d, N_HH, N_Hy over nu unknowns; the thrust integrals
   K): finite iff every one of them is */
static double numbers_sum(int nu, const double *R, const double *d, const double *N_HH,
                          const double *N_Hy, const double *K)
{
    double s = 0.0;
    for (int i = 0; i < nu; i++) {
        s += d[i] + N_Hy[i];
        for (int j = 0; j < nu; j++)
            s += R[i * MU + j] + N_HH[i * MU + j];
    }
    for (int i = 0; i < SR_THRUST_LEN; i++)
        s += K[i];
    return s;
}

/* entry (p, q) of the inverse information S^-1 = Ri Ri^T (Ri = R^-1 upper triangular, nu) */
static double inverse_entry(const double *Ri, int nu, int p, int q)
{
    double s = 0.0;
    for (int j = (p > q ? p : q); j < nu; j++)
        s += Ri[p * MU + j] * Ri[q * MU + j];
    return s;
}

/* out (nr x ncol, row stride HS) = W (nr x nr lower) times in (same shape) */
static void weigh(const double *W, int nr, const double *in, int ncol, double *out)
{
    for (int a = nr - 1; a >= 0; a--)
        for (int j = 0; j < ncol; j++) {
            double s = 0.0;
            for (int b = 0; b <= a; b++)
                s += W[a * nr + b] * in[b * HS + j];
            out[a * HS + j] = s;
        }
}

/* The whiteness test's ring and sums with the sample's whitened residual rows e (nr): the
   rows the QR update leaves, ||e||^2 its rss increment, e about W (y - H u) at the estimate
   before the sample (the update's reflections barely touch the new rows once R is large),
   independent N(0, 1) where the model and the noise model hold */
static void fit_ring_add(const sr_info_model *m, sr_info_data *d, const double *e)
{
    int L = m->fit.lags, cap = L + 1, nr = m->nr;
    if (L < 1 || L > SR_INFO_MAX_LAGS || d->fit_head < 0 || d->fit_head >= cap)
        return;
    memcpy(d->fit_ring + 6 * d->fit_head, e, sizeof(double) * nr);
    int stored = d->fit_count < cap ? d->fit_count + 1 : cap;
    for (int k = 0; k < stored; k++) {       /* sum_t e_t e_(t-k): this row against k back */
        const double *back = d->fit_ring + 6 * ((d->fit_head - k + cap) % cap);
        for (int a = 0; a < nr; a++)
            d->fit_sum[6 * k + a] += e[a] * back[a];
    }
    d->fit_head = (d->fit_head + 1) % cap;
    if (d->fit_count < INT_MAX)
        d->fit_count++;
}

int sr_info_add(const sr_info_model *m, sr_info_data *d, double t, const double *x,
                const double *z_lin, sr_info_work *w)
{
    if (!m || !d || !x || !z_lin || !w || !(z_lin[0] > 0.0) || !(z_lin[10] > 0.0))
        return 1;
    if (!isfinite(t) || (d->samples > 0 && !(t > d->K[SR_THRUST_T])))
        return 1;                      /* the thrust integrals need increasing times */
    int nr = m->nr, nu = m->nu, nz = m->nz, n = m->n;
    double K[SR_THRUST_LEN], W[36], z[20];
    memcpy(K, d->K, sizeof K);
    sr_thrust_integrals_add(K, d->samples == 0, t, x + SR_X_R_S, x + SR_X_F(n), x + SR_X_M(n));
    sr_standard_of_reported(z_lin, z);              /* the linearisation point's z_O */
    if (noise_weight(m, x, z, d->me_var, W) != 0)    /* every sample */
        return 1;
    /* the rows and their right-hand side in one block: H (nr x nu) | y in column nu */
    double Hy[6 * HS], r0[6], rb[6], xs[SR_X_LEN(SR_MAX_JOINTS)], y[6];
    memset(Hy, 0, sizeof Hy);
    linear_rows(m, x, K + SR_THRUST_K, Hy, y);
    int nx = SR_X_LEN(n);
    memcpy(xs, x, sizeof(double) * nx);
    if (m->nb) {                       /* the gyro reads omega + b: the rows' d / d b */
        rows_at(m, x, z, r0);
        for (int i = 0; i < 3; i++) {
            xs[SR_X_OMEGA_B + i] = x[SR_X_OMEGA_B + i] + 1.0;   /* the rows are linear in it */
            rows_at(m, xs, z, rb);
            xs[SR_X_OMEGA_B + i] = x[SR_X_OMEGA_B + i];
            for (int a = 0; a < nr; a++)
                Hy[a * HS + nu - 3 + i] = -(rb[a] - r0[a]);
        }
    }
    for (int a = 0; a < nr; a++)
        Hy[a * HS + nu] = y[a];
    double Wt[6 * HS];
    weigh(W, nr, Hy, nu + 1, Wt);
    /* errors in variables: N += sum_l sigma_l^2 (W dH_l)^T (W [dH_l dy_l]) */
    double *N_HH = w->N_HH, N_Hy[MU];        /* the new sums, committed when finite */
    memcpy(N_HH, d->N_HH, sizeof d->N_HH);
    memcpy(N_Hy, d->N_Hy, sizeof N_Hy);
    int idx[12 + 2 * SR_MAX_JOINTS];
    double sd[12 + 2 * SR_MAX_JOINTS];
    int nc = channels(m, idx, sd);
    for (int c = 0; c < nc; c++) {
        int i = idx[c];
        double h = 1e-4 * (fabs(x[i]) > 1.0 ? fabs(x[i]) : 1.0);
        double Hp[6 * HS], yp[6], dH[6 * HS], wdH[6 * HS];
        memset(Hp, 0, sizeof Hp);
        xs[i] = x[i] + h;
        linear_rows(m, xs, K + SR_THRUST_K, Hp, yp);
        xs[i] = x[i];
        for (int a = 0; a < nr; a++) {
            for (int j = 0; j < nz; j++)     /* only z_O's columns move with the channels */
                dH[a * HS + j] = (Hp[a * HS + j] - Hy[a * HS + j]) / h;
            for (int j = nz; j < nu; j++)
                dH[a * HS + j] = 0.0;
            dH[a * HS + nu] = (yp[a] - y[a]) / h;
        }
        weigh(W, nr, dH, nu + 1, wdH);
        double s2 = sd[c] * sd[c];
        for (int p = 0; p < nz; p++)
            for (int q = 0; q < nz; q++) {
                double s = 0.0;
                for (int a = 0; a < nr; a++)
                    s += wdH[a * HS + p] * wdH[a * HS + q];
                N_HH[p * MU + q] += s2 * s;
            }
        for (int p = 0; p < nz; p++) {
            double s = 0.0;
            for (int a = 0; a < nr; a++)
                s += wdH[a * HS + p] * wdH[a * HS + nu];
            N_Hy[p] += s2 * s;
        }
    }
    /* the QR update of [[R d]; [W H  W y]] (Householder, column by column: R's rows below
       the diagonal are zero, so each reflection touches R's row j and the nr new rows) */
    double *R = w->R, dv[MU], v[6];
    memcpy(R, d->R, sizeof d->R);
    memcpy(dv, d->d, sizeof dv);
    for (int j = 0; j < nu; j++) {
        double sigma = 0.0, alpha = R[j * MU + j];
        for (int a = 0; a < nr; a++)
            sigma += Wt[a * HS + j] * Wt[a * HS + j];
        if (sigma == 0.0)
            continue;
        double norm = sqrt(alpha * alpha + sigma);
        double beta = alpha >= 0.0 ? -norm : norm;
        double v0 = alpha - beta, tau = (beta - alpha) / beta;
        for (int a = 0; a < nr; a++)
            v[a] = Wt[a * HS + j] / v0;
        for (int k = j + 1; k <= nu; k++) {
            double *rk = k < nu ? &R[j * MU + k] : &dv[j];
            double s = *rk;
            for (int a = 0; a < nr; a++)
                s += v[a] * Wt[a * HS + k];
            s *= tau;
            *rk -= s;
            for (int a = 0; a < nr; a++)
                Wt[a * HS + k] -= s * v[a];
        }
        R[j * MU + j] = beta;
        for (int a = 0; a < nr; a++)
            Wt[a * HS + j] = 0.0;
    }
    double rss = d->rss;
    for (int a = 0; a < nr; a++)
        rss += Wt[a * HS + nu] * Wt[a * HS + nu];
    if (!isfinite(numbers_sum(nu, R, dv, N_HH, N_Hy, K) + rss))   /* commit finite only */
        return 1;
    memcpy(d->R, R, sizeof d->R);
    memcpy(d->d, dv, sizeof dv);
    memcpy(d->N_HH, N_HH, sizeof d->N_HH);
    memcpy(d->N_Hy, N_Hy, sizeof N_Hy);
    memcpy(d->K, K, sizeof K);
    d->rss = rss;
    d->rows += nr;
    double e[6];
    for (int a = 0; a < nr; a++)
        e[a] = Wt[a * HS + nu];
    fit_ring_add(m, d, e);
    if (d->samples < INT_MAX)                        /* saturates (~7 years at 10 Hz) */
        d->samples++;
    return 0;
}

/* the reported parameters (20) of the identified z_O entries u (nz) */
static void reported_of_u(const sr_info_model *m, const double *u, double *x)
{
    double z[20];
    memcpy(z, m->zO0, sizeof z);
    for (int q = 0; q < m->nz; q++)
        z[m->zi[q]] = u[q];
    sr_reported_of_standard(z, x);
}

/* Ri = R^-1 (R upper triangular nu x nu with a nonzero diagonal, row stride MU; Ri upper) */
static void upper_inverse(const double *R, int nu, double *Ri)
{
    memset(Ri, 0, sizeof(double) * MU * MU);
    for (int col = 0; col < nu; col++) {
        Ri[col * MU + col] = 1.0 / R[col * MU + col];
        for (int i = col - 1; i >= 0; i--) {
            double s = 0.0;
            for (int j = i + 1; j <= col; j++)
                s += R[i * MU + j] * Ri[j * MU + col];
            Ri[i * MU + col] = -s / R[i * MU + i];
        }
    }
}

/* The first-order Cramér-Rao bound (20; 0 for a parameter not identified) of the reported
 * parameters: J C J^T, C = (Ri Ri^T)[:nz, :nz] (Ri: nu unknowns) the covariance of z_O's
 * entries (the leading unknowns) plus, where G (nz x 8; may be NULL) is given, the consider
 * term G P_c G^T of the thrust errors' prior (sds 1 / prior_sqrt), J = d reported / d z_O at
 * the unknowns u (their identified columns). 1 where a bound is not finite. */
static INFO_NOINLINE int bound_with(const sr_info_model *m, int nu, const double *Ri,
                                    const double *G, const double *u, double *bound)
{
    int nz = m->nz, i1 = m->nz + m->nr;
    double C[20 * 20], J[20 * 20], Jz[20 * 20], zO[20];
    for (int p = 0; p < nz; p++)
        for (int q = 0; q <= p; q++) {
            double s = inverse_entry(Ri, nu, p, q);
            for (int j = 0; G && j < SR_N_CONSIDER; j++) {
                double sd = 1.0 / m->prior_sqrt[i1 + j];
                s += G[p * SR_N_CONSIDER + j] * sd * sd * G[q * SR_N_CONSIDER + j];
            }
            C[p * 20 + q] = C[q * 20 + p] = s;
        }
    memcpy(zO, m->zO0, sizeof zO);
    for (int q = 0; q < nz; q++)
        zO[m->zi[q]] = u[q];
    sr_reported_jacobian(zO, Jz);
    for (int i = 0; i < 20; i++)
        for (int q = 0; q < nz; q++)
            J[i * 20 + q] = Jz[i * 20 + m->zi[q]];
    int ok = 1;
    for (int i = 0; i < 20; i++) {
        double var = 0.0, touched = 0.0;
        for (int p = 0; p < nz; p++) {
            double s = 0.0;
            for (int q = 0; q < nz; q++)
                s += C[p * 20 + q] * J[i * 20 + q];
            var += J[i * 20 + p] * s;
            touched += fabs(J[i * 20 + p]);
        }
        bound[i] = touched > 0.0 ? sqrt(var > 0.0 ? var : 0.0) : 0.0;
        if (!isfinite(bound[i]))
            ok = 0;
    }
    return ok ? 0 : 1;
}

static int bound_of(const sr_info_model *m, const double *Ri, const double *u, double *bound)
{
    return bound_with(m, m->nu, Ri, NULL, u, bound);
}

/* The unknowns u (nu) of the square-root information [R dv] (nu unknowns, the z_O entries
   first; N_HH, N_Hy the errors-in-variables sums over them: zero beyond z_O), compensated as
   sr_info_estimate, and Ri = R^-1 */
static INFO_NOINLINE void solve_square_root(int nu, const double *R, const double *dv,
                                            const double *N_HH, const double *N_Hy,
                                            int compensated, double *u, double *Ri)
{
    /* R u = d (back substitution); Ri = R^-1 (upper triangular) */
    for (int i = nu - 1; i >= 0; i--) {
        double s = dv[i];
        for (int j = i + 1; j < nu; j++)
            s -= R[i * MU + j] * u[j];
        u[i] = s / R[i * MU + i];
    }
    upper_inverse(R, nu, Ri);
    double u_raw[MU];
    memcpy(u_raw, u, sizeof(double) * nu);
    if (compensated == 1 || compensated == 2) {  /* first order: u + S^-1 (N u - n_y) */
        double g[MU], h[MU];
        for (int p = 0; p < nu; p++) {
            double s = -N_Hy[p];
            for (int q = 0; q < nu; q++)
                s += N_HH[p * MU + q] * u[q];
            g[p] = s;
        }
        for (int j = 0; j < nu; j++) {           /* h = Ri^T g */
            double s = 0.0;
            for (int p = 0; p <= j; p++)
                s += Ri[p * MU + j] * g[p];
            h[j] = s;
        }
        for (int p = 0; p < nu; p++) {           /* u += Ri h */
            double s = 0.0;
            for (int j = p; j < nu; j++)
                s += Ri[p * MU + j] * h[j];
            u[p] += s;
        }
    }
    if (compensated == 2) {        /* exact: (S - N) u_c = s - n_y, as (1 - S^-1 N) u_c =
                                      u - S^-1 n_y (S^-1 = Ri Ri^T: no normal equations; its
                                      rows one at a time) */
        double Si[MU], A[MU * MU], b[MU];
        for (int p = 0; p < nu; p++) {
            for (int q = 0; q < nu; q++)
                Si[q] = inverse_entry(Ri, nu, p, q);
            double s = u_raw[p];
            for (int q = 0; q < nu; q++)
                s -= Si[q] * N_Hy[q];
            b[p] = s;
            for (int q = 0; q < nu; q++) {
                double a = p == q ? 1.0 : 0.0;
                for (int j = 0; j < nu; j++)
                    a -= Si[j] * N_HH[j * MU + q];
                A[p * nu + q] = a;
            }
        }
        int finite = sr_lu_solve(A, nu, b, 1) == 0;
        for (int p = 0; p < nu; p++)
            finite = finite && isfinite(b[p]);
        if (finite)                  /* else the first order's answer stays */
            memcpy(u, b, sizeof(double) * nu);
    }
}

/* The unknowns u (nu) of the state d (compensated as sr_info_estimate) and Ri = R^-1 */
static void solve_unknowns(const sr_info_model *m, const sr_info_data *d, int compensated,
                           double *u, double *Ri)
{
    solve_square_root(m->nu, d->R, d->d, d->N_HH, d->N_Hy, compensated, u, Ri);
}

int sr_info_estimate(const sr_info_model *m, const sr_info_data *d, int compensated,
                     double *vec, double *bound, double *chi2)
{
    if (!m || !d || !vec || !bound)
        return 1;
    double u[MU] = {0}, Ri[MU * MU];
    solve_unknowns(m, d, compensated, u, Ri);
    reported_of_u(m, u, vec);
    int ok = bound_of(m, Ri, u, bound) == 0;
    for (int i = 0; i < 20; i++)
        if (!isfinite(vec[i]))
            ok = 0;
    if (chi2) {
        double dof = d->rows - m->nu;
        *chi2 = dof > 0.0 ? d->rss / dof : 0.0;
    }
    if (!ok) {
        for (int i = 0; i < 20; i++)
            vec[i] = bound[i] = NAN;
        return 1;
    }
    return 0;
}

/* -- the thrust errors held at their priors ---------------------------------------------------
 * The unknowns are u = [u1 = (z_O, c0), c (8), b (nb)], R = [[R11 R12 R13], [0 R22 R23],
 * [0 0 R33]]. With c held at its prior mean c_T: R11 u1 + R13 b = d1 - R12 c_T and, in the
 * least-squares sense, [R23; R33] b = [d2 - R22 c_T; d3]: a QR of that (8 + nb) x nb block
 * gives the held square root Rh = [[R11 R13], [0 R33']] (no = nu - 8 unknowns, the z_O entries
 * first as before), its right-hand side dh, the rhs' sensitivity Dh = d dh / d c_T (no x 8,
 * for the consider term C_c = G P_c G^T, G = Rh^-1 Dh) and the weighted residual the hold adds
 * (the QR's leftover rows: the cost J(u) = ||R u - d||^2 + rss at the held answer). */
typedef struct held_sr {
    int no;
    double R[MU * MU], d[MU], D[MU * SR_N_CONSIDER], extra;
} held_sr;

static void held_square_root(const sr_info_model *m, const sr_info_data *d, held_sr *h)
{
    int nu = m->nu, i1 = m->nz + m->nr, i3 = i1 + SR_N_CONSIDER, nb = m->nb;
    const double *cT = m->u0 + i1;
    h->no = nu - SR_N_CONSIDER;
    memset(h->R, 0, sizeof h->R);
    for (int i = 0; i < i1; i++) {            /* block 1: R11, R13; d1 - R12 c_T; -R12 */
        double r = d->d[i];
        for (int j = 0; j < SR_N_CONSIDER; j++) {
            r -= d->R[i * MU + i1 + j] * cT[j];
            h->D[i * SR_N_CONSIDER + j] = -d->R[i * MU + i1 + j];
        }
        h->d[i] = r;
        for (int j = i; j < i1; j++)
            h->R[i * MU + j] = d->R[i * MU + j];
        for (int j = 0; j < nb; j++)
            h->R[i * MU + i1 + j] = d->R[i * MU + i3 + j];
    }
    /* blocks 2, 3 as rows [coefficients of b (nb) | rhs | d rhs / d c_T (8)] */
    enum { NC = 3 + 1 + SR_N_CONSIDER, NRW = SR_N_CONSIDER + 3 };
    double B[NRW * NC];
    int nrw = SR_N_CONSIDER + nb;
    memset(B, 0, sizeof B);
    for (int a = 0; a < nrw; a++) {
        int row = a < SR_N_CONSIDER ? i1 + a : i3 + (a - SR_N_CONSIDER);
        double r = d->d[row];
        for (int j = 0; j < SR_N_CONSIDER && a < SR_N_CONSIDER; j++) {
            r -= d->R[row * MU + i1 + j] * cT[j];
            B[a * NC + nb + 1 + j] = -d->R[row * MU + i1 + j];
        }
        for (int j = 0; j < nb; j++)
            B[a * NC + j] = d->R[row * MU + i3 + j];
        B[a * NC + nb] = r;
    }
    for (int j = 0; j < nb; j++) {            /* Householder QR of the b columns */
        double norm = 0.0;
        for (int a = j; a < nrw; a++)
            norm += B[a * NC + j] * B[a * NC + j];
        norm = sqrt(norm);
        if (norm == 0.0)
            continue;
        double alpha = B[j * NC + j], beta = alpha >= 0.0 ? -norm : norm, v[NRW];
        for (int a = j; a < nrw; a++)
            v[a] = B[a * NC + j];
        v[j] = alpha - beta;
        double vv = 0.0;
        for (int a = j; a < nrw; a++)
            vv += v[a] * v[a];
        for (int k = j; k < nb + 1 + SR_N_CONSIDER; k++) {
            double s = 0.0;
            for (int a = j; a < nrw; a++)
                s += v[a] * B[a * NC + k];
            s *= 2.0 / vv;
            for (int a = j; a < nrw; a++)
                B[a * NC + k] -= s * v[a];
        }
    }
    for (int a = 0; a < nb; a++) {
        for (int j = a; j < nb; j++)
            h->R[(i1 + a) * MU + i1 + j] = B[a * NC + j];
        h->d[i1 + a] = B[a * NC + nb];
        for (int j = 0; j < SR_N_CONSIDER; j++)
            h->D[(i1 + a) * SR_N_CONSIDER + j] = B[a * NC + nb + 1 + j];
    }
    h->extra = 0.0;
    for (int a = nb; a < nrw; a++)
        h->extra += B[a * NC + nb] * B[a * NC + nb];
}

/* the held estimate and bound (sr_info_estimate_held) of h: 0, or 1 where not finite */
static INFO_NOINLINE int held_estimate(const sr_info_model *m, const sr_info_data *d,
                                       const held_sr *h, int compensated, double *vec,
                                       double *bound)
{
    int no = h->no, nz = m->nz;
    double u[MU] = {0}, Ri[MU * MU], G[20 * SR_N_CONSIDER];
    solve_square_root(no, h->R, h->d, d->N_HH, d->N_Hy, compensated, u, Ri);
    reported_of_u(m, u, vec);
    for (int p = 0; p < nz; p++)              /* G = Rh^-1 Dh (the z_O rows) */
        for (int j = 0; j < SR_N_CONSIDER; j++) {
            double s = 0.0;
            for (int k = p; k < no; k++)
                s += Ri[p * MU + k] * h->D[k * SR_N_CONSIDER + j];
            G[p * SR_N_CONSIDER + j] = s;
        }
    int ok = bound_with(m, no, Ri, G, u, bound) == 0;
    for (int i = 0; i < 20; i++)
        ok = ok && isfinite(vec[i]);
    return ok ? 0 : 1;
}

int sr_info_estimate_held(const sr_info_model *m, const sr_info_data *d, int compensated,
                          double *vec, double *bound, double *chi2, double *rss_held)
{
    if (!m || !d || !vec || !bound)
        return 1;
    held_sr h;
    held_square_root(m, d, &h);
    double rss = d->rss + h.extra, dof = d->rows - h.no;
    if (chi2)
        *chi2 = dof > 0.0 ? rss / dof : 0.0;
    if (rss_held)
        *rss_held = rss;
    if (held_estimate(m, d, &h, compensated, vec, bound) != 0) {
        for (int i = 0; i < 20; i++)
            vec[i] = bound[i] = NAN;
        return 1;
    }
    return 0;
}

/* the larger thrust scale's |s| / prior sd of the state d (the unknowns with the thrust
   estimated; 0 without a thrust prior), or NaN where the information is singular */
static INFO_NOINLINE double thrust_ratio(const sr_info_model *m, const sr_info_data *d)
{
    double u[MU] = {0}, Ri[MU * MU], ratio = 0.0;
    solve_unknowns(m, d, 2, u, Ri);
    static const int scales[2] = {0, 4};     /* s_F, s_M of c (sr_thrust_sensitivity) */
    for (int k = 0; k < 2; k++) {
        double sd = m->noise.thrust[scales[k]], s = u[m->nz + m->nr + scales[k]];
        if (sd > 0.0)
            ratio = (fabs(s) / sd > ratio ? fabs(s) / sd : ratio);
        if (!isfinite(s))
            return NAN;
    }
    return ratio;
}

/* the Ljung-Box Q / L of the whitened residuals, per row and averaged over the rows:
   Q = N (N + 2) sum_(k=1..L) r_k^2 / (N - k), r_k = sum_t e_t e_(t-k) / sum_t e_t^2 (about
   chi2(L) for white residuals, Q / L about 1); 0 before 2 L rows */
static double whiteness(const sr_info_model *m, const sr_info_data *d)
{
    int L = m->fit.lags, nr = m->nr;
    double N = d->fit_count, q = 0.0;
    if (L < 1 || !(N >= 2.0 * L))
        return 0.0;
    for (int a = 0; a < nr; a++) {
        double v = d->fit_sum[a], s = 0.0;
        if (!(v > 0.0))
            continue;
        for (int k = 1; k <= L; k++) {
            double r = d->fit_sum[6 * k + a] / v;
            s += r * r / (N - k);
        }
        q += N * (N + 2.0) * s / L;
    }
    return q / nr;
}

/* sr_info_fit_of (m, d, f given) */
static int fit_test(const sr_info_model *m, const sr_info_data *d, sr_info_fit *f)
{
    double dof = d->rows - m->nu;
    f->whiteness = whiteness(m, d);
    f->chi2 = dof > 0.0 ? d->rss / dof : 0.0;
    f->thrust = thrust_ratio(m, d);
    f->misfit = d->misfit;
    if (!isfinite(f->thrust)) {
        f->thrust = 0.0;
        return 1;
    }
    /* coloured residuals count where they are of the noise's size at least (chi2 > 1/2):
       far below it (data less noisy than its model) their colour is the round-off's */
    int coloured = f->whiteness > m->fit.whiteness_max && f->chi2 > 0.5;
    f->misfit = d->misfit || (d->replayed && (coloured || f->chi2 > m->fit.chi2_max
                                              || f->thrust > m->fit.thrust_max));
    return 0;
}

int sr_info_fit_of(const sr_info_model *m, const sr_info_data *d, sr_info_fit *f)
{
    if (!m || !d || !f)
        return 1;
    return fit_test(m, d, f);
}

/* the filter's estimate as the report takes it: with the thrust held where the model does
   not fit */
static int estimate_as_fit(const sr_info_model *m, const sr_info_data *d, double *z,
                           double *bound)
{
    sr_info_fit f;
    if (sr_info_fit_of(m, d, &f) == 0 && f.misfit)
        return sr_info_estimate_held(m, d, 2, z, bound, NULL, NULL);
    return sr_info_estimate(m, d, 2, z, bound, NULL);
}

void sr_info_information(const sr_info_model *m, const sr_info_data *d, double *S)
{
    if (!m || !d || !S)
        return;
    int nu = m->nu;
    for (int p = 0; p < nu; p++)                 /* S = R^T R (R upper triangular) */
        for (int q = 0; q <= p; q++) {
            double s = 0.0;
            for (int k = 0; k <= q; k++)
                s += d->R[k * MU + p] * d->R[k * MU + q];
            S[p * MU + q] = S[q * MU + p] = s;
        }
}

int sr_info_predict(const sr_info_model *m, const sr_info_data *d, const double *dS,
                    double factor, double *bound, sr_info_work *w)
{
    if (!m || !d || !dS || !bound || !w || !(factor >= 0.0 && isfinite(factor))) {
        for (int i = 0; bound && i < 20; i++)
            bound[i] = NAN;
        return 1;
    }
    int nu = m->nu;
    double u[MU] = {0}, *Ri = w->Ri, *S = w->S, *R = w->R, *L = w->L;
    solve_unknowns(m, d, 2, u, Ri);              /* the point the bound is mapped at */
    sr_info_information(m, d, S);
    for (int p = 0; p < nu; p++)                 /* S + factor dS, packed nu x nu */
        for (int q = 0; q < nu; q++)
            L[p * nu + q] = S[p * MU + q] + factor * dS[p * MU + q];
    int fail = sr_cholesky(L, nu) != 0;          /* = L L^T: R = L^T, S = R^T R */
    if (!fail) {
        memset(R, 0, sizeof w->R);
        for (int p = 0; p < nu; p++)
            for (int q = p; q < nu; q++)
                R[p * MU + q] = L[q * nu + p];
        upper_inverse(R, nu, Ri);
        fail = bound_of(m, Ri, u, bound) != 0;
    }
    if (fail)
        for (int i = 0; i < 20; i++)
            bound[i] = NAN;
    return fail;
}

int sr_info_data_finite(const sr_info_model *m, const sr_info_data *d)
{
    if (!m || !d)
        return 0;
    double s = numbers_sum(m->nu, d->R, d->d, d->N_HH, d->N_Hy, d->K) + d->rss + d->rows;
    for (int i = 0; i < 20; i++)
        s += d->z_lin[i];
    return isfinite(s + d->me_var[0] + d->me_var[1]) && d->me_var[0] >= 0.0
           && d->me_var[1] >= 0.0;
}

size_t sr_info_buffer_length(int n)
{
    return n >= 1 && n <= SR_MAX_JOINTS ? (size_t)SR_INFO_REPLAY * (size_t)(1 + SR_X_LEN(n)) : 0;
}

/* the filter's own estimate as a linearisation point into z (20), or 1 where it is not one
   (not finite, a mass <= 0) */
static int own_point(const sr_info_model *m, const sr_info_data *d, double *z)
{
    double bound[20];
    if (estimate_as_fit(m, d, z, bound) != 0 || !(z[0] > 0.0 && z[10] > 0.0))
        return 1;
    return 0;
}

/* The model error's variances (sr_info_data.me_var) from the kept samples: the rows'
   residuals at the estimate z (reported, 20; the thrust errors at 0), the linear ones less
   their mean (the momentum c0) give P_f, the angular ones less r_S x that and their mean
   give L_f about the base point; their mean squares per used row */
static void model_error_of(const sr_info_model *m, const double *buffer, const double *z,
                           double *me_var)
{
    int slot = 1 + SR_X_LEN(m->n), nlin = 0, nang = 0;
    double zO[20], c[6] = {0}, s[2] = {0, 0};
    int used[6] = {0};
    for (int a = 0; a < m->nr; a++) {
        used[m->rows[a]] = 1;
        if (m->rows[a] < 3)
            nlin++;
        else
            nang++;
    }
    sr_standard_of_reported(z, zO);
    for (int pass = 0; pass < 3; pass++) {   /* mean of the linear; of the angular; squares */
        double acc[6] = {0};
        for (int k = 0; k < SR_INFO_REPLAY; k++) {
            const double *x = buffer + (size_t)k * (size_t)slot + 1, *r = x + SR_X_R_S;
            double full[6][20], y[6], e[6];
            rows_full(m, x, full, y);
            for (int i = 0; i < 6; i++) {
                e[i] = -y[i];
                for (int j = 0; j < 20; j++)
                    e[i] += full[i][j] * zO[j];
            }
            double p[3] = {e[0] - c[0], e[1] - c[1], e[2] - c[2]};
            double l[3] = {e[3] - (r[1] * p[2] - r[2] * p[1]) - c[3],
                           e[4] - (r[2] * p[0] - r[0] * p[2]) - c[4],
                           e[5] - (r[0] * p[1] - r[1] * p[0]) - c[5]};
            for (int i = 0; i < 3; i++) {
                if (pass == 0)
                    acc[i] += e[i];
                else if (pass == 1)
                    acc[3 + i] += l[i];
                else {
                    acc[0] += used[i] ? p[i] * p[i] : 0.0;
                    acc[1] += used[3 + i] ? l[i] * l[i] : 0.0;
                }
            }
        }
        for (int i = 0; i < 3 && pass < 2; i++)
            c[3 * pass + i] = acc[3 * pass + i] / SR_INFO_REPLAY;
        if (pass == 2) {
            s[0] = nlin ? acc[0] / (nlin * (double)SR_INFO_REPLAY) : 0.0;
            s[1] = nang ? acc[1] / (nang * (double)SR_INFO_REPLAY) : 0.0;
        }
    }
    me_var[0] = isfinite(s[0]) ? s[0] : 0.0;
    me_var[1] = isfinite(s[1]) ? s[1] : 0.0;
}

/* The replay into d: from the prior the kept samples and then x at t, linearised at z, with
   the model error's variances me_var (NULL: none; else the misfit kept); where a kept sample
   cannot be added, from before instead (no replay rather than no filter). 0, or 1 (d =
   before) where x cannot be added. */
static int replay(const sr_info_model *m, const sr_info_data *before, sr_info_data *d,
                  const double *buffer, double t, const double *x, const double *z,
                  const double *me_var, sr_info_work *w)
{
    int slot = 1 + SR_X_LEN(m->n), ok = 1;
    sr_info_data_init(m, d);
    if (me_var) {
        d->misfit = 1;
        memcpy(d->me_var, me_var, sizeof d->me_var);
    }
    for (int k = 0; k < SR_INFO_REPLAY && ok; k++) {
        const double *s = buffer + (size_t)k * (size_t)slot;
        ok = sr_info_add(m, d, s[0], s + 1, z, w) == 0;
    }
    if (!ok)
        memcpy(d, before, sizeof *d);
    if (sr_info_add(m, d, t, x, z, w) != 0) {
        memcpy(d, before, sizeof *d);
        return 1;
    }
    d->replayed = 1;
    memcpy(d->z_lin, z, sizeof d->z_lin);
    return 0;
}

int sr_info_step(const sr_info_model *m, const sr_info_data *before, sr_info_data *d,
                 double *buffer, double t, const double *x, const double *z_est,
                 sr_info_work *w)
{
    if (!m || !before || !d || before == d || !buffer || !x || !z_est || !w)
        return 1;
    memcpy(d, before, sizeof *d);
    int slot = 1 + SR_X_LEN(m->n);
    if (d->replayed) {                       /* its own estimate, refreshed now and then */
        double z[20];
        if (d->samples % SR_INFO_RELIN == 0 && own_point(m, d, z) == 0)
            memcpy(d->z_lin, z, sizeof z);
        memcpy(z, d->z_lin, sizeof z);
        if (sr_info_add(m, d, t, x, z, w) != 0) {
            memcpy(d, before, sizeof *d);
            return 1;
        }
        return 0;
    }
    if (d->samples < 0 || d->samples > SR_INFO_REPLAY)
        return 1;
    if (d->samples < SR_INFO_REPLAY) {       /* kept for the replay, linearised at z_est */
        double *s = buffer + (size_t)d->samples * (size_t)slot;
        s[0] = t;
        memcpy(s + 1, x, sizeof(double) * (size_t)(slot - 1));
        return sr_info_add(m, d, t, x, z_est, w);
    }
    /* the replay: the kept samples and this one again from the prior, at the own estimate */
    double z[20];
    if (own_point(m, d, z) != 0)
        memcpy(z, z_est, sizeof z);
    if (replay(m, before, d, buffer, t, x, z, NULL, w) != 0)
        return 1;
    /* where the rigid model does not fit the replayed samples: once more with the thrust errors
       held (own_point's estimate) and the model error as the rows' noise */
    sr_info_fit f;
    if (fit_test(m, d, &f) == 0 && f.misfit) {
        double me_var[2];
        if (own_point(m, d, z) != 0)
            memcpy(z, d->z_lin, sizeof z);
        model_error_of(m, buffer, z, me_var);
        if (replay(m, before, d, buffer, t, x, z, me_var, w) != 0)
            return 1;
    }
    return 0;
}

size_t sr_info_model_size(void) { return sizeof(sr_info_model); }
size_t sr_info_work_size(void) { return sizeof(sr_info_work); }
size_t sr_info_data_size(void) { return sizeof(sr_info_data); }
