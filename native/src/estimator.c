/* The estimator core's Model, Data and the one step path (see estimator.h): options and their
 * validation (the rules and messages of spacerobot.estimator.identifier), the layout of the
 * identified parameters (spacerobot.interface.ParameterLayout), the sample's validation, its
 * equations (momentum form against the reference sample or the sample a window earlier,
 * optionally about the base's position; force form with measured or differenced
 * accelerations, or the derivative of the momentum equations; the accelerations' noise rows;
 * the thrust's consider columns and integrals), the transaction around the solver's step
 * (est_paper.c, est_joint.c) and the report (physical projection, identified flags, excitation
 * request).
 */
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "body.h"
#include "differencing.h"
#include "equations.h"
#include "est_internal.h"
#include "linalg.h"
#include "noise_profile.h"
#include "physical.h"
#include "sr_math.h"
#include "sr_text.h"

/* -- options ------------------------------------------------------------------------------------ */

void sr_estimator_options_default(sr_estimator_options *o)
{
    static const double base[10] = {600.0, 0.0, 0.0, 0.0, 100.0, 100.0, 100.0, 0.0, 0.0, 0.0};
    static const double target[10] = {100.0, 0.1, 0.1, 0.1, 10.0, 10.0, 10.0, 0.0, 0.0, 0.0};
    if (!o)
        return;
    memset(o, 0, sizeof *o);
    o->method = 1;
    o->solver = 1;
    o->accel_source = 1;
    o->lambda = 1.0;
    o->P0_mu = 1e6;
    o->P0_theta = 1e6;
    memcpy(o->guess_base, base, sizeof base);
    memcpy(o->guess_target, target, sizeof target);
    o->sd_rel = 1e-3;
    o->excite_mode = 1;
    o->excite_level = 1.0;
    o->diff_half_window = 1;
    o->corr_lags = 0;
    o->momentum_window = 0.0;
    o->noise_scale = 1.0;
    o->noise_dt = 0.1;
    o->excite_rate_try = 4.0;
    o->excite_window = 30.0;
    o->excite_settle = 20.0;
    o->excite_horizon = 300.0;
}

size_t sr_estimator_options_size(void) { return sizeof(sr_estimator_options); }
size_t sr_estimator_data_head_size(void) { return offsetof(est_data, core); }
size_t sr_estimator_report_size(void) { return sizeof(sr_estimator_report); }

/* the excitation design's options of the estimator's (its identified estimates: the model's,
 * set where the model is built) */
static sr_exd_options exd_options(const sr_estimator_options *o)
{
    sr_exd_options x;
    memset(&x, 0, sizeof x);
    x.rate = o->excite_rate_try;
    x.window = o->excite_window;
    x.settle = o->excite_settle;
    x.horizon = o->excite_horizon;
    return x;
}

/* "what = v is not one of choices" (Code.parse) */
static void bad_code(char *err, size_t errlen, const char *what, int v, const char *choices)
{
    sr_text_set(err, errlen, what);
    sr_text_cat(err, errlen, " = ");
    sr_text_int(err, errlen, v);
    sr_text_cat(err, errlen, " is not one of ");
    sr_text_cat(err, errlen, choices);
}

/* the options' checks, in the order of identifier_from_values / Identifier.__init__ */
static int check_options(const sr_estimator_options *o, char *err, size_t errlen)
{
    static const char *row_names[2][2] = {{"ident.sd_row.momentum_lin", "ident.sd_row.momentum_ang"},
                                          {"ident.sd_row.force_lin", "ident.sd_row.force_ang"}};
    static const char *noise_names[6] = {"ident.noise.base.a (signal_sd['a_S'])",
                                         "ident.noise.base.alpha (signal_sd['alpha_B'])",
                                         "ident.noise.arm.qdd (signal_sd['qdd'])",
                                         "ident.noise.base.v (signal_sd['v_S'])",
                                         "ident.noise.base.omega (signal_sd['omega_B'])",
                                         "ident.noise.arm.qd (signal_sd['qd'])"};
    if (o->method != 1 && o->method != 2) {
        bad_code(err, errlen, "method", o->method, "1 (momentum), 2 (force)");
        return 1;
    }
    if (o->solver != 1 && o->solver != 2) {
        bad_code(err, errlen, "solver", o->solver, "1 (paper), 2 (joint)");
        return 1;
    }
    if (o->accel_source != 1 && o->accel_source != 2) {
        bad_code(err, errlen, "accel_source", o->accel_source, "1 (measured), 2 (differenced)");
        return 1;
    }
    double rs[2] = {o->row_sd_lin, o->row_sd_ang};
    for (int i = 0; i < 2; i++)
        if (!(isfinite(rs[i]) && rs[i] >= 0.0)) {
            sr_text_set(err, errlen, row_names[o->method - 1][i]);
            sr_text_cat(err, errlen, " must be a finite number >= 0 (0 = unit weight), got ");
            sr_text_repr(err, errlen, rs[i]);
            return 1;
        }
    if (!(o->lambda > 0.0 && o->lambda <= 1.0)) {
        sr_text_set(err, errlen, "forgetting factor lambda must satisfy 0 < lambda <= 1, got ");
        sr_text_repr(err, errlen, o->lambda);
        return 1;
    }
    if (!(o->sd_rel > 0.0 && o->sd_rel < 1.0)) {
        sr_text_set(err, errlen, "relative standard deviation threshold ident.sd_rel must satisfy "
                             "0 < sd_rel < 1, got ");
        sr_text_repr(err, errlen, o->sd_rel);
        return 1;
    }
    if (o->diff_half_window < 1 || o->diff_half_window > SR_EST_MAX_HALF_WINDOW) {
        sr_text_set(err, errlen, "ident.diff_half_window must be an integer from 1 to 50, got ");
        sr_text_int(err, errlen, o->diff_half_window);
        return 1;
    }
    if (o->corr_lags < 0 || o->corr_lags > SR_EST_MAX_CORR_LAGS) {
        sr_text_set(err, errlen, "ident.corr_lags must be an integer from 0 to 10000, got ");
        sr_text_int(err, errlen, o->corr_lags);
        return 1;
    }
    if (!(isfinite(o->momentum_window) && o->momentum_window >= 0.0
          && o->momentum_window <= 1e6)) {
        sr_text_set(err, errlen, "ident.momentum_window must be a number of seconds from 0 to "
                             "1e+06, got ");
        sr_text_repr(err, errlen, o->momentum_window);
        return 1;
    }
    /* identifier._thrust_sd: each a number from 0 to MAX_THRUST_SD */
    const double tsd[2] = {o->sd_thrust_scale, o->sd_thrust_misalign};
    for (int i = 0; i < 2; i++)
        if (!(tsd[i] >= 0.0 && tsd[i] <= SR_EST_MAX_THRUST_SD)) {
            sr_text_set(err, errlen, i ? "ident.sd_thrust.misalign" : "ident.sd_thrust.scale");
            sr_text_cat(err, errlen, " must be a number from 0 to 1, got ");
            sr_text_repr(err, errlen, tsd[i]);
            return 1;
        }
    if (o->momentum_window_samples != 0 && (o->momentum_window_samples < 2
                                            || o->momentum_window_samples
                                                   > SR_EST_MAX_WINDOW_SAMPLES)) {
        sr_text_set(err, errlen, "momentum_window_samples (the momentum window's ring) must be 0 "
                             "(automatic) or an integer from 2 to 100000, got ");
        sr_text_int(err, errlen, o->momentum_window_samples);
        return 1;
    }
    if (o->momentum_point != 0 && o->momentum_point != 1) {
        sr_text_set(err, errlen, "ident.momentum_point must be 0 or 1, got ");
        sr_text_int(err, errlen, o->momentum_point);
        return 1;
    }
    if (o->accel_bias != 0 && o->accel_bias != 1) {
        sr_text_set(err, errlen, "ident.accel_bias must be 0 or 1, got ");
        sr_text_int(err, errlen, o->accel_bias);
        return 1;
    }
    if (o->diff_momentum != 0 && o->diff_momentum != 1) {
        sr_text_set(err, errlen, "ident.diff_momentum must be 0 or 1, got ");
        sr_text_int(err, errlen, o->diff_momentum);
        return 1;
    }
    if (o->method == 2 && o->accel_source == 2 && o->diff_momentum
        && o->diff_half_window > SR_DIFF_MAX_DISPLACEMENT_HALF_WINDOW) {
        sr_text_set(err, errlen, "ident.diff_half_window must be an integer from 1 to 10 with "
                                 "ident.diff_momentum = 1 (the displacement weights lose their "
                                 "digits beyond), got ");
        sr_text_int(err, errlen, o->diff_half_window);
        return 1;
    }
    if (sr_body_check("guess.base", o->guess_base, err, errlen)
        || sr_body_check("guess.target", o->guess_target, err, errlen))
        return 1;
    if (!(o->P0_mu > 0.0 && isfinite(o->P0_mu))) {
        sr_text_set(err, errlen, "P0_mu must be a finite covariance > 0, got ");
        sr_text_repr(err, errlen, o->P0_mu);
        return 1;
    }
    if (!(o->P0_theta > 0.0 && isfinite(o->P0_theta))) {
        sr_text_set(err, errlen, "P0_theta must be a finite covariance > 0, got ");
        sr_text_repr(err, errlen, o->P0_theta);
        return 1;
    }
    /* beyond the Python rules: the prior's weight 1 / P0 and the covariances' products stay
     * finite (5e-324 would give an infinite weight) */
    const double P0[2] = {o->P0_mu, o->P0_theta};
    for (int i = 0; i < 2; i++)
        if (!(P0[i] >= SR_EST_P0_MIN && P0[i] <= SR_EST_P0_MAX)) {
            sr_text_set(err, errlen, i ? "P0_theta" : "P0_mu");
            sr_text_cat(err, errlen, " must be a covariance within [1e-12, 1e+16] (SI units), got ");
            sr_text_repr(err, errlen, P0[i]);
            return 1;
        }
    for (int i = 0; i < 6; i++)
        if (!(isfinite(o->signal_sd[i]) && o->signal_sd[i] >= 0.0)) {
            sr_text_set(err, errlen, noise_names[i]);
            sr_text_cat(err, errlen, " must be a finite number >= 0, got ");
            sr_text_repr(err, errlen, o->signal_sd[i]);
            return 1;
        }
    if (o->information < 0 || o->information > 2) {
        bad_code(err, errlen, "ident.information", o->information,
                 "0 (automatic), 1 (on), 2 (off)");
        return 1;
    }
    if (o->information == 1 && o->noise_profile != 1) {
        sr_text_set(err, errlen, "ident.information = 1 needs the sensors' noise model: set "
                             "ident.noise_profile = 1 (which turns it on) and the noise.* "
                             "parameters");
        return 1;
    }
    if (o->excite_mode < 0 || o->excite_mode > 2) {
        bad_code(err, errlen, "ident.excite_mode", o->excite_mode,
                 "0 (off), 1 (until_identified), 2 (always)");
        return 1;
    }
    if (!(o->excite_level >= 0.0 && o->excite_level <= 1.0)) {
        sr_text_set(err, errlen, "ident.excite_level must be in [0, 1], got ");
        sr_text_repr(err, errlen, o->excite_level);
        return 1;
    }
    if (o->excite_adapt < 0 || o->excite_adapt > 2) {
        bad_code(err, errlen, "ident.excite_adapt", o->excite_adapt,
                 "0 (automatic), 1 (on), 2 (off)");
        return 1;
    }
    const sr_exd_options exd = exd_options(o);
    const char *bad, *rule;
    double value;
    if (sr_exd_options_check(&exd, &bad, &rule, &value)) {
        sr_text_set(err, errlen, bad);
        sr_text_cat(err, errlen, " must be ");
        sr_text_cat(err, errlen, rule);
        sr_text_cat(err, errlen, ", got ");
        sr_text_repr(err, errlen, value);
        return 1;
    }
    return 0;
}

