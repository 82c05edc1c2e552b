/* The plant's integration (plant.h): classic RK4 at the internal step h with the controls held
 * over each step.
 *
 * One step path: sr_plant_advance -> step() per internal step: the rigid-body terms at the
 * step's start feed the controllers (zero-order hold; their inverse dynamics give the first
 * stage's accelerations), the articulated-body algorithm those of stages 2-4, stage() the RK4
 * bookkeeping. Everything runs on a working copy of the state that is committed only when
 * every step succeeded and the state reached is finite. */
#include <math.h>
#include <string.h>

#include "plant_internal.h"
#include "sr_math.h"
#include "vec3.h"

/* most internal steps one call of sr_plant_advance takes */
#define MAX_STEPS 1e9

/* the normalised configuration (unit quaternion / (cos, sin) pair) and the velocity of the
 * state x into d->qn, d->vs */
void plant_load(const sr_plant_model *md, const double *x, sr_plant_data *d)
{
    const int nq = md->nq, nv = md->nv;
    double *qn = d->qn, nrm;
    int j;
    for (j = 0; j < nq; j++)
        qn[j] = x[6 + j];
    for (j = 0; j < nv; j++)
        d->vs[j] = x[6 + nq + j];
    if (md->planar) {
        nrm = sqrt(qn[2] * qn[2] + qn[3] * qn[3]);
        qn[2] /= nrm;
        qn[3] /= nrm;
    } else {
        nrm = sqrt(qn[3] * qn[3] + qn[4] * qn[4] + qn[5] * qn[5] + qn[6] * qn[6]);
        for (j = 3; j < 7; j++)
            qn[j] /= nrm;
    }
}

/* RK4 stage i (0..3) of a step of dt from x. xa: the stage state where a
 * (= dv/dt) was evaluated (x itself for stage 0, else d->xs). Writes d->K[i]; for i < 3 the
 * next stage state d->xs with its normalised configuration d->qn, d->vs and the held thrust in
 * its base coordinates d->gen[0..nb) (the joint torques are held); for i = 3 the new state
 * d->xn (unit quaternion / (cos, sin) restored) and d->qn, d->vs of it.
 * State derivative: [dJ = F, dH = M + r_S x F, dq/dt, dv/dt = a, propellant rows]. */
