/* Small dense linear algebra of the native core (linalg.h). */
#include "linalg.h"

#include <math.h>
#include <string.h>

#include "sr_math.h"
void sr_matmul(const double *A, const double *B, int n, int k, int m, double *C)
{
    int i, l, j;
    if (n <= 0 || m <= 0)
        return;
    for (i = 0; i < n * m; ++i)
        C[i] = 0.0;
    for (i = 0; i < n; ++i)
        for (l = 0; l < k; ++l) {
            const double a = A[i * k + l];
            for (j = 0; j < m; ++j)
                C[i * m + j] += a * B[l * m + j];
        }
}

void sr_matvec(const double *A, const double *x, int n, int k, double *y)
{
    int i, l;
    for (i = 0; i + 1 < n; i += 2) {            /* two rows a step: two independent sums */
        const double *a0 = A + i * k, *a1 = a0 + k;
        double s0 = 0.0, s1 = 0.0;
        for (l = 0; l < k; ++l) {
            s0 += a0[l] * x[l];
            s1 += a1[l] * x[l];
        }
        y[i] = s0;
        y[i + 1] = s1;
    }
    if (i < n) {
        double s = 0.0;
        for (l = 0; l < k; ++l)
            s += A[i * k + l] * x[l];
        y[i] = s;
    }
}

/* -- eigen-decomposition: EISPACK tred2 / tql2 (as JAMA), report_kernels._tridiagonalize and
 *    _tridiagonal_ql line by line; V (n x n) row-major, V[r][c] = V[r * n + c] -------------- */
#define AT(r, c) V[(r) * n + (c)]

/* Householder reduction of the symmetric V to tridiagonal form in place: d the diagonal,
 * e the sub-diagonal (e[0] = 0), V the accumulated orthogonal transformation. */
static void tridiagonalize(double *V, int n, double *d, double *e)
{
    int i, j, k;
    for (j = 0; j < n; ++j)
        d[j] = AT(n - 1, j);
    for (i = n - 1; i > 0; --i) {
        double scale = 0.0, h = 0.0;
        for (k = 0; k < i; ++k)
            scale += fabs(d[k]);
        if (scale == 0.0) {
            e[i] = d[i - 1];
            for (j = 0; j < i; ++j) {
                d[j] = AT(i - 1, j);
                AT(i, j) = 0.0;
                AT(j, i) = 0.0;
            }
        } else {
            double f, g, hh;
            for (k = 0; k < i; ++k) {           /* the Householder vector */
                d[k] /= scale;
                h += d[k] * d[k];
            }
            f = d[i - 1];
            g = sqrt(h);
            if (f > 0.0)
                g = -g;
            e[i] = scale * g;
            h -= f * g;
            d[i - 1] = f - g;
            for (j = 0; j < i; ++j)
                e[j] = 0.0;
            for (j = 0; j < i; ++j) {           /* the similarity transformation */
                f = d[j];
                AT(j, i) = f;
                g = e[j] + AT(j, j) * f;
                for (k = j + 1; k < i; ++k) {
                    g += AT(k, j) * d[k];
                    e[k] += AT(k, j) * f;
                }
                e[j] = g;
            }
            f = 0.0;
            for (j = 0; j < i; ++j) {
                e[j] /= h;
                f += e[j] * d[j];
            }
            hh = f / (h + h);
            for (j = 0; j < i; ++j)
                e[j] -= hh * d[j];
            for (j = 0; j < i; ++j) {
                f = d[j];
                g = e[j];
                for (k = j; k < i; ++k)
                    AT(k, j) -= f * e[k] + g * d[k];
                d[j] = AT(i - 1, j);
                AT(i, j) = 0.0;
            }
        }
        d[i] = h;
    }
    for (i = 0; i < n - 1; ++i) {               /* accumulate the transformations */
        double h;
        AT(n - 1, i) = AT(i, i);
        AT(i, i) = 1.0;
        h = d[i + 1];
        if (h != 0.0) {
            for (k = 0; k <= i; ++k)
                d[k] = AT(k, i + 1) / h;
            for (j = 0; j <= i; ++j) {
                double g = 0.0;
                for (k = 0; k <= i; ++k)
                    g += AT(k, i + 1) * AT(k, j);
                for (k = 0; k <= i; ++k)
                    AT(k, j) -= g * d[k];
            }
        }
        for (k = 0; k <= i; ++k)
            AT(k, i + 1) = 0.0;
    }
    for (j = 0; j < n; ++j) {
        d[j] = AT(n - 1, j);
        AT(n - 1, j) = 0.0;
    }
    if (n > 0) {
        AT(n - 1, n - 1) = 1.0;
        e[0] = 0.0;
    }
}

