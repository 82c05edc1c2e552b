/* Rigid-body dynamics of the free-floating robot: a port of the former spacerobot/plant/rigid_body.py
 * (aba, terms) with the same order of operations, so that the C plant reproduced the former Numba one
 * to rounding. Conventions in dynamics.h.
 *
 * Source of the equations: R. Featherstone, Rigid Body Dynamics Algorithms (RBDA), Springer
 * 2008, in Pinocchio's conventions (spatial motion and force [linear; angular]):
 *   - recursive Newton-Euler algorithm (RNEA), RBDA Table 5.1:
 *       v_i = v_p + S_i qd_i,  a_i = a_p + S_i qdd_i + v_i x S_i qd_i,
 *       f_i = I_i a_i + v_i x* I_i v_i,  tau_i = S_i^T f_i,  f_p += f_i;
 *   - composite-rigid-body algorithm (CRBA), RBDA Table 6.2:
 *       Ic_i = I_i + sum of the children's Ic,  F = Ic_i S_i,  H_ji = S_j^T F (j ancestors of i);
 *   - articulated-body algorithm (ABA), RBDA Table 7.1:
 *       pass 1: v_i = v_p + S_i qd_i,  c_i = v_i x S_i qd_i,  IA_i = I_i,  pA_i = v_i x* I_i v_i;
 *       pass 2: U_i = IA_i S_i,  D_i = S_i^T U_i,  u_i = tau_i - S_i^T pA_i,
 *               Ia = IA_i - U_i D_i^-1 U_i^T,  pa = pA_i + Ia c_i + U_i D_i^-1 u_i,
 *               IA_p += Ia,  pA_p += pa   (moved to the parent's point);
 *       pass 3: a_i = a_p + c_i,  qdd_i = D_i^-1 (u_i - U_i^T a_i),  a_i += S_i qdd_i;
 *   - floating base, RBDA Chapter 9 (floating bases): the base is body 0 with a 6-dof
 *     joint whose motion subspace is the identity (planar: the columns v_x, v_y, omega_z), no
 *     gravity, so its acceleration solves IA_0 a_0 = f_0 - pA_0 (restricted to the base's
 *     generalised velocities), f_0 the applied base force [A^T F; A^T M_S]; with the base's
 *     velocity in its own frame (Pinocchio's free-flyer) the base joint has no bias term.
 *
 * Frames: without gravity the dynamics do not depend on the base's pose, so every algorithm
 * works in the base frame (the inertial frame that coincides with the base's body frame at the
 * instant considered): there the base's generalised velocity and acceleration are its spatial
 * velocity and acceleration. The ABA expresses body k's quantities in base axes at its joint's
 * origin bp[k] (joint motion [0; s]; from body to parent only the origin moves); the CRBA/RNEA
 * (terms) express everything at the base origin S. Each body's inertia is turned into base axes
 * once per call. The running quantities of the serial chain (placement, velocity, articulated
 * inertia and force, acceleration) stay in local arrays; what a later pass reads is in data.
 */
#include "dynamics.h"

#include <math.h>
#include <string.h>

#include "sr_math.h"
#include "vec3.h"

/* -- small helpers ------------------------------------------------------------------------ */


static int model_ok(const sr_dyn_model *md)
{
    return md != NULL && md->n >= 1 && md->n <= SR_MAX_JOINTS && (md->planar == 0 || md->planar == 1)
        && md->nv == (md->planar ? 3 : 6) + md->n && md->nq == (md->planar ? 4 : 7) + md->n;
}

/* row of the base spatial velocity [v; omega] that is the base's generalised velocity i:
 * all six for the free-flyer, rows 0, 1, 5 (v_x, v_y, omega_z) planar */
static int base_row(int planar, int i)
{
    return (planar && i == 2) ? 5 : i;
}

/* upper triangle of Rk A Rk^T, A symmetric by its upper triangle a = (a00 a01 a02 a11 a12 a22) */
static void rot_sym(const double *r, const double *a, double *o)
{
    const double a0 = a[0], a1 = a[1], a2 = a[2], a3 = a[3], a4 = a[4], a5 = a[5];
    double w[9];
    /* W = Rk A (written out: the loops of 3 unrolled, values kept in registers) */
    w[0] = r[0] * a0 + r[1] * a1 + r[2] * a2;
    w[1] = r[0] * a1 + r[1] * a3 + r[2] * a4;
    w[2] = r[0] * a2 + r[1] * a4 + r[2] * a5;
    w[3] = r[3] * a0 + r[4] * a1 + r[5] * a2;
    w[4] = r[3] * a1 + r[4] * a3 + r[5] * a4;
    w[5] = r[3] * a2 + r[4] * a4 + r[5] * a5;
    w[6] = r[6] * a0 + r[7] * a1 + r[8] * a2;
    w[7] = r[6] * a1 + r[7] * a3 + r[8] * a4;
    w[8] = r[6] * a2 + r[7] * a4 + r[8] * a5;
    /* (W Rk^T)_ij = W_i . Rk_j */
    o[0] = w[0] * r[0] + w[1] * r[1] + w[2] * r[2];
    o[1] = w[0] * r[3] + w[1] * r[4] + w[2] * r[5];
    o[2] = w[0] * r[6] + w[1] * r[7] + w[2] * r[8];
    o[3] = w[3] * r[3] + w[4] * r[4] + w[5] * r[5];
    o[4] = w[3] * r[6] + w[4] * r[7] + w[5] * r[8];
    o[5] = w[6] * r[6] + w[7] * r[7] + w[8] * r[8];
}

/* the sines and cosines of the arm's joint angles qa (n): sc (n x 2) = (sin, cos) rows */
static void arm_sincos(const sr_dyn_model *md, const double *qa, double *sc)
{
    int k;
    for (k = 0; k < md->n; k++)
        sr_sincos(qa[k], &sc[2 * k], &sc[2 * k + 1]);   /* portable: the same bits everywhere */
}

