/* Physical consistency of an estimated body and its projection onto real bodies
 * (physical.h). */
#include "physical.h"

#include <math.h>

#include "linalg.h"

/* finfo(float).tiny: the smallest normal double */
#define TINY 2.2250738585072014e-308

static const int EST0[2] = {SR_EST_BASE, SR_EST_TARGET};

void sr_second_moment(const double *I6, double *S)
{
    const double Ixx = I6[0], Iyy = I6[1], Izz = I6[2], Ixy = I6[3], Ixz = I6[4], Iyz = I6[5];
    const double h = 0.5 * (Ixx + Iyy + Izz);
    S[0] = h - Ixx;
    S[4] = h - Iyy;
    S[8] = h - Izz;
    S[1] = S[3] = -Ixy;
    S[2] = S[6] = -Ixz;
    S[5] = S[7] = -Iyz;
}

int sr_is_physical(double m, const double *b, const double *I6)
{
    double S[9], L[9] = {0.0};
    int i, j, k;
    if (!isfinite(m) || !(m > 0.0))
        return 0;
    for (i = 0; i < 3; ++i)
        if (!isfinite(b[i]))
            return 0;
    for (i = 0; i < 6; ++i)
        if (!isfinite(I6[i]))
            return 0;
    sr_second_moment(I6, S);
    for (j = 0; j < 3; ++j) {                   /* Cholesky of Sigma_c: every pivot > 0 */
        double s = S[3 * j + j];
        for (k = 0; k < j; ++k)
            s -= L[3 * j + k] * L[3 * j + k];
        if (!(s > 0.0))
            return 0;
        L[3 * j + j] = sqrt(s);
        for (i = j + 1; i < 3; ++i) {
            double t = S[3 * i + j];
            for (k = 0; k < j; ++k)
                t -= L[3 * i + k] * L[3 * j + k];
            L[3 * i + j] = t / L[3 * j + j];
        }
    }
    return 1;
}

void sr_both_physical(const double *ls, int *physical)
{
    int k;
    for (k = 0; k < 2; ++k) {
        const int e = EST0[k];
        physical[k] = sr_is_physical(ls[e], ls + e + 1, ls + e + 4);
    }
}

void sr_error_scale(const double *vec, double com_min, double *scale)
{
    int k, i;
    for (k = 0; k < 2; ++k) {
        const int e = EST0[k];
        double imax;
        for (i = 0; i < 10; ++i)
            scale[e + i] = fabs(vec[e + i]);
        imax = scale[e + 4];                    /* NaN propagates, as np.max */
        for (i = 5; i < 7; ++i) {
            const double v = scale[e + i];
            if (v > imax || v != v)
                imax = v;
        }
        if (!(imax > 0.0))
            imax = 1.0;
        if (scale[e] == 0.0)
            scale[e] = 1.0;
        for (i = 1; i < 4; ++i) {               /* np.maximum: NaN propagates */
            const double v = scale[e + i];
            if (!(v > com_min || v != v))
                scale[e + i] = com_min;
        }
        for (i = 4; i < 7; ++i)
            if (scale[e + i] == 0.0)
                scale[e + i] = imax;
        for (i = 7; i < 10; ++i)
            scale[e + i] = imax;
    }
}

void sr_identified_bodies(const double *sd, const double *out, const double *ls,
                          const double *scale, double sd_rel, const int *identified,
                          int *ok_body)
{
    int k, i;
    for (k = 0; k < 2; ++k) {
        int ok = 1;
        for (i = EST0[k]; i < EST0[k] + 10; ++i) {
            const double tol = sd_rel * scale[i];
            if (identified[i] && !(sd[i] <= tol && fabs(out[i] - ls[i]) <= tol))
                ok = 0;
        }
        ok_body[k] = ok;
    }
}

int sr_report_flags(const double *ls, const double *sd, double com_min, double sd_rel,
                    const int *identified, int *flags)
{
    double scale[20];
    sr_both_physical(ls, flags);
    if (!(flags[0] && flags[1]))
        return 0;
    sr_error_scale(ls, com_min, scale);
    sr_identified_bodies(sd, ls, ls, scale, sd_rel, identified, flags + 2);
    return 1;
}

