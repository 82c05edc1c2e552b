/* The plant's controllers (plant.h): the thrusters' bounded momentum laws (eqs. 40-41) and the
 * arm's attitude law (eq. 39) with the null-space posture and the excitation's references,
 * the thrust limited by the propellant left.
 *
 * With flexible parts the controllers are those of the composite rigid body (the base with
 * the panels at rest and the slosh masses at their equilibrium): the attitude law is solved
 * on its dynamics at the measured base and arm state, the thrusters act on the system's
 * momentum; the joints follow the commanded accelerations and the base and the parts respond
 * as the true dynamics say (the free rows solved with the arm's accelerations given). */
#include <math.h>

#include "linalg.h"
#include "plant_internal.h"
#include "sr_math.h"
#include "vec3.h"

/* eigenvalue ratio below which the attitude solve is damped (docs/models.md) */
#define DLS_RATIO 1e-2

/* paper eqs. 40/41 for one axis: u = K x inside |x| < x_max (saturated at u_max),
 * u = sign(K x) u_max outside it; NaN passes through */
static double bounded_law(double x, double K, double x_max, double u_max)
{
    const double kx = K * x;
    if (fabs(x) >= x_max) {
        if (kx > 0.0)
            return u_max;
        if (kx < 0.0)
            return -u_max;
        return 0.0 * u_max;
    }
    if (kx < -u_max)
        return -u_max;
    if (kx > u_max)
        return u_max;
    return kx;
}

/* L = the k x k leading block of S (row stride lds) factored by sr_cholesky (L L^T, lower
 * triangle); sr_cholesky's status: 0, 1 not positive definite, 2 a non-finite pivot */
static int factor(const double *S, int lds, int k, double *L)
{
    int i, j;
    for (i = 0; i < k; i++)
        for (j = 0; j < k; j++)
            L[i * k + j] = S[i * lds + j];
    return sr_cholesky(L, k);
}

/* the plant's status of a failed factor(): singular (which) or non-finite */
static int factor_status(int st, int singular)
{
    return st == 1 ? singular : SR_PLANT_ENONFINITE;
}

/* The free rows u (nu) of M a + nle = gen (M ld x ld, row-major) with the accelerations of the
 * n rows a0 .. a0 + n - 1 (the arm's) given: M_uu a_u = (gen_u - nle_u) - M_ua qdd. Factors
 * M_uu (gathered into L, nu x nu) and solves [X, y0] = M_uu^-1 [M_ua, gen_u - nle_u] into
 * sol (nu x (n + 1)), so that a_u = y0 - X qdd. Returns sr_cholesky's status (0, 1 not
 * positive definite, 2 a non-finite pivot). */
static int free_rows(const double *M, int ld, const int *u, int nu, int a0, int n,
                     const double *gen, const double *nle, double *L, double *sol)
{
    const int w = n + 1;
    int i, j, st;
    for (i = 0; i < nu; i++)
        for (j = 0; j < nu; j++)
            L[i * nu + j] = M[u[i] * ld + u[j]];
    if ((st = sr_cholesky(L, nu)) != 0)
        return st;
    for (i = 0; i < nu; i++) {
        for (j = 0; j < n; j++)
            sol[i * w + j] = M[u[i] * ld + a0 + j];
        sol[i * w + n] = gen[u[i]] - nle[u[i]];
    }
    sr_cholesky_solve(L, nu, sol, w);
    return 0;
}

/* Thruster and arm commands at the normalised configuration q, velocity v, with the
 * rigid-body terms there in d: M (nv x nv), nle (nv), hg (6) = [P, L_c]; the controllers'
 * model's (nl > 0: the composite rigid body's Mr ((nb + n) square), nle_r; else M, nle
 * themselves); ct the controller; t, ramp the excitation (its sines: d->trig where d->trig_t
 * is t, else evaluated here into d->trig). Writes FM[0..5] = [F, M] (inertial),
 * gen (nv) = [f_b, tau, the leaves' spring and damper forces (kept)] and acc (nv) = dv/dt
 * (M acc + nle = gen by construction). Returns 0, SR_PLANT_ESINGULAR_*, or SR_PLANT_ENONFINITE
 * for a non-finite matrix on the way. */
