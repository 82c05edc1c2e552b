/* The information filter's model-fit test (information.h): the estimate with the thrust
 * errors held at their priors, the whiteness, chi2 and thrust-scale statistics, and the model
 * error's variances from the kept samples. */
#include "info_internal.h"

#include "linalg.h"
#include "sr_math.h"
#include "standard_params.h"

#include <limits.h>
#include <math.h>
#include <string.h>

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
    info_solve_square_root(no, h->R, h->d, d->N_HH, d->N_Hy, compensated, u, Ri);
    info_reported_of_u(m, u, vec);
    for (int p = 0; p < nz; p++)              /* G = Rh^-1 Dh (the z_O rows) */
        for (int j = 0; j < SR_N_CONSIDER; j++) {
            double s = 0.0;
            for (int k = p; k < no; k++)
                s += Ri[p * MU + k] * h->D[k * SR_N_CONSIDER + j];
            G[p * SR_N_CONSIDER + j] = s;
        }
    int ok = info_bound_with(m, no, Ri, G, u, bound) == 0;
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
    info_solve_unknowns(m, d, 2, u, Ri);
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

/* coloured residuals count where they are not far below the noise's size (chi2 above
   SR_INFO_FIT_CHI2_MIN): far below it (noise-free data under a noise model, chi2 1e-5 to
   1e-4) their colour is the round-off's */
static int coloured_of(const sr_info_model *m, double whiteness, double chi2)
{
    return whiteness > m->fit.whiteness_max && chi2 > SR_INFO_FIT_CHI2_MIN;
}

static double chi2_of(const sr_info_model *m, const sr_info_data *d)
{
    double dof = d->rows - m->nu;
    return dof > 0.0 ? d->rss / dof : 0.0;
}

int info_coloured(const sr_info_model *m, const sr_info_data *d)
{
    /* as the fit test decides: not where the thrust ratio is not finite (a singular
       information); the ratio's solve only where the residuals are coloured */
    return coloured_of(m, whiteness(m, d), chi2_of(m, d)) && isfinite(thrust_ratio(m, d));
}

/* sr_info_fit_of (m, d, f given) */
static int fit_test(const sr_info_model *m, const sr_info_data *d, sr_info_fit *f)
{
    f->whiteness = whiteness(m, d);
    f->chi2 = chi2_of(m, d);
    f->thrust = thrust_ratio(m, d);
    /* a thrust ratio that is not finite (a singular information): the misfits kept at the
       replay only */
    int ok = isfinite(f->thrust), decide = ok && d->replayed;
    if (!ok)
        f->thrust = 0.0;
    f->model = d->misfit || (decide && coloured_of(m, f->whiteness, f->chi2));
    /* white residuals beyond the noise's: the noise values too small, while the rigid model
       may fit (the estimates not held); first, since values too small (noise.scale) shrink
       the thrust prior too and put the scale beyond it */
    f->noise = !f->model && (d->noise_misfit || (decide && f->chi2 > m->fit.chi2_max));
    /* a thrust scale beyond its prior with white residuals of the noise's size: a thrust
       miscalibration, or a model error the scale absorbs (the slosh: 3.7-5.8 prior
       sds at the replay, chi2 1.0-1.5); the estimates not held, their sds cover the held
       alternative */
    f->scale = !f->model && !f->noise
               && (d->scale_misfit || (decide && f->thrust > m->fit.thrust_max));
    f->misfit = f->model || f->scale || f->noise;
    return ok ? 0 : 1;
}

int sr_info_fit_of(const sr_info_model *m, const sr_info_data *d, sr_info_fit *f)
{
    if (!m || !d || !f)
        return 1;
    return fit_test(m, d, f);
}

/* The model error's variances (sr_info_data.me_var) from the kept samples: the rows'
   residuals at the estimate z (reported, 20; the thrust errors at 0), the linear ones less
   their mean (the momentum c0) give P_f, the angular ones less r_S x that and their mean
   give L_f about the base point; their mean squares per used row */
void info_model_error_of(const sr_info_model *m, const double *buffer, const double *z,
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
            info_rows_full(m, x, full, y);
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

