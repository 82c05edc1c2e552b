/* The sensor models (sensors.h): the measurement of a true sample, the noise processes' state and
 * the checks of the noise parameters, whose limits are also the FMU's declared ranges
 * (sr_sensors_param_range). */
#include "sensors.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "sr_math.h"
#include "sr_text.h"

/* The largest magnitude in effect (noise.<name> times noise.scale, and each of the two alone) of
 * each parameter, so that a true sample within the physical range (|x| <= SR_SAMPLE_LIMIT, SI)
 * always gives a finite measurement: angles' errors up to pi [rad], the thrust scale factor's up
 * to 10 (1000 %), every other error up to 1e6 (SI units). */
#define ANGLE_LIMIT 3.141592653589793
#define SI_LIMIT 1e6
static const struct {
    double max;
    const char *unit;
} LIMIT[SR_NOISE_COUNT] = {
    {SI_LIMIT, "rad/s"}, {SI_LIMIT, "rad/s"}, {SI_LIMIT, "rad/s"}, {ANGLE_LIMIT, "rad"},
    {ANGLE_LIMIT, "rad"}, {SI_LIMIT, "m"}, {SI_LIMIT, "m/s"}, {SI_LIMIT, "m/s2"},
    {SI_LIMIT, "m/s2"}, {SI_LIMIT, "m/s2"}, {SI_LIMIT, "rad/s2"}, {ANGLE_LIMIT, "rad"},
    {SI_LIMIT, "rad"}, {SI_LIMIT, "rad/s"}, {SI_LIMIT, "rad/s2"}, {10.0, ""}, {ANGLE_LIMIT, "rad"}};
/* the smallest encoder step other than 0 (q / step stays far from overflow) */
#define MIN_RESOLUTION 1e-9
/* seed: the FMU's Integer (Int32) variables hold 0..2^31 - 1 */
#define SEED_MAX 2147483647.0

size_t sr_sensors_model_size(void)
{
    return sizeof(sr_sensors_model);
}

size_t sr_sensors_state_size(void)
{
    return sizeof(sr_sensors_state);
}

const char *sr_sensors_parameter_name(int i)
{
    return (i >= 0 && i < SR_NOISE_COUNT) ? sr_noise_name(i) : NULL;
}

int sr_sensors_param_range(const char *fmi_name, double *min, double *max)
{
    double lo = 0.0, hi;
    int i;
    if (fmi_name == NULL || min == NULL || max == NULL)
        return 1;
    if (strncmp(fmi_name, SR_SENSORS_TRUE_PREFIX, sizeof SR_SENSORS_TRUE_PREFIX - 1) == 0) {
        lo = -SR_SAMPLE_LIMIT;                     /* an input true.<signal> */
        hi = SR_SAMPLE_LIMIT;
    } else if (strcmp(fmi_name, "noise.scale") == 0) {
        hi = SR_NOISE_SCALE_MAX;
    } else if (strcmp(fmi_name, "seed") == 0) {
        hi = SEED_MAX;
    } else if (strcmp(fmi_name, "noise.delay") == 0) {
        hi = SR_SENSORS_MAX_DELAY;
    } else if (strcmp(fmi_name, "noise.imu") == 0) {
        hi = 1.0;
    } else {
        for (i = 0; i < SR_NOISE_COUNT && strcmp(fmi_name, sr_noise_name(i)) != 0; ++i) {
        }
        if (i == SR_NOISE_COUNT)
            return 1;
        hi = LIMIT[i].max;
    }
    *min = lo;
    *max = hi;
    return 0;
}

/* "at most <limit> <unit>", pi spelled out (the angles' limit) */
static void limit_text(char *msg, size_t n, double limit, const char *unit)
{
    if (limit == ANGLE_LIMIT)
        sr_text_cat(msg, n, "pi");
    else
        sr_text_num(msg, n, limit, 6);
    if (unit[0]) {
        sr_text_cat(msg, n, " ");
        sr_text_cat(msg, n, unit);
    }
}

static int model_ok(const sr_sensors_model *m)
{
    return m && m->n >= 1 && m->n <= SR_MAX_JOINTS && m->delay >= 0
           && m->delay <= SR_SENSORS_MAX_DELAY && (m->imu == 0 || m->imu == 1);
}

