/* The plant's model, outputs and state (plant.h): sr_plant_model_init with its checks, the
 * output vector at the current state, the state's get / set. The integration is in
 * plant_step.c, the controllers in plant_control.c, the excitation in plant_excitation.c, the
 * propellant in plant_propellant.c, the flexible parts in plant_leaves.c, the tables in
 * plant_params.c.
 */
#include "plant.h"

#include <math.h>
#include <string.h>

#include "body.h"
#include "plant_internal.h"
#include "sr_math.h"
#include "sr_text.h"
#include "vec3.h"

/* the base's DCM from the configuration q (planar: the (cos, sin) pair normalised) */
static void base_dcm(int planar, const double *q, double *A)
{
    if (planar) {
        const double c = q[2], s = q[3], k = 1.0 / sr_hypot(c, s);
        A[0] = c * k; A[1] = -s * k; A[2] = 0.0;
        A[3] = s * k; A[4] = c * k; A[5] = 0.0;
        A[6] = 0.0; A[7] = 0.0; A[8] = 1.0;
    } else {
        quat_dcm(q[3], q[4], q[5], q[6], A);
    }
}

/* body.h's check of the body b named name; the symmetry of b's inertia (3 x 3) checked here,
 * where it becomes body.h's six elements */
static int check_body(const sr_body *b, const char *name, char *err, size_t errlen)
{
    const double *I = b->I;
    const double g[10] = {b->m, b->com[0], b->com[1], b->com[2], I[0], I[4], I[8], I[1], I[2],
                          I[5]};
    if (sr_finite_all(I, 9) && !(I[1] == I[3] && I[2] == I[6] && I[5] == I[7])) {
        sr_text_set(err, errlen, name);
        sr_text_cat(err, errlen, " inertia must be symmetric");
        return 0;
    }
    return sr_body_check(name, g, err, errlen) == 0;
}

/* the model zeroed, why in err (msg; NULL: err holds it already); SR_PLANT_EARG */
static int fail(sr_plant_model *model, char *err, size_t errlen, const char *msg)
{
    memset(model, 0, sizeof(*model));
    if (msg != NULL)
        sr_text_set(err, errlen, msg);
    return SR_PLANT_EARG;
}