/* (a, b) <- (c a - s b, s a + c b) elementwise, a and b n-vectors: the Givens rotation of two
 * eigenvector columns, stored as rows (contiguous), two entries per step (the compiler's
 * straight-line vectoriser packs the pair) */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void rotate_rows(double *restrict a, double *restrict b, int n, double c, double s)
{
    int k;
    for (k = 0; k + 1 < n; k += 2) {
        const double a0 = a[k], a1 = a[k + 1], b0 = b[k], b1 = b[k + 1];
        b[k] = s * a0 + c * b0;
        b[k + 1] = s * a1 + c * b1;
        a[k] = c * a0 - s * b0;
        a[k + 1] = c * a1 - s * b1;
    }
    if (k < n) {
        const double a0 = a[k], b0 = b[k];
        b[k] = s * a0 + c * b0;
        a[k] = c * a0 - s * b0;
    }
}

/* Eigenvalues d and eigenvectors of the tridiagonal form by the implicit QL method, in place;
 * the eigenvectors as the ROWS of V on entry (the transpose of tridiagonalize's V) and on
 * return (EISPACK's column operations on rows: the same numbers, contiguous). Returns 0, or
 * 1 if an eigenvalue did not converge in 100 iterations. */
static int tridiagonal_ql(double *V, int n, double *d, double *e)
{
    int i, l, m, it;
    double f = 0.0, tst1 = 0.0;
    const double eps = 2.220446049250313e-16;   /* 2^-52 */
    for (i = 1; i < n; ++i)
        e[i - 1] = e[i];
    if (n > 0)
        e[n - 1] = 0.0;
    for (l = 0; l < n; ++l) {
        const double t = fabs(d[l]) + fabs(e[l]);
        if (t > tst1)                           /* Python's max(tst1, t): tst1 unless t > tst1 */
            tst1 = t;
        m = l;
        while (m < n - 1 && !(fabs(e[m]) <= eps * tst1))    /* a negligible sub-diagonal */
            ++m;
        if (m > l) {
            for (it = 0; it < 101; ++it) {
                double g, p, r, dl1, h, c, c2, c3, el1, s, s2;
                if (it == 100)
                    return 1;
                g = d[l];                       /* the implicit shift */
                p = (d[l + 1] - g) / (2.0 * e[l]);
                r = sr_hypot_inline(p, 1.0);   /* portable: the same bits everywhere */
                if (p < 0.0)
                    r = -r;
                d[l] = e[l] / (p + r);
                d[l + 1] = e[l] * (p + r);
                dl1 = d[l + 1];
                h = g - d[l];
                for (i = l + 2; i < n; ++i)
                    d[i] -= h;
                f += h;
                p = d[m];                       /* the QL sweep */
                c = c2 = c3 = 1.0;
                el1 = e[l + 1];
                s = s2 = 0.0;
                for (i = m - 1; i >= l; --i) {
                    c3 = c2;
                    c2 = c;
                    s2 = s;
                    g = c * e[i];
                    h = c * p;
                    r = sr_hypot_inline(p, e[i]);
                    e[i + 1] = s * r;
                    s = e[i] / r;
                    c = p / r;
                    p = c * d[i] - s * g;
                    d[i + 1] = h + s * (c * g + s * d[i]);
                    rotate_rows(V + i * n, V + (i + 1) * n, n, c, s);
                }
                p = -s * s2 * c3 * el1 * e[l] / dl1;
                e[l] = s * p;
                d[l] = c * p;
                if (!(fabs(e[l]) > eps * tst1))
                    break;
            }
        }
        d[l] += f;
        e[l] = 0.0;
    }
    return 0;
}

