/* The sensor models between the plant's true signals and the estimator (docs/sensors.md): gyro
 * (white noise, initial bias, bias random walk), star tracker, relative navigation,
 * accelerometer / IMU, joint encoders (noise, quantisation), thrust knowledge (scale factor and
 * misalignment drawn once per run), sample delay.
 *
 * A sample is the flat sample of sample.h (SR_X_LEN(n) values: r_S, v_S, A (row-major),
 * omega_B, a_S, alpha_B, q, qd, qdd, F, M, J, H). The model (sr_sensors_model: constants) and
 * the state (sr_sensors_state: the random generators, biases, white-noise draws, thrust
 * errors, the delay ring) are plain structs without pointers: copy the state to save or
 * restore a run (its size is fixed: sr_sensors_state_size()).
 *
 * Timing: sr_sensors_measure is a pure function of the true sample and the state (the
 * measurement output at the sample's time, direct feedthrough); sr_sensors_advance moves on one
 * sample interval (remember the measurement in the delay ring, integrate the thrust error's
 * angular impulse, walk the biases, draw the next white noise); sr_sensors_update does both.
 *
 * Random numbers: one sr_rng stream per sensor (gyro, star, nav, imu, enc, thrust: stream k is
 * the seed's splitmix64 / xoshiro256** generator jumped k times), drawn in a fixed order per
 * stream, so changing one sensor's parameters leaves the others' noise unchanged. The same seed
 * gives the same bits on every platform (rng.h).
 */
#ifndef SR_SENSORS_H
#define SR_SENSORS_H

#include <stddef.h>

#include "arm.h"
#include "rng.h"
#include "sample.h"
#include "sensor_noise.h"
#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/* the random streams, one per sensor */
enum { SR_STREAM_GYRO = 0, SR_STREAM_STAR, SR_STREAM_NAV, SR_STREAM_IMU, SR_STREAM_ENC,
       SR_STREAM_THRUST, SR_N_STREAMS };

/** Longest sample delay (noise.delay) in samples: the delay ring's size. */
#define SR_SENSORS_MAX_DELAY 100
/** Length of one sample row in the delay ring (the flat sample of SR_MAX_JOINTS joints). */
#define SR_SENSORS_ROW SR_X_LEN(SR_MAX_JOINTS)

/** The constants of a sensor suite (set by sr_sensors_init only). */
typedef struct sr_sensors_model {
    int n;                          /* joints, 1..SR_MAX_JOINTS */
    int delay;                      /* noise.delay [samples], 0..SR_SENSORS_MAX_DELAY */
    int imu;                        /* noise.imu: 1 accelerometer / IMU present, 0 absent */
    int reserved;                   /* 0 */
    double scale;                   /* noise.scale >= 0 */
    double dt;                      /* the communication step [s] (first white-noise draws) */
    uint64_t seed;                  /* seed >= 0 */
    double p[SR_NOISE_COUNT];       /* magnitudes in effect: noise.* times noise.scale */
} sr_sensors_model;

/** Everything that evolves (plain data: copy it to save or restore a run). */
typedef struct sr_sensors_state {
    sr_rng rng[SR_N_STREAMS];       /* one stream per sensor */
    double gyro_bias[3];            /* [rad/s], base frame */
    double accel_bias[3];           /* [m/s2], inertial */
    double E_F[9], E_M[9];          /* (1 + s) R(phi) - 1 of force and moment (3 x 3) */
    double H_err[3];                /* integral of the thrust error's angular impulse [N.m.s] */
    /* the white-noise draws of the current sample */
    double d_omega[3], d_att[3], d_r[3], d_v[3], d_a[3], d_alpha[3];
    double d_q[SR_MAX_JOINTS], d_qd[SR_MAX_JOINTS], d_qdd[SR_MAX_JOINTS];
    int32_t count;                  /* measurements in the delay ring, 0..delay */
    int32_t head;                   /* ring index of the oldest, 0..delay-1 (0 if delay 0) */
    double line[SR_SENSORS_MAX_DELAY][SR_SENSORS_ROW];   /* the last `delay` measurements */
} sr_sensors_state;

/** sizeof(sr_sensors_model) and sizeof(sr_sensors_state) [bytes] (for hosts that allocate
 *  them as opaque blocks). */
SR_API size_t sr_sensors_model_size(void);
SR_API size_t sr_sensors_state_size(void);

/** The FMU parameter name of magnitude i ("noise.gyro.arw", ...), NULL for i out of
 *  0..SR_NOISE_COUNT-1. */
SR_API const char *sr_sensors_parameter_name(int i);