static void stage(const sr_plant_model *md, sr_plant_data *d, int i, const double *x,
                  const double *xa, const double *a, double dt)
{
    const int nq = md->nq, nv = md->nv, nx = md->nx, nb = md->nb, oq = 6, ov = 6 + nq;
    const double *FM = d->FM;
    const double F0 = FM[0], F1 = FM[1], F2 = FM[2], M0 = FM[3], M1 = FM[4], M2 = FM[5];
    double *row = d->K[i], *target, *qn = d->qn, A[9];
    int j, nsc;
    row[0] = F0;                                    /* dJ = F */
    row[1] = F1;
    row[2] = F2;
    if (md->planar) {
        const double px = xa[oq], py = xa[oq + 1], c = xa[oq + 2], s = xa[oq + 3];
        const double vx = xa[ov], vy = xa[ov + 1], wz = xa[ov + 2];
        const double k = 1.0 / sr_hypot(c, s), cn = c * k, sn = s * k;
        A[0] = cn; A[1] = -sn; A[2] = 0.0;         /* base_dcm's */
        A[3] = sn; A[4] = cn; A[5] = 0.0;
        A[6] = 0.0; A[7] = 0.0; A[8] = 1.0;
        row[3] = M0 + py * F2;                      /* dH = M + r_S x F */
        row[4] = M1 - px * F2;
        row[5] = M2 + (px * F1 - py * F0);
        row[6] = cn * vx - sn * vy;                 /* dr_S/dt = A v_l */
        row[7] = sn * vx + cn * vy;
        row[8] = -s * wz;                           /* d(cos, sin)/dt */
        row[9] = c * wz;
        nsc = 10;
    } else {
        const double rx = xa[oq], ry = xa[oq + 1], rz = xa[oq + 2];
        const double x_ = xa[oq + 3], y_ = xa[oq + 4], z_ = xa[oq + 5], w_ = xa[oq + 6];
        const double vx = xa[ov], vy = xa[ov + 1], vz = xa[ov + 2];
        const double wx = xa[ov + 3], wy = xa[ov + 4], wz = xa[ov + 5];
        if (i > 0)                                  /* xa = d->xs: the last stage's DCM */
            memcpy(A, d->A_s, sizeof(A));
        else
            quat_dcm(x_, y_, z_, w_, A);
        row[3] = M0 + (ry * F2 - rz * F1);          /* dH = M + r_S x F */
        row[4] = M1 + (rz * F0 - rx * F2);
        row[5] = M2 + (rx * F1 - ry * F0);
        row[6] = A[0] * vx + A[1] * vy + A[2] * vz;   /* dr_S/dt = A v_l */
        row[7] = A[3] * vx + A[4] * vy + A[5] * vz;
        row[8] = A[6] * vx + A[7] * vy + A[8] * vz;
        row[9] = 0.5 * (w_ * wx + y_ * wz - z_ * wy);  /* quaternion kinematics */
        row[10] = 0.5 * (w_ * wy + z_ * wx - x_ * wz);
        row[11] = 0.5 * (w_ * wz + x_ * wy - y_ * wx);
        row[12] = -0.5 * (x_ * wx + y_ * wy + z_ * wz);
        nsc = 13;
    }
    for (j = nsc; j < ov; j++)                      /* dq_arm/dt = qd */
        row[j] = xa[ov + nb + j - nsc];
    for (j = 0; j < nv; j++)                        /* dv/dt */
        row[ov + j] = a[j];
    plant_propellant_rates(md, xa, A, FM[6], row);
    if (i < 3) {
        const double f = i == 2 ? dt : 0.5 * dt;
        for (j = 0; j < nx; j++)
            d->xs[j] = x[j] + f * row[j];
        target = d->xs;
    } else {
        const double f = dt / 6.0;
        for (j = 0; j < nx; j++)
            d->xn[j] = x[j] + f * (d->K[0][j] + 2.0 * d->K[1][j] + 2.0 * d->K[2][j] + d->K[3][j]);
        target = d->xn;
    }
    /* normalised configuration of the new state (and the unit constraint for x_{n+1}) */
    for (j = 0; j < nq; j++)
        qn[j] = target[oq + j];
    for (j = 0; j < nv; j++)
        d->vs[j] = target[ov + j];
    if (md->planar) {
        const double c = target[oq + 2], s = target[oq + 3], nrm = sqrt(c * c + s * s);
        qn[2] = c / nrm;
        qn[3] = s / nrm;
        if (i == 3) {
            d->xn[oq + 2] = qn[2];
            d->xn[oq + 3] = qn[3];
        } else {
            const double k = 1.0 / sr_hypot(c, s), cn = c * k, sn = s * k;
            d->gen[0] = cn * F0 + sn * F1;
            d->gen[1] = -sn * F0 + cn * F1;
            d->gen[2] = M2;
        }
    } else {
        const double x_ = target[oq + 3], y_ = target[oq + 4], z_ = target[oq + 5],
                     w_ = target[oq + 6];
        const double nrm = sqrt(x_ * x_ + y_ * y_ + z_ * z_ + w_ * w_);
        qn[3] = x_ / nrm;
        qn[4] = y_ / nrm;
        qn[5] = z_ / nrm;
        qn[6] = w_ / nrm;
        if (i == 3) {
            for (j = 0; j < 4; j++)
                d->xn[oq + 3 + j] = qn[3 + j];
        } else {
            quat_dcm(x_, y_, z_, w_, A);            /* kept for the next stage (at d->xs) */
            memcpy(d->A_s, A, sizeof(A));
            for (j = 0; j < 3; j++) {               /* A^T F, A^T M of this stage */
                d->gen[j] = A[j] * F0 + A[3 + j] * F1 + A[6 + j] * F2;
                d->gen[3 + j] = A[j] * M0 + A[3 + j] * M1 + A[6 + j] * M2;
            }
        }
    }
}

/* the sines and cosines sc (n x 2) of the joint angles q (n) from those sc0 of the nearby
 * angles q0 (n) by the angle-addition formulas: sin(q0 + e) = s0 + (c0 e + (s0 (cos e - 1) +
 * c0 (sin e - e))), cos likewise, cos e - 1 and sin e - e by their Taylor polynomials
 * (truncation below 2^-55 relative for |e| <= 2^-5; e = q - q0 exact or nearly (Sterbenz)).
 * Within about 1 ulp of sr_sincos's correctly rounded values (not always the same bits: no
 * error accumulates, q0 is always an anchor), at a fraction of the cost; sr_sincos itself
 * for a larger e (a joint faster than 2^-5 rad per SR_PLANT_JOINT_ANCHOR steps). */
