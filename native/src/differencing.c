/* The weights of a derivative and of the displacements over a window of samples, and the centre
 * sample with its accelerations differenced (differencing.h). */
#include "differencing.h"

#include <math.h>
#include <stddef.h>

#include "linalg.h"
#include "sr_math.h"
/* tau = t - t[centre] and s = max |tau| (the scale of the times: well-conditioned systems) */
static double centred_times(const double *t, int k, int centre, double *tau)
{
    double s = 0.0;
    int i;
    for (i = 0; i < k; ++i) {
        tau[i] = t[i] - t[centre];
        if (fabs(tau[i]) > s || tau[i] != tau[i])   /* np.abs(tau).max(): NaN propagates */
            s = fabs(tau[i]);
    }
    return s;
}

int sr_derivative_weights(const double *t, int k, int centre, double *w)
{
    double tau[SR_DIFF_MAX_SAMPLES], B[3 * SR_DIFF_MAX_SAMPLES], G[9], s;
    int i, a, c;
    if (k < 3 || k > SR_DIFF_MAX_SAMPLES || centre < 0 || centre >= k)
        return 1;
    if (k == 3 && centre == 1) {                /* the central difference for uneven steps */
        const double h1 = t[1] - t[0], h2 = t[2] - t[1];
        w[0] = -h2 / (h1 * (h1 + h2));
        w[1] = (h2 - h1) / (h1 * h2);
        w[2] = h1 / (h2 * (h1 + h2));
        return sr_finite_all(w, 3) ? 0 : 2;
    }
    s = centred_times(t, k, centre, tau);
    /* V = [1, tau/s, (tau/s)^2] (k x 3): B = V^T (3 x k), G = V^T V (3 x 3) */
    for (i = 0; i < k; ++i) {
        const double x = tau[i] / s;
        B[i] = 1.0;
        B[k + i] = x;
        B[2 * k + i] = x * x;
    }
    for (a = 0; a < 3; ++a)
        for (c = 0; c < 3; ++c) {
            double acc = 0.0;
            for (i = 0; i < k; ++i)
                acc += B[a * k + i] * B[c * k + i];
            G[3 * a + c] = acc;
        }
    /* c = (V^T V)^-1 V^T x; the slope at tau = 0 is c[1] / s */
    if (sr_lu_solve(G, 3, B, k) != 0) {
        for (i = 0; i < k; ++i)
            w[i] = NAN;
        return 2;
    }
    for (i = 0; i < k; ++i)
        w[i] = B[k + i] / s;
    return sr_finite_all(w, k) ? 0 : 2;
}

int sr_displacement_weights(const double *t, int k, int centre, const double *w, double *u)
{
    /* V^T (k x k): 3.5 kB of stack at the largest window; no allocation */
    double x[SR_DIFF_MAX_DISPLACEMENT_SAMPLES];
    double A[SR_DIFF_MAX_DISPLACEMENT_SAMPLES * SR_DIFF_MAX_DISPLACEMENT_SAMPLES], s;
    int i, p;
    if (k < 3 || k > SR_DIFF_MAX_DISPLACEMENT_SAMPLES || centre < 0 || centre >= k)
        return 1;
    s = centred_times(t, k, centre, x);
    for (i = 0; i < k; ++i)
        x[i] /= s;                              /* the nodes tau / s */
    for (p = 0; p < k; ++p) {
        double acc = 0.0;
        for (i = 0; i < k; ++i) {
            /* V^T[p][i] = (tau_i / s)^p; W[i][p] = s (tau_i / s)^(p+1) / (p + 1), the
             * integral from 0 to tau_i of (tau / s)^p; the right-hand side W^T w */
            A[p * k + i] = sr_powi(x[i], p);     /* portable integer powers */
            acc += s * sr_powi(x[i], p + 1) / (double)(p + 1) * w[i];
        }
        u[p] = acc;
    }
    /* u = V^-T W^T w by LU with partial pivoting, as np.linalg.solve (LAPACK gesv) */
    if (sr_lu_solve(A, k, u, 1) != 0)
        return 2;
    return sr_finite_all(u, k) ? 0 : 2;
}

int sr_centre_derivative_rows(const double *t, const double *const *X, int k, int n,
                              const int *acc, const int *vel, int npairs, double *out,
                              double *t_c, double *w_out)
{
    double w[SR_DIFF_MAX_SAMPLES];
    int i, p, m, status;
    if (k < 3 || k > SR_DIFF_MAX_SAMPLES || k % 2 == 0 || n < 0 || npairs < 0)
        return 1;
    for (p = 0; p < npairs; ++p)
        if (acc[p] < 0 || acc[p] >= n || vel[p] < 0 || vel[p] >= n)
            return 1;
    m = (k - 1) / 2;
    status = sr_derivative_weights(t, k, m, w);
    *t_c = t[m];
    for (i = 0; i < n; ++i)
        out[i] = X[m][i];
    for (p = 0; p < npairs; ++p) {              /* w @ X[:, vel] (m = 1: term by term) */
        double s = 0.0;
        for (i = 0; i < k; ++i)
            s += w[i] * X[i][vel[p]];
        out[acc[p]] = s;
    }
    if (w_out)
        for (i = 0; i < k; ++i)
            w_out[i] = w[i];
    return status;
}

int sr_centre_derivative(const double *t, const double *X, int k, int n, const int *acc,
                         const int *vel, int npairs, double *out, double *t_c)
{
    const double *rows[SR_DIFF_MAX_SAMPLES];
    if (k < 3 || k > SR_DIFF_MAX_SAMPLES || n < 0)
        return 1;
    for (int i = 0; i < k; ++i)
        rows[i] = X + (size_t)i * (size_t)n;
    return sr_centre_derivative_rows(t, rows, k, n, acc, vel, npairs, out, t_c, NULL);
}