/* placement of body k (joint angle th, sn = sin th, cs = cos th) in the base frame from its
 * parent's (Ep 3 x 3, op): the joint frame sits at x_parent = R[k] Rz(th) x_k + p[k], so
 * Ek = Ep R[k] Rz(th), ok = op + Ep p[k]; the joint axis in the base frame s is the third
 * column of Ep R[k]. Ek must not alias Ep. */
static void place(const sr_dyn_model *md, int k, double sn, double cs, const double *Ep,
                  const double *op, double *Ek, double *ok, double *s)
{
    const double *q = md->R[k], *p = md->p[k];
    const double q0 = q[0], q1 = q[1], q2 = q[2], q3 = q[3], q4 = q[4], q5 = q[5], q6 = q[6],
                 q7 = q[7], q8 = q[8], p0 = p[0], p1 = p[1], p2 = p[2];
    int i;
    for (i = 0; i < 9; i += 3) {           /* row i/3 of Ep (unrolled by the compiler or not:
                                            * the same operations) */
        const double b0 = Ep[i], b1 = Ep[i + 1], b2 = Ep[i + 2];
        const double a0 = b0 * q0 + b1 * q3 + b2 * q6;           /* (Ep R[k]) row */
        const double a1 = b0 * q1 + b1 * q4 + b2 * q7;
        const double a2 = b0 * q2 + b1 * q5 + b2 * q8;
        Ek[i] = a0 * cs + a1 * sn;                               /* columns 0, 1 turned */
        Ek[i + 1] = a1 * cs - a0 * sn;
        Ek[i + 2] = a2;                                           /* column 2: the axis */
        ok[i / 3] = op[i / 3] + (b0 * p0 + b1 * p1 + b2 * p2);
        s[i / 3] = a2;
    }
}

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

/* I v for the rigid-body inertia I = [[m 1, -[g]x], [[g]x, J]] (g the first moment, J by its
 * upper triangle) and the motion v = [v_l; w]: [m v_l - g x w; g x v_l + J w] */
static void rbi_mul(double m, const double *g, const double *J, const double *v, double *o)
{
    const double vl0 = v[0], vl1 = v[1], vl2 = v[2], w0 = v[3], w1 = v[4], w2 = v[5];
    o[0] = m * vl0 - (g[1] * w2 - g[2] * w1);
    o[1] = m * vl1 - (g[2] * w0 - g[0] * w2);
    o[2] = m * vl2 - (g[0] * w1 - g[1] * w0);
    o[3] = (g[1] * vl2 - g[2] * vl1) + (J[0] * w0 + J[1] * w1 + J[2] * w2);
    o[4] = (g[2] * vl0 - g[0] * vl2) + (J[1] * w0 + J[3] * w1 + J[4] * w2);
    o[5] = (g[0] * vl1 - g[1] * vl0) + (J[2] * w0 + J[4] * w1 + J[5] * w2);
}

/* force cross product v x* f = [w x f_l; w x f_n + v_l x f_l] */
static void crf(const double *v, const double *f, double *o)
{
    const double vl0 = v[0], vl1 = v[1], vl2 = v[2], w0 = v[3], w1 = v[4], w2 = v[5];
    o[0] = w1 * f[2] - w2 * f[1];
    o[1] = w2 * f[0] - w0 * f[2];
    o[2] = w0 * f[1] - w1 * f[0];
    o[3] = w1 * f[5] - w2 * f[4] + vl1 * f[2] - vl2 * f[1];
    o[4] = w2 * f[3] - w0 * f[5] + vl2 * f[0] - vl0 * f[2];
    o[5] = w0 * f[4] - w1 * f[3] + vl0 * f[1] - vl1 * f[0];
}

/* the base's velocity v0 (6) from its generalised velocity vb (planar: v_x, v_y, w_z), its
 * momentum I_0 v0 into h (6) and its bias force pA[0] = v0 x* (I_0 v0) */
static void base_motion(const sr_dyn_model *md, sr_dyn_data *d, const double *vb, double *v0,
                        double *h)
{
    int i;
    for (i = 0; i < 6; i++)
        v0[i] = 0.0;
    for (i = 0; i < (md->planar ? 3 : 6); i++)
        v0[base_row(md->planar, i)] = vb[i];
    rbi_mul(md->m[0], md->h[0], md->J[0], v0, h);
    crf(v0, h, d->pA[0]);
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
 * base_row; nr = 3 planar, 6 free-flyer): base_solve6 for the free-flyer, else by L D L^T
 * (no square roots; one division per pivot). IA0 6 x 6. Returns 0, or SR_DYN_EPD if IA0 is
 * not positive definite (a pivot <= 0; a NaN passes). */
static int base_solve(int planar, double IA0[6][6], const double *pA0, const double *fb,
                      double *x)
{
    const int nr = planar ? 3 : 6;
    double L[6][6], dd[6], w[6];
    int i, j, p;
    if (!planar)
        return base_solve6(IA0, pA0, fb, x);
    for (i = 0; i < nr; i++) {
        const int ri = base_row(planar, i);
        x[i] = fb[i] - pA0[ri];
        for (j = 0; j <= i; j++)
            L[i][j] = IA0[ri][base_row(planar, j)];
    }
    for (j = 0; j < nr; j++) {
        /* w_p = L_jp d_p;  d_j = A_jj - sum_p L_jp w_p;  L_ij = (A_ij - sum_p L_ip w_p) / d_j */
        double dj = L[j][j], r;
        for (p = 0; p < j; p++) {
            w[p] = L[j][p] * dd[p];
            dj -= L[j][p] * w[p];
        }
        if (dj <= 0.0)
            return SR_DYN_EPD;
        dd[j] = dj;
        r = 1.0 / dj;
        L[j][j] = r;                       /* the diagonal is not read again: 1 / d_j */
        for (i = j + 1; i < nr; i++) {
            double s = L[i][j];
            for (p = 0; p < j; p++)
                s -= L[i][p] * w[p];
            L[i][j] = s * r;
        }
    }
    for (i = 0; i < nr; i++) {             /* L z = b */
        double s = x[i];
        for (p = 0; p < i; p++)
            s -= L[i][p] * x[p];
        x[i] = s;
    }
    for (i = 0; i < nr; i++)               /* D y = z */
        x[i] *= L[i][i];
    for (i = nr - 1; i >= 0; i--) {        /* L^T x = y */
        double s = x[i];
        for (p = i + 1; p < nr; p++)
            s -= L[p][i] * x[p];
        x[i] = s;
    }
    return SR_DYN_OK;
}

