/*
 * sensors.c -- the sensors FMU's glue: maps the FMI variables (resources/spacerobot_variables.txt,
 * generated from spacerobot/interface.py) to the sensor models (native/src/sensors.h) and back.
 *
 * Direct feedthrough (SR_MODEL_FEEDTHROUGH): the outputs at t are the measurement of the inputs
 * true.<name> set at t, computed when read; doStep(t, h) moves the noise processes on from the
 * sample at t. The FMU knows no robot: only its number of joints (from the variable table) and
 * the scenario's sample time (resources/scenario.txt: the first white-noise draws).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "model.h"
#include "sensors.h"
#include "sr_text.h"

const char *const SR_MODEL_IDENTIFIER = "SpaceRobotSensors";
const int SR_MODEL_FEEDTHROUGH = 1;
const double SR_MODEL_MAX_STEP = INFINITY;      /* the noise processes take any step */

#define SCENARIO_FILE "scenario.txt"

typedef struct {
    int n, len;                                   /* joints; sample length SR_X_LEN(n) */
    double dt;                                    /* the scenario's sample time [s] */
    int vr_in[SR_SENSORS_ROW], vr_out[SR_SENSORS_ROW];
    int vr_noise[SR_NOISE_COUNT], vr_scale, vr_seed, vr_delay, vr_imu;
    int ready;                                    /* model and state set (initialised) */
    sr_sensors_model core;
    sr_sensors_state state;
    double x[SR_SENSORS_ROW], y[SR_SENSORS_ROW];
} sensors_glue;

/* the number of joints: the inputs true.q.<i> the table has */
static int joints(sr_instance *inst) {
    char key[SR_VAR_KEY_MAX];
    int n = 0;
    for (;;) {
        sr_text_format(key, sizeof key, SR_SENSORS_TRUE_PREFIX "q.%d", n);
        if (sr_key_vr(inst, key, 0) < 0 || n == SR_MAX_JOINTS) return n;
        ++n;
    }
}

/* the sample's values in the order of sample.h, each by its key ("A.<row>.<column>" for the
   DCM, "<signal>.<index>" for the others): outputs by the key, inputs by true.<key> */
static int bind(sr_instance *inst, sensors_glue *g) {
    char key[SR_VAR_KEY_MAX], name[SR_VAR_KEY_MAX];
    int k = 0, bad = 0;
    for (int s = 0; s < SR_SIG_COUNT; ++s) {
        const char *signal = sr_sample_signal_key(s);
        for (int i = 0; i < sr_sample_signal_size(s, g->n); ++i, ++k) {
            if (s == SR_SIG_A_B) sr_text_format(name, sizeof name, "%s.%d.%d", signal, i / 3, i % 3);
            else sr_text_format(name, sizeof name, "%s.%d", signal, i);
            sr_text_format(key, sizeof key, SR_SENSORS_TRUE_PREFIX "%s", name);
            bad |= (g->vr_in[k] = sr_key_vr(inst, key, 1)) < 0;
            bad |= (g->vr_out[k] = sr_key_vr(inst, name, 1)) < 0;
        }
    }
    for (int i = 0; i < SR_NOISE_COUNT; ++i)
        bad |= (g->vr_noise[i] = sr_key_vr(inst, sr_sensors_parameter_name(i), 1)) < 0;
    bad |= (g->vr_scale = sr_key_vr(inst, "noise.scale", 1)) < 0;
    bad |= (g->vr_seed = sr_key_vr(inst, "seed", 1)) < 0;
    bad |= (g->vr_delay = sr_key_vr(inst, "noise.delay", 1)) < 0;
    bad |= (g->vr_imu = sr_key_vr(inst, "noise.imu", 1)) < 0;
    return bad;
}

void *sr_model_new(sr_instance *inst, const char *resource_dir) {
    sensors_glue *g = calloc(1, sizeof *g);
    if (!g) return NULL;
    g->n = joints(inst);
    g->len = SR_X_LEN(g->n);
    if (g->n < 1) {
        sr_log(inst, SR_LOG_ERROR, "the variable table has no joint inputs (true.q.0)");
    } else if (sr_resource_double(inst, resource_dir, SCENARIO_FILE, "sample_time", &g->dt) == 0
               && bind(inst, g) == 0) {
        return g;
    }
    free(g);
    return NULL;
}

void sr_model_free(void *model) { free(model); }

void sr_model_reset(void *model) { ((sensors_glue *)model)->ready = 0; }

/* the model from the parameters; 0 ok, else the reason in msg */
static int model_of(sr_instance *inst, const sensors_glue *g, sr_sensors_model *m, char *msg,
                    int size) {
    const double *x = sr_reals(inst);
    const int *z = sr_integers(inst);
    double noise[SR_NOISE_COUNT];
    for (int i = 0; i < SR_NOISE_COUNT; ++i) noise[i] = x[g->vr_noise[i]];
    return sr_sensors_init(m, g->n, noise, x[g->vr_scale], z[g->vr_seed], z[g->vr_delay],
                           z[g->vr_imu], g->dt, msg, size);
}

