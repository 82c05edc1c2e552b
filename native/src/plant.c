/* The plant (see plant.h): a port of the former spacerobot/plant/kernels.py and simulator.py's Plant.
 *
 * One step path: sr_plant_advance -> step() per internal step: the rigid-body terms at the
 * step's start feed control() (zero-order hold; its inverse dynamics give the first stage's
 * accelerations), the articulated-body algorithm those of stages 2-4, stage() the RK4
 * bookkeeping. Everything runs on a working copy of the state that is committed only when
 * every step succeeded and the state reached is finite.
 *
 * Differences from the Numba kernels, all within round-off: the excitation sines come from
 * sr_sincos (libm's sin / cos are not portable); atan2 is fdlibm's arrangement
 * here (libm's is not portable); the 3 x 3 eigenvalues of the damping test come from the
 * Jacobi iteration instead of the closed form (which needs acos / cos).
 */
#include "plant.h"

#include <math.h>
#include <string.h>

#include "body.h"
#include "sr_math.h"
#include "sr_text.h"

/* eigenvalue ratio below which the attitude solve is damped (kernels.DLS_RATIO) */
#define DLS_RATIO 1e-2
/* most internal steps one call of sr_plant_advance takes */
#define MAX_STEPS 1e9

static const double PI = 3.141592653589793;          /* math.pi */

/* -- small numerics (kernels.py / rigid_body.py) -------------------------------------------- */

/* paper eqs. 40/41 for one axis: u = K x inside |x| < x_max (saturated at u_max),
 * u = sign(K x) u_max outside it; NaN passes through (kernels.bounded_law) */
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

/* DCM (body -> inertial, row-major) of a not necessarily unit quaternion (x, y, z, w) */
static void quat_dcm(double x, double y, double z, double w, double *A)
{
    const double s = 2.0 / (x * x + y * y + z * z + w * w);
    const double xx = x * x, yy = y * y, zz = z * z;
    const double xy = x * y, xz = x * z, yz = y * z;
    const double xw = x * w, yw = y * w, zw = z * w;
    A[0] = 1.0 - s * (yy + zz); A[1] = s * (xy - zw); A[2] = s * (xz + yw);
    A[3] = s * (xy + zw); A[4] = 1.0 - s * (xx + zz); A[5] = s * (yz - xw);
    A[6] = s * (xz - yw); A[7] = s * (yz + xw); A[8] = 1.0 - s * (xx + yy);
}

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

/* lower Cholesky factor L (k x k) of the SPD matrix S (k x k, row stride lds), with the
 * reciprocals of its diagonal on the diagonal (what cho_solve multiplies by; the upper
 * triangle is not written); 0 if a pivot is <= 0 (a NaN pivot passes, so that NaN
 * propagates) (rigid_body.cholesky) */
static int cholesky(const double *S, int lds, int k, double *restrict L)
{
    int i, j, p;
    for (j = 0; j < k; j++) {
        double d = S[j * lds + j], r;
        for (p = 0; p < j; p++)
            d -= L[j * k + p] * L[j * k + p];
        if (d <= 0.0)
            return 0;
        d = sqrt(d);
        r = 1.0 / d;
        L[j * k + j] = r;
        for (i = j + 1; i < k; i++) {
            double s = S[i * lds + j];
            for (p = 0; p < j; p++)
                s -= L[i * k + p] * L[j * k + p];
            L[i * k + j] = s * r;
        }
    }
    return 1;
}

/* solve L L^T X = B in place of B (k x c, row-major), L from cholesky (rigid_body.cho_solve;
 * the same operations: the reciprocals 1 / L_ii it multiplies by now come from cholesky) */
static void cho_solve(const double *restrict L, int k, double *restrict B, int c)
{
    int i, p, col;
    for (i = 0; i < k; i++) {
        double *bi = B + i * c;
        const double r = L[i * k + i];
        for (p = 0; p < i; p++) {
            const double lip = L[i * k + p], *bp = B + p * c;
            for (col = 0; col < c; col++)
                bi[col] -= lip * bp[col];
        }
        for (col = 0; col < c; col++)
            bi[col] *= r;
    }
    for (i = k - 1; i >= 0; i--) {
        double *bi = B + i * c;
        const double r = L[i * k + i];
        for (p = i + 1; p < k; p++) {
            const double lpi = L[p * k + i], *bp = B + p * c;
            for (col = 0; col < c; col++)
                bi[col] -= lpi * bp[col];
        }
        for (col = 0; col < c; col++)
            bi[col] *= r;
    }
}

/* eigen-decomposition of a symmetric k x k matrix (k <= 3), cyclic Jacobi:
 * S = U diag(lam) U^T, eigenvalues ascending (kernels._jacobi_eigh) */
