/* The rows of one sample: the stage of an update between its validation and the solver. From
 * a valid sample and the Data block (read only) it forms the equations E (3 x 42,
 * equations.h) the solver takes:
 *   - momentum method: eqs. 11/16 against the reference sample (the first), or against the
 *     newest stored sample at least ident.momentum_window older (the window's ring), with
 *     the angular rows about the base's position where ident.momentum_point asks;
 *   - force method: eqs. 28/31 with the measured accelerations (less the accelerometer bias
 *     estimated online, where ident.accel_bias asks), or at the centre of the differencing
 *     window with the velocities' derivatives, or (ident.diff_momentum) the derivative of the
 *     window's momentum equations;
 * their consider columns Ec (the thrust's errors, est_consider.h), and where the
 * accelerations' noise is compensated (est_eiv.h) the noise rows; with the modal columns over
 * a window, the window rows' noise rows in their noisy position and velocities instead
 * (est_rows.win_chunks, for est_modal.h's compensation only). A sample that only fills
 * the differencing history or becomes the momentum reference is stored, not solved. Nothing
 * is written to the Data block until est_rows_commit. */
#ifndef SR_EST_ROWS_H
#define SR_EST_ROWS_H

#include <stddef.h>

#include "est_types.h"

/* The rows of the valid sample (nflat values) taken at t into *rw and its noise rows into
 * noise (m->work_noise doubles): 0 with rw->stored saying what to do with it, or a rejection
 * status (SR_EST_REJECT_*) with the reason in why (whylen bytes). */
int est_rows_of_sample(const sr_estimator_model *m, const void *data, double t,
                       const double *sample, est_rows *rw, double *noise, char *why,
                       size_t whylen);

/* What the sample of rows rw leaves in the Data block: the differencing history, the momentum
 * window or reference, the thrust integrals, the accelerometer bias's fit. */
void est_rows_commit(const sr_estimator_model *m, void *data, double t, const double *sample,
                     const est_rows *rw);

/* The time of the newest sample the state holds that needs increasing times (the
 * differencing history, the momentum window, the thrust integrals, the information
 * filter's) into *last: 1, or 0 where there is none. */
int est_rows_last_time(const sr_estimator_model *m, const void *data, double *last);

#endif /* SR_EST_ROWS_H */
