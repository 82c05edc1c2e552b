/* Messages: appending to a fixed buffer, locale-independent number formatting and a small
 * printf over it (sr_text.h). */
#include "sr_text.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

/* append the string s to buf (size n, NUL-terminated) */
void sr_text_cat(char *buf, size_t n, const char *s)
{
    if (buf == NULL || n == 0 || s == NULL)
        return;
    size_t len = strlen(buf);
    while (*s && len + 1 < n)
        buf[len++] = *s++;
    buf[len] = '\0';
}

/* append the integer v */
void sr_text_int(char *buf, size_t n, long long v)
{
    char tmp[24];
    int i = 0, neg = v < 0;
    unsigned long long u = neg ? 0ULL - (unsigned long long)v : (unsigned long long)v;
    do {
        tmp[i++] = (char)('0' + (int)(u % 10));
        u /= 10;
    } while (u && i < 22);
    if (neg)
        tmp[i++] = '-';
    char out[24];
    for (int j = 0; j < i; j++)
        out[j] = tmp[i - 1 - j];
    out[i] = '\0';
    sr_text_cat(buf, n, out);
}

/* ---- numbers: exact decimal digits ---------------------------------------------------------
 * A double is m 2^e exactly (m < 2^53): its decimal digits are those of the integer m 2^e
 * (e >= 0) or of m 5^-e, the decimal point -e places from the right (e < 0). They are computed
 * in base-1e9 limbs, then rounded as printf rounds (to nearest, ties to even); every digit is
 * exact, whatever the platform's C library. */
#define LIMB 1000000000u
#define MAX_LIMBS 96            /* 5^1076 2^55 < 10^(96 * 9) */
#define MAX_DIGITS (9 * MAX_LIMBS)

/* limbs a[0..n-1] (little-endian) times f (f < 2^33); returns the new n */
static int limbs_times(uint32_t *a, int n, uint64_t f)
{
    uint64_t carry = 0;
    for (int i = 0; i < n; i++) {
        uint64_t t = (uint64_t)a[i] * f + carry;
        a[i] = (uint32_t)(t % LIMB);
        carry = t / LIMB;
    }
    while (carry && n < MAX_LIMBS) {
        a[n++] = (uint32_t)(carry % LIMB);
        carry /= LIMB;
    }
    return n;
}

/* the digits of mant 2^exp2 (mant > 0, < 2^55; -1080 < exp2 < 1030) into d (MAX_DIGITS + 1
 * bytes): d[0] != '0', the value d[0].d[1]d[2]... 10^*E; returns the number of digits */
static int exact_digits(uint64_t mant, int exp2, char *d, int *E)
{
    uint32_t a[MAX_LIMBS];
    int n = 0, nd = 0;
    while (mant) {
        a[n++] = (uint32_t)(mant % LIMB);
        mant /= LIMB;
    }
    for (int k = exp2; k > 0; k -= 29)               /* times 2^e */
        n = limbs_times(a, n, (uint64_t)1 << (k < 29 ? k : 29));
    for (int k = -exp2; k > 0; k -= 13) {            /* times 5^-e (10^-e / 2^-e) */
        uint64_t f = 1;
        for (int i = 0; i < (k < 13 ? k : 13); i++)
            f *= 5;
        n = limbs_times(a, n, f);
    }
    for (int i = n - 1; i >= 0; i--) {               /* the limbs' digits, leading zeros dropped */
        char nine[9];
        uint32_t v = a[i];
        for (int j = 8; j >= 0; j--) {
            nine[j] = (char)('0' + v % 10);
            v /= 10;
        }
        for (int j = 0; j < 9; j++)
            if (nd || nine[j] != '0' || (i == 0 && j == 8))
                d[nd++] = nine[j];
    }
    d[nd] = '\0';
    *E = nd - 1 + (exp2 < 0 ? exp2 : 0);
    return nd;
}

/* |x| = m 2^e with m an integer (x finite, not 0) */
static void binary_parts(double x, uint64_t *m, int *e)
{
    int e2;
    double f = frexp(fabs(x), &e2);                  /* |x| = f 2^e2, 0.5 <= f < 1 (exact) */
    *m = (uint64_t)ldexp(f, 53);
    *e = e2 - 53;
    while (*m && !(*m & 1u) && *e < 0) {             /* smaller numbers, the same value */
        *m >>= 1;
        ++*e;
    }
}

/* d (nd digits, value d.ddd 10^*E) rounded to sig digits, to nearest, ties to even; returns
 * the number of digits kept (trailing zeros dropped, at least 1) */
