/* estimator_stack.c -- the estimator core run in a thread with a small stack.
 *
 * Hosts that step FMUs on worker threads give each thread a small stack (musl: 128 KiB by
 * default; a pool may give less). This host runs every configuration of the estimator core
 * (below: both methods and solvers, measured and differenced accelerations, the derivative of
 * the momentum equations, the momentum window, the noise options, the thrust's consider term,
 * the accelerometer bias, the residual correlation, the noise profile with the information
 * filter and the excitation's rate choice) over recorded samples, each in a thread whose stack
 * is STACK_BYTES (64 KiB unless given), and after every sample reads everything a host reads
 * (the report, the estimates, the standard deviations without the lag, the message).
 *
 *   estimator_stack ROBOT_RECORD SAMPLES [STACK_BYTES]
 *
 * SAMPLES: int32 n_samples, int32 n_flat, then n_samples x (t, flat sample (n_flat)) doubles
 * (native byte order). Prints one line per configuration, "config NAME samples S rejected R
 * status T rate X score_1 A score_try B finite F", and "done" at the end; exit status 0, or 1 for bad
 * arguments or a configuration the core refused. A stack that is too small ends the process
 * with SIGSEGV before "done".
 */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "arm.h"
#include "estimator.h"
#include "sensor_noise.h"

typedef void (*configure_fn)(sr_estimator_options *o);

/* the sensors' realistic magnitudes (spacerobot.interface.NOISE_PARAMETERS' defaults) */
static void sensors(sr_estimator_options *o)
{
    o->noise_profile = 1;
    o->noise[SR_NOISE_GYRO_ARW] = 2.0e-5;
    o->noise[SR_NOISE_GYRO_BIAS] = 4.8e-6;
    o->noise[SR_NOISE_STAR_CROSS] = 9.7e-6;
    o->noise[SR_NOISE_STAR_ROLL] = 4.8e-5;
    o->noise[SR_NOISE_NAV_R] = 0.01;
    o->noise[SR_NOISE_NAV_V] = 1e-3;
    o->noise[SR_NOISE_ACCEL_VRW] = 5.0e-4;
    o->noise[SR_NOISE_ALPHA] = 2.0e-4;
    o->noise[SR_NOISE_ENC_RESOLUTION] = 1.1984e-5;
    o->noise[SR_NOISE_ENC_Q] = 5.0e-6;
    o->noise[SR_NOISE_ENC_QD] = 1e-4;
    o->noise[SR_NOISE_ENC_QDD] = 1e-3;
    o->noise[SR_NOISE_THRUST_SCALE] = 0.02;
    o->noise[SR_NOISE_THRUST_MISALIGN] = 8.7e-3;
    /* a short trial of the excitation's rate: it ends within the recorded samples */
    o->excite_window = 1.0;
    o->excite_settle = 0.5;
}

#define CONFIG(name, body) static void name(sr_estimator_options *o) { body; }
CONFIG(momentum, (void)o)
CONFIG(momentum_joint, o->solver = 2)
CONFIG(momentum_forget, o->lambda = 0.995; o->row_sd_lin = 0.1; o->row_sd_ang = 0.2;
       o->corr_lags = 5)
CONFIG(momentum_window, o->momentum_window = 2.0; o->momentum_point = 1; o->corr_lags = 3)
CONFIG(momentum_window_joint, o->solver = 2; o->momentum_window = 1.0;
       o->sd_thrust_scale = 0.01; o->sd_thrust_misalign = 0.005)
CONFIG(momentum_point_consider, o->momentum_point = 1; o->sd_thrust_scale = 0.02)
CONFIG(momentum_window_full, o->momentum_window = 1.0; o->momentum_window_samples = 5)
CONFIG(force, o->method = 2)
CONFIG(force_joint, o->method = 2; o->solver = 2; o->corr_lags = 4)
CONFIG(force_eiv_bias, o->method = 2; o->signal_sd[0] = 1e-3; o->signal_sd[1] = 1e-4;
       o->signal_sd[2] = 1e-4; o->accel_bias = 1; o->corr_lags = 2)
