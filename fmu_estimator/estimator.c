/*
 * estimator.c -- the estimator FMU's glue: maps the FMI variables (resources/spacerobot_variables.txt,
 * generated from spacerobot/interface.py) to the estimator core (native/src/estimator.h) and back.
 * The robot's known arm comes from resources/robot.txt (native/src/arm.h), so one binary serves
 * every robot. The FMU carries no truth: only the arm and the guesses.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "arm.h"
#include "equations.h"
#include "estimator.h"
#include "model.h"

const char *const SR_MODEL_IDENTIFIER = "SpaceRobotEstimator";

#define ROBOT_FILE "robot.txt"
#define SCENARIO_FILE "scenario.txt"
#define INPUT_LIMIT 1e15
#define MAX_SAMPLE (24 + 3 * SR_MAX_JOINTS + 12)

/* the signals of a sample in the core's order, with their element counts (n: joints) */
static const struct { const char *key; int size; } SIGNALS[] = {
    {"r_S", 3}, {"v_S", 3}, {"A", 9}, {"omega_B", 3}, {"a_S", 3}, {"alpha_B", 3},
    {"q", -1}, {"qd", -1}, {"qdd", -1}, {"F", 3}, {"M", 3}, {"J", 3}, {"H", 3}};

static const char *const STATUS_TEXT[] = {
    "no sample yet", "reference sample stored", "estimating",
    "last sample rejected: non-finite or out-of-range input, or an update that overflowed",
    "last sample rejected: inconsistent input"};

typedef struct {
    sr_robot robot;
    int n_sample;
    int vr_in[MAX_SAMPLE];                 /* input value reference of each sample element */
    int vr_est[2][10], vr_sd[2][10];       /* outputs: estimates and sd per body */
    int vr_samples, vr_rejected, vr_status, vr_res_lin, vr_res_ang, vr_exc_mu, vr_exc_theta;
    int vr_excite, vr_identified[2], vr_physical[2];
    int vr_crb[2][10], vr_chi2;            /* the information filter's bound and misfit */
    int vr_rate, vr_score[2];              /* the excitation's rate and the choice's scores */
    double sample_time;                    /* the scenario's [s]: the sensors' noise densities
                                              per sample (ident.noise_profile) */
    sr_estimator_model *core;              /* NULL before initialisation */
    void *data;                            /* the core's state (sr_estimator_data_size bytes) */
    void *work;                            /* its work space (sr_estimator_work_size bytes) */
    double sample[MAX_SAMPLE];
} estimator_glue;

static const char *const BODY_KEY[2] = {"base", "target"};

/* key of entry i (0..9: m, b 0..2, I 0..5) of a body's 10 parameters under prefix */
static void body_key(char *out, size_t size, const char *prefix, int i) {
    if (i == 0) snprintf(out, size, "%s.m", prefix);
    else if (i < 4) snprintf(out, size, "%s.b.%d", prefix, i - 1);
    else snprintf(out, size, "%s.I.%d", prefix, i - 4);
}