static int state_ok(const sr_sensors_model *m, const sr_sensors_state *s)
{
    if (m->delay == 0)
        return s->count == 0 && s->head == 0;
    return s->count >= 0 && s->count <= m->delay && s->head >= 0 && s->head < m->delay;
}

int sr_sensors_init(sr_sensors_model *model, int n, const double *noise, double scale,
                    long long seed, int delay, int imu, double dt, char *msg, int msg_size)
{
    sr_sensors_model m;
    const size_t size = msg_size > 0 ? (size_t)msg_size : 0;
    int i;
    sr_text_set(msg, size, "");
    if (model == NULL || noise == NULL) {
        sr_text_set(msg, size, "sensors: NULL model or noise parameters");
        return 1;
    }
    if (n < 1 || n > SR_MAX_JOINTS) {
        sr_text_format(msg, size, "sensors: the number of joints must be 1..%d", SR_MAX_JOINTS);
        return 1;
    }
    if (!(isfinite(scale) && scale >= 0.0 && scale <= SR_NOISE_SCALE_MAX)) {
        sr_text_format(msg, size, "noise.scale must be finite and in [0, %g], got %g",
                       SR_NOISE_SCALE_MAX, scale);
        return 1;
    }
    for (i = 0; i < SR_NOISE_COUNT; ++i) {
        if (!(isfinite(noise[i]) && noise[i] >= 0.0)) {
            sr_text_format(msg, size, "%s must be finite and >= 0, got %g", sr_noise_name(i),
                           noise[i]);
            return 1;
        }
        if (!(noise[i] <= LIMIT[i].max && scale * noise[i] <= LIMIT[i].max)) {
            sr_text_format(msg, size, "%s (%g) and %s times noise.scale (%g) must be at most ",
                           sr_noise_name(i), noise[i], sr_noise_name(i), scale * noise[i]);
            limit_text(msg, size, LIMIT[i].max, LIMIT[i].unit);
            return 1;
        }
    }
    if (scale * noise[SR_NOISE_ENC_RESOLUTION] > 0.0
        && scale * noise[SR_NOISE_ENC_RESOLUTION] < MIN_RESOLUTION) {
        sr_text_format(msg, size, "noise.enc.resolution times noise.scale must be 0 (no "
                       "quantisation) or at least %g rad", MIN_RESOLUTION);
        return 1;
    }
    if (seed < 0 || (double)seed > SEED_MAX) {
        sr_text_format(msg, size, "seed must be in [0, %lld], got %lld", (long long)SEED_MAX,
                       seed);
        return 1;
    }
    if (delay < 0 || delay > SR_SENSORS_MAX_DELAY) {
        sr_text_format(msg, size, "noise.delay must be an integer in 0..%d (samples), got %d",
                       SR_SENSORS_MAX_DELAY, delay);
        return 1;
    }
    if (imu != 0 && imu != 1) {
        sr_text_format(msg, size, "noise.imu must be 0 or 1, got %d", imu);
        return 1;
    }
    if (!(isfinite(dt) && dt > 0.0)) {
        sr_text_format(msg, size, "sensors: the communication step must be finite and > 0, "
                       "got %g s", dt);
        return 1;
    }
    memset(&m, 0, sizeof m);
    m.n = n;
    m.delay = delay;
    m.imu = imu;
    m.scale = scale;
    m.dt = dt;
    m.seed = (uint64_t)seed;
    for (i = 0; i < SR_NOISE_COUNT; ++i)
        m.p[i] = scale * noise[i];          /* every error scaled by noise.scale */
    *model = m;
    return 0;
}

/* -- small vector helpers ------------------------------------------------------------------ */

static void skew(const double w[3], double K[9])
{
    K[0] = 0.0;   K[1] = -w[2]; K[2] = w[1];
    K[3] = w[2];  K[4] = 0.0;   K[5] = -w[0];
    K[6] = -w[1]; K[7] = w[0];  K[8] = 0.0;
}

