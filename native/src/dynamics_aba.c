/* Forward dynamics of the free-floating robot by the articulated-body algorithm (dynamics.h).
 *
 * ABA, RBDA Table 7.1:
 *   pass 1: v_i = v_p + S_i qd_i,  c_i = v_i x S_i qd_i,  IA_i = I_i,  pA_i = v_i x* I_i v_i;
 *   pass 2: U_i = IA_i S_i,  D_i = S_i^T U_i,  u_i = tau_i - S_i^T pA_i,
 *           Ia = IA_i - U_i D_i^-1 U_i^T,  pa = pA_i + Ia c_i + U_i D_i^-1 u_i,
 *           IA_p += Ia,  pA_p += pa   (moved to the parent's point);
 *   pass 3: a_i = a_p + c_i,  qdd_i = D_i^-1 (u_i - U_i^T a_i),  a_i += S_i qdd_i;
 * with the floating base of RBDA Chapter 9: the base is body 0 with a 6-dof joint whose motion
 * subspace is the identity (planar: the columns v_x, v_y, omega_z), no gravity, so its
 * acceleration solves IA_0 a_0 = f_0 - pA_0 (restricted to the base's generalised velocities),
 * f_0 the applied base force [A^T F; A^T M_S]; with the base's velocity in its own frame
 * (Pinocchio's free-flyer) the base joint has no bias term.
 *
 * Body k's quantities are in base axes at its joint's origin bp[k] (joint motion [0; s]; from
 * body to parent only the origin moves); a leaf's at the base origin S (its parent's), with
 * its joint motion S6 there, so that its articulated inertia and force add to the base's as
 * they are. Each body's inertia is turned into base axes once per
 * call. The running quantities of the serial chain (placement, velocity, articulated inertia
 * and force, acceleration) stay in local arrays; what a later pass reads is in data.
 */
#include <math.h>

#include "dynamics_internal.h"
#include "linalg.h"

/* X^T Ia X, an articulated inertia moved to the parent's origin by the pure translation
 * X = [[1, -P], [0, 1]], P = [d]x, d the child's origin seen from the parent's:
 * Ia = [[A, B], [B^T, C]] (A, C upper triangles, B 3 x 3) ->
 * [[A, B - A P], [(.)^T, C + P B + (P B)^T - P A P]] (in place) */
static void shift(const double *d, double *A, double *B, double *C)
{
    const double px = d[0], py = d[1], pz = d[2];
    const double a00 = A[0], a01 = A[1], a02 = A[2], a11 = A[3], a12 = A[4], a22 = A[5];
    double ap[9], pap00, pap01, pap02, pap11, pap12, pap22, pb[9];
    /* A P, P = [[0, -pz, py], [pz, 0, -px], [-py, px, 0]] */
    ap[0] = a01 * pz - a02 * py; ap[1] = a02 * px - a00 * pz; ap[2] = a00 * py - a01 * px;
    ap[3] = a11 * pz - a12 * py; ap[4] = a12 * px - a01 * pz; ap[5] = a01 * py - a11 * px;
    ap[6] = a12 * pz - a22 * py; ap[7] = a22 * px - a02 * pz; ap[8] = a02 * py - a12 * px;
    /* P (A P) */
    pap00 = -pz * ap[3] + py * ap[6];
    pap01 = -pz * ap[4] + py * ap[7];
    pap02 = -pz * ap[5] + py * ap[8];
    pap11 = pz * ap[1] - px * ap[7];
    pap12 = pz * ap[2] - px * ap[8];
    pap22 = -py * ap[2] + px * ap[5];
    /* P B */
    pb[0] = -pz * B[3] + py * B[6];
    pb[1] = -pz * B[4] + py * B[7];
    pb[2] = -pz * B[5] + py * B[8];
    pb[3] = pz * B[0] - px * B[6];
    pb[4] = pz * B[1] - px * B[7];
    pb[5] = pz * B[2] - px * B[8];
    pb[6] = -py * B[0] + px * B[3];
    pb[7] = -py * B[1] + px * B[4];
    pb[8] = -py * B[2] + px * B[5];
    B[0] -= ap[0]; B[1] -= ap[1]; B[2] -= ap[2];
    B[3] -= ap[3]; B[4] -= ap[4]; B[5] -= ap[5];
    B[6] -= ap[6]; B[7] -= ap[7]; B[8] -= ap[8];
    C[0] = C[0] + 2.0 * pb[0] - pap00;
    C[1] = C[1] + pb[1] + pb[3] - pap01;
    C[2] = C[2] + pb[2] + pb[6] - pap02;
    C[3] = C[3] + 2.0 * pb[4] - pap11;
    C[4] = C[4] + pb[5] + pb[7] - pap12;
    C[5] = C[5] + 2.0 * pb[8] - pap22;
}

