/*
 * fmi2_layer.c -- the FMI 2.0 co-simulation layer shared by the project's native FMUs.
 *
 * Implements every fmi2 function a co-simulation FMU exports: the lifecycle state machine, the
 * checks the standard asks for (value references, types, causality and variability per phase),
 * logging through the host's callback, the variable storage, FMU state get/set/serialise. The
 * model's glue (model.h) maps the variables to the numerical core and steps it.
 *
 * A refused call returns fmi2Error (fmi2Discard for a step that cannot be taken) with a logged
 * reason and leaves the instance as it was; nothing here aborts or exits.
 */
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2.h"
#include "model.h"

#define VARIABLES_FILE "spacerobot_variables.txt"
#define MAX_VARIABLES 4096
#define MSG_MAX 1024
#define STATE_MAGIC 0x53524653u   /* "SRFS" */
#define STATE_VERSION 1u

typedef enum { PHASE_INSTANTIATED, PHASE_INITIALIZATION, PHASE_STEP, PHASE_TERMINATED } phase_t;
static const char *const PHASE_NAME[] = {"instantiated", "initialization", "stepping", "terminated"};

struct sr_instance {
    char name[128];
    fmi2CallbackLogger logger;
    fmi2ComponentEnvironment env;
    int log_events;                  /* loggingOn / fmi2SetDebugLogging: logEvents, logAll */
    phase_t phase;
    double time;
    int nvars;
    sr_var *vars;                    /* by value reference */
    double *real;                    /* values by value reference (Real variables) */
    int *integer;                    /* values by value reference (Integer variables) */
    int preview_dirty;               /* a parameter (feedthrough: or an input) changed in
                                        initialisation mode */
    int outputs_dirty;               /* feedthrough: inputs, state or time changed since the
                                        outputs were computed (stepping mode) */
    void *model;
    void **states;                   /* the FMU states handed out and not freed yet */
    int nstates, cap_states;
};

/* one saved FMU state: this header, then real[nvars], integer[nvars], the model's block */
typedef struct {
    uint32_t magic, version;
    uint64_t nvars, model_size, has_model;
    int32_t phase, pad;
    double time;
} state_header;

typedef struct {
    state_header h;
    unsigned char bytes[];           /* values and the model's block */
} saved_state;

/* ---- logging ------------------------------------------------------------------------------- */
static const char *const CATEGORY[] = {"logEvents", "logStatusWarning", "logStatusError",
                                       "logStatusDiscard", "logAll"};

static void vlog(sr_instance *inst, sr_log_category cat, const char *fmt, va_list ap) {
    char msg[MSG_MAX];
    fmi2Status st = cat == SR_LOG_ERROR ? fmi2Error
                  : cat == SR_LOG_WARNING ? fmi2Warning
                  : cat == SR_LOG_DISCARD ? fmi2Discard : fmi2OK;
    if (!inst || !inst->logger) return;
    if ((cat == SR_LOG_EVENTS || cat == SR_LOG_ALL) && !inst->log_events) return;
    vsnprintf(msg, sizeof msg, fmt, ap);
    /* the message is the format itself with every '%' doubled: a host that formats it prints the
       text, and one that cannot read C varargs (a ctypes logger, e.g. fmpy's) still gets it */
    {
        char fmt_msg[2 * MSG_MAX];
        size_t i, o = 0;
        for (i = 0; msg[i] && o + 2 < sizeof fmt_msg; ++i) {
            if (msg[i] == '%') fmt_msg[o++] = '%';
            fmt_msg[o++] = msg[i];
        }
        fmt_msg[o] = '\0';
        inst->logger(inst->env, inst->name, st, CATEGORY[cat], fmt_msg);
    }
}

void sr_log(sr_instance *inst, sr_log_category category, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vlog(inst, category, fmt, ap);
    va_end(ap);
}

