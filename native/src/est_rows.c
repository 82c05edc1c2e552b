/* The rows of one sample (est_rows.h): its equations, formed against the momentum reference or
 * the momentum window, about the base's position, from the differencing window's centre or as
 * the derivative of the window's momentum equations; their consider columns and noise rows;
 * and the commit of what the sample leaves in the Data block. */
#include "est_rows.h"

#include <math.h>
#include <string.h>

#include "differencing.h"
#include "sr_text.h"

/* -- the Data block's rings ----------------------------------------------------------------- */

static double *history(const sr_estimator_model *m, void *data)
{
    return (double *)((char *)data + m->off_hist);
}

/* the slot (t, sample (, own-point rows and their noise rows)) of the differencing history's
 * i-th oldest sample */
static const double *hist_slot(const sr_estimator_model *m, const void *data, const est_core *c,
                               int i)
{
    int cap = 2 * m->half;
    int idx = (c->hist_head - c->hist_count + i + 2 * cap) % cap;
    return history(m, (void *)data) + (size_t)idx * (size_t)m->slot;
}

/* the sample (t, x, its own-point rows own where the derivative is the momentum
 * equations', and their noise rows noise where the noise is compensated) into the history
 * ring's next slot (over the oldest once full) */
static void push_history(const sr_estimator_model *m, void *data, est_core *c, double t,
                         const double *x, const double *own, const double *noise)
{
    double *slot = history(m, data) + (size_t)c->hist_head * (size_t)m->slot;
    slot[0] = t;
    memcpy(slot + 1, x, sizeof(double) * m->nflat);
    if (m->diffmom)
        memcpy(slot + 1 + m->nflat, own,
               sizeof(double) * (EST_NB + (m->consider ? 3 * SR_N_CCOLS : 0)));
    if (m->diffmom && m->eiv)
        memcpy(slot + m->slot_noise, noise, sizeof(double) * m->n_used * EST_NB);
    c->hist_head = (c->hist_head + 1) % (2 * m->half);
}

/* the slot (t, sample, with the thrust integrals their 15 integrals) of the momentum window
 * ring's i-th oldest sample */
static const double *win_at(const sr_estimator_model *m, const void *data, const est_core *c,
                            int i)
{
    int cap = m->win_cap;
    int idx = (c->win_head - c->win_count + i + 2 * cap) % cap;
    return (const double *)((const char *)data + m->off_win) + (size_t)idx * (size_t)m->win_slot;
}

/* the sample (t, x, its thrust integrals k (15) or NULL) into the window ring's next slot
 * after dropping its drop oldest samples (the caller checked the capacity) */
static void win_push(const sr_estimator_model *m, void *data, est_core *c, int drop, double t,
                     const double *x, const double *k)
{
    double *slot = (double *)((char *)data + m->off_win)
                   + (size_t)c->win_head * (size_t)m->win_slot;
    c->win_count -= drop;
    slot[0] = t;
    memcpy(slot + 1, x, sizeof(double) * m->nflat);
    if (m->thrust_int)
        memcpy(slot + 1 + m->nflat, k, sizeof(double) * SR_THRUST_NK);
    c->win_head = (c->win_head + 1) % m->win_cap;
    c->win_count++;
}

int est_rows_last_time(const sr_estimator_model *m, const void *data, double *last)
{
    const est_core *c = &((const est_data *)data)->core;
    int has = 0;
    *last = 0.0;
    if (m->differenced && c->hist_count > 0) {
        *last = hist_slot(m, data, c, c->hist_count - 1)[0];
        has = 1;
    }
    if (m->window && c->win_count > 0) {
        double tw = win_at(m, data, c, c->win_count - 1)[0];
        *last = has ? est_pymax(*last, tw) : tw;
        has = 1;
    }
    if (m->thrust_int && c->thr_started) {
        *last = has ? est_pymax(*last, c->thr[SR_THRUST_T]) : c->thr[SR_THRUST_T];
        has = 1;
    }
    if (m->info) {                           /* the information filter's thrust integrals */
        const sr_info_data *f = est_info_data(m, data);
        if (f->samples > 0) {
            *last = has ? est_pymax(*last, f->K[SR_THRUST_T]) : f->K[SR_THRUST_T];
            has = 1;
        }
    }
    return has;
}

