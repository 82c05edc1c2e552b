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

/* A (3 x 3, row-major): the DCM body -> inertial (x_I = A x_B) of the quaternion (x, y, z, w),
 * which need not be of unit norm (it is normalised on the way) */
static inline void quat_dcm(double x, double y, double z, double w, double *A)
{
    const double s = 2.0 / (x * x + y * y + z * z + w * w);
    const double xx = x * x, yy = y * y, zz = z * z;
    const double xy = x * y, xz = x * z, yz = y * z;
    const double xw = x * w, yw = y * w, zw = z * w;
    A[0] = 1.0 - s * (yy + zz); A[1] = s * (xy - zw); A[2] = s * (xz + yw);
    A[3] = s * (xy + zw); A[4] = 1.0 - s * (xx + zz); A[5] = s * (yz - xw);
    A[6] = s * (xz - yw); A[7] = s * (yz + xw); A[8] = 1.0 - s * (xx + yy);
}

#endif
