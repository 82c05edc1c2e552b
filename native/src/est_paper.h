/* The paper's solver (solver = 1): the modified RLS of eqs. 34-38 over mu and theta, and the
 * standard deviations of its estimates. */
#ifndef SR_EST_PAPER_H
#define SR_EST_PAPER_H

#include "est_types.h"

/* One sample's step from the state old into nw: the rows (est_rows: E, Ec, and the noise
 * blocks noise, rows->n_chunks chunks of m->n_used) in; every part of *nw the commit copies
 * is written (nw need not be initialised but for corr_head, corr_count). e_lin (k1), e_ang
 * (k2): the a-priori residuals (for the residual autocorrelation's commit). data: the Data
 * block (read only: the autocorrelation rings). clock: the tracker's (the sample count).
 * scratch: EST_NOISE_SCRATCH doubles. Returns 0 ok, 1 the covariance lost definiteness, 2
 * non-finite numbers, 3 an eigen-decomposition did not converge. */
int est_paper_step(const sr_estimator_model *m, const void *data, const est_core *old,
                   const est_rows *rows, const double *noise, double *scratch, est_core *nw,
                   double clock, double *e_lin, double *e_ang);

/* The standard deviations of the estimates of the state c: sd (20) floored at the error
 * scale where unobserved, data_only (20) the estimates without the prior's pull, J (20 x 20)
 * the Jacobian of the estimates in z, vec (20) the estimates, rcond (2) the excitation
 * diagnostics; infl_lin, infl_ang: the residual autocorrelation's inflations (1: none).
 * Returns 0, or 3 where an eigen-decomposition did not converge. */
int est_paper_std_parts(const sr_estimator_model *m, const est_core *c, double infl_lin,
                        double infl_ang, double *sd, double *data_only, double *J, double *vec,
                        double *rcond);

#endif /* SR_EST_PAPER_H */