/* -- the equations -------------------------------------------------------------------------- */

/* The equations of the flat sample x (force: eqs. 28/31, else 11/16) into E (3 x 42) and,
 * where Ec is given and the consider term is on, their consider columns (3 x 16) with the
 * thrust integrals k (15; the momentum form's): the one place a sample's equations are
 * evaluated */
static void equations_of(const sr_estimator_model *m, int force, const double *x,
                         const double *k, double *E, double *Ec)
{
    sr_equations(&m->robot, force, x, E);
    if (Ec && m->consider)
        sr_thrust_sensitivity(force, x, m->n, k, Ec);
}

/* out (3 x ncols) = [p]x src (3 rows of ncols, row stride stride) */
static void cross_rows(const double *p, const double *src, int stride, int ncols, double *out)
{
    const double P[9] = {0.0, -p[2], p[1], p[2], 0.0, -p[0], -p[1], p[0], 0.0};   /* [p]x */
    for (int i = 0; i < 3; i++)
        for (int c = 0; c < ncols; c++)
            out[i * ncols + c] = P[3 * i] * src[c] + P[3 * i + 1] * src[stride + c]
                                 + P[3 * i + 2] * src[2 * stride + c];
}

/* The angular rows of a momentum equation array E (3 x 42) about the point p (3) instead of
 * the inertial origin, in place: L_p = L_O - p x P, H_p = H_O - p x J, so y -= [p]x b and, mu
 * being the entries m, m b of D(mu) of each body, psi[:, D index of mu] += [p]x A; the
 * linear rows [A | b] (3 x 9, row stride lin_stride) taken from lin (E's own: lin = E,
 * lin_stride = SR_N_COLS). */
static void about_point_of(double *E, const double *p, const double *lin, int lin_stride)
{
    double pl[3 * 9];
    cross_rows(p, lin, lin_stride, 9, pl);
    for (int i = 0; i < 3; i++) {
        double *row = E + i * SR_N_COLS;
        row[SR_COL_Y] -= pl[9 * i + 8];                      /* y' = y - [p]x b */
        for (int c = 0; c < 4; c++) {
            row[SR_COL_PSI + c] += pl[9 * i + c];            /* base m, m b */
            row[SR_COL_PSI + 10 + c] += pl[9 * i + 4 + c];   /* target m, m b */
        }
    }
}

/* The consider columns Ec (3 x 16: [b_c | y_c] per row) of about_point_of: y_c -= [p]x b_c,
 * b_c taken from src (3 rows of stride src_stride; Ec's own: src = Ec, SR_N_CCOLS) */
static void about_point_c(double *Ec, const double *p, const double *src, int src_stride)
{
    double pb[3 * SR_N_CONSIDER];
    cross_rows(p, src, src_stride, SR_N_CONSIDER, pb);
    for (int i = 0; i < 3; i++)
        for (int c = 0; c < SR_N_CONSIDER; c++)
            Ec[i * SR_N_CCOLS + SR_N_CONSIDER + c] -= pb[SR_N_CONSIDER * i + c];
}

/* The momentum equations of the flat sample x with their angular rows about its own r_S:
 * L_O - [r]x P, P = the system's momentum (the linear rows without the impulse:
 * [A | b - J]). With the consider term its consider columns follow (own + 3 x 42, 3 x 16):
 * the sample's momentum-form sensitivities with the thrust integrals k (15) up to it,
 * unchanged by the point (only the impulse depends on the thrust, and P has none of it);
 * k NULL: the rows alone. */