/* -- the model ----------------------------------------------------------------------------------- */

#define S2P EST_S2P           /* ParameterLayout.sharp_to_project (est_joint.c) */

static size_t align8(size_t x) { return (x + 7) & ~(size_t)7; }

/* the information filter's model from the options (the noise profile applied): its noise
 * model (sr_noise_profile_info_noise), the estimator's guesses and P0 */
static int info_model(sr_estimator_model *m, const sr_robot *robot,
                      const sr_estimator_options *o)
{
    sr_info_noise nz;
    sr_noise_profile_info_noise(o, &nz);
    double z0[20];
    memcpy(z0, o->guess_base, sizeof(double) * 10);
    memcpy(z0 + 10, o->guess_target, sizeof(double) * 10);
    return sr_info_model_init(&m->info_m, robot, &nz, z0, o->P0_mu, o->P0_theta);
}

sr_estimator_model *sr_estimator_model_new(const sr_robot *robot,
                                           const sr_estimator_options *opt,
                                           char *err, size_t errlen)
{
    if (err && errlen)
        err[0] = '\0';
    if (!robot || !opt) {
        sr_text_set(err, errlen, "sr_estimator_model_new: robot and options are required");
        return NULL;
    }
    if (robot->n < 1 || robot->n > SR_MAX_JOINTS) {
        sr_text_set(err, errlen, "the robot must have 1 to 12 joints, got ");
        sr_text_int(err, errlen, robot->n);
        return NULL;
    }
    sr_estimator_options eff;                /* the options with the noise profile applied */
    sr_noise_profile_error why;
    if (sr_noise_profile_apply(opt, &eff, &why)) {
        sr_text_set(err, errlen, why.name);
        sr_text_cat(err, errlen, " must be ");
        sr_text_cat(err, errlen, why.rule);
        sr_text_cat(err, errlen, ", got ");
        sr_text_repr(err, errlen, why.value);
        return NULL;
    }
    opt = &eff;
    if (check_options(opt, err, errlen))
        return NULL;
    sr_estimator_model *m = (sr_estimator_model *)calloc(1, sizeof *m);
    if (!m) {
        sr_text_set(err, errlen, "out of memory");
        return NULL;
    }
    m->robot = *robot;
    m->opt = *opt;
    m->n = robot->n;
    m->nflat = sr_sample_length(robot->n);
    m->force = opt->method == 2;
    m->differenced = m->force && opt->accel_source == 2;
    m->diffmom = m->differenced && opt->diff_momentum;
    /* the thrust's consider term (consider.thrust_sd): the prior sd of
     * c = [s_F, phi_F (3), s_M, phi_M (3)], the same for force and moment */
    m->consider = opt->sd_thrust_scale > 0.0 || opt->sd_thrust_misalign > 0.0;
    for (int i = 0; i < SR_N_CONSIDER; i++)
        m->sd_c[i] = i % 4 == 0 ? opt->sd_thrust_scale : opt->sd_thrust_misalign;
    m->thrust_int = m->consider && (!m->force || m->diffmom);
    /* the momentum window (identifier: window = ident.momentum_window for the momentum
     * method) and its ring's capacity */
    m->window = !m->force && opt->momentum_window > 0.0;
    m->win_len = opt->momentum_window;
    if (m->window) {
        double cap = opt->momentum_window_samples > 0
                         ? (double)opt->momentum_window_samples
                         : ceil(opt->momentum_window / SR_EST_WINDOW_MIN_STEP) + 2.0;
        m->win_cap = cap < SR_EST_MAX_WINDOW_SAMPLES ? (int)cap : SR_EST_MAX_WINDOW_SAMPLES;
        m->win_slot = 1 + m->nflat + (m->thrust_int ? SR_THRUST_NK : 0);
    }
    /* the accelerations' noise per channel (identifier._channel_sd): the measured
     * accelerations' sd, or the velocities' (times the derivative's gain per sample) */
    for (int i = 0; i < 3; i++) {
        m->accel_ch[i] = SR_X_A_S + i;
        m->accel_ch[3 + i] = SR_X_ALPHA_B + i;
    }
    for (int i = 0; i < 3; i++) {
        m->vel_ch[i] = SR_X_V_S + i;
        m->vel_ch[3 + i] = SR_X_OMEGA_B + i;
    }
    for (int i = 0; i < robot->n; i++) {
        m->accel_ch[6 + i] = SR_X_QDD(robot->n) + i;
        m->vel_ch[6 + i] = SR_X_QD(robot->n) + i;
    }
    if (m->force) {                          /* either solver; diffmom: the velocities' */
        const double *sd = opt->signal_sd + (m->differenced ? 3 : 0);
        for (int i = 0; i < 6 + robot->n; i++) {
            m->accel_sd[i] = sd[i < 3 ? 0 : i < 6 ? 1 : 2];
            if (m->accel_sd[i] > 0.0)
                m->used[m->n_used++] = i;
        }
        m->eiv = m->n_used > 0;
    }
    /* the accelerometer bias (Identifier: accel_bias with the force method and measured
     * accelerations; ignored otherwise) */
    m->bias = m->force && !m->differenced && opt->accel_bias;
    m->w_lin = opt->row_sd_lin > 0.0 ? 1.0 / opt->row_sd_lin : 1.0;
    m->w_ang = opt->row_sd_ang > 0.0 ? 1.0 / opt->row_sd_ang : 1.0;
    memcpy(m->sharp_to_project, S2P, sizeof S2P);
    /* the identified estimates (interface.identified_estimates): all 20, or for a planar robot
     * m, b[1], b[2], Izz of each body; then ParameterLayout's index arrays */
    for (int k = 0; k < 2; k++)
        for (int i = 0; i < 10; i++)
            m->identified[10 * k + i] = !robot->planar || i == 0 || i == 1 || i == 2 || i == 6;
    m->p = m->r = 0;
    for (int k = 0; k < 2; k++) {
        for (int i = 0; i < 4; i++)                          /* m, b -> mu */
            if (m->identified[10 * k + i])
                m->mu_active[m->p++] = 4 * k + i;
        int sharp[6], ns = 0;                                /* I -> theta, sorted by I# */
        for (int i = 0; i < 6; i++)
            if (m->identified[10 * k + 4 + i])
                sharp[ns++] = S2P[i];
        for (int a = 1; a < ns; a++)
            for (int b = a; b > 0 && sharp[b - 1] > sharp[b]; b--) {
                int t = sharp[b];
                sharp[b] = sharp[b - 1];
                sharp[b - 1] = t;
            }
        for (int i = 0; i < ns; i++)
            m->theta_active[m->r++] = 6 * k + sharp[i];
    }
    for (int i = 0, a = 0; i < EST_NMU; i++) {
        if (a < m->p && m->mu_active[a] == i)
            a++;
        else
            m->mu_out[m->n_mu_out++] = i;
    }
    for (int i = 0, a = 0; i < EST_NTH; i++) {
        if (a < m->r && m->theta_active[a] == i)
            a++;
        else
            m->th_out[m->n_th_out++] = i;
    }
    m->k1 = m->k2 = 0;
    for (int i = 0; i < 3; i++) {
        if (m->identified[1 + i])                            /* the translation axes of b */
            m->rows_lin[m->k1++] = i;
        if (m->identified[4 + i])                            /* the rotation axes of Ixx.. */
            m->rows_ang[m->k2++] = i;
    }
    m->nl = m->p + 1;
    m->na = m->r + 1 + EST_ND;
    /* the guesses as mu (8) and theta (12) (parameters.paper_vectors) */
    const double *g[2] = {opt->guess_base, opt->guess_target};
    for (int k = 0; k < 2; k++) {
        m->mu0_full[4 * k] = g[k][0];
        for (int i = 0; i < 3; i++)
            m->mu0_full[4 * k + 1 + i] = g[k][0] * g[k][1 + i];
        for (int i = 0; i < 6; i++)
            m->th0_full[6 * k + S2P[i]] = g[k][4 + i];
    }
    /* the joint solver's standard parameters [m, m b, I_O#] per body */
    {
        double x[EST_NZ];
        memcpy(x, opt->guess_base, sizeof(double) * 10);
        memcpy(x + 10, opt->guess_target, sizeof(double) * 10);
        est_standard_of_reported(x, m->pi0_full);
    }
    for (int k = 0; k < 2; k++)
        for (int i = 0; i < 10; i++)
            m->prior[10 * k + i] = i < 4 ? opt->P0_mu : opt->P0_theta;
    m->q = 0;                                    /* ParameterLayout.standard_active */
    for (int k = 0; k < 2; k++) {
        for (int i = 0; i < 4; i++)
            if (m->identified[10 * k + i])
                m->std_active[m->q++] = 10 * k + i;
        for (int i = 0; i < m->r; i++)
            if (m->theta_active[i] / 6 == k)
                m->std_active[m->q++] = 10 * k + 4 + m->theta_active[i] % 6;
    }
    for (int i = 0, a = 0; i < EST_NZ; i++) {
        if (a < m->q && m->std_active[a] == i)
            a++;
        else
            m->std_out[m->n_std_out++] = i;
    }
    for (int i = 0; i < m->q; i++) {
        if (m->std_active[i] % 10 < 4)
            m->lin_cols[m->n_lin_cols++] = i;
        else
            m->ang_cols[m->n_ang_cols++] = i;
    }
    for (int i = 0; i < m->p; i++)
        m->mu0[i] = m->mu0_full[m->mu_active[i]];
    for (int i = 0; i < m->r; i++)
        m->th0[i] = m->th0_full[m->theta_active[i]];
    /* the Data block: head and core, the differencing history (2 m samples of [t, flat]),
     * the autocorrelation sums and rings (L + 1 and L k values per equation) */
    m->half = m->differenced ? opt->diff_half_window : 0;
    m->lags = opt->corr_lags;
    size_t off = align8(sizeof(est_data));
    m->off_hist = off;
    m->slot_noise = 1 + m->nflat + 3 * SR_N_COLS + (m->consider ? 3 * SR_N_CCOLS : 0);
    m->slot = !m->diffmom ? 1 + m->nflat
                          : m->slot_noise + (m->eiv ? 3 * m->n_used * SR_N_COLS : 0);
    off += sizeof(double) * (size_t)(2 * m->half) * (size_t)m->slot;
    m->off_corr_lin = off;          /* the joint solver: one ring of both equations' rows */
    int width_lin = opt->solver == 1 ? m->k1 : m->k1 + m->k2;
    off += m->lags ? sizeof(double) * (size_t)(m->lags + 1 + m->lags * width_lin) : 0;
    m->off_corr_ang = off;
    if (opt->solver == 1)
        off += m->lags ? sizeof(double) * (size_t)(m->lags + 1 + m->lags * m->k2) : 0;
    m->off_win = off;               /* the momentum window's ring */
    off += sizeof(double) * (size_t)m->win_cap * (size_t)m->win_slot;
    m->info = opt->information == 1;
    if (m->info) {                  /* the information filter (information.h) */
        if (info_model(m, robot, opt) != 0) {
            sr_text_set(err, errlen, "ident.information = 1 needs white sensor noise to weigh "
                                 "the equations by (noise.scale > 0 and one of noise.nav.r, "
                                 "nav.v, gyro.arw, star.cross, star.roll, enc.q, "
                                 "enc.resolution, enc.qd > 0)");
            free(m);
            return NULL;
        }
        off = align8(off);
        m->off_info = off;
        off += sizeof(sr_info_data);
        m->off_info_buf = off;
        off += sizeof(double) * sr_info_buffer_length(m->n);
    }
    /* the excitation's rate (excite_design.h): automatic where the filter runs and excitation
     * is requested */
    m->exd = exd_options(opt);
    memcpy(m->exd.identified, m->identified, sizeof m->exd.identified);
    m->adapt = opt->excite_adapt == 1 || (opt->excite_adapt == 0 && m->info
                                          && opt->excite_mode != 0);
    if (m->adapt && !m->info) {
        sr_text_set(err, errlen, "ident.excite_adapt = 1 needs the information filter: set "
                             "ident.noise_profile = 1 with the sensors' noise.* magnitudes, "
                             "and leave ident.information at 0 (automatic) or 1");
        free(m);
        return NULL;
    }
    if (m->adapt) {
        off = align8(off);
        m->off_exd = off;
        off += sizeof(sr_exd_data);
    }
    m->size = off;
    return m;
}

