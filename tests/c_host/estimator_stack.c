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

/* a configuration: (option name, value) pairs (the core's options table; the estimator FMU's
 * parameter names), the list ending with a NULL name */
typedef struct {
    const char *name;
    double value;
} setting;

/* the noise profile with the sensors' realistic magnitudes (spacerobot.interface's
 * NOISE_PARAMETERS defaults), and a short trial of the excitation's rate: it ends within the
 * recorded samples */
#define SENSORS                                                                                 \
    {"ident.noise_profile", 1}, {"noise.gyro.arw", 2.0e-5}, {"noise.gyro.bias", 4.8e-6},        \
        {"noise.star.cross", 9.7e-6}, {"noise.star.roll", 4.8e-5}, {"noise.nav.r", 0.01},       \
        {"noise.nav.v", 1e-3}, {"noise.accel.vrw", 5.0e-4}, {"noise.alpha", 2.0e-4},            \
        {"noise.enc.resolution", 1.1984e-5}, {"noise.enc.q", 5.0e-6}, {"noise.enc.qd", 1e-4},   \
        {"noise.enc.qdd", 1e-3}, {"noise.thrust.scale", 0.02},                                  \
        {"noise.thrust.misalign", 8.7e-3}, {"ident.excite_window", 1.0},                        \
        {"ident.excite_settle", 0.5}
#define FORCE {"method", 2}
#define JOINT {"solver", 2}
#define DIFFERENCED {"method", 2}, {"accel_source", 2}
#define VELOCITY_NOISE {"ident.noise.base.v", 1e-4}, {"ident.noise.base.omega", 1e-5},           \
        {"ident.noise.arm.qd", 1e-5}
#define ACCEL_NOISE {"ident.noise.base.a", 1e-3}, {"ident.noise.base.alpha", 1e-4},              \
        {"ident.noise.arm.qdd", 1e-4}
/* the model-fit test never finding a misfit (the choice of the rate is then tried), or finding
 * the rigid model's at the replay (the profile's noise 100 times below the stream's, the
 * whiteness threshold at its least: the replay again with the thrust held and the model
 * error as the rows' noise) */
#define NO_FIT_TEST {"ident.fit_chi2_max", 1e6}, {"ident.fit_whiteness_max", 1e6},              \
        {"ident.fit_thrust_max", 1e6}
#define FIT_TEST_STRICT {"noise.scale", 0.01}, {"ident.fit_whiteness_max", 1.0}
#define END {NULL, 0}

static const struct {
    const char *name;
    setting settings[40];
} CONFIGS[] = {
    {"momentum", {END}},
    {"momentum_joint", {JOINT, END}},
    {"momentum_modes", {JOINT, {"ident.modes", 1}, END}},
    {"momentum_modes_given", {JOINT, {"ident.modes", 1}, {"ident.mode_f[1]", 0.5},
                              {"ident.momentum_point", 1}, END}},
    {"momentum_forget", {{"lambda", 0.995}, {"ident.sd_row.momentum_lin", 0.1},
                         {"ident.sd_row.momentum_ang", 0.2}, {"ident.corr_lags", 5}, END}},
    {"momentum_window", {{"ident.momentum_window", 2.0}, {"ident.momentum_point", 1},
                         {"ident.corr_lags", 3}, END}},
    {"momentum_window_joint", {JOINT, {"ident.momentum_window", 1.0},
                               {"ident.sd_thrust.scale", 0.01},
                               {"ident.sd_thrust.misalign", 0.005}, END}},
    {"momentum_point_consider", {{"ident.momentum_point", 1}, {"ident.sd_thrust.scale", 0.02},
                                 END}},
    {"momentum_window_full", {{"ident.momentum_window", 1.0}, {"momentum_window_samples", 5},
                              END}},
    {"force", {FORCE, END}},
    {"force_joint", {FORCE, JOINT, {"ident.corr_lags", 4}, END}},
    {"force_eiv_bias", {FORCE, ACCEL_NOISE, {"ident.accel_bias", 1}, {"ident.corr_lags", 2},
                        END}},
    {"force_eiv_joint", {FORCE, JOINT, ACCEL_NOISE, {"ident.sd_thrust.misalign", 0.01},
                         {"ident.accel_bias", 1}, END}},
    {"force_consider", {FORCE, {"ident.sd_thrust.scale", 0.01},
                        {"ident.sd_thrust.misalign", 0.01}, {"lambda", 0.999},
                        {"ident.sd_row.force_lin", 0.1}, {"ident.sd_row.force_ang", 0.1}, END}},
    {"differenced", {DIFFERENCED, END}},
    {"differenced_eiv", {DIFFERENCED, {"ident.diff_half_window", 5}, VELOCITY_NOISE, END}},
    {"differenced_joint", {DIFFERENCED, JOINT, {"ident.diff_half_window", 2},
                           {"ident.corr_lags", 3}, END}},
    {"differenced_long", {DIFFERENCED, {"ident.diff_half_window", 50}, END}},
    {"diff_momentum", {DIFFERENCED, {"ident.diff_momentum", 1}, {"ident.diff_half_window", 4},
                       END}},
    {"diff_momentum_eiv", {DIFFERENCED, {"ident.diff_momentum", 1},
                           {"ident.diff_half_window", 10}, VELOCITY_NOISE,
                           {"ident.sd_thrust.scale", 0.01}, {"ident.corr_lags", 2}, END}},
    {"diff_momentum_joint_eiv", {DIFFERENCED, JOINT, {"ident.diff_momentum", 1},
                                 {"ident.diff_half_window", 10}, VELOCITY_NOISE,
                                 {"ident.sd_thrust.misalign", 0.01}, END}},
    {"profile_momentum", {SENSORS, END}},
    {"profile_momentum_joint", {SENSORS, JOINT, END}},
    {"profile_force", {SENSORS, FORCE, END}},
    {"profile_force_joint", {SENSORS, FORCE, JOINT, END}},
    {"profile_differenced", {SENSORS, DIFFERENCED, END}},
    {"profile_differenced_joint", {SENSORS, DIFFERENCED, JOINT, END}},
    {"profile_always", {SENSORS, {"ident.excite_mode", 2}, NO_FIT_TEST, END}},
    {"profile_filter_off", {SENSORS, {"ident.information", 2}, END}},
    {"profile_misfit", {SENSORS, FIT_TEST_STRICT, END}},
    {"profile_misfit_joint", {SENSORS, FORCE, JOINT, FIT_TEST_STRICT, END}},
};

typedef struct {
    const sr_robot *robot;
    int n_samples, n_flat;
    const double *samples;          /* n_samples x (1 + n_flat) */
    const setting *settings;
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
    for (const setting *s = j->settings; s->name; s++)
        if (sr_estimator_options_set(&o, s->name, s->value, j->err, sizeof j->err) != 0)
            return NULL;
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
        j.settings = CONFIGS[c].settings;
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
               "misfit %d cause %d finite %d\n", CONFIGS[c].name, j.report.samples,
               j.report.rejected, j.report.status, j.report.excite_rate, j.report.excite_score[0],
               j.report.excite_score[1], j.report.misfit, j.report.misfit_cause, j.finite);
        fflush(stdout);
    }
    printf("done\n");
    free(samples);
    return status;
}
