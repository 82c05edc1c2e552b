/* A rigid body's parameters checked (body.h): one rule for the plant's bodies, the estimator's
 * guesses and the Python library's. */
#include "body.h"

#include <math.h>

#include "linalg.h"
#include "sr_text.h"

int sr_body_check(const char *name, const double *g, char *err, size_t errlen)
{
    for (int i = 0; i < 10; i++)
        if (!isfinite(g[i])) {
            sr_text_set(err, errlen, name);
            sr_text_cat(err, errlen, ": parameters must be finite numbers, got mass=");
            sr_text_num(err, errlen, g[0], 6);
            sr_text_cat(err, errlen, ", b=");
            sr_text_vec(err, errlen, g + 1, 3);
            sr_text_cat(err, errlen, ", inertia=");
            sr_text_vec(err, errlen, g + 4, 6);
            return 1;
        }
    if (g[0] <= 0.0) {
        sr_text_set(err, errlen, name);
        sr_text_cat(err, errlen, ".m must be > 0 kg, got ");
        sr_text_repr(err, errlen, g[0]);
        return 1;
    }
    /* Ixx Iyy Izz Ixy Ixz Iyz -> the tensor; its principal moments */
    double I[9] = {g[4], g[7], g[8], g[7], g[5], g[9], g[8], g[9], g[6]}, w[3], V[9];
    if (sr_eigh(I, 3, w, V) != 0 || w[0] <= 0.0) {
        sr_text_set(err, errlen, name);
        sr_text_cat(err, errlen, " inertia must be positive definite; principal moments ");
        sr_text_vec(err, errlen, w, 3);
        sr_text_cat(err, errlen, " kg.m2");
        return 1;
    }
    if (w[2] > w[0] + w[1] + 1e-12 * w[2]) {
        sr_text_set(err, errlen, name);
        sr_text_cat(err, errlen, " inertia violates the triangle inequality: principal moments ");
        sr_text_vec(err, errlen, w, 3);
        sr_text_cat(err, errlen, " kg.m2 (largest must not exceed the sum of the other two)");
        return 1;
    }
    /* the ranges (body.h) */
    if (!(g[0] >= SR_BODY_MASS_MIN && g[0] <= SR_BODY_MASS_MAX)) {
        sr_text_set(err, errlen, name);
        sr_text_cat(err, errlen, ".m must be within [");
        sr_text_num(err, errlen, SR_BODY_MASS_MIN, 6);
        sr_text_cat(err, errlen, ", ");
        sr_text_num(err, errlen, SR_BODY_MASS_MAX, 6);
        sr_text_cat(err, errlen, "] kg, got ");
        sr_text_repr(err, errlen, g[0]);
        return 1;
    }
    for (int i = 0; i < 3; i++)
        if (!(fabs(g[1 + i]) <= SR_BODY_COM_MAX)) {
            sr_text_set(err, errlen, name);
            sr_text_cat(err, errlen, ".b[");
            sr_text_int(err, errlen, i + 1);
            sr_text_cat(err, errlen, "] must be within [");
            sr_text_num(err, errlen, -SR_BODY_COM_MAX, 6);
            sr_text_cat(err, errlen, ", ");
            sr_text_num(err, errlen, SR_BODY_COM_MAX, 6);
            sr_text_cat(err, errlen, "] m (a centre of mass within ");
            sr_text_num(err, errlen, SR_BODY_COM_MAX / 1e3, 6);
            sr_text_cat(err, errlen, " km of the body frame's origin), got ");
            sr_text_repr(err, errlen, g[1 + i]);
            return 1;
        }
    if (!(w[0] >= SR_BODY_INERTIA_MIN && w[2] <= SR_BODY_INERTIA_MAX)) {
        sr_text_set(err, errlen, name);
        sr_text_cat(err, errlen, " inertia: principal moments must be within [");
        sr_text_num(err, errlen, SR_BODY_INERTIA_MIN, 6);
        sr_text_cat(err, errlen, ", ");
        sr_text_num(err, errlen, SR_BODY_INERTIA_MAX, 6);
        sr_text_cat(err, errlen, "] kg.m2, got ");
        sr_text_vec(err, errlen, w, 3);
        return 1;
    }
    return 0;
}