static void jacobi_eigh(const double *S, int k, double *lam, double *U)
{
    double a[9];
    int i, j, p, r, sweep;
    for (i = 0; i < k * k; i++)
        a[i] = S[i];
    for (i = 0; i < k; i++)
        for (j = 0; j < k; j++)
            U[i * k + j] = (i == j) ? 1.0 : 0.0;
    for (sweep = 0; sweep < 50; sweep++) {
        double off = 0.0;
        for (i = 0; i < k; i++)
            for (j = i + 1; j < k; j++)
                off += a[i * k + j] * a[i * k + j];
        if (off <= 1e-30 * (a[0] * a[0] + a[(k - 1) * k + k - 1] * a[(k - 1) * k + k - 1])
            || off == 0.0)
            break;
        for (p = 0; p < k; p++) {
            for (r = p + 1; r < k; r++) {
                double th, t, c, s;
                if (a[p * k + r] == 0.0)
                    continue;
                th = (a[r * k + r] - a[p * k + p]) / (2.0 * a[p * k + r]);
                t = (th >= 0.0 ? 1.0 : -1.0) / (fabs(th) + sqrt(th * th + 1.0));
                c = 1.0 / sqrt(t * t + 1.0);
                s = t * c;
                for (i = 0; i < k; i++) {            /* a <- a G (columns p, r) */
                    const double aip = a[i * k + p], air = a[i * k + r];
                    a[i * k + p] = c * aip - s * air;
                    a[i * k + r] = s * aip + c * air;
                }
                for (i = 0; i < k; i++) {            /* a <- G^T a (rows p, r) */
                    const double api = a[p * k + i], ari = a[r * k + i];
                    a[p * k + i] = c * api - s * ari;
                    a[r * k + i] = s * api + c * ari;
                }
                for (i = 0; i < k; i++) {
                    const double uip = U[i * k + p], uir = U[i * k + r];
                    U[i * k + p] = c * uip - s * uir;
                    U[i * k + r] = s * uip + c * uir;
                }
            }
        }
    }
    for (i = 0; i < k; i++)
        lam[i] = a[i * k + i];
    for (i = 1; i < k; i++) {                        /* insertion sort, columns of U along */
        j = i;
        while (j > 0 && lam[j - 1] > lam[j]) {
            double tmp = lam[j - 1];
            lam[j - 1] = lam[j];
            lam[j] = tmp;
            for (r = 0; r < k; r++) {
                tmp = U[r * k + j - 1];
                U[r * k + j - 1] = U[r * k + j];
                U[r * k + j] = tmp;
            }
            j--;
        }
    }
}

/* -- excitation ---------------------------------------------------------------------------- */

/* level s and its two derivatives at t of the ramp [s0, u, t0, T]: the quintic
 * s = s0 + (u - s0) p(x), p = 10 x^3 - 15 x^4 + 6 x^5, x = (t - t0) / T (kernels.ramp_level) */
static void ramp_level(double t, const double *ramp, double *s)
{
    const double s0 = ramp[0], u = ramp[1], t0 = ramp[2], T = ramp[3];
    double x = (t - t0) / T, d, xm;
    if (x >= 1.0) {
        s[0] = u;
        s[1] = 0.0;
        s[2] = 0.0;
        return;
    }
    if (x <= 0.0)
        x = 0.0;
    d = u - s0;
    xm = 1.0 - x;
    s[0] = s0 + d * x * x * x * (10.0 + x * (6.0 * x - 15.0));
    s[1] = d * 30.0 * x * x * xm * xm / T;
    s[2] = d * 60.0 * x * xm * (1.0 - 2.0 * x) / (T * T);
}

/* the sines and cosines of both phases of every channel at t: trig[c] = [sin(w1 t + p1),
 * cos(w1 t + p1), sin(w2 t + p2), cos(w2 t + p2)] (kernels.fill_trig) */
static void fill_trig(const sr_plant_model *md, const sr_plant_data *d, double t,
                      double (*trig)[4])
{
    int c;
    for (c = 0; c < md->n_ch; c++) {
        const double *row = d->ex_tab[c];
        sr_sincos(row[1] * t + row[2], &trig[c][0], &trig[c][1]);
        sr_sincos(row[3] * t + row[4], &trig[c][2], &trig[c][3]);
    }
}

/* d->trig advanced by h by the angle-addition formulas (kernels.rotate_trig) */
static void rotate_trig(const sr_plant_model *md, sr_plant_data *d)
{
    int c, j;
    for (c = 0; c < md->n_ch; c++)
        for (j = 0; j < 4; j += 2) {
            const double sn = d->trig[c][j], cs = d->trig[c][j + 1];
            const double ch = d->ex_rot[c][j], sh = d->ex_rot[c][j + 1];
            d->trig[c][j] = sn * ch + cs * sh;
            d->trig[c][j + 1] = cs * ch - sn * sh;
        }
}

/* channel c of the table, f = a/2 [sin(w1 t + p1) + sin(w2 t + p2)], f', f'', from its sines
 * trig (4) at t (kernels.channel_trig) */
static void channel(const double *row, const double *trig, double *f)
{
    const double w1 = row[1], w2 = row[3], h = 0.5 * row[0];
    const double s1 = trig[0], c1 = trig[1], s2 = trig[2], c2 = trig[3];
    f[0] = h * (s1 + s2);
    f[1] = h * (w1 * c1 + w2 * c2);
    f[2] = -h * (w1 * w1 * s1 + w2 * w2 * s2);
}

/* s f and its first two time derivatives (product rule), s = (s, s', s''), f = (f, f', f'') */
static void level_times(const double *s, const double *f, double *out)
{
    out[0] = s[0] * f[0];
    out[1] = s[1] * f[0] + s[0] * f[1];
    out[2] = s[2] * f[0] + 2.0 * s[1] * f[1] + s[0] * f[2];
}

/* The excitation channels at `rate` times the excitation's frequencies into d->ex_tab,
 * d->ex_rot (spacerobot.robots.Excitation.channels of period / rate): two sines per channel
 * at frequencies in [w_f, 3 w_f), spread by the golden ratio and sqrt(2); the joint
 * amplitudes the largest keeping |q_ref - q_home| <= q_max, |qd_ref| <= qd_max,
 * |qdd_ref| <= qdd_max with the level's ramp included. */