static fmi2Status refuse(sr_instance *inst, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static fmi2Status refuse(sr_instance *inst, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    vlog(inst, SR_LOG_ERROR, fmt, ap);
    va_end(ap);
    return fmi2Error;
}

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
    snprintf(path, sizeof path, "%s%s", resource_dir, file);
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
    size_t len = 0;
    char *text, *line, *next;
    int lineno = 0, ok = 1, seen_guid = 0;
    snprintf(path, sizeof path, "%s%s", resources, VARIABLES_FILE);   /* resources < 4096 */
    text = read_file(path, &len);
    if (!text) {
        sr_log(inst, SR_LOG_ERROR, "cannot read the FMU's variable table %s", path);
        return 1;
    }
    inst->vars = calloc(MAX_VARIABLES, sizeof *inst->vars);
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
                sr_log(inst, SR_LOG_ERROR, "fmuGUID %s does not match this FMU's %s (a model "
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
            if (n != 7 || parse_uint(f[0], &vr) || vr != inst->nvars || vr >= MAX_VARIABLES ||
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

/* "file:///C:/x%20y/" or "file:/x/" -> a local path with a trailing '/' */
static int uri_to_path(const char *uri, char *out, size_t size) {
    size_t n = 0;
    const char *p = uri;
    if (!uri) return 1;
    if (strncmp(p, "file://", 7) == 0) {
        p += 7;
        if (strncmp(p, "localhost/", 10) == 0) p += 9;
    } else if (strncmp(p, "file:", 5) == 0) {
        p += 5;
    }
#if defined(_WIN32)
    if (p[0] == '/' && p[1] && p[2] == ':') ++p;     /* /C:/... */
#endif
    for (; *p; ++p) {
        int c = (unsigned char)*p;
        if (c == '%' && p[1] && p[2]) {
            char hex[3] = {p[1], p[2], 0};
            char *end;
            long v = strtol(hex, &end, 16);
            if (*end == '\0') { c = (int)v; p += 2; }
        }
        if (n + 2 >= size) return 1;
        out[n++] = (char)c;
    }
    if (n == 0 || out[n - 1] != '/') out[n++] = '/';
    out[n] = '\0';
    return 0;
}

/* ---- instance ------------------------------------------------------------------------------ */
static void free_instance(sr_instance *inst) {
    if (!inst) return;
    for (int i = 0; i < inst->nstates; ++i) free(inst->states[i]);   /* states never freed */
    free(inst->states);
    if (inst->model) sr_model_free(inst->model);
    free(inst->vars);
    free(inst->real);
    free(inst->integer);
    free(inst);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
    char resources[4096];
    sr_instance *inst;
    (void)visible;
    if (!functions || !functions->logger) return NULL;   /* the standard requires a logger */
    inst = calloc(1, sizeof *inst);
    if (!inst) return NULL;
    snprintf(inst->name, sizeof inst->name, "%s", instanceName ? instanceName : "");
    inst->logger = functions->logger;
    inst->env = functions->componentEnvironment;
    inst->log_events = loggingOn != fmi2False;
    if (!instanceName || !instanceName[0]) {
        refuse(inst, "fmi2Instantiate: an instance name is required");
        free_instance(inst);
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        refuse(inst, "fmi2Instantiate: %s implements co-simulation only", SR_MODEL_IDENTIFIER);
        free_instance(inst);
        return NULL;
    }
    if (uri_to_path(fmuResourceLocation, resources, sizeof resources)) {
        refuse(inst, "fmi2Instantiate: the resource location %s is not a file URI",
               fmuResourceLocation ? fmuResourceLocation : "(null)");
        free_instance(inst);
        return NULL;
    }
    if (load_variables(inst, resources, fmuGUID) ||
        (set_starts(inst), (inst->model = sr_model_new(inst, resources)) == NULL)) {
        free_instance(inst);
        return NULL;
    }
    inst->phase = PHASE_INSTANTIATED;
    sr_log(inst, SR_LOG_EVENTS, "instantiated %s from %s (%d variables)", SR_MODEL_IDENTIFIER,
           resources, inst->nvars);
    return inst;
}

void fmi2FreeInstance(fmi2Component c) { free_instance((sr_instance *)c); }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    if (nCategories > 0 && !categories) return refuse(inst, "fmi2SetDebugLogging: categories is NULL");
    for (size_t i = 0; i < nCategories; ++i) {
        int known = 0;
        for (int k = 0; k < 5; ++k) known |= categories[i] && strcmp(categories[i], CATEGORY[k]) == 0;
        if (!known)
            return refuse(inst, "fmi2SetDebugLogging: unknown category %s",
                          categories[i] ? categories[i] : "(null)");
    }
    inst->log_events = loggingOn != fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    sr_instance *inst = c;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (!inst) return fmi2Error;
    if (inst->phase != PHASE_INSTANTIATED)
        return refuse(inst, "fmi2SetupExperiment called in phase '%s'; it is only allowed after "
                      "fmi2Instantiate", PHASE_NAME[inst->phase]);
    if (!isfinite(startTime)) return refuse(inst, "fmi2SetupExperiment: non-finite start time");
    inst->time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    if (inst->phase != PHASE_INSTANTIATED)
        return refuse(inst, "fmi2EnterInitializationMode called in phase '%s'; it is only allowed "
                      "once, after fmi2Instantiate (or fmi2Reset)", PHASE_NAME[inst->phase]);
    inst->phase = PHASE_INITIALIZATION;
    inst->preview_dirty = 1;
    return fmi2OK;
}

/* "nan", "inf", "-inf": the same text on every platform (printf's differs) */
static const char *nonfinite_text(double x) {
    return isnan(x) ? "nan" : x > 0 ? "inf" : "-inf";
}

/* every Real parameter finite, else one error naming them all; 0 ok */
static int check_finite_parameters(sr_instance *inst) {
    char msg[MSG_MAX] = "";
    size_t used = 0;
    for (int i = 0; i < inst->nvars; ++i) {
        const sr_var *v = &inst->vars[i];
        if (v->causality == SR_PARAMETER && v->type == SR_REAL && !isfinite(inst->real[i]) &&
            used + SR_VAR_NAME_MAX + 16 < sizeof msg)
            used += (size_t)snprintf(msg + used, sizeof msg - used, "%s%s = %s", used ? ", " : "",
                                     v->name, nonfinite_text(inst->real[i]));
    }
    if (!used) return 0;
    sr_log(inst, SR_LOG_ERROR, "invalid parameters: non-finite parameter value(s): %s", msg);
    return 1;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    if (inst->phase != PHASE_INITIALIZATION)
        return refuse(inst, "fmi2ExitInitializationMode called in phase '%s'; call "
                      "fmi2EnterInitializationMode first", PHASE_NAME[inst->phase]);
    if (check_finite_parameters(inst) != 0 || sr_model_initialize(inst->model, inst) != 0)
        return fmi2Error;
    inst->phase = PHASE_STEP;
    inst->outputs_dirty = 1;
    sr_log(inst, SR_LOG_EVENTS, "initialised at t = %g s", inst->time);
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    if (inst->phase != PHASE_STEP)
        return refuse(inst, "fmi2Terminate called in phase '%s'; it is allowed after "
                      "initialisation", PHASE_NAME[inst->phase]);
    inst->phase = PHASE_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    sr_model_reset(inst->model);
    set_starts(inst);
    inst->phase = PHASE_INSTANTIATED;
    inst->time = 0.0;
    return fmi2OK;
}

/* ---- get / set ------------------------------------------------------------------------------- */
static fmi2Status check_refs(sr_instance *inst, const char *call, const fmi2ValueReference vr[],
                             size_t nvr, sr_type type) {
    if (nvr > 0 && !vr) return refuse(inst, "%s: the value reference array is NULL", call);
    for (size_t i = 0; i < nvr; ++i) {
        if (vr[i] >= (fmi2ValueReference)inst->nvars)
            return refuse(inst, "%s: unknown value reference %u", call, vr[i]);
        if (inst->vars[vr[i]].type != type)
            return refuse(inst, "%s: %s (value reference %u) is not of type %s", call,
                          inst->vars[vr[i]].name, vr[i], type == SR_REAL ? "Real" : "Integer");
    }
    return fmi2OK;
}

/* Outputs about to be read: in initialisation mode the preview for the parameters set so far;
   in stepping mode (feedthrough models) the outputs for the current inputs. */
static void refresh_outputs(sr_instance *inst, const fmi2ValueReference vr[], size_t nvr) {
    int *dirty = inst->phase == PHASE_INITIALIZATION ? &inst->preview_dirty
               : inst->phase == PHASE_STEP && SR_MODEL_FEEDTHROUGH ? &inst->outputs_dirty : NULL;
    if (!dirty || !*dirty) return;
    for (size_t i = 0; i < nvr; ++i)
        if (inst->vars[vr[i]].causality == SR_OUTPUT) {
            if (inst->phase == PHASE_INITIALIZATION) sr_model_preview(inst->model, inst);
            else sr_model_outputs(inst->model, inst);
            *dirty = 0;
            return;
        }
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    if (nvr > 0 && !value) return refuse(inst, "fmi2GetReal: the value array is NULL");
    if (check_refs(inst, "fmi2GetReal", vr, nvr, SR_REAL) != fmi2OK) return fmi2Error;
    refresh_outputs(inst, vr, nvr);
    for (size_t i = 0; i < nvr; ++i) value[i] = inst->real[vr[i]];
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    if (nvr > 0 && !value) return refuse(inst, "fmi2GetInteger: the value array is NULL");
    if (check_refs(inst, "fmi2GetInteger", vr, nvr, SR_INTEGER) != fmi2OK) return fmi2Error;
    refresh_outputs(inst, vr, nvr);
    for (size_t i = 0; i < nvr; ++i) value[i] = inst->integer[vr[i]];
    return fmi2OK;
}

/* May variable v be set now? NULL if yes, else why not. */
static const char *settable(const sr_instance *inst, const sr_var *v) {
    if (inst->phase == PHASE_TERMINATED) return "the instance is terminated";
    if (v->causality == SR_OUTPUT) return "is an output and cannot be set";
    if (v->causality == SR_PARAMETER && v->variability == SR_FIXED && inst->phase == PHASE_STEP)
        return "is a fixed parameter and cannot be changed after initialisation";
    return NULL;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    if (nvr > 0 && !value) return refuse(inst, "fmi2SetReal: the value array is NULL");
    if (check_refs(inst, "fmi2SetReal", vr, nvr, SR_REAL) != fmi2OK) return fmi2Error;
    for (size_t i = 0; i < nvr; ++i) {             /* all or nothing */
        const char *why = settable(inst, &inst->vars[vr[i]]);
        if (why)
            return refuse(inst, "%s %s (tried to set %.17g); the value stays %.17g",
                          inst->vars[vr[i]].name, why, value[i], inst->real[vr[i]]);
    }
    for (size_t i = 0; i < nvr; ++i) {
        inst->real[vr[i]] = value[i];
        if (inst->vars[vr[i]].causality == SR_PARAMETER
            || (SR_MODEL_FEEDTHROUGH && inst->vars[vr[i]].causality == SR_INPUT))
            inst->preview_dirty = 1;
        inst->outputs_dirty = 1;
    }
    return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    if (nvr > 0 && !value) return refuse(inst, "fmi2SetInteger: the value array is NULL");
    if (check_refs(inst, "fmi2SetInteger", vr, nvr, SR_INTEGER) != fmi2OK) return fmi2Error;
    for (size_t i = 0; i < nvr; ++i) {
        const char *why = settable(inst, &inst->vars[vr[i]]);
        if (why)
            return refuse(inst, "%s %s (tried to set %d); the value stays %d",
                          inst->vars[vr[i]].name, why, value[i], inst->integer[vr[i]]);
    }
    for (size_t i = 0; i < nvr; ++i) {
        inst->integer[vr[i]] = value[i];
        if (inst->vars[vr[i]].causality == SR_PARAMETER
            || (SR_MODEL_FEEDTHROUGH && inst->vars[vr[i]].causality == SR_INPUT))
            inst->preview_dirty = 1;
        inst->outputs_dirty = 1;
    }
    return fmi2OK;
}

static fmi2Status no_such_type(sr_instance *inst, const char *call, size_t nvr) {
    if (!inst) return fmi2Error;
    if (nvr == 0) return fmi2OK;
    return refuse(inst, "%s: %s has no variables of this type", call, SR_MODEL_IDENTIFIER);
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    (void)vr; (void)value;
    return no_such_type(c, "fmi2GetBoolean", nvr);
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    (void)vr; (void)value;
    return no_such_type(c, "fmi2GetString", nvr);
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    (void)vr; (void)value;
    return no_such_type(c, "fmi2SetBoolean", nvr);
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    (void)vr; (void)value;
    return no_such_type(c, "fmi2SetString", nvr);
}

/* ---- stepping ------------------------------------------------------------------------------- */
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    sr_instance *inst = c;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!inst) return fmi2Error;
    if (inst->phase != PHASE_STEP) {
        sr_log(inst, SR_LOG_DISCARD, "doStep called in phase '%s'; call fmi2ExitInitializationMode "
               "first", PHASE_NAME[inst->phase]);
        return fmi2Discard;
    }
    if (!isfinite(t)) {
        sr_log(inst, SR_LOG_DISCARD, "non-finite communication point %g", t);
        return fmi2Discard;
    }
    if (!(isfinite(h) && h > 0.0 && h <= SR_MODEL_MAX_STEP)) {
        char longest[32] = "inf";            /* spelled out: msvcrt prints infinity as 1.#INF */
        if (isfinite(SR_MODEL_MAX_STEP)) snprintf(longest, sizeof longest, "%g", SR_MODEL_MAX_STEP);
        sr_log(inst, SR_LOG_DISCARD, "communication step %g s at t = %g s rejected: it must be "
               "finite and in (0, %s] s", h, t, longest);
        return fmi2Discard;
    }
    inst->outputs_dirty = 1;
    if (sr_model_do_step(inst->model, inst, t, h) != 0) return fmi2Discard;
    inst->time = t + h;
    return fmi2OK;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    return c ? refuse(c, "fmi2CancelStep: steps are synchronous (canRunAsynchronuously is false)")
             : fmi2Error;
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    if (!c) return fmi2Error;
    return nvr ? refuse(c, "fmi2SetRealInputDerivatives: canInterpolateInputs is false") : fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    if (!c) return fmi2Error;
    return nvr ? refuse(c, "fmi2GetRealOutputDerivatives: maxOutputDerivativeOrder is 0") : fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    return c ? refuse(c, "fmi2GetDirectionalDerivative: providesDirectionalDerivative is false")
             : fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s; (void)value;
    return c ? refuse(c, "fmi2GetStatus: steps are synchronous; there is no pending status")
             : fmi2Error;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    if (s == fmi2LastSuccessfulTime && value) {
        *value = inst->time;
        return fmi2OK;
    }
    return refuse(inst, "fmi2GetRealStatus: only fmi2LastSuccessfulTime is available");
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s; (void)value;
    return c ? refuse(c, "fmi2GetIntegerStatus: no integer status is defined") : fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    if (s == fmi2Terminated && value) {
        *value = fmi2False;                         /* the FMU never asks to stop */
        return fmi2OK;
    }
    return refuse(inst, "fmi2GetBooleanStatus: only fmi2Terminated is available");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s; (void)value;
    return c ? refuse(c, "fmi2GetStringStatus: no string status is defined") : fmi2Error;
}

