/* The estimator's Model and the layout of its Data block (estimator.h): the options with the
 * noise profile applied and checked, the identified parameters and equation rows, the
 * prior, the rings' sizes, the information filter's and the excitation design's models; the
 * Data block's initial state and the check of a block restored from outside. */
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "differencing.h"
#include "est_band.h"
#include "est_joint.h"
#include "est_hold.h"
#include "est_modal.h"
#include "est_types.h"
#include "est_options.h"
#include "noise_profile.h"
#include "sr_math.h"
#include "standard_params.h"
#include "sr_text.h"

static size_t align8(size_t x) { return (x + 7) & ~(size_t)7; }

/* the noise's sd per channel (sd: the linear, angular and joint channels' three) and the
   channels with sd > 0 (accel_sd, used, n_used); 1 where there are any */
static int noise_channels(sr_estimator_model *m, const double *sd)
{
    for (int i = 0; i < 6 + m->n; i++) {
        m->accel_sd[i] = sd[i < 3 ? 0 : i < 6 ? 1 : 2];
        if (m->accel_sd[i] > 0.0)
            m->used[m->n_used++] = i;
    }
    return m->n_used > 0;
}

/* the modal columns' window rows' noisy channels: the position (the noise profile's
   noise.nav.r) and the velocities (signal_sd: the profile's nav.v, gyro.arw, enc.qd), the
   rows being affine in them (est_modal.h) */