SR_API int sr_plant_model_init(sr_plant_model *model, const sr_robot *robot, const sr_body *base,
                               const sr_body *target, const sr_plant_controller *ctrl,
                               const sr_plant_excitation *ex, const sr_plant_propellant *prop,
                               const double *q_home, const double v0[3], const double w0[3],
                               double h, char *err, size_t errlen)
{
    double vb[3], wb[3], I[9];
    int i, j, n, nq;
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (model == NULL) {
        sr_text_set(err, errlen, "model is NULL");
        return SR_PLANT_EARG;
    }
    memset(model, 0, sizeof(*model));
    if (robot == NULL || base == NULL || target == NULL || ctrl == NULL || ex == NULL
        || prop == NULL || v0 == NULL || w0 == NULL)
        return fail(model, err, errlen, "a required argument is NULL");
    if (plant_check_range("h", &h, 1, SR_PLANT_H_MIN, SR_PLANT_H_MAX, "s", err, errlen))
        return fail(model, err, errlen, NULL);
    if (robot->n < 1 || robot->n > SR_MAX_JOINTS || (robot->planar != 0 && robot->planar != 1))
        return fail(model, err, errlen, "robot: joint count or planar flag out of range");
    if (!check_body(base, "base", err, errlen) || !check_body(target, "target", err, errlen)
        || plant_check_range("base.v0", v0, 3, -SR_PLANT_V0_MAX, SR_PLANT_V0_MAX, "m/s", err,
                             errlen)
        || plant_check_range("base.omega0", w0, 3, -SR_PLANT_OMEGA0_MAX, SR_PLANT_OMEGA0_MAX,
                             "rad/s", err, errlen)
        || plant_check_fields(SR_PLANT_TABLE_CONTROLLER, ctrl, err, errlen)
        || plant_check_fields(SR_PLANT_TABLE_EXCITATION, ex, err, errlen)
        || plant_check_fields(SR_PLANT_TABLE_PROPELLANT, prop, err, errlen))
        return fail(model, err, errlen, NULL);
    if (q_home != NULL && !sr_finite_all(q_home, robot->n))
        return fail(model, err, errlen, "q_home must be finite numbers [rad]");
    /* the robot + target on the dry base */
    if (sr_dyn_model_init(&model->dyn, robot, target) != SR_DYN_OK
        || sr_dyn_set_base(&model->dyn, base) != SR_DYN_OK)
        return fail(model, err, errlen, "robot: the record is not a valid robot");
    n = robot->n;
    nq = robot->planar ? 4 + n : 7 + n;
    model->planar = robot->planar;
    model->n = n;
    model->nq0 = robot->planar ? 4 : 7;
    model->nq = nq;
    model->nb = robot->planar ? 3 : 6;
    model->nv = model->nb + n;
    model->nx = 6 + nq + model->nv + 7;
    model->ny = SR_PLANT_NY(n);
    plant_output_offsets(n, model->y_at);
    model->n_att = robot->planar ? 1 : 3;
    model->n_ch = model->n_att + n;
    model->ctrl = *ctrl;
    for (i = 0; i < n; i++)
        model->q_home[i] = q_home != NULL ? q_home[i] : 0.0;
    model->h = h;
    model->ex = *ex;
    /* the propellant's constants: all zero when its model is off */
    model->m0 = prop->m0;
    if (prop->m0 > 0.0) {
        model->pp[0] = 1.0 / (prop->Isp * 9.80665);  /* G0 */
        model->pp[1] = 1.0 / prop->arm;
        model->pp[2] = 0.4 * prop->R * prop->R;
        model->pp[3] = prop->r[0];
        model->pp[4] = prop->r[1];
        model->pp[5] = prop->r[2];
    }
    /* the dry base: [m, b, I6], and at S: m b, I_S = I_c + m (|b|^2 1 - b b^T) */
    model->dry[0] = base->m;
    for (i = 0; i < 3; i++)
        model->dry[1 + i] = base->com[i];
    for (i = 0; i < 9; i++)
        I[i] = base->I[i];
    model->dry[4] = I[0];
    model->dry[5] = I[4];
    model->dry[6] = I[8];
    model->dry[7] = I[1];
    model->dry[8] = I[2];
    model->dry[9] = I[5];
    {
        const double *b = base->com, bb = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
        for (i = 0; i < 3; i++) {
            model->dry_hB[i] = base->m * b[i];
            for (j = 0; j < 3; j++)
                model->dry_IS[3 * i + j] = I[3 * i + j]
                                           + base->m * ((i == j ? bb : 0.0) - b[i] * b[j]);
        }
    }
    /* initial state: base at the origin, identity attitude, arm at q_home at rest */
    for (i = 0; i < 3; i++) {
        vb[i] = v0[i];
        wb[i] = w0[i];
    }
    if (robot->planar) {
        vb[2] = 0.0;
        wb[0] = wb[1] = 0.0;
    }
    {
        double *x = model->x0, *q = x + 6, *v = x + 6 + nq;
        const int nb = model->nb;
        if (robot->planar) {
            q[0] = 0.0; q[1] = 0.0; q[2] = 1.0; q[3] = 0.0;
            v[0] = vb[0]; v[1] = vb[1]; v[2] = wb[2];
        } else {
            for (i = 0; i < 6; i++)
                q[i] = 0.0;
            q[6] = 1.0;
            for (i = 0; i < 3; i++) {
                v[i] = vb[i];                       /* A = 1: v_l = A^T v_S = v_S */
                v[3 + i] = wb[i];
            }
        }
        for (i = 0; i < n; i++) {
            q[nq - n + i] = model->q_home[i];
            v[nb + i] = 0.0;
        }
        x[6 + nq + model->nv] = prop->m0;
    }
    return SR_PLANT_OK;
}

SR_API size_t sr_plant_model_size(void) { return sizeof(sr_plant_model); }
SR_API size_t sr_plant_data_size(void) { return sizeof(sr_plant_data); }
SR_API size_t sr_plant_controller_size(void) { return sizeof(sr_plant_controller); }
SR_API size_t sr_plant_excitation_size(void) { return sizeof(sr_plant_excitation); }
SR_API size_t sr_plant_propellant_size(void) { return sizeof(sr_plant_propellant); }

SR_API int sr_plant_dims(const sr_plant_model *model, int *nq, int *nv, int *nx, int *ny,
                         int *n)
{
    if (!plant_model_ok(model))
        return SR_PLANT_EARG;
    if (nq != NULL)
        *nq = model->nq;
    if (nv != NULL)
        *nv = model->nv;
    if (nx != NULL)
        *nx = model->nx;
    if (ny != NULL)
        *ny = model->ny;
    if (n != NULL)
        *n = model->n;
    return SR_PLANT_OK;
}