/* V (n x n) <- V^T in place */
static void transpose(double *V, int n)
{
    int i, j;
    for (i = 0; i < n; ++i)
        for (j = 0; j < i; ++j) {
            const double t = AT(i, j);
            AT(i, j) = AT(j, i);
            AT(j, i) = t;
        }
}

/* a < b in NumPy's sort order (NaN last) */
static int sorts_before(double a, double b)
{
    return a < b || (b != b && a == a);
}

int sr_eigh(const double *A, int n, double *w, double *V)
{
    double d[SR_LINALG_MAX_N], e[SR_LINALG_MAX_N], col[SR_LINALG_MAX_N];
    int order[SR_LINALG_MAX_N], done[SR_LINALG_MAX_N];
    int i, j, k, status, finite = 1;
    if (n < 0 || n > SR_LINALG_MAX_N)
        return 2;
    for (i = 0; i < n; ++i)                     /* the lower triangle is what is read */
        for (j = 0; j <= i; ++j)
            if (!isfinite(A[i * n + j]))
                finite = 0;
    if (V != A)
        memcpy(V, A, sizeof(double) * (size_t)n * (size_t)n);
    tridiagonalize(V, n, d, e);
    transpose(V, n);                            /* the columns of Q as rows */
    status = tridiagonal_ql(V, n, d, e);
    /* ascending order: a stable insertion sort of the indices (np.argsort of Numba is an
     * insertion sort for n <= 15, also stable), then the rows permuted in place */
    for (k = 0; k < n; ++k) {
        int pos = k;
        while (pos > 0 && sorts_before(d[k], d[order[pos - 1]])) {
            order[pos] = order[pos - 1];
            --pos;
        }
        order[pos] = k;
    }
    for (k = 0; k < n; ++k) {
        w[k] = d[order[k]];
        done[k] = 0;
    }
    /* row k of the result is row order[k]: follow the permutation's cycles */
    for (k = 0; k < n; ++k) {
        int dst, src;
        if (done[k] || order[k] == k) {
            done[k] = 1;
            continue;
        }
        memcpy(col, V + k * n, sizeof(double) * (size_t)n);
        dst = k;
        src = order[k];
        while (src != k) {
            memcpy(V + dst * n, V + src * n, sizeof(double) * (size_t)n);
            done[dst] = 1;
            dst = src;
            src = order[src];
        }
        memcpy(V + dst * n, col, sizeof(double) * (size_t)n);
        done[dst] = 1;
    }
    transpose(V, n);                            /* the eigenvectors as columns */
    return (status != 0 || !finite) ? 1 : 0;
}

/* Householder reduction of the symmetric A (n x n, lower triangle read; overwritten, kept
 * full and symmetric) to a tridiagonal T with the same eigenvalues: d (n) its diagonal, e (n)
 * its off-diagonal, e[i] coupling i - 1 and i (e[0] = 0). Column k's reflector
 * H = 1 - tau v v^T taken from row k (contiguous), the trailing block updated as
 * A22 - v w^T - w v^T, w = p - (tau / 2)(v . p) v, p = tau A22 v (LAPACK dsytd2's
 * arrangement on whole rows: two entries a step). For the eigenvalues alone: backward
 * stable as tridiagonalize, not its bits. */