/* -- the algorithms on the base-frame state ---------------------------------------------- */

/* Articulated-body algorithm (RBDA Table 7.1 with the floating base of Chapter 9).
 * sc (n x 2): the sines and cosines of the arm's angles; qd, tau: its rates and torques (n);
 * vb, fb: the base's generalised
 * velocity and force (nr = 3 planar, 6 spatial); out: ab (nr) the base's generalised
 * acceleration, qdd (n). */
static int aba_core(const sr_dyn_model *md, sr_dyn_data *d, const double *sc, const double *qd,
                    const double *tau, const double *vb, const double *fb, double *ab,
                    double *qdd)
{
    const int nb = md->n + 1;
    double v[6], hb[6], E[2][9], o[3], x[6];
    double A[6], B[9], C[6], f[6], IB[6][6];
    int k, i, j, cur = 0;
    /* pass 1 (base to tip): v_k = shift(v_p) + [0; s qd], c_k = v_k x [0; s qd], the body's
     * inertia in base axes, pA_k = v_k x* (I_k v_k); the base: pA_0 = v_0 x* (I_0 v_0) */
    base_motion(md, d, vb, v, hb);
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
    if (base_solve(md->planar, IB, d->pA[0], fb, ab) != SR_DYN_OK)
        return SR_DYN_EPD;
    /* pass 3 (base to tip): a = shift(a_p) + c_k, qdd_k = (u_k - U_k^T a) / D_k,
     * a_k = a + S qdd; with pass 2's uc_k = u_k - U_k^T c_k and Ut_k (U_k moved to the
     * parent's origin): qdd_k = (uc_k - Ut_k^T a_p) / D_k, off the chain of a's updates */
    for (i = 0; i < 6; i++)
        x[i] = 0.0;
    for (i = 0; i < (md->planar ? 3 : 6); i++)
        x[base_row(md->planar, i)] = ab[i];
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

/* CRBA (RBDA Table 6.2), RNEA at zero acceleration (Table 5.1) and the momentum, all in base
 * axes at the base origin S, sc (n x 2) the sines and cosines of the arm's angles. Writes
 * M (nv x nv, both triangles) and nle (nv) when not NULL, and always hm (6) = the system
 * momentum [h_l; h_n about S] and gm (4) = [total mass, first moment about S (3)], base
 * axes. */
static void terms_core(const sr_dyn_model *md, sr_dyn_data *d, const double *sc,
                       const double *qd, const double *vb, double *M, double *nle, double *hm,
                       double *gm)
{
    const int nb = md->n + 1, planar = md->planar;
    const int nr = planar ? 3 : 6, nv = md->nv;
    double v[6], a[6], E[2][9], o[3], mt, g[3], J[6], f[6], F[6];
    int k, i, j, cur = 0;
    /* RNEA, forward: v_k = v_p + S qd, a_k = a_p + c_k (a_0 = 0), c_k = v_k x (S qd);
     * f_k = I a_k + v x* (I v); momentum h = sum I v */
    base_motion(md, d, vb, v, hm);
    for (i = 0; i < 6; i++)
        a[i] = 0.0;
    for (i = 0; i < 9; i++)
        E[0][i] = (i % 4 == 0) ? 1.0 : 0.0;
    o[0] = o[1] = o[2] = 0.0;
    for (k = 1; k < nb; k++) {
        double *S = d->S[k], *gk = d->g[k], *Jk = d->J[k], on[3], s[3], z, hh[3], io[6];
        double mo[3], dd, yv[6], fa[6], cv[6];
        const double m = md->m[k], *h = md->h[k];
        place(md, k, sc[2 * k - 2], sc[2 * k - 1], E[cur], o, E[1 - cur], on, s);
        cur = 1 - cur;
        o[0] = on[0];
        o[1] = on[1];
        o[2] = on[2];
        S[0] = o[1] * s[2] - o[2] * s[1];
        S[1] = o[2] * s[0] - o[0] * s[2];
        S[2] = o[0] * s[1] - o[1] * s[0];
        S[3] = s[0];
        S[4] = s[1];
        S[5] = s[2];
        /* velocity v_k = v_p + S qd; c_k = v_k x (S qd) = [w x sl + vl x sw; w x sw] qd */
        z = qd[k - 1];
        for (i = 0; i < 6; i++)
            v[i] = v[i] + S[i] * z;
        a[0] += (v[4] * S[2] - v[5] * S[1] + v[1] * S[5] - v[2] * S[4]) * z;
        a[1] += (v[5] * S[0] - v[3] * S[2] + v[2] * S[3] - v[0] * S[5]) * z;
        a[2] += (v[3] * S[1] - v[4] * S[0] + v[0] * S[4] - v[1] * S[3]) * z;
        a[3] += (v[4] * S[5] - v[5] * S[4]) * z;
        a[4] += (v[5] * S[3] - v[3] * S[5]) * z;
        a[5] += (v[3] * S[4] - v[4] * S[3]) * z;
        /* inertia at the base origin: h' = bR_k h, I_o' = bR_k I_o bR_k^T, then moved by o:
         * g = h' + m o, J = I_o' + (2 o.h' + m |o|^2) 1 - (h' o^T + o h'^T + m o o^T) */
        {
            const double *Ek = E[cur];
            for (i = 0; i < 3; i++)
                hh[i] = Ek[3 * i] * h[0] + Ek[3 * i + 1] * h[1] + Ek[3 * i + 2] * h[2];
            rot_sym(Ek, md->J[k], io);
        }
        for (i = 0; i < 3; i++)
            mo[i] = m * o[i];
        dd = 2.0 * (o[0] * hh[0] + o[1] * hh[1] + o[2] * hh[2])
             + (mo[0] * o[0] + mo[1] * o[1] + mo[2] * o[2]);
        for (i = 0; i < 3; i++)
            gk[i] = hh[i] + mo[i];       /* h' o^T + o h'^T + m o o^T = g o^T + o h'^T */
        Jk[0] = io[0] + dd - (gk[0] * o[0] + o[0] * hh[0]);
        Jk[3] = io[3] + dd - (gk[1] * o[1] + o[1] * hh[1]);
        Jk[5] = io[5] + dd - (gk[2] * o[2] + o[2] * hh[2]);
        Jk[1] = io[1] - (gk[0] * o[1] + o[0] * hh[1]);
        Jk[2] = io[2] - (gk[0] * o[2] + o[0] * hh[2]);
        Jk[4] = io[4] - (gk[1] * o[2] + o[1] * hh[2]);
        rbi_mul(m, gk, Jk, v, yv);
        for (i = 0; i < 6; i++)
            hm[i] = hm[i] + yv[i];
        rbi_mul(m, gk, Jk, a, fa);
        crf(v, yv, cv);
        for (i = 0; i < 6; i++)
            d->pA[k][i] = fa[i] + cv[i];
    }
    /* backward: f_p += f_k, nle_k = S^T f_k; composite Ic_p += Ic_k; CRBA: F = Ic_k S_k,
     * M_jk = S_j^T F (j <= k), the base's rows F */
    mt = 0.0;
    for (i = 0; i < 3; i++)
        g[i] = 0.0;
    for (i = 0; i < 6; i++)
        J[i] = f[i] = 0.0;
    for (k = nb - 1; k > 0; k--) {
        const double *S = d->S[k];
        const int col = nr + k - 1;
        mt += md->m[k];
        for (i = 0; i < 3; i++)
            g[i] = g[i] + d->g[k][i];
        for (i = 0; i < 6; i++) {
            J[i] = J[i] + d->J[k][i];
            f[i] = f[i] + d->pA[k][i];
        }
        if (nle != NULL)
            nle[col] = S[0] * f[0] + S[1] * f[1] + S[2] * f[2] + S[3] * f[3] + S[4] * f[4]
                       + S[5] * f[5];
        if (M != NULL) {
            rbi_mul(mt, g, J, S, F);
            for (j = k; j > 0; j--) {
                const double *Sj = d->S[j];
                const double mj = (Sj[0] * F[0] + Sj[1] * F[1] + Sj[2] * F[2] + Sj[3] * F[3]
                                   + Sj[4] * F[4] + Sj[5] * F[5]);
                M[(nr + j - 1) * nv + col] = mj;
                M[col * nv + nr + j - 1] = mj;
            }
            for (i = 0; i < nr; i++) {
                M[i * nv + col] = F[base_row(planar, i)];
                M[col * nv + i] = F[base_row(planar, i)];
            }
        }
    }
    /* the base: the whole system's composite inertia and force */
    mt += md->m[0];
    for (i = 0; i < 3; i++)
        g[i] = g[i] + md->h[0][i];
    for (i = 0; i < 6; i++) {
        J[i] = J[i] + md->J[0][i];
        f[i] = f[i] + d->pA[0][i];
    }
    if (nle != NULL)
        for (i = 0; i < nr; i++)
            nle[i] = f[base_row(planar, i)];
    if (M != NULL) {
        /* [[m 1, -[g]x], [[g]x, J]] on the base's rows/columns */
        const double I6[6][6] = {
            {mt, 0.0, 0.0, 0.0, g[2], -g[1]},
            {0.0, mt, 0.0, -g[2], 0.0, g[0]},
            {0.0, 0.0, mt, g[1], -g[0], 0.0},
            {0.0, -g[2], g[1], J[0], J[1], J[2]},
            {g[2], 0.0, -g[0], J[1], J[3], J[4]},
            {-g[1], g[0], 0.0, J[2], J[4], J[5]}};
        for (i = 0; i < nr; i++)
            for (j = 0; j < nr; j++)
                M[i * nv + j] = I6[base_row(planar, i)][base_row(planar, j)];
    }
    gm[0] = mt;
    gm[1] = g[0];
    gm[2] = g[1];
    gm[3] = g[2];
}

/* -- the model ------------------------------------------------------------------------------ */

/* Q (3 x 3) whose third column is the unit vector along a: the joint frame in which the axis a
 * (link frame) is z. The identity and exact permutations for the z, x and y axes, otherwise
 * two orthonormal vectors completing a (rigid_body._z_frame). */
static void z_frame(const double *a_in, double *Q)
{
    const double nrm = sqrt(a_in[0] * a_in[0] + a_in[1] * a_in[1] + a_in[2] * a_in[2]);
    double a[3], e[3], x[3], y[3], xn;
    int i;
    for (i = 0; i < 3; i++)
        a[i] = a_in[i] / nrm;
    memset(Q, 0, 9 * sizeof(double));
    if (a[0] == 0.0 && a[1] == 0.0 && a[2] == 1.0) {
        Q[0] = Q[4] = Q[8] = 1.0;
        return;
    }
    if (a[0] == 1.0 && a[1] == 0.0 && a[2] == 0.0) {            /* columns (y, z, x) */
        Q[2] = 1.0; Q[3] = 1.0; Q[7] = 1.0;
        return;
    }
    if (a[0] == 0.0 && a[1] == 1.0 && a[2] == 0.0) {            /* columns (z, x, y) */
        Q[1] = 1.0; Q[5] = 1.0; Q[6] = 1.0;
        return;
    }
    e[0] = fabs(a[0]) < 0.9 ? 1.0 : 0.0;
    e[1] = fabs(a[0]) < 0.9 ? 0.0 : 1.0;
    e[2] = 0.0;
    x[0] = e[1] * a[2] - e[2] * a[1];
    x[1] = e[2] * a[0] - e[0] * a[2];
    x[2] = e[0] * a[1] - e[1] * a[0];
    xn = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (i = 0; i < 3; i++)
        x[i] /= xn;
    y[0] = a[1] * x[2] - a[2] * x[1];
    y[1] = a[2] * x[0] - a[0] * x[2];
    y[2] = a[0] * x[1] - a[1] * x[0];
    for (i = 0; i < 3; i++) {
        Q[3 * i] = x[i];
        Q[3 * i + 1] = y[i];
        Q[3 * i + 2] = a[i];
    }
}

/* spatial inertia of a body (mass m, com c, inertia about the com Ic 3 x 3) at the frame
 * origin: first moment h = m c, inertia about the origin Io = Ic + m (|c|^2 1 - c c^T) (3 x 3) */
static void body_at_origin(double m, const double *c, const double *Ic, double *h, double *Io)
{
    const double c2 = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    int i, j;
    for (i = 0; i < 3; i++) {
        h[i] = m * c[i];
        for (j = 0; j < 3; j++)
            Io[3 * i + j] = Ic[3 * i + j] + m * ((i == j ? c2 : 0.0) - c[i] * c[j]);
    }
}

/* upper triangle of Q^T X Q (X 3 x 3, symmetrised) and Q^T h */
static void to_joint_frame(const double *Q, const double *X, const double *h, double *J6,
                           double *hq)
{
    double Qt[9], S[6];
    int i, j;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++)
            Qt[3 * i + j] = Q[3 * j + i];
    S[0] = X[0];
    S[1] = 0.5 * (X[1] + X[3]);
    S[2] = 0.5 * (X[2] + X[6]);
    S[3] = X[4];
    S[4] = 0.5 * (X[5] + X[7]);
    S[5] = X[8];
    rot_sym(Qt, S, J6);
    for (i = 0; i < 3; i++)
        hq[i] = Qt[3 * i] * h[0] + Qt[3 * i + 1] * h[1] + Qt[3 * i + 2] * h[2];
}

