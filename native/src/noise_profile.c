/* The estimator's noise model from the sensors' parameters (noise_profile.h). */
#include "noise_profile.h"

#include <math.h>
#include <string.h>

int sr_noise_profile_apply(const sr_estimator_options *in, sr_estimator_options *out,
                           char *err, size_t errlen)
{
    if (sr_estimator_options_check(in, err, errlen))
        return 1;
    sr_estimator_options o = *in, d;
    if (o.noise_profile == SR_NOISE_PROFILE_NONE) {
        *out = o;
        return 0;
    }
    double s = o.noise_scale, dt = o.noise_dt, p[SR_NOISE_COUNT];
    for (int i = 0; i < SR_NOISE_COUNT; i++)     /* the magnitudes scaled (the estimator FMU's */
        p[i] = s * o.noise[i];                    /* are the ones read below; the rest 0) */
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