/* ---- FMU state -------------------------------------------------------------------------------- */
static int has_core(const sr_instance *inst) {
    return inst->phase == PHASE_STEP || inst->phase == PHASE_TERMINATED;
}

/* bytes of the values in a state: reals, then integers padded to 8 bytes (the model's block
   that follows stays aligned for its doubles) */
static size_t values_size(const sr_instance *inst) {
    return (size_t)inst->nvars * sizeof(double) + ((size_t)inst->nvars * sizeof(int) + 7u) / 8u * 8u;
}

/* bytes of a state of this instance as it is now */
static size_t current_size(sr_instance *inst) {
    return sizeof(saved_state) + values_size(inst) +
           (has_core(inst) ? sr_model_state_size(inst->model) : 0);
}

/* bytes of the saved state s (header checked by state_mismatch) */
static size_t stored_size(const sr_instance *inst, const saved_state *s) {
    return sizeof(saved_state) + values_size(inst) +
           (size_t)s->h.model_size;
}

static const char *state_mismatch(sr_instance *inst, const saved_state *s, size_t size);

/* The states this instance handed out are kept in a list and recognised by their address, so
   that a pointer that is not one of them is never dereferenced: not a garbage or freed pointer,
   and not the state itself passed where its address is expected. fmusim 0.0.39 does the latter
   (FMISaveFMUStateToFile and FMIRestoreFMUStateFromFile call fmi2FreeFMUstate(c, state) instead
   of fmi2FreeFMUstate(c, &state)); fmi2FreeFMUstate frees such a state all the same. */