static void mat3_mul(const double *A, const double *B, double *C)
{
    int i, j;
    for (i = 0; i < 3; ++i)
        for (j = 0; j < 3; ++j)
            C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

static void mat3_vec(const double *A, const double *x, double *y)
{
    int i;
    for (i = 0; i < 3; ++i)
        y[i] = A[3 * i] * x[0] + A[3 * i + 1] * x[1] + A[3 * i + 2] * x[2];
}

void sr_rotation_vector_to_matrix(const double *phi, double *R)
{
    double K[9], K2[9], c1, c2;
    const double angle = sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]);
    int i;
    skew(phi, K);
    mat3_mul(K, K, K2);
    if (angle < 1e-8) {                     /* series: exact to round-off for such angles */
        c1 = 1.0;
        c2 = 0.5;
    } else {
        /* R = I + sin(a)/a K + (1 - cos(a))/a^2 K^2 with h = a/2:
         * sin(a)/a = (sin h / h) cos h, (1 - cos a)/a^2 = (sin h / h)^2 / 2 (no cancellation) */
        double sh, ch, t;
        const double h = 0.5 * angle;
        sr_sincos(h, &sh, &ch);
        t = sh / h;
        c1 = t * ch;
        c2 = 0.5 * t * t;
    }
    for (i = 0; i < 9; ++i)
        R[i] = c1 * K[i] + c2 * K2[i];
    R[0] += 1.0;
    R[4] += 1.0;
    R[8] += 1.0;
}

/* (1 + s) R(phi) - I with scale factor error s ~ N(0, thrust.scale^2) and misalignment
 * phi ~ N(0, thrust.misalign^2) per axis */
static void thrust_error(const sr_sensors_model *m, sr_rng *g, double E[9])
{
    double phi[3], R[9];
    const double s = m->p[SR_NOISE_THRUST_SCALE] * sr_rng_normal(g);
    int i;
    for (i = 0; i < 3; ++i)
        phi[i] = m->p[SR_NOISE_THRUST_MISALIGN] * sr_rng_normal(g);
    sr_rotation_vector_to_matrix(phi, R);
    for (i = 0; i < 9; ++i)
        E[i] = (1.0 + s) * R[i] - ((i % 4 == 0) ? 1.0 : 0.0);
}

/* the white-noise draws of one sample: a density d (its sd over 1 s)
 * sampled at interval dt has sd d / sqrt(dt) */
static void draw(const sr_sensors_model *m, sr_sensors_state *s, double dt)
{
    const double *p = m->p;
    const double rt = sqrt(dt);
    const double att[3] = {p[SR_NOISE_STAR_CROSS], p[SR_NOISE_STAR_CROSS], p[SR_NOISE_STAR_ROLL]};
    int i;
    for (i = 0; i < 3; ++i)
        s->d_omega[i] = (p[SR_NOISE_GYRO_ARW] / rt) * sr_rng_normal(&s->rng[SR_STREAM_GYRO]);
    for (i = 0; i < 3; ++i)
        s->d_att[i] = att[i] * sr_rng_normal(&s->rng[SR_STREAM_STAR]);
    for (i = 0; i < 3; ++i)
        s->d_r[i] = p[SR_NOISE_NAV_R] * sr_rng_normal(&s->rng[SR_STREAM_NAV]);
    for (i = 0; i < 3; ++i)
        s->d_v[i] = p[SR_NOISE_NAV_V] * sr_rng_normal(&s->rng[SR_STREAM_NAV]);
    for (i = 0; i < 3; ++i)
        s->d_a[i] = (p[SR_NOISE_ACCEL_VRW] / rt) * sr_rng_normal(&s->rng[SR_STREAM_IMU]);
    for (i = 0; i < 3; ++i)
        s->d_alpha[i] = p[SR_NOISE_ALPHA] * sr_rng_normal(&s->rng[SR_STREAM_IMU]);
    for (i = 0; i < m->n; ++i)
        s->d_q[i] = p[SR_NOISE_ENC_Q] * sr_rng_normal(&s->rng[SR_STREAM_ENC]);
    for (i = 0; i < m->n; ++i)
        s->d_qd[i] = p[SR_NOISE_ENC_QD] * sr_rng_normal(&s->rng[SR_STREAM_ENC]);
    for (i = 0; i < m->n; ++i)
        s->d_qdd[i] = p[SR_NOISE_ENC_QDD] * sr_rng_normal(&s->rng[SR_STREAM_ENC]);
}