void sr_estimator_model_free(sr_estimator_model *m) { free(m); }

size_t sr_estimator_data_size(const sr_estimator_model *m) { return m ? m->size : 0; }

int sr_estimator_sample_length(const sr_estimator_model *m) { return m ? m->nflat : 0; }

void sr_estimator_data_init(const sr_estimator_model *m, void *data)
{
    if (!m || !data)
        return;
    memset(data, 0, m->size);
    est_data *d = (est_data *)data;
    est_core *c = &d->core;
    d->magic = EST_MAGIC;
    d->status = SR_EST_NO_SAMPLE;
    memcpy(c->mu, m->mu0, sizeof(double) * m->p);
    memcpy(c->theta, m->th0, sizeof(double) * m->r);
    for (int i = 0; i < m->p; i++)
        c->P_mu[i * m->p + i] = m->opt.P0_mu;
    for (int i = 0; i < m->r; i++)
        c->P_th[i * m->r + i] = m->opt.P0_theta;
    sr_D_of_mu(m->mu0_full, c->D);                            /* M(0) = 0 */
    if (m->opt.solver == 2)
        est_joint_init(m, c);
    c->decay_lin = c->decay_ang = 1.0;
    c->tr_t_ref = c->tr_t = NAN;                              /* DriftTracker.empty */
    if (m->info)
        sr_info_data_init(&m->info_m, (sr_info_data *)((char *)data + m->off_info));
    if (m->adapt)
        sr_exd_init((sr_exd_data *)((char *)data + m->off_exd));
}

/* -- one sample ------------------------------------------------------------------------------- */

static const char *const KEYS[13] = {"r_S", "v_S", "A", "omega_B", "a_S", "alpha_B", "q", "qd",
                                     "qdd", "F", "M", "J", "H"};

/* Identifier._validate's careful path: the status and message of a sample that
 * sr_sample_check refused */