static int state_index(const sr_instance *inst, const void *s) {
    for (int i = 0; s && i < inst->nstates; ++i)
        if (inst->states[i] == s) return i;
    return -1;
}

static int remember_state(sr_instance *inst, void *s) {
    if (inst->nstates == inst->cap_states) {
        int cap = inst->cap_states ? 2 * inst->cap_states : 8;
        void **more = realloc(inst->states, (size_t)cap * sizeof *more);
        if (!more) return 1;
        inst->states = more;
        inst->cap_states = cap;
    }
    inst->states[inst->nstates++] = s;
    return 0;
}

static void forget_state(sr_instance *inst, int i) {
    free(inst->states[i]);
    inst->states[i] = inst->states[--inst->nstates];
}

static void save_into(sr_instance *inst, saved_state *s) {
    unsigned char *p = s->bytes;
    int with_model = has_core(inst);
    memset(&s->h, 0, sizeof s->h);
    s->h.magic = STATE_MAGIC;
    s->h.version = STATE_VERSION;
    s->h.nvars = (uint64_t)inst->nvars;
    s->h.has_model = (uint64_t)with_model;
    s->h.model_size = with_model ? (uint64_t)sr_model_state_size(inst->model) : 0u;
    s->h.phase = (int32_t)inst->phase;
    s->h.time = inst->time;
    memcpy(p, inst->real, (size_t)inst->nvars * sizeof(double));
    p += (size_t)inst->nvars * sizeof(double);
    memcpy(p, inst->integer, (size_t)inst->nvars * sizeof(int));
    p = s->bytes + values_size(inst);
    if (with_model) sr_model_state_save(inst->model, p);
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    sr_instance *inst = c;
    saved_state *s;
    if (!inst) return fmi2Error;
    if (!state) return refuse(inst, "fmi2GetFMUstate: state is NULL");
    /* a state of ours given back is overwritten (reallocated to the size needed); anything
       else in *state is not read: a new state */
    s = state_index(inst, *state) >= 0 ? *state : NULL;
    if (s && stored_size(inst, s) != current_size(inst)) {
        saved_state *bigger = realloc(s, current_size(inst));
        if (!bigger) return refuse(inst, "fmi2GetFMUstate: out of memory");
        inst->states[state_index(inst, s)] = bigger;
        s = bigger;
    } else if (!s) {
        s = calloc(1, current_size(inst));
        if (!s) return refuse(inst, "fmi2GetFMUstate: out of memory");
        if (remember_state(inst, s)) {
            free(s);
            return refuse(inst, "fmi2GetFMUstate: out of memory");
        }
    }
    save_into(inst, s);
    *state = s;
    return fmi2OK;
}

