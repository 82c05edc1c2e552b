/*
 * fmi_layer.c -- the version-independent part of the FMI layer shared by the project's native
 * FMUs (fmi_layer.h): the instance, the lifecycle state machine, the checks the standard asks for
 * (value references, types, causality and variability per phase), the logging core, the variable
 * storage read from the resources (fmi_state.c: FMU state get/set/serialise). The thin API files fmi2_api.c
 * (FMI 2.0) and fmi3_api.c (FMI 3.0) export the standard's functions on top of it; the model's
 * glue (model.h) maps the variables to the numerical core and steps it.
 *
 * A refused call returns SR_ERROR (SR_DISCARD for a step that cannot be taken) with a logged
 * reason and leaves the instance as it was; nothing here aborts or exits.
 */
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi_layer.h"
#include "sr_text.h"

#define VARIABLES_FILE "spacerobot_variables.txt"
#define MSG_MAX 1024
#if FMI_VERSION == 3
#  define TOKEN_NAME "instantiationToken"
#else
#  define TOKEN_NAME "fmuGUID"
#endif

static const char *const PHASE_NAME[] = {"instantiated", "initialization", "stepping", "terminated"};


/* ---- logging ------------------------------------------------------------------------------- */
const char *const SR_FMI_CATEGORY[5] = {"logEvents", "logStatusWarning", "logStatusError",
                                        "logStatusDiscard", "logAll"};

static void vlog(sr_instance *inst, sr_log_category cat, const char *fmt, va_list ap) {
    char msg[MSG_MAX];
    int st = cat == SR_LOG_ERROR ? SR_ERROR
           : cat == SR_LOG_WARNING ? SR_WARNING
           : cat == SR_LOG_DISCARD ? SR_DISCARD : SR_OK;
    if (!inst || !inst->emit) return;
    if ((cat == SR_LOG_EVENTS || cat == SR_LOG_ALL) && !inst->log_events) return;
    sr_text_vformat(msg, sizeof msg, fmt, ap);      /* numbers independent of the locale */
    inst->emit(inst, st, SR_FMI_CATEGORY[cat], msg);
}

void sr_log(sr_instance *inst, sr_log_category category, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vlog(inst, category, fmt, ap);
    va_end(ap);
}

int sr_fmi_refuse(sr_instance *inst, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vlog(inst, SR_LOG_ERROR, fmt, ap);
    va_end(ap);
    return SR_ERROR;
}
#define refuse sr_fmi_refuse

/* ---- the variable table (resources/spacerobot_variables.txt) -------------------------------- */
/* Each line after the header: vr type causality variability start key name, with the start as the
 * IEEE-754 bits of a double in hex (exact and independent of the host's locale). */

static int parse_hex_double(const char *s, double *out) {
    uint64_t bits = 0;
    int digits = 0;
    if (s[0] != '0' || (s[1] != 'x' && s[1] != 'X')) return 1;
    for (s += 2; *s; ++s, ++digits) {
        int d = (*s >= '0' && *s <= '9') ? *s - '0'
              : (*s >= 'a' && *s <= 'f') ? *s - 'a' + 10
              : (*s >= 'A' && *s <= 'F') ? *s - 'A' + 10 : -1;
        if (d < 0 || digits >= 16) return 1;
        bits = (bits << 4) | (uint64_t)d;
    }
    if (digits == 0) return 1;
    memcpy(out, &bits, sizeof bits);
    return 0;
}

static int parse_uint(const char *s, long *out) {
    long v = 0;
    if (!*s) return 1;
    for (; *s; ++s) {
        if (*s < '0' || *s > '9' || v > 100000000L) return 1;
        v = v * 10 + (*s - '0');
    }
    *out = v;
    return 0;
}

static int word_index(const char *w, const char *const *words, int n) {
    for (int i = 0; i < n; ++i)
        if (strcmp(w, words[i]) == 0) return i;
    return -1;
}

/* split `line` at blanks into at most `max` fields (the last takes the rest of the line) */
static int split(char *line, char **field, int max) {
    int n = 0;
    char *p = line;
    while (n < max) {
        while (*p == ' ' || *p == '\t') ++p;
        if (!*p) break;
        field[n++] = p;
        if (n == max) break;
        while (*p && *p != ' ' && *p != '\t') ++p;
        if (*p) *p++ = '\0';
    }
    return n;
}

