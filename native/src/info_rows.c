/* The information filter's rows (information.h): the momentum equations as rows linear in
 * the standard parameters, and their noise covariance (the sensors' white noise, the
 * navigation noises' product, the model error under misfit) with its weight. */
#include "info_internal.h"

#include "linalg.h"
#include "sr_math.h"
#include "standard_params.h"

#include <limits.h>
#include <math.h>
#include <string.h>

/* the white-noise sds of n (8), the channels the rows are weighed by */
void info_white_sds(const sr_info_noise *n, double *w)
{
    const double v[8] = {n->r, n->v, n->omega, n->att[0], n->att[1], n->att[2], n->q, n->qd};
    memcpy(w, v, sizeof v);
}

/* The momentum equations of x as rows linear in the standard parameters z_O (20): full
   (6 x 20) z_O = y (6), exactly. Linear rows A mu = b; angular rows phi theta_O - psi_lin
   [m, c] = y: the quadratic part of psi D(mu) is -phi P times c_i c_j / m (the parallel-axis
   terms), which the inertias about the frames' origins absorb. */
void info_rows_full(const sr_info_model *m, const double *x, double full[6][20], double *y)
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
void info_rows_at(const sr_info_model *m, const double *x, const double *zO, double *r)
{
    double full[6][20], y[6];
    info_rows_full(m, x, full, y);
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
void info_linear_rows(const sr_info_model *m, const double *x, const double *k, double *H,
                      double *y)
{
    double full[6][20], yf[6], S[3 * SR_N_CCOLS];
    info_rows_full(m, x, full, yf);
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
int info_channels(const sr_info_model *m, int *idx, double *sd)
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

/* The rows' mixed differences in the navigation's position and velocity: G[3 i + j] (nr x
   (nu + 1), row stride HS: the identified z_O's columns and y in column nu, the others 0) =
   [H | y] at (r_i + 1, v_j + 1) - at (r_i + 1) - at (v_j + 1) + at x (Hy). The rows hold
   M r_S x v_S about the origin: bilinear in (r_S, v_S), so with unit steps this is exact
   (d2 [H | y] / dr_i dv_j), and it sits in the masses' columns and the known links' y only.
   k: the thrust integrals; xs: a copy of x, restored on return; V (4 blocks): work space. */
void info_nav_mixed(const sr_info_model *m, const double *x, const double *k, const double *Hy,
                    double *xs, double (*V)[6 * HS], double (*G)[6 * HS])
{
    int nz = m->nz, nr = m->nr, nu = m->nu;
    double y[6], *Ri = V[3];
    for (int j = 0; j < 3; j++) {                  /* at v_j + 1 */
        xs[SR_X_V_S + j] = x[SR_X_V_S + j] + 1.0;
        info_linear_rows(m, xs, k, V[j], y);
        for (int a = 0; a < nr; a++)
            V[j][a * HS + nu] = y[a];
        xs[SR_X_V_S + j] = x[SR_X_V_S + j];
    }
    for (int i = 0; i < 3; i++) {
        xs[SR_X_R_S + i] = x[SR_X_R_S + i] + 1.0;  /* at r_i + 1 */
        info_linear_rows(m, xs, k, Ri, y);
        for (int a = 0; a < nr; a++)
            Ri[a * HS + nu] = y[a];
        for (int j = 0; j < 3; j++) {              /* at (r_i + 1, v_j + 1) */
            double *g = G[3 * i + j];
            xs[SR_X_V_S + j] = x[SR_X_V_S + j] + 1.0;
            info_linear_rows(m, xs, k, g, y);
            xs[SR_X_V_S + j] = x[SR_X_V_S + j];
            for (int a = 0; a < nr; a++) {
                g[a * HS + nu] = y[a];
                for (int q = 0; q <= nu; q++) {
                    int at = a * HS + q;
                    g[at] = q < nz || q == nu ? g[at] - Ri[at] - V[j][at] + Hy[at] : 0.0;
                }
            }
        }
        xs[SR_X_R_S + i] = x[SR_X_R_S + i];
    }
}

/* sd_r^2 sd_v^2: the variance of the navigation noises' product per pair of axes (0 where
   one of them is off: no product terms) */
double info_nav_product_var(const sr_info_model *m)
{
    return m->noise.r * m->noise.r * m->noise.v * m->noise.v;
}

/* Rk (stride 6) += the covariance of the navigation noises' product. The angular rows hold
   r_S x m v_S, bilinear in (r_S, v_S): beside the first-order terms they carry dr x m dv, of
   zero mean (dr, dv independent) and covariance sd_r^2 sd_v^2 sum_ij g_ij g_ij^T with g_ij
   the rows' mixed difference in r_i, v_j at z (G: info_nav_mixed's, times [z_O; -1]). The
   first-order terms leave the angular rows almost noise-free across r and v, where this term
   is of the gyro's size: without it a fast-tumbling target's sds were too small
   (benchmarks/CALIBRATION.md). */
static void product_noise(const sr_info_model *m, const double *z, const double (*G)[6 * HS],
                          double *Rk)
{
    const double s2 = info_nav_product_var(m);
    if (!G || !(s2 > 0.0))
        return;
    int nr = m->nr, nz = m->nz, nu = m->nu;
    for (int ij = 0; ij < 9; ij++) {
        double g[6];
        for (int a = 0; a < nr; a++) {
            double v = -G[ij][a * HS + nu];
            for (int q = 0; q < nz; q++)
                v += G[ij][a * HS + q] * z[m->zi[q]];
            g[a] = v;
        }
        for (int a = 0; a < nr; a++)
            for (int b = 0; b < nr; b++)
                Rk[a * 6 + b] += s2 * g[a] * g[b];
    }
}

/* R_k^-1/2 (lower triangular nr x nr) of the rows' noise covariance at x, z: the channels'
   white noise through central differences of the rows, the attitude's as small rotations
   about the base axes, the navigation noises' product from the mixed differences G
   (info_nav_mixed; NULL: without navigation noise); 0, or 1 when R_k is not positive
   definite */
int info_noise_weight(const sr_info_model *m, const double *x, const double *z,
                      const double (*G)[6 * HS], const double *me_var, double *W)
{
    int nr = m->nr, idx[12 + 2 * SR_MAX_JOINTS];
    double sd[12 + 2 * SR_MAX_JOINTS], Rk[36] = {0}, xs[SR_X_LEN(SR_MAX_JOINTS)];
    double rp[6], rm[6], g[6];
    int nx = SR_X_LEN(m->n);
    memcpy(xs, x, sizeof(double) * nx);
    int nc = info_channels(m, idx, sd);
    for (int c = 0; c < nc; c++) {
        const double h = 1e-4;
        int i = idx[c];
        xs[i] = x[i] + h;
        info_rows_at(m, xs, z, rp);
        xs[i] = x[i] - h;
        info_rows_at(m, xs, z, rm);
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
            info_rows_at(m, xs, z, sgn > 0 ? rp : rm);
        }
        memcpy(xs + SR_X_A_B, x + SR_X_A_B, sizeof(double) * 9);
        double s2 = m->noise.att[i] * m->noise.att[i];
        for (int a = 0; a < nr; a++)
            g[a] = (rp[a] - rm[a]) / (2 * h);
        for (int a = 0; a < nr; a++)
            for (int b = 0; b < nr; b++)
                Rk[a * 6 + b] += s2 * g[a] * g[b];
    }
    product_noise(m, z, G, Rk);
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

/* out (nr x ncol, row stride ld) = W (nr x nr lower) times in (same shape) */
void info_weigh(const double *W, int nr, const double *in, int ld, int ncol, double *out)
{
    /* bottom row first (out may be in); each entry's sum over b in order, the columns
       innermost (contiguous) in blocks of 64 */
    for (int a = nr - 1; a >= 0; a--)
        for (int j0 = 0; j0 < ncol; j0 += 64) {
            int nj = ncol - j0 < 64 ? ncol - j0 : 64;
            double s[64];
            for (int j = 0; j < nj; j++)
                s[j] = 0.0;
            for (int b = 0; b <= a; b++) {
                const double wab = W[a * nr + b], *r = in + b * ld + j0;
                for (int j = 0; j < nj; j++)
                    s[j] += wab * r[j];
            }
            memcpy(out + a * ld + j0, s, sizeof(double) * (size_t)nj);
        }
}

