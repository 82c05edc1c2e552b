/* The recursive least squares of the estimator's solvers: one RLS step with forgetting, the
 * Gram matrices of the weighted augmented rows (whose quadratic forms give the residual
 * variances) and their counts (est_rls.h). */
#include "est_rls.h"

#include <math.h>
#include <string.h>

#include "est_types.h"
#include "linalg.h"

/* -- the Gram matrices ---------------------------------------------------------------------- */

/* out = lam S + R^T R: S (n x n, symmetric), R (k x n) the augmented rows of one sample
 * (S + R^T R for lam = 1). out may alias S. */
void est_gram_add(const double *S, int n, const double *R, int k, double lam, double *out)
{
    /* the lower triangle, mirrored: acc = sum_l R[l][i] R[l][j] summed in the order of l
     * (written out for the k <= 3 rows of one equation); lam S skipped for lam = 1. S is
     * symmetric bit for bit (zero at the start, every update writes both triangles with one
     * number), so its upper triangle gives the same numbers: computed once. */
    const double *R0 = R, *R1 = R + n, *R2 = R + 2 * n;   /* (R1, R2 read for k > 1, 2) */
    if (k == 3) {                  /* whole rows (contiguous, two entries a step): entry (i, j)
                                      for j > i is the number the mirror of (j, i) would be (S
                                      symmetric, the products commute); in place too (each
                                      entry is read by its own row before it is written) */
        for (int i = 0; i < n; i++) {
            double *o = out + i * n;
            const double *Si = S + i * n;
            const double r0 = R0[i], r1 = R1[i], r2 = R2[i];
            int j = 0;
            if (lam == 1.0) {
                for (; j + 1 < n; j += 2) {
                    const double v0 = Si[j] + ((r0 * R0[j] + r1 * R1[j]) + r2 * R2[j]);
                    const double v1 = Si[j + 1]
                                      + ((r0 * R0[j + 1] + r1 * R1[j + 1]) + r2 * R2[j + 1]);
                    o[j] = v0;
                    o[j + 1] = v1;
                }
                if (j < n)
                    o[j] = Si[j] + ((r0 * R0[j] + r1 * R1[j]) + r2 * R2[j]);
            } else {
                for (; j + 1 < n; j += 2) {
                    const double v0 = lam * Si[j] + ((r0 * R0[j] + r1 * R1[j]) + r2 * R2[j]);
                    const double v1 = lam * Si[j + 1]
                                      + ((r0 * R0[j + 1] + r1 * R1[j + 1]) + r2 * R2[j + 1]);
                    o[j] = v0;
                    o[j + 1] = v1;
                }
                if (j < n)
                    o[j] = lam * Si[j] + ((r0 * R0[j] + r1 * R1[j]) + r2 * R2[j]);
            }
        }
        return;
    }
    for (int i = 0; i < n; i++) {
        double *lo = out + i * n;
        const double *Slo = S + i * n;
        const double r0 = R0[i], r1 = k > 1 ? R1[i] : 0.0;
        for (int j = 0; j <= i; j++) {
            double acc = 0.0;
            if (k == 2)
                acc = r0 * R0[j] + r1 * R1[j];
            else if (k == 1)
                acc = r0 * R0[j];
            else
                for (int l = 0; l < k; l++)
                    acc += R[l * n + i] * R[l * n + j];
            double v = (lam == 1.0 ? Slo[j] : lam * Slo[j]) + acc;
            lo[j] = v;
            out[j * n + i] = v;
        }
    }
}

/* the counts after one more sample of k rows */
void est_gram_count(double lam, int k, double *rows, double *decay, double *n1, double *n2)
{
    *rows += k;
    if (lam == 1.0) {
        *decay = 1.0;
        *n1 = *n2 = *rows;
        return;
    }
    *decay = lam * *decay;
    *n1 = lam * *n1 + k;
    *n2 = lam * lam * *n2 + k;
}

/* degrees of freedom of the weighted residual sum for p parameters */
double est_gram_dof(double lam, double rows, double n1, double n2, int p)
{
    if (lam == 1.0)
        return rows - p;
    return n1 > 0.0 ? n1 - p * n2 / n1 : 0.0;
}

/* n2 / n1: the weighted estimate's covariance scale (1 without forgetting) */
double est_gram_var_scale(double lam, double n1, double n2)
{
    if (lam == 1.0 || n1 <= 0.0)
        return 1.0;
    return n2 / n1;
}

/* max(z^T S z, 0) / dof, 0 for dof <= 0: z (n), S (n x n) */
double est_residual_variance(const double *S, const double *z, int n, double dof)
{
    if (dof <= 0)
        return 0.0;
    double Sz[EST_NA > EST_NZ + 1 ? EST_NA : EST_NZ + 1];
    sr_matvec(S, z, n, n, Sz);
    double q = 0.0;
    for (int i = 0; i < n; i++)
        q += z[i] * Sz[i];
    return (q > 0.0 ? q : 0.0) / dof;
}

/* -- the RLS step ------------------------------------------------------------------------------ */

/* the compilers that can be told to inline a function (the row count k of est_rls_step then
 * a constant: its short loops unrolled, the same operations in the same order) */