static int body_ok(const sr_body *b, int allow_zero)
{
    return sr_finite_all(&b->m, 1) && sr_finite_all(b->com, 3) && sr_finite_all(b->I, 9)
        && (allow_zero ? b->m >= 0.0 : b->m > 0.0);
}

SR_API size_t sr_dyn_model_size(void)
{
    return sizeof(sr_dyn_model);
}

SR_API size_t sr_dyn_data_size(void)
{
    return sizeof(sr_dyn_data);
}

SR_API int sr_dyn_set_base_spatial(sr_dyn_model *model, double m, const double h_B[3],
                                   const double I_S[9])
{
    if (model == NULL || h_B == NULL || I_S == NULL || !isfinite(m) || m <= 0.0
        || !sr_finite_all(h_B, 3) || !sr_finite_all(I_S, 9))
        return SR_DYN_EARG;
    model->m[0] = m;
    model->h[0][0] = h_B[0];
    model->h[0][1] = h_B[1];
    model->h[0][2] = h_B[2];
    model->J[0][0] = I_S[0];
    model->J[0][1] = I_S[1];
    model->J[0][2] = I_S[2];
    model->J[0][3] = I_S[4];
    model->J[0][4] = I_S[5];
    model->J[0][5] = I_S[8];
    return SR_DYN_OK;
}