SR_API int sr_plant_output_offsets(const sr_plant_model *model, int *offsets)
{
    int k;
    if (!plant_model_ok(model) || offsets == NULL)
        return SR_PLANT_EARG;
    for (k = 0; k <= SR_PLANT_Y_COUNT; k++)
        offsets[k] = model->y_at[k];
    return SR_PLANT_OK;
}

SR_API const char *sr_plant_status_message(int status)
{
    switch (status) {
    case SR_PLANT_OK: return "ok";
    case SR_PLANT_EARG: return "bad argument";
    case SR_PLANT_ENONFINITE: return "the state became non-finite";
    case SR_PLANT_ESINGULAR_BASE: return "singular base inertia";
    case SR_PLANT_ESINGULAR_ARM: return "singular arm inertia";
    case SR_PLANT_ESINGULAR_COUPLING: return "singular attitude coupling";
    case SR_PLANT_ESINGULAR_ABA: return "singular articulated base inertia";
    default: return "unknown status";
    }
}

SR_API int sr_plant_start(const sr_plant_model *model, sr_plant_data *data)
{
    if (!plant_model_ok(model) || data == NULL)
        return SR_PLANT_EARG;
    memset(data, 0, sizeof(*data));
    data->t = 0.0;
    memcpy(data->x, model->x0, sizeof(data->x));
    data->ramp[0] = 0.0;
    data->ramp[1] = 0.0;
    data->ramp[2] = 0.0;
    data->ramp[3] = model->ex.ramp;
    data->dyn = model->dyn;
    data->rigid = model->rigid;
    data->ex_rate[0] = 0.0;                         /* no level requested, the own rate */
    data->ex_rate[2] = 1.0;
    plant_excitation_table(model, 1.0, data);
    return SR_PLANT_OK;
}

