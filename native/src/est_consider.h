/* The thrust's consider term: a scale factor error and a misalignment of the measured thrust,
 * constant over a run, with the prior standard deviations sigma_c (ident.sd_thrust.*) of
 * c = [s_F, phi_F (3), s_M, phi_M (3)]. The estimates are not changed; what those errors leave
 * in them is added to their standard deviations: each sample's identified rows H (weighted as
 * the solver's) with their consider right-hand sides R_c (the equations' consider columns,
 * equations.h) give the consider sums C = sum lam^j H^T R_c; the solver maps them to dz/dc
 * (G^-1 C with its information G), and sd^2 += sum_c (J dz/dc sigma_c)^2. */
#ifndef SR_EST_CONSIDER_H
#define SR_EST_CONSIDER_H

#include "est_types.h"

/* The consider right-hand sides of a sample's identified rows from its consider columns Ec
 * (3 x 16), weighted and selected as the rows: bc (k1 x 8), yc (k2 x 8) */
void est_consider_rows(const sr_estimator_model *m, const double *Ec, double *bc, double *yc);

/* The consider sums of nw after a sample, from old's and the identified rows with their
 * consider columns Ec (3 x 16), weighted and selected as the rows: the paper solver's
 * A^T b_c (p x 8) from A (k1 x p) and phi^T y_c (r x 8) from phi (k2 x r) (H NULL); the
 * joint solver's Y^T [b_c; y_c] (q x 8, into cons_lin) from H (k1 + k2 rows x q). */
void est_consider_sums(const sr_estimator_model *m, const est_core *old, est_core *nw,
                       const double *Ec, const double *A, const double *phi, const double *H);

/* nw->sd (the tracker's total) with the consider variance added, sd^2 + sd_c^2,
 * sd_c,i^2 = sum_c (J dz/dc sigma_c)_ic^2; J (20 x 20) the Jacobian of the estimates in the
 * solver's z, shift (20 x 8) dz/dc, scaled in place. */
void est_consider_add(const sr_estimator_model *m, est_core *nw, const double *J,
                      double *shift);

#endif /* SR_EST_CONSIDER_H */