static int round_digits(char *d, int nd, int sig, int *E)
{
    if (nd > sig) {
        int up = d[sig] > '5';
        if (d[sig] == '5') {
            up = (d[sig - 1] - '0') % 2 == 1;        /* a tie: to even */
            for (int i = sig + 1; i < nd; i++)
                up |= d[i] != '0';                   /* above the tie */
        }
        nd = sig;
        if (up) {
            int i = sig - 1;
            while (i >= 0 && d[i] == '9')
                d[i--] = '0';
            if (i >= 0) {
                d[i]++;
            } else {                                 /* 99.9 -> 100 */
                d[0] = '1';
                ++*E;
            }
        }
    }
    while (nd > 1 && d[nd - 1] == '0')
        nd--;
    d[nd] = '\0';
    return nd;
}

/* append [-]d.ddde+XX (exponential) or the digits around the decimal point (fixed; with
 * point_zero a ".0" when there is no fraction) */
static void layout(char *buf, size_t n, int neg, const char *d, int nd, int E, int fixed,
                   int point_zero)
{
    char out[MAX_DIGITS + 32];
    int o = 0;
    if (neg)
        out[o++] = '-';
    if (!fixed) {                                            /* d.ddde+XX */
        out[o++] = d[0];
        if (nd > 1) {
            out[o++] = '.';
            for (int i = 1; i < nd; i++)
                out[o++] = d[i];
        }
        out[o++] = 'e';
        out[o++] = E < 0 ? '-' : '+';
        int ae = E < 0 ? -E : E;
        if (ae >= 100)
            out[o++] = (char)('0' + ae / 100);
        out[o++] = (char)('0' + (ae / 10) % 10);
        out[o++] = (char)('0' + ae % 10);
    } else if (E < 0) {                                      /* 0.000ddd */
        out[o++] = '0';
        out[o++] = '.';
        for (int i = 0; i < -E - 1; i++)
            out[o++] = '0';
        for (int i = 0; i < nd; i++)
            out[o++] = d[i];
    } else {                                                 /* ddd.ddd */
        for (int i = 0; i <= E; i++)
            out[o++] = i < nd ? d[i] : '0';
        if (nd > E + 1) {
            out[o++] = '.';
            for (int i = E + 1; i < nd; i++)
                out[o++] = d[i];
        } else if (point_zero) {
            out[o++] = '.';
            out[o++] = '0';
        }
    }
    out[o] = '\0';
    sr_text_cat(buf, n, out);
}

/* append x as C's "%.{sig}g" prints it in the "C" locale (never the C library's formatting) */
void sr_text_num(char *buf, size_t n, double x, int sig)
{
    char d[MAX_DIGITS + 1];
    uint64_t m;
    int e, E;
    if (x != x) {
        sr_text_cat(buf, n, "nan");
        return;
    }
    if (isinf(x)) {
        sr_text_cat(buf, n, x > 0 ? "inf" : "-inf");
        return;
    }
    if (x == 0.0) {
        sr_text_cat(buf, n, signbit(x) ? "-0" : "0");
        return;
    }
    if (sig < 1)
        sig = 1;
    if (sig > 17)
        sig = 17;
    binary_parts(x, &m, &e);
    int nd = round_digits(d, exact_digits(m, e, d, &E), sig, &E);
    layout(buf, n, x < 0, d, nd, E, E >= -4 && E < sig, 0);
}

/* -1, 0, 1: the decimal a (na digits, 10^Ea) against b */
static int decimal_cmp(const char *a, int na, int Ea, const char *b, int nb, int Eb)
{
    if (Ea != Eb)
        return Ea < Eb ? -1 : 1;
    for (int i = 0; i < na || i < nb; i++) {
        char ca = i < na ? a[i] : '0', cb = i < nb ? b[i] : '0';
        if (ca != cb)
            return ca < cb ? -1 : 1;
    }
    return 0;
}

/* append x as Python's repr of a float: the shortest digits that give x back (correctly
 * rounded, as strtod reads them), "1.5", "-1.0", "1e+16", "1e-05", "nan", "inf" */
void sr_text_repr(char *buf, size_t n, double x)
{
    char d[MAX_DIGITS + 1], lo[MAX_DIGITS + 1], hi[MAX_DIGITS + 1];
    uint64_t m;
    int e, E, Elo, Ehi, nd = 0;
    if (!isfinite(x) || x == 0.0) {
        sr_text_num(buf, n, x, 1);
        if (x == 0.0)
            sr_text_cat(buf, n, ".0");
        return;
    }
    binary_parts(x, &m, &e);
    /* the numbers that read back as x lie between the midpoints to its neighbours (the one
       below is half as far at the bottom of a binade), the midpoints themselves when m is
       even (ties to even); m 2^e with m odd here unless e is at its least */
    uint64_t M = m;
    int eM = e;
    while (M < ((uint64_t)1 << 52) && eM > -1074) {          /* the 53-bit mantissa */
        M <<= 1;
        eM--;
    }
    int bottom = M == ((uint64_t)1 << 52) && eM > -1074;
    int nlo = bottom ? exact_digits(4 * M - 1, eM - 2, lo, &Elo)
                     : exact_digits(2 * M - 1, eM - 1, lo, &Elo);
    int nhi = exact_digits(2 * M + 1, eM - 1, hi, &Ehi);
    int even = (M & 1u) == 0;
    int nx = exact_digits(m, e, d, &E);
    char c[MAX_DIGITS + 1];
    int Ec = E;
    for (int s = 1; s <= 17; s++) {                          /* the shortest that reads back */
        memcpy(c, d, (size_t)nx + 1);
        Ec = E;
        nd = round_digits(c, nx, s, &Ec);
        int a = decimal_cmp(c, nd, Ec, lo, nlo, Elo), b = decimal_cmp(c, nd, Ec, hi, nhi, Ehi);
        if ((a > 0 || (a == 0 && even)) && (b < 0 || (b == 0 && even)))
            break;
    }
    layout(buf, n, x < 0, c, nd, Ec, Ec >= -4 && Ec < 16, 1);
}

