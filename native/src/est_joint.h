/* The joint solver (solver = 2): one RLS over the 20 standard parameters (standard_params.h),
 * and the standard deviations of its estimates. */
#ifndef SR_EST_JOINT_H
#define SR_EST_JOINT_H

#include "est_types.h"

/* the joint solver's initial standard parameters and covariance into c */
void est_joint_init(const sr_estimator_model *m, est_core *c);

/* One sample's step from the state old into nw, as est_paper_step (est_paper.h); e (k1 + k2)
 * the a-priori residuals of the linear and angular rows. */
int est_joint_step(const sr_estimator_model *m, const void *data, const est_core *old,
                   const est_rows *rows, const double *noise, double *scratch, est_core *nw,
                   double clock, double *e);

/* sd, data_only, J, vec as est_paper_std_parts, of the joint solver's state c (its covariance
 * scaled by the residual variance times the autocorrelation inflation infl). 0, or 3 not
 * converged. */
int est_joint_std_parts(const sr_estimator_model *m, const est_core *c, double infl,
                        double *sd, double *data_only, double *J, double *vec);

/* The rows of one block E (3 x 42) over the identified standard parameters: H (k1 + k2 x q),
 * yy (k1 + k2) the weighted right-hand sides (the fixed parameters' columns moved there at
 * c's pi) */
void est_joint_rows(const sr_estimator_model *m, const est_core *c, const double *E, double *H,
                    double *yy);

/* The same rows as one matrix [H | yy] (k1 + k2 x q + 1), e.g. of a noise block (est_eiv.h) */
void est_joint_rows_hy(const sr_estimator_model *m, const est_core *c, const double *E,
                       double *Hy);

#endif /* SR_EST_JOINT_H */
