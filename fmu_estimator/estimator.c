/*
 * estimator.c -- the estimator FMU's glue: maps the FMI variables (resources/spacerobot_variables.txt,
 * generated from spacerobot/interface.py) to the estimator core (native/src/estimator.h) and back,
 * through the core's tables: the sample's signals (sample.h), the options by their parameters'
 * names and the outputs by theirs (estimator.h). The robot's known arm comes from
 * resources/robot.txt (native/src/arm.h), so one binary serves every robot. The FMU carries no
 * truth: only the arm and the guesses.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "arm.h"
#include "estimator.h"
#include "model.h"
#include "sample.h"
#include "sr_text.h"

const char *const SR_MODEL_IDENTIFIER = "SpaceRobotEstimator";

#define ROBOT_FILE "robot.txt"
#define SCENARIO_FILE "scenario.txt"
#define MAX_SAMPLE SR_X_LEN(SR_MAX_JOINTS)
#define MAX_OUTPUTS 96

typedef struct {
    sr_robot robot;
    int n_sample;
    int vr_in[MAX_SAMPLE];                 /* input value reference of each sample element */
    int n_out, vr_out[MAX_OUTPUTS];        /* the core's outputs (its table's order) */
    int misfit_cause;                      /* the last report's (SR_EST_MISFIT_*; 0: the
                                              model fits): each change logged */
    double sample_time;                    /* the scenario's [s]: the sensors' noise densities
                                              per sample (ident.noise_profile) */
    sr_estimator_model *core;              /* NULL before initialisation */
    void *data;                            /* the core's state (sr_estimator_data_size bytes) */
    void *work;                            /* its work space (sr_estimator_work_size bytes) */
    double sample[MAX_SAMPLE];
    double outputs[MAX_OUTPUTS];
} estimator_glue;

/* value reference of the variable called name, or -1 (logged as an error) */
static int vr_of_name(sr_instance *inst, const char *name) {
    for (int vr = 0; sr_variable(inst, vr); ++vr)
        if (strcmp(sr_variable(inst, vr)->name, name) == 0) return vr;
    sr_log(inst, SR_LOG_ERROR, "the variable table has no variable %s", name);
    return -1;
}

/* the sample's inputs (sample.h's signals; keys "r_S.0", "A.0.1", "q.2"), the outputs */
static int bind(sr_instance *inst, estimator_glue *g) {
    char key[SR_VAR_KEY_MAX];
    int k = 0, bad = 0;
    for (int s = 0; s < sr_sample_signal_count(); ++s) {
        int size = sr_sample_signal_size(s, g->robot.n);
        for (int i = 0; i < size; ++i) {
            if (s == SR_SIG_A_B)
                sr_text_format(key, sizeof key, "%s.%d.%d", sr_sample_signal_key(s), i / 3, i % 3);
            else
                sr_text_format(key, sizeof key, "%s.%d", sr_sample_signal_key(s), i);
            bad |= (g->vr_in[k++] = sr_key_vr(inst, key, 1)) < 0;
        }
    }
    g->n_sample = k;
    g->n_out = sr_estimator_output_count();
    if (g->n_out > MAX_OUTPUTS) {            /* tests/test_estimator_tables.py guards it */
        sr_log(inst, SR_LOG_ERROR, "the core has %d outputs, this FMU's glue room for %d "
               "(MAX_OUTPUTS in fmu_estimator/estimator.c)", g->n_out, MAX_OUTPUTS);
        return 1;
    }
    for (int i = 0; i < g->n_out; ++i)
        bad |= (g->vr_out[i] = vr_of_name(inst, sr_estimator_output_name(i))) < 0;
    return bad;
}

