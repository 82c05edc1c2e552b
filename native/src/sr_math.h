/* The elementary functions of the native core that must give the same bits on every platform.
 *
 * The C libraries round hypot, sin, cos, log, log10 and pow differently in the last bit (glibc
 * and mingw's msvcrt differ for 13 % of hypot arguments, 47 % of pow(10, k)), and the estimator's
 * standard deviations amplify a 1-ulp difference far beyond 1e-12. Every function here is
 * computed from operations IEEE 754 rounds exactly (+, -, *, /, sqrt; floor and fmod, which are
 * exact) and bit manipulation, so with IEEE doubles and no contraction into FMA
 * (-ffp-contract=off, as native/build.py compiles) the results are the same bits on every
 * platform and compiler. Outside this module the core calls no libm function that is not exact
 * (tests/test_native_math.py checks the sources).
 *
 * Accuracy (measured against glibc through NumPy and against exact rational / decimal values
 * over wide argument ranges, tests/test_native_math.py): within 1 ulp of the true value
 * unless stated otherwise.
 * No global state; thread-safe.
 */
#ifndef SR_MATH_H
#define SR_MATH_H

#include <math.h>

#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/** sqrt(x^2 + y^2) without overflow or underflow in between: the rounded square root, then
 *  one Newton correction with the residual rearranged to be nearly exact without FMA (Borges,
 *  "An improved algorithm for hypot(a, b)", arXiv:1904.09481, 2019), scaled by 2^+-600 for
 *  huge or tiny arguments. This is the arrangement (thresholds included) of glibc's hypot
 *  since 2.35 on machines without FMA: on Linux it gives glibc's bits (measured: 3e6 random
 *  pairs over the whole range, no difference), so the core's eigen solver gives the bits of
 *  the same algorithm on glibc's hypot. Below 1 ulp (correctly rounded for 99.4 % of
 *  arguments). C99 special values: +inf if either is infinite (even with a NaN), else NaN if
 *  either is NaN; hypot(x, +-0) = |x|. */
SR_API double sr_hypot(double x, double y);

/* sr_hypot's kernel: sqrt(ax^2 + ay^2) for ax >= ay > 0 whose squares neither overflow nor
 * underflow, the rounded square root h corrected by h -= (h^2 - ax^2 - ay^2) / (2 h) with the
 * residual rearranged to be nearly exact without FMA (Borges 2019, section 3). Inline here so
 * that sr_hypot_inline shares it (one definition, the same bits). */
static inline double sr_hypot_kernel(double ax, double ay)
{
    /* both arrangements computed and one selected: no branch on the eigen solver's serial
     * path (which one applies is data-dependent: a branch was mispredicted often) */
    const double h = sqrt(ax * ax + ay * ay);
    const double da = h - ay, db = h - ax;
    const double ra = ax * (2.0 * da - ax) + (da - 2.0 * (ax - ay)) * da;
    const double rb = 2.0 * db * (ax - 2.0 * ay) + ((4.0 * db - ay) * ay + db * db);
    return h - (h <= 2.0 * ay ? ra : rb) / (2.0 * h);
}

/** sr_hypot(x, y), the same bits, with its common case inline (for the hot loops of the
 *  eigen solver): finite x, y whose squares neither overflow nor underflow and whose ratio
 *  is above 2^-54 go straight to the kernel; every other case calls sr_hypot. */
static inline double sr_hypot_inline(double x, double y)
{
    double ax = fabs(x), ay = fabs(y);
    if (ax < ay) {
        const double t = ax;
        ax = ay;
        ay = t;
    }
    /* sr_hypot's branches in its order: not huge, not tiny, not negligible (NaN: all false) */
    if (ax <= 0x1.0p+511 && ay >= 0x1.0p-459 && ay > ax * 0x1.0p-54)
        return sr_hypot_kernel(ax, ay);
    return sr_hypot(x, y);
}

/** Sine and cosine of x [rad]: x reduced to r in [-pi/4, pi/4] by x - k pi/2 in double-double
 *  with pi/2 in four parts (152 bits; k pi/2 exact for |k| < 2^20, |x| < 1.6e6), then
 *  sin(a + d), cos(a + d) from a table of sin a, cos a (a = i/128, double-double) and short
 *  polynomials in d (below 2^-64 relative), returned where that error bound proves the
 *  rounding correct (Ziv's test; ~99.7 % of arguments), else the Taylor series of sin r / r
 *  and cos r in double-double arithmetic (below 2^-95 relative), rounded once. The two paths
 *  give the same bits (the fast one only returns what the slow one would): correctly
 *  rounded in every case checked against 70-digit references
 *  (glibc's sin and cos misround 0.13 % of arguments: the core differs from them there) for
 *  |x| < 1.6e6; deterministic but less accurate up to 1e15; NaN for |x| >= 1e15 (no angle in
 *  the core comes near) and for non-finite x. sin(-0) = -0. s or c may be NULL. */