/* outputs: the measurement of the current inputs */
static void measure(sr_instance *inst, sensors_glue *g, const sr_sensors_model *m,
                    const sr_sensors_state *s) {
    double *x = sr_reals(inst);
    for (int k = 0; k < g->len; ++k) g->x[k] = x[g->vr_in[k]];
    if (sr_sensors_measure(m, s, g->x, g->y) == 0)
        for (int k = 0; k < g->len; ++k) x[g->vr_out[k]] = g->y[k];
}

int sr_model_initialize(void *model, sr_instance *inst) {
    sensors_glue *g = model;
    char msg[256];
    if (model_of(inst, g, &g->core, msg, sizeof msg) != 0) {
        sr_log(inst, SR_LOG_ERROR, "invalid sensor parameters: %s", msg);
        return 1;
    }
    sr_sensors_start(&g->core, &g->state);
    g->ready = 1;
    measure(inst, g, &g->core, &g->state);
    return 0;
}

void sr_model_preview(void *model, sr_instance *inst) {
    sensors_glue *g = model;
    sr_sensors_model m;
    char msg[256];
    if (model_of(inst, g, &m, msg, sizeof msg) == 0) {
        sr_sensors_state *s = malloc(sizeof *s);    /* large (the delay ring): not on the stack */
        if (s && sr_sensors_start(&m, s) == 0) measure(inst, g, &m, s);
        free(s);
    }
}

void sr_model_outputs(void *model, sr_instance *inst) {
    sensors_glue *g = model;
    if (g->ready) measure(inst, g, &g->core, &g->state);
}

int sr_model_do_step(void *model, sr_instance *inst, double t, double h) {
    sensors_glue *g = model;
    const double *x = sr_reals(inst);
    char where[512] = "";
    for (int k = 0; k < g->len; ++k) {
        g->x[k] = x[g->vr_in[k]];
        if (!(fabs(g->x[k]) <= SR_SAMPLE_LIMIT) && strlen(where) + SR_VAR_NAME_MAX + 4 < sizeof where) {
            sr_text_cat(where, sizeof where, where[0] ? ", " : "");
            sr_text_cat(where, sizeof where, sr_variable(inst, g->vr_in[k])->name);
        }
    }
    if (where[0])   /* the estimator skips such a sample; the sensors measure it as it is */
        sr_log(inst, SR_LOG_WARNING, "t = %.6g s: input(s) %s non-finite or beyond the physical "
               "range |x| <= %g (SI units?): measured as they are", t, where, SR_SAMPLE_LIMIT);
    if (sr_sensors_advance(&g->core, &g->state, g->x, h) != 0) {
        sr_log(inst, SR_LOG_DISCARD, "t = %.6g s: the sensors' state is inconsistent; step "
               "refused, state unchanged", t);
        return 1;
    }
    return 0;
}

size_t sr_model_state_size(void *model) {
    return ((sensors_glue *)model)->ready ? sizeof(sr_sensors_state) : 0;
}

void sr_model_state_save(void *model, void *buf) {
    sensors_glue *g = model;
    if (g->ready) memcpy(buf, &g->state, sizeof g->state);
}

int sr_model_state_load(void *model, sr_instance *inst, const void *buf, size_t size) {
    sensors_glue *g = model;
    sr_sensors_model m;
    sr_sensors_state *s;
    char msg[256];
    double probe[SR_SENSORS_ROW] = {0.0};
    /* the state's parameters are in place: rebuild the model from them, then take the block */
    if (model_of(inst, g, &m, msg, sizeof msg) != 0) {
        sr_log(inst, SR_LOG_ERROR,
               "restoring the FMU state: the state's parameters are not valid: %s", msg);
        return 1;
    }
    if (size != sizeof(sr_sensors_state)) {
        sr_log(inst, SR_LOG_ERROR,
               "restoring the FMU state: the state's sensors block has %lu bytes, %lu "
               "expected (a state of another build?)", (unsigned long)size,
               (unsigned long)sizeof(sr_sensors_state));
        return 1;
    }
    if ((s = malloc(sizeof *s)) == NULL) {
        sr_log(inst, SR_LOG_ERROR,
               "restoring the FMU state: out of memory");
        return 1;
    }
    memcpy(s, buf, size);
    /* bytes a host hands back: the delay ring's indices checked before any is used */
    if (sr_sensors_measure(&m, s, probe, probe) != 0) {
        sr_log(inst, SR_LOG_ERROR,
               "restoring the FMU state: the sensors' state is inconsistent "
               "(delay ring indices out of range)");
        free(s);
        return 1;
    }
    g->core = m;
    g->state = *s;
    g->ready = 1;
    free(s);
    return 0;
}