static int explain_rejection(const sr_estimator_model *m, const double *x, char *msg, size_t n)
{
    int sizes[13] = {3, 3, 9, 3, 3, 3, m->n, m->n, m->n, 3, 3, 3, 3};
    int o = 0;
    for (int k = 0; k < 13; o += sizes[k], k++) {
        int finite = 1, inrange = 1;
        for (int i = 0; i < sizes[k]; i++) {
            if (!isfinite(x[o + i]))
                finite = 0;
            else if (!(fabs(x[o + i]) <= SR_EST_INPUT_LIMIT))
                inrange = 0;
        }
        if (!finite) {
            sr_text_set(msg, n, "non-finite input ");
            sr_text_cat(msg, n, KEYS[k]);
            sr_text_cat(msg, n, " = ");
            sr_text_vec(msg, n, x + o, sizes[k]);
            return SR_EST_REJECT_NONFINITE;
        }
        if (!inrange) {
            sr_text_set(msg, n, "input ");
            sr_text_cat(msg, n, KEYS[k]);
            sr_text_cat(msg, n, " = ");
            sr_text_vec(msg, n, x + o, sizes[k]);
            sr_text_cat(msg, n, " is beyond the physical range |x| <= 1e+15 (SI units?)");
            return SR_EST_REJECT_NONFINITE;
        }
    }
    double err, det;
    sr_rotation_error(x + SR_X_A_B, &err, &det);
    sr_text_set(msg, n, "base.A is not a rotation matrix (|A^T A - I| = ");
    sr_text_num(msg, n, err, 3);
    sr_text_cat(msg, n, " > 1e-06 or det = ");
    sr_text_num(msg, n, det, 6);
    sr_text_cat(msg, n, " <= 0)");
    return SR_EST_REJECT_INCONSISTENT;
}

static double *history(const sr_estimator_model *m, void *data)
{
    return (double *)((char *)data + m->off_hist);
}

/* the slot (1 + nflat values: t, sample) of the history's i-th oldest sample */
static const double *hist_slot(const sr_estimator_model *m, const void *data, const est_core *c,
                               int i)
{
    int cap = 2 * m->half;
    int idx = (c->hist_head - c->hist_count + i + 2 * cap) % cap;
    return history(m, (void *)data) + (size_t)idx * (size_t)m->slot;
}

/* The centre sample of the window (the 2 m stored samples and the new one) with its
 * accelerations the derivatives of its velocities at its time (Identifier._differenced,
 * differencing.centre_derivative): into xc (nflat). Returns 0 or the weights' status. */
static int centre_sample(const sr_estimator_model *m, const void *data, const est_core *c,
                         double t, const double *x, double *xc, double *gain)
{
    int half = m->half, k = 2 * half + 1, n = m->n;
    double times[SR_DIFF_MAX_SAMPLES], w[SR_DIFF_MAX_SAMPLES];
    const double *rows[SR_DIFF_MAX_SAMPLES];
    for (int i = 0; i < k - 1; i++) {
        const double *s = hist_slot(m, data, c, i);
        times[i] = s[0];
        rows[i] = s + 1;
    }
    times[k - 1] = t;
    rows[k - 1] = x;
    int st = sr_derivative_weights(times, k, half, w);
    if (st != 0)
        return st;
    double g = 0.0;                          /* |w|: white velocity noise s gives s |w| */
    for (int i = 0; i < k; i++)
        g += w[i] * w[i];
    *gain = sqrt(g);
    memcpy(xc, rows[half], sizeof(double) * m->nflat);
    /* (acceleration, velocity) channels: a_S <- v_S, alpha_B <- omega_B, qdd <- qd */
    int acc[6 + SR_MAX_JOINTS], vel[6 + SR_MAX_JOINTS];
    for (int i = 0; i < 3; i++) {
        acc[i] = SR_X_A_S + i;
        vel[i] = SR_X_V_S + i;
        acc[3 + i] = SR_X_ALPHA_B + i;
        vel[3 + i] = SR_X_OMEGA_B + i;
    }
    for (int i = 0; i < n; i++) {
        acc[6 + i] = SR_X_QDD(n) + i;
        vel[6 + i] = SR_X_QD(n) + i;
    }
    for (int p = 0; p < 6 + n; p++) {
        double s = 0.0;
        for (int i = 0; i < k; i++)
            s += w[i] * rows[i][vel[p]];
        xc[acc[p]] = s;
    }
    return 0;
}

/* The angular rows of a momentum equation array E (3 x 42) about the point p (3) instead of
 * the inertial origin, in place (identifier.about_point): L_p = L_O - p x P, H_p = H_O - p x J,
 * so y -= [p]x b and, mu being the entries m, m b of D(mu) of each body,
 * psi[:, D index of mu] += [p]x A; the linear rows [A | b] (3 x 9, row stride lin_stride)
 * taken from lin (E's own: lin = E, lin_stride = SR_N_COLS). */
static void about_point_of(double *E, const double *p, const double *lin, int lin_stride)
{
    const double P[9] = {0.0, -p[2], p[1], p[2], 0.0, -p[0], -p[1], p[0], 0.0};   /* [p]x */
    double pl[3][9];
    for (int i = 0; i < 3; i++)
        for (int c = 0; c <= SR_COL_B; c++)
            pl[i][c] = P[3 * i] * lin[c] + P[3 * i + 1] * lin[lin_stride + c]
                       + P[3 * i + 2] * lin[2 * lin_stride + c];
    for (int i = 0; i < 3; i++) {
        double *row = E + i * SR_N_COLS;
        row[SR_COL_Y] -= pl[i][8];                           /* y' = y - [p]x b */
        for (int c = 0; c < 4; c++) {
            row[SR_COL_PSI + c] += pl[i][c];                 /* base m, m b */
            row[SR_COL_PSI + 10 + c] += pl[i][4 + c];        /* target m, m b */
        }
    }
}

static void about_point(double *E, const double *p) { about_point_of(E, p, E, SR_N_COLS); }

/* The consider columns Ec (3 x 16: [b_c | y_c] per row) of about_point_of: y_c -= [p]x b_c,
 * b_c taken from src (3 rows of stride src_stride; Ec's own: src = Ec, SR_N_CCOLS) */
static void about_point_c(double *Ec, const double *p, const double *src, int src_stride)
{
    const double P[9] = {0.0, -p[2], p[1], p[2], 0.0, -p[0], -p[1], p[0], 0.0};   /* [p]x */
    double pb[3][SR_N_CONSIDER];
    for (int i = 0; i < 3; i++)
        for (int c = 0; c < SR_N_CONSIDER; c++)
            pb[i][c] = P[3 * i] * src[c] + P[3 * i + 1] * src[src_stride + c]
                       + P[3 * i + 2] * src[2 * src_stride + c];
    for (int i = 0; i < 3; i++)
        for (int c = 0; c < SR_N_CONSIDER; c++)
            Ec[i * SR_N_CCOLS + SR_N_CONSIDER + c] -= pb[i][c];
}

/* the slot (win_slot values: t, sample, with the thrust integrals their 15 integrals) of the
 * momentum window ring's i-th oldest sample */
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

/* The momentum equations of the flat sample x with their angular rows about its own r_S
 * (Identifier._own_point_into): L_O - [r]x P, P = the system's momentum (the linear rows
 * without the impulse: [A | b - J]). With the consider term its consider columns follow
 * (own + 3 SR_N_COLS, 3 x 16): the sample's momentum-form sensitivities with the thrust
 * integrals k (15) up to it, unchanged by the point (only the impulse depends on the thrust,
 * and P has none of it: identifier._momentum_part); k NULL: the rows alone. */
static void own_point_rows(const sr_estimator_model *m, const double *x, const double *k,
                           double *own)
{
    if (m->consider && k)
        sr_thrust_sensitivity(0, x, m->n, k, own + 3 * SR_N_COLS);
    double mom[3 * 9];
    sr_equations(&m->robot, 0, x, own);                      /* eqs. 11/16 of this sample */
    for (int i = 0; i < 3; i++) {
        memcpy(mom + 9 * i, own + i * SR_N_COLS, sizeof(double) * 8);
        mom[9 * i + 8] = own[i * SR_N_COLS + SR_COL_B] - x[SR_X_J(m->n) + i];
    }
    about_point_of(own, x + SR_X_R_S, mom, 9);
}

/* The noise rows sigma_l C_l of the own-point rows own (3 x 42) of the flat sample x in the
 * velocity channels with sd > 0 (eiv.noise_rows with Identifier._own_point_into, eq. 1:
 * C_l = own(x + e_l) - own(x), the rows being affine in the velocities: the [u v]x P(v)
 * term's quadratic part is [e]x (m e) = 0) into C (n_used blocks of 3 x 42). */
static void own_point_noise(const sr_estimator_model *m, const double *x, const double *own,
                            double *C)
{
    double xk[SR_X_LEN(SR_MAX_JOINTS)], ok[3 * SR_N_COLS];
    memcpy(xk, x, sizeof(double) * m->nflat);
    for (int b = 0; b < m->n_used; b++) {
        int l = m->used[b], i = m->vel_ch[l];
        double sd = m->accel_sd[l];
        xk[i] = x[i] + 1.0;
        own_point_rows(m, xk, NULL, ok);
        xk[i] = x[i];
        for (int a = 0; a < 3 * SR_N_COLS; a++)
            C[b * 3 * SR_N_COLS + a] = sd * (ok[a] - own[a]);
    }
}