static char *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    char *buf = NULL;
    long size;
    if (!f) return NULL;
    if (fseek(f, 0, SEEK_END) == 0 && (size = ftell(f)) >= 0 && size < (1L << 26) &&
        fseek(f, 0, SEEK_SET) == 0 && (buf = malloc((size_t)size + 1)) != NULL) {
        *len = fread(buf, 1, (size_t)size, f);
        buf[*len] = '\0';
    }
    fclose(f);
    return buf;
}

int sr_resource_double(sr_instance *inst, const char *resource_dir, const char *file,
                       const char *key, double *out) {
    char path[4096], *text, *line, *next;
    size_t len = 0;
    int found = 0;
    sr_text_format(path, sizeof path, "%s%s", resource_dir, file);
    if ((text = read_file(path, &len)) == NULL) {
        sr_log(inst, SR_LOG_ERROR, "cannot read %s", path);
        return 1;
    }
    for (line = text; line && !found; line = next) {
        char *field[3];
        next = strchr(line, '\n');
        if (next) *next++ = '\0';
        if (split(line, field, 3) == 2 && strcmp(field[0], key) == 0) {
            char *end = field[1] + strcspn(field[1], "\r");
            *end = '\0';
            found = parse_hex_double(field[1], out) == 0 ? 1 : -1;
        }
    }
    free(text);
    if (found != 1)
        sr_log(inst, SR_LOG_ERROR, "%s: %s %s", path, found ? "not a hexadecimal IEEE-754 "
               "double: the value of" : "no line with the key", key);
    return found == 1 ? 0 : 1;
}

static int load_variables(sr_instance *inst, const char *resources, const char *guid) {
    static const char *const TYPES[] = {"Real", "Integer"};
    static const char *const CAUS[] = {"parameter", "input", "output"};
    static const char *const VARY[] = {"fixed", "tunable", "continuous", "discrete"};
    char path[4096 + sizeof VARIABLES_FILE];
    size_t len = 0, nlines = 1;
    char *text, *line, *next;
    int lineno = 0, ok = 1, seen_guid = 0;
    sr_text_format(path, sizeof path, "%s%s", resources, VARIABLES_FILE);   /* resources < 4096 */
    text = read_file(path, &len);
    if (!text) {
        sr_log(inst, SR_LOG_ERROR, "cannot read the FMU's variable table %s", path);
        return 1;
    }
    /* at most one variable per line: slots for that many, trimmed to the count below */
    for (size_t i = 0; i < len; ++i) nlines += text[i] == '\n';
    inst->vars = calloc(nlines, sizeof *inst->vars);
    if (!inst->vars) { free(text); return 1; }
    for (line = text; ok && line && *line; line = next) {
        char *f[8];
        int n;
        next = strchr(line, '\n');
        if (next) *next++ = '\0';
        ++lineno;
        if (strlen(line) && line[strlen(line) - 1] == '\r') line[strlen(line) - 1] = '\0';
        if (line[0] == '#' || line[0] == '\0') continue;
        n = split(line, f, 7);
        if (lineno == 1) {
            ok = n == 2 && strcmp(f[0], "spacerobot-variables") == 0 && strcmp(f[1], "1") == 0;
            if (!ok) sr_log(inst, SR_LOG_ERROR, "%s: not a version 1 variable table", path);
        } else if (n == 2 && strcmp(f[0], "guid") == 0) {
            seen_guid = 1;
            if (guid && strcmp(guid, f[1]) != 0) {
                sr_log(inst, SR_LOG_ERROR, TOKEN_NAME " %s does not match this FMU's %s (a model "
                       "description of another build?)", guid, f[1]);
                ok = 0;
            }
        } else if (n == 2 && strcmp(f[0], "model") == 0) {
            if (strcmp(f[1], SR_MODEL_IDENTIFIER) != 0) {
                sr_log(inst, SR_LOG_ERROR, "%s describes model %s, not %s", path, f[1],
                       SR_MODEL_IDENTIFIER);
                ok = 0;
            }
        } else {
            long vr;
            sr_var *v;
            int t, c, va;
            if (n != 7 || parse_uint(f[0], &vr) || vr != inst->nvars || (size_t)vr >= nlines ||
                (t = word_index(f[1], TYPES, 2)) < 0 || (c = word_index(f[2], CAUS, 3)) < 0 ||
                (va = word_index(f[3], VARY, 4)) < 0 || strlen(f[5]) >= SR_VAR_KEY_MAX ||
                strlen(f[6]) >= SR_VAR_NAME_MAX) {
                sr_log(inst, SR_LOG_ERROR, "%s line %d: malformed variable", path, lineno);
                ok = 0;
                break;
            }
            v = &inst->vars[inst->nvars++];
            v->type = (sr_type)t;
            v->causality = (sr_causality)c;
            v->variability = (sr_variability)va;
            if (parse_hex_double(f[4], &v->start) || !isfinite(v->start) ||
                (v->type == SR_INTEGER && !(v->start >= INT_MIN && v->start <= INT_MAX))) {
                sr_log(inst, SR_LOG_ERROR, "%s line %d: malformed start value", path, lineno);
                ok = 0;
                break;
            }
            strcpy(v->key, f[5]);
            strcpy(v->name, f[6]);
        }
    }
    free(text);
    if (ok && (!seen_guid || inst->nvars == 0)) {
        sr_log(inst, SR_LOG_ERROR, "%s has no guid or no variables", path);
        ok = 0;
    }
    if (ok) {
        sr_var *fit = realloc(inst->vars, (size_t)inst->nvars * sizeof *inst->vars);
        if (fit) inst->vars = fit;                  /* a failed shrink keeps the larger block */
        inst->real = calloc((size_t)inst->nvars, sizeof *inst->real);
        inst->integer = calloc((size_t)inst->nvars, sizeof *inst->integer);
        ok = inst->real && inst->integer;
    }
    return ok ? 0 : 1;
}