static void excitation_table(const sr_plant_model *md, double rate, sr_plant_data *d)
{
    const sr_plant_excitation *ex = &md->ex;
    const double phi = (sqrt(5.0) - 1.0) / 2.0, sq2 = sqrt(2.0);
    const double wf = 2.0 * PI * rate / ex->period;
    const double S1 = 15.0 / 8.0 / ex->ramp, S2 = 10.0 / sqrt(3.0) / (ex->ramp * ex->ramp);
    int c;
    for (c = 0; c < md->n_ch; c++) {
        const int k = 2 * c + 1;
        const double w1 = wf * (1.0 + 2.0 * fmod(phi * k, 1.0));
        const double w2 = wf * (1.0 + 2.0 * fmod(phi * (k + 1), 1.0));
        const double p1 = 2.0 * PI * fmod(sq2 * k, 1.0);
        const double p2 = 2.0 * PI * fmod(sq2 * (k + 1), 1.0);
        double a;
        if (c < md->n_att) {
            a = ex->att_max;
        } else {
            const double qd = S1 + 0.5 * (w1 + w2);
            const double qdd = S2 + S1 * (w1 + w2) + 0.5 * (w1 * w1 + w2 * w2);
            const double a2 = ex->qd_max / qd, a3 = ex->qdd_max / qdd;
            a = ex->q_max;
            if (a2 < a)
                a = a2;
            if (a3 < a)
                a = a3;
        }
        d->ex_tab[c][0] = a;
        d->ex_tab[c][1] = w1;
        d->ex_tab[c][2] = p1;
        d->ex_tab[c][3] = w2;
        d->ex_tab[c][4] = p2;
        sr_sincos(w1 * md->h, &d->ex_rot[c][1], &d->ex_rot[c][0]);
        sr_sincos(w2 * md->h, &d->ex_rot[c][3], &d->ex_rot[c][2]);
    }
    d->ex_rate[1] = rate;
    d->trig_t = NAN;                       /* the cached sines were of the old table */
}

/* The level targeted now: the one requested, or 0 while a change of rate is pending; where
 * the level has settled at 0 the new rate takes over (its table) and the requested level is
 * targeted. A new target starts a ramp from the level in effect at d->t. */
static void excitation_update(const sr_plant_model *md, sr_plant_data *d)
{
    double s[3], target;
    ramp_level(d->t, d->ramp, s);
    if (d->ex_rate[2] != d->ex_rate[1] && s[0] == 0.0 && s[1] == 0.0 && s[2] == 0.0)
        excitation_table(md, d->ex_rate[2], d);
    target = d->ex_rate[2] != d->ex_rate[1] ? 0.0 : d->ex_rate[0];
    if (target == d->ramp[1])
        return;
    d->ramp[0] = s[0];
    d->ramp[1] = target;
    d->ramp[2] = d->t;
    d->ramp[3] = md->ex.ramp;
}

/* -- the controllers ----------------------------------------------------------------------- */

/* Thruster and arm commands at the normalised configuration q, velocity v (kernels.control):
 * M (nv x nv), nle (nv), hg (6) = [P, L_c] the rigid-body terms there; par (11) the controller;
 * t, ramp the excitation (its sines: d->trig where d->trig_t is t, else evaluated here into
 * d->trig). Writes FM[0..5] = [F, M] (inertial), gen (nv) = [f_b, tau] and
 * acc (nv) = dv/dt (M acc + nle = gen by construction). Returns 0 or SR_PLANT_ESINGULAR_*. */