/* The momentum equations differentiated at the centre c of the window (the 2 m stored
 * samples and the new one, x with its own-point rows own_x) by the derivative's weights w
 * (Identifier._differenced_momentum, docs/identification.md section 6): for any weights with
 * sum w = 0 the unknown momentum cancels and sum_i w_i E_mom(t_i) holds exactly (the force
 * equations averaged by the derivative's filter). With P_i the momentum, J_i the impulse,
 * tau_i = t_i - t_c and u the displacement weights:
 *   sum_i w_i (L_O,i - [r_c]x (P_i - J_i))
 *     = sum_i w_i (L_O,i - [r_i]x P_i)                 own point: no position needed
 *     + [sum_i w_i (r_i - r_c)]x P_c                   = [u . v]x P_c (velocities)
 *     + sum_i w_i [r_i - r_c]x (J_i - J_c)             ~ [v_c]x sum_i w_i tau_i (J_i - J_c)
 *     + [r_c]x sum_i w_i J_i
 * into out (3 x 42); with the consider term its consider columns into out_c (3 x 16), the
 * own-point rows' (each sample's own_x + 3 x 42) combined the same way. With N_a, N_b (the
 * noise Gram matrices begun by est_noise_begin) the noise rows of the window's samples
 * (noise_x the new sample's, own_point_noise) are added, combined as the rows
 * (Identifier._differenced_momentum): w_j sigma_l C_l,j, with for v_S channels
 * + [u_j sigma_l e_l]x P_c (the displacement's) and at the centre + [u.v]x dP_c (the
 * centre's momentum's). Returns 0 or the weights' status. */
/* the consider columns (3 x 16) that follow own-point rows (3 x 42) */
static const double *own_c_of(const double *own) { return own + 3 * SR_N_COLS; }

static int momentum_derivative(const sr_estimator_model *m, const void *data, const est_core *c,
                               double t, const double *x, const double *own_x, double *out,
                               double *out_c, const double *noise_x, double *N_a, double *N_b,
                               est_work *wk)
{
    int half = m->half, k = 2 * half + 1, oJ = SR_X_J(m->n);
    double times[SR_DIFF_MAX_SAMPLES], w[SR_DIFF_MAX_SAMPLES], u[SR_DIFF_MAX_SAMPLES];
    const double *fl[SR_DIFF_MAX_SAMPLES], *own[SR_DIFF_MAX_SAMPLES];
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
    for (int a = 0; a < 3 * SR_N_COLS; a++) {               /* d/dt momentum ~ force */
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
    if (N_a && m->eiv) {                     /* the noise rows, one sample's blocks at a time */
        const int nb = 3 * SR_N_COLS;
        double *blk = wk->blk;
        for (int i = 0; i < k; i++) {
            const double *Ci = i == k - 1 ? noise_x : own[i] - 1 - m->nflat + m->slot_noise;
            for (int b = 0; b < m->n_used; b++) {
                int l = m->used[b];
                double *B = blk + b * nb;
                for (int a = 0; a < nb; a++)                 /* w_j sigma_l C_l,j */
                    B[a] = w[i] * Ci[b * nb + a];
                if (l < 3) {                                 /* v_S: [u_j sigma e_l]x P_c */
                    double e[3] = {0.0, 0.0, 0.0};
                    e[l] = -(u[i] * m->accel_sd[l]);
                    about_point_of(B, e, mom_c, 9);
                }
                if (i == half)                               /* the centre: [u.v]x dP_c */
                    about_point_of(B, neg_vu, Ci + b * nb, SR_N_COLS);
            }
            est_noise_add(m, c, blk, m->n_used, N_a, N_b, wk->noise_rows);
        }
    }
    return 0;
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
               sizeof(double) * (3 * SR_N_COLS + (m->consider ? 3 * SR_N_CCOLS : 0)));
    if (m->diffmom && m->eiv)
        memcpy(slot + m->slot_noise, noise, sizeof(double) * 3 * m->n_used * SR_N_COLS);
    c->hist_head = (c->hist_head + 1) % (2 * m->half);
}

/* The fit f with one more sample (accel_bias.BiasFit.add): time t [s] (after the last),
 * measured velocity v (3) [m/s] and acceleration a (3) [m/s2], into out; started 0: f is
 * empty (the first sample sets t0). The trapezoid I += (t - t_last) (a_last + a) / 2, then
 * x = v - I = c - b tau + noise (tau = t - t0) adds to the sums of 1, tau, tau^2, x, tau x. */
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

/* the bias estimate b (3) [m/s2] of the fit f (accel_bias.BiasFit.bias): minus the
 * least-squares slope, slope = (n sum tau x - sum tau sum x) / (n sum tau^2 - (sum tau)^2);
 * 0 before two distinct times */
static void bias_fit_bias(const est_bias_fit *f, double *b)
{
    double n = f->s[0], s1 = f->s[1], s2 = f->s[2];
    double den = n * s2 - s1 * s1;
    for (int i = 0; i < 3; i++)
        b[i] = den > 0.0 ? -(n * f->sx[3 + i] - s1 * f->sx[i]) / den : 0.0;
}

/* n + 1, saturated at INT_MAX (the counters of a long run, or of a restored block, never
 * overflow) */
static int count_up(int n) { return n < 2147483647 ? n + 1 : n; }

/* a rejection after validation: counters, status, message */
static int reject(est_data *d, int status, const char *why, char *msg, size_t msglen)
{
    d->rejected = count_up(d->rejected);
    d->status = status;
    sr_text_set(d->msg, sizeof d->msg, why);
    if (msg && msglen)
        sr_text_set(msg, msglen, d->msg);
    return status;
}

/* "name = v is out of range lo..hi" (a Data block's count or index) */
static void bad_count(char *err, size_t errlen, const char *name, long v, long lo, long hi)
{
    sr_text_set(err, errlen, "the estimator's state block is not valid: ");
    sr_text_cat(err, errlen, name);
    sr_text_cat(err, errlen, " = ");
    sr_text_int(err, errlen, v);
    sr_text_cat(err, errlen, " is out of its range ");
    sr_text_int(err, errlen, lo);
    sr_text_cat(err, errlen, "..");
    sr_text_int(err, errlen, hi);
}

int sr_estimator_data_check(const sr_estimator_model *m, const void *data, char *err,
                            size_t errlen)
{
    if (err && errlen)
        err[0] = '\0';
    if (!m || !data) {
        sr_text_set(err, errlen, "the estimator's state block is not valid: no model or no block");
        return 1;
    }
    const est_data *d = (const est_data *)data;
    const est_core *c = &d->core;
    /* the history holds 2 m samples (none without differenced accelerations), each ring L */
    int cap = 2 * m->half, L = m->lags;
    if (d->magic != EST_MAGIC) {
        sr_text_set(err, errlen, "the estimator's state block is not valid (not initialised, or "
                             "not an estimator's state)");
        return 1;
    }
    const struct { const char *name; long v, lo, hi; } ranges[] = {
        {"diag.samples", d->samples, 0, 2147483647L},
        {"diag.rejected", d->rejected, 0, 2147483647L},
        {"diag.status", d->status, SR_EST_NO_SAMPLE, SR_EST_REJECT_INCONSISTENT},
        /* the momentum reference exists only for the momentum method */
        {"the momentum reference flag", c->has_ref, 0, m->force || m->window ? 0 : 1},
        /* the thrust integrals exist only where the consider term keeps them */
        {"the thrust integrals' flag", c->thr_started, 0, m->thrust_int ? 1 : 0},
        {"the momentum window's count", c->win_count, 0, m->win_cap},
        {"the momentum window's head", c->win_head, 0, m->win_cap > 0 ? m->win_cap - 1 : 0},
        /* the noise parts exist only where the accelerations' noise is compensated */
        {"the noise compensation flag", c->has_eiv, 0, m->eiv ? 1 : 0},
        /* the accelerometer bias's fit only where it is subtracted */
        {"the accelerometer bias fit's flag", c->has_bias, 0, m->bias ? 1 : 0},
        {"the differencing history's count", c->hist_count, 0, cap},
        {"the differencing history's head", c->hist_head, 0, cap > 0 ? cap - 1 : 0},
        {"the residual ring's count (linear)", c->corr_count[0], 0, L},
        {"the residual ring's head (linear)", c->corr_head[0], 0, L > 0 ? L - 1 : 0},
        {"the residual ring's count (angular)", c->corr_count[1], 0, L},
        {"the residual ring's head (angular)", c->corr_head[1], 0, L > 0 ? L - 1 : 0},
    };
    for (size_t i = 0; i < sizeof ranges / sizeof ranges[0]; i++)
        if (ranges[i].v < ranges[i].lo || ranges[i].v > ranges[i].hi) {
            bad_count(err, errlen, ranges[i].name, ranges[i].v, ranges[i].lo, ranges[i].hi);
            return 1;
        }
    if (m->info) {
        const sr_info_data *f = (const sr_info_data *)((const char *)data + m->off_info);
        if (f->samples < 0 || !(f->rows >= 0.0) ||
            f->replayed < 0 || f->replayed > 1 ||
            (!f->replayed && f->samples > SR_INFO_REPLAY) ||
            !sr_info_data_finite(&m->info_m, f)) {
            sr_text_set(err, errlen, "the estimator's state block is not valid: the information "
                                 "filter's counters are out of range or its numbers not "
                                 "finite");
            return 1;
        }
    }
    if (m->adapt && !sr_exd_data_valid(&m->exd, (const sr_exd_data *)((const char *)data
                                                                      + m->off_exd))) {
        sr_text_set(err, errlen, "the estimator's state block is not valid: the excitation "
                             "design's phase or rate is out of range or its numbers not "
                             "finite");
        return 1;
    }
    if (!memchr(d->msg, '\0', sizeof d->msg)) {
        sr_text_set(err, errlen, "the estimator's state block is not valid: its message is not "
                             "terminated");
        return 1;
    }
    return 0;
}