/* append "[a b c]" of v (k values, 4 significant digits, as NumPy's array2string precision=4) */
void sr_text_vec(char *buf, size_t n, const double *v, int k)
{
    sr_text_cat(buf, n, "[");
    for (int i = 0; i < k; i++) {
        if (i)
            sr_text_cat(buf, n, " ");
        sr_text_num(buf, n, v[i], 4);
    }
    sr_text_cat(buf, n, "]");
}

void sr_text_set(char *buf, size_t n, const char *s)
{
    if (buf != NULL && n) {
        buf[0] = '\0';
        sr_text_cat(buf, n, s);
    }
}

/* the precision of a "%.<p>g" conversion at *f (after '%'), or 6; moves *f past it */
static int precision(const char **f)
{
    int p = 6;
    if (**f == '.') {
        ++*f;
        p = 0;
        while (**f >= '0' && **f <= '9')
            p = 10 * p + (*(*f)++ - '0');
        if (p < 1)
            p = 1;
    }
    return p;
}

size_t sr_text_vformat(char *buf, size_t n, const char *fmt, va_list ap)
{
    if (buf == NULL || n == 0)
        return 0;
    buf[0] = '\0';
    if (fmt == NULL)
        return 0;
    for (const char *f = fmt; *f; ) {
        const char *lit = f;
        while (*f && *f != '%')
            f++;
        if (f > lit) {                                   /* the literal run */
            size_t len = strlen(buf), k = (size_t)(f - lit);
            if (len + k + 1 > n)
                k = n - 1 - len;
            memcpy(buf + len, lit, k);
            buf[len + k] = '\0';
        }
        if (!*f)
            break;
        const char *conv = f++;                          /* at '%' */
        int sig = precision(&f);
        int longs = 0, size_t_arg = 0;
        while (*f == 'l') {
            longs++;
            f++;
        }
        if (*f == 'z') {
            size_t_arg = 1;
            f++;
        }
        char one[2] = {0, 0};
        switch (*f) {
        case '%':
            sr_text_cat(buf, n, "%");
            break;
        case 's':
            sr_text_cat(buf, n, va_arg(ap, const char *));
            break;
        case 'c':
            one[0] = (char)va_arg(ap, int);
            sr_text_cat(buf, n, one);
            break;
        case 'd':
        case 'i':
            sr_text_int(buf, n, size_t_arg ? (long long)va_arg(ap, size_t)
                                : longs >= 2 ? va_arg(ap, long long)
                                : longs == 1 ? (long long)va_arg(ap, long)
                                : (long long)va_arg(ap, int));
            break;
        case 'u': {
            unsigned long long u = size_t_arg ? (unsigned long long)va_arg(ap, size_t)
                                   : longs >= 2 ? va_arg(ap, unsigned long long)
                                   : longs == 1 ? (unsigned long long)va_arg(ap, unsigned long)
                                   : (unsigned long long)va_arg(ap, unsigned);
            if (u > 9223372036854775807ULL) {            /* beyond long long: digit by digit */
                char d[24];
                int i = 23;
                d[i] = '\0';
                do {
                    d[--i] = (char)('0' + (int)(u % 10));
                    u /= 10;
                } while (u);
                sr_text_cat(buf, n, d + i);
            } else {
                sr_text_int(buf, n, (long long)u);
            }
            break;
        }
        case 'g':
        case 'e':
        case 'f':
            sr_text_num(buf, n, va_arg(ap, double), sig);
            break;
        default: {                                       /* unknown: copied as it stands */
            char tmp[16];
            size_t k = (size_t)(f - conv) + (*f ? 1 : 0);
            if (k > sizeof tmp - 1)
                k = sizeof tmp - 1;
            memcpy(tmp, conv, k);
            tmp[k] = '\0';
            sr_text_cat(buf, n, tmp);
            if (!*f)
                return strlen(buf);
        }
        }
        f++;
    }
    return strlen(buf);
}

size_t sr_text_format(char *buf, size_t n, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    size_t len = sr_text_vformat(buf, n, fmt, ap);
    va_end(ap);
    return len;
}
