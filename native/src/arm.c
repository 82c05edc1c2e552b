/* The robot record reader (format in arm.h).
 *
 * Integer parsing only: every double is its IEEE-754 bit pattern in hex, so the value read is
 * exactly the value written and no locale can change it (no strtod, no scanf). Robust against
 * any bytes: every access is bounded by len, every line is checked, the first error stops.
 */
#include "arm.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_TOKENS 11                 /* key + 9 values + one to detect "too many" */
#define MAX_FILE_BYTES (16L * 1024L * 1024L)

/* the keys that appear once in the record (besides the per-link ones) */
enum { K_NAME, K_PLANAR, K_N, K_BASE_MASS, K_BASE_COM, K_BASE_I, K_EE_XYZ, K_EE_R, K_END,
       N_KEYS };
static const char *const KEY_NAMES[N_KEYS] = {
    "name", "planar", "n", "base.mass", "base.com", "base.inertia", "ee.xyz", "ee.R", "end"};
static const int KEY_VALUES[N_KEYS] = {1, 1, 1, 1, 3, 9, 3, 9, 0};

/* the fields of each link "linkK.<field>" */
enum { L_JOINT, L_XYZ, L_R, L_AXIS, L_MASS, L_COM, L_I, N_LFIELDS };
static const char *const LFIELD_NAMES[N_LFIELDS] = {
    "joint", "xyz", "R", "axis", "mass", "com", "inertia"};
static const int LFIELD_VALUES[N_LFIELDS] = {1, 3, 9, 3, 1, 3, 9};

typedef struct tok {
    const char *p;
    size_t n;
} tok;

typedef struct parser {
    char *err;
    size_t errlen;
    unsigned long line;                       /* current line, 1-based */
    unsigned long key_line[N_KEYS];           /* 0: not seen */
    unsigned long link_line[SR_MAX_JOINTS][N_LFIELDS];
} parser;

static int tok_is(tok t, const char *s)
{
    size_t n = strlen(s);
    return t.n == n && memcmp(t.p, s, n) == 0;
}

/* A printable, bounded copy of a token for a message (non-printable bytes become '?'). */
static void tok_show(tok t, char *buf, size_t size)
{
    size_t i, n = t.n, lim = size - 1;
    int cut = 0;
    if (n > lim) {
        n = lim > 3 ? lim - 3 : lim;
        cut = 1;
    }
    for (i = 0; i < n; i++) {
        unsigned char c = (unsigned char)t.p[i];
        buf[i] = (c >= 0x20 && c < 0x7f) ? (char)c : '?';
    }
    if (cut && lim > 3) {
        buf[i++] = '.';
        buf[i++] = '.';
        buf[i++] = '.';
    }
    buf[i] = '\0';
}

/* "line L: <what>" into the error buffer; returns 1 (the parse's failure status). */
static int fail(parser *ps, unsigned long line, const char *what, const char *detail)
{
    if (ps->err && ps->errlen > 0) {
        if (line > 0)
            snprintf(ps->err, ps->errlen, "robot record line %lu: %s%s", line, what,
                     detail ? detail : "");
        else
            snprintf(ps->err, ps->errlen, "robot record: %s%s", what, detail ? detail : "");
    }
    return 1;
}

static int fail_key(parser *ps, const char *key, const char *what)
{
    char buf[160];
    snprintf(buf, sizeof buf, "%s: %s", key, what);
    return fail(ps, ps->line, buf, NULL);
}