static void window_channels(sr_estimator_model *m, const sr_estimator_options *opt)
{
    double r = 0.0;
    if (opt->noise_profile != SR_NOISE_PROFILE_NONE) {
        sr_info_noise nz;
        sr_noise_profile_info_noise(opt, &nz);
        r = nz.r;
    }
    for (int i = 0; i < 9 + m->n; i++) {
        int ch = i < 3 ? SR_X_R_S + i : m->vel_ch[i - 3];
        double sd = i < 3 ? r : opt->signal_sd[i < 6 ? 3 : i < 9 ? 4 : 5];
        if (sd > 0.0) {
            m->win_ch[m->n_win] = ch;
            m->win_sd[m->n_win++] = sd;
        }
    }
}

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
    if (sr_info_model_init(&m->info_m, robot, &nz, z0, o->P0_mu, o->P0_theta) != 0)
        return 1;
    m->info_m.fit.lags = o->fit_lags;
    m->info_m.fit.whiteness_max = o->fit_whiteness_max;
    m->info_m.fit.chi2_max = o->fit_chi2_max;
    m->info_m.fit.thrust_max = o->fit_thrust_max;
    return 0;
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
    /* the options as given checked, the noise profile applied, and the rules between options
     * checked again where the profile set some */
    sr_estimator_options eff;
    if (sr_noise_profile_apply(opt, &eff, err, errlen)
        || sr_estimator_options_check(&eff, err, errlen))
        return NULL;
    opt = &eff;
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
    /* differenced accelerations: the derivative's weights on the momentum equations (exact
     * however fast the accelerations change between samples) unless switched off, or, when
     * automatic, unless the window is wider than those weights keep their digits */
    m->diffmom = m->differenced
                 && (opt->diff_momentum == 1
                     || (opt->diff_momentum == 0
                         && opt->diff_half_window <= SR_DIFF_MAX_DISPLACEMENT_HALF_WINDOW));
    /* the thrust's consider term (consider.thrust_sd): the prior sd of
     * c = [s_F, phi_F (3), s_M, phi_M (3)], the same for force and moment */
    m->consider = opt->sd_thrust_scale > 0.0 || opt->sd_thrust_misalign > 0.0;
    for (int i = 0; i < SR_N_CONSIDER; i++)
        m->sd_c[i] = i % 4 == 0 ? opt->sd_thrust_scale : opt->sd_thrust_misalign;
    m->thrust_int = m->consider && (!m->force || m->diffmom);
    /* the momentum window (ident.momentum_window, the momentum method's) and its ring's
     * capacity */
    m->window = !m->force && opt->momentum_window > 0.0;
    m->win_len = opt->momentum_window;
    if (m->window) {
        double cap = opt->momentum_window_samples > 0
                         ? (double)opt->momentum_window_samples
                         : ceil(opt->momentum_window / SR_EST_WINDOW_MIN_STEP) + 2.0;
        m->win_cap = cap < SR_EST_MAX_WINDOW_SAMPLES ? (int)cap : SR_EST_MAX_WINDOW_SAMPLES;
        m->win_slot = 1 + m->nflat + (m->thrust_int ? SR_THRUST_NK : 0);
    }
    /* the accelerations' noise per channel: the measured accelerations' sd, or the
     * velocities' (times the derivative's gain per sample) */
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
    if (m->force)                            /* either solver; diffmom: the velocities' */
        m->eiv = noise_channels(m, opt->signal_sd + (m->differenced ? 3 : 0));
    /* the accelerometer bias (ident.accel_bias with the force method and measured
     * accelerations; ignored otherwise) */
    m->bias = m->force && !m->differenced && opt->accel_bias;
    /* the row weights 1 / sd of the chosen method's equations */
    const double *row_sd = opt->row_sd + 2 * (opt->method - 1);
    m->w_lin = row_sd[0] > 0.0 ? 1.0 / row_sd[0] : 1.0;
    m->w_ang = row_sd[1] > 0.0 ? 1.0 / row_sd[1] : 1.0;
    /* the identified estimates (spacerobot.interface.identified_estimates): all 20, or for a
     * planar robot m, b[1], b[2], Izz of each body; then the index arrays of
     * spacerobot.interface.ParameterLayout */
    for (int k = 0; k < 2; k++)
        for (int i = 0; i < 10; i++)
            m->identified[10 * k + i] = !robot->planar || i == 0 || i == 1 || i == 2 || i == 6;
    {
        int k_body = 0;                                      /* a body's identified estimates */
        for (int i = 0; i < 10; i++)
            k_body += m->identified[i];
        m->flag_z = sr_normal_quantile2((1.0 - opt->flag_confidence) / k_body);
    }
    m->p = m->r = 0;
    for (int k = 0; k < 2; k++) {
        for (int i = 0; i < 4; i++)                          /* m, b -> mu */
            if (m->identified[10 * k + i])
                m->mu_active[m->p++] = 4 * k + i;
        int sharp[6], ns = 0;                                /* I -> theta, sorted by I# */
        for (int i = 0; i < 6; i++)
            if (m->identified[10 * k + 4 + i])
                sharp[ns++] = SR_SHARP_TO_PROJECT[i];
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
    /* the guesses as mu (8) and theta (12) */
    const double *g[2] = {opt->guess_base, opt->guess_target};
    for (int k = 0; k < 2; k++) {
        m->mu0_full[4 * k] = g[k][0];
        for (int i = 0; i < 3; i++)
            m->mu0_full[4 * k + 1 + i] = g[k][0] * g[k][1 + i];
        for (int i = 0; i < 6; i++)
            m->th0_full[6 * k + SR_SHARP_TO_PROJECT[i]] = g[k][4 + i];
    }
    /* the joint solver's standard parameters [m, m b, I_O#] per body */
    {
        double x[EST_NZ];
        memcpy(x, opt->guess_base, sizeof(double) * 10);
        memcpy(x + 10, opt->guess_target, sizeof(double) * 10);
        sr_standard_of_reported(x, m->pi0_full);
    }
    for (int k = 0; k < 2; k++)
        for (int i = 0; i < 10; i++)
            m->prior[10 * k + i] = i < 4 ? opt->P0_mu : opt->P0_theta;
    m->q = 0;                                    /* the identified standard parameters */
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
    m->exd = est_exd_options(opt);
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
    m->modes = opt->modes == 1;     /* the modal columns (est_modal.h) */
    if (m->modes && m->window)
        window_channels(m, opt);
    if (m->modes) {
        off = align8(off);
        m->off_modal = off;
        off += est_modal_size(m);
    }
    /* the rigid band (est_band.h): automatic, where the filter runs at a sample time it takes */
    m->band = opt->band == 1
              || (opt->band == 0 && m->info && opt->noise_dt >= SR_BAND_DT_MIN
                  && opt->noise_dt <= SR_BAND_DT_MAX);
    if (m->band && !m->info) {
        sr_text_set(err, errlen, "ident.band = 1 (the rigid band) needs the information filter: "
                                 "set ident.noise_profile = 1 with the sensors' noise.* "
                                 "magnitudes, and leave ident.information at 0 (automatic) or 1");
        free(m);
        return NULL;
    }
    if (m->band && sr_band_model_init(&m->band_m, &m->info_m, opt->noise_dt) != 0) {
        sr_text_set(err, errlen, "ident.band = 1 (the rigid band) needs a sample time noise_dt "
                                 "from ");
        sr_text_num(err, errlen, SR_BAND_DT_MIN, 6);
        sr_text_cat(err, errlen, " to ");
        sr_text_num(err, errlen, SR_BAND_DT_MAX, 6);
        sr_text_cat(err, errlen, " s (its low-pass at 0.15 Hz), got ");
        sr_text_repr(err, errlen, opt->noise_dt);
        free(m);
        return NULL;
    }
    if (m->band && m->modes)    /* (the same sample time: it cannot fail here) */
        sr_band_model_init_modes(&m->band_modes_m, &m->info_m, opt->noise_dt);
    if (m->band) {
        off = align8(off);
        m->off_band = off;
        off += est_band_size(m);
    }
    m->size = off;
    /* the work space's noise rows: the window's 2 m + 1 chunks with diff_momentum, else one */
    if (m->eiv)
        m->work_noise = (size_t)(m->diffmom ? 2 * m->half + 1 : 1) * (size_t)m->n_used * EST_NB;
    if (m->n_win)                            /* the sample's and the reference's */
        m->work_noise = 2 * (size_t)m->n_win * EST_NB;
    return m;
}

