/* A rigid body's ten parameters and the one rule that says whether they describe a body the
 * project accepts: the plant's base and target, the estimator's guesses, the Python library's
 * bodies (spacerobot.robots.check_body calls sr_body_check).
 *
 * Parameters g (10): m [kg], b (3) [m] (centre of mass in the body frame), Ixx Iyy Izz Ixy Ixz
 * Iyz [kg.m2] (about the centre of mass, body frame; Ixy is the tensor element).
 */
#ifndef SR_BODY_H
#define SR_BODY_H

#include <stddef.h>

#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/* The accepted ranges (SI units): a body of 1 mg to 1e15 kg, its centre of mass within 1 km of
 * its frame's origin, principal moments of 1e-6 to 1e15 kg.m2. Outside them no body is real,
 * and inside them every product the estimator forms stays far from overflow (m |b|^2 <= 1e21
 * in D(mu); the sd of b ~ sqrt(P0) / m <= 1e21). */
#define SR_BODY_MASS_MIN 1e-6
#define SR_BODY_MASS_MAX 1e15
#define SR_BODY_COM_MAX 1e3
#define SR_BODY_INERTIA_MIN 1e-6
#define SR_BODY_INERTIA_MAX 1e15
/* the bound |a product of inertia| <= (max - min) / 2 that principal moments within
 * [SR_BODY_INERTIA_MIN, SR_BODY_INERTIA_MAX] imply (an off-diagonal element of a symmetric
 * matrix is at most half the spread of its eigenvalues) */
#define SR_BODY_PRODUCT_MAX (0.5 * (SR_BODY_INERTIA_MAX - SR_BODY_INERTIA_MIN))

/** 0 when g (10, above) is a real body within the ranges: finite, m > 0, inertia positive
 *  definite with principal moments obeying the triangle inequality (the largest at most the
 *  sum of the other two, within 1e-12 of it), then the ranges. Else 1 with a one-line reason
 *  naming the body (name, e.g. "guess.base") in err (errlen bytes; err may be NULL). */
SR_API int sr_body_check(const char *name, const double *g, char *err, size_t errlen);

#ifdef __cplusplus
}
#endif

#endif /* SR_BODY_H */
