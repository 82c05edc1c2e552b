/* Small dense linear algebra (see linalg.h): ports of report_kernels.py / kernels.py. */
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
    for (i = 0; i < n; ++i) {
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

/* Eigenvalues d and eigenvectors (columns of V) of the tridiagonal form by the implicit QL
 * method, in place. Returns 0, or 1 if an eigenvalue did not converge in 100 iterations. */
static int tridiagonal_ql(double *V, int n, double *d, double *e)
{
    int i, k, l, m, it;
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
                r = sr_hypot(p, 1.0);   /* portable: the same bits everywhere */
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
                    r = sr_hypot(p, e[i]);
                    e[i + 1] = s * r;
                    s = e[i] / r;
                    c = p / r;
                    p = c * d[i] - s * g;
                    d[i + 1] = h + s * (c * g + s * d[i]);
                    for (k = 0; k < n; ++k) {
                        h = AT(k, i + 1);
                        AT(k, i + 1) = s * AT(k, i) + c * h;
                        AT(k, i) = c * AT(k, i) - s * h;
                    }
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
    status = tridiagonal_ql(V, n, d, e);
    /* ascending order: a stable insertion sort of the indices (np.argsort of Numba is an
     * insertion sort for n <= 15, also stable), then the columns permuted in place */
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
    /* column k of the result is column order[k] of V: follow the permutation's cycles */
    for (k = 0; k < n; ++k) {
        int dst, src;
        if (done[k] || order[k] == k) {
            done[k] = 1;
            continue;
        }
        for (i = 0; i < n; ++i)
            col[i] = AT(i, k);
        dst = k;
        src = order[k];
        while (src != k) {
            for (i = 0; i < n; ++i)
                AT(i, dst) = AT(i, src);
            done[dst] = 1;
            dst = src;
            src = order[src];
        }
        for (i = 0; i < n; ++i)
            AT(i, dst) = col[i];
        done[dst] = 1;
    }
    return (status != 0 || !finite) ? 1 : 0;
}
#undef AT

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
        for (i = j + 1; i < n; ++i) {           /* eliminate below the pivot */
            const double f = A[i * n + j] / A[j * n + j];
            A[i * n + j] = f;
            for (c = j + 1; c < n; ++c)
                A[i * n + c] -= f * A[j * n + c];
            for (c = 0; c < ncol; ++c)
                B[i * ncol + c] -= f * B[j * ncol + c];
        }
    }
    for (j = n - 1; j >= 0; --j)                /* back substitution, U X = L^-1 B */
        for (c = 0; c < ncol; ++c) {
            double s = B[j * ncol + c];
            for (l = j + 1; l < n; ++l)
                s -= A[j * n + l] * B[l * ncol + c];
            B[j * ncol + c] = s / A[j * n + j];
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