/* s_min = rel_sigma_min * max(largest |eigenvalue| of lam (3), tiny) */
static double sigma_floor(const double *lam, double rel_sigma_min)
{
    double big = 0.0;
    int k;
    for (k = 0; k < 3; ++k)
        if (fabs(lam[k]) > big)                 /* Python's max(big, |lam_k|) */
            big = fabs(lam[k]);
    return rel_sigma_min * (TINY > big ? TINY : big);
}

int sr_project_body(double m, const double *b, const double *I6, double m_min,
                    double rel_sigma_min, double *m_out, double *I6_out, int *projected)
{
    double S[9], lam[3], V[9], s_min, tr;
    int i, j, k, status;
    if (sr_is_physical(m, b, I6)) {
        *m_out = m;
        for (i = 0; i < 6; ++i)
            I6_out[i] = I6[i];
        *projected = 0;
        return 0;
    }
    *m_out = m >= m_min ? m : m_min;            /* m >= m_min: a half-line */
    sr_second_moment(I6, S);
    status = sr_eigh(S, 3, lam, V);
    s_min = sigma_floor(lam, rel_sigma_min);
    for (i = 0; i < 3; ++i)                     /* Sigma_c >= s_min 1: clip the eigenvalues */
        for (j = 0; j < 3; ++j) {
            double acc = 0.0;
            for (k = 0; k < 3; ++k)
                acc += V[3 * i + k] * (s_min > lam[k] ? s_min : lam[k]) * V[3 * j + k];
            S[3 * i + j] = acc;
        }
    for (i = 0; i < 3; ++i)                     /* 0.5 (S + S^T) */
        for (j = i + 1; j < 3; ++j)
            S[3 * i + j] = S[3 * j + i] = 0.5 * (S[3 * i + j] + S[3 * j + i]);
    tr = S[0] + S[4] + S[8];                    /* I_c = tr(S) 1 - S */
    I6_out[0] = tr - S[0];
    I6_out[1] = tr - S[4];
    I6_out[2] = tr - S[8];
    I6_out[3] = -S[1];
    I6_out[4] = -S[2];
    I6_out[5] = -S[5];
    *projected = 1;
    return status == 0 ? 0 : 1;
}

int sr_project_planar_body(double m, const double *b, const double *I6, double m_min,
                           double rel_sigma_min, double *m_out, double *I6_out, int *projected)
{
    double S[9], S2[4], lam[2], V[4], lam3[3], V3[9], P[9] = {0.0}, s_min, izz, tr;
    int i, j, ok2, ok3;
    if (sr_is_physical(m, b, I6)) {
        *m_out = m;
        for (i = 0; i < 6; ++i)
            I6_out[i] = I6[i];
        *projected = 0;
        return 0;
    }
    sr_second_moment(I6, S);
    S2[0] = S[0];
    S2[1] = S[1];
    S2[2] = S[3];
    S2[3] = S[4];
    ok2 = sr_eigh(S2, 2, lam, V) == 0;          /* the in-plane block */
    ok3 = sr_eigh(S, 3, lam3, V3) == 0;
    izz = I6[2];                                /* = trace of the in-plane block */
    s_min = sigma_floor(lam3, rel_sigma_min);
    if (!(izz > 2.0 * s_min))                   /* no real body keeps this Izz */
        return sr_project_body(m, b, I6, m_min, rel_sigma_min, m_out, I6_out, projected);
    if (lam[0] < s_min) {                       /* clip with the sum kept */
        lam[0] = s_min;
        lam[1] = izz - s_min;
    }
    for (i = 0; i < 2; ++i)
        for (j = 0; j < 2; ++j)
            P[3 * i + j] = V[2 * i + 0] * lam[0] * V[2 * j + 0]
                           + V[2 * i + 1] * lam[1] * V[2 * j + 1];
    P[8] = s_min > S[8] ? s_min : S[8];         /* Python's max(S_zz, s_min) */
    P[1] = P[3] = 0.5 * (P[1] + P[3]);
    tr = P[0] + P[4] + P[8];
    I6_out[0] = tr - P[0];
    I6_out[1] = tr - P[4];
    I6_out[2] = izz;                            /* exact, not re-rounded */
    I6_out[3] = -P[1];
    I6_out[4] = -P[2];
    I6_out[5] = -P[5];
    *m_out = m >= m_min ? m : m_min;
    *projected = 1;
    return (ok2 && ok3) ? 0 : 1;
}
