/* The plant's flexible parts (plant.h): hinged panels with torsional springs and dampers and
 * spring-mass propellant slosh modes, added to the model as leaves of the base
 * (sr_plant_model_set_leaves); their spring and damper forces; the composite rigid base they
 * make at rest (the truth a rigid-model estimator should converge to).
 *
 * A panel: k = I_h w^2, c = 2 zeta w I_h, w = 2 pi f, I_h = a^T (I_c + m S(c - p)) a its
 * inertia about the hinge axis (a through p), S(d) = |d|^2 1 - d d^T: f is the frequency of
 * the panel alone on a base held fixed (cantilevered). A slosh mode: k = m w^2,
 * c = 2 zeta w m (Abramson, NASA SP-106, the spring-mass equivalent of one lateral mode).
 */
#include <math.h>
#include <string.h>

#include "body.h"
#include "plant_internal.h"
#include "sr_math.h"
#include "sr_text.h"

#define TWO_PI 6.283185307179586

/* the model zeroed, SR_PLANT_EARG (the message is in err) */
static int refuse(sr_plant_model *model)
{
    memset(model, 0, sizeof(*model));
    return SR_PLANT_EARG;
}

/* 0 when the count n is within [0, max], else 1 with "<name> must be within [0, max], got n" */
static int check_count(const char *name, int n, int max, char *err, size_t errlen)
{
    if (n >= 0 && n <= max)
        return 0;
    sr_text_format(err, errlen, "%s must be within [0, %d], got %d", name, max, n);
    return 1;
}

/* 0 when the axis a (3) of record i of table is not zero and, on a planar robot, keeps the
 * motion in the plane (planar_z: the axis must be along z, else in x-y); else 1 with why */
static int check_axis(int table, int i, const double *a, int planar, int planar_z, char *err,
                      size_t errlen)
{
    char name[64];
    plant_field_name(table, "axis", i, -1, name, sizeof name);
    if (!(a[0] != 0.0 || a[1] != 0.0 || a[2] != 0.0)) {
        sr_text_set(err, errlen, name);
        sr_text_cat(err, errlen, " must not be zero");
        return 1;
    }
    if (planar && (planar_z ? (a[0] != 0.0 || a[1] != 0.0) : a[2] != 0.0)) {
        sr_text_set(err, errlen, name);
        sr_text_cat(err, errlen, planar_z ? ": a planar robot's panels turn in its plane: the "
                                            "hinge axis must be along z, got "
                                          : ": a planar robot's slosh masses move in its plane: "
                                            "the axis must have no z component, got ");
        sr_text_vec(err, errlen, a, 3);
        return 1;
    }
    return 0;
}

/* 0 when 2 pi f h is within SR_PLANT_STEP_PHASE_MAX for the frequency f of record i of table,
 * else 1 with why */
static int check_step(int table, int i, double f, double h, char *err, size_t errlen)
{
    char name[64];
    if (TWO_PI * f * h <= SR_PLANT_STEP_PHASE_MAX)
        return 0;
    plant_field_name(table, "f", i, -1, name, sizeof name);
    sr_text_set(err, errlen, name);
    sr_text_cat(err, errlen, " = ");
    sr_text_repr(err, errlen, f);
    sr_text_cat(err, errlen, " Hz is too fast for the step h = ");
    sr_text_repr(err, errlen, h);
    sr_text_cat(err, errlen, " s: 2 pi f h must be at most ");
    sr_text_num(err, errlen, SR_PLANT_STEP_PHASE_MAX, 6);
    sr_text_cat(err, errlen, " (lower h or f)");
    return 1;
}

/* a panel's body (mass, centre of mass, inertia 3 x 3 about it, base axes at rest) */
static void panel_body(const sr_plant_panel *p, sr_body *b)
{
    b->m = p->m;
    memcpy(b->com, p->com, sizeof(b->com));
    b->I[0] = p->Ixx; b->I[1] = p->Ixy; b->I[2] = p->Ixz;
    b->I[3] = p->Ixy; b->I[4] = p->Iyy; b->I[5] = p->Iyz;
    b->I[6] = p->Ixz; b->I[7] = p->Iyz; b->I[8] = p->Izz;
}