SR_API int sr_plant_outputs(const sr_plant_model *model, sr_plant_data *data, double *y)
{
    const sr_plant_model *md = model;
    sr_plant_data *d = data;
    double A[9], r[3], vl[3], w[3], dl[3], al[3], e[3], lev[3];
    const double *x, *q, *v, *acc, *hg, *c;
    int err, i, j, n, nb, nq, nq0, om, ra;
#define Y(id) (y + md->y_at[SR_PLANT_Y_##id])      /* output id in y */
    if (!plant_model_ok(md) || d == NULL || y == NULL)
        return SR_PLANT_EARG;
    n = md->n;
    nb = md->nb;
    nq = md->nq;
    nq0 = md->nq0;
    om = 6 + nq + md->nv;
    x = d->x;
    d->dyn = md->dyn;
    if (md->nl > 0)
        d->rigid = md->rigid;
    d->trig_t = NAN;                                /* the sines evaluated afresh at t */
    plant_load(md, x, d);
    err = plant_control_here(md, d, x, d->t, d->ramp, md->h, 1);
    if (err)
        return err;
    q = x + 6;
    v = x + 6 + nq;
    acc = d->acc;
    hg = d->hg;
    c = d->com;
    /* base pose and motion: A, v_l, omega_B, dv_l/dt, alpha_B (planar: in the plane) */
    base_dcm(md->planar, q, A);
    if (md->planar) {
        r[0] = q[0]; r[1] = q[1]; r[2] = 0.0;
        vl[0] = v[0]; vl[1] = v[1]; vl[2] = 0.0;
        w[0] = 0.0; w[1] = 0.0; w[2] = v[2];
        dl[0] = acc[0]; dl[1] = acc[1]; dl[2] = 0.0;
        al[0] = 0.0; al[1] = 0.0; al[2] = acc[2];
    } else {
        for (i = 0; i < 3; i++) {
            r[i] = q[i];
            vl[i] = v[i];
            w[i] = v[3 + i];
            dl[i] = acc[i];
            al[i] = acc[3 + i];
        }
    }
    /* classical acceleration of S in base axes: dv_l/dt + omega x v_l */
    e[0] = dl[0] + (w[1] * vl[2] - w[2] * vl[1]);
    e[1] = dl[1] + (w[2] * vl[0] - w[0] * vl[2]);
    e[2] = dl[2] + (w[0] * vl[1] - w[1] * vl[0]);
    for (i = 0; i < 3; i++) {
        Y(R_S)[i] = r[i];
        Y(V_S)[i] = A[3 * i] * vl[0] + A[3 * i + 1] * vl[1] + A[3 * i + 2] * vl[2];
        Y(OMEGA_B)[i] = w[i];
        Y(A_S)[i] = A[3 * i] * e[0] + A[3 * i + 1] * e[1] + A[3 * i + 2] * e[2];
        Y(ALPHA_B)[i] = al[i];
    }
    for (i = 0; i < 9; i++)
        Y(A_B)[i] = A[i];
    for (i = 0; i < n; i++) {
        Y(Q)[i] = q[nq0 + i];
        Y(QD)[i] = v[nb + i];
        Y(QDD)[i] = acc[nb + i];
    }
    for (i = 0; i < 3; i++) {
        Y(F)[i] = d->FM[i];
        Y(M)[i] = d->FM[3 + i];
        Y(J)[i] = x[i];
        Y(H)[i] = x[3 + i];
    }
    /* P and L about the inertial origin: L_c + c x P */
    Y(P)[0] = hg[0];
    Y(P)[1] = hg[1];
    Y(P)[2] = hg[2];
    Y(L)[0] = hg[3] + (c[1] * hg[2] - c[2] * hg[1]);
    Y(L)[1] = hg[4] + (c[2] * hg[0] - c[0] * hg[2]);
    Y(L)[2] = hg[5] + (c[0] * hg[1] - c[1] * hg[0]);
    for (i = 0; i < n; i++)
        Y(TAU)[i] = d->gen[nb + i];
    plant_ramp_level(d->t, d->ramp, lev);
    Y(EXCITE)[0] = lev[0];
    ra = md->n_att;
    for (i = 0; i < 3; i++)
        Y(ATT_REF)[i] = 0.0;
    for (i = 0; i < n; i++)
        Y(QD_REF)[i] = 0.0;
    if (d->ramp[0] != 0.0 || d->ramp[1] != 0.0) {
        double f[3], g[3];
        if (!(d->trig_t == d->t)) {
            plant_fill_trig(md, d, d->t, d->trig);
            d->trig_t = d->t;
        }
        for (j = 0; j < ra; j++) {                  /* planar: the z axis */
            plant_channel(d->ex_tab[j], d->trig[j], f);
            plant_level_times(lev, f, g);
            Y(ATT_REF)[3 - ra + j] = g[0];
        }
        for (i = 0; i < n; i++) {
            plant_channel(d->ex_tab[ra + i], d->trig[ra + i], f);
            plant_level_times(lev, f, g);
            Y(QD_REF)[i] = g[1];
        }
    }
    Y(M_P)[0] = x[om];
    for (i = 0; i < 3; i++) {
        Y(P_X)[i] = x[om + 1 + i];
        Y(L_X)[i] = x[om + 4 + i];
    }
    Y(EXCITE_RATE)[0] = d->ex_rate[1];
    for (i = 0; i < 3; i++) {
        Y(FLEX_P)[i] = 0.0;
        Y(FLEX_L)[i] = 0.0;
    }
    for (i = 0; i < SR_PLANT_MAX_FLEX; i++)
        Y(FLEX_Q)[i] = Y(FLEX_QD)[i] = 0.0;
    for (i = 0; i < SR_PLANT_MAX_SLOSH; i++)
        Y(SLOSH_X)[i] = Y(SLOSH_V)[i] = 0.0;
    if (md->nl == 0) {
        plant_base_now(md, x[om], Y(BASE_NOW));
    } else {
        const double *hr = d->hg_r, *cr = d->com_r;
        double Lr[3];
        plant_composite_now(md, x[om], Y(BASE_NOW));
        /* the flexible parts' momentum: the system's minus the composite rigid body's at the
         * same base and arm motion (both L about the inertial origin: L_c + c x P) */
        Lr[0] = hr[3] + (cr[1] * hr[2] - cr[2] * hr[1]);
        Lr[1] = hr[4] + (cr[2] * hr[0] - cr[0] * hr[2]);
        Lr[2] = hr[5] + (cr[0] * hr[1] - cr[1] * hr[0]);
        for (i = 0; i < 3; i++) {
            Y(FLEX_P)[i] = Y(P)[i] - hr[i];
            Y(FLEX_L)[i] = Y(L)[i] - Lr[i];
        }
        for (i = 0; i < md->n_flex; i++) {
            Y(FLEX_Q)[i] = q[nq0 + n + i];
            Y(FLEX_QD)[i] = v[nb + n + i];
        }
        for (i = 0; i < md->n_slosh; i++) {
            Y(SLOSH_X)[i] = q[nq0 + n + md->n_flex + i];
            Y(SLOSH_V)[i] = v[nb + n + md->n_flex + i];
        }
    }
    return sr_finite_all(y, md->ny) ? SR_PLANT_OK : SR_PLANT_ENONFINITE;
#undef Y
}