static int bind(sr_instance *inst, estimator_glue *g) {
    char key[SR_VAR_KEY_MAX];
    int k = 0, bad = 0;
    for (size_t s = 0; s < sizeof SIGNALS / sizeof SIGNALS[0]; ++s) {
        int size = SIGNALS[s].size < 0 ? g->robot.n : SIGNALS[s].size;
        for (int i = 0; i < size; ++i) {
            if (SIGNALS[s].size == 9) snprintf(key, sizeof key, "A.%d.%d", i / 3, i % 3);
            else snprintf(key, sizeof key, "%s.%d", SIGNALS[s].key, i);
            bad |= (g->vr_in[k++] = sr_key_vr(inst, key, 1)) < 0;
        }
    }
    g->n_sample = k;
    for (int b = 0; b < 2; ++b)
        for (int i = 0; i < 10; ++i) {
            char prefix[32];
            snprintf(prefix, sizeof prefix, "est_%s", BODY_KEY[b]);
            body_key(key, sizeof key, prefix, i);
            bad |= (g->vr_est[b][i] = sr_key_vr(inst, key, 1)) < 0;
            snprintf(prefix, sizeof prefix, "sd_%s", BODY_KEY[b]);
            body_key(key, sizeof key, prefix, i);
            bad |= (g->vr_sd[b][i] = sr_key_vr(inst, key, 1)) < 0;
            snprintf(prefix, sizeof prefix, "crb_%s", BODY_KEY[b]);
            body_key(key, sizeof key, prefix, i);
            bad |= (g->vr_crb[b][i] = sr_key_vr(inst, key, 1)) < 0;
        }
    bad |= (g->vr_chi2 = sr_key_vr(inst, "info_chi2", 1)) < 0;
    bad |= (g->vr_samples = sr_key_vr(inst, "samples", 1)) < 0;
    bad |= (g->vr_rejected = sr_key_vr(inst, "rejected", 1)) < 0;
    bad |= (g->vr_status = sr_key_vr(inst, "status", 1)) < 0;
    bad |= (g->vr_res_lin = sr_key_vr(inst, "residual_lin", 1)) < 0;
    bad |= (g->vr_res_ang = sr_key_vr(inst, "residual_ang", 1)) < 0;
    bad |= (g->vr_exc_mu = sr_key_vr(inst, "excitation_mu", 1)) < 0;
    bad |= (g->vr_exc_theta = sr_key_vr(inst, "excitation_theta", 1)) < 0;
    bad |= (g->vr_excite = sr_key_vr(inst, "excite", 1)) < 0;
    bad |= (g->vr_rate = sr_key_vr(inst, "excite_rate", 1)) < 0;
    bad |= (g->vr_score[0] = sr_key_vr(inst, "excite_score.rate_1", 1)) < 0;
    bad |= (g->vr_score[1] = sr_key_vr(inst, "excite_score.rate_try", 1)) < 0;
    for (int b = 0; b < 2; ++b) {
        snprintf(key, sizeof key, "identified.%s", BODY_KEY[b]);
        bad |= (g->vr_identified[b] = sr_key_vr(inst, key, 1)) < 0;
        snprintf(key, sizeof key, "physical.%s", BODY_KEY[b]);
        bad |= (g->vr_physical[b] = sr_key_vr(inst, key, 1)) < 0;
    }
    return bad;
}

void *sr_model_new(sr_instance *inst, const char *resource_dir) {
    char path[4096 + sizeof ROBOT_FILE], err[512];
    estimator_glue *g = calloc(1, sizeof *g);
    if (!g) return NULL;
    snprintf(path, sizeof path, "%s%s", resource_dir, ROBOT_FILE);
    if (sr_robot_read(path, &g->robot, err, sizeof err) != 0) {
        sr_log(inst, SR_LOG_ERROR, "cannot read the robot record: %s", err);
        free(g);
        return NULL;
    }
    if (bind(inst, g) || sr_resource_double(inst, resource_dir, SCENARIO_FILE, "sample_time",
                                            &g->sample_time)) {
        free(g);
        return NULL;
    }
    return g;
}

static void drop_core(estimator_glue *g) {
    if (g->core) sr_estimator_model_free(g->core);
    free(g->data);
    free(g->work);
    g->core = NULL;
    g->data = NULL;
    g->work = NULL;
}

/* the instance takes a new core (model, data and its work space), dropping the one it had */
static void adopt_core(estimator_glue *g, sr_estimator_model *core, void *data, void *work) {
    drop_core(g);
    g->core = core;
    g->data = data;
    g->work = work;
}

void sr_model_free(void *model) {
    if (!model) return;
    drop_core(model);
    free(model);
}

void sr_model_reset(void *model) { drop_core(model); }

/* ---- parameters -> options ---------------------------------------------------------------- */
static double real_of(sr_instance *inst, const char *key) { return sr_key_real(inst, key, 0); }

static int int_of(sr_instance *inst, const char *key) {
    int vr = sr_key_vr(inst, key, 0);
    return vr < 0 ? -1 : sr_integers(inst)[vr];
}

