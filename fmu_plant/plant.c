/*
 * The plant FMU's glue: maps the FMI variables (resources/spacerobot_variables.txt, generated
 * from spacerobot/interface.py) to the plant core (native/src/plant.h) and back. The robot
 * comes from resources/robot.txt, its home posture from resources/scenario.txt; the truth
 * (base, target), controller, excitation, propellant and flexible parts are parameters, set
 * field by field from the core's tables (a field's key is its FMI name, ".<i>" for an element
 * of a vector; a struct of several records: ".<record>" and ".<record>.<i>"; the counts of
 * the flexible parts flex.n, slosh.n are Integer parameters).
 *
 * Outputs change only in doStep (no direct feedthrough): the inputs ident.excite (level) and
 * ident.excite_rate (rate) are what is asked for from the next step on.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "arm.h"
#include "model.h"
#include "plant.h"
#include "sr_text.h"

const char *const SR_MODEL_IDENTIFIER = "SpaceRobotPlant";
const int SR_MODEL_FEEDTHROUGH = 0;
/* the longest communication step [s] (1e5 internal steps at the default h) */
const double SR_MODEL_MAX_STEP = 100.0;

#define ROBOT_FILE "robot.txt"
#define SCENARIO_FILE "scenario.txt"

typedef struct {
    sr_robot robot;
    double q_home[SR_MAX_JOINTS];
    int n_out;                             /* outputs mapped */
    int out_vr[SR_PLANT_MAX_NY], out_at[SR_PLANT_MAX_NY];   /* value reference <- y[out_at] */
    int vr_excite, vr_rate;
    sr_plant_model *core;                  /* NULL before initialisation */
    sr_plant_data *data;
    double y[SR_PLANT_MAX_NY];
} plant_glue;

/* the table key of element e of output k: "A.i.j" for the matrix, "<name>.e" else */
static void output_key(char *out, size_t size, int k, int e) {
    if (k == SR_PLANT_Y_A_B) sr_text_format(out, size, "A.%d.%d", e / 3, e % 3);
    else sr_text_format(out, size, "%s.%d", sr_plant_output_name(k), e);
}

/* map every output variable to its place in the core's output vector (all must be found) */
static int bind_outputs(sr_instance *inst, plant_glue *g, const sr_plant_model *core) {
    int off[SR_PLANT_Y_COUNT + 1], outputs = 0;
    char key[SR_VAR_KEY_MAX];
    const sr_var *v;
    sr_plant_output_offsets(core, off);
    g->n_out = 0;
    for (int k = 0; k < SR_PLANT_Y_COUNT; ++k)
        for (int e = 0; e < off[k + 1] - off[k]; ++e) {
            int vr;
            output_key(key, sizeof key, k, e);
            if ((vr = sr_key_vr(inst, key, 0)) >= 0) {
                g->out_vr[g->n_out] = vr;
                g->out_at[g->n_out++] = off[k] + e;
            }
        }
    for (int vr = 0; (v = sr_variable(inst, vr)) != NULL; ++vr)
        outputs += v->causality == SR_OUTPUT;
    if (outputs != g->n_out) {
        sr_log(inst, SR_LOG_ERROR, "the variable table has %d outputs, the plant core computes %d "
               "of them (a table of another version?)", outputs, g->n_out);
        return 1;
    }
    return 0;
}

void *sr_model_new(sr_instance *inst, const char *resource_dir) {
    char path[4096 + sizeof ROBOT_FILE], err[512], key[32];
    plant_glue *g = calloc(1, sizeof *g);
    int bad = 0;
    if (!g) return NULL;
    sr_text_format(path, sizeof path, "%s%s", resource_dir, ROBOT_FILE);
    if (sr_robot_read(path, &g->robot, err, sizeof err) != 0) {
        sr_log(inst, SR_LOG_ERROR, "cannot read the robot record: %s", err);
        free(g);
        return NULL;
    }
    for (int i = 0; i < g->robot.n && !bad; ++i) {
        sr_text_format(key, sizeof key, "q_home.%d", i);
        bad = sr_resource_double(inst, resource_dir, SCENARIO_FILE, key, &g->q_home[i]);
    }
    if (bad || (g->vr_excite = sr_key_vr(inst, "excite", 1)) < 0
        || (g->vr_rate = sr_key_vr(inst, "excite_rate", 1)) < 0) {
        free(g);
        return NULL;
    }
    return g;
}

