/* The dynamics of the physical state (dynamics.h's second view), for models without leaves. */
#include <math.h>
#include <string.h>

#include "dynamics_internal.h"
#include "vec3.h"

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
void dyn_base_velocity(const sr_dyn_model *md, const double *A, const double *v_S,
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
void dyn_base_force(const sr_dyn_model *md, const double *Ae, const double *F,
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
    if (!dyn_model_ok(model) || model->nl != 0 || r_S == NULL || A == NULL || v_S == NULL || omega_B == NULL
        || q_arm == NULL || qd == NULL || q == NULL || v == NULL)
        return SR_DYN_EARG;
    nr = model->planar ? 3 : 6;
    nq0 = model->planar ? 4 : 7;
    dyn_base_velocity(model, A, v_S, omega_B, v, Ae);
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
    if (!dyn_model_ok(model) || model->nl != 0 || A == NULL || F == NULL || M_S == NULL || tau == NULL || gen == NULL)
        return SR_DYN_EARG;
    nr = model->planar ? 3 : 6;
    if (model->planar)
        planar_dcm(A, Ae, &cs, &sn);
    else
        memcpy(Ae, A, sizeof(Ae));
    dyn_base_force(model, Ae, F, M_S, gen);
    for (i = 0; i < model->n; i++)
        gen[nr + i] = tau[i];
    return SR_DYN_OK;
}

SR_API int sr_dyn_forward(const sr_dyn_model *model, sr_dyn_data *data, const double A[9],
                          const double v_S[3], const double omega_B[3], const double *q_arm,
                          const double *qd, const double F[3], const double M_S[3],
                          const double *tau, double a_S[3], double alpha_B[3], double *qdd)
{
    double Ae[9], vb[6], fb[6], ab[6], vl[3], w[3], al[3], t[3], sc[2 * SR_DYN_MAX_COORDS];
    int st;
    if (!dyn_model_ok(model) || model->nl != 0 || data == NULL || A == NULL || v_S == NULL || omega_B == NULL
        || q_arm == NULL || qd == NULL || F == NULL || M_S == NULL || tau == NULL
        || a_S == NULL || alpha_B == NULL || qdd == NULL)
        return SR_DYN_EARG;
    dyn_base_velocity(model, A, v_S, omega_B, vb, Ae);
    dyn_base_force(model, Ae, F, M_S, fb);
    dyn_arm_sincos(model, q_arm, sc);
    st = dyn_aba_core(model, data, sc, NULL, qd, tau, vb, fb, ab, qdd);
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
    double Ae[9], vb[6], hm[6], gm[4], sc[2 * SR_DYN_MAX_COORDS];
    if (!dyn_model_ok(model) || model->nl != 0 || data == NULL || A == NULL || v_S == NULL || omega_B == NULL
        || q_arm == NULL || qd == NULL)
        return SR_DYN_EARG;
    dyn_base_velocity(model, A, v_S, omega_B, vb, Ae);
    dyn_arm_sincos(model, q_arm, sc);
    dyn_terms_core(model, data, sc, NULL, qd, vb, M, h, hm, gm);
    return SR_DYN_OK;
}

SR_API int sr_dyn_momentum(const sr_dyn_model *model, sr_dyn_data *data, const double r_S[3],
                           const double A[9], const double v_S[3], const double omega_B[3],
                           const double *q_arm, const double *qd, double P[3], double L[3],
                           double *com)
{
    double Ae[9], vb[6], hm[6], gm[4], t[3], sc[2 * SR_DYN_MAX_COORDS];
    if (!dyn_model_ok(model) || model->nl != 0 || data == NULL || r_S == NULL || A == NULL || v_S == NULL
        || omega_B == NULL || q_arm == NULL || qd == NULL || P == NULL || L == NULL)
        return SR_DYN_EARG;
    dyn_base_velocity(model, A, v_S, omega_B, vb, Ae);
    dyn_arm_sincos(model, q_arm, sc);
    dyn_terms_core(model, data, sc, NULL, qd, vb, NULL, NULL, hm, gm);
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
