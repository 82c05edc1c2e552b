/* The estimator's options (sr_estimator_options; their table's API: estimator.h): the excitation
 * design's options among them. */
#ifndef SR_EST_OPTIONS_H
#define SR_EST_OPTIONS_H

#include <stddef.h>

#include "estimator.h"
#include "excite_design.h"

/* the excitation design's options of o (its identified estimates not set: the model's) */
sr_exd_options est_exd_options(const sr_estimator_options *o);

#endif /* SR_EST_OPTIONS_H */