static void tridiagonal_values(double *A, int n, double *d, double *e)
{
    double v[SR_LINALG_MAX_N], pw[SR_LINALG_MAX_N];
    int i, j, k;
    for (i = 0; i < n; ++i)                     /* the full symmetric matrix */
        for (j = 0; j < i; ++j)
            A[j * n + i] = A[i * n + j];
    if (n > 0)
        e[0] = 0.0;
    for (k = 0; k + 2 < n; ++k) {
        const int m = n - k - 1;
        const double *x = A + k * n + k + 1;    /* the column below the diagonal (as a row) */
        double scale = 0.0, sigma = 0.0, alpha, tau, vp = 0.0;
        d[k] = A[k * n + k];
        for (i = 0; i < m; ++i)
            scale += fabs(x[i]);
        if (!(scale > 0.0)) {                   /* nothing to annihilate (or NaN: left as is) */
            e[k + 1] = x[0];
            continue;
        }
        for (i = 0; i < m; ++i) {
            v[i] = x[i] / scale;
            sigma += v[i] * v[i];
        }
        sigma = sqrt(sigma);
        alpha = v[0] > 0.0 ? -sigma : sigma;    /* H x = alpha e1, no cancellation */
        tau = 1.0 / (sigma * (sigma + fabs(v[0])));
        v[0] -= alpha;
        e[k + 1] = alpha * scale;
        for (i = 0; i < m; ++i) {               /* p = tau A22 v */
            const double *Ai = A + (k + 1 + i) * n + k + 1;
            double s0 = 0.0;
            for (j = 0; j < m; ++j)
                s0 += Ai[j] * v[j];
            pw[i] = tau * s0;
            vp += v[i] * pw[i];
        }
        vp *= 0.5 * tau;
        for (i = 0; i < m; ++i)                 /* w = p - (tau / 2)(v . p) v */
            pw[i] -= vp * v[i];
        for (i = 0; i < m; ++i) {               /* A22 -= v w^T + w v^T, whole rows */
            double *Ai = A + (k + 1 + i) * n + k + 1;
            const double vi = v[i], wi = pw[i];
            for (j = 0; j + 1 < m; j += 2) {
                const double a0 = Ai[j] - (vi * pw[j] + wi * v[j]);
                const double a1 = Ai[j + 1] - (vi * pw[j + 1] + wi * v[j + 1]);
                Ai[j] = a0;
                Ai[j + 1] = a1;
            }
            if (j < m)
                Ai[j] -= vi * pw[j] + wi * v[j];
        }
    }
    if (n >= 2) {
        d[n - 2] = A[(n - 2) * n + n - 2];
        e[n - 1] = A[(n - 2) * n + n - 1];
    }
    if (n >= 1)
        d[n - 1] = A[(n - 1) * n + n - 1];
}

/* the characteristic polynomial p(x) = det(T - x 1) of the tridiagonal T (diagonal d,
 * e2[i] = e[i]^2 for the e[i] coupling i - 1 and i, e2[0] unused) and its first two
 * derivatives, by the three-term recurrence p_k = (d_k - x) p_k-1 - e_k^2 p_k-2 (no
 * division: a short serial chain), at two points x (2) at once: two independent chains side
 * by side, in about the time of one */
static void char_poly2(const double *d, const double *e2, int n, const double *x,
                       double *p0, double *p1, double *p2)
{
    double p[2] = {1.0, 1.0}, dp[2] = {0.0, 0.0}, ddp[2] = {0.0, 0.0};
    double pm[2] = {0.0, 0.0}, dpm[2] = {0.0, 0.0}, ddpm[2] = {0.0, 0.0};
    int k, c;
    for (k = 0; k < n; ++k) {
        const double b = k > 0 ? e2[k] : 0.0;
        for (c = 0; c < 2; ++c) {
            const double a = d[k] - x[c];
            const double pn = a * p[c] - b * pm[c];
            const double dpn = a * dp[c] - p[c] - b * dpm[c];
            const double ddpn = a * ddp[c] - 2.0 * dp[c] - b * ddpm[c];
            pm[c] = p[c];
            dpm[c] = dp[c];
            ddpm[c] = ddp[c];
            p[c] = pn;
            dp[c] = dpn;
            ddp[c] = ddpn;
        }
    }
    for (c = 0; c < 2; ++c) {
        p0[c] = p[c];
        p1[c] = dp[c];
        p2[c] = ddp[c];
    }
}

/* Laguerre's iteration towards an extreme eigenvalue of a tridiagonal T from a point outside
 * its spectrum (below it for dir = +1, above for dir = -1): for a polynomial with real roots
 * it converges monotonically from there, cubically near the root; it stops where the step
 * falls to round-off, or where round-off carried it across the root (p's sign changed: of
 * the iterates on either side the one with the smaller |p|). */
typedef struct laguerre {
    double x, xprev, p0, pprev;
    int dir, it, state;            /* state: 0 running, 1 settled, 2 failed */
} laguerre;

