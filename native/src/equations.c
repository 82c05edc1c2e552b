/* The identification equations of one sample, D(mu), the sample's check, and the thrust's
 * consider sensitivities and integrals (equations.h).
 *
 * Arm kinematics, revolute joint i with parent frame p (all vectors inertial):
 *   d = A_p xyz_i,  A_i = A_p R_i Rot(axis_i, q_i),  z = A_i axis_i,  w_i = w_p + z qd_i,
 *   v_i = v_p + w_p x d,  b_i = b_p + z qdd_i + w_p x z qd_i,  a_i = a_p + b_p x d + w_p x (w_p x d).
 */
#include "equations.h"

#include <math.h>
#include <string.h>

#include "sr_math.h"
#include "vec3.h"

/* out = A B (3 x 3 each) */
static void matmul3(const double *A, const double *B, double *out)
{
    int i, j;
    for (i = 0; i < 3; i++)
        for (j = 0; j < 3; j++)
            out[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

/* out = A I A^T w: an inertia I in body coordinates applied to an inertial vector w */
static void inertia_times(const double *A, const double *I, const double *w, double *out)
{
    double tmp[3], s[3];
    int i;
    mat3t_vec(A, w, tmp);
    for (i = 0; i < 3; i++)
        s[i] = I[3 * i] * tmp[0] + I[3 * i + 1] * tmp[1] + I[3 * i + 2] * tmp[2];
    mat3_vec(A, s, out);
}

/* E[:, col:col+6] += sign * A [#u] (6 columns of a 3 x ncols array); eq. 20: I v = [#v] I# */
static void a_sharp(const double *A, const double *u, double *E, int ncols, int col, double sign)
{
    int i;
    for (i = 0; i < 3; i++) {
        double a0 = A[3 * i], a1 = A[3 * i + 1], a2 = A[3 * i + 2];
        double *e = E + ncols * i + col;
        e[0] += sign * (a0 * u[0]);
        e[1] += sign * (a0 * u[1] + a1 * u[0]);
        e[2] += sign * (a0 * u[2] + a2 * u[0]);
        e[3] += sign * (a1 * u[1]);
        e[4] += sign * (a1 * u[2] + a2 * u[1]);
        e[5] += sign * (a2 * u[2]);
    }
}

/* E[:, dst:dst+6] = sign * E[:, src:src+6] T_SHIFT: the parallel-axis map taking the
 * quadratic monomials m [bx^2, bx by, bx bz, by^2, by bz, bz^2] to (m (|b|^2 1 - b b^T))# */
static void shift(double *E, int src, int dst, double sign)
{
    int i;
    for (i = 0; i < 3; i++) {
        double *e = E + SR_N_COLS * i;
        double x0 = e[src], x1 = e[src + 1], x2 = e[src + 2], x3 = e[src + 3], x4 = e[src + 4],
               x5 = e[src + 5];
        e[dst + 0] = sign * (x3 + x5);
        e[dst + 1] = sign * -x1;
        e[dst + 2] = sign * -x2;
        e[dst + 3] = sign * (x0 + x5);
        e[dst + 4] = sign * -x4;
        e[dst + 5] = sign * (x0 + x3);
    }
}

/* Columns of body k (0 base, 1 target) in E.
 * Momentum (eqs. 11, 16, 19-22): B = [v_O, [w]x A], D = A [#(A^T w)],
 *   -Psi = -[r_O x v_O, ([r_O]x [w]x - [v_O]x) A, D T].
 * Force (eqs. 28-31, moments about S): G = [a_O, K A], K = [beta]x + [w]x[w]x,
 *   Q = A [#(A^T beta)] + [w]x A [#(A^T w)], -S = -[rho x a_O, ([rho]x K - [a_O]x) A, Q T].
 * The two share their shape: a vector l (v_O / a_O), a lever r (r_O / rho) and a map
 * X ([w]x / K): [l, X A] and [r x l, ([r]x X - [l]x) A, ...]. */
static void body_rows(int force, int k, const double *r_O, const double *A, const double *v_O,
                      const double *w, const double *a_O, const double *beta, const double *rho,
                      double *E)
{
    int cA = SR_COL_A + 4 * k, cP = SR_COL_PHI + 6 * k, cS = SR_COL_PSI + 10 * k;
    const double *lvec = force ? a_O : v_O;
    const double *lever = force ? rho : r_O;
    double u[3], t1[3], t2[3], col[3];
    int i, j, c;
    vec3_cross(lever, lvec, t1);
    for (i = 0; i < 3; i++) {
        E[SR_N_COLS * i + cA] = lvec[i];                 /* eq. 11 / 29: v_O or a_O */
        E[SR_N_COLS * i + cS] = -t1[i];                  /* -(r_O x v_O) or -(rho x a_O) */
    }
    for (j = 0; j < 3; j++) {
        col[0] = A[j];
        col[1] = A[3 + j];
        col[2] = A[6 + j];
        vec3_cross(w, col, t1);                               /* [w]x A_j */
        if (force) {
            vec3_cross(w, t1, t2);                            /* w x (w x A_j) */
            vec3_cross(beta, col, t1);                        /* beta x A_j */
            for (i = 0; i < 3; i++)
                t1[i] += t2[i];                          /* K A_j */
        }
        vec3_cross(lever, t1, t2);                            /* r x X A_j */
        vec3_cross(lvec, col, u);                             /* l x A_j */
        for (i = 0; i < 3; i++) {
            E[SR_N_COLS * i + cA + 1 + j] = t1[i];
            E[SR_N_COLS * i + cS + 1 + j] = -(t2[i] - u[i]);
        }
    }
    for (i = 0; i < 3; i++)
        for (c = 0; c < 6; c++)
            E[SR_N_COLS * i + cP + c] = 0.0;
    mat3t_vec(A, force ? beta : w, u);
    a_sharp(A, u, E, SR_N_COLS, cP, 1.0);               /* A [#(A^T w)] or A [#(A^T beta)] */
    if (force) {                                         /* + [w]x A [#(A^T w)] (eq. 31) */
        double tmpE[18];
        memset(tmpE, 0, sizeof tmpE);
        mat3t_vec(A, w, u);
        a_sharp(A, u, tmpE, 6, 0, 1.0);
        for (c = 0; c < 6; c++) {
            col[0] = tmpE[c];
            col[1] = tmpE[6 + c];
            col[2] = tmpE[12 + c];
            vec3_cross(w, col, t1);
            for (i = 0; i < 3; i++)
                E[SR_N_COLS * i + cP + c] += t1[i];
        }
    }
    shift(E, cP, cS + 4, -1.0);                          /* -(D or Q) T: eq. 22 */
}

SR_API int sr_equations(const sr_robot *robot, int force, const double *x, double *E)
{
    const double *r_S, *v_S, *a_S, *q, *qd, *qdd, *Fm, *Mm, *Jm, *Hm;
    double A0[9], w0[3], b0[3], Ap[9], rp[3], vp[3], wp[3], ap[3], bp[3];
    double Ai[9], Rq[9], T[9], d[3], z[3], c[3], t1[3], t2[3], t3[3], rc[3], vc[3], ac[3];
    double Iw[3], Ib[3], lin[3], ang[3], AE[9], rE[3], vE[3], aE[3], rho[3];
    static const double zero[3] = {0.0, 0.0, 0.0};
    int n, i, j, o;
    if (!robot || !x || !E || robot->n < 1 || robot->n > SR_MAX_JOINTS)
        return 1;
    n = robot->n;
    r_S = x + SR_X_R_S;
    v_S = x + SR_X_V_S;
    a_S = x + SR_X_A_S;
    memcpy(A0, x + SR_X_A_B, sizeof A0);
    q = x + SR_X_Q;
    qd = x + SR_X_QD(n);
    qdd = x + SR_X_QDD(n);
    o = SR_X_F(n);
    Fm = x + o;
    Mm = x + o + 3;
    Jm = x + o + 6;
    Hm = x + o + 9;
    mat3_vec(A0, x + SR_X_OMEGA_B, w0);                    /* w = A omega_B */
    mat3_vec(A0, x + SR_X_ALPHA_B, b0);                    /* d/dt(A w_B) = A dw_B/dt */
    /* parent frame state (starts at the base, origin S) */
    memcpy(Ap, A0, sizeof Ap);
    memcpy(rp, r_S, sizeof rp);
    memcpy(vp, v_S, sizeof vp);
    memcpy(wp, w0, sizeof wp);
    memcpy(ap, a_S, sizeof ap);
    memcpy(bp, b0, sizeof bp);
    for (j = 0; j < 3; j++)
        lin[j] = ang[j] = 0.0;                           /* P_arm or F_arm; L_arm or M_arm,S */
    for (i = 0; i < n; i++) {
        const double *k = robot->axis[i];
        double cq, sq, vq, m;
        mat3_vec(Ap, robot->xyz[i], d);
        /* Rot(axis, q) = cos q 1 + sin q [k]x + (1 - cos q) k k^T */
        sr_sincos(q[i], &sq, &cq);                       /* portable: the same bits everywhere */
        vq = 1.0 - cq;
        Rq[0] = cq + vq * k[0] * k[0];
        Rq[1] = vq * k[0] * k[1] - sq * k[2];
        Rq[2] = vq * k[0] * k[2] + sq * k[1];
        Rq[3] = vq * k[1] * k[0] + sq * k[2];
        Rq[4] = cq + vq * k[1] * k[1];
        Rq[5] = vq * k[1] * k[2] - sq * k[0];
        Rq[6] = vq * k[2] * k[0] - sq * k[1];
        Rq[7] = vq * k[2] * k[1] + sq * k[0];
        Rq[8] = cq + vq * k[2] * k[2];
        matmul3(Ap, robot->R[i], T);
        matmul3(T, Rq, Ai);                              /* A_i = A_p R_i Rot(axis_i, q_i) */
        mat3_vec(Ai, k, z);
        /* origin of frame i: r, v (a) from the parent */
        vec3_cross(wp, d, t1);
        for (j = 0; j < 3; j++) {
            rp[j] += d[j];
            vp[j] += t1[j];
        }
        if (force) {
            vec3_cross(bp, d, t2);
            vec3_cross(wp, t1, t3);
            for (j = 0; j < 3; j++)
                ap[j] += t2[j] + t3[j];
            vec3_cross(wp, z, t2);                            /* b_i = b_p + z qdd + w_p x z qd */
            for (j = 0; j < 3; j++)
                bp[j] += z[j] * qdd[i] + t2[j] * qd[i];
        }
        for (j = 0; j < 3; j++)
            wp[j] += z[j] * qd[i];
        /* the link's centre of mass */
        mat3_vec(Ai, robot->link[i].com, c);
        vec3_cross(wp, c, t1);
        for (j = 0; j < 3; j++) {
            rc[j] = rp[j] + c[j];
            vc[j] = vp[j] + t1[j];
        }
        m = robot->link[i].m;
        inertia_times(Ai, robot->link[i].I, wp, Iw);
        if (!force) {
            /* P = sum m v_c ;  L = sum A I A^T w + m r_c x v_c  (the arm's part of eqs. 11, 16) */
            vec3_cross(rc, vc, t2);
            for (j = 0; j < 3; j++) {
                lin[j] += m * vc[j];
                ang[j] += Iw[j] + m * t2[j];
            }
        } else {
            /* F = sum m a_c ;  M_S = sum A I A^T beta + w x A I A^T w + m (r_c - r_S) x a_c
               (eqs. 26-27) */
            vec3_cross(bp, c, t2);
            vec3_cross(wp, t1, t3);
            for (j = 0; j < 3; j++)
                ac[j] = ap[j] + t2[j] + t3[j];
            inertia_times(Ai, robot->link[i].I, bp, Ib);
            vec3_cross(wp, Iw, t1);
            for (j = 0; j < 3; j++)
                t3[j] = rc[j] - r_S[j];
            vec3_cross(t3, ac, t2);
            for (j = 0; j < 3; j++) {
                lin[j] += m * ac[j];
                ang[j] += Ib[j] + t1[j] + m * t2[j];
            }
        }
        memcpy(Ap, Ai, sizeof Ap);
    }
    /* end-effector frame E (the target's frame) */
    mat3_vec(Ap, robot->ee_xyz, d);
    matmul3(Ap, robot->ee_R, AE);
    vec3_cross(wp, d, t1);
    for (j = 0; j < 3; j++) {
        rE[j] = rp[j] + d[j];
        vE[j] = vp[j] + t1[j];
    }
    if (force) {
        vec3_cross(bp, d, t2);
        vec3_cross(wp, t1, t3);
        for (j = 0; j < 3; j++)
            aE[j] = ap[j] + t2[j] + t3[j];
        for (j = 0; j < 3; j++)
            rho[j] = rE[j] - r_S[j];
        body_rows(1, 0, r_S, A0, v_S, w0, a_S, b0, zero, E);
        body_rows(1, 1, rE, AE, vE, wp, aE, bp, rho, E);
        for (j = 0; j < 3; j++) {
            E[SR_N_COLS * j + SR_COL_B] = Fm[j] - lin[j];        /* eq. 28 */
            E[SR_N_COLS * j + SR_COL_Y] = Mm[j] - ang[j];        /* eq. 31: the thrust acts at S */
        }
    } else {
        body_rows(0, 0, r_S, A0, v_S, w0, a_S, b0, zero, E);
        body_rows(0, 1, rE, AE, vE, wp, zero, bp, zero, E);
        for (j = 0; j < 3; j++) {
            E[SR_N_COLS * j + SR_COL_B] = Jm[j] - lin[j];        /* eq. 11 */
            E[SR_N_COLS * j + SR_COL_Y] = Hm[j] - ang[j];        /* eq. 16 */
        }
    }
    return 0;
}

SR_API void sr_D_of_mu(const double mu[8], double D[20])
{
    int k;
    for (k = 0; k < 2; k++) {                            /* eq. 23: D = [m J(b)] per body */
        double m = mu[4 * k];
        double bx = mu[4 * k + 1] / m, by = mu[4 * k + 2] / m, bz = mu[4 * k + 3] / m;
        double *o = D + 10 * k;
        o[0] = m;
        o[1] = m * bx;
        o[2] = m * by;
        o[3] = m * bz;
        o[4] = m * (bx * bx);
        o[5] = m * (bx * by);
        o[6] = m * (bx * bz);
        o[7] = m * (by * by);
        o[8] = m * (by * bz);
        o[9] = m * (bz * bz);
    }
}

static double max2(double a, double b)
{
    /* as Python's max(): the first unless the second is larger (a NaN first argument stays) */
    return b > a ? b : a;
}

SR_API void sr_rotation_error(const double *A, double *err, double *det)
{
    double a00 = A[0], a01 = A[1], a02 = A[2], a10 = A[3], a11 = A[4], a12 = A[5], a20 = A[6],
           a21 = A[7], a22 = A[8];
    double e = fabs(a00 * a00 + a10 * a10 + a20 * a20 - 1.0);
    e = max2(e, fabs(a01 * a01 + a11 * a11 + a21 * a21 - 1.0));
    e = max2(e, fabs(a02 * a02 + a12 * a12 + a22 * a22 - 1.0));
    e = max2(e, fabs(a00 * a01 + a10 * a11 + a20 * a21));
    e = max2(e, fabs(a00 * a02 + a10 * a12 + a20 * a22));
    e = max2(e, fabs(a01 * a02 + a11 * a12 + a21 * a22));
    if (err)
        *err = e;
    if (det)
        *det = (a00 * (a11 * a22 - a12 * a21) - a01 * (a10 * a22 - a12 * a20)
                + a02 * (a10 * a21 - a11 * a20));
}

SR_API int sr_sample_check(const double *x, int len, double limit, double tol)
{
    double err, det;
    int i;
    if (!x || len < SR_X_A_B + 9)
        return 3;
    for (i = 0; i < len; i++)
        if (!(fabs(x[i]) <= limit))
            return 1;
    sr_rotation_error(x + SR_X_A_B, &err, &det);
    if (err <= tol && det > 0.0)
        return 0;
    return 2;
}

/* -- the thrust's consider terms (consider.py) ------------------------------------------------ */

/* out = [v]x (3 x 3, row-major): [v]x u = v x u */
static void skew3(const double *v, double *out)
{
    out[0] = 0.0;   out[1] = -v[2]; out[2] = v[1];
    out[3] = v[2];  out[4] = 0.0;   out[5] = -v[0];
    out[6] = -v[1]; out[7] = v[0];  out[8] = 0.0;
}

void sr_thrust_integrals_add(double *K, int first, double t, const double *r_S, const double *F,
                             const double *M)
{
    if (!K || !r_S || !F || !M)
        return;
    if (!first) {                          /* the previous sample's thrust over [t_prev, t] */
        double dt = t - K[SR_THRUST_T], Rx[9], Fx[9];
        const double *r = K + 1, *Fp = K + 4, *Mp = K + 7;
        double *k_s = K + SR_THRUST_K, *k_phi = k_s + 3, *k_M = k_s + 12;
        skew3(r, Rx);
        skew3(Fp, Fx);
        for (int i = 0; i < 3; i++) {
            /* int r_S x F dt */
            k_s[i] += dt * (Rx[3 * i] * Fp[0] + Rx[3 * i + 1] * Fp[1] + Rx[3 * i + 2] * Fp[2]);
            /* -int [r_S]x [F]x dt */
            for (int j = 0; j < 3; j++)
                k_phi[3 * i + j] -= dt * (Rx[3 * i] * Fx[j] + Rx[3 * i + 1] * Fx[3 + j]
                                          + Rx[3 * i + 2] * Fx[6 + j]);
        }
        for (int i = 0; i < 3; i++)
            k_M[i] += dt * Mp[i];          /* int M dt */
    }
    K[SR_THRUST_T] = t;
    for (int i = 0; i < 3; i++) {
        K[1 + i] = r_S[i];
        K[4 + i] = F[i];
        K[7 + i] = M[i];
    }
}

/* out[:, col] = v and out[:, col + 1 .. col + 3] = -[v]x (3 rows of stride SR_N_CCOLS): the
 * sensitivity of a right-hand side v to its scale factor and misalignment,
 * d((1 + s) v + phi x v) = v ds - [v]x dphi */
static void scale_and_misalign(const double *v, double *out, int col)
{
    double S[9];
    skew3(v, S);
    for (int i = 0; i < 3; i++) {
        out[i * SR_N_CCOLS + col] = v[i];
        for (int j = 0; j < 3; j++)
            out[i * SR_N_CCOLS + col + 1 + j] = -S[3 * i + j];
    }
}

void sr_thrust_sensitivity(int force, const double *x, int n, const double *k, double *out)
{
    if (!x || !out || n < 1 || n > SR_MAX_JOINTS || (!force && !k))
        return;
    memset(out, 0, sizeof(double) * 3 * SR_N_CCOLS);
    const int nc = SR_N_CONSIDER;
    if (force) {
        scale_and_misalign(x + SR_X_F(n), out, 0);          /* b = F - F_arm */
        scale_and_misalign(x + SR_X_M(n), out, nc + 4);     /* y = M - M_arm,S */
        return;
    }
    scale_and_misalign(x + SR_X_J(n), out, 0);              /* b = J - P_arm */
    for (int i = 0; i < 3; i++) {                           /* y = H - L_arm */
        out[i * SR_N_CCOLS + nc] = k[i];                    /* dy/ds_F = int r_S x F dt */
        for (int j = 0; j < 3; j++)                         /* dy/dphi_F = k_phi */
            out[i * SR_N_CCOLS + nc + 1 + j] = k[3 + 3 * i + j];
    }
    scale_and_misalign(k + 12, out, nc + 4);                /* dy/ds_M, dy/dphi_M of int M */
}