/* the checks of the parts in use (ranges are checked for every record before) */
static int check_parts(const sr_plant_model *md, int n_flex, const sr_plant_panel *flex,
                       int n_slosh, const sr_plant_slosh *slosh, char *err, size_t errlen)
{
    double total = 0.0;
    int i;
    for (i = 0; i < n_flex; i++) {
        const sr_plant_panel *p = &flex[i];
        const double g[10] = {p->m, p->com[0], p->com[1], p->com[2], p->Ixx, p->Iyy, p->Izz,
                              p->Ixy, p->Ixz, p->Iyz};
        char name[32];
        sr_text_format(name, sizeof name, "flex[%d]", i + 1);
        if (sr_body_check(name, g, err, errlen) != 0
            || check_axis(SR_PLANT_TABLE_FLEX, i, p->axis, md->planar, 1, err, errlen)
            || check_step(SR_PLANT_TABLE_FLEX, i, p->f, md->h, err, errlen))
            return 1;
    }
    for (i = 0; i < n_slosh; i++) {
        if (check_axis(SR_PLANT_TABLE_SLOSH, i, slosh[i].axis, md->planar, 0, err, errlen)
            || check_step(SR_PLANT_TABLE_SLOSH, i, slosh[i].f, md->h, err, errlen))
            return 1;
        total += slosh[i].m;
    }
    if (md->m0 > 0.0 && total > md->m0) {
        sr_text_set(err, errlen, "slosh.m: the slosh masses in use total ");
        sr_text_num(err, errlen, total, 10);
        sr_text_cat(err, errlen, " kg, more than the propellant prop.m0 = ");
        sr_text_num(err, errlen, md->m0, 10);
        sr_text_cat(err, errlen, " kg (with a propellant model they are part of it)");
        return 1;
    }
    return 0;
}

/* leaf j of the model: the body b added on its joint, its spring and damper from the
 * frequency f [Hz], the damping ratio zeta and its inertia along the joint (I_h or m), its
 * rest inertia added to the model's sum */
static int add_leaf(sr_plant_model *md, int kind, const double *point, const double *axis,
                    const sr_body *b, double f, double zeta)
{
    const int j = md->dyn.nl;
    const double w = TWO_PI * f, *c = b->com;
    const double cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    double a[3], nrm, inertia, S[9];
    int i, k;
    if (sr_dyn_add_leaf(&md->dyn, kind, point, axis, b) != SR_DYN_OK)
        return 1;
    nrm = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    for (i = 0; i < 3; i++)
        a[i] = axis[i] / nrm;
    if (kind == SR_DYN_REVOLUTE) {
        /* I_h = a^T (I_c + m S(c - p)) a */
        double dv[3], dd;
        for (i = 0; i < 3; i++)
            dv[i] = c[i] - point[i];
        dd = dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2];
        for (i = 0; i < 3; i++)
            for (k = 0; k < 3; k++)
                S[3 * i + k] = b->I[3 * i + k] + b->m * ((i == k ? dd : 0.0) - dv[i] * dv[k]);
        inertia = 0.0;
        for (i = 0; i < 3; i++)
            inertia += a[i] * (S[3 * i] * a[0] + S[3 * i + 1] * a[1] + S[3 * i + 2] * a[2]);
    } else {
        inertia = b->m;
    }
    md->k_leaf[j] = inertia * w * w;
    md->c_leaf[j] = 2.0 * zeta * w * inertia;
    /* at rest: m, m c, I_c + m S(c) about S */
    md->rest_m += b->m;
    for (i = 0; i < 3; i++) {
        md->rest_hB[i] += b->m * c[i];
        for (k = 0; k < 3; k++)
            md->rest_IS[3 * i + k] += b->I[3 * i + k] + b->m * ((i == k ? cc : 0.0) - c[i] * c[k]);
    }
    return 0;
}