static int control(const sr_plant_model *md, sr_plant_data *d, const double *q, const double *v,
                   const double *M, const double *nle, const double *hg, const double *par,
                   double t, const double *ramp, double *gen, double *acc, double *FM)
{
    const int nv = md->nv, nb = md->nb, n = md->n, r = md->n_att, r0 = nb - r, nq = md->nq;
    const double KD = par[6], KP = par[7], KPn = par[8], KDn = par[9], qdd_max = par[10];
    double e[3], Lb[36], sol[6 * (SR_MAX_JOINTS + 1)], Lm[SR_MAX_JOINTS * SR_MAX_JOINTS];
    double WiGt[SR_MAX_JOINTS * 3], GWG[9], Lg[9], zv[3], rhs[3], post[SR_MAX_JOINTS];
    double lev[3], lam[3], U[9], peak;
    const int w = n + 1;                            /* row length of sol: [X, y0] */
    int i, j, p, k, plain;
    for (i = 0; i < 3; i++) {
        FM[i] = bounded_law(hg[i], par[0], par[1], par[2]);           /* eq. 41 (P) */
        FM[3 + i] = bounded_law(hg[3 + i], par[3], par[4], par[5]);   /* eq. 40 (L_c) */
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
    /* base rows: M_bb dv_b + M_bm qdd = f_b - c_b  ->  dv_b = y0 - X qdd */
    if (!cholesky(M, nv, nb, Lb))
        return SR_PLANT_ESINGULAR_BASE;
    for (i = 0; i < nb; i++) {
        for (j = 0; j < n; j++)
            sol[i * w + j] = M[i * nv + nb + j];
        sol[i * w + n] = gen[i] - nle[i];
    }
    cho_solve(Lb, nb, sol, w);                      /* [X, y0] */
    /* attitude rows: G qdd = y0_rot - alpha_des with G = X_rot; W = M_mm weights the solve */
    if (!cholesky(M + nb * nv + nb, nv, n, Lm))
        return SR_PLANT_ESINGULAR_ARM;
    for (i = 0; i < n; i++)
        for (j = 0; j < r; j++)
            WiGt[i * r + j] = sol[(r0 + j) * w + i];
    cho_solve(Lm, n, WiGt, r);                      /* W^-1 G^T */
    for (i = 0; i < r; i++)
        for (j = 0; j < r; j++) {
            double s = 0.0;
            for (p = 0; p < n; p++)
                s += sol[(r0 + i) * w + p] * WiGt[p * r + j];
            GWG[i * r + j] = s;
        }
    /* posture: -K_Pn (q - q_home) - K_Dn qd */
    for (i = 0; i < n; i++)
        post[i] = -KPn * (q[nq - n + i] - md->q_home[i]) - KDn * v[nb + i];
    /* eq. 39: alpha_des = -K_D omega - K_P e; rhs_att = y0_rot - alpha_des - G post */
    for (j = 0; j < r; j++)
        rhs[j] = sol[(r0 + j) * w + n] + KD * v[r0 + j] + KP * e[3 - r + j];
    ramp_level(t, ramp, lev);
    if (lev[0] != 0.0 || lev[1] != 0.0 || lev[2] != 0.0) {
        /* excitation: posture about q_home + q_r, eq. 39 about the attitude reference e_r:
         * alpha_des = e_r'' - K_D (omega - e_r') - K_P (e - e_r) */
        double f[3], g[3];
        if (!(d->trig_t == t)) {
            fill_trig(md, d, t, d->trig);
            d->trig_t = t;
        }
        for (i = 0; i < n; i++) {
            channel(d->ex_tab[r + i], d->trig[r + i], f);
            level_times(lev, f, g);
            post[i] += g[2] + KPn * g[0] + KDn * g[1];
        }
        for (j = 0; j < r; j++) {
            channel(d->ex_tab[j], d->trig[j], f);
            level_times(lev, f, g);
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
            jacobi_eigh(GWG, 3, lam, U);
            plain = lam[0] / (lam[2] > 1e-300 ? lam[2] : 1e-300) >= 1.01 * DLS_RATIO;
        }
    } else {
        plain = GWG[0] / (GWG[0] > 1e-300 ? GWG[0] : 1e-300) >= 1.01 * DLS_RATIO;
    }
    if (plain) {                                    /* z = (GWG)^-1 rhs */
        if (!cholesky(GWG, r, r, Lg))
            return SR_PLANT_ESINGULAR_COUPLING;
        for (j = 0; j < r; j++)
            zv[j] = rhs[j];
        cho_solve(Lg, r, zv, 1);
    } else {
        double lmax;
        jacobi_eigh(GWG, r, lam, U);
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
    for (i = 0; i < nb; i++) {                      /* dv_b = y0 - X qdd */
        double s = sol[i * w + n];
        for (p = 0; p < n; p++)
            s -= sol[i * w + p] * acc[nb + p];
        acc[i] = s;
    }
    for (i = 0; i < n; i++) {                       /* tau = M_m. acc + c_m (arm rows) */
        double s = nle[nb + i];
        for (p = 0; p < nv; p++)
            s += M[(nb + i) * nv + p] * acc[p];
        gen[nb + i] = s;
    }
    return SR_PLANT_OK;
}

/* propellant mass flow [kg/s] of the thrust FM = [F, M]:
 * (|F_x| + |F_y| + |F_z| + (|M_x| + |M_y| + |M_z|) / arm) / (Isp g0) */
static double mass_flow(const double *FM, const double *pp)
{
    return (fabs(FM[0]) + fabs(FM[1]) + fabs(FM[2])
            + (fabs(FM[3]) + fabs(FM[4]) + fabs(FM[5])) * pp[1]) * pp[0];
}

/* control() limited by the propellant m_p [kg] available for a step of dt: when the flow would
 * need more than m_p, the thrust is scaled by s = m_p / (flow dt) (the gains and bounds of both
 * thruster laws scaled: bounded_law is then s times the unscaled one) and control() runs again
 * so that the accelerations and torques are those of the scaled thrust. FM[6] = the flow
 * (0 without propellant model) (kernels.thrust_control). */
static int thrust_control(const sr_plant_model *md, sr_plant_data *d, double t,
                          const double *ramp, double m_p, double dt)
{
    double parw[SR_PLANT_NPAR], flow, need, s;
    int err, i;
    const double *pp = md->pp;
    err = control(md, d, d->qn, d->vs, d->M, d->nle, d->hg, md->par, t, ramp, d->gen, d->acc, d->FM);
    if (err || pp[0] == 0.0) {
        d->FM[6] = 0.0;
        return err;
    }
    flow = mass_flow(d->FM, pp);
    need = flow * dt;
    if (need <= m_p) {
        d->FM[6] = flow;
        return SR_PLANT_OK;
    }
    s = (m_p > 0.0 ? m_p : 0.0) / need;
    for (i = 0; i < SR_PLANT_NPAR; i++)
        parw[i] = md->par[i];
    parw[0] *= s;                                   /* K_F, F_max, K_M, M_max */
    parw[2] *= s;
    parw[3] *= s;
    parw[5] *= s;
    err = control(md, d, d->qn, d->vs, d->M, d->nle, d->hg, parw, t, ramp, d->gen, d->acc, d->FM);
    d->FM[6] = mass_flow(d->FM, pp);
    return err;
}

/* -- the propellant ------------------------------------------------------------------------ */

/* the base of d->dyn with m_p [kg] of propellant: spatial inertias add, so the base's is the
 * dry one plus m_p times that of 1 kg of propellant at r (I_S += m_p ((2/5) R^2 + |r|^2) 1 -
 * m_p r r^T) (kernels.base_inertia). Nothing to do without propellant model. Returns 0, or
 * SR_PLANT_ENONFINITE for a non-finite or non-positive resulting mass. */
static int base_inertia(const sr_plant_model *md, sr_plant_data *d, double m_p)
{
    const double *pp = md->pp, *rt = md->pp + 3;
    double hB[3], IS[9], rr;
    int i, j;
    if (pp[0] == 0.0)
        return SR_PLANT_OK;
    rr = pp[2] + (rt[0] * rt[0] + rt[1] * rt[1] + rt[2] * rt[2]);
    for (i = 0; i < 3; i++) {
        hB[i] = md->dry_hB[i] + m_p * rt[i];
        for (j = 0; j < 3; j++)
            IS[3 * i + j] = md->dry_IS[3 * i + j]
                            + m_p * ((i == j ? rr : 0.0) - rt[i] * rt[j]);
    }
    return sr_dyn_set_base_spatial(&d->dyn, md->dry[0] + m_p, hB, IS) == SR_DYN_OK
           ? SR_PLANT_OK : SR_PLANT_ENONFINITE;
}

/* rows [dm_p, dP_x (3), dL_x (3)] of the state derivative at the stage state xa (A its base
 * DCM, base_dcm) for the mass flow [kg/s]: the expelled propellant leaves with the tank
 * centre's velocity v_c: dP_x = flow v_c, dL_x = flow (r_c x v_c + (2/5) R^2 omega_I)
 * (kernels._propellant_rates) */
static void propellant_rates(const sr_plant_model *md, const double *xa, const double *A,
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

/* -- RK4 ----------------------------------------------------------------------------------- */

/* the normalised configuration (unit quaternion / (cos, sin) pair) and the velocity of the
 * state x into d->qn, d->vs (kernels.load) */
static void load(const sr_plant_model *md, const double *x, sr_plant_data *d)
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

/* RK4 stage i (0..3) of a step of dt from x (kernels.stage). xa: the stage state where a
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
    propellant_rates(md, xa, A, FM[6], row);
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

/* the sines and cosines of the arm's angles of d->qn into d->sc: sr_sincos's (correctly
 * rounded) when anchor is set, which makes d->qn the anchor (d->q_anc, d->sc_anc), else
 * stepped from the anchor's (step_sincos) */
static void joint_sincos(const sr_plant_model *md, sr_plant_data *d, int anchor)
{
    const double *qa = d->qn + md->nq - md->n;
    int k;
    if (anchor) {
        for (k = 0; k < md->n; k++) {
            sr_sincos(qa[k], &d->sc_anc[2 * k], &d->sc_anc[2 * k + 1]);
            d->q_anc[k] = qa[k];
        }
        for (k = 0; k < 2 * md->n; k++)
            d->sc[k] = d->sc_anc[k];
    } else {
        step_sincos(md->n, d->q_anc, d->sc_anc, qa, d->sc);
    }
}

/* the rigid-body terms and the controls at the state x (time t) for a step of dt, x's
 * configuration already in d->qn, d->vs: d->M, nle, hg, com, gen, acc, FM; the joint
 * placements' sines and cosines as joint_sincos (anchor: afresh) */
static int control_here(const sr_plant_model *md, sr_plant_data *d, const double *x, double t,
                        const double *ramp, double dt, int anchor)
{
    const int om = 6 + md->nq + md->nv;
    if (base_inertia(md, d, x[om]) != SR_PLANT_OK)
        return SR_PLANT_ENONFINITE;
    joint_sincos(md, d, anchor);
    if (sr_dyn_terms_sc(&d->dyn, &d->dd, d->qn, d->vs, d->sc, d->M, d->nle, d->hg, d->com)
        != SR_DYN_OK)
        return SR_PLANT_EARG;
    return thrust_control(md, d, t, ramp, x[om], dt);
}

/* one RK4 step of dt from d->xa (configuration in d->qn, d->vs) at t into d->xn, the controls
 * of its start held over it (kernels.advance's loop body). The joint placements' sines and
 * cosines: sr_sincos at the start of an anchor step, stepped from those at every other
 * stage (joint_sincos) */
static int step(const sr_plant_model *md, sr_plant_data *d, double t, double dt, int anchor)
{
    const int om = 6 + md->nq + md->nv;
    int err, i;
    err = control_here(md, d, d->xa, t, d->ramp, dt, anchor);
    if (err)
        return err;
    stage(md, d, 0, d->xa, d->xa, d->acc, dt);
    for (i = 1; i < 4; i++) {
        if (base_inertia(md, d, d->xs[om]) != SR_PLANT_OK)
            return SR_PLANT_ENONFINITE;
        joint_sincos(md, d, 0);
        err = sr_dyn_aba_sc(&d->dyn, &d->dd, d->qn, d->vs, d->gen, d->sc, d->ddq);
        if (err == SR_DYN_EPD)
            return SR_PLANT_ESINGULAR_ABA;
        if (err)
            return SR_PLANT_EARG;
        stage(md, d, i, d->xa, d->xs, d->ddq, dt);
    }
    return SR_PLANT_OK;
}

/* -- model --------------------------------------------------------------------------------- */

/* a model sr_plant_model_init built (its sizes consistent: no access out of bounds) */
static int model_ok(const sr_plant_model *md)
{
    if (md == NULL || (md->planar != 0 && md->planar != 1) || md->n < 1
        || md->n > SR_MAX_JOINTS)
        return 0;
    return md->nb == (md->planar ? 3 : 6) && md->nq == (md->planar ? 4 : 7) + md->n
           && md->nv == md->nb + md->n && md->nx == 6 + md->nq + md->nv + 7
           && md->ny == 64 + 5 * md->n && md->n_att == (md->planar ? 1 : 3)
           && md->n_ch == md->n_att + md->n && md->h > 0.0 && md->h <= 1.0
           && md->ex.ramp > 0.0;
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

static const char *const CTRL_NAMES[SR_PLANT_NPAR] = {
    "K_F", "P_max", "F_max", "K_M", "L_max", "M_max", "K_D", "K_P", "K_Pn", "K_Dn", "qdd_max"};

static int fail(sr_plant_model *model, char *err, size_t errlen, const char *a, const char *b)
{
    memset(model, 0, sizeof(*model));
    sr_text_set(err, errlen, a);
    sr_text_cat(err, errlen, b);
    return SR_PLANT_EARG;
}

SR_API int sr_plant_model_init(sr_plant_model *model, const sr_robot *robot, const sr_body *base,
                               const sr_body *target, const sr_plant_controller *ctrl,
                               const sr_plant_excitation *ex, const sr_plant_propellant *prop,
                               const double *q_home, const double v0[3], const double w0[3],
                               double h, char *err, size_t errlen)
{
    const double *par;
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
        return fail(model, err, errlen, "a required argument is NULL", NULL);
    if (!(h >= 1e-6 && h <= 1.0))
        return fail(model, err, errlen, "h must be in [1e-6, 1] s", NULL);
    if (robot->n < 1 || robot->n > SR_MAX_JOINTS || (robot->planar != 0 && robot->planar != 1))
        return fail(model, err, errlen, "robot: joint count or planar flag out of range", NULL);
    if (!check_body(base, "base", err, errlen) || !check_body(target, "target", err, errlen)) {
        memset(model, 0, sizeof(*model));           /* the message is in err */
        return SR_PLANT_EARG;
    }
    par = &ctrl->K_F;
    for (i = 0; i < SR_PLANT_NPAR; i++) {
        if (!(fabs(par[i]) <= 1e9))     /* beyond, products overflow within a step */
            return fail(model, err, errlen, CTRL_NAMES[i], " must be a number within +-1e9");
        if ((i == 1 || i == 2 || i == 4 || i == 5 || i == 10) && !(par[i] >= 0.0))
            return fail(model, err, errlen, CTRL_NAMES[i], " must be >= 0");
    }
    {
        const double exv[6] = {ex->att_max, ex->q_max, ex->qd_max, ex->qdd_max, ex->period,
                               ex->ramp};
        static const char *const names[6] = {"excite.att_max", "excite.q_max", "excite.qd_max",
                                             "excite.qdd_max", "excite.period", "excite.ramp"};
        static const double lo[6] = {0.0, 0.0, 0.0, 0.0, 1e-3, 1e-3},
                            hi[6] = {3.141592653589793, 6.283185307179586, 1e3, 1e6, 1e9, 1e9};
        static const char *const range[6] = {" must be in [0, pi] rad", " must be in [0, 2 pi] rad",
                                             " must be in [0, 1e3] rad/s",
                                             " must be in [0, 1e6] rad/s2",
                                             " must be in [1e-3, 1e9] s", " must be in [1e-3, 1e9] s"};
        for (i = 0; i < 6; i++)
            if (!(exv[i] >= lo[i] && exv[i] <= hi[i]))
                return fail(model, err, errlen, names[i], range[i]);
    }
    if (!(prop->m0 >= 0.0 && prop->m0 <= 1e9))
        return fail(model, err, errlen, "prop.m0 must be in [0, 1e9] kg", NULL);
    if (!(prop->Isp >= 1e-3 && prop->Isp <= 1e9))
        return fail(model, err, errlen, "prop.Isp must be in [1e-3, 1e9] s", NULL);
    if (!(prop->arm >= 1e-6 && prop->arm <= 1e6))
        return fail(model, err, errlen, "prop.arm must be in [1e-6, 1e6] m", NULL);
    if (!(prop->R >= 0.0 && prop->R <= 1e3))
        return fail(model, err, errlen, "prop.R must be in [0, 1e3] m", NULL);
    for (i = 0; i < 3; i++) {
        if (!(fabs(prop->r[i]) <= 1e3))
            return fail(model, err, errlen, "prop.r must be 3 numbers within +-1e3 m", NULL);
        if (!(fabs(v0[i]) <= 1e6))
            return fail(model, err, errlen, "base.v0 must be 3 numbers within +-1e6 m/s", NULL);
        if (!(fabs(w0[i]) <= 1e3))
            return fail(model, err, errlen, "base.omega0 must be 3 numbers within +-1e3 rad/s",
                        NULL);
    }
    if (q_home != NULL && !sr_finite_all(q_home, robot->n))
        return fail(model, err, errlen, "q_home must be finite numbers [rad]", NULL);
    /* the robot + target on the dry base */
    if (sr_dyn_model_init(&model->dyn, robot, target) != SR_DYN_OK
        || sr_dyn_set_base(&model->dyn, base) != SR_DYN_OK)
        return fail(model, err, errlen, "robot: the record is not a valid robot", NULL);
    n = robot->n;
    nq = robot->planar ? 4 + n : 7 + n;
    model->planar = robot->planar;
    model->n = n;
    model->nq = nq;
    model->nb = robot->planar ? 3 : 6;
    model->nv = model->nb + n;
    model->nx = 6 + nq + model->nv + 7;
    model->ny = 64 + 5 * n;
    model->n_att = robot->planar ? 1 : 3;
    model->n_ch = model->n_att + n;
    for (i = 0; i < SR_PLANT_NPAR; i++)
        model->par[i] = par[i];
    for (i = 0; i < n; i++)
        model->q_home[i] = q_home != NULL ? q_home[i] : 0.0;
    model->h = h;
    model->ex = *ex;
    /* propellant (simulator.propellant_array): all zero when its model is off */
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
    if (!model_ok(model))
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

static const char *const OUTPUT_NAMES[SR_PLANT_Y_COUNT] = {
    "r_S", "v_S", "A", "omega_B", "a_S", "alpha_B", "q", "qd", "qdd", "F", "M", "J", "H", "P",
    "L", "tau", "excite_level", "att_ref", "qd_ref", "m_p", "P_x", "L_x", "base_now",
    "excite_rate"};

SR_API int sr_plant_output_offsets(const sr_plant_model *model, int *offsets)
{
    /* sizes, -1 for n */
    static const int size[SR_PLANT_Y_COUNT] = {3, 3, 9, 3, 3, 3, -1, -1, -1, 3, 3, 3, 3, 3, 3,
                                               -1, 1, 3, -1, 1, 3, 3, 10, 1};
    int k, o = 0;
    if (!model_ok(model) || offsets == NULL)
        return SR_PLANT_EARG;
    for (k = 0; k < SR_PLANT_Y_COUNT; k++) {
        offsets[k] = o;
        o += size[k] < 0 ? model->n : size[k];
    }
    offsets[SR_PLANT_Y_COUNT] = o;
    return SR_PLANT_OK;
}

SR_API const char *sr_plant_output_name(int k)
{
    return (k >= 0 && k < SR_PLANT_Y_COUNT) ? OUTPUT_NAMES[k] : NULL;
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

/* -- data ---------------------------------------------------------------------------------- */

SR_API int sr_plant_start(const sr_plant_model *model, sr_plant_data *data)
{
    if (!model_ok(model) || data == NULL)
        return SR_PLANT_EARG;
    memset(data, 0, sizeof(*data));
    data->t = 0.0;
    memcpy(data->x, model->x0, sizeof(data->x));
    data->ramp[0] = 0.0;
    data->ramp[1] = 0.0;
    data->ramp[2] = 0.0;
    data->ramp[3] = model->ex.ramp;
    data->dyn = model->dyn;
    data->ex_rate[0] = 0.0;                         /* no level requested, the own rate */
    data->ex_rate[2] = 1.0;
    excitation_table(model, 1.0, data);
    return SR_PLANT_OK;
}

SR_API int sr_plant_set_excitation(const sr_plant_model *model, sr_plant_data *data,
                                   double level)
{
    if (!model_ok(model) || data == NULL || !(level >= 0.0 && level <= 1.0))
        return SR_PLANT_EARG;
    data->ex_rate[0] = level;
    excitation_update(model, data);
    return SR_PLANT_OK;
}

SR_API int sr_plant_set_excitation_rate(const sr_plant_model *model, sr_plant_data *data,
                                        double rate)
{
    if (!model_ok(model) || data == NULL
        || !(rate >= SR_PLANT_RATE_MIN && rate <= SR_PLANT_RATE_MAX))
        return SR_PLANT_EARG;
    data->ex_rate[2] = rate;
    excitation_update(model, data);
    return SR_PLANT_OK;
}

SR_API int sr_plant_excitation_rate(const sr_plant_model *model, const sr_plant_data *data,
                                    double *rate)
{
    if (!model_ok(model) || data == NULL || rate == NULL)
        return SR_PLANT_EARG;
    rate[0] = data->ex_rate[1];
    rate[1] = data->ex_rate[2];
    return SR_PLANT_OK;
}

SR_API int sr_plant_excitation_level(const sr_plant_model *model, const sr_plant_data *data,
                                     double *s)
{
    if (!model_ok(model) || data == NULL || s == NULL)
        return SR_PLANT_EARG;
    ramp_level(data->t, data->ramp, s);
    return SR_PLANT_OK;
}

SR_API int sr_plant_advance(const sr_plant_model *model, sr_plant_data *data, double dt)
{
    const sr_plant_model *md = model;
    sr_plant_data *d = data;
    double steps, rest, t;
    long k, n, total;
    int err, j, nx, excited;
    if (!model_ok(md) || d == NULL || !(dt > 0.0 && isfinite(dt)))
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
    excitation_update(md, d);                       /* a pending rate whose dip has ended */
    /* work on a copy: d->x, d->t change only when every step succeeded */
    for (j = 0; j < nx; j++)
        d->xa[j] = d->x[j];
    t = d->t;
    excited = d->ramp[0] != 0.0 || d->ramp[1] != 0.0;
    d->trig_t = NAN;                                /* evaluated afresh at the first step */
    load(md, d->xa, d);
    for (k = 0; k < total; k++) {
        const double h = k < n ? md->h : rest, t_prev = t;
        err = step(md, d, t, h, k % SR_PLANT_JOINT_ANCHOR == 0);
        if (err)
            return err;
        if (!sr_finite_all(d->xn, nx))
            return SR_PLANT_ENONFINITE;
        if (d->xn[6 + md->nq + md->nv] < 0.0)        /* an emptied tank: round-off below 0 kg */
            d->xn[6 + md->nq + md->nv] = 0.0;
        for (j = 0; j < nx; j++)                    /* stage() left xn's configuration in qn */
            d->xa[j] = d->xn[j];
        t += h;
        /* the next step's sines from this step's, rotated by h (kernels.advance) */
        if (excited && d->trig_t == t_prev && h == md->h
            && (k + 1) % SR_PLANT_TRIG_ANCHOR != 0) {
            rotate_trig(md, d);
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

/* the base's truth [m, b, I6] with m_p of propellant (spacerobot.robots.Propellant.base):
 * m = m_d + m_p, b = b_d + (m_p / m)(r - b_d), I = I_d + m_d S(b_d - b) + (2/5) m_p R^2 1 +
 * m_p S(r - b), S(d) = |d|^2 1 - d d^T (kernels._base_now) */
static void base_now(const sr_plant_model *md, double m_p, double *out)
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

SR_API int sr_plant_outputs(const sr_plant_model *model, sr_plant_data *data, double *y)
{
    const sr_plant_model *md = model;
    sr_plant_data *d = data;
    double A[9], r[3], vl[3], w[3], dl[3], al[3], e[3], lev[3];
    const double *x, *q, *v, *acc, *hg, *c;
    int err, i, j, o, n, nb, nq, om, ra;
    if (!model_ok(md) || d == NULL || y == NULL)
        return SR_PLANT_EARG;
    n = md->n;
    nb = md->nb;
    nq = md->nq;
    om = 6 + nq + md->nv;
    x = d->x;
    d->dyn = md->dyn;
    d->trig_t = NAN;                                /* the sines evaluated afresh at t */
    load(md, x, d);
    err = control_here(md, d, x, d->t, d->ramp, md->h, 1);
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
        y[i] = r[i];
        y[3 + i] = A[3 * i] * vl[0] + A[3 * i + 1] * vl[1] + A[3 * i + 2] * vl[2];
        y[15 + i] = w[i];
        y[18 + i] = A[3 * i] * e[0] + A[3 * i + 1] * e[1] + A[3 * i + 2] * e[2];
        y[21 + i] = al[i];
    }
    for (i = 0; i < 9; i++)
        y[6 + i] = A[i];
    o = 24;
    for (i = 0; i < n; i++) {
        y[o + i] = q[nq - n + i];
        y[o + n + i] = v[nb + i];
        y[o + 2 * n + i] = acc[nb + i];
    }
    o += 3 * n;
    for (i = 0; i < 6; i++) {                       /* F, M, J, H */
        y[o + i] = d->FM[i];
        y[o + 6 + i] = x[i];
    }
    o += 12;
    /* P and L about the inertial origin: L_c + c x P */
    y[o] = hg[0];
    y[o + 1] = hg[1];
    y[o + 2] = hg[2];
    y[o + 3] = hg[3] + (c[1] * hg[2] - c[2] * hg[1]);
    y[o + 4] = hg[4] + (c[2] * hg[0] - c[0] * hg[2]);
    y[o + 5] = hg[5] + (c[0] * hg[1] - c[1] * hg[0]);
    o += 6;
    for (i = 0; i < n; i++)
        y[o + i] = d->gen[nb + i];
    o += n;
    ramp_level(d->t, d->ramp, lev);
    y[o] = lev[0];
    o += 1;
    ra = md->n_att;
    for (i = 0; i < 3 + n; i++)                     /* att_ref (3), qd_ref (n) */
        y[o + i] = 0.0;
    if (d->ramp[0] != 0.0 || d->ramp[1] != 0.0) {
        double f[3], g[3];
        if (!(d->trig_t == d->t)) {
            fill_trig(md, d, d->t, d->trig);
            d->trig_t = d->t;
        }
        for (j = 0; j < ra; j++) {
            channel(d->ex_tab[j], d->trig[j], f);
            level_times(lev, f, g);
            y[o + 3 - ra + j] = g[0];
        }
        for (i = 0; i < n; i++) {
            channel(d->ex_tab[ra + i], d->trig[ra + i], f);
            level_times(lev, f, g);
            y[o + 3 + i] = g[1];
        }
    }
    o += 3 + n;
    for (i = 0; i < 7; i++)                         /* m_p, P_x, L_x */
        y[o + i] = x[om + i];
    o += 7;
    base_now(md, x[om], y + o);
    o += 10;
    y[o] = d->ex_rate[1];
    return sr_finite_all(y, md->ny) ? SR_PLANT_OK : SR_PLANT_ENONFINITE;
}

SR_API int sr_plant_controls(const sr_plant_model *model, sr_plant_data *data, double *F,
                             double *M, double *tau, double *a, double *flow)
{
    int err, i;
    if (!model_ok(model) || data == NULL)
        return SR_PLANT_EARG;
    data->dyn = model->dyn;
    data->trig_t = NAN;
    load(model, data->x, data);
    err = control_here(model, data, data->x, data->t, data->ramp, model->h, 1);
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

SR_API int sr_plant_base_now(const sr_plant_model *model, const sr_plant_data *data,
                             double *out)
{
    if (!model_ok(model) || data == NULL || out == NULL)
        return SR_PLANT_EARG;
    base_now(model, data->x[6 + model->nq + model->nv], out);
    return SR_PLANT_OK;
}

SR_API int sr_plant_references(const sr_plant_model *model, const sr_plant_data *data,
                               double *ref)
{
    double lev[3], f[3], trig[SR_PLANT_MAX_CHANNELS][4];
    int c;
    if (!model_ok(model) || data == NULL || ref == NULL)
        return SR_PLANT_EARG;
    ramp_level(data->t, data->ramp, lev);
    fill_trig(model, data, data->t, trig);
    for (c = 0; c < model->n_ch; c++) {
        channel(data->ex_tab[c], trig[c], f);
        level_times(lev, f, ref + 3 * c);
    }
    return SR_PLANT_OK;
}

SR_API int sr_plant_get_state(const sr_plant_model *model, const sr_plant_data *data, double *t,
                              double *x, double *ex)
{
    int j;
    if (!model_ok(model) || data == NULL)
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
    if (!model_ok(model) || data == NULL || x == NULL) {
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
    if (!(mp >= 0.0 && mp <= model->m0 * (1.0 + 1e-12))) {
        sr_text_set(err, errlen, "propellant mass outside [0, prop.m0]");
        return SR_PLANT_EARG;
    }
    data->t = t;
    for (j = 0; j < model->nx; j++)
        data->x[j] = x[j];
    for (j = 0; j < 4; j++)
        data->ramp[j] = rp[j];
    data->ex_rate[0] = rp[4];
    data->ex_rate[2] = rp[6];
    excitation_table(model, rp[5], data);
    return SR_PLANT_OK;
}
