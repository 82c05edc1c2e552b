/* The standard deviations' shared machinery (est_uncertainty.h): the scale-free information of
 * a block, decomposed or factored, the solves restricted to its observed directions, and the
 * standard deviations of the estimates from a covariance and the prior's pull. */
#include "est_uncertainty.h"

#include <math.h>
#include <string.h>

#include "linalg.h"
#include "physical.h"

/* 1 where the spectrum lam (q, ascending) of a scaled information allows the Cholesky solve */
static int well_conditioned(const double *lam, int q)
{
    return q > 0 && lam[0] > EST_CHOL_RCOND * lam[q - 1];
}

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

int est_block_eigs(const double *S, int n, int q, int mode, est_eigs *out)
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
    if (mode == EST_EIGS_CHOL_SPECTRUM_FIRST && all && q > 0) {
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
    if (mode != EST_EIGS_EIGEN && st == 0 && all && well_conditioned(out->lam, q)
        && sr_cholesky(G, q) == 0) {
        inverse_of_cholesky(G, q, out->V);
        out->chol = 1;
    }
    return st;
}

void est_eigs_solve(const est_eigs *e, int q, const double *r, double *x, int *unobserved)
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

void est_observed_solve(const double *G, int q, const double *r, double *x)
{
    est_eigs e;
    int u[EST_NTH];
    est_block_eigs(G, q, q, EST_EIGS_EIGEN, &e);
    est_eigs_solve(&e, q, r, x, u);
}

void est_scatter_sd(const double *J, const double *C, const double *pull,
                    const int *unobserved_z, const double *x, int nan_to_zero, double *sd)
{
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

void est_solve_columns(const double *lam, const double *V, const double *d, const int *un,
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

void est_eigs_solve_columns(const est_eigs *e, int q, const double *R, int c, double *X)
{
    double col[EST_NTH], x[EST_NTH];
    int u[EST_NTH];
    if (!e->chol) {
        est_solve_columns(e->lam, e->V, e->d, e->unobserved, q, R, c, X);
        return;
    }
    for (int j = 0; j < c; j++) {
        for (int i = 0; i < q; i++)
            col[i] = R[i * c + j];
        est_eigs_solve(e, q, col, x, u);
        for (int i = 0; i < q; i++)
            X[i * c + j] = x[i];
    }
}