static int hexval(unsigned char c)
{
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

/* "0x" + exactly 16 hex digits -> the double with those bits; 0 ok. */
static int parse_double(parser *ps, const char *key, tok t, double *out)
{
    char shown[40], buf[160];
    {
        unsigned long long bits = 0;
        size_t i;
        int ok = t.n == 18 && t.p[0] == '0' && (t.p[1] == 'x' || t.p[1] == 'X');
        for (i = 2; ok && i < 18; i++) {
            int h = hexval((unsigned char)t.p[i]);
            if (h < 0)
                ok = 0;
            else
                bits = (bits << 4) | (unsigned long long)h;
        }
        if (!ok) {
            tok_show(t, shown, sizeof shown);
            snprintf(buf, sizeof buf, "%s: malformed number '%s' (expected 0x and 16 hex "
                     "digits, the IEEE-754 bits of a double)", key, shown);
            return fail(ps, ps->line, buf, NULL);
        }
        memcpy(out, &bits, sizeof *out);
        if (!isfinite(*out)) {
            tok_show(t, shown, sizeof shown);
            snprintf(buf, sizeof buf, "%s: %s is not a finite number", key, shown);
            return fail(ps, ps->line, buf, NULL);
        }
    }
    return 0;
}

/* A name: 1..SR_NAME_MAX printable ASCII bytes (the tokenizer already split at blanks and '#'). */
static int parse_name(parser *ps, const char *key, tok t, char *out)
{
    size_t i;
    if (t.n > SR_NAME_MAX)
        return fail_key(ps, key, "name longer than 63 bytes");
    for (i = 0; i < t.n; i++) {
        unsigned char c = (unsigned char)t.p[i];
        if (c < 0x21 || c > 0x7e)
            return fail_key(ps, key, "name has a byte that is not printable ASCII");
    }
    memcpy(out, t.p, t.n);
    out[t.n] = '\0';
    return 0;
}

/* A small decimal integer (1 or 2 digits) in [lo, hi]. */
static int parse_small_int(tok t, int lo, int hi, int *out)
{
    int v = 0;
    size_t i;
    if (t.n < 1 || t.n > 2)
        return 1;
    for (i = 0; i < t.n; i++) {
        if (t.p[i] < '0' || t.p[i] > '9')
            return 1;
        v = 10 * v + (t.p[i] - '0');
    }
    if (v < lo || v > hi)
        return 1;
    *out = v;
    return 0;
}

/* R (3 x 3) is a rotation: max |R^T R - 1| <= 1e-9 and det R > 0. */
static int check_rotation(parser *ps, const char *key, const double *R)
{
    double err = 0.0, det;
    int i, j, k;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++) {
            double s = i == j ? -1.0 : 0.0;
            for (k = 0; k < 3; k++)
                s += R[3 * k + i] * R[3 * k + j];
            if (fabs(s) > err)
                err = fabs(s);
        }
    det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6])
        + R[2] * (R[3] * R[7] - R[4] * R[6]);
    if (!(err <= 1e-9) || !(det > 0.0))
        return fail_key(ps, key, "not a rotation matrix (R^T R = 1 within 1e-9, det R > 0)");
    return 0;
}

static int check_unit(parser *ps, const char *key, const double *a)
{
    double s = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    if (!(fabs(s - 1.0) <= 1e-9))
        return fail_key(ps, key, "joint axis is not a unit vector (|axis| = 1 within 1e-9)");
    return 0;
}

static int check_mass(parser *ps, const char *key, double m)
{
    if (!(m > 0.0))
        return fail_key(ps, key, "mass must be > 0 kg");
    return 0;
}

/* I (3 x 3) is an inertia about the centre of mass: symmetric, positive definite, and the
 * principal moments obey the triangle inequality, i.e. C = tr(I)/2 1 - I (the second moment of
 * the mass distribution) is positive semi-definite; tolerances relative to tr(I). */
static int check_inertia(parser *ps, const char *key, const double *I)
{
    double tr = I[0] + I[4] + I[8], a, b, c, d, e, f, h, eps;
    if (!(tr > 0.0))
        return fail_key(ps, key, "inertia is not positive definite");
    if (fabs(I[1] - I[3]) > 1e-12 * tr || fabs(I[2] - I[6]) > 1e-12 * tr
        || fabs(I[5] - I[7]) > 1e-12 * tr)
        return fail_key(ps, key, "inertia is not symmetric");
    a = I[0]; b = I[4]; c = I[8]; d = I[1]; e = I[2]; f = I[5];
    /* Sylvester: leading principal minors > 0 */
    if (!(a > 0.0) || !(a * b - d * d > 0.0)
        || !(a * (b * c - f * f) - d * (d * c - f * e) + e * (d * f - b * e) > 0.0))
        return fail_key(ps, key, "inertia is not positive definite");
    /* all principal minors of C + eps 1 >= 0 */
    eps = 1e-9 * tr;
    h = 0.5 * tr + eps;
    a = h - I[0]; b = h - I[4]; c = h - I[8]; d = -d; e = -e; f = -f;
    if (!(a >= 0.0) || !(b >= 0.0) || !(c >= 0.0) || !(a * b - d * d >= 0.0)
        || !(a * c - e * e >= 0.0) || !(b * c - f * f >= 0.0)
        || !(a * (b * c - f * f) - d * (d * c - f * e) + e * (d * f - b * e) >= 0.0))
        return fail_key(ps, key, "inertia violates the triangle inequality (no principal "
                                 "moment may exceed the sum of the other two)");
    return 0;
}