SR_API int sr_plant_get_state(const sr_plant_model *model, const sr_plant_data *data, double *t,
                              double *x, double *ex)
{
    int j;
    if (!plant_model_ok(model) || data == NULL)
        return SR_PLANT_EARG;
    if (t != NULL)
        *t = data->t;
    for (j = 0; x != NULL && j < model->nx; j++)
        x[j] = data->x[j];
    for (j = 0; ex != NULL && j < 4; j++)
        ex[j] = data->ramp[j];
    for (j = 0; ex != NULL && j < 3; j++)
        ex[4 + j] = data->ex_rate[j];
    return SR_PLANT_OK;
}

SR_API int sr_plant_set_state(const sr_plant_model *model, sr_plant_data *data, double t,
                              const double *x, const double *ex, char *err, size_t errlen)
{
    double rp[SR_PLANT_EXCITE_STATE], nrm, mp;
    const double *qb;
    int j, om;
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (!plant_model_ok(model) || data == NULL || x == NULL) {
        sr_text_set(err, errlen, "model, data or x is NULL or not initialised");
        return SR_PLANT_EARG;
    }
    if (!isfinite(t)) {
        sr_text_set(err, errlen, "state time must be finite");
        return SR_PLANT_EARG;
    }
    if (ex != NULL) {
        for (j = 0; j < SR_PLANT_EXCITE_STATE; j++)
            rp[j] = ex[j];
    } else {
        rp[0] = rp[1] = rp[2] = rp[4] = 0.0;
        rp[3] = model->ex.ramp;
        rp[5] = rp[6] = 1.0;
    }
    if (!sr_finite_all(rp, SR_PLANT_EXCITE_STATE) || !(rp[3] > 0.0)
        || !(rp[0] >= 0.0 && rp[0] <= 1.0) || !(rp[1] >= 0.0 && rp[1] <= 1.0)
        || !(rp[4] >= 0.0 && rp[4] <= 1.0)) {
        sr_text_set(err, errlen, "excitation state must be finite numbers [s0, u, t0, T > 0, level "
                    "requested, rate in effect, rate requested] with the levels in [0, 1]");
        return SR_PLANT_EARG;
    }
    for (j = 5; j < 7; j++)
        if (!(rp[j] >= SR_PLANT_RATE_MIN && rp[j] <= SR_PLANT_RATE_MAX)) {
            sr_text_format(err, errlen, "excitation state: the rates must be in [%g, %g]",
                           SR_PLANT_RATE_MIN, SR_PLANT_RATE_MAX);
            return SR_PLANT_EARG;
        }
    if (!sr_finite_all(x, model->nx)) {
        sr_text_set(err, errlen, "state x must be finite");
        return SR_PLANT_EARG;
    }
    qb = x + 6 + (model->planar ? 2 : 3);
    nrm = model->planar ? sqrt(qb[0] * qb[0] + qb[1] * qb[1])
                        : sqrt(qb[0] * qb[0] + qb[1] * qb[1] + qb[2] * qb[2] + qb[3] * qb[3]);
    if (!(fabs(nrm - 1.0) <= 1e-6)) {
        sr_text_set(err, errlen, "state q: the base quaternion (or planar cos/sin pair) is not of "
                    "unit norm");
        return SR_PLANT_EARG;
    }
    om = 6 + model->nq + model->nv;
    mp = x[om];
    if (!(mp >= model->m_slosh && mp <= model->m0 * (1.0 + 1e-12))) {
        sr_text_set(err, errlen, model->m_slosh > 0.0
                    ? "propellant mass outside [the slosh masses, prop.m0]"
                    : "propellant mass outside [0, prop.m0]");
        return SR_PLANT_EARG;
    }
    data->t = t;
    for (j = 0; j < model->nx; j++)
        data->x[j] = x[j];
    for (j = 0; j < 4; j++)
        data->ramp[j] = rp[j];
    data->ex_rate[0] = rp[4];
    data->ex_rate[2] = rp[6];
    plant_excitation_table(model, rp[5], data);
    return SR_PLANT_OK;
}