SR_API int sr_dyn_set_base(sr_dyn_model *model, const sr_body *base)
{
    double h[3], Io[9];
    if (model == NULL || base == NULL || !body_ok(base, 0))
        return SR_DYN_EARG;
    body_at_origin(base->m, base->com, base->I, h, Io);
    return sr_dyn_set_base_spatial(model, base->m, h, Io);
}

SR_API int sr_dyn_model_init(sr_dyn_model *model, const sr_robot *robot, const sr_body *target)
{
    int k, n, i, j;
    double Qp[9], h[3], Io[9];
    if (model == NULL)
        return SR_DYN_EARG;
    memset(model, 0, sizeof(*model));
    if (robot == NULL || robot->n < 1 || robot->n > SR_MAX_JOINTS
        || (robot->planar != 0 && robot->planar != 1) || !body_ok(&robot->base, 0)
        || !sr_finite_all(robot->ee_xyz, 3) || !sr_finite_all(robot->ee_R, 9)
        || (target != NULL && !body_ok(target, 1)))
        return SR_DYN_EARG;
    n = robot->n;
    for (k = 0; k < n; k++) {
        const double *ax = robot->axis[k];
        if (!sr_finite_all(robot->xyz[k], 3) || !sr_finite_all(robot->R[k], 9) || !sr_finite_all(ax, 3)
            || !body_ok(&robot->link[k], 0)
            || ax[0] * ax[0] + ax[1] * ax[1] + ax[2] * ax[2] <= 0.0)
            return SR_DYN_EARG;
    }
    /* body 0: the base, in its own frame B at S */
    for (i = 0; i < 9; i++) {
        model->R[0][i] = (i % 4 == 0) ? 1.0 : 0.0;
        model->Q[0][i] = model->R[0][i];
        Qp[i] = model->R[0][i];
    }
    body_at_origin(robot->base.m, robot->base.com, robot->base.I, h, Io);
    model->m[0] = robot->base.m;
    to_joint_frame(model->Q[0], Io, h, model->J[0], model->h[0]);
    /* links: x_p = Rj Rot(a, q) x_k + pj, Rot(a, q) = Q Rz(q) Q^T; in joint frames (x = Q x'):
     * x_p' = (Qp^T Rj Q) Rz(q) x_k' + Qp^T pj */
    for (k = 1; k <= n; k++) {
        const double *Rj = robot->R[k - 1], *pj = robot->xyz[k - 1];
        double *Q = model->Q[k], T[9];
        const sr_body *b = &robot->link[k - 1];
        z_frame(robot->axis[k - 1], Q);
        for (i = 0; i < 3; i++)          /* T = Rj Q */
            for (j = 0; j < 3; j++)
                T[3 * i + j] = Rj[3 * i] * Q[j] + Rj[3 * i + 1] * Q[3 + j] + Rj[3 * i + 2] * Q[6 + j];
        for (i = 0; i < 3; i++) {        /* R = Qp^T T, p = Qp^T pj */
            for (j = 0; j < 3; j++)
                model->R[k][3 * i + j] = Qp[i] * T[j] + Qp[3 + i] * T[3 + j] + Qp[6 + i] * T[6 + j];
            model->p[k][i] = Qp[i] * pj[0] + Qp[3 + i] * pj[1] + Qp[6 + i] * pj[2];
        }
        /* the link's spatial inertia at its origin; the target's added to the last link's
         * (spatial inertias at one point add): com c_L = ee_xyz + ee_R c_E,
         * I_L = ee_R I_E ee_R^T */
        body_at_origin(b->m, b->com, b->I, h, Io);
        model->m[k] = b->m;
        if (k == n && target != NULL && target->m > 0.0) {
            const double *eR = robot->ee_R, *ex = robot->ee_xyz;
            double c[3], W[9], It[9], ht[3], Iot[9];
            for (i = 0; i < 3; i++)
                c[i] = ex[i] + (eR[3 * i] * target->com[0] + eR[3 * i + 1] * target->com[1]
                                + eR[3 * i + 2] * target->com[2]);
            for (i = 0; i < 3; i++)      /* W = eR I_E */
                for (j = 0; j < 3; j++)
                    W[3 * i + j] = eR[3 * i] * target->I[j] + eR[3 * i + 1] * target->I[3 + j]
                                   + eR[3 * i + 2] * target->I[6 + j];
            for (i = 0; i < 3; i++)      /* It = W eR^T */
                for (j = 0; j < 3; j++)
                    It[3 * i + j] = W[3 * i] * eR[3 * j] + W[3 * i + 1] * eR[3 * j + 1]
                                    + W[3 * i + 2] * eR[3 * j + 2];
            body_at_origin(target->m, c, It, ht, Iot);
            model->m[k] += target->m;
            for (i = 0; i < 3; i++)
                h[i] += ht[i];
            for (i = 0; i < 9; i++)
                Io[i] += Iot[i];
        }
        to_joint_frame(Q, Io, h, model->J[k], model->h[k]);
        memcpy(Qp, Q, sizeof(Qp));
    }
    model->planar = robot->planar;
    model->n = n;
    model->nv = (robot->planar ? 3 : 6) + n;
    model->nq = (robot->planar ? 4 : 7) + n;
    return SR_DYN_OK;
}