CONFIG(force_eiv_joint, o->method = 2; o->solver = 2; o->signal_sd[0] = 1e-3;
       o->signal_sd[1] = 1e-4; o->signal_sd[2] = 1e-4; o->sd_thrust_misalign = 0.01;
       o->accel_bias = 1)
CONFIG(force_consider, o->method = 2; o->sd_thrust_scale = 0.01; o->sd_thrust_misalign = 0.01;
       o->lambda = 0.999)
CONFIG(differenced, o->method = 2; o->accel_source = 2)
CONFIG(differenced_eiv, o->method = 2; o->accel_source = 2; o->diff_half_window = 5;
       o->signal_sd[3] = 1e-4; o->signal_sd[4] = 1e-5; o->signal_sd[5] = 1e-5)
CONFIG(differenced_joint, o->method = 2; o->accel_source = 2; o->solver = 2;
       o->diff_half_window = 2; o->corr_lags = 3)
CONFIG(differenced_long, o->method = 2; o->accel_source = 2; o->diff_half_window = 50)
CONFIG(diff_momentum, o->method = 2; o->accel_source = 2; o->diff_momentum = 1;
       o->diff_half_window = 4)
CONFIG(diff_momentum_eiv, o->method = 2; o->accel_source = 2; o->diff_momentum = 1;
       o->diff_half_window = 10; o->signal_sd[3] = 1e-4; o->signal_sd[4] = 1e-5;
       o->signal_sd[5] = 1e-5; o->sd_thrust_scale = 0.01; o->corr_lags = 2)
CONFIG(diff_momentum_joint_eiv, o->method = 2; o->accel_source = 2; o->solver = 2;
       o->diff_momentum = 1; o->diff_half_window = 10; o->signal_sd[3] = 1e-4;
       o->signal_sd[4] = 1e-5; o->signal_sd[5] = 1e-5; o->sd_thrust_misalign = 0.01)
CONFIG(profile_momentum, sensors(o))
CONFIG(profile_momentum_joint, sensors(o); o->solver = 2)
CONFIG(profile_force, sensors(o); o->method = 2)
CONFIG(profile_force_joint, sensors(o); o->method = 2; o->solver = 2)
CONFIG(profile_differenced, sensors(o); o->method = 2; o->accel_source = 2)
CONFIG(profile_differenced_joint, sensors(o); o->method = 2; o->accel_source = 2;
       o->solver = 2)
CONFIG(profile_always, sensors(o); o->excite_mode = 2)
CONFIG(profile_filter_off, sensors(o); o->information = 2)
#undef CONFIG

static const struct {
    const char *name;
    configure_fn configure;
} CONFIGS[] = {
#define C(x) {#x, x}
    C(momentum), C(momentum_joint), C(momentum_forget), C(momentum_window),
    C(momentum_window_joint), C(momentum_point_consider), C(momentum_window_full), C(force),
    C(force_joint), C(force_eiv_bias), C(force_eiv_joint), C(force_consider), C(differenced),
    C(differenced_eiv), C(differenced_joint), C(differenced_long), C(diff_momentum),
    C(diff_momentum_eiv), C(diff_momentum_joint_eiv), C(profile_momentum),
    C(profile_momentum_joint), C(profile_force), C(profile_force_joint),
    C(profile_differenced), C(profile_differenced_joint), C(profile_always),
    C(profile_filter_off),
#undef C
};

typedef struct {
    const sr_robot *robot;
    int n_samples, n_flat;
    const double *samples;          /* n_samples x (1 + n_flat) */
    configure_fn configure;
    /* out */
    int built, finite;
    sr_estimator_report report;
    char err[SR_EST_MSG_LEN];
} job;

