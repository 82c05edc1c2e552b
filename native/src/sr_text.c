/* Messages: appending to a fixed buffer, locale-independent number formatting and a small
 * printf over it (sr_text.h). */
#include "sr_text.h"

#include <math.h>
#include <string.h>

#include "sr_math.h"

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

/* append x as C's "%.{sig}g" would in the "C" locale (never the C library's formatting) */
void sr_text_num(char *buf, size_t n, double x, int sig)
{
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
    char out[64];
    int o = 0;
    if (x < 0) {
        out[o++] = '-';
        x = -x;
    }
    int e10 = (int)floor(sr_log10(x));
    int shift = sig - 1 - e10;
    if (shift > 300) {                       /* below ~1e-284: 10^shift overflows; two steps */
        x *= 1e300;
        shift -= 300;
    }
    double scale = sr_pow10(shift);
    double dig = floor(x * scale + 0.5);                     /* sig digits as an integer */
    double top = sr_pow10(sig);
    if (dig >= top) {
        dig = floor(dig / 10.0 + 0.5);
        e10++;
    }
    char d[20];
    for (int i = sig - 1; i >= 0; i--) {
        d[i] = (char)('0' + (int)fmod(dig, 10.0));
        dig = floor(dig / 10.0);
    }
    int nd = sig;
    while (nd > 1 && d[nd - 1] == '0')                       /* strip trailing zeros */
        nd--;
    if (e10 < -4 || e10 >= sig) {                            /* d.ddde+XX */
        out[o++] = d[0];
        if (nd > 1) {
            out[o++] = '.';
            for (int i = 1; i < nd; i++)
                out[o++] = d[i];
        }
        out[o++] = 'e';
        out[o++] = e10 < 0 ? '-' : '+';
        int ae = e10 < 0 ? -e10 : e10;
        if (ae >= 100)
            out[o++] = (char)('0' + ae / 100);
        out[o++] = (char)('0' + (ae / 10) % 10);
        out[o++] = (char)('0' + ae % 10);
    } else if (e10 < 0) {                                    /* 0.000ddd */
        out[o++] = '0';
        out[o++] = '.';
        for (int i = 0; i < -e10 - 1; i++)
            out[o++] = '0';
        for (int i = 0; i < nd; i++)
            out[o++] = d[i];
    } else {                                                 /* ddd.ddd */
        for (int i = 0; i <= e10; i++)
            out[o++] = i < nd ? d[i] : '0';
        if (nd > e10 + 1) {
            out[o++] = '.';
            for (int i = e10 + 1; i < nd; i++)
                out[o++] = d[i];
        }
    }
    out[o] = '\0';
    sr_text_cat(buf, n, out);
}

/* append x as Python's repr of a float: the shortest digits that give x back (checked in
 * double arithmetic, good for messages), "1.5", "-1.0", "1e+16", "1e-05", "nan", "inf" */
void sr_text_repr(char *buf, size_t n, double x)
{
    if (!isfinite(x) || x == 0.0) {
        sr_text_num(buf, n, x, 1);
        if (x == 0.0)
            sr_text_cat(buf, n, ".0");
        return;
    }
    double ax = fabs(x);
    int e10 = (int)floor(sr_log10(ax)), sig = 17;
    for (int s = 1; s <= 17; s++) {                          /* the shortest round trip */
        double scale = sr_pow10(s - 1 - e10);
        double dig = floor(ax * scale + 0.5);
        if (dig / scale == ax || dig * sr_pow10(e10 + 1 - s) == ax) {
            sig = s;
            break;
        }
    }
    char tmp[64];
    tmp[0] = '\0';
    if (e10 >= -5 && e10 < 16) {                             /* fixed notation */
        /* %.{sig}g switches to exponents at e10 >= sig: pad with the integer digits */
        sr_text_num(tmp, sizeof tmp, x, e10 + 1 > sig ? e10 + 1 : sig);
        if (e10 == -5) {                                     /* repr: 1e-05, not 0.00001 */
            tmp[0] = '\0';
            sr_text_num(tmp, sizeof tmp, x, sig);
        }
        if (!strchr(tmp, '.') && !strchr(tmp, 'e'))
            sr_text_cat(tmp, sizeof tmp, ".0");
    } else {
        sr_text_num(tmp, sizeof tmp, x, sig);
    }
    sr_text_cat(buf, n, tmp);
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
