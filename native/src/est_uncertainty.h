/* The standard deviations' shared machinery: the scale-free information of a block of a Gram
 * matrix (its eigen-decomposition, or where every direction is observed well, the extremes of
 * its spectrum and its inverse from a Cholesky factor), the solves restricted to the
 * directions it observes, and the standard deviations of the estimates from their covariance
 * and the prior's pull (delta method: sd^2 = diag(J C J^T) + pull^2). */
#ifndef SR_EST_UNCERTAINTY_H
#define SR_EST_UNCERTAINTY_H

#include "est_types.h"

/* the Cholesky solve replaces the eigen-decomposition's where the smallest eigenvalue of the
 * scaled information is above this fraction of the largest: every direction is kept
 * (SR_REL_EIG_MIN is far below) and the two solves agree to ~ eps / EST_CHOL_RCOND relative
 * (both backward stable); below it (the first samples, a poorly excited direction) the
 * eigen-decomposition decides what is observed (sr_eig_solve) */
#ifndef EST_CHOL_RCOND
#define EST_CHOL_RCOND 1e-2
#endif

/* A scaled eigen-decomposition of an information block (sr_scaled_eigh's lam, V, d,
 * unobserved), or where every direction is observed well, the extremes of its spectrum
 * (lam[0], lam[q-1]; the rest NaN) and the inverse of the scaled information from its
 * Cholesky factor (chol = 1: V holds Gs^-1), which solves the same systems at a fraction of
 * the cost. q <= EST_NTH. */
typedef struct est_eigs {
    double lam[EST_NTH], V[EST_NTH * EST_NTH], d[EST_NTH];
    int unobserved[EST_NTH];
    int chol;
} est_eigs;

/* est_block_eigs' modes: the eigen-decomposition only; the Cholesky solve where the spectrum
 * allows it, the eigenvectors taken first (expected: the block was poorly conditioned the
 * sample before) or the spectrum alone first (expected: well conditioned). The two last give
 * the same numbers; the expectation only decides which work may be wasted. */
enum { EST_EIGS_EIGEN = 0, EST_EIGS_CHOL_EIGEN_FIRST = 1, EST_EIGS_CHOL_SPECTRUM_FIRST = 2 };

/* The scaled information of the leading q x q block of S (n x n) into *out: d, unobserved,
 * and either (mode != EST_EIGS_EIGEN, all observed, well conditioned) its inverse and the
 * extremes of its spectrum (sr_eigvalsh_extremes where the spectrum is taken first, else
 * sr_eigh's: the same numbers to round-off, ~1e-14 relative in the excitation diagnostic),
 * or its eigenvectors and whole spectrum. Returns sr_eigh's status (0 in the Cholesky
 * path). */
int est_block_eigs(const double *S, int n, int q, int mode, est_eigs *out);

/* x (q) = G^-1 r in the directions G observes, unobserved (q) the parameters that touch a
 * direction it does not (sr_eig_solve), from est_block_eigs' e */
void est_eigs_solve(const est_eigs *e, int q, const double *r, double *x, int *unobserved);

/* X (q x c) = G^-1 R (R: q x c) column by column, from e (q <= EST_NTH) */
void est_eigs_solve_columns(const est_eigs *e, int q, const double *R, int c, double *X);

/* x (q) = G^-1 r in the directions the information G (q x q, q <= EST_NTH) observes */
void est_observed_solve(const double *G, int q, const double *r, double *x);

/* X (q x c) = G^-1 R column by column in the directions the information G observes, from its
 * scaled eigen-decomposition (sr_scaled_eigh's lam, V, d, un; q <= EST_NZ) */
void est_solve_columns(const double *lam, const double *V, const double *d, const int *un,
                       int q, const double *R, int c, double *X);

/* sd (20) of the estimates x (20): sqrt(diag(J C J^T) + pull^2) (J (20 x 20) has few entries
 * per row: the sums run over them, the zeros would add exact zeros), a negative or NaN
 * variance giving 0 (nan_to_zero) or NaN (else; a negative one 0); an estimate whose row of J
 * touches an unobserved entry of z (unobserved_z (20)) at least its error scale. C (20 x 20)
 * the covariance of z, pull (20) the prior's pull on the estimates. */
void est_scatter_sd(const double *J, const double *C, const double *pull,
                    const int *unobserved_z, const double *x, int nan_to_zero, double *sd);

#endif /* SR_EST_UNCERTAINTY_H */