static void own_point_rows(const sr_estimator_model *m, const double *x, const double *k,
                           double *own)
{
    double mom[3 * 9];
    equations_of(m, 0, x, k, own, k ? own + EST_NB : NULL);   /* eqs. 11/16 of this sample */
    for (int i = 0; i < 3; i++) {
        memcpy(mom + 9 * i, own + i * SR_N_COLS, sizeof(double) * 8);
        mom[9 * i + 8] = own[i * SR_N_COLS + SR_COL_B] - x[SR_X_J(m->n) + i];
    }
    about_point_of(own, x + SR_X_R_S, mom, 9);
}

/* The noise rows sigma_l C_l of the own-point rows own (3 x 42) of the flat sample x in the
 * velocity channels with sd > 0 (est_eiv.h, eq. 1: C_l = own(x + e_l) - own(x), the rows
 * being affine in the velocities: the [u v]x P(v) term's quadratic part is [e]x (m e) = 0)
 * into C (n_used blocks of 3 x 42). */
static void own_point_noise(const sr_estimator_model *m, const double *x, const double *own,
                            double *C)
{
    double xk[SR_X_LEN(SR_MAX_JOINTS)], ok[EST_NB];
    memcpy(xk, x, sizeof(double) * m->nflat);
    for (int b = 0; b < m->n_used; b++) {
        int l = m->used[b], i = m->vel_ch[l];
        double sd = m->accel_sd[l];
        xk[i] = x[i] + 1.0;
        own_point_rows(m, xk, NULL, ok);
        xk[i] = x[i];
        for (int a = 0; a < EST_NB; a++)
            C[b * EST_NB + a] = sd * (ok[a] - own[a]);
    }
}

/* A window row (3 x 42) of the sample x from its equations Et and its reference's Er:
 * Et - Er, with momentum_point about x's r_S */
static void window_row(const sr_estimator_model *m, const double *x, const double *Et,
                       const double *Er, double *out)
{
    for (int i = 0; i < EST_NB; i++)
        out[i] = Et[i] - Er[i];
    if (m->opt.momentum_point)
        about_point_of(out, x + SR_X_R_S, out, SR_N_COLS);
}

/* The noise rows of the window row rw->E of the sample x and its reference xr (the modal
 * columns' errors in variables, est_modal.h): per noisy channel l (the model's win_ch),
 * sigma_l (row(x + e_l) - row(x)) into chunk 0 and sigma_l (row(xr + e_l) - row(xr)) into
 * chunk 1 (n_win blocks of 3 x 42 each), the row being affine in each channel (the momentum
 * equations in the velocities and in r_S; the point r_S of x) and the two samples' noises
 * independent */
static void window_noise(const sr_estimator_model *m, const double *x, const double *xr,
                         est_rows *rw, double *noise)
{
    for (int side = 0; side < 2; side++) {
        const double *xs = side ? xr : x;
        memcpy(rw->xk, xs, sizeof(double) * m->nflat);
        for (int b = 0; b < m->n_win; b++) {
            int i = m->win_ch[b];
            double *C = noise + ((size_t)side * m->n_win + b) * EST_NB;
            rw->xk[i] = xs[i] + 1.0;
            equations_of(m, 0, rw->xk, NULL, rw->Ek, NULL);
            if (side)
                window_row(m, x, rw->Et, rw->Ek, C);
            else
                window_row(m, rw->xk, rw->Ek, rw->Er, C);
            rw->xk[i] = xs[i];
            for (int a = 0; a < EST_NB; a++)
                C[a] = m->win_sd[b] * (C[a] - rw->E[a]);
        }
    }
}

/* The noise rows sigma_l C_l of the force equations E (3 x 42) of the flat sample x in the
 * acceleration channels with sd > 0 (C_l = E(x + e_l) - E(x), eq. 1: the equations are affine
 * in the accelerations), each sd times the derivative's gain, into C (n_used blocks). */