static void set_starts(sr_instance *inst) {
    for (int i = 0; i < inst->nvars; ++i) {
        inst->real[i] = inst->vars[i].type == SR_REAL ? inst->vars[i].start : 0.0;
        inst->integer[i] = inst->vars[i].type == SR_INTEGER ? (int)inst->vars[i].start : 0;
    }
}

int sr_key_vr(sr_instance *inst, const char *key, int required) {
    for (int i = 0; i < inst->nvars; ++i)
        if (strcmp(inst->vars[i].key, key) == 0) return i;
    if (required) sr_log(inst, SR_LOG_ERROR, "the variable table has no variable with key %s", key);
    return -1;
}

double sr_key_real(sr_instance *inst, const char *key, int required) {
    int vr = sr_key_vr(inst, key, required);
    return vr < 0 ? NAN : inst->real[vr];
}

double *sr_reals(sr_instance *inst) { return inst->real; }
int *sr_integers(sr_instance *inst) { return inst->integer; }
const sr_var *sr_variable(const sr_instance *inst, int vr) {
    return vr >= 0 && vr < inst->nvars ? &inst->vars[vr] : NULL;
}

/* "file:///C:/x%20y/" or "file:/x/" (FMI 2.0) or, with native_path, a plain path (FMI 3.0)
   -> a local path ending in a separator */
int sr_fmi_resource_dir(const char *location, int native_path, char *out, size_t size) {
    size_t n = 0;
    const char *p = location;
    int uri;
    if (!location || size < 2) return 1;
    uri = strncmp(p, "file:", 5) == 0 || !native_path;   /* FMI 2.0: always a URI */
    if (strncmp(p, "file://", 7) == 0) {
        p += 7;
        if (strncmp(p, "localhost/", 10) == 0) p += 9;
    } else if (strncmp(p, "file:", 5) == 0) {
        p += 5;
    }
#if defined(_WIN32)
    if (uri && p[0] == '/' && p[1] && p[2] == ':') ++p;     /* /C:/... */
#endif
    for (; *p; ++p) {
        int c = (unsigned char)*p;
        if (uri && c == '%' && p[1] && p[2]) {       /* a plain path keeps its '%' */
            char hex[3] = {p[1], p[2], 0};
            char *end;
            long v = strtol(hex, &end, 16);
            if (*end == '\0') { c = (int)v; p += 2; }
        }
        if (n + 2 >= size) return 1;
        out[n++] = (char)c;
    }
    if (n == 0 || (out[n - 1] != '/' && !(native_path && out[n - 1] == '\\'))) out[n++] = '/';
    out[n] = '\0';
    return 0;
}

/* ---- instance ------------------------------------------------------------------------------ */
sr_instance *sr_fmi_new(const char *name, int logging_on, sr_emit_fn emit, sr_host_logger logger,
                        void *env) {
    sr_instance *inst = calloc(1, sizeof *inst);
    if (!inst) return NULL;
    sr_text_set(inst->name, sizeof inst->name, name);
    inst->emit = emit;
    inst->logger = logger;
    inst->env = env;
    inst->log_events = logging_on != 0;
    inst->phase = PHASE_INSTANTIATED;
    return inst;
}

