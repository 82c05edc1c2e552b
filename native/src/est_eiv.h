/* Errors in variables: noisy accelerations (or velocities) make the equations' regressors
 * noisy, and the least-squares answer biased. A sample's noise rows sigma_l C_l (C_l = E(x +
 * e_l) - E(x), the equations being affine in the noisy channels) give the expected noise part
 * of the Gram matrices, N = sum_k w_k sum_l sigma_l^2 C_l,k^T C_l,k (eq. 1); the solvers take
 * it out of their answers (bias-compensated least squares, (S - N) x_c = s - n) and report
 * the compensated answer's covariance K P K^T. */
#ifndef SR_EST_EIV_H
#define SR_EST_EIV_H

/* N (n x n) = lam N_old, or zeros where no noise rows came yet (has 0): the noise Gram
 * matrix before a sample's rows (which est_gram_add then adds with lam = 1) */
void est_noise_begin(double lam, int has, const double *N_old, int n, double *N);

/* The bias-compensated answer xc (q) = x_r + dx, (S_HH - N_HH) dx = N_HH x_r - N_Hy (eq. 2)
 * in the directions S - N observes (a direction the noise swamps is left uncorrected): S, N
 * ((n x n) Gram matrices of [H | y], q + 1 <= n, q <= 20, y's column q), x_r (q) the
 * least-squares answer (S_HH x_r = S_Hy). */
void est_compensate(const double *S, const double *N, int n, int q, const double *x,
                    double *xc);

/* K P K^T (q x q) with K = 1 + (S - N)^-1 N in the directions S - N observes: the covariance
 * of a bias-compensated answer (it moves K times as far as the RLS's). S, N (n x n), their
 * leading q x q blocks (q <= 20); P (q x q). */
void est_compensated_covariance(const double *S, const double *N, int n, int q,
                                const double *P, double *out);

#endif /* SR_EST_EIV_H */
