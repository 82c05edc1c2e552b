/*
 * fmi_layer.h -- the version-independent part of the FMI layer shared by the native FMUs, and
 * what the thin API files (fmi2_api.c: FMI 2.0, fmi3_api.c: FMI 3.0) call, in the manner of the
 * Reference FMUs. Internal to the layer: a model's glue sees only model.h.
 *
 * One compile-time switch selects the FMI version: -DFMI_VERSION=2 (default) or 3. The build
 * (native/build.py) compiles fmi_layer.c with the model's glue, the core and fmi<V>_api.c. The
 * switch changes only the names of the FMI functions in the log messages.
 *
 * Every function here returns a status with the numbers of fmi2Status and fmi3Status (which are
 * the same for OK, Warning, Discard, Error); a refused call logs its reason and changes nothing.
 */
#ifndef SR_FMI_LAYER_H
#define SR_FMI_LAYER_H

#include <stddef.h>

#include "model.h"

#ifndef FMI_VERSION
#  define FMI_VERSION 2
#endif
#if FMI_VERSION != 2 && FMI_VERSION != 3
#  error "FMI_VERSION must be 2 or 3"
#endif

/* a function's name in the messages of this FMI version: FMI_NAME("SetupExperiment") */
#if FMI_VERSION == 3
#  define FMI_NAME(n) "fmi3" n
#else
#  define FMI_NAME(n) "fmi2" n
#endif

enum { SR_OK = 0, SR_WARNING = 1, SR_DISCARD = 2, SR_ERROR = 3 };

typedef enum { PHASE_INSTANTIATED, PHASE_INITIALIZATION, PHASE_STEP, PHASE_TERMINATED } sr_phase;

/* The host's logger as the API file stored it (cast back there before a call). */
typedef void (*sr_host_logger)(void);
/* Hands one formatted message to the host's logger (one per FMI version, in its API file). */
typedef void (*sr_emit_fn)(const sr_instance *inst, int status, const char *category,
                           const char *message);

struct sr_instance {
    char name[128];
    sr_emit_fn emit;                 /* NULL: no logging */
    sr_host_logger logger;
    void *env;                       /* the host's environment pointer, passed back */
    int log_events;                  /* loggingOn / SetDebugLogging: logEvents, logAll */
    sr_phase phase;
    double time;
    int nvars;
    sr_var *vars;                    /* by value reference */
    double *real;                    /* values by value reference (Real / Float64 variables) */
    int *integer;                    /* values by value reference (Integer / Int32 variables) */
    int preview_dirty;               /* a parameter (feedthrough: or an input) changed in
                                        initialisation mode */
    int outputs_dirty;               /* feedthrough: inputs, state or time changed since the
                                        outputs were computed (stepping mode) */
    void *model;
    void **states;                   /* the FMU states handed out and not freed yet */
    int nstates, cap_states;
};

/* ---- lifecycle ---------------------------------------------------------------------------- */
/* A new instance (not loaded yet): NULL when out of memory. `emit` and `logger` may be NULL. */
sr_instance *sr_fmi_new(const char *name, int logging_on, sr_emit_fn emit, sr_host_logger logger,
                        void *env);
/* Read the variable table of the resources folder `resource_dir` ('/'-terminated local path),
   check the token (GUID / instantiationToken; NULL: not checked), create the model. 0 ok, else
   logged. */
int sr_fmi_load(sr_instance *inst, const char *token, const char *resource_dir);
void sr_fmi_free(sr_instance *inst);
/* "file:///C:/x%20y/" or "file:/x/" (FMI 2.0 resource URI; with `native_path`: also a plain
   path, FMI 3.0's resourcePath, copied as it is) -> a local folder path ending in a separator.
   0 ok. */
int sr_fmi_resource_dir(const char *location, int native_path, char *out, size_t size);
int sr_fmi_set_debug_logging(sr_instance *inst, const char *call, int logging_on,
                             size_t ncategories, const char *const categories[]);
/* FMI 2.0's SetupExperiment (only after instantiation): the start time. */
int sr_fmi_setup(sr_instance *inst, double start_time);
/* EnterInitializationMode; `start_time` taken when `set_start` (FMI 3.0). */
int sr_fmi_enter_initialization(sr_instance *inst, int set_start, double start_time);
int sr_fmi_exit_initialization(sr_instance *inst);
int sr_fmi_terminate(sr_instance *inst);
int sr_fmi_reset(sr_instance *inst);
/* One communication step: SR_OK, SR_DISCARD (logged: a non-finite time, a bad step, the
   model refused, FMI 2.0: a bad phase; the state is as before) or SR_ERROR (logged: a time other
   than the instance's, FMI 3.0: a bad phase; nothing changed). */
int sr_fmi_do_step(sr_instance *inst, double t, double h);

/* ---- variables ---------------------------------------------------------------------------- */
int sr_fmi_get_real(sr_instance *inst, const char *call, const unsigned int vr[], size_t nvr,
                    double value[]);
int sr_fmi_get_integer(sr_instance *inst, const char *call, const unsigned int vr[], size_t nvr,
                       int value[]);
int sr_fmi_set_real(sr_instance *inst, const char *call, const unsigned int vr[], size_t nvr,
                    const double value[]);
int sr_fmi_set_integer(sr_instance *inst, const char *call, const unsigned int vr[], size_t nvr,
                       const int value[]);
/* A get/set of a type the FMU has no variables of: SR_OK for none, else refused. */
int sr_fmi_no_such_type(sr_instance *inst, const char *call, size_t nvr);

/* ---- FMU state (`call`: the function's name for the messages) ------------------------------ */
int sr_fmi_get_state(sr_instance *inst, const char *call, void **state);
int sr_fmi_set_state(sr_instance *inst, const char *call, const void *state);
int sr_fmi_free_state(sr_instance *inst, const char *call, void **state);
int sr_fmi_serialized_size(sr_instance *inst, const char *call, const void *state, size_t *size);
int sr_fmi_serialize(sr_instance *inst, const char *call, const void *state, void *bytes,
                     size_t size);
int sr_fmi_deserialize(sr_instance *inst, const char *call, const void *bytes, size_t size,
                       void **state);

/* ---- logging ------------------------------------------------------------------------------ */
/* Log `fmt` as an error and return SR_ERROR. */
int sr_fmi_refuse(sr_instance *inst, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/* The log category names, by sr_log_category. */
extern const char *const SR_FMI_CATEGORY[5];

#endif