/* Split [s, e) at blanks, stopping at '#'; returns the number of tokens (<= MAX_TOKENS). */
static int tokenize(const char *s, const char *e, tok *t)
{
    int nt = 0;
    while (s < e && nt < MAX_TOKENS) {
        while (s < e && (*s == ' ' || *s == '\t' || *s == '\r' || *s == '\v' || *s == '\f'))
            s++;
        if (s >= e || *s == '#')
            break;
        t[nt].p = s;
        while (s < e && !(*s == ' ' || *s == '\t' || *s == '\r' || *s == '\v' || *s == '\f'
                          || *s == '#'))
            s++;
        t[nt].n = (size_t)(s - t[nt].p);
        nt++;
    }
    return nt;
}

/* The values of one key: exactly count numbers into v; 0 ok. */
static int parse_values(parser *ps, const char *key, const tok *t, int nt, int count, double *v)
{
    char buf[160];
    int i;
    if (nt - 1 != count) {
        snprintf(buf, sizeof buf, "%s: expected %d value%s, got %s%d", key, count,
                 count == 1 ? "" : "s", nt - 1 >= MAX_TOKENS - 1 ? "more than " : "",
                 nt - 1 >= MAX_TOKENS - 1 ? MAX_TOKENS - 2 : nt - 1);
        return fail(ps, ps->line, buf, NULL);
    }
    for (i = 0; i < count; i++)
        if (parse_double(ps, key, t[1 + i], &v[i]))
            return 1;
    return 0;
}

/* "linkK.field" -> K (1..SR_MAX_JOINTS) and the field; 0 ok, 1 not a link key, 2 bad index. */
static int link_key(tok t, int *k, int *field)
{
    size_t i = 4, start;
    int v = 0, j;
    if (t.n < 6 || memcmp(t.p, "link", 4) != 0)
        return 1;
    start = i;
    while (i < t.n && t.p[i] >= '0' && t.p[i] <= '9' && i - start < 3) {
        v = 10 * v + (t.p[i] - '0');
        i++;
    }
    if (i == start || i >= t.n || t.p[i] != '.')
        return 1;
    i++;
    for (j = 0; j < N_LFIELDS; j++) {
        size_t n = strlen(LFIELD_NAMES[j]);
        if (t.n - i == n && memcmp(t.p + i, LFIELD_NAMES[j], n) == 0) {
            if (v < 1 || v > SR_MAX_JOINTS)
                return 2;
            *k = v;
            *field = j;
            return 0;
        }
    }
    return 1;
}