static void force_noise(const sr_estimator_model *m, const double *x, const double *E,
                        double gain, double *C)
{
    double xk[SR_X_LEN(SR_MAX_JOINTS)], Ek[EST_NB];
    memcpy(xk, x, sizeof(double) * m->nflat);
    for (int b = 0; b < m->n_used; b++) {
        int l = m->used[b], i = m->accel_ch[l];
        double sd = m->accel_sd[l] * gain;               /* differenced: the derivative's */
        xk[i] = x[i] + 1.0;
        equations_of(m, 1, xk, NULL, Ek, NULL);
        xk[i] = x[i];
        for (int a = 0; a < EST_NB; a++)
            C[b * EST_NB + a] = sd * (Ek[a] - E[a]);
    }
}

/* The centre sample of the window (the 2 m stored samples and the new one, x at t) with its
 * accelerations the derivatives of its velocities at its time (sr_centre_derivative_rows)
 * into xc (nflat), and the derivative's noise gain |w| (white velocity noise s gives s |w|).
 * Returns 0 or the weights' status. */
static int centre_sample(const sr_estimator_model *m, const void *data, const est_core *c,
                         double t, const double *x, double *xc, double *gain)
{
    int half = m->half, k = 2 * half + 1;
    double times[SR_DIFF_MAX_SAMPLES], w[SR_DIFF_MAX_SAMPLES], t_c;
    const double *rows[SR_DIFF_MAX_SAMPLES];
    for (int i = 0; i < k - 1; i++) {
        const double *s = hist_slot(m, data, c, i);
        times[i] = s[0];
        rows[i] = s + 1;
    }
    times[k - 1] = t;
    rows[k - 1] = x;
    int st = sr_centre_derivative_rows(times, rows, k, m->nflat, m->accel_ch, m->vel_ch,
                                       6 + m->n, xc, &t_c, w);
    if (st != 0)
        return st;
    double g = 0.0;
    for (int i = 0; i < k; i++)
        g += w[i] * w[i];
    *gain = sqrt(g);
    return 0;
}

/* the consider columns (3 x 16) that follow own-point rows (3 x 42) */
static const double *own_c_of(const double *own) { return own + EST_NB; }

/* The momentum equations differentiated at the centre c of the window (the 2 m stored
 * samples and the new one, x with its own-point rows own_x) by the derivative's weights w
 * (docs/identification.md section 6): for any weights with sum w = 0 the unknown momentum
 * cancels and sum_i w_i E_mom(t_i) holds exactly (the force equations averaged by the
 * derivative's filter). With P_i the momentum, J_i the impulse, tau_i = t_i - t_c and u the
 * displacement weights:
 *   sum_i w_i (L_O,i - [r_c]x (P_i - J_i))
 *     = sum_i w_i (L_O,i - [r_i]x P_i)                 own point: no position needed
 *     + [sum_i w_i (r_i - r_c)]x P_c                   = [u . v]x P_c (velocities)
 *     + sum_i w_i [r_i - r_c]x (J_i - J_c)             ~ [v_c]x sum_i w_i tau_i (J_i - J_c)
 *     + [r_c]x sum_i w_i J_i
 * into out (3 x 42); with the consider term its consider columns into out_c (3 x 16), the
 * own-point rows' (each sample's own_x + 3 x 42) combined the same way. Where the noise is
 * compensated, the noise rows of the window's samples (noise_x the new sample's,
 * own_point_noise) combined as the rows into noise (k chunks of n_used blocks): w_j sigma_l
 * C_l,j, with for v_S channels + [u_j sigma_l e_l]x P_c (the displacement's) and at the
 * centre + [u.v]x dP_c (the centre's momentum's). Returns 0 or the weights' status. */