void sr_estimator_model_free(sr_estimator_model *m) { free(m); }

void sr_estimator_model_options(const sr_estimator_model *m, sr_estimator_options *out)
{
    if (!m || !out)
        return;
    *out = m->opt;
    if (!m->window)                          /* the momentum method's */
        out->momentum_window = 0.0;
    if (m->force)
        out->momentum_point = 0;
    if (!m->bias)                            /* the force method's, measured accelerations */
        out->accel_bias = 0;
    out->diff_momentum = m->diffmom;         /* as used: 1 the momentum form, else 0 */
    if (!m->force)                           /* the force method's noisy accelerations, */
        for (int i = 0; i < 6; i++)          /* the modal window rows' velocities */
            if (i < 3 || !m->n_win)
                out->signal_sd[i] = 0.0;
}

size_t sr_estimator_data_size(const sr_estimator_model *m) { return m ? m->size : 0; }

size_t sr_estimator_work_size(const sr_estimator_model *m)
{
    return m ? sizeof(est_work) + sizeof(double) * m->work_noise
                   + est_modal_work_size(m) + est_band_work_size(m)
             : 0;
}

size_t sr_estimator_data_head_size(void) { return offsetof(est_data, core); }

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
        sr_info_data_init(&m->info_m, est_info_data(m, data));
    if (m->adapt)
        sr_exd_init(est_exd_data(m, data));
    est_modal_init(m, data);
    est_band_init(m, data);
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
        const sr_info_data *f = est_info_data(m, data);
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
    if (m->adapt && !sr_exd_data_valid(&m->exd, est_exd_data(m, data))) {
        sr_text_set(err, errlen, "the estimator's state block is not valid: the excitation "
                             "design's phase or rate is out of range or its numbers not "
                             "finite");
        return 1;
    }
    if (est_hold_check(&d->hold)) {
        sr_text_set(err, errlen, "the estimator's state block is not valid: the identified "
                             "flags' hold has counts out of range or numbers not finite");
        return 1;
    }
    if (est_modal_check(m, data)) {
        sr_text_set(err, errlen, "the estimator's state block is not valid: the modal columns' "
                             "counts or frequencies are out of range or its numbers not "
                             "finite");
        return 1;
    }
    if (est_band_check(m, data)) {
        sr_text_set(err, errlen, "the estimator's state block is not valid: the rigid band's "
                                 "counts are out of range or its numbers not finite");
        return 1;
    }
    if (!memchr(d->msg, '\0', sizeof d->msg)) {
        sr_text_set(err, errlen, "the estimator's state block is not valid: its message is not "
                             "terminated");
        return 1;
    }
    return 0;
}
