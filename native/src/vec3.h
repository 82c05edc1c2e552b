/* Small 3-vector and 3 x 3 helpers shared by the core's modules (internal, not exported).
 * Matrices are row-major double[9]; the order of operations is fixed here so that every module
 * gets the same bits. No state; the output must not alias an input.
 */
#ifndef SR_VEC3_H
#define SR_VEC3_H

/* out = a x b (3-vectors) */
static inline void vec3_cross(const double *a, const double *b, double *out)
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* out = A x (A 3 x 3 row-major, x 3) */
static inline void mat3_vec(const double *A, const double *x, double *out)
{
    int i;
    for (i = 0; i < 3; i++)
        out[i] = A[3 * i] * x[0] + A[3 * i + 1] * x[1] + A[3 * i + 2] * x[2];
}

/* out = A^T x (A 3 x 3 row-major, x 3) */
static inline void mat3t_vec(const double *A, const double *x, double *out)
{
    int i;
    for (i = 0; i < 3; i++)
        out[i] = A[i] * x[0] + A[3 + i] * x[1] + A[6 + i] * x[2];
}

#endif
