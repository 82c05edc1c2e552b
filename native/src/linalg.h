/* Small dense linear algebra of the native core: the one module every other one uses, written
 * out (no LAPACK/BLAS), each algorithm with one operation order (the same results on every
 * platform):
 *   - sr_eigh: Householder tridiagonalisation + implicit QL (EISPACK tred2 / tql2, as JAMA);
 *   - sr_lu_solve: LU with partial (row) pivoting;
 *   - sr_cholesky / sr_cholesky_solve: the Cholesky factorisation and the two triangular
 *     solves;
 *   - the scale-free eigen-decomposition of an information matrix and the solve restricted to
 *     its observed directions (sr_scaled_information, sr_scaled_eigh, sr_rcond_scaled,
 *     sr_rcond_of_spectrum, sr_eig_solve);
 *   - sr_eigvalsh_extremes: the smallest and largest eigenvalue alone (the estimator's
 *     excitation diagnostic where its information is well conditioned);
 *   - sr_qr_add_rows: a square-root information's update with a few new rows (Householder).
 * The kernels keep their operation order and thus their results bit for bit where they are
 * vectorised (two entries a step, which the compiler packs; no reassociation).
 *
 * All matrices are row-major double arrays; no allocation, no global state. Sizes are bounded
 * by SR_LINALG_MAX_N where a routine needs work space; other routines take any n >= 0.
 * Booleans in arrays are int (0 false, 1 true).
 */
#ifndef SR_LINALG_H
#define SR_LINALG_H

#include "sr_api.h"

/* largest n that sr_eigh, sr_scaled_eigh, sr_eig_solve take (work space on the stack);
 * a larger n returns status 2 */
#define SR_LINALG_MAX_N 64
/* eigenvalues of a scaled information below this fraction of the largest count as
 * unobserved (report_kernels.REL_EIG_MIN = uncertainty.REL_EIG_MIN) */
#define SR_REL_EIG_MIN 1e-12
/* |eigenvector component| above which a parameter touches an unobserved direction
 * (report_kernels.UNOBSERVED_COMPONENT) */
#define SR_UNOBSERVED_COMPONENT 1e-6