int sr_sensors_start(const sr_sensors_model *model, sr_sensors_state *state)
{
    int k, i;
    if (!model_ok(model) || state == NULL)
        return 1;
    memset(state, 0, sizeof *state);
    sr_rng_seed(&state->rng[0], model->seed);
    for (k = 1; k < SR_N_STREAMS; ++k) {    /* stream k: the seed's generator jumped k times */
        state->rng[k] = state->rng[k - 1];
        sr_rng_jump(&state->rng[k]);
    }
    /* constant per run: initial biases, thrust scale factor and misalignment */
    for (i = 0; i < 3; ++i)
        state->gyro_bias[i] = model->p[SR_NOISE_GYRO_BIAS] * sr_rng_normal(&state->rng[SR_STREAM_GYRO]);
    for (i = 0; i < 3; ++i)
        state->accel_bias[i] = model->p[SR_NOISE_ACCEL_BIAS] * sr_rng_normal(&state->rng[SR_STREAM_IMU]);
    thrust_error(model, &state->rng[SR_STREAM_THRUST], state->E_F);   /* F_meas = (1 + E_F) F */
    thrust_error(model, &state->rng[SR_STREAM_THRUST], state->E_M);
    draw(model, state, model->dt);
    return 0;
}

/* the measurement of the true sample x now, without delay, into y
 * (may alias x: written through a local copy) */
static void corrupt(const sr_sensors_model *m, const sr_sensors_state *s, const double *x,
                    double *y)
{
    const int n = m->n, len = SR_X_LEN(n);
    double out[SR_SENSORS_ROW];
    int i;
    if (m->scale == 0.0) {                  /* ideal: the true sample itself, bit for bit */
        memcpy(out, x, (size_t)len * sizeof(double));
    } else {
        const double res = m->p[SR_NOISE_ENC_RESOLUTION];
        double R[9];
        for (i = 0; i < 3; ++i) {
            out[SR_X_R_S + i] = x[SR_X_R_S + i] + s->d_r[i];
            out[SR_X_V_S + i] = x[SR_X_V_S + i] + s->d_v[i];
            out[SR_X_OMEGA_B + i] = x[SR_X_OMEGA_B + i] + s->gyro_bias[i] + s->d_omega[i];
            out[SR_X_A_S + i] = x[SR_X_A_S + i] + s->accel_bias[i] + s->d_a[i];
            out[SR_X_ALPHA_B + i] = x[SR_X_ALPHA_B + i] + s->d_alpha[i];
            out[SR_X_H(n) + i] = x[SR_X_H(n) + i] + s->H_err[i];
        }
        /* star tracker: a small rotation in the base frame, x_I = A exp([att]x) x_B */
        sr_rotation_vector_to_matrix(s->d_att, R);
        mat3_mul(x + SR_X_A_B, R, out + SR_X_A_B);
        for (i = 0; i < n; ++i) {
            const double q = x[SR_X_Q + i] + s->d_q[i];
            /* encoder quantisation: nearest step, ties to even (NumPy's round) */
            out[SR_X_Q + i] = res > 0.0 ? res * nearbyint(q / res) : q;
            out[SR_X_QD(n) + i] = x[SR_X_QD(n) + i] + s->d_qd[i];
            out[SR_X_QDD(n) + i] = x[SR_X_QDD(n) + i] + s->d_qdd[i];
        }
        {
            double eF[3], eM[3], eJ[3];
            mat3_vec(s->E_F, x + SR_X_F(n), eF);
            mat3_vec(s->E_M, x + SR_X_M(n), eM);
            /* J = int F dt, and E_F is constant: int (1 + E_F) F dt = J + E_F J */
            mat3_vec(s->E_F, x + SR_X_J(n), eJ);
            for (i = 0; i < 3; ++i) {
                out[SR_X_F(n) + i] = x[SR_X_F(n) + i] + eF[i];
                out[SR_X_M(n) + i] = x[SR_X_M(n) + i] + eM[i];
                out[SR_X_J(n) + i] = x[SR_X_J(n) + i] + eJ[i];
            }
        }
    }
    if (!m->imu)
        for (i = 0; i < 3; ++i) {
            out[SR_X_A_S + i] = 0.0;
            out[SR_X_ALPHA_B + i] = 0.0;
        }
    memcpy(y, out, (size_t)len * sizeof(double));
}

