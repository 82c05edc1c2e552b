/* The drift tracker (est_tracker.h): the weighted forgetting lines through the data-only
 * estimates, the age-weighted Gram matrices, the lag of one least-squares problem behind
 * parameters that move (eq. 2), and the total standard deviations. */
#include "est_tracker.h"

#include <math.h>
#include <string.h>

#include "linalg.h"
#include "physical.h"

/* memory of the rate regression, in multiples of the estimator's, and the lag taken as the
 * estimate's own movement */
#define EST_RATE_MEMORY 2.0
#define EST_NOISE_LAG 1.0
/* the rate regression weighs a point by 1 / sd^2 with sd at least EST_SD_ROUNDOFF times the
 * estimate's error scale (the round-off of a double estimate: a smaller sd, e.g. the 0 of a
 * noise-free run's variance that round-off made <= 0, says nothing more) and sd^2 at least
 * EST_SD2_MIN: the weights stay <= 1e200, so that the regression's sums w, w dt^2, w dt dx
 * stay finite (a weight of 1 / 1e-300 overflowed them and every such sample was rejected) */
#define EST_SD_ROUNDOFF 1e-15
#define EST_SD2_MIN 1e-200

/* x = A^-1 b for A (n x n, n <= EST_NZ; overwritten) and b (n; overwritten by x): sr_lu_solve
 * (LU with partial pivoting) skipping the operations with an exact zero, which change
 * nothing (but the sign of a zero): the same numbers for the Jacobian of the estimates, with
 * two entries in a row at most, at a tenth of the cost. All NaN where a pivot column is 0. */
void est_sparse_lu_solve(double *A, int n, double *b)
{
    for (int j = 0; j < n; j++) {
        int piv = j;
        double big = fabs(A[j * n + j]);
        for (int i = j + 1; i < n; i++)
            if (fabs(A[i * n + j]) > big) {
                piv = i;
                big = fabs(A[i * n + j]);
            }
        if (big == 0.0 || big != big) {
            for (int i = 0; i < n; i++)
                b[i] = NAN;
            return;
        }
        if (piv != j) {
            for (int c = 0; c < n; c++) {
                double t = A[j * n + c];
                A[j * n + c] = A[piv * n + c];
                A[piv * n + c] = t;
            }
            double t = b[j];
            b[j] = b[piv];
            b[piv] = t;
        }
        int cols[EST_NZ], nc = 0;            /* the pivot row's nonzero columns past j */
        for (int c = j + 1; c < n; c++)
            if (A[j * n + c] != 0.0)
                cols[nc++] = c;
        for (int i = j + 1; i < n; i++) {
            if (A[i * n + j] == 0.0)
                continue;
            double f = A[i * n + j] / A[j * n + j];
            A[i * n + j] = f;
            for (int t = 0; t < nc; t++)
                A[i * n + cols[t]] -= f * A[j * n + cols[t]];
            b[i] -= f * b[j];
        }
    }
    for (int j = n - 1; j >= 0; j--) {
        double s = b[j];
        for (int l = j + 1; l < n; l++)
            if (A[j * n + l] != 0.0)
                s -= A[j * n + l] * b[l];
        b[j] = s / A[j * n + j];
    }
}

/* (A r, r) of one least-squares problem (tracking eq. 2):
 * A = G^-1 M (information-weighted mean age), r = (1 - growth A)^-1 rate; G, M (q x q, read
 * from the leading blocks of n x n matrices), rate (q). NaN where a matrix is singular. */
void est_block_lag(const double *G_full, const double *M_full, int n, int q,
                   const double *rate, double growth, double *Ar, double *r_out, double *extra)
{
    /* extra (q, may be NULL): replaced by G^-1 extra (one more column of the same solve) */
    int w = q + (extra != NULL);
    double G[EST_NZ * EST_NZ], A[EST_NZ * (EST_NZ + 1)], R[EST_NZ * EST_NZ];
    for (int i = 0; i < q; i++) {
        for (int j = 0; j < q; j++) {
            G[i * q + j] = G_full[i * n + j];
            A[i * w + j] = M_full[i * n + j];
        }
        if (extra)
            A[i * w + q] = extra[i];
    }
    sr_lu_solve(G, q, A, w);                                 /* A = G^-1 M */
    for (int i = 0; i < q; i++) {
        for (int j = 0; j < q; j++)
            R[i * q + j] = (i == j ? 1.0 : 0.0) - growth * A[i * w + j];
        if (extra)
            extra[i] = A[i * w + q];
    }
    for (int i = 0; i < q; i++)                              /* compact A (q x q) */
        for (int j = 0; j < q; j++)
            A[i * q + j] = A[i * w + j];
    memcpy(r_out, rate, sizeof(double) * q);
    sr_lu_solve(R, q, r_out, 1);
    sr_matvec(A, r_out, q, q, Ar);
}

