/* Internals of the rigid-body dynamics shared by its files: dynamics.c (the model),
 * dynamics_aba.c (forward dynamics), dynamics_crba.c (joint-space inertia, non-linear effects,
 * momentum) and dynamics_state.c (the physical state). Not part of the library's API.
 *
 * Every algorithm works in the base frame (the inertial frame that coincides with the base's
 * body frame at the instant considered): without gravity the dynamics do not depend on the
 * base's pose. Spatial motion and force vectors are [linear; angular] (Pinocchio's order). */
#ifndef SR_DYNAMICS_INTERNAL_H
#define SR_DYNAMICS_INTERNAL_H

#include "dynamics.h"
#include "sr_math.h"

static inline int dyn_model_ok(const sr_dyn_model *md)
{
    return md != NULL && md->n >= 1 && md->n <= SR_MAX_JOINTS
        && (md->planar == 0 || md->planar == 1) && md->nl >= 0 && md->nl <= SR_DYN_MAX_LEAVES
        && md->nv == (md->planar ? 3 : 6) + md->n + md->nl
        && md->nq == (md->planar ? 4 : 7) + md->n + md->nl;
}

/* row of the base spatial velocity [v; omega] that is the base's generalised velocity i:
 * all six for the free-flyer, rows 0, 1, 5 (v_x, v_y, omega_z) planar */
static inline int base_row(int planar, int i)
{
    return (planar && i == 2) ? 5 : i;
}

/* upper triangle of Rk A Rk^T, A symmetric by its upper triangle a = (a00 a01 a02 a11 a12 a22) */
static inline void rot_sym(const double *r, const double *a, double *o)
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

/* the sines and cosines of the coordinates after the base qa (n + nl: the arm's, then the
 * leaves'): sc ((n + nl) x 2) = (sin, cos) rows */
static inline void dyn_arm_sincos(const sr_dyn_model *md, const double *qa, double *sc)
{
    int k;
    for (k = 0; k < md->n + md->nl; k++)
        sr_sincos(qa[k], &sc[2 * k], &sc[2 * k + 1]);   /* portable: the same bits everywhere */
}

/* placement of body k (joint angle th, sn = sin th, cs = cos th) in the base frame from its
 * parent's (Ep 3 x 3, op): the joint frame sits at x_parent = R[k] Rz(th) x_k + p[k], so
 * Ek = Ep R[k] Rz(th), ok = op + Ep p[k]; the joint axis in the base frame s is the third
 * column of Ep R[k]. Ek must not alias Ep. */
