/* The estimator's noise model from the sensors' parameters (noise_profile.h). */
#include "noise_profile.h"

#include <math.h>
#include <string.h>

/* the magnitudes the profile reads */
static const int READ[] = {SR_NOISE_GYRO_ARW, SR_NOISE_NAV_V, SR_NOISE_ACCEL_VRW, SR_NOISE_ALPHA,
                           SR_NOISE_ENC_QD, SR_NOISE_ENC_QDD, SR_NOISE_THRUST_SCALE,
                           SR_NOISE_THRUST_MISALIGN, SR_NOISE_NAV_R, SR_NOISE_STAR_CROSS,
                           SR_NOISE_STAR_ROLL, SR_NOISE_ENC_Q, SR_NOISE_ENC_RESOLUTION,
                           SR_NOISE_GYRO_BIAS};

static int fail(sr_noise_profile_error *e, const char *name, const char *rule, double value)
{
    e->name = name;
    e->rule = rule;
    e->value = value;
    return 1;
}

int sr_noise_profile_apply(const sr_estimator_options *in, sr_estimator_options *out,
                           sr_noise_profile_error *e)
{
    sr_estimator_options o = *in, d;
    if (o.noise_profile != SR_NOISE_PROFILE_NONE && o.noise_profile != SR_NOISE_PROFILE_SENSORS)
        return fail(e, "ident.noise_profile", "0 (none) or 1 (sensors)",
                    (double)o.noise_profile);
    if (o.noise_profile == SR_NOISE_PROFILE_NONE) {
        *out = o;
        return 0;
    }
    double s = o.noise_scale, dt = o.noise_dt;
    if (!(isfinite(s) && s >= 0.0 && s <= SR_NOISE_PROFILE_MAX))
        return fail(e, "noise.scale", "a finite number in [0, 1e6]", s);
    if (!(isfinite(dt) && dt > 0.0 && dt <= SR_NOISE_PROFILE_MAX))
        return fail(e, "the sample time (noise_dt)", "a finite number in (0, 1e6] s",
                    dt);
    double p[SR_NOISE_COUNT] = {0};
    for (size_t k = 0; k < sizeof READ / sizeof READ[0]; k++) {
        int i = READ[k];
        double x = o.noise[i];
        if (!(isfinite(x) && x >= 0.0))
            return fail(e, sr_noise_name(i), "a finite number >= 0", x);
        p[i] = s * x;
        if (!(p[i] <= SR_NOISE_PROFILE_MAX))
            return fail(e, sr_noise_name(i), "at most 1e6 / noise.scale", x);
    }
    for (int k = SR_NOISE_THRUST_SCALE; k <= SR_NOISE_THRUST_MISALIGN; k++)
        if (p[k] > SR_EST_MAX_THRUST_SD)
            return fail(e, sr_noise_name(k), "at most 1 / noise.scale", o.noise[k]);
    double rt = sqrt(dt);
    sr_estimator_options_default(&d);
    /* each option still at its default takes the profile's value; the user's stay */
#define FILL(field, value) do { if (o.field == d.field) o.field = (value); } while (0)
    FILL(sd_thrust_scale, p[SR_NOISE_THRUST_SCALE]);
    FILL(sd_thrust_misalign, p[SR_NOISE_THRUST_MISALIGN]);
    /* the information filter weighs the rows by the sensors' white noise: with none (e.g.
       noise.scale 0) there is nothing to weigh by, and the estimator's own equations serve */
    sr_info_noise nz;
    sr_noise_profile_info_noise(&o, &nz);
    FILL(information, sr_info_noise_white(&nz) ? 1 : 2);
    /* white noise per sample of the accelerations (measured) and velocities (differenced);
       a density over 1 s drawn every dt has the sd d / sqrt(dt) (docs/sensors.md) */
    FILL(signal_sd[0], p[SR_NOISE_ACCEL_VRW] / rt);          /* a_S */
    FILL(signal_sd[1], p[SR_NOISE_ALPHA]);                   /* alpha_B */
    FILL(signal_sd[2], p[SR_NOISE_ENC_QDD]);                 /* qdd */
    FILL(signal_sd[3], p[SR_NOISE_NAV_V]);                   /* v_S */
    FILL(signal_sd[4], p[SR_NOISE_GYRO_ARW] / rt);           /* omega_B */
    FILL(signal_sd[5], p[SR_NOISE_ENC_QD]);                  /* qd */
    if (o.method == 1) {
        FILL(momentum_window, SR_NOISE_PROFILE_WINDOW);
        FILL(momentum_point, 1);
        /* the overlapping windows share their errors over the window's samples */
        double lags = floor(SR_NOISE_PROFILE_WINDOW / dt + 0.5);
        FILL(corr_lags, lags < SR_EST_MAX_CORR_LAGS ? (int)lags : SR_EST_MAX_CORR_LAGS);
    } else if (o.accel_source == 1) {
        FILL(accel_bias, 1);
    } else {
        FILL(diff_momentum, 1);
        FILL(diff_half_window, SR_NOISE_PROFILE_HALF_WINDOW);
    }
#undef FILL
    *out = o;
    return 0;
}

void sr_noise_profile_info_noise(const sr_estimator_options *o, sr_info_noise *nz)
{
    const double *p = o->noise, s = o->noise_scale;
    double res = p[SR_NOISE_ENC_RESOLUTION];
    nz->r = s * p[SR_NOISE_NAV_R];
    nz->v = s * p[SR_NOISE_NAV_V];
    nz->omega = s * p[SR_NOISE_GYRO_ARW] / sqrt(o->noise_dt);
    nz->att[0] = nz->att[1] = s * p[SR_NOISE_STAR_CROSS];
    nz->att[2] = s * p[SR_NOISE_STAR_ROLL];
    nz->q = s * sqrt(p[SR_NOISE_ENC_Q] * p[SR_NOISE_ENC_Q] + res * res / 12.0);
    nz->qd = s * p[SR_NOISE_ENC_QD];
    for (int k = 0; k < 2; k++) {
        nz->thrust[4 * k] = o->sd_thrust_scale;
        for (int i = 1; i < 4; i++)
            nz->thrust[4 * k + i] = o->sd_thrust_misalign;
    }
    nz->gyro_bias = s * p[SR_NOISE_GYRO_BIAS];
}
