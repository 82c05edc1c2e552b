/* The plant's propellant (plant.h): the mass flow of the thrust, the base's inertia with the
 * propellant left, the momentum the expelled propellant carries away. With slosh modes the
 * propellant's rigid part is m_p less their masses (plant_leaves.c), which stay. */
#include <math.h>

#include "plant_internal.h"

/* propellant mass flow [kg/s] of the thrust FM = [F, M]:
 * (|F_x| + |F_y| + |F_z| + (|M_x| + |M_y| + |M_z|) / arm) / (Isp g0) */
double plant_mass_flow(const double *FM, const double *pp)
{
    return (fabs(FM[0]) + fabs(FM[1]) + fabs(FM[2])
            + (fabs(FM[3]) + fabs(FM[4]) + fabs(FM[5])) * pp[1]) * pp[0];
}

/* the base with m_p [kg] of propellant as a spatial inertia at S (base axes): spatial
 * inertias add, so it is the dry one plus the rigid part m_r = m_p - m_slosh times that of
 * 1 kg of propellant at r: *m = m_d + m_r, hB = m_d b_d + m_r r,
 * IS = I_S,d + m_r ((2/5) R^2 + |r|^2) 1 - m_r r r^T (the dry base without propellant model) */
void plant_base_spatial(const sr_plant_model *md, double m_p, double *m, double *hB,
                        double *IS)
{
    const double *pp = md->pp, *rt = md->pp + 3, m_r = m_p - md->m_slosh;
    const double rr = pp[2] + (rt[0] * rt[0] + rt[1] * rt[1] + rt[2] * rt[2]);
    int i, j;
    for (i = 0; i < 3; i++) {
        hB[i] = md->dry_hB[i] + m_r * rt[i];
        for (j = 0; j < 3; j++)
            IS[3 * i + j] = md->dry_IS[3 * i + j]
                            + m_r * ((i == j ? rr : 0.0) - rt[i] * rt[j]);
    }
    *m = md->dry[0] + m_r;
}

/* the base of d->dyn with m_p [kg] of propellant (plant_base_spatial), and with flexible
 * parts that of d->rigid (plus the parts at rest). Nothing to do without propellant model.
 * Returns 0, or SR_PLANT_ENONFINITE for a non-finite or non-positive resulting mass. */
int plant_base_inertia(const sr_plant_model *md, sr_plant_data *d, double m_p)
{
    double hB[3], IS[9], m;
    int i;
    if (md->pp[0] == 0.0)
        return SR_PLANT_OK;
    plant_base_spatial(md, m_p, &m, hB, IS);
    if (sr_dyn_set_base_spatial(&d->dyn, m, hB, IS) != SR_DYN_OK)
        return SR_PLANT_ENONFINITE;
    if (md->nl == 0)
        return SR_PLANT_OK;
    for (i = 0; i < 3; i++)
        hB[i] += md->rest_hB[i];
    for (i = 0; i < 9; i++)
        IS[i] += md->rest_IS[i];
    return sr_dyn_set_base_spatial(&d->rigid, m + md->rest_m, hB, IS) == SR_DYN_OK
           ? SR_PLANT_OK : SR_PLANT_ENONFINITE;
}

/* rows [dm_p, dP_x (3), dL_x (3)] of the state derivative at the stage state xa (A its base
 * DCM, base_dcm) for the mass flow [kg/s]: the expelled propellant leaves with the tank
 * centre's velocity v_c: dP_x = flow v_c, dL_x = flow (r_c x v_c + (2/5) R^2 omega_I) */