/** The prefix of the sensors FMU's inputs: true.<name> for each signal <name> it measures. */
#define SR_SENSORS_TRUE_PREFIX "true."

/** The range [*min, *max] sr_sensors_init accepts for the sensors FMU's parameter or input
 *  fmi_name: noise.scale [0, SR_NOISE_SCALE_MAX]; each magnitude noise.<name> [0, its limit]
 *  (below; the product with noise.scale has the same limit); seed [0, 2^31 - 1] (the FMU's
 *  Int32); noise.delay [0, SR_SENSORS_MAX_DELAY]; noise.imu [0, 1]; an input true.<signal>
 *  [-SR_SAMPLE_LIMIT, SR_SAMPLE_LIMIT] (the range within which a measurement is always finite).
 *  Returns 0, or 1 (nothing written) for a name the sensors FMU does not have. */
SR_API int sr_sensors_param_range(const char *fmi_name, double *min, double *max);

/** Set up the model: n joints; noise (SR_NOISE_COUNT): the noise.* magnitudes in the order
 *  above (not yet scaled); scale = noise.scale; seed = seed; delay = noise.delay;
 *  imu = noise.imu; dt the communication step [s]. Returns 0, or 1 with model untouched and
 *  a NUL-terminated message naming the FMU parameter in msg (msg_size bytes; msg may be
 *  NULL) for: n outside 1..SR_MAX_JOINTS, noise.scale outside [0, SR_NOISE_SCALE_MAX], a
 *  magnitude not finite and >= 0, a magnitude or its product with noise.scale above its limit
 *  (angles pi rad, the thrust scale factor 10, every other 1e6 in SI units: a sample within
 *  the physical range, |x| <= SR_SAMPLE_LIMIT, then always gives a finite measurement), an
 *  encoder step times noise.scale in (0, 1e-9) rad, seed outside [0, 2^31 - 1], noise.delay
 *  outside 0..SR_SENSORS_MAX_DELAY, noise.imu not 0 or 1, dt not finite and > 0, a NULL model
 *  or noise. sr_sensors_param_range gives each parameter's range. */
SR_API int sr_sensors_init(sr_sensors_model *model, int n, const double *noise, double scale,
                           long long seed, int delay, int imu, double dt, char *msg,
                           int msg_size);

/** Start a run: seed the streams, draw the initial biases, the
 *  thrust errors E_F then E_M, the first white noise (with model->dt); H_err = 0; empty delay
 *  ring. Returns 0, or 1 for a NULL pointer or a model not set by sr_sensors_init. */
SR_API int sr_sensors_start(const sr_sensors_model *model, sr_sensors_state *state);

/** The measurement y (SR_X_LEN(n)) at the time of the true sample x (SR_X_LEN(n)): the
 *  oldest measurement in the delay ring when noise.delay > 0 and the ring is not empty,
 *  else the measurement of x. noise.scale = 0: y = x bit for bit
 *  (with noise.imu = 0 a_S = alpha_B = 0 whatever the scale). y may alias x. The state is
 *  not changed. Returns 0; 1 for a NULL pointer or a bad model; 3 for an inconsistent state
 *  (delay ring indices out of range; y untouched). Non-finite inputs are passed on. */
SR_API int sr_sensors_measure(const sr_sensors_model *model, const sr_sensors_state *state,
                              const double *x, double *y);

/** Move on from the true sample x (SR_X_LEN(n)) to the next, dt [s] later:
 *  remember the measurement of x (delay ring); then, unless
 *  noise.scale = 0, add dt (E_M M + r_S x E_F F) to H_err (not if non-finite), walk the
 *  biases (b += d sqrt(dt) N(0, 1)), draw the next white noise. Returns 0; 1 for a NULL
 *  pointer or a bad model; 2 for dt not finite and > 0; 3 for an inconsistent state (state
 *  untouched on every error). */
SR_API int sr_sensors_advance(const sr_sensors_model *model, sr_sensors_state *state,
                              const double *x, double dt);

/** sr_sensors_measure then sr_sensors_advance: one call per sample. y may alias x. Returns
 *  as those (nothing changed on an error). */
SR_API int sr_sensors_update(const sr_sensors_model *model, sr_sensors_state *state,
                             const double *x, double dt, double *y);

/** exp([phi]x) (R 3 x 3, row-major) of the rotation vector phi (3) [rad] (Rodrigues, with
 *  the portable sine and cosine of rng.h; I + K + K^2/2 below 1e-8 rad). */
SR_API void sr_rotation_vector_to_matrix(const double *phi, double *R);

#ifdef __cplusplus
}
#endif

#endif /* SR_SENSORS_H */
