/* One switch for real sensors (docs/identification.md, "One switch"): the estimator's noise
 * model set from the sensors' own parameters (the sensors FMU's noise.*
 * names and units, docs/sensors.md) instead of a dozen hand settings.
 *
 * With ident.noise_profile = 1 each noise option of sr_estimator_options still at its default
 * (sr_estimator_options_default) takes the value below; an option set to anything else is the
 * user's and kept. Measured on the noise benchmark (benchmarks/NOISE.md, realistic sensors,
 * 20 random spatial cases, 300 s), these are the settings that gave the smallest errors with
 * calibrated standard deviations:
 *   - every method: the thrust's scale and misalignment errors as a consider covariance
 *     (ident.sd_thrust.* = noise.thrust.*);
 *   - momentum: equations differenced over a 5 s window with the angular rows about the base
 *     (ident.momentum_window = 5 s, ident.momentum_point = 1), the residual correlation over
 *     the window's samples (ident.corr_lags = 5 s / noise_dt);
 *   - force, measured accelerations: the accelerometer bias estimated from the navigation
 *     velocity (ident.accel_bias = 1), the accelerations' white noise compensated
 *     (ident.noise.base.a = noise.accel.vrw / sqrt(dt), base.alpha = noise.alpha,
 *     arm.qdd = noise.enc.qdd);
 *   - force, differenced accelerations: the derivative's weights on the momentum equations
 *     over 9 samples (ident.diff_momentum = 1, ident.diff_half_window = 4), the velocities'
 *     noise compensated (ident.noise.base.v = noise.nav.v, base.omega = noise.gyro.arw /
 *     sqrt(dt), arm.qd = noise.enc.qd);
 *   - the information filter (ident.information = 1, information.h) where the sensors have
 *     white noise (2, off, where they have none, e.g. noise.scale 0): its estimates and
 *     standard deviations are reported, the estimator's own equations linearise its weights;
 *   - row weights: unit (ident.sd_row.* 0). With the paper's solver the weights only set the
 *     data's weight against the weak prior: a pilot run's row standard deviations changed no
 *     estimate's worst error nor the calibration on the benchmark's cases.
 * Every magnitude is multiplied by noise.scale.
 */
#ifndef SR_NOISE_PROFILE_H
#define SR_NOISE_PROFILE_H

#include <stddef.h>

#include "estimator.h"
#include "information.h"
#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/* the momentum method's window under the profile [s] */
#define SR_NOISE_PROFILE_WINDOW 5.0
/* the force method's derivative under the profile: 2 m + 1 samples */
#define SR_NOISE_PROFILE_HALF_WINDOW 4

/** out = in with the noise profile in->noise_profile applied (out may alias in). Returns 0,
 *  or 1 with the message of sr_estimator_options_check in err (errlen bytes) where the options
 *  in are not valid. With profile 0 the options are copied unchanged (the sensors' values are
 *  not read). */
SR_API int sr_noise_profile_apply(const sr_estimator_options *in, sr_estimator_options *out,
                                  char *err, size_t errlen);

/** The information filter's noise model (information.h) of the options o (the profile
 *  applied): the sensors' white noise per sample (densities over 1 s drawn every noise_dt:
 *  d / sqrt(noise_dt); the encoder's angle with its quantisation, variance res^2 / 12) and the
 *  gyro bias' prior, all times noise.scale; the thrust errors' prior the consider term's
 *  (ident.sd_thrust.*, the profile's noise.thrust.* unless the user set them). */
SR_API void sr_noise_profile_info_noise(const sr_estimator_options *o, sr_info_noise *out);

#ifdef __cplusplus
}
#endif

#endif
