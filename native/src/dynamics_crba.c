/* Joint-space inertia (CRBA), non-linear effects (RNEA) and the system momentum of the
 * free-floating robot (dynamics.h), in one pass over the chain (Pinocchio's computeAllTerms):
 *   - RNEA, RBDA Table 5.1 (at zero acceleration):
 *       v_i = v_p + S_i qd_i,  a_i = a_p + S_i qdd_i + v_i x S_i qd_i,
 *       f_i = I_i a_i + v_i x* I_i v_i,  tau_i = S_i^T f_i,  f_p += f_i;
 *   - CRBA, RBDA Table 6.2:
 *       Ic_i = I_i + sum of the children's Ic,  F = Ic_i S_i,  H_ji = S_j^T F (j ancestors of i);
 *   - the momentum h = sum I_i v_i.
 * Everything is expressed at the base origin S in base axes. A leaf (a body on a joint of the
 * base) is a branch of one body: its column of M is I_j S_j on the base's rows, S_j^T I_j S_j
 * on its own, 0 elsewhere.
 */
#include <math.h>

#include "dynamics_internal.h"
#include "vec3.h"

/* the leaves' RNEA at zero acceleration (j < nl, body k = n + 1 + j, at S): placement and
 * inertia, v_k = v_0 + S6 qd, a_k = c_k = v_k x S6 qd, f_k = I a_k + v_k x* (I v_k) into
 * d->pA[k]; their momentum I v_k added to hm */
static void leaves_forward(const sr_dyn_model *md, sr_dyn_data *d, const double *sc,
                           const double *ql, const double *qd, const double *v0, double *hm)
{
    int j, i;
    for (j = 0; j < md->nl; j++) {
        const int k = md->n + 1 + j, c = md->n + j;
        double *S6 = d->S[k], vk[6], z[6], ak[6], y[6], fa[6], cv[6];
        leaf_place(md, j, ql[j], sc[2 * c], sc[2 * c + 1], d->g[k], d->J[k], d->bp[k], S6);
        for (i = 0; i < 6; i++) {
            z[i] = S6[i] * qd[c];
            vk[i] = v0[i] + z[i];
        }
        crm(vk, z, ak);
        rbi_mul(md->m[k], d->g[k], d->J[k], vk, y);
        for (i = 0; i < 6; i++)
            hm[i] = hm[i] + y[i];
        rbi_mul(md->m[k], d->g[k], d->J[k], ak, fa);
        crf(vk, y, cv);
        for (i = 0; i < 6; i++)
            d->pA[k][i] = fa[i] + cv[i];
    }
}

/* CRBA (RBDA Table 6.2), RNEA at zero acceleration (Table 5.1) and the momentum, all in base
 * axes at the base origin S, sc ((n + nl) x 2) the sines and cosines of the arm's (and the
 * leaves') angles, ql the leaves' coordinates, qd the arm's and the leaves' rates. Writes
 * M (nv x nv, both triangles) and nle (nv) when not NULL, and always hm (6) = the system
 * momentum [h_l; h_n about S] and gm (4) = [total mass, first moment about S (3)], base
 * axes. */
