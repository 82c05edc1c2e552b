/* What the estimator reports, read from a Data block: the least-squares estimates and their
 * standard deviations, their projection onto real bodies, the identified flags. */
#ifndef SR_EST_REPORT_H
#define SR_EST_REPORT_H

#include "est_types.h"

/* The least-squares estimates vec (20) and standard deviations sd (20) of this estimator's
 * equations: after a sample as the step left them, before any the prior's. */
void est_least_squares(const sr_estimator_model *m, const void *data, double *vec, double *sd);

/* The reported vector out (20) of the least-squares estimates ls (20) and their sds (20):
 * flags[0..1] physical (the estimate a real body), flags[2..3] identified (small sd and the
 * reported value the estimate's); the projection onto real bodies where needed. */
void est_physical_vector(const sr_estimator_model *m, const double *ls, const double *sd,
                         double *out, int *flags);

#endif /* SR_EST_REPORT_H */
