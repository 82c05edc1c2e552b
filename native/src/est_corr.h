/* The residual autocorrelation: the a-priori residuals of the equations (linear and angular
 * separately for the paper's solver, one ring of both for the joint solver) over the last
 * L = corr_lags samples, their exponentially forgotten lagged sums c_j, and the inflation of
 * the residual variance for correlated equation errors,
 * max(1, 1 + 2 sum_{j=1..L} (1 - j / (L + 1)) c_j / c_0) (Bartlett's window). The sums and the
 * ring live in the Data block (sr_estimator_model's off_corr_lin, off_corr_ang); their heads
 * and counts in est_core. */
#ifndef SR_EST_CORR_H
#define SR_EST_CORR_H

#include "est_types.h"

/* The inflation after adding the residual e (k) to the ring of equation eq (0 lin, 1 ang) of
 * the Data block data whose heads and counts are c's, without writing. */
double est_corr_inflation(const sr_estimator_model *m, const void *data, const est_core *c,
                          int eq, const double *e, int k);

/* The inflation of the sums as they are. */
double est_corr_current(const sr_estimator_model *m, const void *data, int eq);

/* Add the residual e (k) to the ring of equation eq: the sums, the ring, and c's head and
 * count (the commit). */
void est_corr_commit(const sr_estimator_model *m, void *data, est_core *c, int eq,
                     const double *e, int k);

#endif /* SR_EST_CORR_H */