/* -- generalised coordinates ------------------------------------------------------------- */

/* DCM base -> inertial of the configuration q: planar (cos, sin) as given; the quaternion
 * normalised on the fly (rigid_body.terms) */
static void dcm_of_q(const sr_dyn_model *md, const double *q, double *A, double *r)
{
    if (md->planar) {
        const double c = q[2], s = q[3];
        A[0] = c; A[1] = -s; A[2] = 0.0;
        A[3] = s; A[4] = c; A[5] = 0.0;
        A[6] = 0.0; A[7] = 0.0; A[8] = 1.0;
        r[0] = q[0];
        r[1] = q[1];
        r[2] = 0.0;
    } else {
        const double x = q[3], y = q[4], z = q[5], w = q[6];
        const double s2 = 2.0 / (x * x + y * y + z * z + w * w);
        A[0] = 1.0 - s2 * (y * y + z * z); A[1] = s2 * (x * y - z * w); A[2] = s2 * (x * z + y * w);
        A[3] = s2 * (x * y + z * w); A[4] = 1.0 - s2 * (x * x + z * z); A[5] = s2 * (y * z - x * w);
        A[6] = s2 * (x * z - y * w); A[7] = s2 * (y * z + x * w); A[8] = 1.0 - s2 * (x * x + y * y);
        r[0] = q[0];
        r[1] = q[1];
        r[2] = q[2];
    }
}

SR_API int sr_dyn_aba(const sr_dyn_model *model, sr_dyn_data *data, const double *q,
                      const double *v, const double *tau, double *ddq)
{
    double sc[2 * SR_MAX_JOINTS];
    if (!model_ok(model) || q == NULL)
        return SR_DYN_EARG;
    arm_sincos(model, q + (model->planar ? 4 : 7), sc);
    return sr_dyn_aba_sc(model, data, q, v, tau, sc, ddq);
}

SR_API int sr_dyn_aba_sc(const sr_dyn_model *model, sr_dyn_data *data, const double *q,
                         const double *v, const double *tau, const double *sc, double *ddq)
{
    int nr;
    if (!model_ok(model) || data == NULL || q == NULL || v == NULL || tau == NULL || sc == NULL
        || ddq == NULL)
        return SR_DYN_EARG;
    nr = model->planar ? 3 : 6;
    return aba_core(model, data, sc, v + nr, tau + nr, v, tau, ddq, ddq + nr);
}

SR_API int sr_dyn_arm_sincos(const sr_dyn_model *model, const double *q_arm, double *sc)
{
    if (!model_ok(model) || q_arm == NULL || sc == NULL)
        return SR_DYN_EARG;
    arm_sincos(model, q_arm, sc);
    return SR_DYN_OK;
}

SR_API int sr_dyn_terms(const sr_dyn_model *model, sr_dyn_data *data, const double *q,
                        const double *v, double *M, double *nle, double *hg, double *com)
{
    double sc[2 * SR_MAX_JOINTS];
    if (!model_ok(model) || q == NULL)
        return SR_DYN_EARG;
    arm_sincos(model, q + (model->planar ? 4 : 7), sc);
    return sr_dyn_terms_sc(model, data, q, v, sc, M, nle, hg, com);
}