/* one step of l from p(x), p'(x), p''(x) (degree n) */
static void laguerre_step(laguerre *l, int n, double p, double dp, double ddp)
{
    const double eps = 2.220446049250313e-16;
    double g, h, disc, sq, den, xn;
    if (!isfinite(p) || !isfinite(dp) || !isfinite(ddp)) {
        l->state = 2;
        return;
    }
    if (p == 0.0) {                             /* on a root */
        l->state = 1;
        return;
    }
    if (l->it == 0)
        l->p0 = p;
    else if ((p > 0.0) != (l->p0 > 0.0)) {      /* across the root: of the two iterates */
        if (fabs(l->pprev) < fabs(p))           /* around it the one p says is nearer */
            l->x = l->xprev;
        l->state = 1;
        return;
    }
    l->pprev = p;
    g = dp / p;
    h = g * g - ddp / p;
    disc = (n - 1) * (n * h - g * g);
    sq = sqrt(disc > 0.0 ? disc : 0.0);
    den = l->dir > 0 ? g - sq : g + sq;         /* the larger |G -+ sq|: G < 0 below, > 0 above */
    if (den == 0.0 || !isfinite(den)) {
        l->state = 2;
        return;
    }
    xn = l->x - n / den;
    if (!(l->dir > 0 ? xn > l->x : xn < l->x)) {    /* no more progress */
        l->state = 1;
        return;
    }
    l->xprev = l->x;
    l->x = xn;
    if (++l->it == 60)
        l->state = 2;
    else if (fabs(l->x - l->xprev) <= 4.0 * eps * fabs(l->x))  /* the step at round-off */
        l->state = 1;
}

/* the smallest (from x_lo below the spectrum) and the largest (from x_hi above) eigenvalue
 * of T (n x n, d, e2 = e^2) by Laguerre's iteration, the two side by side. 0 and *lo, *hi;
 * 1 where one did not settle in 60 steps or met non-finite numbers. */
static int laguerre_extremes(const double *d, const double *e2, int n, double x_lo,
                             double x_hi, double *lo, double *hi)
{
    laguerre l[2] = {{x_lo, x_lo, 0.0, 0.0, 1, 0, 0}, {x_hi, x_hi, 0.0, 0.0, -1, 0, 0}};
    while (l[0].state == 0 || l[1].state == 0) {
        double x[2] = {l[0].x, l[1].x}, p[2], dp[2], ddp[2];
        char_poly2(d, e2, n, x, p, dp, ddp);
        for (int c = 0; c < 2; ++c)
            if (l[c].state == 0)
                laguerre_step(&l[c], n, p[c], dp[c], ddp[c]);
    }
    if (l[0].state != 1 || l[1].state != 1)
        return 1;
    *lo = l[0].x;
    *hi = l[1].x;
    return 0;
}

int sr_eigvalsh_extremes(double *A, int n, double *lo, double *hi)
{
    double d[SR_LINALG_MAX_N], e[SR_LINALG_MAX_N], e2[SR_LINALG_MAX_N];
    double glo = 0.0, ghi = 0.0;
    int i, j;
    if (n < 1 || n > SR_LINALG_MAX_N)
        return 2;
    for (i = 0; i < n; ++i)
        for (j = 0; j <= i; ++j)
            if (!isfinite(A[i * n + j]))
                return 1;
    tridiagonal_values(A, n, d, e);
    for (i = 0; i < n; ++i) {                   /* Gershgorin bounds of the spectrum */
        const double r = (i > 0 ? fabs(e[i]) : 0.0) + (i + 1 < n ? fabs(e[i + 1]) : 0.0);
        e2[i] = i > 0 ? e[i] * e[i] : 0.0;
        if (i == 0 || d[i] - r < glo)
            glo = d[i] - r;
        if (i == 0 || d[i] + r > ghi)
            ghi = d[i] + r;
    }
    if (n == 1) {
        *lo = *hi = d[0];
        return 0;
    }
    /* started just outside the bounds (a root on a bound would stop the first step) */
    glo -= 1e-3 * (fabs(glo) + fabs(ghi)) + 1e-300;
    ghi += 1e-3 * (fabs(glo) + fabs(ghi)) + 1e-300;
    return laguerre_extremes(d, e2, n, glo, ghi, lo, hi);
}
#undef AT