/* the inverse (upper triangle o (6)) of the symmetric 3 x 3 matrix a (upper triangle a00 a01
 * a02 a11 a12 a22) by its cofactors (one division). Returns 0, or SR_DYN_EPD if a leading
 * minor is <= 0 (a is not positive definite; a NaN passes). */
static int spd3_inverse(const double *a, double *o)
{
    const double a00 = a[0], a01 = a[1], a02 = a[2], a11 = a[3], a12 = a[4], a22 = a[5];
    const double c00 = a11 * a22 - a12 * a12, c01 = a02 * a12 - a01 * a22,
                 c02 = a01 * a12 - a02 * a11, c11 = a00 * a22 - a02 * a02,
                 c12 = a01 * a02 - a00 * a12, c22 = a00 * a11 - a01 * a01;
    const double det = a00 * c00 + a01 * c01 + a02 * c02;
    double r;
    if (a00 <= 0.0 || c22 <= 0.0 || det <= 0.0)
        return SR_DYN_EPD;
    r = 1.0 / det;
    o[0] = c00 * r; o[1] = c01 * r; o[2] = c02 * r;
    o[3] = c11 * r; o[4] = c12 * r; o[5] = c22 * r;
    return SR_DYN_OK;
}

/* the free-flyer base's acceleration x (6) from IA0 x = fb - pA0 (IA0 6 x 6 symmetric) by
 * blocks, IA0 = [[A, B], [B^T, C]]: the Schur complement C - B^T A^-1 B, both 3 x 3 inverses
 * by cofactors (a short dependency chain: the ABA's critical path). Returns 0, or SR_DYN_EPD
 * if A or the Schur complement is not positive definite (IA0 is not; a NaN passes). */
static int base_solve6(double IA0[6][6], const double *pA0, const double *fb, double *x)
{
    const double a[6] = {IA0[0][0], IA0[0][1], IA0[0][2], IA0[1][1], IA0[1][2], IA0[2][2]};
    double ai[6], X[9], sc[6], si[6], y[3], rw[3], aw[3], b[6];
    int i, j;
    if (spd3_inverse(a, ai) != SR_DYN_OK)
        return SR_DYN_EPD;
    for (i = 0; i < 6; i++)
        b[i] = fb[i] - pA0[i];
    for (j = 0; j < 3; j++) {                /* X = A^-1 B */
        const double b0 = IA0[0][3 + j], b1 = IA0[1][3 + j], b2 = IA0[2][3 + j];
        X[j] = ai[0] * b0 + ai[1] * b1 + ai[2] * b2;
        X[3 + j] = ai[1] * b0 + ai[3] * b1 + ai[4] * b2;
        X[6 + j] = ai[2] * b0 + ai[4] * b1 + ai[5] * b2;
    }
    /* Schur complement C - B^T X (upper triangle), y = A^-1 b_l, rw = b_w - B^T y */
    sc[0] = IA0[3][3] - (IA0[0][3] * X[0] + IA0[1][3] * X[3] + IA0[2][3] * X[6]);
    sc[1] = IA0[3][4] - (IA0[0][3] * X[1] + IA0[1][3] * X[4] + IA0[2][3] * X[7]);
    sc[2] = IA0[3][5] - (IA0[0][3] * X[2] + IA0[1][3] * X[5] + IA0[2][3] * X[8]);
    sc[3] = IA0[4][4] - (IA0[0][4] * X[1] + IA0[1][4] * X[4] + IA0[2][4] * X[7]);
    sc[4] = IA0[4][5] - (IA0[0][4] * X[2] + IA0[1][4] * X[5] + IA0[2][4] * X[8]);
    sc[5] = IA0[5][5] - (IA0[0][5] * X[2] + IA0[1][5] * X[5] + IA0[2][5] * X[8]);
    y[0] = ai[0] * b[0] + ai[1] * b[1] + ai[2] * b[2];
    y[1] = ai[1] * b[0] + ai[3] * b[1] + ai[4] * b[2];
    y[2] = ai[2] * b[0] + ai[4] * b[1] + ai[5] * b[2];
    for (j = 0; j < 3; j++)
        rw[j] = b[3 + j] - (IA0[0][3 + j] * y[0] + IA0[1][3 + j] * y[1] + IA0[2][3 + j] * y[2]);
    if (spd3_inverse(sc, si) != SR_DYN_OK)
        return SR_DYN_EPD;
    aw[0] = si[0] * rw[0] + si[1] * rw[1] + si[2] * rw[2];
    aw[1] = si[1] * rw[0] + si[3] * rw[1] + si[4] * rw[2];
    aw[2] = si[2] * rw[0] + si[4] * rw[1] + si[5] * rw[2];
    for (i = 0; i < 3; i++) {                /* a_l = y - X a_w */
        x[i] = y[i] - (X[3 * i] * aw[0] + X[3 * i + 1] * aw[1] + X[3 * i + 2] * aw[2]);
        x[3 + i] = aw[i];
    }
    return SR_DYN_OK;
}