/* est_block_lag by two solves of one column instead of a q-column one: (1 - growth A) r =
 * rate with A = G^-1 M is (G - growth M) r = G rate, and A r = G^-1 (M r): a third of the
 * work. The same numbers to round-off; taken where both information blocks are well
 * conditioned (the rounding of est_block_lag's G^-1 M is then what both agree to), never in
 * the first, poorly excited samples, whose standard deviations amplify any rounding. */
void est_block_lag_two_solves(const double *G_full, const double *M_full, int n, int q,
                              const double *rate, double growth, double *Ar, double *r_out,
                              double *extra, const est_eigs *eg)
{
    double G[EST_NZ * EST_NZ], R[EST_NZ * EST_NZ], B[EST_NZ * 2];
    int w = 1 + (extra != NULL);
    for (int i = 0; i < q; i++) {
        const double *Gi = G_full + i * n, *Mi = M_full + i * n;
        double s = 0.0;
        for (int j = 0; j < q; j++) {
            G[i * q + j] = Gi[j];
            R[i * q + j] = Gi[j] - growth * Mi[j];
            s += Gi[j] * rate[j];
        }
        r_out[i] = s;                                        /* G rate */
    }
    sr_lu_solve(R, q, r_out, 1);                             /* r = (G - growth M)^-1 G rate */
    for (int i = 0; i < q; i++) {
        const double *Mi = M_full + i * n;
        double s = 0.0;
        for (int j = 0; j < q; j++)
            s += Mi[j] * r_out[j];
        B[i * w] = s;                                        /* M r */
        if (extra)
            B[i * w + 1] = extra[i];
    }
    if (eg && eg->chol) {          /* A r = G^-1 M r (, G^-1 extra): G = D Gs D */
        double Bd[EST_NTH * 2];
        for (int i = 0; i < q * w; i++)
            Bd[i] = B[i] / eg->d[i / w];
        for (int i = 0; i < q; i++)
            for (int c = 0; c < w; c++) {
                const double *Vi = eg->V + i * q;
                double s = 0.0;
                for (int k = 0; k < q; k++)
                    s += Vi[k] * Bd[k * w + c];
                B[i * w + c] = s / eg->d[i];
            }
    } else {
        sr_lu_solve(G, q, B, w);
    }
    for (int i = 0; i < q; i++) {
        Ar[i] = B[i * w];
        if (extra)
            extra[i] = B[i * w + 1];
    }
}

/* out = lam (age + step S) (n x n), its first `rows` rows: what the lag reads of the
 * age-weighted Gram matrix (est_block_lag: the leading q x q block; the paper's lag: rows < r
 * of the theta block); the rows below stay as they are (zero) */
static void age_step(const double *age, const double *S, int n, int rows, double lam,
                     double step, double *out)
{
    /* whole rows, two entries a step (the numbers the lower triangle mirrored gave: S and the
     * rows of age in use are symmetric bit for bit) */
    for (int i = 0; i < rows; i++) {
        const double *a = age + i * n, *g = S + i * n;
        double *o = out + i * n;
        int j = 0;
        for (; j + 1 < n; j += 2) {
            const double v0 = lam * (a[j] + step * g[j]), v1 = lam * (a[j + 1] + step * g[j + 1]);
            o[j] = v0;
            o[j + 1] = v1;
        }
        if (j < n)
            o[j] = lam * (a[j] + step * g[j]);
    }
}

