/* The estimator's options (sr_estimator_options, estimator.h): their defaults, their rules
 * (every value in its range, the combinations the core accepts) with the messages that name
 * the FMU parameter at fault, and the excitation design's options among them. */
#ifndef SR_EST_OPTIONS_H
#define SR_EST_OPTIONS_H

#include <stddef.h>

#include "estimator.h"
#include "excite_design.h"

/* 0 when the options o (the noise profile applied) are valid, else 1 with a one-line message
 * in err (errlen bytes) naming the parameter by its FMU name */
int est_options_check(const sr_estimator_options *o, char *err, size_t errlen);

/* the excitation design's options of o (its identified estimates not set: the model's) */
sr_exd_options est_exd_options(const sr_estimator_options *o);

#endif /* SR_EST_OPTIONS_H */