/* the base's acceleration of the ABA: x (nr) from (S^T IA0 S) x = fb - S^T pA0 (S the rows
 * base_row; nr = 3 planar, 6 free-flyer): base_solve6 for the free-flyer, else by sr_cholesky.
 * IA0 6 x 6. Returns 0, or SR_DYN_EPD if IA0 is not positive definite (a non-finite pivot
 * passes: x is then NaN, so that NaN propagates). */
static int base_solve(int planar, double IA0[6][6], const double *pA0, const double *fb,
                      double *x)
{
    double L[9];
    int i, j, st;
    if (!planar)
        return base_solve6(IA0, pA0, fb, x);
    for (i = 0; i < 3; i++) {
        const int ri = base_row(planar, i);
        x[i] = fb[i] - pA0[ri];
        for (j = 0; j < 3; j++)
            L[3 * i + j] = IA0[ri][base_row(planar, j)];
    }
    st = sr_cholesky(L, 3);
    if (st == 1)
        return SR_DYN_EPD;
    if (st == 2) {
        x[0] = x[1] = x[2] = NAN;
        return SR_DYN_OK;
    }
    sr_cholesky_solve(L, 3, x, 1);
    return SR_DYN_OK;
}

/* the leaves' pass 1 (j < nl, body k = n + 1 + j, at S): placement and inertia, v_k = v_0 +
 * S6 qd, c_k = v_k x S6 qd, pA_k = v_k x* (I_k v_k) */
static void leaves_pass1(const sr_dyn_model *md, sr_dyn_data *d, const double *sc,
                         const double *ql, const double *qd, const double *v0)
{
    int j, i;
    for (j = 0; j < md->nl; j++) {
        const int k = md->n + 1 + j, c = md->n + j;
        double *S6 = d->S[k], vk[6], z[6], y[6];
        leaf_place(md, j, ql[j], sc[2 * c], sc[2 * c + 1], d->g[k], d->J[k], d->bp[k], S6);
        for (i = 0; i < 6; i++) {
            z[i] = S6[i] * qd[c];
            vk[i] = v0[i] + z[i];
        }
        crm(vk, z, d->cb[k]);
        rbi_mul(md->m[k], d->g[k], d->J[k], vk, y);
        crf(vk, y, d->pA[k]);
    }
}

/* the leaves' pass 2 folded into the base's articulated inertia IB (6 x 6) and bias force
 * pA0: U = I S6, D = S6^T U, u = tau - S6^T pA, uc = u - U^T c;
 * IB += I - U U^T / D, pA0 += pA + I c + U uc / D (RBDA Table 7.1 at the parent's point) */
