/* The estimator's options (est_options.h): their defaults and their rules. */
#include "est_options.h"

#include <math.h>
#include <string.h>

#include "body.h"
#include "differencing.h"
#include "sr_text.h"

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

sr_exd_options est_exd_options(const sr_estimator_options *o)
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

int est_options_check(const sr_estimator_options *o, char *err, size_t errlen)
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
    const sr_exd_options exd = est_exd_options(o);
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