SR_API int sr_plant_model_set_leaves(sr_plant_model *model, int n_flex,
                                     const sr_plant_panel *flex, int n_slosh,
                                     const sr_plant_slosh *slosh, char *err, size_t errlen)
{
    sr_plant_model *md = model;
    double x0[SR_PLANT_MAX_NX], hB[3], IS[9], m;
    int i, nl, nq_old, nv_old;
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (!plant_model_ok(md) || md->nl != 0) {
        sr_text_set(err, errlen, "model is NULL, not initialised, or has its flexible parts");
        return SR_PLANT_EARG;
    }
    if (check_count("flex.n", n_flex, SR_PLANT_MAX_FLEX, err, errlen)
        || check_count("slosh.n", n_slosh, SR_PLANT_MAX_SLOSH, err, errlen))
        return refuse(md);
    if ((n_flex > 0 && flex == NULL) || (n_slosh > 0 && slosh == NULL)) {
        sr_text_set(err, errlen, "the records of the flexible parts in use are NULL");
        return refuse(md);
    }
    for (i = 0; flex != NULL && i < SR_PLANT_MAX_FLEX; i++)
        if (plant_check_record(SR_PLANT_TABLE_FLEX, i, &flex[i], err, errlen))
            return refuse(md);
    for (i = 0; slosh != NULL && i < SR_PLANT_MAX_SLOSH; i++)
        if (plant_check_record(SR_PLANT_TABLE_SLOSH, i, &slosh[i], err, errlen))
            return refuse(md);
    if (check_parts(md, n_flex, flex, n_slosh, slosh, err, errlen))
        return refuse(md);
    nl = n_flex + n_slosh;
    if (nl == 0)
        return SR_PLANT_OK;
    /* the controllers' model: the rigid robot on the base with the parts at rest */
    md->rigid = md->dyn;
    for (i = 0; i < n_flex; i++) {
        sr_body b;
        panel_body(&flex[i], &b);
        if (add_leaf(md, SR_DYN_REVOLUTE, flex[i].hinge, flex[i].axis, &b, flex[i].f,
                     flex[i].zeta))
            return refuse(md);
    }
    for (i = 0; i < n_slosh; i++) {
        sr_body b;
        memset(&b, 0, sizeof b);
        b.m = slosh[i].m;
        memcpy(b.com, slosh[i].r, sizeof(b.com));
        if (add_leaf(md, SR_DYN_PRISMATIC, NULL, slosh[i].axis, &b, slosh[i].f,
                     slosh[i].zeta))
            return refuse(md);
        if (md->m0 > 0.0)
            md->m_slosh += slosh[i].m;
    }
    md->n_flex = n_flex;
    md->n_slosh = n_slosh;
    md->nl = nl;
    plant_base_spatial(md, md->m0, &m, hB, IS);
    for (i = 0; i < 3; i++)
        hB[i] += md->rest_hB[i];
    for (i = 0; i < 9; i++)
        IS[i] += md->rest_IS[i];
    if (sr_dyn_set_base_spatial(&md->rigid, m + md->rest_m, hB, IS) != SR_DYN_OK) {
        sr_text_set(err, errlen, "the composite rigid base is not finite");
        return refuse(md);
    }
    /* the state grows by the leaves' coordinates and rates (after the arm's) */
    nq_old = md->nq;
    nv_old = md->nv;
    memcpy(x0, md->x0, sizeof(x0));
    md->nq += nl;
    md->nv += nl;
    md->nx += 2 * nl;
    memset(md->x0, 0, sizeof(md->x0));
    memcpy(md->x0, x0, (size_t)(6 + nq_old) * sizeof(double));
    memcpy(md->x0 + 6 + md->nq, x0 + 6 + nq_old, (size_t)nv_old * sizeof(double));
    memcpy(md->x0 + 6 + md->nq + md->nv, x0 + 6 + nq_old + nv_old, 7 * sizeof(double));
    for (i = 0; i < n_flex; i++) {
        md->x0[6 + nq_old + i] = flex[i].q0;
        md->x0[6 + md->nq + nv_old + i] = flex[i].qd0;
    }
    for (i = 0; i < n_slosh; i++) {
        md->x0[6 + nq_old + n_flex + i] = slosh[i].x0;
        md->x0[6 + md->nq + nv_old + n_flex + i] = slosh[i].v0;
    }
    return SR_PLANT_OK;
}

SR_API size_t sr_plant_flex_size(void) { return sizeof(sr_plant_panel); }
SR_API size_t sr_plant_slosh_size(void) { return sizeof(sr_plant_slosh); }

void plant_leaf_forces(const sr_plant_model *md, sr_plant_data *d)
{
    const double *ql = d->qn + md->nq0 + md->n, *vl = d->vs + md->nb + md->n;
    double *tau = d->gen + md->nb + md->n;
    int j;
    for (j = 0; j < md->nl; j++)
        tau[j] = -md->k_leaf[j] * ql[j] - md->c_leaf[j] * vl[j];
}

void plant_composite_now(const sr_plant_model *md, double m_p, double *out)
{
    double m, hB[3], IS[9], b[3], bb;
    int i;
    plant_base_spatial(md, m_p, &m, hB, IS);
    m += md->rest_m;
    for (i = 0; i < 3; i++)
        hB[i] += md->rest_hB[i];
    for (i = 0; i < 9; i++)
        IS[i] += md->rest_IS[i];
    /* b = h / m, I_c = I_S - m S(b) */
    for (i = 0; i < 3; i++)
        b[i] = hB[i] / m;
    bb = b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
    out[0] = m;
    out[1] = b[0];
    out[2] = b[1];
    out[3] = b[2];
    out[4] = IS[0] - m * (bb - b[0] * b[0]);
    out[5] = IS[4] - m * (bb - b[1] * b[1]);
    out[6] = IS[8] - m * (bb - b[2] * b[2]);
    out[7] = IS[1] + m * (b[0] * b[1]);
    out[8] = IS[2] + m * (b[0] * b[2]);
    out[9] = IS[5] + m * (b[1] * b[2]);
}