static int momentum_derivative(const sr_estimator_model *m, const void *data, const est_core *c,
                               double t, const double *x, const double *own_x, double *out,
                               double *out_c, const double *noise_x, double *noise)
{
    int half = m->half, k = 2 * half + 1, oJ = SR_X_J(m->n);
    if (k > SR_DIFF_MAX_DISPLACEMENT_SAMPLES)            /* (the options refuse it) */
        return 1;
    double times[SR_DIFF_MAX_DISPLACEMENT_SAMPLES], w[SR_DIFF_MAX_DISPLACEMENT_SAMPLES];
    double u[SR_DIFF_MAX_DISPLACEMENT_SAMPLES];
    const double *fl[SR_DIFF_MAX_DISPLACEMENT_SAMPLES], *own[SR_DIFF_MAX_DISPLACEMENT_SAMPLES];
    for (int i = 0; i < k - 1; i++) {
        const double *slot = hist_slot(m, data, c, i);
        times[i] = slot[0];
        fl[i] = slot + 1;
        own[i] = slot + 1 + m->nflat;
    }
    times[k - 1] = t;
    fl[k - 1] = x;
    own[k - 1] = own_x;
    int st = sr_derivative_weights(times, k, half, w);
    if (st == 0)
        st = sr_displacement_weights(times, k, half, w, u);
    if (st != 0)
        return st;
    const double *xc = fl[half], *own_c = own[half];
    double v_u[3] = {0.0, 0.0, 0.0};                         /* sum u v = sum w (r - r_c) */
    for (int i = 0; i < k; i++)
        for (int j = 0; j < 3; j++)
            v_u[j] += u[i] * fl[i][SR_X_V_S + j];
    for (int a = 0; a < EST_NB; a++) {                       /* d/dt momentum ~ force */
        double s = 0.0;
        for (int i = 0; i < k; i++)
            s += w[i] * own[i][a];
        out[a] = s;
    }
    double lin[27] = {0.0};                                  /* [A | b] rows, A = 0 */
    for (int j = 0; j < 3; j++) {                            /* + [r_c]x sum w J */
        double s = 0.0;
        for (int i = 0; i < k; i++)
            s += w[i] * fl[i][oJ + j];
        lin[9 * j + 8] = s;
    }
    about_point_of(out, xc + SR_X_R_S, lin, 9);
    double mom_c[27], neg_vu[3] = {-v_u[0], -v_u[1], -v_u[2]};
    for (int j = 0; j < 3; j++) {                            /* + [u.v]x P_c */
        memcpy(mom_c + 9 * j, own_c + j * SR_N_COLS, sizeof(double) * 8);
        mom_c[9 * j + 8] = own_c[j * SR_N_COLS + SR_COL_B] - xc[oJ + j];
    }
    about_point_of(out, neg_vu, mom_c, 9);
    for (int j = 0; j < 3; j++) {                            /* + [v_c]x sum w tau (J - J_c) */
        double s = 0.0;
        for (int i = 0; i < k; i++)
            s += w[i] * (times[i] - times[half]) * (fl[i][oJ + j] - xc[oJ + j]);
        lin[9 * j + 8] = s;
    }
    about_point_of(out, xc + SR_X_V_S, lin, 9);
    if (m->consider) {
        /* the consider columns the same way: sum_i w_i C_i of the own-point rows' (their
         * impulse's, E_i's), y_c -= [r_c]x sum_i w_i b_c,i, and the lever term
         * y_c -= [v_c]x sum_i w_i tau_i (b_c,i - b_c,c) (P has no consider part) */
        const int nk = 3 * SR_N_CCOLS;
        const double *own_cc = own_c_of(own[half]);
        double imp[3 * SR_N_CCOLS], lev[3 * SR_N_CCOLS];
        for (int a = 0; a < nk; a++) {
            double s = 0.0, l = 0.0;
            for (int i = 0; i < k; i++) {
                const double *oc = own_c_of(own[i]);
                s += w[i] * oc[a];
                l += w[i] * (times[i] - times[half]) * (oc[a] - own_cc[a]);
            }
            out_c[a] = s;
            imp[a] = s;
            lev[a] = l;
        }
        about_point_c(out_c, xc + SR_X_R_S, imp, SR_N_CCOLS);
        about_point_c(out_c, xc + SR_X_V_S, lev, SR_N_CCOLS);
    }
    if (m->eiv) {                            /* the noise rows, one chunk per sample */
        for (int i = 0; i < k; i++) {
            const double *Ci = i == k - 1 ? noise_x : own[i] - 1 - m->nflat + m->slot_noise;
            double *chunk = noise + (size_t)i * m->n_used * EST_NB;
            for (int b = 0; b < m->n_used; b++) {
                int l = m->used[b];
                double *B = chunk + b * EST_NB;
                for (int a = 0; a < EST_NB; a++)             /* w_j sigma_l C_l,j */
                    B[a] = w[i] * Ci[b * EST_NB + a];
                if (l < 3) {                                 /* v_S: [u_j sigma e_l]x P_c */
                    double e[3] = {0.0, 0.0, 0.0};
                    e[l] = -(u[i] * m->accel_sd[l]);
                    about_point_of(B, e, mom_c, 9);
                }
                if (i == half)                               /* the centre: [u.v]x dP_c */
                    about_point_of(B, neg_vu, Ci + b * EST_NB, SR_N_COLS);
            }
        }
    }
    return 0;
}