/* 1 if the Data block passes sr_estimator_data_check (a block restored from outside, e.g. FMI
 * set/deserialize state, is checked before any index into it is used) */
static int data_valid(const sr_estimator_model *m, const est_data *d)
{
    return sr_estimator_data_check(m, d, NULL, 0) == 0;
}

/* 1 if everything the report reads after the step nw is finite */
static int outputs_finite(const est_core *nw)
{
    int ok = isfinite(nw->residual_lin + nw->residual_ang) && isfinite(nw->rcond_mu) && isfinite(nw->rcond_theta);
    for (int i = 0; i < EST_NZ; i++)
        ok &= isfinite(nw->vec[i]) && isfinite(nw->sd[i]);
    return ok;
}

static void rls_estimates(const sr_estimator_model *m, const est_data *d, double *vec,
                          double *sd);
static void physical_vector(const sr_estimator_model *m, const double *ls, const double *sd,
                            double *out, int *flags);

/* The information filter's sample (information.h) into *nwi, a copy of the Data's filter,
 * linearised at this estimator's physical estimates of ls, sd (20 each; the guesses where a
 * mass is not positive). 0 ok, 1 failed (non-finite numbers: the sample is rejected). */
static int info_step(const sr_estimator_model *m, void *data, double t,
                     const double *sample, const double *ls, const double *sd,
                     sr_info_data *nwi, sr_info_work *w)
{
    double z[EST_NZ];
    int flags[4];
    physical_vector(m, ls, sd, z, flags);
    if (!(z[0] > 0.0 && z[10] > 0.0)) {
        memcpy(z, m->opt.guess_base, sizeof(double) * 10);
        memcpy(z + 10, m->opt.guess_target, sizeof(double) * 10);
    }
    /* the replay buffer: written at the filter's next slot only, which counts at the commit */
    double *buffer = (double *)((char *)data + m->off_info_buf);
    return sr_info_step(&m->info_m, (const sr_info_data *)((const char *)data + m->off_info),
                        nwi, buffer, t, sample, z, w);
}

/* the excitation's rate (excite_design.h), after a committed sample at t: the estimator
 * still asks for excitation where a window ends (the report's ident.excite) */
typedef struct {
    const sr_estimator_model *m;
    const void *data;
} excite_ctx;

static int excite_wanted(void *ctx)
{
    const excite_ctx *x = (const excite_ctx *)ctx;
    sr_estimator_report r;
    memset(&r, 0, sizeof r);               /* report_get writes it: for the compiler */
    sr_estimator_report_get(x->m, x->data, &r);
    return r.excite > 0.0;
}

static void design_step(const sr_estimator_model *m, void *data, double t, sr_exd_work *w)
{
    if (!m->adapt)
        return;
    excite_ctx ctx = {m, data};
    /* a failed prediction leaves the rate at 1 (the plant's own): nothing to reject */
    (void)sr_exd_step(&m->exd, (sr_exd_data *)((char *)data + m->off_exd), &m->info_m,
                      (const sr_info_data *)((const char *)data + m->off_info), t,
                      excite_wanted, &ctx, w);
}

static const char *const info_fail_msg =
    "the information filter's update failed (non-finite numbers or a noise covariance that is "
    "not positive definite); are the inputs in SI units and of physical size, the noise.* "
    "magnitudes those of the sensors?";

size_t sr_estimator_work_size(const sr_estimator_model *m) { return m ? sizeof(est_work) : 0; }