/* y[c] -= f x[c] for c < n, two entries a step (the straight-line vectoriser packs the pair;
 * each entry the same operation as one at a time) */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void sub_scaled(double *restrict y, const double *restrict x, double f, int n)
{
    int c;
    for (c = 0; c + 1 < n; c += 2) {
        const double y0 = y[c] - f * x[c], y1 = y[c + 1] - f * x[c + 1];
        y[c] = y0;
        y[c + 1] = y1;
    }
    if (c < n)
        y[c] -= f * x[c];
}

/* y[c] = y[c] / u for c < n, two quotients a step (packed) */
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
static inline void div_by(double *y, double u, int n)
{
    int c;
    for (c = 0; c + 1 < n; c += 2) {
        const double y0 = y[c] / u, y1 = y[c + 1] / u;
        y[c] = y0;
        y[c + 1] = y1;
    }
    if (c < n)
        y[c] = y[c] / u;
}

/* -- Cholesky (kernels.rls_update) --------------------------------------------------------- */
int sr_cholesky(double *A, int n)
{
    int i, j, a;
    for (j = 0; j < n; ++j) {
        double s = A[j * n + j], ljj;
        for (a = 0; a < j; ++a)
            s -= A[j * n + a] * A[j * n + a];
        if (s != s || s == HUGE_VAL)
            return 2;
        if (!(s > 0.0))
            return 1;
        ljj = sqrt(s);
        A[j * n + j] = ljj;
        for (i = j + 1; i < n; ++i) {           /* column j below the diagonal: still S here */
            double t = A[i * n + j];
            for (a = 0; a < j; ++a)
                t -= A[i * n + a] * A[j * n + a];
            A[i * n + j] = t / ljj;
        }
    }
    for (i = 0; i < n; ++i)
        for (j = i + 1; j < n; ++j)
            A[i * n + j] = 0.0;
    return 0;
}

void sr_cholesky_solve(const double *L, int n, double *B, int ncol)
{
    int c, i, a;
    if (ncol > 2) {                             /* row by row over the columns: each entry the
                                                   same operations in the same order, the
                                                   columns two a step (packed) */
        for (i = 0; i < n; ++i) {               /* L Y = B */
            double *Bi = B + i * ncol;
            const double lii = L[i * n + i];
            for (a = 0; a < i; ++a)
                sub_scaled(Bi, B + a * ncol, L[i * n + a], ncol);
            div_by(Bi, lii, ncol);
        }
        for (i = n - 1; i >= 0; --i) {          /* L^T X = Y */
            double *Bi = B + i * ncol;
            const double lii = L[i * n + i];
            for (a = i + 1; a < n; ++a)
                sub_scaled(Bi, B + a * ncol, L[a * n + i], ncol);
            div_by(Bi, lii, ncol);
        }
        return;
    }
    for (c = 0; c < ncol; ++c) {
        for (i = 0; i < n; ++i) {               /* L y = b */
            double s = B[i * ncol + c];
            for (a = 0; a < i; ++a)
                s -= L[i * n + a] * B[a * ncol + c];
            B[i * ncol + c] = s / L[i * n + i];
        }
        for (i = n - 1; i >= 0; --i) {          /* L^T x = y */
            double s = B[i * ncol + c];
            for (a = i + 1; a < n; ++a)
                s -= L[a * n + i] * B[a * ncol + c];
            B[i * ncol + c] = s / L[i * n + i];
        }
    }
}

/* -- LU with partial pivoting (report_kernels.lu_solve) -------------------------------------- */