#if defined(__GNUC__)
#define EST_INLINE static inline __attribute__((always_inline))
#else
#define EST_INLINE static inline
#endif

/* One RLS step for H x = y with forgetting factor lam:
 * S = lam 1 + H P H^T, K = P H^T S^-1, x+ = x + K e (e = y - H x), P+ = (P - K H P) / lam
 * symmetrised. x (p), P (p x p), H (k x p), y (k) -> x_new (p), P_new (p x p), e (k), K (p x k).
 * Returns 0 ok, 1 S not positive definite, 2 non-finite numbers. */
EST_INLINE int rls_step(const double *x, const double *P, const double *H, const double *y,
                        int p, int k, double lam, double *x_new, double *P_new, double *e,
                        double *K)
{
    double PHt[EST_NZ * EST_MAXK], S[EST_MAXK * EST_MAXK], Kt[EST_MAXK * (EST_NZ + 1)];
    for (int i = 0; i < k; i++) {                            /* e = y - H x */
        double s = y[i];
        for (int j = 0; j < p; j++)
            s -= H[i * p + j] * x[j];
        e[i] = s;
    }
    for (int a = 0; a < p; a++) {                            /* P H^T: the k sums of row a
                                                                side by side, each in its order */
        double s[EST_MAXK];
        const double *Pa = P + a * p;
        for (int i = 0; i < k; i++)
            s[i] = 0.0;
        for (int j = 0; j < p; j++)
            for (int i = 0; i < k; i++)
                s[i] += Pa[j] * H[i * p + j];
        for (int i = 0; i < k; i++)
            PHt[a * k + i] = s[i];
    }
    for (int i = 0; i < k; i++)                              /* S = lam 1 + H P H^T */
        for (int j = 0; j < k; j++) {
            double s = i == j ? lam : 0.0;
            for (int a = 0; a < p; a++)
                s += H[i * p + a] * PHt[a * k + j];
            S[i * k + j] = s;
        }
    int st = sr_cholesky(S, k);
    if (st != 0)
        return st == 2 ? 2 : 1;
    for (int i = 0; i < k; i++) {                            /* K^T = S^-1 (P H^T)^T, S^-1 e */
        for (int a = 0; a < p; a++)
            Kt[i * (p + 1) + a] = PHt[a * k + i];
        Kt[i * (p + 1) + p] = e[i];
    }
    sr_cholesky_solve(S, k, Kt, p + 1);
    double total = 0.0;
    for (int i = 0; i < k; i++)
        total += e[i] * Kt[i * (p + 1) + p];                 /* e^T S^-1 e */
    for (int a = 0; a < p; a++) {
        double s = x[a];
        for (int i = 0; i < k; i++) {
            K[a * k + i] = Kt[i * (p + 1) + a];
            s += Kt[i * (p + 1) + a] * e[i];
        }
        x_new[a] = s;                                        /* x+ = x + K e */
    }
    for (int a = 0; a < p; a++) {
        total += x_new[a];
        for (int b = a; b < p; b++) {                        /* P+ = (P - K H P) / lam */
            double s1 = P[a * p + b], s2 = P[b * p + a];
            for (int i = 0; i < k; i++) {
                s1 -= K[a * k + i] * PHt[b * k + i];
                s2 -= K[b * k + i] * PHt[a * k + i];
            }
            double v = 0.5 * (s1 + s2);
            if (lam != 1.0)                                  /* (x / 1 is x: skipped) */
                v /= lam;
            P_new[a * p + b] = v;
            P_new[b * p + a] = v;
            total += v;
        }
    }
    return isfinite(total) ? 0 : 2;
}

int est_rls_step(const double *x, const double *P, const double *H, const double *y, int p,
                 int k, double lam, double *x_new, double *P_new, double *e, double *K)
{
    if (k == 3)                              /* the 3 rows of one spatial equation */
        return rls_step(x, P, H, y, p, 3, lam, x_new, P_new, e, K);
    if (k == 2)                              /* a planar robot's linear rows */
        return rls_step(x, P, H, y, p, 2, lam, x_new, P_new, e, K);
    if (k == 1)
        return rls_step(x, P, H, y, p, 1, lam, x_new, P_new, e, K);
    return rls_step(x, P, H, y, p, k, lam, x_new, P_new, e, K);
}

/* |e| / |rhs| (|rhs| floored at 1e-300), the relative a-priori residual */
double est_relative_norm(const double *e, const double *rhs, int k)
{
    double se = 0.0, sr = 0.0;
    for (int i = 0; i < k; i++)
        se += e[i] * e[i];
    for (int i = 0; i < k; i++)
        sr += rhs[i] * rhs[i];
    return sqrt(se) / est_pymax(sqrt(sr), 1e-300);
}


void est_fit_sums(const double *H, const double *y, const double *x, int k, int q,
                  double *sums)
{
    double se = 0.0, sy = 0.0;
    for (int a = 0; a < k; a++) {
        double e = y[a];
        for (int i = 0; i < q; i++)
            e -= H[a * q + i] * x[i];
        se += e * e;
        sy += y[a] * y[a];
    }
    sums[0] = se;
    sums[1] = sy;
}
