/* The information filter and the bound (information.h). */
#include "information.h"
#include "info_internal.h"

#include "linalg.h"
#include "sr_math.h"
#include "standard_params.h"

#include <limits.h>
#include <math.h>
#include <string.h>

/* The unknowns' z part is in the standard layout of standard_params.h: per body m, c = m b (3),
 * I_O# (6, about the body frame's origin); sr_standard_of_reported / sr_reported_of_standard
 * map it from / to the reported parameters. */

int sr_info_noise_white(const sr_info_noise *n)
{
    double w[8];
    int white = 0;
    info_white_sds(n, w);
    for (int i = 0; i < 8; i++)
        white = white || w[i] > 0.0;
    return white;
}

/* 1 if every sd of n is finite and >= 0 */
static int noise_valid(const sr_info_noise *n)
{
    double w[8];
    int ok = isfinite(n->gyro_bias) && n->gyro_bias >= 0.0;
    info_white_sds(n, w);
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

/* The whiteness test's ring and sums with the sample's whitened residual rows e (nr),
   W (y - H u) (sr_info_add: u the compensated estimate d->u_fit from the replay on, the
   estimate before the sample up to it), independent N(0, 1) where the model and the noise
   model hold */
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

/* N_HH, N_Hy (the z_O block) += s2 (W dH)^T (W [dH dy]) of one noise direction's weighted
   slopes wdH (nr x nz | dy in column nu, row stride HS) */
static void eiv_add(const sr_info_model *m, double s2, const double *wdH, double *N_HH,
                    double *N_Hy)
{
    int nz = m->nz, nr = m->nr, nu = m->nu;
    /* the upper triangle, mirrored (the products commute: the same numbers), each row's
       sums over the rows a in order with q innermost (contiguous) */
    for (int p = 0; p < nz; p++) {
        double s[MU], sy = 0.0;
        for (int q = p; q < nz; q++)
            s[q] = 0.0;
        for (int a = 0; a < nr; a++) {
            const double *r = wdH + a * HS;
            double wp = r[p];
            for (int q = p; q < nz; q++)
                s[q] += wp * r[q];
            sy += wp * r[nu];
        }
        for (int q = p; q < nz; q++) {
            N_HH[p * MU + q] += s2 * s[q];
            if (q != p)
                N_HH[q * MU + p] += s2 * s[q];
        }
        N_Hy[p] += s2 * sy;
    }
}

/* Errors in variables, the navigation noises' product. N's terms are the rows' slopes at the
   measured sample, and the rows are bilinear in r_S and v_S (M r_S x v_S): the slope in r_S
   carries v_S's noise and the slope in v_S r_S's, so N's expectation counts sd_r^2 sd_v^2
   |W g_ij|^2 (g_ij = G's mixed differences, info_nav_mixed) twice where the Gram's expected
   share of the product dr x M dv holds it once: subtracted once. Without it the correction
   overshot by 8 % (3 sd) under a 0.37 m/s drift (docs/identification.md, "Errors in
   variables"). The other bilinear pairs (r_S with omega_B and the joint rates, the rates with
   the angles) are of the same kind but, at the sensors' noise, much smaller: left. s2:
   info_nav_product_var. */
static void eiv_nav_product(const sr_info_model *m, double s2, const double (*G)[6 * HS],
                            const double *W, double *wg, double *N_HH, double *N_Hy)
{
    for (int ij = 0; ij < 9; ij++) {
        info_weigh(W, m->nr, G[ij], HS, m->nu + 1, wg);
        eiv_add(m, -s2, wg, N_HH, N_Hy);
    }
}

/* The sample x's unweighted rows [H | y] (nr x (nu + 1), row stride HS) with the thrust
   integrals K, the gyro bias's columns at z (standard form) */
void info_sample_rows(const sr_info_model *m, const double *x, const double *K,
                      const double *z, double *Hy)
{
    int nr = m->nr, nu = m->nu;
    double r0[6], rb[6], y[6], xs[SR_X_LEN(SR_MAX_JOINTS)];
    memset(Hy, 0, sizeof(double) * 6 * HS);
    info_linear_rows(m, x, K + SR_THRUST_K, Hy, y);
    for (int a = 0; a < nr; a++)
        Hy[a * HS + nu] = y[a];
    if (m->nb) {                       /* the gyro reads omega + b: the rows' d / d b */
        memcpy(xs, x, sizeof(double) * (size_t)SR_X_LEN(m->n));
        info_rows_at(m, x, z, r0);
        for (int i = 0; i < 3; i++) {
            xs[SR_X_OMEGA_B + i] = x[SR_X_OMEGA_B + i] + 1.0;   /* the rows are linear in it */
            info_rows_at(m, xs, z, rb);
            xs[SR_X_OMEGA_B + i] = x[SR_X_OMEGA_B + i];
            for (int a = 0; a < nr; a++)
                Hy[a * HS + nu - 3 + i] = -(rb[a] - r0[a]);
        }
    }
}

/* The weight W = R_k^-1/2 of the sample x's rows Hy (info_sample_rows') at z (standard form),
   the model error's variances me_var in the rows' noise; leaves in xs a copy of x and in w
   the navigation's mixed differences (info_eiv_sample reads them). 0, or 1 where the rows'
   noise covariance is not positive definite. */
int info_sample_weight(const sr_info_model *m, const double *x, const double *K,
                       const double *z, const double *me_var, const double *Hy, double *W,
                       double *xs, sr_info_work *w)
{
    memcpy(xs, x, sizeof(double) * (size_t)SR_X_LEN(m->n));
    const int nav = info_nav_product_var(m) > 0.0;            /* their product's terms */
    if (nav)             /* (the mixed differences read Hy's z_O columns and y only) */
        info_nav_mixed(m, x, K + SR_THRUST_K, Hy, xs, w->nav_v, w->nav_g);
    return info_noise_weight(m, x, z, nav ? (const double (*)[6 * HS])w->nav_g : NULL,
                             me_var, W);
}

/* Errors in variables of the sample x (its rows Hy and weight W: info_sample_rows' and
   info_sample_weight's, which also left xs and w's mixed differences):
   N += sum_l sigma_l^2 (W dH_l)^T (W [dH_l dy_l])
   over the noisy channels, less the navigation's product once (eiv_nav_product) */
void info_eiv_sample(const sr_info_model *m, const double *x, const double *K,
                     const double *Hy, const double *W, double *xs, sr_info_work *w,
                     double *N_HH, double *N_Hy)
{
    int nr = m->nr, nu = m->nu, nz = m->nz;
    int idx[12 + 2 * SR_MAX_JOINTS];
    double sd[12 + 2 * SR_MAX_JOINTS];
    int nc = info_channels(m, idx, sd);
    for (int c = 0; c < nc; c++) {
        int i = idx[c];
        double h = 1e-4 * (fabs(x[i]) > 1.0 ? fabs(x[i]) : 1.0);
        double Hp[6 * HS], yp[6], dH[6 * HS], wdH[6 * HS];
        memset(Hp, 0, sizeof Hp);
        xs[i] = x[i] + h;
        info_linear_rows(m, xs, K + SR_THRUST_K, Hp, yp);
        xs[i] = x[i];
        for (int a = 0; a < nr; a++) {
            for (int j = 0; j < nz; j++)     /* only z_O's columns move with the channels */
                dH[a * HS + j] = (Hp[a * HS + j] - Hy[a * HS + j]) / h;
            for (int j = nz; j < nu; j++)
                dH[a * HS + j] = 0.0;
            dH[a * HS + nu] = (yp[a] - Hy[a * HS + nu]) / h;
        }
        info_weigh(W, nr, dH, HS, nu + 1, wdH);
        eiv_add(m, sd[c] * sd[c], wdH, N_HH, N_Hy);
    }
    double s2_nav = info_nav_product_var(m);
    if (s2_nav > 0.0)
        eiv_nav_product(m, s2_nav, (const double (*)[6 * HS])w->nav_g, W, w->nav_wg, N_HH,
                        N_Hy);
}

int sr_info_add(const sr_info_model *m, sr_info_data *d, double t, const double *x,
                const double *z_lin, sr_info_work *w)
{
    if (!m || !d || !x || !z_lin || !w || !(z_lin[0] > 0.0) || !(z_lin[10] > 0.0))
        return 1;
    if (!isfinite(t) || (d->samples > 0 && !(t > d->K[SR_THRUST_T])))
        return 1;                      /* the thrust integrals need increasing times */
    int nr = m->nr, nu = m->nu;
    double K[SR_THRUST_LEN], W[36], z[20];
    memcpy(K, d->K, sizeof K);
    sr_thrust_integrals_add(K, d->samples == 0, t, x + SR_X_R_S, x + SR_X_F(m->n),
                            x + SR_X_M(m->n));
    sr_standard_of_reported(z_lin, z);              /* the linearisation point's z_O */
    /* the rows and their right-hand side in one block: H (nr x nu) | y in column nu */
    double Hy[6 * HS], xs[SR_X_LEN(SR_MAX_JOINTS)];
    info_sample_rows(m, x, K, z, Hy);
    if (info_sample_weight(m, x, K, z, d->me_var, Hy, W, xs, w) != 0)   /* every sample */
        return 1;
    double Wt[6 * HS], e[6];
    info_weigh(W, nr, Hy, HS, nu + 1, Wt);
    /* the whiteness test's residual W (y - H u_fit) from the replay on (fit_restart); up to
       it the rows the QR update leaves below (W (y - H u) at the estimate before the sample:
       the update's reflections barely touch the new rows once R is large) */
    for (int a = 0; a < nr && d->fit_at; a++) {
        double s = Wt[a * HS + nu];
        for (int j = 0; j < nu; j++)
            s -= Wt[a * HS + j] * d->u_fit[j];
        e[a] = s;
    }
    double *N_HH = w->N_HH, N_Hy[MU];        /* the new sums, committed when finite */
    memcpy(N_HH, d->N_HH, sizeof d->N_HH);
    memcpy(N_Hy, d->N_Hy, sizeof N_Hy);
    info_eiv_sample(m, x, K, Hy, W, xs, w, N_HH, N_Hy);
    /* the QR update of [[R d]; [W H  W y]] */
    double *R = w->R, dv[MU];
    memcpy(R, d->R, sizeof d->R);
    memcpy(dv, d->d, sizeof dv);
    sr_qr_add_rows(R, MU, dv, nu, Wt, HS, nr);
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
    for (int a = 0; a < nr && !d->fit_at; a++)
        e[a] = Wt[a * HS + nu];
    fit_ring_add(m, d, e);
    if (d->samples < INT_MAX)                        /* saturates (~7 years at 10 Hz) */
        d->samples++;
    return 0;
}

/* the reported parameters (20) of the identified z_O entries u (nz) */
void info_reported_of_u(const sr_info_model *m, const double *u, double *x)
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
INFO_NOINLINE int info_bound_with(const sr_info_model *m, int nu, const double *Ri,
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
    return info_bound_with(m, m->nu, Ri, NULL, u, bound);
}

/* The unknowns u (nu) of the square-root information [R dv] (nu unknowns, the z_O entries
   first; N_HH, N_Hy the errors-in-variables sums over them: zero beyond z_O), compensated as
   sr_info_estimate, and Ri = R^-1 */
INFO_NOINLINE void info_solve_square_root(int nu, const double *R, const double *dv,
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
void info_solve_unknowns(const sr_info_model *m, const sr_info_data *d, int compensated,
                         double *u, double *Ri)
{
    info_solve_square_root(m->nu, d->R, d->d, d->N_HH, d->N_Hy, compensated, u, Ri);
}

int sr_info_estimate(const sr_info_model *m, const sr_info_data *d, int compensated,
                     double *vec, double *bound, double *chi2)
{
    if (!m || !d || !vec || !bound)
        return 1;
    double u[MU] = {0}, Ri[MU * MU];
    info_solve_unknowns(m, d, compensated, u, Ri);
    info_reported_of_u(m, u, vec);
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

/* the filter's estimate as the report takes it: with the thrust held where the model does
   not fit */
static int estimate_as_fit(const sr_info_model *m, const sr_info_data *d, double *z,
                           double *bound)
{
    sr_info_fit f;
    if (sr_info_fit_of(m, d, &f) == 0 && f.model)
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
    info_solve_unknowns(m, d, 2, u, Ri);              /* the point the bound is mapped at */
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
    for (int i = 0; i < m->nu; i++)
        s += d->u_fit[i];
    /* the misfits are found at the replay, one cause at most; model error only with a model
       misfit */
    return isfinite(s + d->me_var[0] + d->me_var[1]) && d->me_var[0] >= 0.0
           && d->me_var[1] >= 0.0 && (d->fit_at == 0 || d->fit_at == 1)
           && (d->misfit == 0 || d->misfit == 1) && (d->noise_misfit == 0 || d->noise_misfit == 1)
           && (d->scale_misfit == 0 || d->scale_misfit == 1)
           && d->fit_at <= d->replayed && d->misfit <= d->replayed
           && d->noise_misfit <= d->replayed && d->scale_misfit <= d->replayed
           && d->misfit + d->noise_misfit + d->scale_misfit <= 1
           && (d->misfit || (d->me_var[0] == 0.0 && d->me_var[1] == 0.0));
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

/* d->u_fit: the compensated unknowns of d (with the thrust errors estimated, also where a
   misfit holds them in the reported estimates: the test's residuals stay those of the full
   model); where they are not finite the previous point stays. 0, or 1 where not finite. */
static INFO_NOINLINE int fit_point(const sr_info_model *m, sr_info_data *d, sr_info_work *w)
{
    double u[MU] = {0};
    info_solve_unknowns(m, d, 2, u, w->Ri);
    for (int j = 0; j < m->nu; j++)
        if (!isfinite(u[j]))
            return 1;
    memcpy(d->u_fit, u, sizeof d->u_fit);
    return 0;
}

/* The whiteness test from the replay on: its sums restarted, the residuals at the compensated
   estimate (fit_point; the innovations go on only where it is not finite there). The
   innovations, which the replay's decision reads, follow a running estimate that is not
   compensated; its errors-in-variables bias colours them more with every sample, so carried
   on they gave rigid bodies a false misfit (Q/L 50-54 by 300 s at 0.1 rad; at the compensated
   estimate 0.8-1.8: docs/identification.md, "Weak excitation"). */
static void fit_restart(const sr_info_model *m, sr_info_data *d, sr_info_work *w)
{
    d->fit_head = d->fit_count = 0;
    memset(d->fit_ring, 0, sizeof d->fit_ring);
    memset(d->fit_sum, 0, sizeof d->fit_sum);
    d->fit_at = fit_point(m, d, w) == 0;
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
        if (d->samples % SR_INFO_RELIN == 0) {
            if (own_point(m, d, z) == 0)
                memcpy(d->z_lin, z, sizeof z);
            if (d->fit_at)
                fit_point(m, d, w);
        }
        memcpy(z, d->z_lin, sizeof z);
        if (sr_info_add(m, d, t, x, z, w) != 0) {
            memcpy(d, before, sizeof *d);
            return 1;
        }
        /* a rigid-model misfit found after the replay stays, as one found at it (without its
           model-error variances, which come from the kept samples): residuals whose colour
           hovers about the threshold would otherwise flip the cause and the held estimates
           back and forth (a held-out servicer's slosh: 8 changes in 6 s) */
        if (!d->misfit && info_coloured(m, d)) {
            d->misfit = 1;
            d->noise_misfit = d->scale_misfit = 0;
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
    if (sr_info_fit_of(m, d, &f) == 0 && f.model) {
        double me_var[2];
        if (own_point(m, d, z) != 0)
            memcpy(z, d->z_lin, sizeof z);
        info_model_error_of(m, buffer, z, me_var);
        if (replay(m, before, d, buffer, t, x, z, me_var, w) != 0)
            return 1;
    } else if (f.noise) {
        d->noise_misfit = 1;
    } else if (f.scale) {
        d->scale_misfit = 1;
    }
    fit_restart(m, d, w);
    return 0;
}

size_t sr_info_model_size(void) { return sizeof(sr_info_model); }
size_t sr_info_work_size(void) { return sizeof(sr_info_work); }
size_t sr_info_data_size(void) { return sizeof(sr_info_data); }