void sr_fmi_free(sr_instance *inst) {
    if (!inst) return;
    for (int i = 0; i < inst->nstates; ++i) free(inst->states[i]);   /* states never freed */
    free(inst->states);
    if (inst->model) sr_model_free(inst->model);
    free(inst->vars);
    free(inst->real);
    free(inst->integer);
    free(inst);
}

int sr_fmi_load(sr_instance *inst, const char *token, const char *resource_dir) {
    if (load_variables(inst, resource_dir, token)) return 1;
    set_starts(inst);
    if ((inst->model = sr_model_new(inst, resource_dir)) == NULL) return 1;
    inst->phase = PHASE_INSTANTIATED;
    sr_log(inst, SR_LOG_EVENTS, "instantiated %s from %s (%d variables)", SR_MODEL_IDENTIFIER,
           resource_dir, inst->nvars);
    return 0;
}

int sr_fmi_set_debug_logging(sr_instance *inst, const char *call, int logging_on,
                             size_t ncategories, const char *const categories[]) {
    if (ncategories > 0 && !categories) return refuse(inst, "%s: categories is NULL", call);
    for (size_t i = 0; i < ncategories; ++i) {
        int known = 0;
        for (int k = 0; k < 5; ++k)
            known |= categories[i] && strcmp(categories[i], SR_FMI_CATEGORY[k]) == 0;
        if (!known)
            return refuse(inst, "%s: unknown category %s", call,
                          categories[i] ? categories[i] : "(null)");
    }
    inst->log_events = logging_on != 0;
    return SR_OK;
}

int sr_fmi_setup(sr_instance *inst, double start_time) {
    if (inst->phase != PHASE_INSTANTIATED)
        return refuse(inst, FMI_NAME("SetupExperiment") " called in phase '%s'; it is only allowed "
                      "after " FMI_NAME("Instantiate"), PHASE_NAME[inst->phase]);
    if (!isfinite(start_time))
        return refuse(inst, FMI_NAME("SetupExperiment") ": non-finite start time");
    inst->time = start_time;
    return SR_OK;
}

int sr_fmi_enter_initialization(sr_instance *inst, int set_start, double start_time) {
    if (inst->phase != PHASE_INSTANTIATED)
        return refuse(inst, FMI_NAME("EnterInitializationMode") " called in phase '%s'; it is only "
                      "allowed once, after " FMI_NAME("Instantiate") " (or " FMI_NAME("Reset") ")",
                      PHASE_NAME[inst->phase]);
    if (set_start) {
        if (!isfinite(start_time))
            return refuse(inst, FMI_NAME("EnterInitializationMode") ": non-finite start time");
        inst->time = start_time;
    }
    inst->phase = PHASE_INITIALIZATION;
    inst->preview_dirty = 1;
    return SR_OK;
}

/* every Real parameter finite, else one error naming them all; 0 ok */
static int check_finite_parameters(sr_instance *inst) {
    char msg[MSG_MAX] = "";
    size_t used = 0;
    for (int i = 0; i < inst->nvars; ++i) {
        const sr_var *v = &inst->vars[i];
        if (v->causality == SR_PARAMETER && v->type == SR_REAL && !isfinite(inst->real[i]) &&
            used + SR_VAR_NAME_MAX + 16 < sizeof msg)
            used = sr_text_format(msg + used, sizeof msg - used, "%s%s = %g", used ? ", " : "",
                                  v->name, inst->real[i]) + used;
    }
    if (!used) return 0;
    sr_log(inst, SR_LOG_ERROR, "invalid parameters: non-finite parameter value(s): %s", msg);
    return 1;
}

int sr_fmi_exit_initialization(sr_instance *inst) {
    if (inst->phase != PHASE_INITIALIZATION)
        return refuse(inst, FMI_NAME("ExitInitializationMode") " called in phase '%s'; call "
                      FMI_NAME("EnterInitializationMode") " first", PHASE_NAME[inst->phase]);
    if (check_finite_parameters(inst) != 0 || sr_model_initialize(inst->model, inst) != 0)
        return SR_ERROR;
    inst->phase = PHASE_STEP;
    inst->outputs_dirty = 1;
    sr_log(inst, SR_LOG_EVENTS, "initialised at t = %g s", inst->time);
    return SR_OK;
}

int sr_fmi_terminate(sr_instance *inst) {
    if (inst->phase != PHASE_STEP)
        return refuse(inst, FMI_NAME("Terminate") " called in phase '%s'; it is allowed after "
                      "initialisation", PHASE_NAME[inst->phase]);
    inst->phase = PHASE_TERMINATED;
    return SR_OK;
}

