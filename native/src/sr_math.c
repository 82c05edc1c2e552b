/* Portable elementary functions (see sr_math.h): +, -, *, /, sqrt, floor, fmod and bit
 * manipulation only, so every IEEE 754 platform gives the same bits. Constants are hexadecimal
 * floating literals (exact). sr_ln is the algorithm rng.c used for its normals (unchanged:
 * the same bits as before); sr_sincos replaces rng.c's single-double Taylor sine and cosine
 * (within 2 ulp) by a correctly rounded double-double one. */
#include "sr_math.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

static double from_bits(uint64_t b)
{
    double x;
    memcpy(&x, &b, sizeof x);
    return x;
}

static uint64_t to_bits(double x)
{
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

/* -- exact products (Dekker / Veltkamp, no FMA) ---------------------------------------------- */

/* a = hi + lo with hi of 26 significant bits (|a| < 2^995: the product below must not overflow) */
static void split(double a, double *hi, double *lo)
{
    const double c = 134217729.0 * a;       /* 2^27 + 1 */
    *hi = c - (c - a);
    *lo = a - *hi;
}

/* p + e = a b exactly (p = fl(a b); no underflow in the partial products) */
static void two_prod(double a, double b, double *p, double *e)
{
    double ah, al, bh, bl;
    *p = a * b;
    split(a, &ah, &al);
    split(b, &bh, &bl);
    *e = ((ah * bh - *p) + ah * bl + al * bh) + al * bl;
}

/* s + e = a + b exactly, |a| >= |b| */
static void fast_two_sum(double a, double b, double *s, double *e)
{
    *s = a + b;
    *e = b - (*s - a);
}

/* s + e = a + b exactly */
static void two_sum(double a, double b, double *s, double *e)
{
    const double t = a + b, v = t - a;
    *e = (a - (t - v)) + (b - v);
    *s = t;
}

/* (h, l) = (ah + al) (bh + bl) in double-double (relative error ~2^-102) */
static void dd_mul(double ah, double al, double bh, double bl, double *h, double *l)
{
    double p, e;
    two_prod(ah, bh, &p, &e);
    e += ah * bl + al * bh;
    fast_two_sum(p, e, h, l);
}

/* (h, l) = (ah + al) + (bh + bl) in double-double */
static void dd_add(double ah, double al, double bh, double bl, double *h, double *l)
{
    double t, e;
    two_sum(ah, bh, &t, &e);
    e += al + bl;
    fast_two_sum(t, e, h, l);
}

/* x 2^e with one rounding (x normal, |x| in [1, 4)); +-inf or +-0 beyond the range */
static double scale2(double x, long long e)
{
    if (e > 2100)
        e = 2100;
    if (e < -2200)
        e = -2200;
    while (e > 1023) {
        x *= 0x1.0p+1023;
        e -= 1023;
    }
    while (e < -1022) {                     /* exact until the last step (x stays normal) */
        x *= 0x1.0p-1022;
        e += 1022;
    }
    return x * from_bits((uint64_t)(e + 1023) << 52);
}

/* -- hypot ------------------------------------------------------------------------------------ */

/* sqrt(ax^2 + ay^2), ax >= ay > 0, squares neither overflowing nor underflowing: the rounded
 * square root h, then h -= (h^2 - ax^2 - ay^2) / (2 h) with the residual rearranged so that it
 * is computed nearly exactly without FMA (Borges 2019, section 3) */
static double hypot_kernel(double ax, double ay)
{
    double h = sqrt(ax * ax + ay * ay), t1, t2, delta;
    if (h <= 2.0 * ay) {
        delta = h - ay;
        t1 = ax * (2.0 * delta - ax);
        t2 = (delta - 2.0 * (ax - ay)) * delta;
    } else {
        delta = h - ax;
        t1 = 2.0 * delta * (ax - 2.0 * ay);
        t2 = (4.0 * delta - ay) * ay + delta * delta;
    }
    return h - (t1 + t2) / (2.0 * h);
}

double sr_hypot(double x, double y)
{
    double ax, ay;
    if (!(fabs(x) <= 0x1.fffffffffffffp+1023) || !(fabs(y) <= 0x1.fffffffffffffp+1023)) {
        if (fabs(x) > 0x1.fffffffffffffp+1023 || fabs(y) > 0x1.fffffffffffffp+1023)
            return HUGE_VAL;                /* inf wins over NaN (C99 F.9.4.3) */
        return x + y;                       /* NaN */
    }
    ax = fabs(x);
    ay = fabs(y);
    if (ax < ay) {
        const double t = ax;
        ax = ay;
        ay = t;
    }
    /* scaled by 2^-+600 (exact) where a square would overflow or underflow */
    if (ax > 0x1.0p+511) {
        if (ay <= ax * 0x1.0p-54)           /* ay^2 below half an ulp of ax^2 */
            return ax + ay;
        return hypot_kernel(ax * 0x1.0p-600, ay * 0x1.0p-600) * 0x1.0p+600;
    }
    if (ay < 0x1.0p-459) {
        if (ax >= ay * 0x1.0p+54)           /* also ay = 0 */
            return ax + ay;
        return hypot_kernel(ax * 0x1.0p+600, ay * 0x1.0p+600) * 0x1.0p-600;
    }
    if (ay <= ax * 0x1.0p-54)
        return ax + ay;
    return hypot_kernel(ax, ay);
}

/* -- sine and cosine -------------------------------------------------------------------------- */

/* 1/k! in double-double (hi correctly rounded, lo = 1/k! - hi rounded) */
static const double INV_FACT[24][2] = {
    {0x1.0000000000000p+0, 0.0}, {0x1.0000000000000p+0, 0.0},
    {0x1.0000000000000p-1, 0.0}, {0x1.5555555555555p-3, 0x1.5555555555555p-57},
    {0x1.5555555555555p-5, 0x1.5555555555555p-59}, {0x1.1111111111111p-7, 0x1.1111111111111p-63},
    {0x1.6c16c16c16c17p-10, -0x1.f49f49f49f49fp-65}, {0x1.a01a01a01a01ap-13, 0x1.a01a01a01a01ap-73},
    {0x1.a01a01a01a01ap-16, 0x1.a01a01a01a01ap-76}, {0x1.71de3a556c734p-19, -0x1.c154f8ddc6c00p-73},
    {0x1.27e4fb7789f5cp-22, 0x1.cbbc05b4fa99ap-76}, {0x1.ae64567f544e4p-26, -0x1.c062e06d1f209p-80},
    {0x1.1eed8eff8d898p-29, -0x1.2aec959e14c06p-83}, {0x1.6124613a86d09p-33, 0x1.f28e0cc748ebep-87},
    {0x1.93974a8c07c9dp-37, 0x1.05d6f8a2efd1fp-92}, {0x1.ae7f3e733b81fp-41, 0x1.1d8656b0ee8cbp-97},
    {0x1.ae7f3e733b81fp-45, 0x1.1d8656b0ee8cbp-101}, {0x1.952c77030ad4ap-49, 0x1.ac981465ddc6cp-103},
    {0x1.6827863b97d97p-53, 0x1.eec01221a8b0bp-107}, {0x1.2f49b46814157p-57, 0x1.2650f61dbdcb4p-112},
    {0x1.e542ba4020225p-62, 0x1.ea72b4afe3c2fp-120}, {0x1.71b8ef6dcf572p-66, -0x1.d043ae40c4647p-120},
    {0x1.0ce396db7f853p-70, -0x1.aebcdbd20331cp-124}, {0x1.761b41316381ap-75, -0x1.3423c7d91404fp-130}};

/* sum_j (-1)^j z^j / (2j + odd)!, j = 0..11, for z = zh + zl <= (pi/4)^2 + a little: the terms
 * j >= 4 (below 4e-7 of the sum) in double, the rest by double-double Horner steps */
static void series(double zh, double zl, int odd, double *h, double *l)
{
    double a = 0.0, ah, al;
    int j;
    for (j = 11; j >= 4; --j)
        a = a * zh + ((j & 1) ? -INV_FACT[2 * j + odd][0] : INV_FACT[2 * j + odd][0]);
    ah = a;
    al = 0.0;
    for (j = 3; j >= 0; --j) {
        const double ch = INV_FACT[2 * j + odd][0], cl = INV_FACT[2 * j + odd][1];
        dd_mul(ah, al, zh, zl, &ah, &al);
        if (j & 1)
            dd_add(ah, al, -ch, -cl, &ah, &al);
        else
            dd_add(ah, al, ch, cl, &ah, &al);
    }
    *h = ah;
    *l = al;
}

void sr_sincos(double x, double *s, double *c)
{
    /* pi/2 in four parts, the first three of 33 significant bits (k P_i exact for
     * |k| < 2^20), 152 bits in all: x - k pi/2 keeps its accuracy next to multiples of pi/2 */
    static const double P1 = 0x1.921fb54400000p+0, P2 = 0x1.0b4611a600000p-34,
                        P3 = 0x1.3198a2e000000p-69, P3T = 0x1.b839a252049c1p-104;
    static const double TWO_OVER_PI = 0x1.45f306dc9c883p-1, PIO4 = 0x1.921fb54442d18p-1;
    double k, rh, rl, zh, zl, sh, sl, cl, ss, cc;
    long long q;
    if (!(fabs(x) < 1e15)) {                /* non-finite or beyond any meaningful angle */
        if (s) *s = NAN;
        if (c) *c = NAN;
        return;
    }
    if (fabs(x) < 0x1.0p-27) {              /* x^3/6, x^2/2 below a quarter ulp: x and 1 are
                                             * the correctly rounded values (+-0 kept) */
        if (s) *s = x;
        if (c) *c = 1.0;
        return;
    }
    if (fabs(x) <= PIO4) {
        k = 0.0;
        rh = x;
        rl = 0.0;
    } else {
        /* r = x - k pi/2 in double-double: x - k P1 exact (k P1 exact, then Sterbenz),
         * - k P2 (exact product) with its rounding error kept, then the small parts */
        double t, e1;
        k = floor(x * TWO_OVER_PI + 0.5);   /* nearest quadrant */
        two_sum(x - k * P1, -(k * P2), &t, &e1);
        two_sum(t, (e1 - k * P3) - k * P3T, &rh, &rl);
    }
    /* sin r = r (1 - z/3! + z^2/5! - ...), cos r = 1 - z/2! + z^2/4! - ..., z = r^2, all in
     * double-double (below 2^-100 relative): the results are the correctly rounded values of
     * a number within ~2^-95 of sin r, cos r */
    dd_mul(rh, rl, rh, rl, &zh, &zl);
    series(zh, zl, 1, &sh, &sl);
    dd_mul(sh, sl, rh, rl, &ss, &sl);
    series(zh, zl, 0, &cc, &cl);
    q = (long long)fmod(k, 4.0);            /* fmod is exact */
    if (q < 0)
        q += 4;
    switch (q) {
    case 0: if (s) *s = ss;  if (c) *c = cc;  break;
    case 1: if (s) *s = cc;  if (c) *c = -ss; break;
    case 2: if (s) *s = -ss; if (c) *c = -cc; break;
    default: if (s) *s = -cc; if (c) *c = ss; break;
    }
}

double sr_sin(double x)
{
    double s;
    sr_sincos(x, &s, NULL);
    return s;
}

double sr_cos(double x)
{
    double c;
    sr_sincos(x, NULL, &c);
    return c;
}

/* -- logarithms ------------------------------------------------------------------------------- */

/* x finite > 0: x = 2^k (1 + f), 1 + f in [sqrt(1/2), sqrt(2)] (f exact); then s = f / (2 + f),
 * hfsq = f^2 / 2 and R with log(1 + f) = f - (hfsq - s (hfsq + R)) */
static void log_reduce(double x, int *k_out, double *f_out, double *s_out, double *hfsq_out,
                       double *R_out)
{
    static const double SQRT2 = 0x1.6a09e667f3bcdp+0;
    uint64_t b;
    int k = 0, i;
    double m, f, s, z, R;
    if (x < 0x1.0p-1022) {                  /* subnormal: scale into the normal range (exact) */
        x *= 0x1.0p+54;
        k = -54;
    }
    b = to_bits(x);
    k += (int)((b >> 52) & 0x7ff) - 1023;
    m = from_bits((b & UINT64_C(0x000fffffffffffff)) | UINT64_C(0x3ff0000000000000)); /* [1, 2) */
    if (m > SQRT2) {                        /* m in [sqrt(1/2), sqrt(2)]: |f| <= 0.42 */
        m *= 0.5;
        k += 1;
    }
    f = m - 1.0;                            /* exact (Sterbenz) */
    /* log(1 + f) = 2 atanh(s), s = f / (2 + f), |s| <= 0.172:
     * = f - (hfsq - s (hfsq + R)), R = 2 (z/3 + z^2/5 + ...), z = s^2 <= 0.0295; the series
     * is cut after z^12 (0.0295^13 / 27 < 2^-70 of the result) */
    s = f / (2.0 + f);
    z = s * s;
    R = 0.0;
    for (i = 12; i >= 1; --i)
        R = (R + 2.0 / (double)(2 * i + 1)) * z;    /* exact-rounded division: portable */
    *k_out = k;
    *f_out = f;
    *s_out = s;
    *hfsq_out = 0.5 * f * f;
    *R_out = R;
}

/* the special values of both logarithms; 1 if x needs no computation (*y set) */
static int log_special(double x, double *y)
{
    if (x != x)
        *y = x;
    else if (x < 0.0)
        *y = NAN;
    else if (x == 0.0)
        *y = -HUGE_VAL;
    else if (x > 0x1.fffffffffffffp+1023)
        *y = x;                             /* +inf */
    else
        return 0;
    return 1;
}

double sr_ln(double x)
{
    /* ln 2 in two parts: LN2_HI has 32 significant bits, so k LN2_HI is exact for |k| < 2^21 */
    static const double LN2_HI = 0x1.62e42fee00000p-1, LN2_LO = 0x1.a39ef35793c76p-33;
    int k;
    double f, s, hfsq, R, dk, y;
    if (log_special(x, &y))
        return y;
    log_reduce(x, &k, &f, &s, &hfsq, &R);
    dk = (double)k;
    return dk * LN2_HI - ((hfsq - (s * (hfsq + R) + dk * LN2_LO)) - f);
}

double sr_log10(double x)
{
    /* 1/ln 10 and log10(2) in two parts each; the high parts have at most 33 significant
     * bits, so hi IVLN10_HI (hi of 21 bits) and k LOG10_2HI are exact (FreeBSD e_log10.c) */
    static const double IVLN10_HI = 0x1.bcb7b15200000p-2, IVLN10_LO = 0x1.b9438ca9aadd5p-36,
                        LOG10_2HI = 0x1.34413509f6000p-2, LOG10_2LO = 0x1.9fef311f12b36p-42;
    int k;
    double f, s, hfsq, R, dk, y, hi, lo, val_hi, val_lo, y2, w;
    if (log_special(x, &y))
        return y;
    log_reduce(x, &k, &f, &s, &hfsq, &R);
    /* log(1 + f) = hi + lo with hi = f - hfsq cut to 21 significant bits (low word cleared) */
    hi = from_bits(to_bits(f - hfsq) & UINT64_C(0xffffffff00000000));
    lo = (f - hi) - hfsq + s * (hfsq + R);
    dk = (double)k;
    val_hi = hi * IVLN10_HI;
    y2 = dk * LOG10_2HI;
    val_lo = dk * LOG10_2LO + (lo + hi) * IVLN10_LO + lo * IVLN10_HI;
    w = y2 + val_hi;                        /* the sum of the two large parts, its error kept */
    val_lo += (y2 - w) + val_hi;
    return val_lo + w;
}

/* -- integer powers --------------------------------------------------------------------------- */

/* (ah + al) 2^ae *= (bh + bl) 2^be in double-double, renormalised to ah in [1, 2) */
static void dd_mul_exp(double *ah, double *al, long long *ae, double bh, double bl, long long be)
{
    double p, e, h, l;
    two_prod(*ah, bh, &p, &e);
    e += *ah * bl + *al * bh;
    fast_two_sum(p, e, &h, &l);
    *ae += be;
    if (h >= 2.0) {                         /* exact: powers of two, no subnormals here */
        h *= 0.5;
        l *= 0.5;
        *ae += 1;
    }
    *ah = h;
    *al = l;
}

double sr_powi(double x, int n)
{
    double ax, m, bh, bl = 0.0, ah = 1.0, al = 0.0, r;
    long long be = 0, ae = 0, e;
    unsigned int un;
    int neg, ex, adj = 0;
    uint64_t b;
    if (n == 0)
        return 1.0;
    if (x != x)
        return x;
    neg = signbit(x) && (n & 1);            /* an odd power keeps the sign */
    ax = fabs(x);
    if (ax == 0.0 || ax > 0x1.fffffffffffffp+1023) {
        r = ((ax == 0.0) == (n > 0)) ? 0.0 : HUGE_VAL;
        return neg ? -r : r;
    }
    if (ax < 0x1.0p-1022) {                 /* subnormal: scale into the normal range (exact) */
        ax *= 0x1.0p+54;
        adj = -54;
    }
    b = to_bits(ax);
    ex = (int)((b >> 52) & 0x7ff) - 1023 + adj;
    m = from_bits((b & UINT64_C(0x000fffffffffffff)) | UINT64_C(0x3ff0000000000000)); /* [1, 2) */
    /* m^|n| by squaring (|n| as unsigned: INT_MIN too) */
    un = n < 0 ? 0u - (unsigned int)n : (unsigned int)n;
    bh = m;
    for (;;) {
        if (un & 1u)
            dd_mul_exp(&ah, &al, &ae, bh, bl, be);
        un >>= 1;
        if (!un)
            break;
        dd_mul_exp(&bh, &bl, &be, bh, bl, be);
    }
    e = (long long)ex * (n < 0 ? -(long long)n : (long long)n) + ae;
    if (n < 0) {
        /* 1 / (ah + al): q = 1/ah corrected by the exact residual 1 - q (ah + al) */
        double q = 1.0 / ah, p, pe, res;
        two_prod(q, ah, &p, &pe);
        res = ((1.0 - p) - pe) - q * al;    /* 1 - p exact (Sterbenz) */
        fast_two_sum(q, res * q, &ah, &al);
        e = -e;
        if (ah < 1.0) {                     /* (1/2, 1]: back to [1, 2) */
            ah *= 2.0;
            al *= 2.0;
            e -= 1;
        }
    }
    /* one rounding for a normal result; hi and lo scaled apart in the subnormal range */
    r = e >= -1022 ? scale2(ah + al, e) : scale2(ah, e) + scale2(al * 0x1.0p+60, e - 60);
    return neg ? -r : r;
}

double sr_pow10(int n)
{
    return sr_powi(10.0, n);
}