void plant_propellant_rates(const sr_plant_model *md, const double *xa, const double *A,
                            double flow, double *row)
{
    const int oq = 6, ov = 6 + md->nq, o = ov + md->nv;
    const double *pp = md->pp;
    const double rtx = pp[3], rty = pp[4], rtz = pp[5], k2 = pp[2];
    double rx, ry, rz, vx, vy, vz, wx, wy, wz, ux, uy, uz, vc[3], c[3], wi[3];
    int j;
    row[o] = -flow;                                 /* dm_p/dt */
    if (flow == 0.0) {
        for (j = 1; j < 7; j++)
            row[o + j] = 0.0;
        return;
    }
    if (md->planar) {
        rx = xa[oq]; ry = xa[oq + 1]; rz = 0.0;
        vx = xa[ov]; vy = xa[ov + 1]; vz = 0.0;
        wx = 0.0; wy = 0.0; wz = xa[ov + 2];
    } else {
        rx = xa[oq]; ry = xa[oq + 1]; rz = xa[oq + 2];
        vx = xa[ov]; vy = xa[ov + 1]; vz = xa[ov + 2];
        wx = xa[ov + 3]; wy = xa[ov + 4]; wz = xa[ov + 5];
    }
    /* tank centre velocity, base frame: u = v_l + omega_B x r_t; inertial v_c = A u */
    ux = vx + (wy * rtz - wz * rty);
    uy = vy + (wz * rtx - wx * rtz);
    uz = vz + (wx * rty - wy * rtx);
    for (j = 0; j < 3; j++) {
        vc[j] = A[3 * j] * ux + A[3 * j + 1] * uy + A[3 * j + 2] * uz;
        wi[j] = A[3 * j] * wx + A[3 * j + 1] * wy + A[3 * j + 2] * wz;
    }
    /* tank centre r_c = r_S + A r_t */
    c[0] = rx + A[0] * rtx + A[1] * rty + A[2] * rtz;
    c[1] = ry + A[3] * rtx + A[4] * rty + A[5] * rtz;
    c[2] = rz + A[6] * rtx + A[7] * rty + A[8] * rtz;
    row[o + 1] = flow * vc[0];
    row[o + 2] = flow * vc[1];
    row[o + 3] = flow * vc[2];
    row[o + 4] = flow * (c[1] * vc[2] - c[2] * vc[1] + k2 * wi[0]);
    row[o + 5] = flow * (c[2] * vc[0] - c[0] * vc[2] + k2 * wi[1]);
    row[o + 6] = flow * (c[0] * vc[1] - c[1] * vc[0] + k2 * wi[2]);
}

/* the base's truth [m, b, I6] with m_p of propellant (spacerobot.robots.Propellant.base):
 * m = m_d + m_p, b = b_d + (m_p / m)(r - b_d), I = I_d + m_d S(b_d - b) + (2/5) m_p R^2 1 +
 * m_p S(r - b), S(d) = |d|^2 1 - d d^T */
void plant_base_now(const sr_plant_model *md, double m_p, double *out)
{
    const double *dry = md->dry, *pp = md->pp;
    double md_, m, f, b0, b1, b2, d0, d1, d2, e0, e1, e2, dd, ee;
    int i;
    for (i = 0; i < 10; i++)
        out[i] = dry[i];
    if (pp[0] == 0.0)
        return;
    md_ = dry[0];
    m = md_ + m_p;
    f = m_p / m;
    b0 = dry[1] + f * (pp[3] - dry[1]);
    b1 = dry[2] + f * (pp[4] - dry[2]);
    b2 = dry[3] + f * (pp[5] - dry[3]);
    d0 = dry[1] - b0; d1 = dry[2] - b1; d2 = dry[3] - b2;
    e0 = pp[3] - b0; e1 = pp[4] - b1; e2 = pp[5] - b2;
    dd = d0 * d0 + d1 * d1 + d2 * d2;
    ee = e0 * e0 + e1 * e1 + e2 * e2;
    out[0] = m;
    out[1] = b0;
    out[2] = b1;
    out[3] = b2;
    out[4] = dry[4] + md_ * (dd - d0 * d0) + m_p * ((pp[2] + ee) - e0 * e0);
    out[5] = dry[5] + md_ * (dd - d1 * d1) + m_p * ((pp[2] + ee) - e1 * e1);
    out[6] = dry[6] + md_ * (dd - d2 * d2) + m_p * ((pp[2] + ee) - e2 * e2);
    out[7] = dry[7] + md_ * (-d0 * d1) + m_p * (-e0 * e1);
    out[8] = dry[8] + md_ * (-d0 * d2) + m_p * (-e0 * e2);
    out[9] = dry[9] + md_ * (-d1 * d2) + m_p * (-e1 * e2);
}

SR_API int sr_plant_base_now(const sr_plant_model *model, const sr_plant_data *data,
                             double *out)
{
    double m_p;
    if (!plant_model_ok(model) || data == NULL || out == NULL)
        return SR_PLANT_EARG;
    m_p = data->x[6 + model->nq + model->nv];
    if (model->nl > 0)
        plant_composite_now(model, m_p, out);
    else
        plant_base_now(model, m_p, out);
    return SR_PLANT_OK;
}