void sr_qr_add_rows(double *R, int ldr, double *d, int n, double *rows, int ldw, int k)
{
    int last = d ? n : n - 1;                  /* the last column the reflections update */
    for (int j = 0; j < n; j++) {
        double sigma = 0.0, alpha = R[j * ldr + j], v[6];
        for (int a = 0; a < k; a++)
            sigma += rows[a * ldw + j] * rows[a * ldw + j];
        if (sigma == 0.0)
            continue;
        double norm = sqrt(alpha * alpha + sigma);
        double beta = alpha >= 0.0 ? -norm : norm;
        double v0 = alpha - beta, tau = (beta - alpha) / beta;
        for (int a = 0; a < k; a++)
            v[a] = rows[a * ldw + j] / v0;
        /* the columns j+1 .. last in blocks of 64, innermost (contiguous); each column's
           s = tau (R_jc + sum_a v_a rows_ac) summed over a in order */
        for (int c0 = j + 1; c0 <= last; c0 += 64) {
            int nb = last + 1 - c0 < 64 ? last + 1 - c0 : 64;
            int nR = c0 + nb <= n ? nb : n - c0;       /* of them in R (the rest is d) */
            double s[64];
            for (int i = 0; i < nR; i++)
                s[i] = R[j * ldr + c0 + i];
            if (nR < nb)
                s[nR] = d[j];
            for (int a = 0; a < k; a++) {
                const double va = v[a], *r = rows + a * ldw + c0;
                for (int i = 0; i < nb; i++)
                    s[i] += va * r[i];
            }
            for (int i = 0; i < nb; i++)
                s[i] *= tau;
            for (int i = 0; i < nR; i++)
                R[j * ldr + c0 + i] -= s[i];
            if (nR < nb)
                d[j] -= s[nR];
            for (int a = 0; a < k; a++) {
                const double va = v[a];
                double *r = rows + a * ldw + c0;
                for (int i = 0; i < nb; i++)
                    r[i] -= s[i] * va;
            }
        }
        R[j * ldr + j] = beta;
        for (int a = 0; a < k; a++)
            rows[a * ldw + j] = 0.0;
    }
}

int sr_lu_solve(double *A, int n, double *B, int ncol)
{
    int i, j, c, l;
    if (n < 0 || ncol < 0)
        return 2;
    for (j = 0; j < n; ++j) {
        int piv = j;
        double big = fabs(A[j * n + j]);        /* the largest |entry| of column j */
        for (i = j + 1; i < n; ++i)
            if (fabs(A[i * n + j]) > big) {
                piv = i;
                big = fabs(A[i * n + j]);
            }
        if (big == 0.0 || big != big) {
            for (i = 0; i < n * ncol; ++i)
                B[i] = NAN;
            return 1;
        }
        if (piv != j) {                         /* swap rows of A and of B */
            for (c = 0; c < n; ++c) {
                const double t = A[j * n + c];
                A[j * n + c] = A[piv * n + c];
                A[piv * n + c] = t;
            }
            for (c = 0; c < ncol; ++c) {
                const double t = B[j * ncol + c];
                B[j * ncol + c] = B[piv * ncol + c];
                B[piv * ncol + c] = t;
            }
        }
        for (i = j + 1; i < n; ++i)             /* the multipliers (independent divisions) */
            A[i * n + j] = A[i * n + j] / A[j * n + j];
        for (i = j + 1; i < n; ++i) {           /* eliminate below the pivot */
            const double f = A[i * n + j];
            sub_scaled(A + i * n + j + 1, A + j * n + j + 1, f, n - j - 1);
            sub_scaled(B + i * ncol, B + j * ncol, f, ncol);
        }
    }
    /* back substitution, U X = L^-1 B: row j of X is (B_j - sum_l>j U_jl X_l) / U_jj, the
     * terms subtracted in the order of l (row by row: contiguous) */
    if (ncol <= 2) {                            /* column by column, the sums in registers */
        for (c = 0; c < ncol; ++c)
            for (j = n - 1; j >= 0; --j) {
                double s = B[j * ncol + c];
                for (l = j + 1; l < n; ++l)
                    s -= A[j * n + l] * B[l * ncol + c];
                B[j * ncol + c] = s / A[j * n + j];
            }
        return 0;
    }
    for (j = n - 1; j >= 0; --j) {
        double *Bj = B + j * ncol;
        const double u = A[j * n + j];
        for (l = j + 1; l < n; ++l)
            sub_scaled(Bj, B + l * ncol, A[j * n + l], ncol);
        for (c = 0; c + 1 < ncol; c += 2) {     /* two divisions a step (packed) */
            const double b0 = Bj[c] / u, b1 = Bj[c + 1] / u;
            Bj[c] = b0;
            Bj[c + 1] = b1;
        }
        if (c < ncol)
            Bj[c] = Bj[c] / u;
    }
    return 0;
}