/* One line with its tokens (nt >= 1) after the header; sets *done at "end". */
static int parse_line(parser *ps, const tok *t, int nt, sr_robot *r, int *done)
{
    char key[40], buf[200];
    double v[9];
    int i, k = 0, field = 0, lk;
    tok_show(t[0], key, sizeof key);
    for (i = 0; i < N_KEYS; i++)
        if (tok_is(t[0], KEY_NAMES[i]))
            break;
    if (i < N_KEYS) {
        if (ps->key_line[i]) {
            snprintf(buf, sizeof buf, "key '%s' repeated (first on line %lu)", KEY_NAMES[i],
                     ps->key_line[i]);
            return fail(ps, ps->line, buf, NULL);
        }
        ps->key_line[i] = ps->line;
        if (i == K_END) {
            if (nt != 1)
                return fail_key(ps, key, "expected no value");
            *done = 1;
            return 0;
        }
        if (i == K_NAME || i == K_PLANAR || i == K_N) {
            if (nt != 2)
                return fail_key(ps, key, "expected one value");
            if (i == K_NAME)
                return parse_name(ps, key, t[1], r->name);
            if (i == K_PLANAR) {
                if (parse_small_int(t[1], 0, 1, &r->planar))
                    return fail_key(ps, key, "expected 0 or 1");
                return 0;
            }
            if (parse_small_int(t[1], 1, SR_MAX_JOINTS, &r->n))
                return fail_key(ps, key, "n out of range: expected 1 to 12 movable joints");
            return 0;
        }
        if (parse_values(ps, key, t, nt, KEY_VALUES[i], v))
            return 1;
        switch (i) {
        case K_BASE_MASS:
            r->base.m = v[0];
            return check_mass(ps, key, v[0]);
        case K_BASE_COM:
            memcpy(r->base.com, v, sizeof r->base.com);
            return 0;
        case K_BASE_I:
            memcpy(r->base.I, v, sizeof r->base.I);
            return check_inertia(ps, key, v);
        case K_EE_XYZ:
            memcpy(r->ee_xyz, v, sizeof r->ee_xyz);
            return 0;
        default: /* K_EE_R */
            memcpy(r->ee_R, v, sizeof r->ee_R);
            return check_rotation(ps, key, v);
        }
    }
    lk = link_key(t[0], &k, &field);
    if (lk == 2)
        return fail_key(ps, key, "link number out of range: expected link1 to link12");
    if (lk != 0)
        return fail_key(ps, key, "unknown key");
    if (ps->link_line[k - 1][field]) {
        snprintf(buf, sizeof buf, "key '%s' repeated (first on line %lu)", key,
                 ps->link_line[k - 1][field]);
        return fail(ps, ps->line, buf, NULL);
    }
    ps->link_line[k - 1][field] = ps->line;
    if (field == L_JOINT) {
        if (nt != 2)
            return fail_key(ps, key, "expected one name");
        return parse_name(ps, key, t[1], r->joint[k - 1]);
    }
    if (parse_values(ps, key, t, nt, LFIELD_VALUES[field], v))
        return 1;
    switch (field) {
    case L_XYZ:
        memcpy(r->xyz[k - 1], v, sizeof r->xyz[0]);
        return 0;
    case L_R:
        memcpy(r->R[k - 1], v, sizeof r->R[0]);
        return check_rotation(ps, key, v);
    case L_AXIS:
        memcpy(r->axis[k - 1], v, sizeof r->axis[0]);
        return check_unit(ps, key, v);
    case L_MASS:
        r->link[k - 1].m = v[0];
        return check_mass(ps, key, v[0]);
    case L_COM:
        memcpy(r->link[k - 1].com, v, sizeof r->link[0].com);
        return 0;
    default: /* L_I */
        memcpy(r->link[k - 1].I, v, sizeof r->link[0].I);
        return check_inertia(ps, key, v);
    }
}

/* After "end": every key present, links 1..n complete and none beyond n. */
static int check_complete(parser *ps, const sr_robot *r)
{
    char buf[200];
    int i, k, f;
    for (i = 0; i < N_KEYS; i++)
        if (!ps->key_line[i]) {
            snprintf(buf, sizeof buf, "missing key '%s'", KEY_NAMES[i]);
            return fail(ps, ps->line, buf, NULL);
        }
    for (k = 0; k < SR_MAX_JOINTS; k++)
        for (f = 0; f < N_LFIELDS; f++) {
            if (k < r->n && !ps->link_line[k][f]) {
                snprintf(buf, sizeof buf, "missing key 'link%d.%s' (n = %d)", k + 1,
                         LFIELD_NAMES[f], r->n);
                return fail(ps, ps->line, buf, NULL);
            }
            if (k >= r->n && ps->link_line[k][f]) {
                snprintf(buf, sizeof buf, "key 'link%d.%s' but the robot has n = %d joints",
                         k + 1, LFIELD_NAMES[f], r->n);
                return fail(ps, ps->link_line[k][f], buf, NULL);
            }
        }
    return 0;
}