/* -- the accelerometer bias ----------------------------------------------------------------- */

/* The fit f with one more sample: time t [s] (after the last), measured velocity v (3) [m/s]
 * and acceleration a (3) [m/s2], into out; started 0: f is empty (the first sample sets t0).
 * The trapezoid I += (t - t_last) (a_last + a) / 2, then x = v - I = c - b tau + noise
 * (tau = t - t0) adds to the sums of 1, tau, tau^2, x, tau x. */
static void bias_fit_add(const est_bias_fit *f, int started, double t, const double *v,
                         const double *a, est_bias_fit *out)
{
    *out = *f;
    if (!started) {
        memset(out, 0, sizeof *out);
        out->t0 = t;
    } else {
        for (int i = 0; i < 3; i++)
            out->integral[i] = f->integral[i] + 0.5 * (t - f->t_last) * (f->a_last[i] + a[i]);
    }
    double tau = t - out->t0;
    out->t_last = t;
    for (int i = 0; i < 3; i++) {
        double x = v[i] - out->integral[i];
        out->a_last[i] = a[i];
        out->sx[i] += x;
        out->sx[3 + i] += tau * x;
    }
    out->s[0] += 1.0;
    out->s[1] += tau;
    out->s[2] += tau * tau;
}

/* the bias estimate b (3) [m/s2] of the fit f: minus the least-squares slope,
 * slope = (n sum tau x - sum tau sum x) / (n sum tau^2 - (sum tau)^2); 0 before two distinct
 * times */
static void bias_fit_bias(const est_bias_fit *f, double *b)
{
    double n = f->s[0], s1 = f->s[1], s2 = f->s[2];
    double den = n * s2 - s1 * s1;
    for (int i = 0; i < 3; i++)
        b[i] = den > 0.0 ? -(n * f->sx[3 + i] - s1 * f->sx[i]) / den : 0.0;
}

/* -- one sample ----------------------------------------------------------------------------- */

static const char *const overflow_msg = "the update failed: it produced non-finite numbers; "
                                        "are the inputs in SI units and of physical size?";