void *sr_model_new(sr_instance *inst, const char *resource_dir) {
    char path[4096 + sizeof ROBOT_FILE], err[512];
    estimator_glue *g = calloc(1, sizeof *g);
    if (!g) return NULL;
    sr_text_format(path, sizeof path, "%s%s", resource_dir, ROBOT_FILE);
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

void sr_model_free(void *model) {
    if (!model) return;
    drop_core(model);
    free(model);
}

void sr_model_reset(void *model) { drop_core(model); }

/* ---- parameters -> options ---------------------------------------------------------------- */

/* the options from the parameter values, by the core's table (the core checks their values:
 * sr_estimator_model_new); 0, or 1 with the reason in err */
static int options_of(sr_instance *inst, double sample_time, sr_estimator_options *o, char *err,
                      size_t errlen) {
    sr_estimator_options_default(o);
    for (int i = 0; i < sr_estimator_option_count(); ++i) {
        if (!sr_estimator_option_parameter(i)) continue;
        const char *name = sr_estimator_option_name(i);
        int vr = vr_of_name(inst, name);
        if (vr < 0) {
            sr_text_format(err, errlen, "no parameter %s", name);
            return 1;
        }
        const sr_var *v = sr_variable(inst, vr);
        double value = v->type == SR_INTEGER ? (double)sr_integers(inst)[vr] : sr_reals(inst)[vr];
        if (sr_estimator_options_set(o, name, value, err, errlen) != 0) return 1;
    }
    return sr_estimator_options_set(o, "noise_dt", sample_time, err, errlen) != 0;
}

/* build a core for the current parameters (its Model, Data block and, where work is given, its
   work space); 0 ok (err untouched), else err says why */
static int build_core(sr_instance *inst, estimator_glue *g, sr_estimator_model **core, void **data,
                      void **work, char *err, size_t errlen) {
    sr_estimator_options o;
    if (options_of(inst, g->sample_time, &o, err, errlen)) return 1;
    *core = sr_estimator_model_new(&g->robot, &o, err, errlen);
    if (!*core) return 1;
    *data = malloc(sr_estimator_data_size(*core));
    if (work) *work = malloc(sr_estimator_work_size(*core));
    if (!*data || (work && !*work)) {
        sr_estimator_model_free(*core);
        free(*data);
        if (work) free(*work);
        *core = NULL;
        sr_text_set(err, errlen, "out of memory");
        return 1;
    }
    sr_estimator_data_init(*core, *data);
    return 0;
}

/* the core's report into the output variables (and into *out where given) */
static void write_outputs(sr_instance *inst, estimator_glue *g, const sr_estimator_model *core,
                          const void *data, sr_estimator_report *out) {
    sr_estimator_report r;
    if (!core || !data) return;              /* no core: the report would stay unset */
    sr_estimator_report_get(core, data, &r);
    if (out) *out = r;
    sr_estimator_outputs(&r, g->outputs);
    for (int i = 0; i < g->n_out; ++i) {
        if (sr_variable(inst, g->vr_out[i])->type == SR_INTEGER)
            sr_integers(inst)[g->vr_out[i]] = (int)g->outputs[i];
        else
            sr_reals(inst)[g->vr_out[i]] = g->outputs[i];
    }
}

/* the instance takes a new core (model, data and its work space), dropping the one it had */
static void adopt_core(estimator_glue *g, sr_estimator_model *core, void *data, void *work) {
    drop_core(g);
    g->core = core;
    g->data = data;
    g->work = work;
}

int sr_model_initialize(void *model, sr_instance *inst) {
    estimator_glue *g = model;
    sr_estimator_model *core;
    void *data, *work;
    char err[512];
    if (build_core(inst, g, &core, &data, &work, err, sizeof err)) {
        sr_log(inst, SR_LOG_ERROR, "invalid estimator parameters: %s", err);
        return 1;
    }
    sr_estimator_report r = {0};
    adopt_core(g, core, data, work);
    write_outputs(inst, g, core, data, &r);
    g->misfit_cause = r.misfit_cause;
    return 0;
}

void sr_model_preview(void *model, sr_instance *inst) {
    estimator_glue *g = model;
    sr_estimator_model *core;
    void *data;
    char err[512];
    if (build_core(inst, g, &core, &data, NULL, err, sizeof err) == 0) {
        write_outputs(inst, g, core, data, NULL);
        sr_estimator_model_free(core);
        free(data);
    }
}

/* diag.misfit's onsets and its cause's changes, told once each: a host that does not read it
 * still learns that the model does not fit, and why (docs/identification.md, "When the rigid
 * model does not fit") */
static void log_misfit(sr_instance *inst, double t, int before, const sr_estimator_report *r) {
    int now = r->misfit_cause;
    const char *set = before ? "diag.misfit stays 1, its cause changed" : "diag.misfit = 1";
    if (now == before) return;
    if (now == SR_EST_MISFIT_THRUST)
        sr_log(inst, SR_LOG_WARNING,
               "t = %.6g s: a thrust scale factor is estimated beyond its prior with white "
               "residuals (%s): the thrust is miscalibrated, or the scale absorbs momentum the "
               "rigid model lacks (sloshing propellant); no body is flagged identified, the "
               "estimates are kept and their sds cover the estimates with the thrust held "
               "(docs/identification.md, \"When the rigid model does not fit\")", t, set);
    else if (now == SR_EST_MISFIT_NOISE)
        sr_log(inst, SR_LOG_WARNING,
               "t = %.6g s: the residuals are white but larger than the noise model's "
               "(diag.info_chi2 %.3g, %s): the noise.* values look too small for the sensors; "
               "no body is flagged identified, the estimates are kept and their sds widened "
               "(docs/identification.md, \"When the rigid model does not fit\")",
               t, r->info_chi2, set);
    else if (now == SR_EST_MISFIT_MODEL)
        sr_log(inst, SR_LOG_WARNING,
               "t = %.6g s: the rigid model does not fit the samples (%s): no body is flagged "
               "identified and the sds carry a model-error term (flexible parts or sloshing "
               "propellant; the rigid band's estimates are reported once it has an answer, "
               "diag.band, else the held filter's, which can be far off; where the band stays "
               "without an answer, diag.band 0, a large panel's mode may lie at 0.2-0.3 Hz, "
               "and ident.modes = 1 (method = 1, solver = 2) finds it: the band with its "
               "columns reports where its rows fit, diag.band 3, else the modal columns' "
               "estimates: docs/identification.md, \"The rigid band\", Limits)", t, set);
    else
        sr_log(inst, SR_LOG_EVENTS, "t = %.6g s: the rigid model fits the samples again "
               "(diag.misfit = 0)", t);
}

int sr_model_do_step(void *model, sr_instance *inst, double t, double h) {
    estimator_glue *g = model;
    const double *x = sr_reals(inst);
    char msg[512] = "";
    int status;
    (void)h;                                 /* one sample per communication point */
    for (int k = 0; k < g->n_sample; ++k) g->sample[k] = x[g->vr_in[k]];
    sr_estimator_report r = {0};
    status = sr_estimator_update(g->core, g->data, g->work, t, g->sample, msg, sizeof msg);
    write_outputs(inst, g, g->core, g->data, &r);
    log_misfit(inst, t, g->misfit_cause, &r);
    g->misfit_cause = r.misfit_cause;
    if (status == SR_EST_REJECT_NONFINITE || status == SR_EST_REJECT_INCONSISTENT) {
        char where[512] = "";                /* skipped: name the inputs at fault */
        for (int k = 0; k < g->n_sample; ++k)
            if (!(fabs(g->sample[k]) <= SR_EST_INPUT_LIMIT)) {
                sr_text_cat(where, sizeof where, where[0] ? ", " : " [input ");
                sr_text_cat(where, sizeof where, sr_variable(inst, g->vr_in[k])->name);
            }
        if (where[0]) sr_text_cat(where, sizeof where, "]");
        sr_log(inst, SR_LOG_WARNING, "t = %.6g s: sample skipped (%s)%s: %s; estimates unchanged", t,
               sr_estimator_status_text(status), where, msg);
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
    void *data, *work;
    char err[512];
    /* the state's parameters are in place: rebuild the core from them, then take its block */
    if (build_core(inst, g, &core, &data, &work, err, sizeof err)) {
        sr_log(inst, SR_LOG_ERROR,
               "restoring the FMU state: the state's parameters are not valid: %s", err);
        return 1;
    }
    if (size != sr_estimator_data_size(core)) {
        sr_log(inst, SR_LOG_ERROR,
               "restoring the FMU state: the state's estimator block has %lu bytes, "
               "%lu expected (a state of another robot or build?)", (unsigned long)size,
               (unsigned long)sr_estimator_data_size(core));
        sr_estimator_model_free(core);
        free(data);
        free(work);
        return 1;
    }
    memcpy(data, buf, size);
    /* bytes a host hands back: every count and index checked before any is used */
    if (sr_estimator_data_check(core, data, err, sizeof err) != 0) {
        sr_log(inst, SR_LOG_ERROR, "restoring the FMU state: %s", err);
        sr_estimator_model_free(core);
        free(data);
        free(work);
        return 1;
    }
    adopt_core(g, core, data, work);
    sr_estimator_report r;
    sr_estimator_report_get(core, data, &r);
    g->misfit_cause = r.misfit_cause;     /* as the restored diag.misfit says */
    return 0;
}

/* outputs change only in doStep (no direct feedthrough) */
const int SR_MODEL_FEEDTHROUGH = 0;
const double SR_MODEL_MAX_STEP = INFINITY;      /* one sample per step, of any length */
void sr_model_outputs(void *model, sr_instance *inst) { (void)model; (void)inst; }