int sr_estimator_update(const sr_estimator_model *m, void *data, void *work, double t,
                        const double *sample, char *msg, size_t msglen)
{
    if (msg && msglen)
        msg[0] = '\0';
    if (!m || !data)
        return SR_EST_REJECT_NONFINITE;
    if (!work) {
        sr_text_set(msg, msglen, "sr_estimator_update: no work space given "
                                 "(sr_estimator_work_size bytes)");
        return SR_EST_REJECT_NONFINITE;
    }
    est_work *wk = (est_work *)work;
    est_data *d = (est_data *)data;
    est_core *c = &d->core;
    if (sr_estimator_data_check(m, d, msg, msglen) != 0)   /* never index with a corrupt
                                                             block's counts */
        return SR_EST_REJECT_NONFINITE;
    char why[SR_EST_MSG_LEN];
    why[0] = '\0';
    /* validation (Identifier._update): one rule, a sample as a whole */
    int status = SR_EST_ESTIMATING;
    if (!sample) {
        status = SR_EST_REJECT_INCONSISTENT;
        sr_text_set(why, sizeof why, "no sample given");
    } else if (sr_sample_check(sample, m->nflat, SR_EST_INPUT_LIMIT, SR_EST_ROTATION_TOL) != 0) {
        status = explain_rejection(m, sample, why, sizeof why);
    }
    if (status != SR_EST_ESTIMATING || !isfinite(t)) {
        if (!isfinite(t)) {
            sr_text_set(why, sizeof why, "non-finite sample time ");
            sr_text_num(why, sizeof why, t, 6);
        }
        return reject(d, status != SR_EST_ESTIMATING ? status : SR_EST_REJECT_NONFINITE, why,
                      msg, msglen);
    }
    /* the differencing history, the momentum window and the thrust integrals need increasing
     * sample times (Identifier._time_ok: after the newest sample any of them holds) */
    double last = 0.0;
    int has_last = 0;
    if (m->differenced && c->hist_count > 0) {
        last = hist_slot(m, data, c, c->hist_count - 1)[0];
        has_last = 1;
    }
    if (m->window && c->win_count > 0) {
        double tw = win_at(m, data, c, c->win_count - 1)[0];
        last = has_last ? est_pymax(last, tw) : tw;
        has_last = 1;
    }
    if (m->thrust_int && c->thr_started) {
        last = has_last ? est_pymax(last, c->thr[SR_THRUST_T]) : c->thr[SR_THRUST_T];
        has_last = 1;
    }
    if (m->info) {                           /* the information filter's thrust integrals */
        const sr_info_data *f = (const sr_info_data *)((const char *)data + m->off_info);
        if (f->samples > 0) {
            last = has_last ? est_pymax(last, f->K[SR_THRUST_T]) : f->K[SR_THRUST_T];
            has_last = 1;
        }
    }
    if (has_last && !(t > last)) {
        sr_text_set(why, sizeof why, "differenced accelerations, the moving reference and the "
                                 "thrust integrals need increasing sample times: t = ");
        sr_text_num(why, sizeof why, t, 6);
        sr_text_cat(why, sizeof why, " s after ");
        sr_text_num(why, sizeof why, last, 6);
        sr_text_cat(why, sizeof why, " s");
        return reject(d, SR_EST_REJECT_INCONSISTENT, why, msg, msglen);
    }

    /* the information filter's sample, linearised at this estimator's estimates so far (its
     * own can run away while it is poorly informed); committed with the sample */
    sr_info_data *nwi = &wk->nwi;
    if (m->info) {
        double ls[EST_NZ], sdv[EST_NZ];
        rls_estimates(m, d, ls, sdv);
        if (info_step(m, data, t, sample, ls, sdv, nwi, &wk->exd.info) != 0)
            return reject(d, SR_EST_REJECT_NONFINITE, info_fail_msg, msg, msglen);
    }
    /* the transaction: the new state on the stack, committed only if all came out finite */
    static const char *const overflow_msg = "the update failed: it produced non-finite numbers; "
                                        "are the inputs in SI units and of physical size?";
    /* E (3 x 42) and, with the consider term, its consider columns Ec (3 x 16: the
     * right-hand sides' sensitivities, consider.py), which every linear step on E follows */
    double *E = wk->E, *Ec = wk->Ec;
    double *own = wk->own;                               /* own-point rows (, consider) */
    double *xc = wk->xc, *xb = wk->xb;
    const double *x = sample;
    int stored = 0, have_E = 0;               /* stored 1: a history sample only */
    /* the accelerometer bias (accel_bias.py; committed with the sample): the fit with this
     * sample, and a_S minus the bias estimated so far */
    est_bias_fit bfit;
    if (m->bias) {
        double bias[3];
        bias_fit_add(&c->bias, c->has_bias, t, sample + SR_X_V_S, sample + SR_X_A_S, &bfit);
        bias_fit_bias(&bfit, bias);
        double sum = bfit.t0 + bfit.t_last + bias[0] + bias[1] + bias[2];
        for (int i = 0; i < 3; i++)
            sum += bfit.integral[i] + bfit.s[i] + bfit.sx[i] + bfit.sx[3 + i];
        if (!isfinite(sum))
            return reject(d, SR_EST_REJECT_NONFINITE, overflow_msg, msg, msglen);
        memcpy(xb, sample, sizeof(double) * m->nflat);
        for (int i = 0; i < 3; i++)
            xb[SR_X_A_S + i] -= bias[i];
        x = xb;
    }
    /* the accelerations' noise (eiv.py): the expected noise parts of the Gram matrices after
     * this sample (paper: [A | b] and [phi | y | psi]; joint: [H | yy]); with diffmom the
     * new sample's own-point noise rows (stored with it), else this sample's noise rows */
    double *N_a = wk->N_a, *N_b = wk->N_b;
    double *own_noise = wk->own_noise;
    int has_noise = 0;
    double gain = 1.0;                        /* the derivative's noise gain */
    /* the thrust integrals up to this sample (consider.ThrustIntegrals.add; committed with
     * the sample, a stored one too) */
    double thr[SR_THRUST_LEN];
    const double *kint = NULL;                /* their 15 integrals */
    if (m->thrust_int) {
        memcpy(thr, c->thr, sizeof thr);
        sr_thrust_integrals_add(thr, !c->thr_started, t, sample + SR_X_R_S,
                                sample + SR_X_F(m->n), sample + SR_X_M(m->n));
        double sum = 0.0;
        for (int i = 0; i < SR_THRUST_LEN; i++)
            sum += thr[i];
        if (!isfinite(sum))
            return reject(d, SR_EST_REJECT_NONFINITE, overflow_msg, msg, msglen);
        kint = thr + SR_THRUST_K;
    }
    memset(Ec, 0, sizeof wk->Ec);
    if (m->diffmom)
        own_point_rows(m, sample, kint, own);
    if (m->diffmom && m->eiv)
        own_point_noise(m, sample, own, own_noise);
    if (m->differenced) {
        int wst = 0;
        if (c->hist_count < 2 * m->half)
            stored = 1;
        else if (m->diffmom) {                           /* the momentum equations' derivative */
            if (m->eiv)
                est_noise_begin(m, c, N_a, N_b);
            have_E = (wst = momentum_derivative(m, data, c, t, sample, own, E, Ec, own_noise,
                                                m->eiv ? N_a : NULL, N_b, wk)) == 0;
            has_noise = m->eiv;
        }
        else if ((wst = centre_sample(m, data, c, t, sample, xc, &gain)) == 0)
            x = xc;                                      /* the centre, its accelerations */
        if (wst != 0)
            return reject(d, SR_EST_REJECT_NONFINITE, "the update failed: the derivative's "
                          "weights are not finite; are the inputs in SI units and of "
                          "physical size?", msg, msglen);
    }
    if (!stored && !have_E) {
        sr_equations(&m->robot, m->force, x, E);         /* eqs. 11/16 or 28/31 */
        if (m->consider)                                 /* d b / d c, d y / d c */
            sr_thrust_sensitivity(m->force, x, m->n, kint, Ec);
    }
    int first_reference = !m->force && !m->window && !c->has_ref;
    int first_window = m->window && c->win_count == 0;
    int win_drop = 0;                         /* the ring's samples this one makes obsolete */
    if (first_reference || first_window) {               /* the momentum reference t0 */
        double s = 0.0;
        for (int i = 0; i < 3 * SR_N_COLS; i++)
            s += E[i];
        for (int i = 0; i < 3 * SR_N_CCOLS; i++)
            s += Ec[i];
        if (!isfinite(s))
            return reject(d, SR_EST_REJECT_NONFINITE, overflow_msg, msg, msglen);
        if (first_reference) {
            memcpy(c->ref, E, sizeof wk->E);
            memcpy(c->ref_c, Ec, sizeof wk->Ec);
            c->has_ref = 1;
            stored = 2;
        } else {
            stored = 3;                                  /* into the window's ring */
        }
    } else if (m->window) {
        /* eqs. 11/16 against the window's reference (Identifier._windowed): the newest stored
         * sample at least momentum_window older than t ("at least" to within 1e-9 s per
         * second of t: sample times k h carry round-off), the oldest while the run is
         * shorter; its equations evaluated again from its sample (and thrust integrals) */
        double limit = t - m->win_len + 1e-9 * est_pymax(1.0, fabs(t));
        while (win_drop + 1 < c->win_count && win_at(m, data, c, win_drop + 1)[0] <= limit)
            win_drop++;
        if (c->win_count - win_drop + 1 > m->win_cap) {
            sr_text_set(why, sizeof why, "the momentum window's ring is full (");
            sr_text_int(why, sizeof why, m->win_cap);
            sr_text_cat(why, sizeof why, " samples within ident.momentum_window = ");
            sr_text_num(why, sizeof why, m->win_len, 6);
            sr_text_cat(why, sizeof why, " s; sized for samples at least 1 ms apart unless "
                                 "momentum_window_samples says otherwise): sample skipped");
            return reject(d, SR_EST_REJECT_INCONSISTENT, why, msg, msglen);
        }
        const double *ref = win_at(m, data, c, win_drop);
        double Er[3 * SR_N_COLS], Erc[3 * SR_N_CCOLS];
        sr_equations(&m->robot, 0, ref + 1, Er);
        for (int i = 0; i < 3 * SR_N_COLS; i++)
            E[i] -= Er[i];
        if (m->consider) {
            sr_thrust_sensitivity(0, ref + 1, m->n, ref + 1 + m->nflat, Erc);
            for (int i = 0; i < 3 * SR_N_CCOLS; i++)
                Ec[i] -= Erc[i];
        }
    } else if (!m->force) {                              /* eqs. 11/16: [.](t) - [.](t0) */
        for (int i = 0; i < 3 * SR_N_COLS; i++)
            E[i] -= c->ref[i];
        for (int i = 0; i < 3 * SR_N_CCOLS; i++)
            Ec[i] -= c->ref_c[i];
    }
    if (!m->force && !stored && m->opt.momentum_point) { /* about r_S of this sample */
        about_point(E, sample + SR_X_R_S);
        if (m->consider)
            about_point_c(Ec, sample + SR_X_R_S, Ec, SR_N_CCOLS);
    }
    if (stored == 1) {                                   /* the differencing history fills */
        push_history(m, data, c, t, sample, own, own_noise);
        c->hist_count++;
    }
    if (stored == 3)
        win_push(m, data, c, 0, t, sample, kint);
    if (stored) {
        if (m->info)
            memcpy((char *)data + m->off_info, nwi, sizeof *nwi);
        if (m->thrust_int) {
            memcpy(c->thr, thr, sizeof thr);
            c->thr_started = 1;
        }
        d->status = SR_EST_REFERENCE;
        d->msg[0] = '\0';
        design_step(m, data, t, &wk->exd);
        return d->status;
    }
    /* the noise rows sigma_l C_l, C_l = E(x + e_l) - E(x) (eiv.noise_rows, eq. 1): the
     * equations are affine in the accelerations; their Gram matrix the expected noise part
     * N = sum_k w_k sum_l sigma_l^2 C_l,k^T C_l,k of this sample's */
    if (m->eiv && !m->diffmom) {
        double *noise = own_noise;                       /* (its buffer: unused here) */
        double xk[SR_X_LEN(SR_MAX_JOINTS)], Ek[3 * SR_N_COLS];
        memcpy(xk, x, sizeof(double) * m->nflat);
        for (int b = 0; b < m->n_used; b++) {
            int l = m->used[b], i = m->accel_ch[l];
            double sd = m->accel_sd[l] * gain;           /* differenced: the derivative's */
            xk[i] = x[i] + 1.0;
            sr_equations(&m->robot, 1, xk, Ek);
            xk[i] = x[i];
            for (int a = 0; a < 3 * SR_N_COLS; a++)
                noise[b * 3 * SR_N_COLS + a] = sd * (Ek[a] - E[a]);
        }
        est_noise_begin(m, c, N_a, N_b);
        est_noise_add(m, c, noise, m->n_used, N_a, N_b, wk->noise_rows);
        has_noise = 1;
    }
    est_core *nw = &wk->nw;                  /* written by the step, copied by the commit */
    for (int i = 0; i < 2; i++) {
        nw->corr_head[i] = c->corr_head[i];
        nw->corr_count[i] = c->corr_count[i];
    }
    double e_lin[EST_MAXK], e_ang[3];
    /* the tracker's clock is the sample count: the estimates depend on the samples, not on
     * the step sizes between them */
    int st = m->opt.solver == 1
                 ? est_paper_step(m, data, c, nw, E, Ec, has_noise ? N_a : NULL,
                                  has_noise ? N_b : NULL, (double)d->samples, e_lin, e_ang)
                 : est_joint_step(m, data, c, nw, E, Ec, has_noise ? N_a : NULL,
                                  (double)d->samples, e_lin);
    if (st == 0 && !outputs_finite(nw))   /* e.g. a restored block's numbers: never report
                                               them non-finite */
        st = 2;
    if (st != 0) {
        const char *what = st == 1 ? "the update failed (LinAlgError: lam I + H P H^T is not "
                                     "positive definite); are the inputs in SI units and of "
                                     "physical size?"
                         : st == 3 ? "the update failed (LinAlgError: Eigenvalues did not "
                                     "converge); are the inputs in SI units and of physical "
                                     "size?"
                                   : "the update failed: it produced non-finite numbers; are "
                                     "the inputs in SI units and of physical size?";
        return reject(d, SR_EST_REJECT_NONFINITE, what, msg, msglen);
    }
    /* commit */
    if (m->info)
        memcpy((char *)data + m->off_info, nwi, sizeof *nwi);
    if (m->lags > 0 && m->opt.solver == 1) {
        est_corr_commit(m, data, nw, 0, e_lin, m->k1);
        est_corr_commit(m, data, nw, 1, e_ang, m->k2);
    } else if (m->lags > 0) {
        est_corr_commit(m, data, nw, 0, e_lin, m->k1 + m->k2);
    }
    if (m->differenced)                                  /* the window moves by one sample */
        push_history(m, data, c, t, sample, own, own_noise);
    if (m->window)                                       /* the momentum window moves on */
        win_push(m, data, c, win_drop, t, sample, kint);
    if (m->thrust_int) {
        memcpy(c->thr, thr, sizeof thr);
        c->thr_started = 1;
    }
    if (m->bias) {
        c->bias = bfit;
        c->has_bias = 1;
    }
    est_core_commit(m, c, nw);
    d->samples = count_up(d->samples);
    d->status = SR_EST_ESTIMATING;
    d->msg[0] = '\0';
    design_step(m, data, t, &wk->exd);
    return d->status;
}