int est_rows_of_sample(const sr_estimator_model *m, const void *data, double t,
                       const double *sample, est_rows *rw, double *noise, char *why,
                       size_t whylen)
{
    const est_core *c = &((const est_data *)data)->core;
    const double *x = sample;
    double *E = rw->E, *Ec = rw->Ec;
    int have_E = 0;
    double gain = 1.0;                        /* the derivative's noise gain */
    rw->stored = EST_ROWS;
    rw->win_drop = 0;
    rw->n_chunks = 0;
    rw->win_chunks = 0;
    /* the accelerometer bias (committed with the sample): the fit with this sample, and a_S
     * minus the bias estimated so far */
    if (m->bias) {
        double bias[3];
        est_bias_fit *f = &rw->bias;
        bias_fit_add(&c->bias, c->has_bias, t, sample + SR_X_V_S, sample + SR_X_A_S, f);
        bias_fit_bias(f, bias);
        double sum = f->t0 + f->t_last + bias[0] + bias[1] + bias[2];
        for (int i = 0; i < 3; i++)
            sum += f->integral[i] + f->s[i] + f->sx[i] + f->sx[3 + i];
        if (!isfinite(sum)) {
            sr_text_set(why, whylen, overflow_msg);
            return SR_EST_REJECT_NONFINITE;
        }
        memcpy(rw->xb, sample, sizeof(double) * m->nflat);
        for (int i = 0; i < 3; i++)
            rw->xb[SR_X_A_S + i] -= bias[i];
        x = rw->xb;
    }
    /* the thrust integrals up to this sample (committed with the sample, a stored one too) */
    const double *kint = NULL;                /* their 15 integrals */
    if (m->thrust_int) {
        memcpy(rw->thr, c->thr, sizeof rw->thr);
        sr_thrust_integrals_add(rw->thr, !c->thr_started, t, sample + SR_X_R_S,
                                sample + SR_X_F(m->n), sample + SR_X_M(m->n));
        double sum = 0.0;
        for (int i = 0; i < SR_THRUST_LEN; i++)
            sum += rw->thr[i];
        if (!isfinite(sum)) {
            sr_text_set(why, whylen, overflow_msg);
            return SR_EST_REJECT_NONFINITE;
        }
        kint = rw->thr + SR_THRUST_K;
    }
    memset(Ec, 0, sizeof rw->Ec);
    /* differenced accelerations: the window's centre, or the derivative of its momentum
     * equations (each sample's own-point rows and noise rows stored with it) */
    if (m->diffmom)
        own_point_rows(m, sample, kint, rw->own);
    if (m->diffmom && m->eiv)
        own_point_noise(m, sample, rw->own, rw->own_noise);
    if (m->differenced) {
        int wst = 0;
        if (c->hist_count < 2 * m->half) {
            rw->stored = EST_STORED_HISTORY;
        } else if (m->diffmom) {
            have_E = (wst = momentum_derivative(m, data, c, t, sample, rw->own, E, Ec,
                                                rw->own_noise, noise)) == 0;
            rw->n_chunks = m->eiv ? 2 * m->half + 1 : 0;
        } else if ((wst = centre_sample(m, data, c, t, sample, rw->xc, &gain)) == 0) {
            x = rw->xc;                                  /* the centre, its accelerations */
        }
        if (wst != 0) {
            sr_text_set(why, whylen, "the update failed: the derivative's weights are not "
                                     "finite; are the inputs in SI units and of physical "
                                     "size?");
            return SR_EST_REJECT_NONFINITE;
        }
    }
    if (rw->stored == EST_ROWS && !have_E)
        equations_of(m, m->force, x, kint, E, Ec);       /* eqs. 11/16 or 28/31 */
    /* the momentum method: against the reference sample or the window's */
    int first_reference = !m->force && !m->window && !c->has_ref;
    int first_window = m->window && c->win_count == 0;
    if (first_reference || first_window) {               /* the momentum reference t0 */
        double s = 0.0;
        for (int i = 0; i < EST_NB; i++)
            s += E[i];
        for (int i = 0; i < 3 * SR_N_CCOLS; i++)
            s += Ec[i];
        if (!isfinite(s)) {
            sr_text_set(why, whylen, overflow_msg);
            return SR_EST_REJECT_NONFINITE;
        }
        rw->stored = first_reference ? EST_STORED_REFERENCE : EST_STORED_WINDOW;
    } else if (m->window) {
        /* eqs. 11/16 against the window's reference: the newest stored sample at least
         * momentum_window older than t ("at least" to within 1e-9 s per second of t: sample
         * times k h carry round-off), the oldest while the run is shorter; its equations
         * evaluated again from its sample (and thrust integrals) */
        double limit = t - m->win_len + 1e-9 * est_pymax(1.0, fabs(t));
        int drop = 0;
        while (drop + 1 < c->win_count && win_at(m, data, c, drop + 1)[0] <= limit)
            drop++;
        if (c->win_count - drop + 1 > m->win_cap) {
            sr_text_set(why, whylen, "the momentum window's ring is full (");
            sr_text_int(why, whylen, m->win_cap);
            sr_text_cat(why, whylen, " samples within ident.momentum_window = ");
            sr_text_num(why, whylen, m->win_len, 6);
            sr_text_cat(why, whylen, " s; sized for samples at least 1 ms apart unless "
                                     "momentum_window_samples says otherwise): sample skipped");
            return SR_EST_REJECT_INCONSISTENT;
        }
        rw->win_drop = drop;
        const double *ref = win_at(m, data, c, drop);
        double *Er = rw->Er, Erc[3 * SR_N_CCOLS];
        equations_of(m, 0, ref + 1, ref + 1 + m->nflat, Er, Erc);
        if (m->n_win)                                   /* (window_noise's) */
            memcpy(rw->Et, E, sizeof rw->Et);
        for (int i = 0; i < EST_NB; i++)
            E[i] -= Er[i];
        if (m->consider)
            for (int i = 0; i < 3 * SR_N_CCOLS; i++)
                Ec[i] -= Erc[i];
    } else if (!m->force) {                              /* eqs. 11/16: [.](t) - [.](t0) */
        for (int i = 0; i < EST_NB; i++)
            E[i] -= c->ref[i];
        for (int i = 0; i < 3 * SR_N_CCOLS; i++)
            Ec[i] -= c->ref_c[i];
    }
    if (!m->force && rw->stored == EST_ROWS && m->opt.momentum_point) {  /* about its r_S */
        about_point_of(E, sample + SR_X_R_S, E, SR_N_COLS);
        if (m->consider)
            about_point_c(Ec, sample + SR_X_R_S, Ec, SR_N_CCOLS);
    }
    if (m->window && rw->stored == EST_ROWS && m->n_win) {
        window_noise(m, sample, win_at(m, data, c, rw->win_drop) + 1, rw, noise);
        rw->win_chunks = 2;
    }
    /* the force equations' noise rows (measured or differenced accelerations, one chunk) */
    if (rw->stored == EST_ROWS && m->eiv && !m->diffmom) {
        force_noise(m, x, E, gain, noise);
        rw->n_chunks = 1;
    }
    return 0;
}