static void leaves_pass2(const sr_dyn_model *md, sr_dyn_data *d, const double *tau,
                         double IB[6][6], double *pA0)
{
    int j, r, c;
    for (j = 0; j < md->nl; j++) {
        const int k = md->n + 1 + j;
        const double m = md->m[k], *g = d->g[k], *J = d->J[k], *S6 = d->S[k], *cb = d->cb[k];
        const double *pA = d->pA[k];
        double I6[6][6], *U = d->U[k], Ic[6], D = 0.0, u = tau[md->n + j], uc, rD;
        rbi_full(m, g, J, I6);
        rbi_mul(m, g, J, S6, U);
        rbi_mul(m, g, J, cb, Ic);
        for (r = 0; r < 6; r++) {
            D += S6[r] * U[r];
            u -= S6[r] * pA[r];
        }
        uc = u;
        for (r = 0; r < 6; r++)
            uc -= U[r] * cb[r];
        rD = 1.0 / D;
        d->Du[k][0] = rD;
        d->Du[k][1] = uc;
        for (r = 0; r < 6; r++) {
            for (c = 0; c < 6; c++)
                IB[r][c] += I6[r][c] - U[r] * U[c] * rD;
            pA0[r] += pA[r] + Ic[r] + U[r] * (uc * rD);
        }
    }
}

/* Articulated-body algorithm (RBDA Table 7.1 with the floating base of Chapter 9).
 * sc ((n + nl) x 2): the sines and cosines of the arm's angles (and the leaves'); ql: the
 * leaves' coordinates; qd, tau: the rates and torques (generalised forces) of the arm and the
 * leaves (n + nl); vb, fb: the base's generalised velocity and force (nr = 3 planar, 6
 * spatial); out: ab (nr) the base's generalised acceleration, qdd (n + nl). */
