/* The rigid-body model of the free-floating robot (dynamics.h): the base and the links in their
 * joint frames with their spatial inertias, built from the robot record and the captured target;
 * the base replaced (the plant's propellant). The algorithms on the model: dynamics_aba.c
 * (forward dynamics), dynamics_crba.c (joint-space inertia, non-linear effects, momentum),
 * dynamics_state.c (the physical state's view).
 *
 * Source of the equations: R. Featherstone, Rigid Body Dynamics Algorithms (RBDA), Springer
 * 2008, in Pinocchio's conventions (spatial motion and force [linear; angular]).
 */
#include "dynamics.h"

#include <math.h>
#include <string.h>

#include "dynamics_internal.h"

/* Q (3 x 3) whose third column is the unit vector along a: the joint frame in which the axis a
 * (link frame) is z. The identity and exact permutations for the z, x and y axes, otherwise
 * two orthonormal vectors completing a. */
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
        if (!sr_finite_all(robot->xyz[k], 3) || !sr_finite_all(robot->R[k], 9)
            || !sr_finite_all(ax, 3)
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
                T[3 * i + j] = Rj[3 * i] * Q[j] + Rj[3 * i + 1] * Q[3 + j]
                               + Rj[3 * i + 2] * Q[6 + j];
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

SR_API int sr_dyn_add_leaf(sr_dyn_model *model, int kind, const double point[3],
                           const double axis[3], const sr_body *body)
{
    double a[3], nrm, h[3], Io[9], rel[3];
    int i, k, j;
    if (!dyn_model_ok(model) || model->nl >= SR_DYN_MAX_LEAVES || axis == NULL || body == NULL
        || (kind != SR_DYN_REVOLUTE && kind != SR_DYN_PRISMATIC)
        || (kind == SR_DYN_REVOLUTE && (point == NULL || !sr_finite_all(point, 3)))
        || !sr_finite_all(axis, 3) || !body_ok(body, 0))
        return SR_DYN_EARG;
    nrm = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    if (!(nrm > 0.0))
        return SR_DYN_EARG;
    for (i = 0; i < 3; i++)
        a[i] = axis[i] / nrm;
    j = model->nl;
    k = model->n + 1 + j;
    model->kind[j] = kind;
    memcpy(model->axis[j], a, sizeof(a));
    model->m[k] = body->m;
    if (kind == SR_DYN_REVOLUTE) {
        /* in the joint frame Q (z along the axis) at the point: x_B = Q x_joint + point */
        z_frame(a, model->Q[k]);
        memcpy(model->R[k], model->Q[k], 9 * sizeof(double));
        for (i = 0; i < 3; i++) {
            model->p[k][i] = point[i];
            rel[i] = body->com[i] - point[i];
        }
        body_at_origin(body->m, rel, body->I, h, Io);
        to_joint_frame(model->Q[k], Io, h, model->J[k], model->h[k]);
    } else {
        /* base axes at its centre of mass at rest: first moment 0, the inertia about it */
        static const double I3[9] = {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0};
        static const double Z3[3] = {0.0, 0.0, 0.0};
        memcpy(model->Q[k], I3, sizeof(I3));
        memcpy(model->R[k], I3, sizeof(I3));
        for (i = 0; i < 3; i++)
            model->p[k][i] = body->com[i];
        to_joint_frame(I3, body->I, Z3, model->J[k], model->h[k]);
    }
    model->nl = j + 1;
    model->nq += 1;
    model->nv += 1;
    return SR_DYN_OK;
}

SR_API int sr_dyn_arm_sincos(const sr_dyn_model *model, const double *q_arm, double *sc)
{
    if (!dyn_model_ok(model) || q_arm == NULL || sc == NULL)
        return SR_DYN_EARG;
    dyn_arm_sincos(model, q_arm, sc);
    return SR_DYN_OK;
}