void est_tracker_begin(const sr_estimator_model *m, const est_core *old, est_core *nw,
                       double t, const double *x, const double *sd, est_tracker_step *ts)
{
    double lam = m->opt.lambda;
    int first = old->tr_s0 == 0.0;
    double t_ref = first ? t : old->tr_t_ref;
    double s0 = lam * old->tr_s0 + 1.0;                      /* sum w,  w = lam^(N-k) */
    double s1 = lam * old->tr_s1 + (t - t_ref);              /* sum w (t_k - t_ref) */
    double a_bar = (t - t_ref) - s1 / s0;                    /* sum w (t - t_k) / sum w */
    double step = t - old->tr_t;
    double da_dt = (!first && step > 0.0) ? (a_bar - old->tr_a_bar) / step : 0.0;
    double lam_r = 1.0 - 1.0 / (EST_RATE_MEMORY * s0);
    double lag_factor = a_bar / est_pymax(1.0 - da_dt, 0.1);     /* tracking eq. 1 */
    double scale[EST_NZ];
    int all_positive = 1;
    sr_error_scale(nw->vec, SR_COM_SCALE_MIN, scale);      /* nw->vec: the step's estimates */
    for (int i = 0; i < EST_NZ; i++) {
        double floor_sd = EST_SD_ROUNDOFF * scale[i];       /* (NaN: no floor but EST_SD2_MIN) */
        double v = 1.0 / est_pymax(est_pymax(sd[i] * sd[i], floor_sd * floor_sd), EST_SD2_MIN);
        double w_old = lam_r * old->tr_w[i];
        double wi = w_old + v;
        double d_t = t - old->tr_mt[i], d_x = x[i] - old->tr_mx[i];
        double f = v * w_old / wi;                           /* weighted Welford update */
        nw->tr_ctt[i] = lam_r * old->tr_ctt[i] + f * d_t * d_t;
        nw->tr_ctx[i] = lam_r * old->tr_ctx[i] + f * d_t * d_x;
        nw->tr_w[i] = wi;
        nw->tr_mt[i] = old->tr_mt[i] + v * d_t / wi;
        nw->tr_mx[i] = old->tr_mx[i] + v * d_x / wi;
        ts->rate[i] = nw->tr_ctt[i] > 0.0 ? nw->tr_ctx[i] / nw->tr_ctt[i] : 0.0;
        double spread = sqrt(nw->tr_ctt[i] / wi);
        ts->gain[i] = spread > 0.0 ? est_pymax(lag_factor / spread, 1.0) : 1.0;
        if (!(nw->tr_ctt[i] > 0.0))
            all_positive = 0;
    }
    step = (!first && step > 0.0) ? step : 0.0;
    /* tracking eq. 2: every old row is step older: M_age <- lam (M_age + step G_before) */
    if (m->opt.solver == 1) {
        age_step(old->age_lin, old->S_lin, m->nl, m->p, lam, step, nw->age_lin);
        age_step(old->age_ang, old->S_ang, m->na, m->r, lam, step, nw->age_ang);
    } else {
        age_step(old->age_pi, old->S_pi, m->q + 1, m->q, lam, step, nw->age_pi);
    }
    ts->all_positive = all_positive;
    ts->growth = all_positive && a_bar > 0.0 ? da_dt / a_bar : 0.0;
    ts->factor = a_bar / est_pymax(1.0 - da_dt, 0.1);
    ts->s0 = s0;
    ts->s1 = s1;
    ts->t_ref = t_ref;
    ts->t = t;
    ts->a_bar = a_bar;
}

void est_tracker_end(est_core *nw, const double *sd, const double *lag,
                     const est_tracker_step *ts)
{
    for (int i = 0; i < EST_NZ; i++) {          /* sd^2 + max(0, lag^2 - (NOISE_LAG g sd)^2) */
        double l = lag ? lag[i] : ts->rate[i] * ts->factor;
        double sd2 = sd[i] * sd[i], g = EST_NOISE_LAG * ts->gain[i];
        double excess = est_pymax(l * l - (g * g) * sd2, 0.0);
        nw->sd[i] = sqrt(sd2 + excess);
    }
    nw->tr_s0 = ts->s0;
    nw->tr_s1 = ts->s1;
    nw->tr_t_ref = ts->t_ref;
    nw->tr_t = ts->t;
    nw->tr_a_bar = ts->a_bar;
}