int dyn_aba_core(const sr_dyn_model *md, sr_dyn_data *d, const double *sc, const double *ql,
                 const double *qd, const double *tau, const double *vb, const double *fb,
                 double *ab, double *qdd)
{
    const int nb = md->n + 1;
    double v[6], hb[6], E[2][9], o[3], x[6];
    double A[6], B[9], C[6], f[6], IB[6][6];
    int k, i, j, cur = 0;
    /* pass 1 (base to tip): v_k = shift(v_p) + [0; s qd], c_k = v_k x [0; s qd], the body's
     * inertia in base axes, pA_k = v_k x* (I_k v_k); the base: pA_0 = v_0 x* (I_0 v_0) */
    base_motion(md, d, vb, v, hb);
    leaves_pass1(md, d, sc, ql, qd, v);
    for (i = 0; i < 9; i++)
        E[0][i] = (i % 4 == 0) ? 1.0 : 0.0;
    o[0] = o[1] = o[2] = 0.0;
    d->bp[0][0] = d->bp[0][1] = d->bp[0][2] = 0.0;
    for (k = 1; k < nb; k++) {
        double *bp = d->bp[k], *s = d->S[k] + 3, *cb = d->cb[k], *pA = d->pA[k];
        double dl[3], z[3], fl[3], fn[3], m;
        const double *g = d->g[k], *J = d->J[k];
        place(md, k, sc[2 * k - 2], sc[2 * k - 1], E[cur], o, E[1 - cur], bp, s);
        cur = 1 - cur;
        dl[0] = bp[0] - o[0];
        dl[1] = bp[1] - o[1];
        dl[2] = bp[2] - o[2];
        o[0] = bp[0];
        o[1] = bp[1];
        o[2] = bp[2];
        /* linear velocity at the new origin: v_l + w x d */
        v[0] = v[0] + (v[4] * dl[2] - v[5] * dl[1]);
        v[1] = v[1] + (v[5] * dl[0] - v[3] * dl[2]);
        v[2] = v[2] + (v[3] * dl[1] - v[4] * dl[0]);
        z[0] = s[0] * qd[k - 1];
        z[1] = s[1] * qd[k - 1];
        z[2] = s[2] * qd[k - 1];
        cb[0] = v[1] * z[2] - v[2] * z[1];            /* c_k = v_k x [0; z] */
        cb[1] = v[2] * z[0] - v[0] * z[2];
        cb[2] = v[0] * z[1] - v[1] * z[0];
        cb[3] = v[4] * z[2] - v[5] * z[1];
        cb[4] = v[5] * z[0] - v[3] * z[2];
        cb[5] = v[3] * z[1] - v[4] * z[0];
        v[3] += z[0];
        v[4] += z[1];
        v[5] += z[2];
        /* body inertia in base axes: h' = bR_k h, I_o' = bR_k I_o bR_k^T */
        {
            const double *Ek = E[cur], *h = md->h[k];
            double *gk = d->g[k];
            gk[0] = Ek[0] * h[0] + Ek[1] * h[1] + Ek[2] * h[2];
            gk[1] = Ek[3] * h[0] + Ek[4] * h[1] + Ek[5] * h[2];
            gk[2] = Ek[6] * h[0] + Ek[7] * h[1] + Ek[8] * h[2];
            rot_sym(Ek, md->J[k], d->J[k]);
        }
        /* pA_k = v_k x* (I_k v_k), I_k v_k = [m v_l + w x h; h x v_l + I_o w] */
        m = md->m[k];
        fl[0] = m * v[0] + (v[4] * g[2] - v[5] * g[1]);
        fl[1] = m * v[1] + (v[5] * g[0] - v[3] * g[2]);
        fl[2] = m * v[2] + (v[3] * g[1] - v[4] * g[0]);
        fn[0] = (g[1] * v[2] - g[2] * v[1]) + (J[0] * v[3] + J[1] * v[4] + J[2] * v[5]);
        fn[1] = (g[2] * v[0] - g[0] * v[2]) + (J[1] * v[3] + J[3] * v[4] + J[4] * v[5]);
        fn[2] = (g[0] * v[1] - g[1] * v[0]) + (J[2] * v[3] + J[4] * v[4] + J[5] * v[5]);
        pA[0] = v[4] * fl[2] - v[5] * fl[1];           /* [w x f_l; w x f_n + v_l x f_l] */
        pA[1] = v[5] * fl[0] - v[3] * fl[2];
        pA[2] = v[3] * fl[1] - v[4] * fl[0];
        pA[3] = v[4] * fn[2] - v[5] * fn[1] + v[1] * fl[2] - v[2] * fl[1];
        pA[4] = v[5] * fn[0] - v[3] * fn[2] + v[2] * fl[0] - v[0] * fl[2];
        pA[5] = v[3] * fn[1] - v[4] * fn[0] + v[0] * fl[1] - v[1] * fl[0];
    }
    /* pass 2 (tip to base): IA_k = I_k + (the child's articulated inertia moved here),
     * U = IA S, D = S^T U, u = tau - S^T pA; Ia = IA - U U^T / D, pa = pA + Ia c + U u / D
     * to the parent. IA = [[A, B], [B^T, C]]; f the child's force moved here. */
    for (i = 0; i < 6; i++)
        A[i] = C[i] = f[i] = 0.0;
    for (i = 0; i < 9; i++)
        B[i] = 0.0;
    for (k = nb - 1; k > 0; k--) {
        const double m = md->m[k], *h = d->g[k], *J = d->J[k], *s = d->S[k] + 3;
        const double *x0 = d->cb[k];
        double P[6], U[6], pa[6], y[6], D, u, uc, rD, gg, dl[3];
        double *Ut = d->U[k];
        A[0] += m; A[3] += m; A[5] += m;
        B[1] += h[2]; B[2] -= h[1]; B[3] -= h[2];        /* -[h]x */
        B[5] += h[0]; B[6] += h[1]; B[7] -= h[0];
        C[0] += J[0]; C[1] += J[1]; C[2] += J[2];
        C[3] += J[3]; C[4] += J[4]; C[5] += J[5];
        P[0] = d->pA[k][0] + f[0];
        P[1] = d->pA[k][1] + f[1];
        P[2] = d->pA[k][2] + f[2];
        P[3] = d->pA[k][3] + f[3];
        P[4] = d->pA[k][4] + f[4];
        P[5] = d->pA[k][5] + f[5];
        U[0] = B[0] * s[0] + B[1] * s[1] + B[2] * s[2];
        U[1] = B[3] * s[0] + B[4] * s[1] + B[5] * s[2];
        U[2] = B[6] * s[0] + B[7] * s[1] + B[8] * s[2];
        U[3] = C[0] * s[0] + C[1] * s[1] + C[2] * s[2];
        U[4] = C[1] * s[0] + C[3] * s[1] + C[4] * s[2];
        U[5] = C[2] * s[0] + C[4] * s[1] + C[5] * s[2];
        D = U[3] * s[0] + U[4] * s[1] + U[5] * s[2];
        u = tau[k - 1] - (P[3] * s[0] + P[4] * s[1] + P[5] * s[2]);
        rD = 1.0 / D;                                    /* one division per joint */
        dl[0] = d->bp[k][0] - d->bp[k - 1][0];
        dl[1] = d->bp[k][1] - d->bp[k - 1][1];
        dl[2] = d->bp[k][2] - d->bp[k - 1][2];
        /* for pass 3: U moved to the parent's origin, Ut = [U_l; U_n + d x U_l] (so that
         * Ut^T a_p = U^T (a_p moved here)), and uc = u - U^T c */
        Ut[0] = U[0];
        Ut[1] = U[1];
        Ut[2] = U[2];
        Ut[3] = U[3] + (dl[1] * U[2] - dl[2] * U[1]);
        Ut[4] = U[4] + (dl[2] * U[0] - dl[0] * U[2]);
        Ut[5] = U[5] + (dl[0] * U[1] - dl[1] * U[0]);
        uc = u - (U[0] * x0[0] + U[1] * x0[1] + U[2] * x0[2] + U[3] * x0[3] + U[4] * x0[4]
                  + U[5] * x0[5]);
        d->Du[k][0] = rD;
        d->Du[k][1] = uc;
        /* pa = pA + IA c + U (u - U^T c) / D */
        gg = uc * rD;
        pa[0] = P[0] + U[0] * gg + A[0] * x0[0] + A[1] * x0[1] + A[2] * x0[2] + B[0] * x0[3]
                + B[1] * x0[4] + B[2] * x0[5];
        pa[1] = P[1] + U[1] * gg + A[1] * x0[0] + A[3] * x0[1] + A[4] * x0[2] + B[3] * x0[3]
                + B[4] * x0[4] + B[5] * x0[5];
        pa[2] = P[2] + U[2] * gg + A[2] * x0[0] + A[4] * x0[1] + A[5] * x0[2] + B[6] * x0[3]
                + B[7] * x0[4] + B[8] * x0[5];
        pa[3] = P[3] + U[3] * gg + B[0] * x0[0] + B[3] * x0[1] + B[6] * x0[2] + C[0] * x0[3]
                + C[1] * x0[4] + C[2] * x0[5];
        pa[4] = P[4] + U[4] * gg + B[1] * x0[0] + B[4] * x0[1] + B[7] * x0[2] + C[1] * x0[3]
                + C[3] * x0[4] + C[4] * x0[5];
        pa[5] = P[5] + U[5] * gg + B[2] * x0[0] + B[5] * x0[1] + B[8] * x0[2] + C[2] * x0[3]
                + C[4] * x0[4] + C[5] * x0[5];
        /* Ia = IA - U U^T / D, then to the parent's origin */
        y[0] = U[0] * rD; y[1] = U[1] * rD; y[2] = U[2] * rD;
        y[3] = U[3] * rD; y[4] = U[4] * rD; y[5] = U[5] * rD;
        A[0] = A[0] - y[0] * U[0]; A[1] = A[1] - y[0] * U[1]; A[2] = A[2] - y[0] * U[2];
        A[3] = A[3] - y[1] * U[1]; A[4] = A[4] - y[1] * U[2]; A[5] = A[5] - y[2] * U[2];
        B[0] = B[0] - y[0] * U[3]; B[1] = B[1] - y[0] * U[4]; B[2] = B[2] - y[0] * U[5];
        B[3] = B[3] - y[1] * U[3]; B[4] = B[4] - y[1] * U[4]; B[5] = B[5] - y[1] * U[5];
        B[6] = B[6] - y[2] * U[3]; B[7] = B[7] - y[2] * U[4]; B[8] = B[8] - y[2] * U[5];
        C[0] = C[0] - y[3] * U[3]; C[1] = C[1] - y[3] * U[4]; C[2] = C[2] - y[3] * U[5];
        C[3] = C[3] - y[4] * U[4]; C[4] = C[4] - y[4] * U[5]; C[5] = C[5] - y[5] * U[5];
        shift(dl, A, B, C);
        /* force to the parent's origin: f_l, f_n + d x f_l */
        f[0] = pa[0];
        f[1] = pa[1];
        f[2] = pa[2];
        f[3] = pa[3] + (dl[1] * pa[2] - dl[2] * pa[1]);
        f[4] = pa[4] + (dl[2] * pa[0] - dl[0] * pa[2]);
        f[5] = pa[5] + (dl[0] * pa[1] - dl[1] * pa[0]);
    }
    /* the base: IA_0 = I_0 + the chain's, pA_0 += f; (S^T IA_0 S) a_0 = f_0 - S^T pA_0 */
    {
        const double m0 = md->m[0], *h = md->h[0], *J = md->J[0];
        const int up[3][3] = {{0, 1, 2}, {1, 3, 4}, {2, 4, 5}};
        const double hx[9] = {0.0, -h[2], h[1], h[2], 0.0, -h[0], -h[1], h[0], 0.0};
        for (i = 0; i < 3; i++)
            for (j = 0; j < 3; j++) {
                IB[i][j] = ((i == j) ? m0 : 0.0) + A[up[i][j]];
                IB[i][3 + j] = -hx[3 * i + j] + B[3 * i + j];
                IB[3 + j][i] = hx[3 * j + i] + B[3 * i + j];
                IB[3 + i][3 + j] = J[up[i][j]] + C[up[i][j]];
            }
        for (i = 0; i < 6; i++)
            d->pA[0][i] += f[i];
    }
    leaves_pass2(md, d, tau, IB, d->pA[0]);
    if (base_solve(md->planar, IB, d->pA[0], fb, ab) != SR_DYN_OK)
        return SR_DYN_EPD;
    /* pass 3 (base to tip): a = shift(a_p) + c_k, qdd_k = (u_k - U_k^T a) / D_k,
     * a_k = a + S qdd; with pass 2's uc_k = u_k - U_k^T c_k and Ut_k (U_k moved to the
     * parent's origin): qdd_k = (uc_k - Ut_k^T a_p) / D_k, off the chain of a's updates */
    for (i = 0; i < 6; i++)
        x[i] = 0.0;
    for (i = 0; i < (md->planar ? 3 : 6); i++)
        x[base_row(md->planar, i)] = ab[i];
    for (j = 0; j < md->nl; j++) {          /* the leaves: qdd = (uc - U^T a_0) / D */
        const double *Du = d->Du[nb + j], *U = d->U[nb + j];
        double s = Du[1];
        for (i = 0; i < 6; i++)
            s -= U[i] * x[i];
        qdd[md->n + j] = s * Du[0];
    }
    for (k = 1; k < nb; k++) {
        const double *cb = d->cb[k], *Ut = d->U[k], *s = d->S[k] + 3;
        double dl[3], t0, t1, t2, sc, a;
        sc = d->Du[k][1] - ((Ut[0] * x[0] + Ut[1] * x[1]) + (Ut[2] * x[2] + Ut[3] * x[3])
                            + (Ut[4] * x[4] + Ut[5] * x[5]));
        a = sc * d->Du[k][0];
        dl[0] = d->bp[k][0] - d->bp[k - 1][0];
        dl[1] = d->bp[k][1] - d->bp[k - 1][1];
        dl[2] = d->bp[k][2] - d->bp[k - 1][2];
        t0 = x[0] + (x[4] * dl[2] - x[5] * dl[1]) + cb[0];
        t1 = x[1] + (x[5] * dl[0] - x[3] * dl[2]) + cb[1];
        t2 = x[2] + (x[3] * dl[1] - x[4] * dl[0]) + cb[2];
        x[0] = t0;
        x[1] = t1;
        x[2] = t2;
        x[3] = x[3] + cb[3];
        x[4] = x[4] + cb[4];
        x[5] = x[5] + cb[5];
        qdd[k - 1] = a;
        x[3] = x[3] + s[0] * a;
        x[4] = x[4] + s[1] * a;
        x[5] = x[5] + s[2] * a;
    }
    return SR_DYN_OK;
}

SR_API int sr_dyn_aba(const sr_dyn_model *model, sr_dyn_data *data, const double *q,
                      const double *v, const double *tau, double *ddq)
{
    double sc[2 * SR_DYN_MAX_COORDS];
    if (!dyn_model_ok(model) || q == NULL)
        return SR_DYN_EARG;
    dyn_arm_sincos(model, q + (model->planar ? 4 : 7), sc);
    return sr_dyn_aba_sc(model, data, q, v, tau, sc, ddq);
}

SR_API int sr_dyn_aba_sc(const sr_dyn_model *model, sr_dyn_data *data, const double *q,
                         const double *v, const double *tau, const double *sc, double *ddq)
{
    int nr;
    if (!dyn_model_ok(model) || data == NULL || q == NULL || v == NULL || tau == NULL || sc == NULL
        || ddq == NULL)
        return SR_DYN_EARG;
    nr = model->planar ? 3 : 6;
    return dyn_aba_core(model, data, sc, q + (model->planar ? 4 : 7) + model->n, v + nr,
                        tau + nr, v, tau, ddq, ddq + nr);
}