static int control(const sr_plant_model *md, sr_plant_data *d, const double *q, const double *v,
                   const sr_plant_controller *ct,
                   double t, const double *ramp, double *gen, double *acc, double *FM)
{
    const int nv = md->nv, nb = md->nb, n = md->n, r = md->n_att, r0 = nb - r, nq0 = md->nq0;
    const double KD = ct->K_D, KP = ct->K_P, KPn = ct->K_Pn, KDn = ct->K_Dn, qdd_max = ct->qdd_max;
    const double *M = d->M, *nle = d->nle, *hg = d->hg;
    const double *Mr = md->nl > 0 ? d->Mr : M, *nle_r = md->nl > 0 ? d->nle_r : nle;
    const int ldr = nb + n;                         /* Mr's rows */
    double e[3], Lb[36], sol[6 * (SR_MAX_JOINTS + 1)];
    double Lm[SR_MAX_JOINTS * SR_MAX_JOINTS];
    double WiGt[SR_MAX_JOINTS * 3], GWG[9], Lg[9], zv[3], rhs[3], post[SR_MAX_JOINTS];
    double lev[3], lam[3], U[9], peak;
    const double *sol_b = sol;                      /* [X, y0] of the base's response */
    const int w = n + 1;                            /* row length of sol: [X, y0] */
    int i, j, p, k, plain, st, u[6 + SR_PLANT_MAX_LEAVES], nu = nb;
    for (i = 0; i < 3; i++) {
        FM[i] = bounded_law(hg[i], ct->K_F, ct->P_max, ct->F_max);          /* eq. 41 (P) */
        FM[3 + i] = bounded_law(hg[3 + i], ct->K_M, ct->L_max, ct->M_max);  /* eq. 40 (L_c) */
    }
    /* thrust in base coordinates, and the attitude error e (rotation vector; theta_z planar) */
    e[0] = e[1] = e[2] = 0.0;
    if (md->planar) {
        const double c = q[2], s = q[3], kk = 1.0 / sr_hypot(c, s);
        const double cs = c * kk, sn = s * kk;
        gen[0] = cs * FM[0] + sn * FM[1];
        gen[1] = -sn * FM[0] + cs * FM[1];
        gen[2] = FM[5];
        e[2] = sr_atan2(s, c);
    } else {
        double A[9], x = q[3], y = q[4], z = q[5], ww = q[6], nvec, kk;
        quat_dcm(x, y, z, ww, A);
        for (i = 0; i < 3; i++) {                   /* A^T F, A^T M */
            gen[i] = A[i] * FM[0] + A[3 + i] * FM[1] + A[6 + i] * FM[2];
            gen[3 + i] = A[i] * FM[3] + A[3 + i] * FM[4] + A[6 + i] * FM[5];
        }
        if (ww < 0.0) {                             /* hemisphere w >= 0 */
            x = -x;
            y = -y;
            z = -z;
            ww = -ww;
        }
        nvec = sqrt(x * x + y * y + z * z);
        kk = nvec > 1e-8 * ww ? 2.0 * sr_atan2(nvec, ww) / nvec : 2.0 / ww;
        e[0] = kk * x;
        e[1] = kk * y;
        e[2] = kk * z;
    }
    /* base rows (the controllers' model): M_bb dv_b + M_bm qdd = f_b - c_b -> dv_b = y0 - X qdd */
    for (i = 0; i < nb; i++)
        u[i] = i;
    if ((st = free_rows(Mr, ldr, u, nb, nb, n, gen, nle_r, Lb, sol)) != 0)   /* [X, y0] */
        return factor_status(st, SR_PLANT_ESINGULAR_BASE);
    /* attitude rows: G qdd = y0_rot - alpha_des with G = X_rot; W = M_mm weights the solve */
    if ((st = factor(Mr + nb * ldr + nb, ldr, n, Lm)) != 0)
        return factor_status(st, SR_PLANT_ESINGULAR_ARM);
    for (i = 0; i < n; i++)
        for (j = 0; j < r; j++)
            WiGt[i * r + j] = sol[(r0 + j) * w + i];
    sr_cholesky_solve(Lm, n, WiGt, r);                      /* W^-1 G^T */
    for (i = 0; i < r; i++)
        for (j = 0; j < r; j++) {
            double s = 0.0;
            for (p = 0; p < n; p++)
                s += sol[(r0 + i) * w + p] * WiGt[p * r + j];
            GWG[i * r + j] = s;
        }
    /* posture: -K_Pn (q - q_home) - K_Dn qd */
    for (i = 0; i < n; i++)
        post[i] = -KPn * (q[nq0 + i] - md->q_home[i]) - KDn * v[nb + i];
    /* eq. 39: alpha_des = -K_D omega - K_P e; rhs_att = y0_rot - alpha_des - G post */
    for (j = 0; j < r; j++)
        rhs[j] = sol[(r0 + j) * w + n] + KD * v[r0 + j] + KP * e[3 - r + j];
    plant_ramp_level(t, ramp, lev);
    if (lev[0] != 0.0 || lev[1] != 0.0 || lev[2] != 0.0) {
        /* excitation: posture about q_home + q_r, eq. 39 about the attitude reference e_r:
         * alpha_des = e_r'' - K_D (omega - e_r') - K_P (e - e_r) */
        double f[3], g[3];
        if (!(d->trig_t == t)) {
            plant_fill_trig(md, d, t, d->trig);
            d->trig_t = t;
        }
        for (i = 0; i < n; i++) {
            plant_channel(d->ex_tab[r + i], d->trig[r + i], f);
            plant_level_times(lev, f, g);
            post[i] += g[2] + KPn * g[0] + KDn * g[1];
        }
        for (j = 0; j < r; j++) {
            plant_channel(d->ex_tab[j], d->trig[j], f);
            plant_level_times(lev, f, g);
            rhs[j] -= g[2] + KD * g[1] + KP * g[0];
        }
    }
    for (j = 0; j < r; j++) {
        double s = rhs[j];
        for (p = 0; p < n; p++)
            s -= sol[(r0 + j) * w + p] * post[p];
        rhs[j] = s;
    }
    /* selectively damped inverse of GWG (damped only near a singular coupling) */
    lam[0] = lam[1] = lam[2] = 0.0;
    if (r == 3) {
        const double g00 = GWG[0], g01 = GWG[1], g02 = GWG[2], g11 = GWG[4], g12 = GWG[5],
                     g22 = GWG[8];
        const double det = (g00 * (g11 * g22 - g12 * g12) - g01 * (g01 * g22 - g12 * g02)
                            + g02 * (g01 * g12 - g11 * g02));
        const double tr = g00 + g11 + g22;
        /* positive definite with lo / hi >= 4 det / tr^3 twice the threshold: the eigenvalues
         * would choose the undamped branch too */
        plain = (g00 > 0.0 && g00 * g11 - g01 * g01 > 0.0 && det > 0.0
                 && 4.0 * det >= 2.0 * 1.01 * DLS_RATIO * (tr * tr * tr));
        if (!plain) {
            if (sr_eigh(GWG, 3, lam, U) != 0)
                return SR_PLANT_ENONFINITE;
            plain = lam[0] / (lam[2] > 1e-300 ? lam[2] : 1e-300) >= 1.01 * DLS_RATIO;
        }
    } else {
        plain = GWG[0] / (GWG[0] > 1e-300 ? GWG[0] : 1e-300) >= 1.01 * DLS_RATIO;
    }
    if (plain) {                                    /* z = (GWG)^-1 rhs */
        if ((st = factor(GWG, r, r, Lg)) != 0)
            return factor_status(st, SR_PLANT_ESINGULAR_COUPLING);
        for (j = 0; j < r; j++)
            zv[j] = rhs[j];
        sr_cholesky_solve(Lg, r, zv, 1);
    } else {
        double lmax;
        if (sr_eigh(GWG, r, lam, U) != 0)
            return SR_PLANT_ENONFINITE;
        lmax = lam[r - 1] > 1e-300 ? lam[r - 1] : 1e-300;
        for (j = 0; j < r; j++)
            zv[j] = 0.0;
        for (k = 0; k < r; k++) {
            double rr = lam[k] / lmax, damp, uk, dd;
            if (!(rr > 0.0))
                rr = 0.0;
            dd = 1.0 - rr / DLS_RATIO;
            damp = rr < DLS_RATIO ? DLS_RATIO * lmax * (dd * dd) : 0.0;
            uk = 0.0;
            for (j = 0; j < r; j++)
                uk += U[j * r + k] * rhs[j];
            uk /= lam[k] + damp;
            for (j = 0; j < r; j++)
                zv[j] += U[j * r + k] * uk;
        }
    }
    /* qdd = W^-1 G^T z + post, scaled down (direction kept) to |qdd| <= qdd_max */
    peak = 0.0;
    for (i = 0; i < n; i++) {
        double s = post[i];
        for (j = 0; j < r; j++)
            s += WiGt[i * r + j] * zv[j];
        acc[nb + i] = s;
        if (fabs(s) > peak)
            peak = fabs(s);
    }
    if (peak > qdd_max) {
        const double f = qdd_max / peak;
        for (i = 0; i < n; i++)
            acc[nb + i] *= f;
    }
    /* the free rows' response to qdd (the true dynamics): without flexible parts the
     * controllers' solve of the base rows; with them the base's and the leaves' rows of M */
    if (md->nl > 0) {
        for (j = 0; j < md->nl; j++)
            u[nb + j] = nb + n + j;
        nu = nb + md->nl;
        if ((st = free_rows(M, nv, u, nu, nb, n, gen, nle, d->Luu, d->sol_u)) != 0)
            return factor_status(st, SR_PLANT_ESINGULAR_BASE);
        sol_b = d->sol_u;
    }
    for (i = 0; i < nu; i++) {                      /* dv_u = y0 - X qdd */
        double s = sol_b[i * w + n];
        for (p = 0; p < n; p++)
            s -= sol_b[i * w + p] * acc[nb + p];
        acc[u[i]] = s;
    }
    for (i = 0; i < n; i++) {                       /* tau = M_m. acc + c_m (arm rows) */
        double s = nle[nb + i];
        for (p = 0; p < nv; p++)
            s += M[(nb + i) * nv + p] * acc[p];
        gen[nb + i] = s;
    }
    return SR_PLANT_OK;
}