void est_rows_commit(const sr_estimator_model *m, void *data, double t, const double *sample,
                     const est_rows *rw)
{
    est_core *c = &((est_data *)data)->core;
    const double *kint = m->thrust_int ? rw->thr + SR_THRUST_K : NULL;
    switch (rw->stored) {
    case EST_STORED_HISTORY:                             /* the differencing history fills */
        push_history(m, data, c, t, sample, rw->own, rw->own_noise);
        c->hist_count++;
        break;
    case EST_STORED_REFERENCE:
        memcpy(c->ref, rw->E, sizeof rw->E);
        memcpy(c->ref_c, rw->Ec, sizeof rw->Ec);
        c->has_ref = 1;
        break;
    case EST_STORED_WINDOW:
        win_push(m, data, c, 0, t, sample, kint);
        break;
    default:
        if (m->differenced)                              /* the window moves by one sample */
            push_history(m, data, c, t, sample, rw->own, rw->own_noise);
        if (m->window)                                   /* the momentum window moves on */
            win_push(m, data, c, rw->win_drop, t, sample, kint);
        if (m->bias) {                                   /* (never a stored sample) */
            c->bias = rw->bias;
            c->has_bias = 1;
        }
    }
    if (m->thrust_int) {
        memcpy(c->thr, rw->thr, sizeof rw->thr);
        c->thr_started = 1;
    }
}
