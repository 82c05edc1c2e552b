/* The paper solver's step (the modified RLS of eqs. 34-38) and what the estimator reports after
 * it: the standard deviations (the data's scatter from the Gram matrices, the prior's pull
 * through the map, the delta-method Jacobian, the unobserved floor), the excitation
 * diagnostics, the drift tracker's total standard deviation, the residual autocorrelation's
 * inflation and, with signal_sd, the errors-in-variables compensation (eiv.py). Also the
 * pieces the joint solver (est_joint.c) shares: RLS step, Gram sums, tracker.
 *
 * A port of tests/oracles/estimator/kernels.py (formerly the library's) (rls_update, modified_rls_update),
 * report_kernels.py (paper_step and what it calls), solvers.py and tracking.py, written once:
 * the Python package has a layered and a fused version of the same mathematics; here there is
 * one step path. The operations follow the Python (fused) order: the estimates equal the
 * Python oracle's bit for bit; so do the standard deviations while an information block is
 * poorly conditioned (the first samples: the drift tracker's lag, the slope of round-off-sized
 * data-only estimates, turns any round-off difference there into visible sd differences).
 * Once both blocks are well conditioned (excitation diagnostic > EST_CHOL_RCOND, resp.
 * EST_LAG_RCOND for the lag) the solves take cheaper routes (issue #26: the extremes of the
 * spectrum instead of the eigen-decomposition, solves by the Cholesky factor's inverse, the
 * lag by two one-column solves): the same numbers to round-off (measured: standard deviations
 * within 5.4e-10 relative over recorded runs, planar and spatial, momentum and force, with
 * the noise options; estimates unchanged).
 *
 * Notation: z = [mu (8), theta (12)], mu = [m1, m1 b1, mn, mn bn], theta = [I1#, In#]
 * (eq. 21), D(mu) (20, eq. 23); p, r the identified entries of mu and theta; the estimates
 * (20) per body m, b (3), I (6).
 */
#include <math.h>
#include <string.h>

#include "est_internal.h"
#include "equations.h"
#include "linalg.h"
#include "physical.h"

/* Python's max(a, b) / NumPy-free builtins: b only where b > a (NaN in a is kept) */
double est_pymax(double a, double b) { return b > a ? b : a; }

/* -- the Gram matrices (uncertainty.Gram) -------------------------------------------------- */

/* out = lam S + R^T R: S (n x n, symmetric), R (k x n) the augmented rows of one sample
 * (report_kernels.est_gram_add; S + R^T R for lam = 1). out may alias S. */