/* -- the scale-free information and its observed directions ------------------------------- */
int sr_scaled_information(const double *G, int p, double *Gs, double *d, int *unobserved)
{
    int i, j;
    if (p < 0)
        return 2;
    for (i = 0; i < p; ++i) {
        const double g = G[i * p + i];
        unobserved[i] = !(g > 0.0);
        d[i] = sqrt(unobserved[i] ? 1.0 : g);
    }
    for (i = 0; i < p; ++i)
        for (j = 0; j < p; ++j)
            Gs[i * p + j] = (unobserved[i] || unobserved[j]) ? 0.0
                            : G[i * p + j] / (d[i] * d[j]);
    return 0;
}

int sr_scaled_eigh(const double *G, int p, double *lam, double *V, double *d, int *unobserved)
{
    if (p < 0 || p > SR_LINALG_MAX_N)
        return 2;
    sr_scaled_information(G, p, V, d, unobserved);
    return sr_eigh(V, p, lam, V);
}

int sr_rcond_scaled(const double *G, int p, double *Gs)
{
    int i, j, ok = 1;
    if (p < 0)
        return 2;
    for (i = 0; i < p; ++i) {                   /* sr_scaled_information without work arrays */
        const double gi = G[i * p + i];
        const double di = sqrt(gi > 0.0 ? gi : 1.0);
        if (!(gi > 0.0))
            ok = 0;
        for (j = 0; j < p; ++j) {
            const double gj = G[j * p + j];
            const double dj = sqrt(gj > 0.0 ? gj : 1.0);
            Gs[i * p + j] = (gi > 0.0 && gj > 0.0) ? G[i * p + j] / (di * dj) : 0.0;
            if (!isfinite(Gs[i * p + j]))
                ok = 0;
        }
    }
    return ok ? 0 : 1;
}

double sr_rcond_of_spectrum(const double *lam, const int *unobserved, int p)
{
    int i;
    if (p <= 0)
        return 0.0;
    if (unobserved)
        for (i = 0; i < p; ++i)
            if (unobserved[i])
                return 0.0;
    if (!(lam[p - 1] > 0.0))
        return 0.0;
    return (lam[0] > 0.0 ? lam[0] : 0.0) / lam[p - 1];
}

int sr_eig_solve(const double *lam, const double *V, const double *d, const int *unobserved,
                 const double *r, int p, double *x, int *unobserved_out)
{
    double c[SR_LINALG_MAX_N];
    int keep[SR_LINALG_MAX_N];
    int i, k;
    double big;
    if (p < 0 || p > SR_LINALG_MAX_N)
        return 2;
    for (i = 0; i < p; ++i) {
        x[i] = 0.0;
        unobserved_out[i] = unobserved[i] ? 1 : 0;
    }
    if (p == 0)
        return 0;
    big = lam[p - 1] > 0.0 ? lam[p - 1] : 0.0;
    for (k = 0; k < p; ++k)
        keep[k] = lam[k] > SR_REL_EIG_MIN * big;
    for (k = 0; k < p; ++k) {                   /* c = V_k^T (r / d) */
        c[k] = 0.0;
        if (keep[k]) {
            double s = 0.0;
            for (i = 0; i < p; ++i)
                s += V[i * p + k] * (r[i] / d[i]);
            c[k] = s;
        }
    }
    for (i = 0; i < p; ++i) {                   /* x = (V_k / lam_k) c / d */
        double s = 0.0;
        for (k = 0; k < p; ++k)
            if (keep[k])
                s += V[i * p + k] / lam[k] * c[k];
        x[i] = s / d[i];
    }
    for (i = 0; i < p; ++i)
        for (k = 0; k < p; ++k)
            if (!keep[k] && fabs(V[i * p + k]) > SR_UNOBSERVED_COMPONENT)
                unobserved_out[i] = 1;
    return 0;
}