int sr_fmi_reset(sr_instance *inst) {
    sr_model_reset(inst->model);
    set_starts(inst);
    inst->phase = PHASE_INSTANTIATED;
    inst->time = 0.0;
    return SR_OK;
}

/* ---- get / set ------------------------------------------------------------------------------- */
static const char *type_name(sr_type type) {
#if FMI_VERSION == 3
    return type == SR_REAL ? "Float64" : "Int32";
#else
    return type == SR_REAL ? "Real" : "Integer";
#endif
}

/* FMI 3.0 declares the independent variable, time, after the table's variables: value
   reference nvars, a Float64 that can be read (the instance's time) and never set. */
static int is_time(const sr_instance *inst, unsigned int vr) {
    return FMI_VERSION == 3 && vr == (unsigned int)inst->nvars;
}

static int check_refs(sr_instance *inst, const char *call, const unsigned int vr[], size_t nvr,
                      sr_type type, int get) {
    if (nvr > 0 && !vr) return refuse(inst, "%s: the value reference array is NULL", call);
    for (size_t i = 0; i < nvr; ++i) {
        if (is_time(inst, vr[i]) && type == SR_REAL) {
            if (get) continue;
            return refuse(inst, "%s: time (value reference %u) is the independent variable and "
                          "cannot be set", call, vr[i]);
        }
        if (vr[i] >= (unsigned int)inst->nvars)
            return refuse(inst, "%s: unknown value reference %u", call, vr[i]);
        if (inst->vars[vr[i]].type != type)
            return refuse(inst, "%s: %s (value reference %u) is not of type %s", call,
                          inst->vars[vr[i]].name, vr[i], type_name(type));
    }
    return SR_OK;
}

/* Outputs about to be read: in initialisation mode the preview for the parameters set so far;
   in stepping mode (feedthrough models) the outputs for the current inputs. */
static void refresh_outputs(sr_instance *inst, const unsigned int vr[], size_t nvr) {
    int *dirty = inst->phase == PHASE_INITIALIZATION ? &inst->preview_dirty
               : inst->phase == PHASE_STEP && SR_MODEL_FEEDTHROUGH ? &inst->outputs_dirty : NULL;
    if (!dirty || !*dirty) return;
    for (size_t i = 0; i < nvr; ++i)
        if (!is_time(inst, vr[i]) && inst->vars[vr[i]].causality == SR_OUTPUT) {
            if (inst->phase == PHASE_INITIALIZATION) sr_model_preview(inst->model, inst);
            else sr_model_outputs(inst->model, inst);
            *dirty = 0;
            return;
        }
}

int sr_fmi_get_real(sr_instance *inst, const char *call, const unsigned int vr[], size_t nvr,
                    double value[]) {
    if (nvr > 0 && !value) return refuse(inst, "%s: the value array is NULL", call);
    if (check_refs(inst, call, vr, nvr, SR_REAL, 1) != SR_OK) return SR_ERROR;
    refresh_outputs(inst, vr, nvr);
    for (size_t i = 0; i < nvr; ++i)
        value[i] = is_time(inst, vr[i]) ? inst->time : inst->real[vr[i]];
    return SR_OK;
}

int sr_fmi_get_integer(sr_instance *inst, const char *call, const unsigned int vr[], size_t nvr,
                       int value[]) {
    if (nvr > 0 && !value) return refuse(inst, "%s: the value array is NULL", call);
    if (check_refs(inst, call, vr, nvr, SR_INTEGER, 1) != SR_OK) return SR_ERROR;
    refresh_outputs(inst, vr, nvr);
    for (size_t i = 0; i < nvr; ++i) value[i] = inst->integer[vr[i]];
    return SR_OK;
}

/* May variable v be set now? NULL if yes, else why not. */
static const char *settable(const sr_instance *inst, const sr_var *v) {
    if (inst->phase == PHASE_TERMINATED) return "the instance is terminated";
    if (v->causality == SR_OUTPUT) return "is an output and cannot be set";
    if (v->causality == SR_PARAMETER && v->variability == SR_FIXED && inst->phase == PHASE_STEP)
        return "is a fixed parameter and cannot be changed after initialisation";
    return NULL;
}

static void mark_set(sr_instance *inst, unsigned int vr) {
    if (inst->vars[vr].causality == SR_PARAMETER
        || (SR_MODEL_FEEDTHROUGH && inst->vars[vr].causality == SR_INPUT))
        inst->preview_dirty = 1;
    inst->outputs_dirty = 1;
}