SR_API void sr_sincos(double x, double *s, double *c);

/** sin x [rad] (sr_sincos). */
SR_API double sr_sin(double x);

/** cos x [rad] (sr_sincos). */
SR_API double sr_cos(double x);

/** Arc tangent [rad] in [-pi/2, pi/2]: fdlibm's arrangement (s_atan.c: a reduction by the
 *  breakpoints 1/2, 1, 3/2 and 1/x, then an odd polynomial); below 1 ulp.
 *  atan(+-inf) = +-pi/2, atan(+-0) = +-0, NaN for NaN. */
SR_API double sr_atan(double x);

/** The angle of the point (x, y) [rad] in [-pi, pi]: sr_atan(|y / x|) placed in its quadrant,
 *  pi in two parts (fdlibm's e_atan2.c for finite arguments); within 2 ulp. Special values:
 *  NaN if either is NaN; atan2(+-0, x > 0) = +-0, atan2(+-0, x < 0) = +-pi,
 *  atan2(y != 0, +-0) = +-pi/2 by the sign of y, and atan2(+-0, +-0) = 0 (C99: +-0 or +-pi);
 *  one infinite argument gives C99's value, two give NaN (C99: +-pi/4 or +-3 pi/4). */
SR_API double sr_atan2(double y, double x);

/** Natural logarithm (sr_ln: sr_log is the FMI layer's logger): x = 2^k m,
 *  m in [sqrt(1/2), sqrt(2)], log m = 2 atanh(f / (2 + f)) by its series (fdlibm's
 *  arrangement), ln 2 in two parts; below 1 ulp. log(+-0) = -inf, log(+inf) = +inf, NaN for
 *  x < 0 or NaN; subnormal x handled. */
SR_API double sr_ln(double x);

/** Base-10 logarithm: sr_ln's reduction carried in extra precision and multiplied by 1/ln 10
 *  in two parts (FreeBSD's e_log10.c arrangement); below 1 ulp, and log10(10^n) = n exactly
 *  for 0 <= n <= 22. Special values as sr_ln. */
SR_API double sr_log10(double x);

/** x^n for an integer n: |x| = m 2^e, m^|n| by squaring in double-double arithmetic with the
 *  binary exponent kept apart (no overflow in between), 1 / that by one corrected division
 *  for n < 0; below 1 ulp (about 0.5 ulp plus 2^-95 relative for a normal result; one more
 *  rounding in the subnormal range), exact whenever x^n is representable as a double and
 *  n >= 0. C99 pow's special values for an integer exponent: x^0 = 1 (also for NaN),
 *  (+-0)^n = +-0 or +-inf by the sign of n and the parity of n, (+-inf)^n likewise, NaN^n = NaN
 *  for n != 0. */
SR_API double sr_powi(double x, int n);

/** e^x: x = k ln 2 + r with |r| <= ln 2 / 2 (ln 2 in two parts, Cody and Waite, so k ln 2 is
 *  exact), e^r by its Taylor series to degree 13 (truncation below 5e-18) in Horner's form,
 *  times 2^k by ldexp; within 2 ulp. +inf above 709.78, 0 below -745.2, NaN for NaN. */
SR_API double sr_exp(double x);

/** The two-sided standard normal quantile: z >= 0 with P(|Z| > z) = p for Z ~ N(0, 1), for
 *  1e-300 <= p <= 0.5 (z from 0.674 to 37.07); NaN outside. ln P(|Z| > z) = ln erfc(z / sqrt 2)
 *  = -x^2 - ln sqrt(pi) - ln K(x), x = z / sqrt 2, with K(x) = x + (1/2) / (x + 1 / (x + (3/2) /
 *  (x + ...))) (Laplace's continued fraction, 1000 terms evaluated backwards: 4e-12 relative at
 *  x = 0.7, round-off from x = 1), solved for x by bisection. About 1e5 flops: for set-up,
 *  not for a step. */
SR_API double sr_normal_quantile2(double p);

/** 10^n (sr_powi(10, n)): exact for 0 <= n <= 22, correctly rounded for -22 <= n < 0,
 *  below 1 ulp elsewhere; +inf for n > 308, 0 below the subnormal range. */
SR_API double sr_pow10(int n);

/** 1 if the n numbers at x are all finite, else 0. */
static inline int sr_finite_all(const double *x, int n)
{
    int i;
    for (i = 0; i < n; i++)
        if (!isfinite(x[i]))
            return 0;
    return 1;
}

#ifdef __cplusplus
}
#endif

#endif /* SR_MATH_H */