void dyn_terms_core(const sr_dyn_model *md, sr_dyn_data *d, const double *sc, const double *ql,
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
    leaves_forward(md, d, sc, ql, qd, v, hm);
    for (i = 0; i < 6; i++)
        a[i] = 0.0;
    for (i = 0; i < 9; i++)
        E[0][i] = (i % 4 == 0) ? 1.0 : 0.0;
    o[0] = o[1] = o[2] = 0.0;
    for (k = 1; k < nb; k++) {
        double *S = d->S[k], *gk = d->g[k], *Jk = d->J[k], on[3], s[3], z, hh[3], io[6];
        double yv[6], fa[6], cv[6];
        const double m = md->m[k], *h = md->h[k];
        place(md, k, sc[2 * k - 2], sc[2 * k - 1], E[cur], o, E[1 - cur], on, s);
        cur = 1 - cur;
        o[0] = on[0];
        o[1] = on[1];
        o[2] = on[2];
        joint_motion(o, s, S);
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
        /* inertia at the base origin: h' = bR_k h, I_o' = bR_k I_o bR_k^T, then moved by o
         * (inertia_at) */
        {
            const double *Ek = E[cur];
            for (i = 0; i < 3; i++)
                hh[i] = Ek[3 * i] * h[0] + Ek[3 * i + 1] * h[1] + Ek[3 * i + 2] * h[2];
            rot_sym(Ek, md->J[k], io);
        }
        inertia_at(m, hh, io, o, gk, Jk);
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
    /* the leaves: the composite and the force of each added to the base's; its own column */
    for (j = 0; j < md->nl; j++) {
        const int kl = nb + j, col = nr + md->n + j;
        const double *S = d->S[kl], *fl = d->pA[kl];
        mt += md->m[kl];
        for (i = 0; i < 3; i++)
            g[i] = g[i] + d->g[kl][i];
        for (i = 0; i < 6; i++) {
            J[i] = J[i] + d->J[kl][i];
            f[i] = f[i] + fl[i];
        }
        if (nle != NULL)
            nle[col] = S[0] * fl[0] + S[1] * fl[1] + S[2] * fl[2] + S[3] * fl[3] + S[4] * fl[4]
                       + S[5] * fl[5];
        if (M != NULL) {
            rbi_mul(md->m[kl], d->g[kl], d->J[kl], S, F);
            for (i = nr; i < nv; i++) {
                M[i * nv + col] = 0.0;
                M[col * nv + i] = 0.0;
            }
            M[col * nv + col] = S[0] * F[0] + S[1] * F[1] + S[2] * F[2] + S[3] * F[3]
                                + S[4] * F[4] + S[5] * F[5];
            for (i = 0; i < nr; i++) {
                M[i * nv + col] = F[base_row(planar, i)];
                M[col * nv + i] = F[base_row(planar, i)];
            }
        }
    }
    if (nle != NULL)
        for (i = 0; i < nr; i++)
            nle[i] = f[base_row(planar, i)];
    if (M != NULL) {
        /* [[m 1, -[g]x], [[g]x, J]] on the base's rows/columns */
        double I6[6][6];
        rbi_full(mt, g, J, I6);
        for (i = 0; i < nr; i++)
            for (j = 0; j < nr; j++)
                M[i * nv + j] = I6[base_row(planar, i)][base_row(planar, j)];
    }
    gm[0] = mt;
    gm[1] = g[0];
    gm[2] = g[1];
    gm[3] = g[2];
}

/* DCM base -> inertial of the configuration q: planar (cos, sin) as given; the quaternion
 * normalised on the fly */
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
        quat_dcm(q[3], q[4], q[5], q[6], A);
        r[0] = q[0];
        r[1] = q[1];
        r[2] = q[2];
    }
}

SR_API int sr_dyn_terms(const sr_dyn_model *model, sr_dyn_data *data, const double *q,
                        const double *v, double *M, double *nle, double *hg, double *com)
{
    double sc[2 * SR_DYN_MAX_COORDS];
    if (!dyn_model_ok(model) || q == NULL)
        return SR_DYN_EARG;
    dyn_arm_sincos(model, q + (model->planar ? 4 : 7), sc);
    return sr_dyn_terms_sc(model, data, q, v, sc, M, nle, hg, com);
}

SR_API int sr_dyn_terms_sc(const sr_dyn_model *model, sr_dyn_data *data, const double *q,
                           const double *v, const double *sc, double *M, double *nle,
                           double *hg, double *com)
{
    int nr;
    double hm[6], gm[4], A[9], r[3], c[3], l[3], nn[3];
    if (!dyn_model_ok(model) || data == NULL || q == NULL || v == NULL || sc == NULL)
        return SR_DYN_EARG;
    nr = model->planar ? 3 : 6;
    dyn_terms_core(model, data, sc, q + (model->planar ? 4 : 7) + model->n, v + nr, v, M, nle,
                   hm, gm);
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