/* options from the parameter values (the core checks them: sr_estimator_model_new) */
static void options_of(sr_instance *inst, double sample_time, sr_estimator_options *o) {
    static const char *const SIGNAL_SD[6] = {"signal_sd.a_S", "signal_sd.alpha_B", "signal_sd.qdd",
                                             "signal_sd.v_S", "signal_sd.omega_B", "signal_sd.qd"};
    char key[SR_VAR_KEY_MAX];
    sr_estimator_options_default(o);
    o->method = int_of(inst, "method");
    o->solver = int_of(inst, "solver");
    o->accel_source = int_of(inst, "accel_source");
    o->lambda = real_of(inst, "lambda");
    o->P0_mu = real_of(inst, "P0_mu");
    o->P0_theta = real_of(inst, "P0_theta");
    for (int i = 0; i < 10; ++i) {
        body_key(key, sizeof key, "guess_base", i);
        o->guess_base[i] = real_of(inst, key);
        body_key(key, sizeof key, "guess_target", i);
        o->guess_target[i] = real_of(inst, key);
    }
    o->sd_rel = real_of(inst, "sd_rel");
    o->excite_mode = int_of(inst, "excite_mode");
    o->excite_level = real_of(inst, "excite_level");
    /* the row weights of the chosen method's equations */
    o->row_sd_lin = real_of(inst, o->method == 2 ? "sd_row.force_lin" : "sd_row.momentum_lin");
    o->row_sd_ang = real_of(inst, o->method == 2 ? "sd_row.force_ang" : "sd_row.momentum_ang");
    o->diff_half_window = int_of(inst, "diff_half_window");
    o->diff_momentum = int_of(inst, "diff_momentum");
    o->corr_lags = int_of(inst, "corr_lags");
    for (int i = 0; i < 6; ++i) o->signal_sd[i] = real_of(inst, SIGNAL_SD[i]);
    o->momentum_window = real_of(inst, "window.momentum");
    o->momentum_point = int_of(inst, "momentum_point");
    o->sd_thrust_scale = real_of(inst, "sd_thrust.scale");
    o->sd_thrust_misalign = real_of(inst, "sd_thrust.misalign");
    o->accel_bias = int_of(inst, "accel_bias");
    o->noise_profile = int_of(inst, "noise_profile");
    o->noise_scale = real_of(inst, "noise.scale");
    for (int i = 0; i < SR_NOISE_COUNT; ++i) {  /* the magnitudes the FMU has (the rest 0) */
        const char *name = sr_noise_name(i);
        o->noise[i] = sr_key_vr(inst, name, 0) < 0 ? 0.0 : real_of(inst, name);
    }
    o->noise_dt = sample_time;
    o->information = int_of(inst, "information");
    o->excite_adapt = int_of(inst, "excite_adapt");
    o->excite_rate_try = real_of(inst, "excite_rate_try");
    o->excite_window = real_of(inst, "excite_window");
    o->excite_settle = real_of(inst, "excite_settle");
    o->excite_horizon = real_of(inst, "excite_horizon");
}

/* build a core for the current parameters; 0 ok (err untouched), else err says why */
static int build_core(sr_instance *inst, estimator_glue *g, sr_estimator_model **core, void **data,
                      char *err, size_t errlen) {
    sr_estimator_options o;
    options_of(inst, g->sample_time, &o);
    *core = sr_estimator_model_new(&g->robot, &o, err, errlen);
    if (!*core) return 1;
    *data = malloc(sr_estimator_data_size(*core));
    if (!*data) {
        sr_estimator_model_free(*core);
        *core = NULL;
        snprintf(err, errlen, "out of memory");
        return 1;
    }
    sr_estimator_data_init(*core, *data);
    return 0;
}

static void write_outputs(sr_instance *inst, const estimator_glue *g, const sr_estimator_model *core,
                          const void *data) {
    sr_estimator_report r;
    double *x = sr_reals(inst);
    int *z = sr_integers(inst);
    if (!core || !data) return;              /* no core: the report would stay unset */
    sr_estimator_report_get(core, data, &r);
    for (int b = 0; b < 2; ++b) {
        for (int i = 0; i < 10; ++i) {
            x[g->vr_est[b][i]] = r.vector[10 * b + i];
            x[g->vr_sd[b][i]] = r.sd[10 * b + i];
            x[g->vr_crb[b][i]] = r.crb[10 * b + i];
        }
        z[g->vr_identified[b]] = r.identified[b];
        z[g->vr_physical[b]] = r.physical[b];
    }
    z[g->vr_samples] = r.samples;
    z[g->vr_rejected] = r.rejected;
    z[g->vr_status] = r.status;
    x[g->vr_res_lin] = r.residual_lin;
    x[g->vr_res_ang] = r.residual_ang;
    x[g->vr_exc_mu] = r.excitation_mu;
    x[g->vr_exc_theta] = r.excitation_theta;
    x[g->vr_excite] = r.excite;
    x[g->vr_chi2] = r.info_chi2;
    x[g->vr_rate] = r.excite_rate;
    x[g->vr_score[0]] = r.excite_score[0];
    x[g->vr_score[1]] = r.excite_score[1];
}