int sr_sensors_measure(const sr_sensors_model *model, const sr_sensors_state *state,
                       const double *x, double *y)
{
    if (!model_ok(model) || state == NULL || x == NULL || y == NULL)
        return 1;
    if (!state_ok(model, state))
        return 3;
    if (model->delay > 0 && state->count > 0)   /* the measurement of `delay` samples before */
        memcpy(y, state->line[state->head], (size_t)SR_X_LEN(model->n) * sizeof(double));
    else
        corrupt(model, state, x, y);
    return 0;
}

int sr_sensors_advance(const sr_sensors_model *model, sr_sensors_state *state, const double *x,
                       double dt)
{
    const double *p;
    double eF[3], eM[3], dH[3];
    int i, n;
    if (!model_ok(model) || state == NULL || x == NULL)
        return 1;
    if (!(isfinite(dt) && dt > 0.0))
        return 2;
    if (!state_ok(model, state))
        return 3;
    n = model->n;
    p = model->p;
    if (model->delay > 0) {                 /* the delay ring keeps the last `delay` */
        if (state->count < model->delay) {
            corrupt(model, state, x, state->line[(state->head + state->count) % model->delay]);
            state->count += 1;
        } else {
            corrupt(model, state, x, state->line[state->head]);
            state->head = (state->head + 1) % model->delay;
        }
    }
    if (model->scale == 0.0)
        return 0;
    /* H = int (M + r_S x F) dt: its error is int (E_M M + r_S x E_F F) dt (thrust held over
     * the step); a non-finite sample (passed on for the estimator to reject) adds nothing */
    mat3_vec(state->E_M, x + SR_X_M(n), eM);
    mat3_vec(state->E_F, x + SR_X_F(n), eF);
    {
        const double *r = x + SR_X_R_S;
        const double c[3] = {r[1] * eF[2] - r[2] * eF[1], r[2] * eF[0] - r[0] * eF[2],
                             r[0] * eF[1] - r[1] * eF[0]};
        int finite = 1;
        for (i = 0; i < 3; ++i) {
            dH[i] = dt * (eM[i] + c[i]);
            finite = finite && isfinite(dH[i]);
        }
        if (finite)
            for (i = 0; i < 3; ++i)
                state->H_err[i] = state->H_err[i] + dH[i];
    }
    /* bias random walks: b(t + dt) = b(t) + d sqrt(dt) N(0, 1), d the change over 1 s */
    for (i = 0; i < 3; ++i)
        state->gyro_bias[i] = state->gyro_bias[i]
                              + p[SR_NOISE_GYRO_RRW] * sqrt(dt) * sr_rng_normal(&state->rng[SR_STREAM_GYRO]);
    for (i = 0; i < 3; ++i)
        state->accel_bias[i] = state->accel_bias[i]
                               + p[SR_NOISE_ACCEL_BRW] * sqrt(dt) * sr_rng_normal(&state->rng[SR_STREAM_IMU]);
    draw(model, state, dt);
    return 0;
}

int sr_sensors_update(const sr_sensors_model *model, sr_sensors_state *state, const double *x,
                      double dt, double *y)
{
    double out[SR_SENSORS_ROW];
    int status;
    if (!model_ok(model) || state == NULL || x == NULL || y == NULL)
        return 1;
    if (!(isfinite(dt) && dt > 0.0))
        return 2;
    status = sr_sensors_measure(model, state, x, out);
    if (status == 0)
        status = sr_sensors_advance(model, state, x, dt);   /* x read before y is written */
    if (status == 0)
        memcpy(y, out, (size_t)SR_X_LEN(model->n) * sizeof(double));
    return status;
}