/* control() limited by the propellant m_p [kg] available for a step of dt (less the slosh
 * masses, which stay): when the flow would need more than that, the thrust is scaled by s = m_p / (flow dt) (the gains and bounds of both
 * thruster laws scaled: bounded_law is then s times the unscaled one) and control() runs again
 * so that the accelerations and torques are those of the scaled thrust. FM[6] = the flow
 * (0 without propellant model). */
int plant_thrust_control(const sr_plant_model *md, sr_plant_data *d, double t,
                         const double *ramp, double m_p, double dt)
{
    sr_plant_controller scaled;
    double flow, need, s;
    int err;
    const double *pp = md->pp;
    err = control(md, d, d->qn, d->vs, &md->ctrl, t, ramp, d->gen, d->acc, d->FM);
    if (err || pp[0] == 0.0) {
        d->FM[6] = 0.0;
        return err;
    }
    flow = plant_mass_flow(d->FM, pp);
    need = flow * dt;
    m_p -= md->m_slosh;                             /* what the thrusters may draw */
    if (need <= m_p) {
        d->FM[6] = flow;
        return SR_PLANT_OK;
    }
    s = (m_p > 0.0 ? m_p : 0.0) / need;
    scaled = md->ctrl;
    scaled.K_F *= s;
    scaled.F_max *= s;
    scaled.K_M *= s;
    scaled.M_max *= s;
    err = control(md, d, d->qn, d->vs, &scaled, t, ramp, d->gen, d->acc, d->FM);
    d->FM[6] = plant_mass_flow(d->FM, pp);
    return err;
}