int sr_model_initialize(void *model, sr_instance *inst) {
    estimator_glue *g = model;
    sr_estimator_model *core;
    void *data;
    char err[512];
    if (build_core(inst, g, &core, &data, err, sizeof err)) {
        sr_log(inst, SR_LOG_ERROR, "invalid estimator parameters: %s", err);
        return 1;
    }
    void *work = malloc(sr_estimator_work_size(core));
    if (!work) {
        sr_log(inst, SR_LOG_ERROR, "out of memory");
        sr_estimator_model_free(core);
        free(data);
        return 1;
    }
    adopt_core(g, core, data, work);
    write_outputs(inst, g, core, data);
    return 0;
}

void sr_model_preview(void *model, sr_instance *inst) {
    estimator_glue *g = model;
    sr_estimator_model *core;
    void *data;
    char err[512];
    if (build_core(inst, g, &core, &data, err, sizeof err) == 0) {
        write_outputs(inst, g, core, data);
        sr_estimator_model_free(core);
        free(data);
    }
}

int sr_model_do_step(void *model, sr_instance *inst, double t, double h) {
    estimator_glue *g = model;
    const double *x = sr_reals(inst);
    char msg[512] = "";
    int status;
    (void)h;                                 /* one sample per communication point */
    for (int k = 0; k < g->n_sample; ++k) g->sample[k] = x[g->vr_in[k]];
    status = sr_estimator_update(g->core, g->data, g->work, t, g->sample, msg, sizeof msg);
    write_outputs(inst, g, g->core, g->data);
    if (status == 3 || status == 4) {        /* skipped: name the inputs at fault */
        char where[512] = "";
        size_t used = 0;
        for (int k = 0; k < g->n_sample && used + SR_VAR_NAME_MAX + 4 < sizeof where; ++k)
            if (!(fabs(g->sample[k]) <= INPUT_LIMIT)) {
                used += (size_t)snprintf(where + used, sizeof where - used, "%s%s",
                                         used ? ", " : " [input ", sr_variable(inst, g->vr_in[k])->name);
            }
        if (used) snprintf(where + used, sizeof where - used, "]");
        sr_log(inst, SR_LOG_WARNING, "t = %.6g s: sample skipped (%s)%s: %s; estimates unchanged", t,
               STATUS_TEXT[status], where, msg);
    }
    return 0;
}

size_t sr_model_state_size(void *model) {
    estimator_glue *g = model;
    return g->core ? sr_estimator_data_size(g->core) : 0;
}

void sr_model_state_save(void *model, void *buf) {
    estimator_glue *g = model;
    if (g->core) memcpy(buf, g->data, sr_estimator_data_size(g->core));
}

int sr_model_state_load(void *model, sr_instance *inst, const void *buf, size_t size) {
    estimator_glue *g = model;
    sr_estimator_model *core;
    void *data;
    char err[512];
    /* the state's parameters are in place: rebuild the core from them, then take its block */
    if (build_core(inst, g, &core, &data, err, sizeof err)) {
        sr_log(inst, SR_LOG_ERROR,
               "restoring the FMU state: the state's parameters are not valid: %s", err);
        return 1;
    }
    if (size != sr_estimator_data_size(core)) {
        sr_log(inst, SR_LOG_ERROR,
               "restoring the FMU state: the state's estimator block has %lu bytes, "
               "%lu expected (a state of another robot or build?)", (unsigned long)size,
               (unsigned long)sr_estimator_data_size(core));   /* msvcrt knows no %zu */
        sr_estimator_model_free(core);
        free(data);
        return 1;
    }
    memcpy(data, buf, size);
    /* bytes a host hands back: every count and index checked before any is used */
    if (sr_estimator_data_check(core, data, err, sizeof err) != 0) {
        sr_log(inst, SR_LOG_ERROR,
               "restoring the FMU state: %s", err);
        sr_estimator_model_free(core);
        free(data);
        return 1;
    }
    void *work = malloc(sr_estimator_work_size(core));
    if (!work) {
        sr_log(inst, SR_LOG_ERROR, "restoring the FMU state: out of memory");
        sr_estimator_model_free(core);
        free(data);
        return 1;
    }
    adopt_core(g, core, data, work);
    return 0;
}

/* outputs change only in doStep (no direct feedthrough) */
const int SR_MODEL_FEEDTHROUGH = 0;
const double SR_MODEL_MAX_STEP = INFINITY;      /* one sample per step, of any length */
void sr_model_outputs(void *model, sr_instance *inst) { (void)model; (void)inst; }