static void step_sincos(int n, const double *q0, const double *sc0, const double *q, double *sc)
{
    /* 1/3!, 1/5!, 1/7!, 1/9!; 1/4!, 1/6!, 1/8! (correctly rounded) */
    static const double S3 = 0x1.5555555555555p-3, S5 = 0x1.1111111111111p-7,
                        S7 = 0x1.a01a01a01a01ap-13, S9 = 0x1.71de3a556c734p-19,
                        C4 = 0x1.5555555555555p-5, C6 = 0x1.6c16c16c16c17p-10,
                        C8 = 0x1.a01a01a01a01ap-16;
    int k;
    for (k = 0; k < n; k++) {
        const double e = q[k] - q0[k], s0 = sc0[2 * k], c0 = sc0[2 * k + 1];
        double z, s3, cm;
        if (!(fabs(e) <= 0x1.0p-5)) {
            sr_sincos(q[k], &sc[2 * k], &sc[2 * k + 1]);
            continue;
        }
        z = e * e;
        s3 = e * (z * (-S3 + z * (S5 + z * (-S7 + z * S9))));    /* sin e - e */
        cm = z * (-0.5 + z * (C4 + z * (-C6 + z * C8)));          /* cos e - 1 */
        sc[2 * k] = s0 + (c0 * e + (s0 * cm + c0 * s3));
        sc[2 * k + 1] = c0 + (-(s0 * e) + (c0 * cm - s0 * s3));
    }
}

/* the sines and cosines of the arm's (and the leaves') coordinates of d->qn into d->sc:
 * sr_sincos's (correctly rounded) when anchor is set, which makes d->qn the anchor (d->q_anc,
 * d->sc_anc), else stepped from the anchor's (step_sincos); a slosh stroke's are not used */
static void joint_sincos(const sr_plant_model *md, sr_plant_data *d, int anchor)
{
    const double *qa = d->qn + md->nq0;
    const int nc = md->n + md->nl;
    int k;
    if (anchor) {
        for (k = 0; k < nc; k++) {
            sr_sincos(qa[k], &d->sc_anc[2 * k], &d->sc_anc[2 * k + 1]);
            d->q_anc[k] = qa[k];
        }
        for (k = 0; k < 2 * nc; k++)
            d->sc[k] = d->sc_anc[k];
    } else {
        step_sincos(nc, d->q_anc, d->sc_anc, qa, d->sc);
    }
}

/* the rigid-body terms and the controls at the state x (time t) for a step of dt, x's
 * configuration already in d->qn, d->vs: d->M, nle, hg, com, gen, acc, FM (with flexible
 * parts also the composite rigid body's terms d->Mr, nle_r, hg_r, com_r at the same base and
 * arm state: the prefix of q, v); the joint placements' sines and cosines as joint_sincos
 * (anchor: afresh) */
int plant_control_here(const sr_plant_model *md, sr_plant_data *d, const double *x, double t,
                        const double *ramp, double dt, int anchor)
{
    const int om = 6 + md->nq + md->nv;
    if (plant_base_inertia(md, d, x[om]) != SR_PLANT_OK)
        return SR_PLANT_ENONFINITE;
    joint_sincos(md, d, anchor);
    if (sr_dyn_terms_sc(&d->dyn, &d->dd, d->qn, d->vs, d->sc, d->M, d->nle, d->hg, d->com)
        != SR_DYN_OK)
        return SR_PLANT_EARG;
    if (md->nl > 0) {
        if (sr_dyn_terms_sc(&d->rigid, &d->dd, d->qn, d->vs, d->sc, d->Mr, d->nle_r, d->hg_r,
                            d->com_r) != SR_DYN_OK)
            return SR_PLANT_EARG;
        plant_leaf_forces(md, d);
    }
    return plant_thrust_control(md, d, t, ramp, x[om], dt);
}

/* one RK4 step of dt from d->xa (configuration in d->qn, d->vs) at t into d->xn, the controls
 * of its start held over it. The joint placements' sines and
 * cosines: sr_sincos at the start of an anchor step, stepped from those at every other
 * stage (joint_sincos) */
