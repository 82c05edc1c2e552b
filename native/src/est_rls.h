/* The recursive least squares the estimator's solvers share: one RLS step with a forgetting
 * factor (eqs. 34-35's form), the Gram matrices of the weighted augmented rows of every sample
 * so far (the quadratic form of the answer's residual) and their counts, the degrees of
 * freedom and variance scale of the weighted residuals. */
#ifndef SR_EST_RLS_H
#define SR_EST_RLS_H

/* One RLS step for H x = y with forgetting factor lam: S = lam 1 + H P H^T,
 * K = P H^T S^-1, x+ = x + K e (e = y - H x), P+ = (P - K H P) / lam symmetrised.
 * x (p), P (p x p), H (k x p, k <= EST_MAXK), y (k) -> x_new (p; may be x), P_new (p x p),
 * e (k), K (p x k). Returns 0 ok, 1 S not positive definite, 2 non-finite numbers. */
int est_rls_step(const double *x, const double *P, const double *H, const double *y, int p,
                 int k, double lam, double *x_new, double *P_new, double *e, double *K);

/* out = lam S + R^T R: S (n x n, symmetric), R (k x n) the augmented rows of one sample.
 * out may alias S. */
void est_gram_add(const double *S, int n, const double *R, int k, double lam, double *out);

/* the counts after one more sample of k rows: rows, the prior's remaining weight decay
 * (lam^N), n1 = sum lam^j k_j, n2 = sum lam^2j k_j */
void est_gram_count(double lam, int k, double *rows, double *decay, double *n1, double *n2);

/* degrees of freedom of the weighted residual sum for p parameters */
double est_gram_dof(double lam, double rows, double n1, double n2, int p);

/* n2 / n1: the weighted estimate's covariance scale (1 without forgetting) */
double est_gram_var_scale(double lam, double n1, double n2);

/* max(z^T S z, 0) / dof, 0 for dof <= 0: z (n), S (n x n) */
double est_residual_variance(const double *S, const double *z, int n, double dof);

/* |e| / |rhs| (|rhs| floored at 1e-300), the relative a-priori residual of k rows */
double est_relative_norm(const double *e, const double *rhs, int k);

/* The model-fit test's sums of one sample's rows H x = y (k x q, row-major) at the estimate x
 * after the step: sums[0] = sum (y - H x)^2 (the a-posteriori residuals), sums[1] = sum y^2 */
void est_fit_sums(const double *H, const double *y, const double *x, int k, int q,
                  double *sums);

#endif /* SR_EST_RLS_H */