static inline void place(const sr_dyn_model *md, int k, double sn, double cs, const double *Ep,
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

/* the motion S6 = [o x s; s] at the base origin of a rotation about the unit axis s through
 * the point o */
static inline void joint_motion(const double *o, const double *s, double *S6)
{
    S6[0] = o[1] * s[2] - o[2] * s[1];
    S6[1] = o[2] * s[0] - o[0] * s[2];
    S6[2] = o[0] * s[1] - o[1] * s[0];
    S6[3] = s[0];
    S6[4] = s[1];
    S6[5] = s[2];
}

/* the rigid-body inertia [[m 1, -[g]x], [[g]x, J]] (J by its upper triangle) as a 6 x 6 matrix */
static inline void rbi_full(double m, const double *g, const double *J, double I6[6][6])
{
    const double rows[6][6] = {
        {m, 0.0, 0.0, 0.0, g[2], -g[1]},
        {0.0, m, 0.0, -g[2], 0.0, g[0]},
        {0.0, 0.0, m, g[1], -g[0], 0.0},
        {0.0, -g[2], g[1], J[0], J[1], J[2]},
        {g[2], 0.0, -g[0], J[1], J[3], J[4]},
        {-g[1], g[0], 0.0, J[2], J[4], J[5]}};
    int i, j;
    for (i = 0; i < 6; i++)
        for (j = 0; j < 6; j++)
            I6[i][j] = rows[i][j];
}

/* the spatial inertia at the base origin S of a body whose first moment about the point o
 * is hh and inertia about o is io (upper triangle), base axes, mass m: the first moment
 * g = hh + m o and the inertia J = io + (2 o.hh + m |o|^2) 1 - (hh o^T + o hh^T + m o o^T)
 * (upper triangle; the last bracket written g o^T + o hh^T) */
static inline void inertia_at(double m, const double *hh, const double *io, const double *o,
                              double *g, double *J)
{
    double mo[3], dd;
    int i;
    for (i = 0; i < 3; i++)
        mo[i] = m * o[i];
    dd = 2.0 * (o[0] * hh[0] + o[1] * hh[1] + o[2] * hh[2])
         + (mo[0] * o[0] + mo[1] * o[1] + mo[2] * o[2]);
    for (i = 0; i < 3; i++)
        g[i] = hh[i] + mo[i];
    J[0] = io[0] + dd - (g[0] * o[0] + o[0] * hh[0]);
    J[3] = io[3] + dd - (g[1] * o[1] + o[1] * hh[1]);
    J[5] = io[5] + dd - (g[2] * o[2] + o[2] * hh[2]);
    J[1] = io[1] - (g[0] * o[1] + o[0] * hh[1]);
    J[2] = io[2] - (g[0] * o[2] + o[0] * hh[2]);
    J[4] = io[4] - (g[1] * o[2] + o[1] * hh[2]);
}

/* leaf j (body k = n + 1 + j) at its coordinate ql (sn, cs: sine and cosine, a revolute
 * leaf's): its spatial inertia at the base origin S in base axes (first moment g, inertia J
 * by its upper triangle), its joint origin o (revolute: on the axis; prismatic: the centre
 * of mass) and its joint motion S6 at S, [o x a; a] (revolute) or [a; 0] (prismatic) */
static inline void leaf_place(const sr_dyn_model *md, int j, double ql, double sn, double cs,
                              double *g, double *J, double *o, double *S6)
{
    static const double I3[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
    static const double Z3[3] = {0.0, 0.0, 0.0};
    const int k = md->n + 1 + j;
    const double *a = md->axis[j];
    int i;
    if (md->kind[j] == SR_DYN_REVOLUTE) {
        double E[9], hh[3], io[6], s[3];
        const double *h = md->h[k];
        place(md, k, sn, cs, I3, Z3, E, o, s);      /* E = R[k] Rz(q), o = p[k], s = a */
        for (i = 0; i < 3; i++)
            hh[i] = E[3 * i] * h[0] + E[3 * i + 1] * h[1] + E[3 * i + 2] * h[2];
        rot_sym(E, md->J[k], io);
        inertia_at(md->m[k], hh, io, o, g, J);
        joint_motion(o, a, S6);
    } else {                                        /* translated: first moment 0 about o */
        for (i = 0; i < 3; i++) {
            o[i] = md->p[k][i] + a[i] * ql;
            S6[i] = a[i];
            S6[3 + i] = 0.0;
        }
        inertia_at(md->m[k], Z3, md->J[k], o, g, J);
    }
}

/* the motion cross product v x u = [w x u_l + v_l x u_w; w x u_w] */
static inline void crm(const double *v, const double *u, double *o)
{
    o[0] = v[4] * u[2] - v[5] * u[1] + v[1] * u[5] - v[2] * u[4];
    o[1] = v[5] * u[0] - v[3] * u[2] + v[2] * u[3] - v[0] * u[5];
    o[2] = v[3] * u[1] - v[4] * u[0] + v[0] * u[4] - v[1] * u[3];
    o[3] = v[4] * u[5] - v[5] * u[4];
    o[4] = v[5] * u[3] - v[3] * u[5];
    o[5] = v[3] * u[4] - v[4] * u[3];
}

/* I v for the rigid-body inertia I = [[m 1, -[g]x], [[g]x, J]] (g the first moment, J by its
 * upper triangle) and the motion v = [v_l; w]: [m v_l - g x w; g x v_l + J w] */
static inline void rbi_mul(double m, const double *g, const double *J, const double *v, double *o)
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
static inline void crf(const double *v, const double *f, double *o)
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
static inline void base_motion(const sr_dyn_model *md, sr_dyn_data *d, const double *vb, double *v0,
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

/* the algorithms (dynamics_aba.c, dynamics_crba.c) on the base-frame state, and the base's
 * generalised velocity and force of a physical state (dynamics_state.c); qd, tau, qdd: the
 * arm's then the leaves' (n + nl), ql: the leaves' coordinates (nl; NULL without leaves) */
int dyn_aba_core(const sr_dyn_model *md, sr_dyn_data *d, const double *sc, const double *ql,
                 const double *qd, const double *tau, const double *vb, const double *fb,
                 double *ab, double *qdd);
void dyn_terms_core(const sr_dyn_model *md, sr_dyn_data *d, const double *sc, const double *ql,
                    const double *qd, const double *vb, double *M, double *nle, double *hm,
                    double *gm);
void dyn_base_velocity(const sr_dyn_model *md, const double *A, const double *v_S,
                       const double *omega_B, double *vb, double *Ae);
void dyn_base_force(const sr_dyn_model *md, const double *Ae, const double *F,
                    const double *M_S, double *fb);

#endif /* SR_DYNAMICS_INTERNAL_H */