static void drop_core(plant_glue *g) {
    free(g->core);
    free(g->data);
    g->core = NULL;
    g->data = NULL;
}

/* the instance takes a new core (model and data), dropping the one it had */
static void adopt_core(plant_glue *g, sr_plant_model *core, sr_plant_data *data) {
    drop_core(g);
    g->core = core;
    g->data = data;
}

void sr_model_free(void *model) {
    if (!model) return;
    drop_core(model);
    free(model);
}

void sr_model_reset(void *model) { drop_core(model); }

/* ---- parameters -> core ------------------------------------------------------------------ */
static double real_of(sr_instance *inst, const char *key) { return sr_key_real(inst, key, 1); }

/* the body held in parameters <prefix>.m, .b.0-2, .I.0-5 (Ixx Iyy Izz Ixy Ixz Iyz) */
static void body_of(sr_instance *inst, const char *prefix, sr_body *b) {
    static const int AT[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
    char key[SR_VAR_KEY_MAX];
    sr_text_format(key, sizeof key, "%s.m", prefix);
    b->m = real_of(inst, key);
    for (int i = 0; i < 3; ++i) {
        sr_text_format(key, sizeof key, "%s.b.%d", prefix, i);
        b->com[i] = real_of(inst, key);
    }
    for (int k = 0; k < 6; ++k) {
        sr_text_format(key, sizeof key, "%s.I.%d", prefix, k);
        b->I[3 * AT[k][0] + AT[k][1]] = b->I[3 * AT[k][1] + AT[k][0]] = real_of(inst, key);
    }
}

/* the fields of parameter struct `table` (plant.h's tables) from their variables into s: the
 * struct, or record `rec` of a table of several (rec >= 0) */
static void record_of(sr_instance *inst, int table, int rec, void *s) {
    char key[SR_VAR_KEY_MAX];
    for (int i = 0; i < sr_plant_field_count(table); ++i) {
        const char *fmi = sr_plant_field_fmi_name(table, i);
        const int size = sr_plant_field_size(table, i);
        double *at = (double *)((char *)s + sr_plant_field_offset(table, i));
        for (int e = 0; e < size; ++e) {
            if (rec < 0 && size == 1) sr_text_set(key, sizeof key, fmi);
            else if (rec < 0) sr_text_format(key, sizeof key, "%s.%d", fmi, e);
            else if (size == 1) sr_text_format(key, sizeof key, "%s.%d", fmi, rec);
            else sr_text_format(key, sizeof key, "%s.%d.%d", fmi, rec, e);
            at[e] = real_of(inst, key);
        }
    }
}

static void fields_of(sr_instance *inst, int table, void *s) { record_of(inst, table, -1, s); }

/* the Integer parameter with key `key` (0 if there is none: logged as an error) */
static int integer_of(sr_instance *inst, const char *key) {
    const int vr = sr_key_vr(inst, key, 1);
    return vr >= 0 ? sr_integers(inst)[vr] : 0;
}

/* the flexible parts from their parameters into the model (sr_plant_model_set_leaves) */
static int leaves_of(sr_instance *inst, sr_plant_model *core, char *err, size_t size) {
    sr_plant_panel flex[SR_PLANT_MAX_FLEX];
    sr_plant_slosh slosh[SR_PLANT_MAX_SLOSH];
    for (int i = 0; i < SR_PLANT_MAX_FLEX; ++i) record_of(inst, SR_PLANT_TABLE_FLEX, i, &flex[i]);
    for (int i = 0; i < SR_PLANT_MAX_SLOSH; ++i)
        record_of(inst, SR_PLANT_TABLE_SLOSH, i, &slosh[i]);
    return sr_plant_model_set_leaves(core, integer_of(inst, "flex.n"), flex,
                                     integer_of(inst, "slosh.n"), slosh, err, size);
}

/* a new core (model and started data) from the parameters; 0 ok, else the reason in err */
static int build_core(sr_instance *inst, plant_glue *g, sr_plant_model **core,
                      sr_plant_data **data, char *err, size_t size) {
    sr_body base, target;
    sr_plant_controller ctrl;
    sr_plant_excitation ex;
    sr_plant_propellant prop;
    double v0[3], w0[3];
    char key[SR_VAR_KEY_MAX];
    body_of(inst, "base", &base);
    body_of(inst, "target", &target);
    fields_of(inst, SR_PLANT_TABLE_CONTROLLER, &ctrl);
    fields_of(inst, SR_PLANT_TABLE_EXCITATION, &ex);
    fields_of(inst, SR_PLANT_TABLE_PROPELLANT, &prop);
    for (int i = 0; i < 3; ++i) {
        sr_text_format(key, sizeof key, "v0.%d", i);
        v0[i] = real_of(inst, key);
        sr_text_format(key, sizeof key, "omega0.%d", i);
        w0[i] = real_of(inst, key);
    }
    *core = malloc(sizeof **core);
    *data = malloc(sizeof **data);
    if (!*core || !*data) {
        sr_text_set(err, size, "out of memory");
    } else if (sr_plant_model_init(*core, &g->robot, &base, &target, &ctrl, &ex, &prop, g->q_home,
                                   v0, w0, real_of(inst, "h"), err, size) == 0 &&
               leaves_of(inst, *core, err, size) == 0 && sr_plant_start(*core, *data) == 0) {
        return 0;
    }
    free(*core);
    free(*data);
    *core = NULL;
    *data = NULL;
    return 1;
}

/* outputs from the core; 0 ok, else the core's status */
static int write_outputs(sr_instance *inst, plant_glue *g, const sr_plant_model *core,
                         sr_plant_data *data) {
    double *x = sr_reals(inst);
    int status = sr_plant_outputs(core, data, g->y);   /* non-finite outputs: an error */
    if (status == 0)
        for (int i = 0; i < g->n_out; ++i) x[g->out_vr[i]] = g->y[g->out_at[i]];
    return status;
}

int sr_model_initialize(void *model, sr_instance *inst) {
    plant_glue *g = model;
    sr_plant_model *core;
    sr_plant_data *data;
    char err[512];
    int status;
    if (build_core(inst, g, &core, &data, err, sizeof err)) {
        sr_log(inst, SR_LOG_ERROR, "invalid plant parameters: %s", err);
        return 1;
    }
    status = bind_outputs(inst, g, core) ? -1 : write_outputs(inst, g, core, data);
    if (status != 0) {
        if (status > 0) sr_log(inst, SR_LOG_ERROR, "the initial state has no outputs: %s",
                               sr_plant_status_message(status));
        free(core);
        free(data);
        return 1;
    }
    adopt_core(g, core, data);
    return 0;
}

void sr_model_preview(void *model, sr_instance *inst) {
    plant_glue *g = model;
    sr_plant_model *core;
    sr_plant_data *data;
    char err[512];
    if (build_core(inst, g, &core, &data, err, sizeof err) == 0) {
        if (bind_outputs(inst, g, core) == 0) write_outputs(inst, g, core, data);
        free(core);
        free(data);
    }
}

void sr_model_outputs(void *model, sr_instance *inst) { (void)model; (void)inst; }

/* an excitation input (value reference vr, FMI name) within the core's range (clipped with a
 * warning), or NaN */
static double excite_input(sr_instance *inst, int vr, const char *name, double t) {
    double u = sr_reals(inst)[vr], lo = 0.0, hi = 0.0;
    sr_plant_param_range(name, &lo, &hi);
    if (isnan(u)) return u;
    if (!(u >= lo && u <= hi)) {
        double clipped = u < lo ? lo : hi;
        sr_log(inst, SR_LOG_WARNING, "%s = %.17g at t = %.6g s is outside [%g, %g]; using %g",
               name, u, t, lo, hi, clipped);
        return clipped;
    }
    return u;
}

int sr_model_do_step(void *model, sr_instance *inst, double t, double h) {
    plant_glue *g = model;
    double x0[SR_PLANT_MAX_NX], ex0[SR_PLANT_EXCITE_STATE], t0, level, rate;
    int status;
    sr_plant_get_state(g->core, g->data, &t0, x0, ex0);
    /* t is the instance's time: the layer refused any other communication point */
    level = excite_input(inst, g->vr_excite, "ident.excite", t);
    rate = excite_input(inst, g->vr_rate, "ident.excite_rate", t);
    if (isnan(level) || isnan(rate)) {
        sr_log(inst, SR_LOG_DISCARD, "%s is NaN at t = %.6g s: step discarded, state kept at "
               "t = %.6g s", isnan(level) ? "ident.excite" : "ident.excite_rate", t, t0);
        return 1;
    }
    sr_plant_set_excitation_rate(g->core, g->data, rate);
    sr_plant_set_excitation(g->core, g->data, level);
    status = sr_plant_advance(g->core, g->data, h);
    if (status == 0) status = write_outputs(inst, g, g->core, g->data);
    if (status != 0) {                     /* back to the state before the call, outputs too */
        sr_plant_set_state(g->core, g->data, t0, x0, ex0, NULL, 0);
        write_outputs(inst, g, g->core, g->data);
        sr_log(inst, SR_LOG_DISCARD, "step from t = %.6g s by %.6g s failed: %s; state kept at "
               "t = %.6g s", t, h, sr_plant_status_message(status), t0);
        return 1;
    }
    return 0;
}

/* ---- FMU state: t, x (nx), the excitation state (SR_PLANT_EXCITE_STATE) ----------------- */
static size_t state_doubles(const sr_plant_model *core) {
    int nx = 0;
    sr_plant_dims(core, NULL, NULL, &nx, NULL, NULL);
    return (size_t)(1 + nx + SR_PLANT_EXCITE_STATE);
}

size_t sr_model_state_size(void *model) {
    plant_glue *g = model;
    return g->core ? state_doubles(g->core) * sizeof(double) : 0;
}

void sr_model_state_save(void *model, void *buf) {
    plant_glue *g = model;
    double s[1 + SR_PLANT_MAX_NX + SR_PLANT_EXCITE_STATE];
    int nx = 0;
    if (!g->core) return;
    sr_plant_dims(g->core, NULL, NULL, &nx, NULL, NULL);
    sr_plant_get_state(g->core, g->data, &s[0], s + 1, s + 1 + nx);
    memcpy(buf, s, state_doubles(g->core) * sizeof(double));
}

int sr_model_state_load(void *model, sr_instance *inst, const void *buf, size_t size) {
    plant_glue *g = model;
    sr_plant_model *core;
    sr_plant_data *data;
    double s[1 + SR_PLANT_MAX_NX + SR_PLANT_EXCITE_STATE];
    char err[512];
    int nx = 0;
    /* the state's parameters are in place: rebuild the core from them, then take the state */
    if (build_core(inst, g, &core, &data, err, sizeof err)) {
        sr_log(inst, SR_LOG_ERROR,
               "restoring the FMU state: the state's parameters are not valid: %s", err);
        return 1;
    }
    sr_plant_dims(core, NULL, NULL, &nx, NULL, NULL);
    if (size != state_doubles(core) * sizeof(double)) {
        sr_log(inst, SR_LOG_ERROR,
               "restoring the FMU state: the state's plant block has %lu bytes, %lu "
               "expected (a state of another robot or build?)", (unsigned long)size,
               (unsigned long)(state_doubles(core) * sizeof(double)));
        free(core);
        free(data);
        return 1;
    }
    memcpy(s, buf, size);
    /* bytes a host hands back: the core checks them (finite, unit quaternion, m_p range) */
    err[0] = '\0';
    if (sr_plant_set_state(core, data, s[0], s + 1, s + 1 + nx, err, sizeof err) == 0) {
        if (bind_outputs(inst, g, core) != 0)          /* logged by bind_outputs */
            sr_text_set(err, sizeof err, "the state does not fit this FMU's variables");
        else if (write_outputs(inst, g, core, data) != 0)
            sr_text_set(err, sizeof err, "the state's outputs are not finite");
    }
    if (err[0]) {
        sr_log(inst, SR_LOG_ERROR,
               "restoring the FMU state: %s", err);
        free(core);
        free(data);
        return 1;
    }
    adopt_core(g, core, data);
    return 0;
}