/* -- the report ------------------------------------------------------------------------------ */

/* the reported vector out (20) of the least-squares estimates ls (20) and their sds: physical
 * flags (flags[0..1]); identified (flags[2..3]): small sd and the reported value the
 * estimate's (Identifier.report); the projection onto real bodies where needed */
static void physical_vector(const sr_estimator_model *m, const double *ls, const double *sd,
                            double *out, int *flags)
{
    /* the information filter's sds are calibrated (an error beyond 2 sd in 1 of 20): its flag
       asks 2 sd below the threshold, so that a flagged estimate is within it at 95 % */
    double sd_rel = m->info ? 0.5 * m->opt.sd_rel : m->opt.sd_rel;
    memcpy(out, ls, sizeof(double) * EST_NZ);
    if (sr_report_flags(ls, sd, SR_COM_SCALE_MIN, sd_rel, m->identified, flags))
        return;
    const double *g[2] = {m->opt.guess_base, m->opt.guess_target};
    for (int k = 0; k < 2; k++) {
        if (flags[k])
            continue;
        double *body = out + 10 * k, m_out;
        int projected;
        double m_min = SR_REL_MASS_MIN * fabs(g[k][0]);
        if (m->robot.planar)
            sr_project_planar_body(body[0], body + 1, body + 4, m_min, SR_REL_SIGMA_MIN,
                                   &m_out, body + 4, &projected);
        else
            sr_project_body(body[0], body + 1, body + 4, m_min, SR_REL_SIGMA_MIN, &m_out,
                            body + 4, &projected);
        body[0] = m_out;
    }
    double scale[EST_NZ];
    sr_error_scale(out, SR_COM_SCALE_MIN, scale);
    sr_identified_bodies(sd, out, ls, scale, sd_rel, m->identified, flags + 2);
}

/* the least-squares estimates and standard deviations of this estimator's equations: after a
 * sample as the step left them, before any the prior's (solvers.ParameterSolver.std) */
static void rls_estimates(const sr_estimator_model *m, const est_data *d, double *vec,
                          double *sd)
{
    if (d->samples > 0) {
        memcpy(vec, d->core.vec, sizeof(double) * EST_NZ);
        memcpy(sd, d->core.sd, sizeof(double) * EST_NZ);
        return;
    }
    double data_only[EST_NZ], J[EST_NZ * EST_NZ], rcond[2];
    est_std_parts(m, &d->core, 1.0, 1.0, sd, data_only, J, vec, rcond);
}

/* the reported least-squares estimates and standard deviations: the information filter's
 * (its bound times sqrt(max(1, chi2)): the misfit the noise model did not foresee widens them)
 * where it runs, else the equations' own; crb (20) and chi2 (may be NULL) the filter's bound
 * and misfit, 0 without it */
static void estimates_info(const sr_estimator_model *m, const est_data *d, double *vec,
                           double *sd, double *crb, double *chi2)
{
    double bound[EST_NZ], x2 = 0.0;
    if (!m->info) {
        rls_estimates(m, d, vec, sd);
        memset(bound, 0, sizeof bound);
    } else {
        const sr_info_data *f = (const sr_info_data *)((const char *)d + m->off_info);
        if (sr_info_estimate(&m->info_m, f, 2, vec, bound, &x2) == 0) {
            double k = sqrt(x2 > 1.0 ? x2 : 1.0);
            for (int i = 0; i < EST_NZ; i++)
                sd[i] = k * bound[i];
        } else {                          /* a singular information: the equations' own */
            rls_estimates(m, d, vec, sd);
            memset(bound, 0, sizeof bound);
            x2 = 0.0;
        }
    }
    if (crb)
        memcpy(crb, bound, sizeof bound);
    if (chi2)
        *chi2 = x2;
}

static void estimates(const sr_estimator_model *m, const est_data *d, double *vec, double *sd)
{
    estimates_info(m, d, vec, sd, NULL, NULL);
}

void sr_estimator_estimates(const sr_estimator_model *m, const void *data, double *vec,
                            double *sd)
{
    if (!m || !data || !vec || !sd)
        return;
    if (!data_valid(m, (const est_data *)data)) {
        for (int i = 0; i < EST_NZ; i++)
            vec[i] = sd[i] = NAN;
        return;
    }
    estimates(m, (const est_data *)data, vec, sd);
}

void sr_estimator_sd_without_lag(const sr_estimator_model *m, const void *data, double *sd)
{
    if (!m || !data || !sd)
        return;
    const est_data *d = (const est_data *)data;
    if (!data_valid(m, d)) {
        for (int i = 0; i < EST_NZ; i++)
            sd[i] = NAN;
        return;
    }
    double vec[EST_NZ], data_only[EST_NZ], J[EST_NZ * EST_NZ], rcond[2];
    est_std_parts(m, &d->core, est_corr_current(m, data, 0),
                  m->opt.solver == 1 ? est_corr_current(m, data, 1) : 1.0, sd, data_only, J,
                  vec, rcond);
}

void sr_estimator_message(const sr_estimator_model *m, const void *data, char *msg,
                          size_t msglen)
{
    if (!m || !data || !msg || !msglen)
        return;
    const est_data *d = (const est_data *)data;
    char buf[SR_EST_MSG_LEN];
    memcpy(buf, d->msg, sizeof buf);         /* NUL-terminated even in a corrupt block */
    buf[SR_EST_MSG_LEN - 1] = '\0';
    sr_text_set(msg, msglen, buf);
}

void sr_estimator_report_get(const sr_estimator_model *m, const void *data,
                             sr_estimator_report *r)
{
    if (!m || !data || !r)
        return;
    const est_data *d = (const est_data *)data;
    double ls[EST_NZ];
    memset(r, 0, sizeof *r);
    r->excite_rate = 1.0;                    /* the plant's own rate unless chosen */
    if (!data_valid(m, d)) {                 /* a corrupt block: nothing but the status */
        r->status = SR_EST_REJECT_NONFINITE;
        return;
    }
    estimates_info(m, d, ls, r->sd, r->crb, &r->info_chi2);
    int flags[4];
    physical_vector(m, ls, r->sd, r->vector, flags);
    for (int k = 0; k < 2; k++) {
        r->physical[k] = flags[k];
        r->identified[k] = d->samples > 0 && flags[2 + k];
    }
    r->residual_lin = d->core.residual_lin;
    r->residual_ang = d->core.residual_ang;
    r->excitation_mu = d->samples > 0 ? d->core.rcond_mu : 0.0;
    r->excitation_theta = d->samples > 0 ? d->core.rcond_theta : 0.0;
    r->samples = d->samples;
    r->rejected = d->rejected;
    r->status = d->status;
    /* the excitation request (identifier.ExcitationRequest) */
    int mode = m->opt.excite_mode;
    r->excite = (mode == 2 || (mode == 1 && !(r->identified[0] && r->identified[1])))
                    ? m->opt.excite_level : 0.0;
    if (m->adapt) {
        const sr_exd_data *x = (const sr_exd_data *)((const char *)data + m->off_exd);
        r->excite_rate = x->rate;
        r->excite_score[0] = x->score[0];
        r->excite_score[1] = x->score[1];
    }
}