int sr_fmi_set_real(sr_instance *inst, const char *call, const unsigned int vr[], size_t nvr,
                    const double value[]) {
    if (nvr > 0 && !value) return refuse(inst, "%s: the value array is NULL", call);
    if (check_refs(inst, call, vr, nvr, SR_REAL, 0) != SR_OK) return SR_ERROR;
    for (size_t i = 0; i < nvr; ++i) {             /* all or nothing */
        const char *why = settable(inst, &inst->vars[vr[i]]);
        if (why)
            return refuse(inst, "%s %s (tried to set %.17g); the value stays %.17g",
                          inst->vars[vr[i]].name, why, value[i], inst->real[vr[i]]);
    }
    for (size_t i = 0; i < nvr; ++i) {
        inst->real[vr[i]] = value[i];
        mark_set(inst, vr[i]);
    }
    return SR_OK;
}

int sr_fmi_set_integer(sr_instance *inst, const char *call, const unsigned int vr[], size_t nvr,
                       const int value[]) {
    if (nvr > 0 && !value) return refuse(inst, "%s: the value array is NULL", call);
    if (check_refs(inst, call, vr, nvr, SR_INTEGER, 0) != SR_OK) return SR_ERROR;
    for (size_t i = 0; i < nvr; ++i) {
        const char *why = settable(inst, &inst->vars[vr[i]]);
        if (why)
            return refuse(inst, "%s %s (tried to set %d); the value stays %d",
                          inst->vars[vr[i]].name, why, value[i], inst->integer[vr[i]]);
    }
    for (size_t i = 0; i < nvr; ++i) {
        inst->integer[vr[i]] = value[i];
        mark_set(inst, vr[i]);
    }
    return SR_OK;
}

int sr_fmi_no_such_type(sr_instance *inst, const char *call, size_t nvr) {
    if (nvr == 0) return SR_OK;
    return refuse(inst, "%s: %s has no variables of this type", call, SR_MODEL_IDENTIFIER);
}

/* ---- stepping ------------------------------------------------------------------------------- */
/* How far a step's communication point may lie from the instance's time: a millionth of the
   step, plus the round-off of the time itself (a master that computes t = k h, or t + h, lands
   within a few units in the last place of it). */
#define STEP_TIME_TOLERANCE 1e-6
#define TIME_ROUNDOFF (8.0 * DBL_EPSILON)

int sr_fmi_do_step(sr_instance *inst, double t, double h) {
    double off, tol;
    if (inst->phase != PHASE_STEP) {
#if FMI_VERSION == 3
        /* FMI 3.0: an illegal call in this state is an error */
        return refuse(inst, "fmi3DoStep called in phase '%s'; call fmi3ExitInitializationMode "
                      "first", PHASE_NAME[inst->phase]);
#else
        sr_log(inst, SR_LOG_DISCARD, "doStep called in phase '%s'; call "
               FMI_NAME("ExitInitializationMode") " first", PHASE_NAME[inst->phase]);
        return SR_DISCARD;
#endif
    }
    if (!isfinite(t)) {
        sr_log(inst, SR_LOG_DISCARD, "non-finite communication point %g", t);
        return SR_DISCARD;
    }
    if (!(isfinite(h) && h > 0.0 && h <= SR_MODEL_MAX_STEP)) {
        sr_log(inst, SR_LOG_DISCARD, "communication step %g s at t = %g s rejected: it must be "
               "finite and in (0, %g] s", h, t, SR_MODEL_MAX_STEP);
        return SR_DISCARD;
    }
    /* a step starts where the last one ended (or at the start time): another communication
       point is an illegal argument, as in the Reference FMUs (FMI 3.0, 2.2.3: fmi3Error) */
    off = fabs(t - inst->time);
    tol = STEP_TIME_TOLERANCE * h + TIME_ROUNDOFF * fmax(fabs(t), fabs(inst->time));
    if (!(off <= tol))
        return refuse(inst, FMI_NAME("DoStep") ": the communication point %.17g s differs from "
                      "the FMU's time %.17g s by %g s (more than 1e-6 of the step %g s): a step "
                      "must start where the last one ended; step refused, state unchanged",
                      t, inst->time, off, h);
    inst->outputs_dirty = 1;
    if (sr_model_do_step(inst->model, inst, t, h) != 0) return SR_DISCARD;
    inst->time = t + h;
    return SR_OK;
}