/* a state's header is consistent with this instance (and its bytes with `size`, if given) */
static const char *state_mismatch(sr_instance *inst, const saved_state *s, size_t size) {
    if (!s || (!size && state_index(inst, s) < 0)) return "not a state of this instance (freed?)";
    if (s->h.magic != STATE_MAGIC) return "not a state of this FMU";
    if (s->h.version != STATE_VERSION) return "a state of another version of this FMU";
    if (s->h.nvars != (uint64_t)inst->nvars) return "a state of an FMU with other variables";
    if (s->h.phase < PHASE_INSTANTIATED || s->h.phase > PHASE_TERMINATED) return "a damaged state";
    if (s->h.has_model > 1 || s->h.model_size > (1u << 30) || (!s->h.has_model && s->h.model_size))
        return "a damaged state";
    /* save_into stores the model exactly in the phases that have one (has_core): a state that
       says otherwise would leave a stepping instance without its core */
    if (s->h.has_model != (uint64_t)(s->h.phase == PHASE_STEP || s->h.phase == PHASE_TERMINATED))
        return "a damaged state";
    if (size && size != stored_size(inst, s)) return "a state of the wrong size";
    return NULL;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    sr_instance *inst = c;
    const saved_state *s = state;
    const char *why;
    double *real_before;
    int *int_before;
    const unsigned char *p;
    if (!inst) return fmi2Error;
    if ((why = state_mismatch(inst, s, 0)) != NULL) return refuse(inst, "fmi2SetFMUstate: %s", why);
    p = s->bytes;
    real_before = malloc((size_t)inst->nvars * sizeof(double));
    int_before = malloc((size_t)inst->nvars * sizeof(int));
    if (!real_before || !int_before) {
        free(real_before); free(int_before);
        return refuse(inst, "fmi2SetFMUstate: out of memory");
    }
    memcpy(real_before, inst->real, (size_t)inst->nvars * sizeof(double));
    memcpy(int_before, inst->integer, (size_t)inst->nvars * sizeof(int));
    memcpy(inst->real, p, (size_t)inst->nvars * sizeof(double));
    p += (size_t)inst->nvars * sizeof(double);
    memcpy(inst->integer, p, (size_t)inst->nvars * sizeof(int));
    p = s->bytes + values_size(inst);
    if (s->h.has_model) {
        /* the core is rebuilt from the state's parameters, then takes its block */
        if (sr_model_state_load(inst->model, inst, p, (size_t)s->h.model_size) != 0) {
            memcpy(inst->real, real_before, (size_t)inst->nvars * sizeof(double));
            memcpy(inst->integer, int_before, (size_t)inst->nvars * sizeof(int));
            free(real_before); free(int_before);
            return fmi2Error;
        }
    } else {
        sr_model_reset(inst->model);
    }
    free(real_before); free(int_before);
    inst->phase = (phase_t)s->h.phase;
    inst->time = s->h.time;
    inst->preview_dirty = 1;
    inst->outputs_dirty = 1;
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    sr_instance *inst = c;
    int i;
    if (!inst) return fmi2Error;
    if (!state) return fmi2OK;
    if ((i = state_index(inst, state)) >= 0) {      /* the state itself (fmusim 0.0.39) */
        forget_state(inst, i);
        return fmi2OK;
    }
    if (!*state) return fmi2OK;
    if ((i = state_index(inst, *state)) < 0)
        return refuse(inst, "fmi2FreeFMUstate: not a state of this instance (freed already?)");
    forget_state(inst, i);
    *state = NULL;
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    sr_instance *inst = c;
    const saved_state *s = state;
    const char *why;
    if (!inst) return fmi2Error;
    if (!size) return refuse(inst, "fmi2SerializedFMUstateSize: size is NULL");
    if ((why = state_mismatch(inst, s, 0)) != NULL)
        return refuse(inst, "fmi2SerializedFMUstateSize: %s", why);
    *size = stored_size(inst, s);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    sr_instance *inst = c;
    size_t need;
    if (!inst) return fmi2Error;
    if (fmi2SerializedFMUstateSize(c, state, &need) != fmi2OK) return fmi2Error;
    if (!bytes || size < need)
        return refuse(inst, "fmi2SerializeFMUstate: the buffer holds %lu bytes, %lu needed",
                      (unsigned long)size, (unsigned long)need);   /* msvcrt knows no %zu */
    memcpy(bytes, state, need);
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    sr_instance *inst = c;
    saved_state *s;
    const char *why;
    if (!inst) return fmi2Error;
    if (!bytes || !state || size < sizeof(saved_state))
        return refuse(inst, "fmi2DeSerializeFMUstate: not a serialised state of this FMU");
    s = malloc(size);
    if (!s) return refuse(inst, "fmi2DeSerializeFMUstate: out of memory");
    memcpy(s, bytes, size);
    if ((why = state_mismatch(inst, s, size)) != NULL || remember_state(inst, s)) {
        free(s);
        return refuse(inst, "fmi2DeSerializeFMUstate: %s", why ? why : "out of memory");
    }
    *state = s;                      /* a new state: *state on entry is not read */
    return fmi2OK;
}