static int parse(parser *ps, const char *text, size_t len, sr_robot *r)
{
    const char *s = text, *end = text + len;
    tok t[MAX_TOKENS];
    int header = 0, done = 0;
    char shown[40], buf[160];
    if (!text && len > 0)
        return fail(ps, 0, "no text", NULL);
    if (len >= 3 && (unsigned char)s[0] == 0xEF && (unsigned char)s[1] == 0xBB
        && (unsigned char)s[2] == 0xBF)
        s += 3;                                       /* UTF-8 byte order mark */
    while (s < end) {
        const char *e = memchr(s, '\n', (size_t)(end - s));
        const char *next;
        int nt;
        if (!e)
            e = end;
        next = e < end ? e + 1 : end;
        ps->line++;
        nt = tokenize(s, e, t);
        s = next;
        if (nt == 0)
            continue;                                 /* blank or comment line */
        if (done)
            return fail(ps, ps->line, "content after 'end'", NULL);
        if (!header) {
            int version = 0;
            if (!tok_is(t[0], "spacerobot-robot") || nt != 2)
                return fail(ps, ps->line, "not a spacerobot robot record (the first line must "
                                          "be 'spacerobot-robot 1')", NULL);
            if (parse_small_int(t[1], 0, 99, &version) || version != SR_ROBOT_RECORD_VERSION) {
                tok_show(t[1], shown, sizeof shown);
                snprintf(buf, sizeof buf, "record version '%s': this reader reads version %d",
                         shown, SR_ROBOT_RECORD_VERSION);
                return fail(ps, ps->line, buf, NULL);
            }
            header = 1;
            continue;
        }
        if (parse_line(ps, t, nt, r, &done))
            return 1;
    }
    if (!header)
        return fail(ps, 0, "empty: not a spacerobot robot record", NULL);
    if (!done)
        return fail(ps, ps->line, "the record ends without 'end' (truncated?)", NULL);
    ps->line = ps->key_line[K_END];
    return check_complete(ps, r);
}

SR_API int sr_robot_parse(const char *text, size_t len, sr_robot *out, char *err, size_t errlen)
{
    parser ps;
    int st;
    if (err && errlen > 0)
        err[0] = '\0';
    if (!out) {
        if (err && errlen > 0)
            snprintf(err, errlen, "robot record: no output struct");
        return 1;
    }
    memset(&ps, 0, sizeof ps);
    ps.err = err;
    ps.errlen = err ? errlen : 0;
    memset(out, 0, sizeof *out);
    st = parse(&ps, text, len, out);
    if (st)
        memset(out, 0, sizeof *out);
    return st;
}

SR_API int sr_robot_read(const char *path, sr_robot *out, char *err, size_t errlen)
{
    FILE *f;
    char *buf;
    long size;
    size_t got;
    int st;
    if (err && errlen > 0)
        err[0] = '\0';
    if (out)
        memset(out, 0, sizeof *out);
    if (!path || !(f = fopen(path, "rb"))) {
        if (err && errlen > 0)
            snprintf(err, errlen, "robot record: cannot open '%s'", path ? path : "(null)");
        return 1;
    }
    if (fseek(f, 0, SEEK_END) != 0 || (size = ftell(f)) < 0 || fseek(f, 0, SEEK_SET) != 0) {
        fclose(f);
        if (err && errlen > 0)
            snprintf(err, errlen, "robot record: cannot read '%s'", path);
        return 1;
    }
    if (size > MAX_FILE_BYTES) {
        fclose(f);
        if (err && errlen > 0)
            snprintf(err, errlen, "robot record: '%s' is too large (%ld bytes, at most %ld)",
                     path, size, MAX_FILE_BYTES);
        return 1;
    }
    buf = (char *)malloc(size > 0 ? (size_t)size : 1);
    if (!buf) {
        fclose(f);
        if (err && errlen > 0)
            snprintf(err, errlen, "robot record: out of memory reading '%s'", path);
        return 1;
    }
    got = fread(buf, 1, (size_t)size, f);
    st = ferror(f);
    fclose(f);
    if (st || got != (size_t)size) {
        free(buf);
        if (err && errlen > 0)
            snprintf(err, errlen, "robot record: cannot read '%s'", path);
        return 1;
    }
    st = sr_robot_parse(buf, got, out, err, errlen);
    free(buf);
    return st;
}

SR_API size_t sr_robot_size(void)
{
    return sizeof(sr_robot);
}