#ifdef __cplusplus
extern "C" {
#endif

/* [[R d]; rows] -> [[R' d']; 0 e]: the square-root information R (n x n upper triangular, row
 * stride ldr) and its right-hand side d (n; NULL: none, the right-hand side then R's last
 * column) updated with k <= 6 new rows (row stride ldw: n columns, then d's in column n where
 * d is given), by Householder reflections column by column (R's rows below the diagonal are
 * zero, so each touches R's row j and the new rows). The rows are overwritten: their columns
 * below n zero, column n (with d) the residual e. */
SR_API void sr_qr_add_rows(double *R, int ldr, double *d, int n, double *rows, int ldw, int k);

/* C = A B.  A (n x k), B (k x m), C (n x m); C must not alias A or B. Same loop order as
 * report_kernels._matmul (C[i][j] += A[i][l] B[l][j], l outer of j). n, k, m >= 0. */
SR_API void sr_matmul(const double *A, const double *B, int n, int k, int m, double *C);

/* y = A x.  A (n x k), x (k), y (n); y must not alias x (report_kernels.matvec). */
SR_API void sr_matvec(const double *A, const double *x, int n, int k, double *y);

/* Eigen-decomposition A = V diag(w) V^T of the symmetric A (n x n; only its lower triangle
 * and diagonal are read, as tred2 does): eigenvalues ascending into w (n), orthonormal
 * eigenvectors as the COLUMNS of V (n x n); eigenvectors of equal eigenvalues are an
 * orthonormal basis of their space. Householder tridiagonalisation + implicit QL (EISPACK
 * tred2 / tql2; report_kernels.eigh: absolute accuracy ~ eps |A|, as LAPACK's). A may be the
 * same array as V (decomposed in place). Ties keep the QL order (a stable sort); NaN last.
 * Returns 0 converged; 1 not converged in 100 iterations or non-finite input (w, V are then
 * written but meaningless); 2 n out of range (n < 0 or n > SR_LINALG_MAX_N; nothing written). */
SR_API int sr_eigh(const double *A, int n, double *w, double *V);

/* The smallest and the largest eigenvalue of the symmetric A (n x n; only its lower triangle
 * and diagonal are read; overwritten) without the rest of the spectrum: a Householder
 * reduction to a tridiagonal T (LAPACK dsytd2's arrangement, on whole rows), then Laguerre's
 * method on T's characteristic polynomial (its three-term recurrence) from Gershgorin bounds,
 * which for real roots converges monotonically to the extreme ones, cubically near simple
 * ones, both side by side, and stops where round-off stops its progress. Accuracy: ~ eps |A|
 * absolute, as sr_eigh's (the same numbers to round-off, not the same bits: measured
 * <= 3.1e-15 |A| on random matrices); an extreme eigenvalue in a cluster narrower than ~1e-9
 * relative (nearly multiple) only to ~1e-11 |A|. About a quarter of sr_eigh's time for
 * n = 8..12. Returns 0 and *lo <= *hi; 1 non-finite input, or the iteration did not settle
 * in 60 steps or overflowed (large n with large entries: use sr_eigh); 2 n out of range
 * (n < 1 or n > SR_LINALG_MAX_N). */
SR_API int sr_eigvalsh_extremes(double *A, int n, double *lo, double *hi);

/* Cholesky A = L L^T in place: A (n x n) row-major symmetric (its lower triangle is read), on
 * success the lower triangle holds L and the strict upper triangle is set to 0 (the order of
 * operations of kernels.rls_update). Returns 0 ok; 1 not positive definite (a pivot <= 0,
 * or -inf); 2 non-finite pivot (NaN or +inf). On failure A is partly overwritten. n >= 0. */
SR_API int sr_cholesky(double *A, int n);

/* Solve (L L^T) X = B in place: L (n x n) lower triangular from sr_cholesky (only its lower
 * triangle is read), B (n x ncol) row-major, overwritten by X (forward then back
 * substitution per column, as kernels.rls_update). */
SR_API void sr_cholesky_solve(const double *L, int n, double *B, int ncol);

/* Solve A X = B by LU with partial (row) pivoting (report_kernels.lu_solve, = LAPACK gesv to
 * round-off): A (n x n) is overwritten by its factors (unit-lower L below the diagonal, U on
 * and above, rows in pivot order), B (n x ncol) by X. Returns 0 ok; 1 singular (a pivot column
 * exactly 0, or NaN): B is then all NaN, as report_kernels.lu_solve returns; 2 n < 0 or
 * ncol < 0 (nothing written). For a vector right-hand side (lu_solve_vec) pass ncol = 1. */
SR_API int sr_lu_solve(double *A, int n, double *B, int ncol);

/* The scale-free information of G (p x p) (report_kernels.scaled_information):
 * d[i] = sqrt(G[i][i]) (1 where G[i][i] is not > 0: unobserved[i] = 1, else 0), Gs = G / (d d^T)
 * with the rows and columns of the unobserved set to 0. Gs (p x p) may alias G.
 * Returns 0 ok, 2 p < 0. */
SR_API int sr_scaled_information(const double *G, int p, double *Gs, double *d, int *unobserved);

/* report_kernels.eig_scaled: sr_scaled_information of G (p x p), then the eigen-decomposition
 * Gs = V diag(lam) V^T (sr_eigh): lam (p) ascending, V (p x p) eigenvectors as columns,
 * d (p), unobserved (p) as sr_scaled_information. These are what sr_eig_solve and
 * sr_rcond_of_spectrum take. V may alias G. Returns sr_eigh's status (0 converged, 1 not
 * converged / non-finite, 2 p out of range). */
SR_API int sr_scaled_eigh(const double *G, int p, double *lam, double *V, double *d,
                          int *unobserved);

/* report_kernels.rcond_scaled: Gs (p x p) = the scale-free information of G (p x p) as
 * sr_scaled_information, and whether it can go to an eigenvalue solver as it is.
 * Returns 0 when every diagonal entry of G is > 0 and every entry of Gs is finite, 1 otherwise
 * (then the caller takes the general path), 2 p < 0. Gs must not alias G. Any p >= 0. */
SR_API int sr_rcond_scaled(const double *G, int p, double *Gs);

/* report_kernels.rcond_of_spectrum: max(lam[0], 0) / lam[p-1] of the ascending spectrum lam (p)
 * of a scaled information (sr_scaled_eigh); 0 where a parameter is unobserved (unobserved (p),
 * may be NULL for none), p <= 0, or no eigenvalue is > 0. */
SR_API double sr_rcond_of_spectrum(const double *lam, const int *unobserved, int p);

/* report_kernels.eig_solve (uncertainty.observed_solve): x = G^-1 r in the directions the
 * information observes, from sr_scaled_eigh's lam (p, ascending), V (p x p), d (p),
 * unobserved (p):  x = V_k diag(1 / lam_k) V_k^T (r / d) / d  over the k with
 * lam_k > SR_REL_EIG_MIN * max(lam[p-1], 0). unobserved_out (p) = unobserved, plus every
 * parameter i with |V[i][k]| > SR_UNOBSERVED_COMPONENT for a k not kept. r (p), x (p).
 * unobserved_out may alias unobserved; x must not alias r. Returns 0 ok, 2 p out of range
 * (p < 0 or p > SR_LINALG_MAX_N; nothing written). */
SR_API int sr_eig_solve(const double *lam, const double *V, const double *d,
                        const int *unobserved, const double *r, int p, double *x,
                        int *unobserved_out);

#ifdef __cplusplus
}
#endif

#endif /* SR_LINALG_H */