static int step(const sr_plant_model *md, sr_plant_data *d, double t, double dt, int anchor)
{
    const int om = 6 + md->nq + md->nv;
    int err, i;
    err = plant_control_here(md, d, d->xa, t, d->ramp, dt, anchor);
    if (err)
        return err;
    stage(md, d, 0, d->xa, d->xa, d->acc, dt);
    for (i = 1; i < 4; i++) {
        if (plant_base_inertia(md, d, d->xs[om]) != SR_PLANT_OK)
            return SR_PLANT_ENONFINITE;
        joint_sincos(md, d, 0);
        plant_leaf_forces(md, d);
        err = sr_dyn_aba_sc(&d->dyn, &d->dd, d->qn, d->vs, d->gen, d->sc, d->ddq);
        if (err == SR_DYN_EPD)
            return SR_PLANT_ESINGULAR_ABA;
        if (err)
            return SR_PLANT_EARG;
        stage(md, d, i, d->xa, d->xs, d->ddq, dt);
    }
    return SR_PLANT_OK;
}

SR_API int sr_plant_advance(const sr_plant_model *model, sr_plant_data *data, double dt)
{
    const sr_plant_model *md = model;
    sr_plant_data *d = data;
    double steps, rest, t;
    long k, n, total;
    int err, j, nx, excited;
    if (!plant_model_ok(md) || d == NULL || !(dt > 0.0 && isfinite(dt)))
        return SR_PLANT_EARG;
    steps = floor(dt / md->h + 1e-9);
    if (!(steps <= MAX_STEPS))
        return SR_PLANT_EARG;
    n = (long)steps;
    rest = dt - steps * md->h;
    if (rest < 1e-9 * md->h)
        rest = 0.0;
    total = n + (rest > 0.0 ? 1 : 0);
    nx = md->nx;
    d->dyn = md->dyn;
    if (md->nl > 0)
        d->rigid = md->rigid;
    plant_excitation_update(md, d);                       /* a pending rate whose dip has ended */
    /* work on a copy: d->x, d->t change only when every step succeeded */
    for (j = 0; j < nx; j++)
        d->xa[j] = d->x[j];
    t = d->t;
    excited = d->ramp[0] != 0.0 || d->ramp[1] != 0.0;
    d->trig_t = NAN;                                /* evaluated afresh at the first step */
    plant_load(md, d->xa, d);
    for (k = 0; k < total; k++) {
        const double h = k < n ? md->h : rest, t_prev = t;
        err = step(md, d, t, h, k % SR_PLANT_JOINT_ANCHOR == 0);
        if (err)
            return err;
        if (!sr_finite_all(d->xn, nx))
            return SR_PLANT_ENONFINITE;
        if (d->xn[6 + md->nq + md->nv] < md->m_slosh)  /* an emptied tank: round-off below */
            d->xn[6 + md->nq + md->nv] = md->m_slosh;
        for (j = 0; j < nx; j++)                    /* stage() left xn's configuration in qn */
            d->xa[j] = d->xn[j];
        t += h;
        /* the next step's sines from this step's, rotated by h */
        if (excited && d->trig_t == t_prev && h == md->h
            && (k + 1) % SR_PLANT_TRIG_ANCHOR != 0) {
            plant_rotate_trig(md, d);
            d->trig_t = t;
        } else {
            d->trig_t = NAN;
        }
    }
    if (!isfinite(t))
        return SR_PLANT_ENONFINITE;
    for (j = 0; j < nx; j++)
        d->x[j] = d->xa[j];
    d->t = t;
    return SR_PLANT_OK;
}

SR_API int sr_plant_controls(const sr_plant_model *model, sr_plant_data *data, double *F,
                             double *M, double *tau, double *a, double *flow)
{
    int err, i;
    if (!plant_model_ok(model) || data == NULL)
        return SR_PLANT_EARG;
    data->dyn = model->dyn;
    if (model->nl > 0)
        data->rigid = model->rigid;
    data->trig_t = NAN;
    plant_load(model, data->x, data);
    err = plant_control_here(model, data, data->x, data->t, data->ramp, model->h, 1);
    if (err)
        return err;
    for (i = 0; i < 3; i++) {
        if (F != NULL)
            F[i] = data->FM[i];
        if (M != NULL)
            M[i] = data->FM[3 + i];
    }
    for (i = 0; i < model->n && tau != NULL; i++)
        tau[i] = data->gen[model->nb + i];
    for (i = 0; i < model->nv && a != NULL; i++)
        a[i] = data->acc[i];
    if (flow != NULL)
        *flow = data->FM[6];
    return SR_PLANT_OK;
}