SR_API int sr_dyn_terms_sc(const sr_dyn_model *model, sr_dyn_data *data, const double *q,
                           const double *v, const double *sc, double *M, double *nle,
                           double *hg, double *com)
{
    int nr;
    double hm[6], gm[4], A[9], r[3], c[3], l[3], nn[3];
    if (!model_ok(model) || data == NULL || q == NULL || v == NULL || sc == NULL)
        return SR_DYN_EARG;
    nr = model->planar ? 3 : 6;
    terms_core(model, data, sc, v + nr, v, M, nle, hm, gm);
    if (hg == NULL && com == NULL)
        return SR_DYN_OK;
    /* centre of mass (base frame): the composite's first moment over its mass;
     * inertial frame: P = A h_l, L_c = A (h_n - c x h_l) */
    c[0] = gm[1] / gm[0];
    c[1] = gm[2] / gm[0];
    c[2] = gm[3] / gm[0];
    dcm_of_q(model, q, A, r);
    if (hg != NULL) {
        l[0] = hm[0];
        l[1] = hm[1];
        l[2] = hm[2];
        nn[0] = hm[3] - (c[1] * l[2] - c[2] * l[1]);
        nn[1] = hm[4] - (c[2] * l[0] - c[0] * l[2]);
        nn[2] = hm[5] - (c[0] * l[1] - c[1] * l[0]);
        mat3_vec(A, l, hg);
        mat3_vec(A, nn, hg + 3);
    }
    if (com != NULL) {
        int i;
        for (i = 0; i < 3; i++)
            com[i] = r[i] + A[3 * i] * c[0] + A[3 * i + 1] * c[1] + A[3 * i + 2] * c[2];
    }
    return SR_DYN_OK;
}

/* -- the physical state ------------------------------------------------------------------- */

/* the base rotation a planar robot sees: A's rotation about z, normalised */
static void planar_dcm(const double *A, double *Ap, double *cs, double *sn)
{
    const double c = A[0], s = A[3], k = 1.0 / sqrt(c * c + s * s);
    *cs = c * k;
    *sn = s * k;
    Ap[0] = *cs; Ap[1] = -*sn; Ap[2] = 0.0;
    Ap[3] = *sn; Ap[4] = *cs; Ap[5] = 0.0;
    Ap[6] = 0.0; Ap[7] = 0.0; Ap[8] = 1.0;
}

/* the base's generalised velocity vb (nr) of the physical state; Ae: the DCM used */
static void base_velocity(const sr_dyn_model *md, const double *A, const double *v_S,
                          const double *omega_B, double *vb, double *Ae)
{
    double vl[3];
    if (md->planar) {
        double cs, sn;
        planar_dcm(A, Ae, &cs, &sn);
        mat3t_vec(Ae, v_S, vl);
        vb[0] = vl[0];
        vb[1] = vl[1];
        vb[2] = omega_B[2];
    } else {
        memcpy(Ae, A, 9 * sizeof(double));
        mat3t_vec(A, v_S, vl);
        vb[0] = vl[0]; vb[1] = vl[1]; vb[2] = vl[2];
        vb[3] = omega_B[0]; vb[4] = omega_B[1]; vb[5] = omega_B[2];
    }
}

/* the base's generalised force fb (nr): [A^T F; A^T M_S] (planar rows x, y and M_S,z) */
static void base_force(const sr_dyn_model *md, const double *Ae, const double *F,
                       const double *M_S, double *fb)
{
    double t[3];
    mat3t_vec(Ae, F, t);
    fb[0] = t[0];
    fb[1] = t[1];
    if (md->planar) {
        fb[2] = M_S[2];
    } else {
        fb[2] = t[2];
        mat3t_vec(Ae, M_S, fb + 3);
    }
}

SR_API int sr_dyn_generalised(const sr_dyn_model *model, const double r_S[3], const double A[9],
                              const double v_S[3], const double omega_B[3],
                              const double *q_arm, const double *qd, double *q, double *v)
{
    double Ae[9];
    int nr, nq0, i;
    if (!model_ok(model) || r_S == NULL || A == NULL || v_S == NULL || omega_B == NULL
        || q_arm == NULL || qd == NULL || q == NULL || v == NULL)
        return SR_DYN_EARG;
    nr = model->planar ? 3 : 6;
    nq0 = model->planar ? 4 : 7;
    base_velocity(model, A, v_S, omega_B, v, Ae);
    if (model->planar) {
        q[0] = r_S[0];
        q[1] = r_S[1];
        q[2] = Ae[0];
        q[3] = Ae[3];
    } else {
        /* Shepperd's method: the largest of 4 w^2, 4 x^2, 4 y^2, 4 z^2 gives the pivot */
        const double tr = A[0] + A[4] + A[8];
        double x, y, z, w, s;
        q[0] = r_S[0];
        q[1] = r_S[1];
        q[2] = r_S[2];
        if (tr >= A[0] && tr >= A[4] && tr >= A[8]) {
            s = 2.0 * sqrt(1.0 + tr);           /* 4 w */
            w = 0.25 * s;
            x = (A[7] - A[5]) / s;
            y = (A[2] - A[6]) / s;
            z = (A[3] - A[1]) / s;
        } else if (A[0] >= A[4] && A[0] >= A[8]) {
            s = 2.0 * sqrt(1.0 + A[0] - A[4] - A[8]);    /* 4 x */
            w = (A[7] - A[5]) / s;
            x = 0.25 * s;
            y = (A[1] + A[3]) / s;
            z = (A[2] + A[6]) / s;
        } else if (A[4] >= A[8]) {
            s = 2.0 * sqrt(1.0 - A[0] + A[4] - A[8]);    /* 4 y */
            w = (A[2] - A[6]) / s;
            x = (A[1] + A[3]) / s;
            y = 0.25 * s;
            z = (A[5] + A[7]) / s;
        } else {
            s = 2.0 * sqrt(1.0 - A[0] - A[4] + A[8]);    /* 4 z */
            w = (A[3] - A[1]) / s;
            x = (A[2] + A[6]) / s;
            y = (A[5] + A[7]) / s;
            z = 0.25 * s;
        }
        if (w < 0.0) {
            x = -x; y = -y; z = -z; w = -w;
        }
        s = 1.0 / sqrt(x * x + y * y + z * z + w * w);
        q[3] = x * s;
        q[4] = y * s;
        q[5] = z * s;
        q[6] = w * s;
    }
    for (i = 0; i < model->n; i++) {
        q[nq0 + i] = q_arm[i];
        v[nr + i] = qd[i];
    }
    return SR_DYN_OK;
}