void est_gram_add(const double *S, int n, const double *R, int k, double lam, double *out)
{
    /* the lower triangle, mirrored: acc = sum_l R[l][i] R[l][j] summed in the order of l
     * (written out for the k <= 3 rows of one equation); lam S skipped for lam = 1. S is
     * symmetric bit for bit (zero at the start, every update writes both triangles with one
     * number), so its upper triangle gives the same numbers: computed once. */
    const double *R0 = R, *R1 = R + n, *R2 = R + 2 * n;
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
        const double r0 = R0[i], r1 = k > 1 ? R1[i] : 0.0, r2 = k > 2 ? R2[i] : 0.0;
        if (k == 3 && lam == 1.0) {
            for (int j = 0; j <= i; j++) {
                double v = Slo[j] + ((r0 * R0[j] + r1 * R1[j]) + r2 * R2[j]);
                lo[j] = v;
                out[j * n + i] = v;
            }
            continue;
        }
        if (k == 3) {
            for (int j = 0; j <= i; j++) {
                double v = lam * Slo[j] + ((r0 * R0[j] + r1 * R1[j]) + r2 * R2[j]);
                lo[j] = v;
                out[j * n + i] = v;
            }
            continue;
        }
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

/* the counts after one more sample of k rows (Gram.counted) */
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

/* degrees of freedom of the weighted residual sum for p parameters (Gram.dof) */
double est_gram_dof(double lam, double rows, double n1, double n2, int p)
{
    if (lam == 1.0)
        return rows - p;
    return n1 > 0.0 ? n1 - p * n2 / n1 : 0.0;
}

/* n2 / n1: the weighted estimate's covariance scale (Gram.var_scale; 1 without forgetting) */
double est_gram_var_scale(double lam, double n1, double n2)
{
    if (lam == 1.0 || n1 <= 0.0)
        return 1.0;
    return n2 / n1;
}

/* max(z^T S z, 0) / dof, 0 for dof <= 0 (uncertainty.est_residual_variance): z (n), S (n x n) */
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

/* One RLS step for H x = y with forgetting factor lam (kernels.rls_update):
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

/* -- the maps between z and the estimates ------------------------------------------------------ */

/* per body: position of m in the estimates and in mu, of theta in z */
static const int EST0[2] = {0, 10}, MU0[2] = {0, 4}, ZTH0[2] = {8, 14};
/* index pairs (i, j) of the entries of I# (eq. 21) */
static const int SHARP_I[6] = {0, 0, 0, 1, 1, 2}, SHARP_J[6] = {0, 1, 2, 1, 2, 2};

/* dD/dmu (20 x 8) (report_kernels.D_jacobian): per body with c = m b, D = [m, c, c_i c_j / m],
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
            int i = SHARP_I[q], j = SHARP_J[q], row = e + 4 + q;
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

/* the 20 estimates from z: m, b = c / m, I = I#[sharp_to_project] (paper_vector_of) */
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
 * parameter (paper_jacobian) */
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

void est_full_vectors(const sr_estimator_model *m, const est_core *c, double *mu_full,
                      double *theta_full)
{
    memcpy(mu_full, m->mu0_full, sizeof(double) * EST_NMU);
    memcpy(theta_full, m->th0_full, sizeof(double) * EST_NTH);
    for (int i = 0; i < m->p; i++)
        mu_full[m->mu_active[i]] = c->mu[i];
    for (int i = 0; i < m->r; i++)
        theta_full[m->theta_active[i]] = c->theta[i];
}

/* -- the standard deviations ------------------------------------------------------------------ */

/* a scaled eigen-decomposition of an information block (uncertainty.eig_scaled), or where
 * every direction is observed well, the extremes of its spectrum and the inverse of the
 * scaled information from its Cholesky factor (chol = 1: V holds Gs^-1), which solves the
 * same systems at a fraction of the cost */
typedef struct eigs {
    double lam[EST_NTH], V[EST_NTH * EST_NTH], d[EST_NTH];
    int unobserved[EST_NTH];
    int chol;
} eigs;

/* the Cholesky solve replaces the eigen-decomposition's where the smallest eigenvalue of the
 * scaled information is above this fraction of the largest: every direction is kept
 * (SR_REL_EIG_MIN is far below) and the two solves agree to ~ eps / EST_CHOL_RCOND relative
 * (both backward stable); below it (the first samples, a poorly excited direction) the
 * eigen-decomposition decides what is observed, as uncertainty.observed_solve */
#ifndef EST_CHOL_RCOND
#define EST_CHOL_RCOND 1e-2
#endif

/* 1 where the spectrum lam (q, ascending) of a scaled information allows the Cholesky solve */
static int well_conditioned(const double *lam, int q)
{
    return q > 0 && lam[0] > EST_CHOL_RCOND * lam[q - 1];
}

/* block_eigs' modes: the eigen-decomposition only (the solves of uncertainty.observed_solve
 * as they were); the Cholesky solve where the spectrum allows it, the eigenvectors taken
 * first (expected: the block was poorly conditioned the sample before) or the spectrum alone
 * first (expected: well conditioned). The two last give the same numbers; the expectation
 * only decides which work may be wasted. */
enum { EIGS_EIGEN = 0, EIGS_CHOL_EIGEN_FIRST = 1, EIGS_CHOL_SPECTRUM_FIRST = 2 };

/* Gs^-1 (q x q, symmetric; may be the array L) from the Cholesky factor L of Gs (its lower
 * triangle, q x q): Li = L^-1 column by column, then Gs^-1 = Li^T Li. Taken once per sample
 * and block, it makes every solve with Gs a product with a matrix (independent sums, no
 * serial substitution); Gs is well conditioned where this is used (rcond > EST_CHOL_RCOND):
 * the inverse is as accurate as the solves. */
static void inverse_of_cholesky(const double *L, int q, double *Ginv)
{
    double Li[EST_NTH * EST_NTH], inv[EST_NTH];
    for (int j = 0; j < q; j++)
        inv[j] = 1.0 / L[j * q + j];
    for (int j = 0; j < q; j++) {
        Li[j * q + j] = inv[j];
        for (int i = j + 1; i < q; i++) {
            double s = 0.0;
            for (int k = j; k < i; k++)
                s -= L[i * q + k] * Li[k * q + j];
            Li[i * q + j] = s * inv[i];
        }
    }
    for (int i = 0; i < q; i++)
        for (int j = 0; j <= i; j++) {
            double s = 0.0;
            for (int k = i; k < q; k++)             /* Li[k][j] = 0 for k < j <= i */
                s += Li[k * q + i] * Li[k * q + j];
            Ginv[i * q + j] = s;
            Ginv[j * q + i] = s;
        }
}

/* the scaled information of the leading q x q block of S (n x n) (uncertainty.eig_scaled):
 * d, unobserved, and either (mode != EIGS_EIGEN, all observed, well_conditioned) its
 * inverse (from its Cholesky factor) and the extremes of its spectrum (lam[0], lam[q-1]:
 * what the excitation diagnostic and the test read; the rest NaN), or its eigenvectors and
 * whole spectrum (sr_scaled_eigh). The extremes come from sr_eigvalsh_extremes where the
 * spectrum is taken first, else from sr_eigh: the same numbers to round-off (~1e-14 relative
 * in the excitation diagnostic). Returns sr_eigh's status (0 in the Cholesky path). */
static int block_eigs(const double *S, int n, int q, int mode, eigs *out)
{
    double G[EST_NTH * EST_NTH] = {0.0};
    int all = 1, st;
    for (int i = 0; i < q; i++) {               /* sr_scaled_information of the block */
        const double g = S[i * n + i];
        out->unobserved[i] = !(g > 0.0);
        out->d[i] = sqrt(out->unobserved[i] ? 1.0 : g);
        if (out->unobserved[i])
            all = 0;
    }
    if (all) {                                  /* the same quotients, two a step (packed) */
        for (int i = 0; i < q; i++) {
            const double di = out->d[i], *Si = S + i * n;
            double *Gi = G + i * q;
            int j = 0;
            for (; j + 1 < q; j += 2) {
                const double g0 = Si[j] / (di * out->d[j]), g1 = Si[j + 1] / (di * out->d[j + 1]);
                Gi[j] = g0;
                Gi[j + 1] = g1;
            }
            if (j < q)
                Gi[j] = Si[j] / (di * out->d[j]);
        }
    } else {
        for (int i = 0; i < q; i++)
            for (int j = 0; j < q; j++)
                G[i * q + j] = (out->unobserved[i] || out->unobserved[j])
                                   ? 0.0 : S[i * n + j] / (out->d[i] * out->d[j]);
    }
    out->chol = 0;
    if (mode == EIGS_CHOL_SPECTRUM_FIRST && all && q > 0) {
        double lo, hi;
        memcpy(out->V, G, sizeof(double) * q * q);
        if (sr_eigvalsh_extremes(out->V, q, &lo, &hi) == 0) {
            for (int i = 0; i < q; i++)         /* the Cholesky path reads no other */
                out->lam[i] = NAN;
            out->lam[0] = lo;
            out->lam[q - 1] = hi;
            if (well_conditioned(out->lam, q)) {
                memcpy(out->V, G, sizeof(double) * q * q);     /* G kept for sr_eigh */
                if (sr_cholesky(out->V, q) == 0) {
                    inverse_of_cholesky(out->V, q, out->V);
                    out->chol = 1;
                    return 0;
                }
            }
        }
    }
    st = sr_eigh(G, q, out->lam, out->V);
    if (mode != EIGS_EIGEN && st == 0 && all && well_conditioned(out->lam, q)
        && sr_cholesky(G, q) == 0) {
        inverse_of_cholesky(G, q, out->V);
        out->chol = 1;
    }
    return st;
}

/* x (q) = G^-1 r in the directions G observes and unobserved (q) the parameters that touch
 * a direction it does not (sr_eig_solve), from block_eigs' e */
static void eigs_solve(const eigs *e, int q, const double *r, double *x, int *unobserved)
{
    if (!e->chol) {
        sr_eig_solve(e->lam, e->V, e->d, e->unobserved, r, q, x, unobserved);
        return;
    }
    double rd[EST_NTH];
    for (int i = 0; i < q; i++) {               /* x = Gs^-1 (r / d) / d */
        rd[i] = r[i] / e->d[i];
        unobserved[i] = 0;
    }
    for (int i = 0; i < q; i++) {
        const double *Vi = e->V + i * q;
        double s = 0.0;
        for (int k = 0; k < q; k++)
            s += Vi[k] * rd[k];
        x[i] = s / e->d[i];
    }
}

/* x (q) = G^-1 r in the directions the information G (q x q) observes
 * (uncertainty.observed_solve) */
static void observed_solve(const double *G, int q, const double *r, double *x)
{
    eigs e;
    int u[EST_NTH];
    block_eigs(G, q, q, EIGS_EIGEN, &e);
    eigs_solve(&e, q, r, x, u);
}

/* K P K^T (q x q) with K = 1 + (S - N)^-1 N in the directions S - N observes
 * (solvers.compensation_gain, PaperSolver._covariances): the bias-compensated answer moves
 * K times as far as the RLS's. S, N (n x n), their leading q x q blocks; P (q x q). */
void est_compensated_covariance(const double *S, const double *N, int n, int q,
                                const double *P, double *out)
{
    double G[EST_NZ * EST_NZ] = {0.0}, K[EST_NZ * EST_NZ], KP[EST_NZ * EST_NZ];
    double col[EST_NZ], x[EST_NZ], V[EST_NZ * EST_NZ], lam[EST_NZ], d[EST_NZ];
    int un[EST_NZ], u[EST_NZ];
    for (int i = 0; i < q; i++)
        for (int j = 0; j < q; j++)
            G[i * q + j] = S[i * n + j] - N[i * n + j];
    sr_scaled_eigh(G, q, lam, V, d, un);
    for (int j = 0; j < q; j++) {                        /* column j of (S - N)^-1 N */
        for (int i = 0; i < q; i++)
            col[i] = N[i * n + j];
        sr_eig_solve(lam, V, d, un, col, q, x, u);
        for (int i = 0; i < q; i++)
            K[i * q + j] = (i == j ? 1.0 : 0.0) + x[i];
    }
    sr_matmul(K, P, q, q, q, KP);
    for (int i = 0; i < q; i++)                          /* (K P) K^T */
        for (int j = 0; j < q; j++) {
            double s = 0.0;
            for (int l = 0; l < q; l++)
                s += KP[i * q + l] * K[j * q + l];
            out[i * q + j] = s;
        }
}

/* The prior's pull delta (20) on z and the unobserved entries of z (20)
 * (report_kernels.paper_prior_pull): mu: delta = -G^-1 W0 (mu - mu0); theta is affine in D, so
 * theta - theta_LS = G^-1 [-W0 (theta - theta0) + S_phi,psi (D(mu) - D(mu_LS))]. */
static void prior_pull(const sr_estimator_model *m, const est_core *c, const double *mu_full,
                       const double *Tm, double w_mu, double w_theta, const eigs *el,
                       const eigs *ea, double *delta, int *unobserved)
{
    int p = m->p, r = m->r, na = m->na;
    double rhs[EST_NTH], d_mu[EST_NMU], d_th[EST_NTH];
    int u_mu[EST_NMU], u_th[EST_NTH];
    for (int i = 0; i < p; i++)                              /* -W0 (x - x0) */
        rhs[i] = -(w_mu * (c->mu[i] - m->mu0[i]));
    eigs_solve(el, p, rhs, d_mu, u_mu);
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
    eigs_solve(ea, r, rhs, d_th, u_th);
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

/* Covariance (20 x 20) of z (report_kernels.paper_covariance): Cov(mu) = s2_lin P_mu;
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

static int paper_std_parts(const sr_estimator_model *m, const est_core *c, double infl_lin,
                           double infl_ang, double *sd, double *data_only, double *J,
                           double *vec, double *rcond, eigs *eig_out,
                           const double *expect_rcond)
{
    int p = m->p, r = m->r, nl = m->nl, na = m->na;
    double lam = m->opt.lambda;
    /* the RLS's full mu (its prior's pull), and what the estimates report: the same, or the
     * bias-compensated answers where the accelerations' noise is compensated (eiv.py) */
    double mu_rls[EST_NMU], mu_full[EST_NMU], th_full[EST_NTH], D_rep[EST_ND];
    const double *mu_rep = c->mu, *th_rep = c->theta, *P_lin = c->P_mu, *P_ang = c->P_th;
    double KPK_lin[EST_NMU * EST_NMU], KPK_ang[EST_NTH * EST_NTH];
    est_full_vectors(m, c, mu_rls, th_full);
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
     * [theta, -1, -D(mu)] (paper_residual_variances) */
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
    eigs eg_local[2];                        /* into eig_out where given (no copy) */
    eigs *el = eig_out ? &eig_out[0] : &eg_local[0], *ea = eig_out ? &eig_out[1] : &eg_local[1];
    /* expect_rcond (2): the excitation diagnostics of the state before, which say which
     * work is likely needed (not what is computed) */
    int st_l = block_eigs(c->S_lin, nl, p, expect_rcond[0] > EST_CHOL_RCOND
                          ? EIGS_CHOL_SPECTRUM_FIRST : EIGS_CHOL_EIGEN_FIRST, el);
    int st_a = block_eigs(c->S_ang, na, r, expect_rcond[1] > EST_CHOL_RCOND
                          ? EIGS_CHOL_SPECTRUM_FIRST : EIGS_CHOL_EIGEN_FIRST, ea);
    double w_mu = c->decay_lin * (1.0 / m->opt.P0_mu);      /* the prior's remaining weight */
    double w_theta = c->decay_ang * (1.0 / m->opt.P0_theta);
    double z[EST_NZ], zd[EST_NZ], delta[EST_NZ], x[EST_NZ], xd[EST_NZ], pull[EST_NZ];
    int unobserved_z[EST_NZ];
    memcpy(z, mu_full, sizeof mu_full);
    memcpy(z + EST_NMU, th_full, sizeof th_full);
    jacobian(m->sharp_to_project, z, J);
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
    vector_of(m->sharp_to_project, z, x);
    for (int i = 0; i < EST_NZ; i++)
        zd[i] = z[i] - delta[i];
    vector_of(m->sharp_to_project, zd, xd);
    int finite = 1;
    for (int i = 0; i < EST_NZ; i++) {                       /* the pull through the map */
        pull[i] = x[i] - xd[i];
        if (!isfinite(pull[i]))
            finite = 0;
    }
    if (!finite)                                             /* the data-only mass <= 0 */
        sr_matvec(J, delta, EST_NZ, EST_NZ, pull);
    /* sd^2 = diag(J C J^T) + pull^2 (scatter_and_pull) */
    double C[EST_NZ * EST_NZ];
    covariance(m, P_lin, P_ang, Tm_rep, s2_lin, s2_ang, C);
    est_scatter_sd(m, J, C, pull, unobserved_z, x, 1, sd);
    for (int i = 0; i < EST_NZ; i++) {
        data_only[i] = x[i] - pull[i];
        vec[i] = x[i];
    }
    rcond[0] = sr_rcond_of_spectrum(el->lam, el->unobserved, p);
    rcond[1] = sr_rcond_of_spectrum(ea->lam, ea->unobserved, r);
    return (st_l != 0 || st_a != 0) ? 3 : 0;
}

/* sd (20) of the estimates x (20): sqrt(diag(J C J^T) + pull^2) (scatter_and_pull; J (20 x 20)
 * has few entries per row: the sums over them, the zeros would add exact zeros), a negative
 * or NaN variance giving 0 (nan_to_zero, report_kernels.paper_uncertainty) or NaN
 * (np.sqrt(np.clip(var, 0))); an estimate whose row of J touches an unobserved entry of z
 * (unobserved_z (20)) at least its error scale (solvers.ParameterSolver.std_parts) */
void est_scatter_sd(const sr_estimator_model *m, const double *J, const double *C,
                    const double *pull, const int *unobserved_z, const double *x,
                    int nan_to_zero, double *sd)
{
    (void)m;
    int unobserved[EST_NZ], any = 0;
    for (int i = 0; i < EST_NZ; i++) {
        const double *Ji = J + i * EST_NZ;
        int nz[EST_NZ], nnz = 0;
        unobserved[i] = 0;
        for (int k = 0; k < EST_NZ; k++)
            if (Ji[k] != 0.0) {
                nz[nnz++] = k;
                if (unobserved_z[k])
                    unobserved[i] = 1;
            }
        double s = 0.0;
        for (int b = 0; b < nnz; b++) {
            double jc = 0.0;                                 /* (J C)_il */
            for (int a = 0; a < nnz; a++)
                jc += Ji[nz[a]] * C[nz[a] * EST_NZ + nz[b]];
            s += jc * Ji[nz[b]];
        }
        double var = s + pull[i] * pull[i];
        if (nan_to_zero)
            sd[i] = var > 0.0 ? sqrt(var) : 0.0;
        else
            sd[i] = var != var ? var : sqrt(var > 0.0 ? var : 0.0);
        any |= unobserved[i];
    }
    if (any) {                     /* an unobserved estimate: at least its error scale (100 %) */
        double floor_[EST_NZ];
        sr_error_scale(x, SR_COM_SCALE_MIN, floor_);
        for (int i = 0; i < EST_NZ; i++)
            if (unobserved[i] && !(sd[i] != sd[i] || sd[i] >= floor_[i]))
                sd[i] = floor_[i];
    }
}

int est_std_parts(const sr_estimator_model *m, const est_core *c, double infl_lin,
                  double infl_ang, double *sd, double *data_only, double *J, double *vec,
                  double *rcond)
{
    const double expect[2] = {c->rcond_mu, c->rcond_theta};
    if (m->opt.solver == 1)
        return paper_std_parts(m, c, infl_lin, infl_ang, sd, data_only, J, vec, rcond, NULL,
                               expect);
    return est_joint_std_parts(m, c, infl_lin, sd, data_only, J, vec);
}

/* -- the drift tracker (tracking.py, docs/identification.md section 7) --------------------- */

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

/* (A r, r) of one least-squares problem (tracking eq. 2; report_kernels.est_block_lag):
 * A = G^-1 M (information-weighted mean age), r = (1 - growth A)^-1 rate; G, M (q x q, read
 * from the leading blocks of n x n matrices), rate (q). NaN where a matrix is singular. */
void est_block_lag(const double *G_full, const double *M_full, int n, int q,
                      const double *rate, double growth, double *Ar, double *r_out,
                      double *extra)
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

/* the excitation diagnostics (of both blocks) above which block_lag_two_solves serves
 * est_block_lag: measured on recorded runs (planar and spatial, both methods, the noise
 * options), no standard deviation moves by more than 1e-9 relative down to 1e-4; at 1e-6 the
 * first samples' (meaningless, ~1e20) ones do */
#ifndef EST_LAG_RCOND
#define EST_LAG_RCOND 1e-3
#endif

/* est_block_lag by two solves of one column instead of a q-column one: (1 - growth A) r =
 * rate with A = G^-1 M is (G - growth M) r = G rate, and A r = G^-1 (M r): a third of the
 * work. The same numbers to round-off; taken where both information blocks are well
 * conditioned (the rounding of est_block_lag's G^-1 M is then what both agree to), never in
 * the first, poorly excited samples, whose standard deviations amplify any rounding. */
static void block_lag_two_solves(const double *G_full, const double *M_full, int n, int q,
                                 const double *rate, double growth, double *Ar,
                                 double *r_out, double *extra, const eigs *eg)
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
 * estimates show: J L(J^-1 rate_x) with L the lag of z (report_kernels.paper_drift_lag:
 * mu by eq. 2; theta, the batch answer at the latest mu, by eq. 2 plus its response to mu's
 * lag and rate, G^-1 (S_phi,psi dD/dmu lag_mu - M_phi,psi dD/dmu r_mu)).
 * Returns 1 if finite (else no matrix lag). */
static int estimates_lag(const sr_estimator_model *m, const est_core *c, const double *J,
                         const double *rate_x, double growth, const double *mu_full,
                         double *lag, const eigs *eg)
{
    int p = m->p, r = m->r, nl = m->nl, na = m->na;
    double Jc[EST_NZ * EST_NZ], rate_z[EST_NZ];
    if (!jacobian_solve(m->sharp_to_project, J, rate_x, rate_z)) {    /* J^-1 rate_x */
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
        block_lag_two_solves(c->S_lin, c->age_lin, nl, p, rate_mu, growth, lag_mu, r_mu, NULL,
                             eg ? &eg[0] : NULL);
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
        block_lag_two_solves(c->S_ang, c->age_ang, na, r, rate_th, growth, lag_th, r_th, rhs,
                             eg ? &eg[1] : NULL);
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

/* out = lam (age + step S) (n x n), its first `rows` rows: what the lag reads of the
 * age-weighted Gram matrix (est_block_lag: the leading q x q block; estimates_lag: rows < r of
 * the theta block); the rows below stay as they are (zero) */
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

/* The tracker after the sample of clock t (DriftTracker.add, report_kernels.paper_tracker_add
 * and total_sd): the data's weight and mean age, the weighted forgetting line through the
 * data-only estimates x (20) with weights 1 / sd^2 (sd (20), floored at the round-off of the
 * step's estimates nw->vec, which the step wrote before), the age-weighted Gram matrices
 * stepped with the Gram matrices before the sample (old), the lag (eq. 2 where every line has
 * a spread, else eq. 1) and the total standard deviations into nw->sd. J (20 x 20) the
 * Jacobian of the estimates, mu_full (8) after the sample. */
static void tracker_add(const sr_estimator_model *m, const est_core *old, est_core *nw,
                        double t, const double *x, const double *sd, const double *J,
                        const double *mu_full, const eigs *eg);

void est_tracker_add(const sr_estimator_model *m, const est_core *old, est_core *nw,
                        double t, const double *x, const double *sd, const double *J,
                        const double *mu_full)
{
    tracker_add(m, old, nw, t, x, sd, J, mu_full, NULL);
}

/* est_tracker_add; eg (2, may be NULL): the paper solver's block_eigs of nw's information
 * blocks (their Cholesky factors serve the lag's solves) */
static void tracker_add(const sr_estimator_model *m, const est_core *old, est_core *nw,
                        double t, const double *x, const double *sd, const double *J,
                        const double *mu_full, const eigs *eg)
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
    double rate[EST_NZ], gain[EST_NZ], scale[EST_NZ];
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
        rate[i] = nw->tr_ctt[i] > 0.0 ? nw->tr_ctx[i] / nw->tr_ctt[i] : 0.0;
        double spread = sqrt(nw->tr_ctt[i] / wi);
        gain[i] = spread > 0.0 ? est_pymax(lag_factor / spread, 1.0) : 1.0;
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
    double lag[EST_NZ];
    int has_lag = 0;
    if (all_positive) {
        double growth = a_bar > 0.0 ? da_dt / a_bar : 0.0;
        has_lag = m->opt.solver == 1 ? estimates_lag(m, nw, J, rate, growth, mu_full, lag, eg)
                                     : est_joint_lag(m, nw, J, rate, growth, lag);
    }
    double factor = a_bar / est_pymax(1.0 - da_dt, 0.1);
    for (int i = 0; i < EST_NZ; i++) {          /* sd^2 + max(0, lag^2 - (NOISE_LAG g sd)^2) */
        double l = has_lag ? lag[i] : rate[i] * factor;
        double sd2 = sd[i] * sd[i], g = EST_NOISE_LAG * gain[i];
        double excess = est_pymax(l * l - (g * g) * sd2, 0.0);
        nw->sd[i] = sqrt(sd2 + excess);
    }
    nw->tr_s0 = s0;
    nw->tr_s1 = s1;
    nw->tr_t_ref = t_ref;
    nw->tr_t = t;
    nw->tr_a_bar = a_bar;
}

/* -- the residual autocorrelation (uncertainty.Autocorrelation) ------------------------------ */

static double *corr_sums(const sr_estimator_model *m, const void *data, int eq)
{
    return (double *)((char *)data + (eq == 0 ? m->off_corr_lin : m->off_corr_ang));
}

/* c_j after adding e: lam c_j + e . e_(t-j) (write: into the sums and the ring) and the
 * inflation max(1, 1 + 2 sum_j (1 - j/(L+1)) c_j / c_0) (report_kernels.autocorrelation_add) */
static double corr_add(const sr_estimator_model *m, const void *data, const est_core *c, int eq,
                       const double *e, int k, int write)
{
    int L = m->lags;
    double lam = m->opt.lambda;
    double *cs = corr_sums(m, data, eq), *ring = cs + (L + 1);
    int head = c->corr_head[eq], count = c->corr_count[eq];
    double s = 0.0;
    for (int a = 0; a < k; a++)
        s += e[a] * e[a];
    double c0 = (lam != 1.0 ? cs[0] * lam : cs[0]) + s;
    double acc = 0.0;
    int row = head;
    for (int j = 1; j <= L; j++) {
        double cj = lam != 1.0 ? cs[j] * lam : cs[j];
        if (j <= count) {                                    /* lag j: the row j back */
            row = row > 0 ? row - 1 : L - 1;
            double d = 0.0;
            for (int a = 0; a < k; a++)
                d += e[a] * ring[row * k + a];
            cj += d;
        }
        acc += (1.0 - j / (L + 1.0)) * cj;
        if (write)
            cs[j] = cj;
    }
    if (write) {
        cs[0] = c0;
        for (int a = 0; a < k; a++)
            ring[head * k + a] = e[a];
    }
    if (!(c0 > 0.0))
        return 1.0;
    double f = 1.0 + 2.0 * (acc / c0);
    return f > 1.0 ? f : 1.0;
}

double est_corr_current(const sr_estimator_model *m, const void *data, int eq)
{
    int L = m->lags;
    if (L == 0)
        return 1.0;
    const double *cs = corr_sums(m, data, eq);
    double acc = 0.0;
    for (int j = 1; j <= L; j++)
        acc += (1.0 - j / (L + 1.0)) * cs[j];
    if (!(cs[0] > 0.0))
        return 1.0;
    double f = 1.0 + 2.0 * (acc / cs[0]);
    return f > 1.0 ? f : 1.0;
}

double est_corr_inflation(const sr_estimator_model *m, const void *data, const est_core *c,
                          int eq, const double *e, int k)
{
    return corr_add(m, data, c, eq, e, k, 0);
}

void est_corr_commit(const sr_estimator_model *m, void *data, est_core *c, int eq,
                     const double *e, int k)
{
    corr_add(m, data, c, eq, e, k, 1);
    c->corr_head[eq] = (c->corr_head[eq] + 1) % m->lags;
    if (c->corr_count[eq] < m->lags)
        c->corr_count[eq]++;
}

/* -- one step ---------------------------------------------------------------------------------- */

void est_core_commit(const sr_estimator_model *m, est_core *dst, const est_core *src)
{
#define EST_COPY(f, count) memcpy(dst->f, src->f, sizeof(double) * (size_t)(count))
    int p = m->p, r = m->r, nl = m->nl, na = m->na, nj = m->q + 1;
    if (m->opt.solver == 1) {
        EST_COPY(mu, p);
        EST_COPY(P_mu, p * p);
        EST_COPY(theta, r);
        EST_COPY(P_th, r * r);
        EST_COPY(M, r * EST_ND);
        EST_COPY(D, EST_ND);
        EST_COPY(S_lin, nl * nl);
        EST_COPY(S_ang, na * na);
        EST_COPY(age_lin, p * nl);           /* (the rows age_step writes) */
        EST_COPY(age_ang, r * na);
        if (m->eiv) {
            EST_COPY(N_lin, nl * nl);
            EST_COPY(N_ang, na * na);
            EST_COPY(mu_c, p);
            EST_COPY(th_c, r);
            dst->has_eiv = src->has_eiv;
        }
    } else {
        EST_COPY(pi, EST_NZ);
        EST_COPY(P_pi, m->q * m->q);
        EST_COPY(S_pi, nj * nj);
        EST_COPY(age_pi, m->q * nj);
        EST_COPY(info_lin, m->n_lin_cols * m->n_lin_cols);
        EST_COPY(info_ang, m->n_ang_cols * m->n_ang_cols);
        if (m->eiv) {
            EST_COPY(N_pi, nj * nj);
            EST_COPY(pi_c, EST_NZ);
            dst->has_eiv = src->has_eiv;
        }
    }
    EST_COPY(tr_w, EST_NZ);
    EST_COPY(tr_mt, EST_NZ);
    EST_COPY(tr_mx, EST_NZ);
    EST_COPY(tr_ctt, EST_NZ);
    EST_COPY(tr_ctx, EST_NZ);
    EST_COPY(vec, EST_NZ);
    EST_COPY(sd, EST_NZ);
    if (m->consider) {
        EST_COPY(cons_lin, (m->opt.solver == 1 ? p : m->q) * SR_N_CONSIDER);
        if (m->opt.solver == 1)
            EST_COPY(cons_ang, r * SR_N_CONSIDER);
    }
#undef EST_COPY
    dst->rows_lin = src->rows_lin;
    dst->rows_ang = src->rows_ang;
    dst->decay_lin = src->decay_lin;
    dst->decay_ang = src->decay_ang;
    dst->n1_lin = src->n1_lin;
    dst->n2_lin = src->n2_lin;
    dst->n1_ang = src->n1_ang;
    dst->n2_ang = src->n2_ang;
    dst->tr_s0 = src->tr_s0;
    dst->tr_s1 = src->tr_s1;
    dst->tr_t_ref = src->tr_t_ref;
    dst->tr_t = src->tr_t;
    dst->tr_a_bar = src->tr_a_bar;
    for (int i = 0; i < 2; i++) {
        dst->corr_head[i] = src->corr_head[i];
        dst->corr_count[i] = src->corr_count[i];
    }
    dst->residual_lin = src->residual_lin;
    dst->residual_ang = src->residual_ang;
    dst->rcond_mu = src->rcond_mu;
    dst->rcond_theta = src->rcond_theta;
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

void est_noise_begin(const sr_estimator_model *m, const est_core *old, double *N_a,
                     double *N_b)
{
    double lam = m->opt.lambda;
    int na_ = m->opt.solver == 1 ? m->nl : m->q + 1, nb_ = m->opt.solver == 1 ? m->na : 0;
    const double *Oa = m->opt.solver == 1 ? old->N_lin : old->N_pi;
    for (int i = 0; i < na_ * na_; i++)     /* lam N (Gram.add: lam S + R^T R) */
        N_a[i] = !old->has_eiv ? 0.0 : lam == 1.0 ? Oa[i] : lam * Oa[i];
    for (int i = 0; i < nb_ * nb_; i++)
        N_b[i] = !old->has_eiv ? 0.0 : lam == 1.0 ? old->N_ang[i] : lam * old->N_ang[i];
}

void est_noise_add(const sr_estimator_model *m, const est_core *old, const double *blocks,
                   int nblocks, double *N_a, double *N_b, double *scratch)
{
    if (nblocks <= 0)
        return;
    if (nblocks > EST_MAXCH)                 /* the callers' chunks: never more */
        nblocks = EST_MAXCH;
    if (m->opt.solver == 1) {                /* rows [A | b] and [phi | y | psi] */
        double mu_full[EST_NMU], th_full[EST_NTH];
        double *Rn_lin = scratch, *Rn_ang = scratch + 3 * EST_MAXCH * EST_NL;
        est_full_vectors(m, old, mu_full, th_full);
        identified_rows(m, blocks, nblocks, mu_full, th_full, Rn_lin, Rn_ang);
        est_gram_add(N_a, m->nl, Rn_lin, nblocks * m->k1, 1.0, N_a);   /* (in place) */
        est_gram_add(N_b, m->na, Rn_ang, nblocks * m->k2, 1.0, N_b);
        return;
    }
    int q = m->q, nj = q + 1, k = m->k1 + m->k2;   /* rows [H | yy] (JointSolver._stack) */
    double H[EST_MAXK * EST_NZ], yy[EST_MAXK], *R = scratch;
    for (int blk = 0; blk < nblocks; blk++) {
        est_joint_rows(m, old, blocks + 3 * blk * SR_N_COLS, H, yy, NULL);
        for (int a = 0; a < k; a++) {
            memcpy(R + (blk * k + a) * nj, H + a * q, sizeof(double) * q);
            R[(blk * k + a) * nj + q] = yy[a];
        }
    }
    est_gram_add(N_a, nj, R, nblocks * k, 1.0, N_a);
}

/* the bias-compensated answers (PaperSolver._compensated, eiv.compensation):
 * (S_AA - N_AA) dmu = N_AA mu_r - N_Ab,
 * (S_pp - N_pp) dtheta = N_pp theta_r - N_py - N_ppsi D(mu_c) + S_ppsi (D(mu_c) - D(mu_r)),
 * each in the directions S - N observes; from nw's RLS answers, S and N */
static void compensate(const sr_estimator_model *m, est_core *nw)
{
    int p = m->p, r = m->r, nl = m->nl, na = m->na;
    double G[EST_NTH * EST_NTH] = {0.0}, rhs[EST_NTH], dx[EST_NTH];
    for (int i = 0; i < p; i++) {
        double s = 0.0;
        for (int j = 0; j < p; j++) {
            G[i * p + j] = nw->S_lin[i * nl + j] - nw->N_lin[i * nl + j];
            s += nw->N_lin[i * nl + j] * nw->mu[j];
        }
        rhs[i] = s - nw->N_lin[i * nl + p];
    }
    observed_solve(G, p, rhs, dx);
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
    observed_solve(G, r, rhs, dx);
    for (int i = 0; i < r; i++)
        nw->th_c[i] = nw->theta[i] + dx[i];
}

static void paper_consider_shift(const sr_estimator_model *m, const est_core *nw,
                                 const eigs *el, const eigs *ea, double *shift);
static void consider_add(const sr_estimator_model *m, est_core *nw, const double *J,
                         double *shift);

int est_paper_step(const sr_estimator_model *m, const void *data, const est_core *old,
                   est_core *nw, const double *E, const double *Ec, const double *N_lin,
                   const double *N_ang, double clock, double *e_lin, double *e_ang)
{
    int p = m->p, r = m->r, k1 = m->k1, k2 = m->k2, nl = m->nl, na = m->na;
    double lam = m->opt.lambda;
    double mu_full[EST_NMU], th_full[EST_NTH];
    est_full_vectors(m, old, mu_full, th_full);
    /* the identified rows, weighted by their noise (1 / row_sd), the parameters that are not
     * identified moved to the right-hand sides (Identifier._identified_rows,
     * PaperSolver._active): A mu = b (eq. 11 / 28), phi theta = y + psi D(mu) (eq. 16 / 31) */
    double A[3 * EST_NMU], b[3], phi[3 * EST_NTH], y[3], psi[3 * EST_ND];
    double rowf[SR_N_COLS];
    for (int a = 0; a < k1; a++) {
        const double *row = E + m->rows_lin[a] * SR_N_COLS;
        for (int j = 0; j <= SR_COL_B; j++)
            rowf[j] = m->w_lin != 1.0 ? row[j] * m->w_lin : row[j];
        double s = 0.0;
        for (int o = 0; o < m->n_mu_out; o++)
            s += rowf[SR_COL_A + m->mu_out[o]] * mu_full[m->mu_out[o]];
        b[a] = m->n_mu_out ? rowf[SR_COL_B] - s : rowf[SR_COL_B];
        for (int i = 0; i < p; i++)
            A[a * p + i] = rowf[SR_COL_A + m->mu_active[i]];
    }
    for (int a = 0; a < k2; a++) {
        const double *row = E + m->rows_ang[a] * SR_N_COLS;
        for (int j = SR_COL_PHI; j < SR_N_COLS; j++)
            rowf[j] = m->w_ang != 1.0 ? row[j] * m->w_ang : row[j];
        double s = 0.0;
        for (int o = 0; o < m->n_th_out; o++)
            s += rowf[SR_COL_PHI + m->th_out[o]] * th_full[m->th_out[o]];
        y[a] = m->n_th_out ? rowf[SR_COL_Y] - s : rowf[SR_COL_Y];
        for (int i = 0; i < r; i++)
            phi[a * r + i] = rowf[SR_COL_PHI + m->theta_active[i]];
        memcpy(psi + a * EST_ND, rowf + SR_COL_PSI, sizeof(double) * EST_ND);
    }

    /* the modified RLS (eqs. 34-38; kernels.modified_rls_update) */
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
    for (int i = 0; i < r; i++) {            /* M+ = M + K (psi - phi M) = (1 - K phi) M + K psi */
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
    if (!isfinite(total))
        return 2;
    memcpy(nw->D, D_new, sizeof D_new);

    /* the Gram matrices of the augmented rows [A | b], [phi | y | psi] */
    double R_lin[3 * EST_NL], R_ang[3 * EST_NA];
    for (int a = 0; a < k1; a++) {
        memcpy(R_lin + a * nl, A + a * p, sizeof(double) * p);
        R_lin[a * nl + p] = b[a];
    }
    for (int a = 0; a < k2; a++) {
        memcpy(R_ang + a * na, phi + a * r, sizeof(double) * r);
        R_ang[a * na + r] = y[a];
        memcpy(R_ang + a * na + r + 1, psi + a * EST_ND, sizeof(double) * EST_ND);
    }
    est_gram_add(old->S_lin, nl, R_lin, k1, lam, nw->S_lin);
    est_gram_add(old->S_ang, na, R_ang, k2, lam, nw->S_ang);
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

    /* the accelerations' noise: its expected part of the Gram matrices, the compensated
     * answers (eiv.py) */
    nw->has_eiv = old->has_eiv;
    if (N_lin && N_ang) {                    /* eq. 1, est_noise_begin / est_noise_add */
        memcpy(nw->N_lin, N_lin, sizeof(double) * nl * nl);
        memcpy(nw->N_ang, N_ang, sizeof(double) * na * na);
        nw->has_eiv = 1;
        compensate(m, nw);
    } else if (old->has_eiv) {               /* (a sample without noise rows: none come) */
        memcpy(nw->N_lin, old->N_lin, sizeof nw->N_lin);
        memcpy(nw->N_ang, old->N_ang, sizeof nw->N_ang);
        compensate(m, nw);
    }
    /* the standard deviations, the excitation diagnostics, the tracker */
    double infl_lin = 1.0, infl_ang = 1.0;
    if (m->lags > 0) {
        infl_lin = est_corr_inflation(m, data, old, 0, e_lin, k1);
        infl_ang = est_corr_inflation(m, data, old, 1, e_ang, k2);
    }
    double sd[EST_NZ], data_only[EST_NZ], J[EST_NZ * EST_NZ], rcond[2];
    eigs eg[2];
    const double expect[2] = {old->rcond_mu, old->rcond_theta};
    if (paper_std_parts(m, nw, infl_lin, infl_ang, sd, data_only, J, nw->vec, rcond, eg,
                        expect) != 0)
        return 3;
    nw->rcond_mu = rcond[0];
    nw->rcond_theta = rcond[1];
    if (nw->has_eiv)                         /* the tracker's lag at the reported mu */
        for (int i = 0; i < p; i++)
            mu_new[m->mu_active[i]] = nw->mu_c[i];
    tracker_add(m, old, nw, clock, data_only, sd, J, mu_new, eg);
    if (m->consider) {                       /* the thrust's consider term (consider.py) */
        double shift[EST_NZ * SR_N_CONSIDER];
        est_consider_sums(m, old, nw, Ec, A, phi, NULL);
        paper_consider_shift(m, nw, &eg[0], &eg[1], shift);   /* the spectra just taken */
        consider_add(m, nw, J, shift);
    }
    return 0;
}

/* -- the thrust's consider term (consider.py, solvers.ParameterSolver.consider_shift) ------- */

/* X (q x c) = G^-1 R (R q x c) column by column in the directions the information G
 * observes, from its scaled eigen-decomposition (lam, V, d, unobserved of sr_scaled_eigh; q x q)
 * (solvers._observed_solve_columns) */
static void solve_columns(const double *lam, const double *V, const double *d, const int *un,
                          int q, const double *R, int c, double *X)
{
    double col[EST_NZ], x[EST_NZ];
    int u[EST_NZ];
    for (int j = 0; j < c; j++) {
        for (int i = 0; i < q; i++)
            col[i] = R[i * c + j];
        sr_eig_solve(lam, V, d, un, col, q, x, u);
        for (int i = 0; i < q; i++)
            X[i * c + j] = x[i];
    }
}

/* solve_columns from block_eigs' e (q <= EST_NTH) */
static void eigs_solve_columns(const eigs *e, int q, const double *R, int c, double *X)
{
    double col[EST_NTH], x[EST_NTH];
    int u[EST_NTH];
    if (!e->chol) {
        solve_columns(e->lam, e->V, e->d, e->unobserved, q, R, c, X);
        return;
    }
    for (int j = 0; j < c; j++) {
        for (int i = 0; i < q; i++)
            col[i] = R[i * c + j];
        eigs_solve(e, q, col, x, u);
        for (int i = 0; i < q; i++)
            X[i * c + j] = x[i];
    }
}

void est_consider_sums(const sr_estimator_model *m, const est_core *old, est_core *nw,
                       const double *Ec, const double *A, const double *phi, const double *H)
{
    const int nc = SR_N_CONSIDER, k1 = m->k1, k2 = m->k2;
    double lam = m->opt.lambda;
    /* the consider right-hand sides of the identified rows, weighted as their rows
     * (Identifier._identified_rows(b_c, y_c)) */
    double bc[3 * SR_N_CONSIDER], yc[3 * SR_N_CONSIDER];
    for (int a = 0; a < k1; a++)
        for (int c = 0; c < nc; c++) {
            double v = Ec[m->rows_lin[a] * SR_N_CCOLS + c];
            bc[a * nc + c] = m->w_lin != 1.0 ? v * m->w_lin : v;
        }
    for (int a = 0; a < k2; a++)
        for (int c = 0; c < nc; c++) {
            double v = Ec[m->rows_ang[a] * SR_N_CCOLS + nc + c];
            yc[a * nc + c] = m->w_ang != 1.0 ? v * m->w_ang : v;
        }
    if (m->opt.solver == 1) {                /* lam C + A^T b_c, lam C + phi^T y_c */
        for (int i = 0; i < m->p; i++)
            for (int c = 0; c < nc; c++) {
                double s = 0.0;
                for (int a = 0; a < k1; a++)
                    s += A[a * m->p + i] * bc[a * nc + c];
                nw->cons_lin[i * nc + c] = lam * old->cons_lin[i * nc + c] + s;
            }
        for (int i = 0; i < m->r; i++)
            for (int c = 0; c < nc; c++) {
                double s = 0.0;
                for (int a = 0; a < k2; a++)
                    s += phi[a * m->r + i] * yc[a * nc + c];
                nw->cons_ang[i * nc + c] = lam * old->cons_ang[i * nc + c] + s;
            }
        return;
    }
    for (int i = 0; i < m->q; i++)           /* lam C + Y^T [b_c; y_c] */
        for (int c = 0; c < nc; c++) {
            double s = 0.0;
            for (int a = 0; a < k1; a++)
                s += H[a * m->q + i] * bc[a * nc + c];
            for (int a = 0; a < k2; a++)
                s += H[(k1 + a) * m->q + i] * yc[a * nc + c];
            nw->cons_lin[i * nc + c] = lam * old->cons_lin[i * nc + c] + s;
        }
}

/* dz/dc (20 x 8) of the paper solver (PaperSolver.consider_shift): mu = G_lin^-1 sum A^T b,
 * theta = G_ang^-1 sum phi^T (y + psi D(mu)), so dmu/dc = G_lin^-1 C_lin and
 * dtheta/dc = G_ang^-1 (C_ang + S_phi,psi dD/dmu dmu/dc), at the reported mu; el, ea the
 * scaled eigen-decompositions of G_lin, G_ang (the p x p, r x r blocks of S_lin, S_ang) */
static void paper_consider_shift(const sr_estimator_model *m, const est_core *nw,
                                 const eigs *el, const eigs *ea, double *shift)
{
    const int nc = SR_N_CONSIDER, p = m->p, r = m->r, na = m->na;
    double dmu[EST_NMU * SR_N_CONSIDER], dth[EST_NTH * SR_N_CONSIDER];
    double rhs[EST_NTH * SR_N_CONSIDER] = {0.0}, dDdc[EST_ND * SR_N_CONSIDER];
    double mu_full[EST_NMU], th_full[EST_NTH], Dj[EST_ND * EST_NMU];
    memset(shift, 0, sizeof(double) * EST_NZ * SR_N_CONSIDER);
    eigs_solve_columns(el, p, nw->cons_lin, nc, dmu);
    est_full_vectors(m, nw, mu_full, th_full);
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
    eigs_solve_columns(ea, r, rhs, nc, dth);
    for (int i = 0; i < p; i++)
        memcpy(shift + m->mu_active[i] * nc, dmu + i * nc, sizeof(double) * nc);
    for (int i = 0; i < r; i++)
        memcpy(shift + (EST_NMU + m->theta_active[i]) * nc, dth + i * nc, sizeof(double) * nc);
}

/* nw->sd (the tracker's total) with the consider variance added, sd^2 + sd_c^2,
 * sd_c,i^2 = sum_c (J dz/dc sigma_c)_ic^2 (consider.consider_sd); shift (20 x 8) dz/dc,
 * scaled in place */
static void consider_add(const sr_estimator_model *m, est_core *nw, const double *J,
                         double *shift)
{
    const int nc = SR_N_CONSIDER;
    for (int k = 0; k < EST_NZ; k++)                         /* each parameter at 1 sigma */
        for (int c = 0; c < nc; c++)
            shift[k * nc + c] *= m->sd_c[c];
    for (int i = 0; i < EST_NZ; i++) {
        double v = 0.0;
        for (int c = 0; c < nc; c++) {
            double dx = 0.0;
            for (int k = 0; k < EST_NZ; k++)
                dx += J[i * EST_NZ + k] * shift[k * nc + c];
            v += dx * dx;
        }
        double sdc = sqrt(v), sd = nw->sd[i];
        nw->sd[i] = sqrt(sd * sd + sdc * sdc);
    }
}

void est_consider_sd(const sr_estimator_model *m, est_core *nw, const double *J)
{
    double shift[EST_NZ * SR_N_CONSIDER];
    if (m->opt.solver == 1) {
        eigs el, ea;
        block_eigs(nw->S_lin, m->nl, m->p, EIGS_CHOL_SPECTRUM_FIRST, &el);
        block_eigs(nw->S_ang, m->na, m->r, EIGS_CHOL_SPECTRUM_FIRST, &ea);
        paper_consider_shift(m, nw, &el, &ea, shift);
    } else {                                 /* d pi / d c = G^-1 C (JointSolver) */
        int q = m->q, nj = q + 1;
        double G[EST_NZ * EST_NZ] = {0.0}, lam[EST_NZ], V[EST_NZ * EST_NZ], d[EST_NZ];
        double dpi[EST_NZ * SR_N_CONSIDER];
        int un[EST_NZ];
        for (int i = 0; i < q; i++)
            for (int j = 0; j < q; j++)
                G[i * q + j] = nw->S_pi[i * nj + j];
        sr_scaled_eigh(G, q, lam, V, d, un);
        solve_columns(lam, V, d, un, q, nw->cons_lin, SR_N_CONSIDER, dpi);
        memset(shift, 0, sizeof shift);
        for (int i = 0; i < q; i++)
            memcpy(shift + m->std_active[i] * SR_N_CONSIDER, dpi + i * SR_N_CONSIDER,
                   sizeof(double) * SR_N_CONSIDER);
    }
    consider_add(m, nw, J, shift);
}