static void *run(void *arg)
{
    job *j = (job *)arg;
    sr_estimator_options o;
    sr_estimator_options_default(&o);
    o.noise_dt = 0.1;
    j->configure(&o);
    sr_estimator_model *m = sr_estimator_model_new(j->robot, &o, j->err, sizeof j->err);
    if (!m)
        return NULL;
    void *data = malloc(sr_estimator_data_size(m)), *work = malloc(sr_estimator_work_size(m));
    if (!data || !work) {
        free(data);
        free(work);
        sr_estimator_model_free(m);
        return NULL;
    }
    sr_estimator_data_init(m, data);
    j->built = 1;
    j->finite = 1;
    for (int k = 0; k < j->n_samples; k++) {
        const double *s = j->samples + (size_t)k * (size_t)(1 + j->n_flat);
        double vec[20], sd[20], sd_lag[20];
        char msg[SR_EST_MSG_LEN];
        sr_estimator_update(m, data, work, s[0], s + 1, msg, sizeof msg);
        sr_estimator_report_get(m, data, &j->report);
        sr_estimator_estimates(m, data, vec, sd);
        sr_estimator_sd_without_lag(m, data, sd_lag);
        sr_estimator_message(m, data, msg, sizeof msg);
        for (int i = 0; i < 20; i++)
            if (!isfinite(j->report.vector[i]) || !isfinite(j->report.sd[i]))
                j->finite = 0;
    }
    free(work);
    free(data);
    sr_estimator_model_free(m);
    return NULL;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: %s ROBOT_RECORD SAMPLES [STACK_BYTES]\n", argv[0]);
        return 1;
    }
    size_t stack = argc > 3 ? (size_t)strtoul(argv[3], NULL, 10) : 64 * 1024;
    sr_robot robot;
    char err[256];
    if (sr_robot_read(argv[1], &robot, err, sizeof err) != 0) {
        fprintf(stderr, "robot record: %s\n", err);
        return 1;
    }
    FILE *f = fopen(argv[2], "rb");
    int head[2];
    if (!f || fread(head, sizeof(int), 2, f) != 2 || head[0] < 1 || head[1] < 1) {
        fprintf(stderr, "cannot read %s\n", argv[2]);
        return 1;
    }
    size_t count = (size_t)head[0] * (size_t)(1 + head[1]);
    double *samples = malloc(count * sizeof(double));
    if (!samples || fread(samples, sizeof(double), count, f) != count) {
        fprintf(stderr, "cannot read the samples of %s\n", argv[2]);
        return 1;
    }
    fclose(f);
    pthread_attr_t attr;
    pthread_attr_init(&attr);
    if (pthread_attr_setstacksize(&attr, stack) != 0) {
        fprintf(stderr, "pthread_attr_setstacksize(%lu) refused\n", (unsigned long)stack);
        return 1;
    }
    int status = 0;
    for (size_t c = 0; c < sizeof CONFIGS / sizeof CONFIGS[0]; c++) {
        job j;
        memset(&j, 0, sizeof j);
        j.robot = &robot;
        j.n_samples = head[0];
        j.n_flat = head[1];
        j.samples = samples;
        j.configure = CONFIGS[c].configure;
        pthread_t th;
        if (pthread_create(&th, &attr, run, &j) != 0 || pthread_join(th, NULL) != 0) {
            fprintf(stderr, "cannot run a thread\n");
            return 1;
        }
        if (!j.built) {
            printf("config %s refused: %s\n", CONFIGS[c].name, j.err);
            status = 1;
            continue;
        }
        printf("config %s samples %d rejected %d status %d rate %.17g score_1 %.17g score_try %.17g "
               "finite %d\n", CONFIGS[c].name, j.report.samples, j.report.rejected,
               j.report.status, j.report.excite_rate, j.report.excite_score[0],
               j.report.excite_score[1], j.finite);
        fflush(stdout);
    }
    printf("done\n");
    free(samples);
    return status;
}