SR_API int sr_dyn_generalised_force(const sr_dyn_model *model, const double A[9],
                                    const double F[3], const double M_S[3], const double *tau,
                                    double *gen)
{
    double Ae[9], cs, sn;
    int nr, i;
    if (!model_ok(model) || A == NULL || F == NULL || M_S == NULL || tau == NULL || gen == NULL)
        return SR_DYN_EARG;
    nr = model->planar ? 3 : 6;
    if (model->planar)
        planar_dcm(A, Ae, &cs, &sn);
    else
        memcpy(Ae, A, sizeof(Ae));
    base_force(model, Ae, F, M_S, gen);
    for (i = 0; i < model->n; i++)
        gen[nr + i] = tau[i];
    return SR_DYN_OK;
}

SR_API int sr_dyn_forward(const sr_dyn_model *model, sr_dyn_data *data, const double A[9],
                          const double v_S[3], const double omega_B[3], const double *q_arm,
                          const double *qd, const double F[3], const double M_S[3],
                          const double *tau, double a_S[3], double alpha_B[3], double *qdd)
{
    double Ae[9], vb[6], fb[6], ab[6], vl[3], w[3], al[3], t[3], sc[2 * SR_MAX_JOINTS];
    int st;
    if (!model_ok(model) || data == NULL || A == NULL || v_S == NULL || omega_B == NULL
        || q_arm == NULL || qd == NULL || F == NULL || M_S == NULL || tau == NULL
        || a_S == NULL || alpha_B == NULL || qdd == NULL)
        return SR_DYN_EARG;
    base_velocity(model, A, v_S, omega_B, vb, Ae);
    base_force(model, Ae, F, M_S, fb);
    arm_sincos(model, q_arm, sc);
    st = aba_core(model, data, sc, qd, tau, vb, fb, ab, qdd);
    if (st != SR_DYN_OK)
        return st;
    /* classical acceleration of S: a_S = A (dv_l/dt + omega_B x v_l) */
    if (model->planar) {
        vl[0] = vb[0]; vl[1] = vb[1]; vl[2] = 0.0;
        w[0] = 0.0; w[1] = 0.0; w[2] = vb[2];
        al[0] = ab[0]; al[1] = ab[1]; al[2] = 0.0;
        alpha_B[0] = 0.0; alpha_B[1] = 0.0; alpha_B[2] = ab[2];
    } else {
        vl[0] = vb[0]; vl[1] = vb[1]; vl[2] = vb[2];
        w[0] = vb[3]; w[1] = vb[4]; w[2] = vb[5];
        al[0] = ab[0]; al[1] = ab[1]; al[2] = ab[2];
        alpha_B[0] = ab[3]; alpha_B[1] = ab[4]; alpha_B[2] = ab[5];
    }
    vec3_cross(w, vl, t);
    t[0] += al[0];
    t[1] += al[1];
    t[2] += al[2];
    mat3_vec(Ae, t, a_S);
    return SR_DYN_OK;
}

SR_API int sr_dyn_mass_bias(const sr_dyn_model *model, sr_dyn_data *data, const double A[9],
                            const double v_S[3], const double omega_B[3], const double *q_arm,
                            const double *qd, double *M, double *h)
{
    double Ae[9], vb[6], hm[6], gm[4], sc[2 * SR_MAX_JOINTS];
    if (!model_ok(model) || data == NULL || A == NULL || v_S == NULL || omega_B == NULL
        || q_arm == NULL || qd == NULL)
        return SR_DYN_EARG;
    base_velocity(model, A, v_S, omega_B, vb, Ae);
    arm_sincos(model, q_arm, sc);
    terms_core(model, data, sc, qd, vb, M, h, hm, gm);
    return SR_DYN_OK;
}

SR_API int sr_dyn_momentum(const sr_dyn_model *model, sr_dyn_data *data, const double r_S[3],
                           const double A[9], const double v_S[3], const double omega_B[3],
                           const double *q_arm, const double *qd, double P[3], double L[3],
                           double *com)
{
    double Ae[9], vb[6], hm[6], gm[4], t[3], sc[2 * SR_MAX_JOINTS];
    if (!model_ok(model) || data == NULL || r_S == NULL || A == NULL || v_S == NULL
        || omega_B == NULL || q_arm == NULL || qd == NULL || P == NULL || L == NULL)
        return SR_DYN_EARG;
    base_velocity(model, A, v_S, omega_B, vb, Ae);
    arm_sincos(model, q_arm, sc);
    terms_core(model, data, sc, qd, vb, NULL, NULL, hm, gm);
    /* P = A h_l;  L about the origin = A h_n (about S) + r_S x P */
    mat3_vec(Ae, hm, P);
    mat3_vec(Ae, hm + 3, L);
    vec3_cross(r_S, P, t);
    L[0] += t[0];
    L[1] += t[1];
    L[2] += t[2];
    if (com != NULL) {
        double c[3];
        c[0] = gm[1] / gm[0];
        c[1] = gm[2] / gm[0];
        c[2] = gm[3] / gm[0];
        mat3_vec(Ae, c, t);
        com[0] = r_S[0] + t[0];
        com[1] = r_S[1] + t[1];
        com[2] = r_S[2] + t[2];
    }
    return SR_DYN_OK;
}
