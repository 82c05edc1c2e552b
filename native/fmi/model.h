/*
 * model.h -- the contract between the shared FMI layer (fmi_layer.c, with the thin API files
 * fmi2_api.c for FMI 2.0 and fmi3_api.c for FMI 3.0) and one model's glue
 * (fmu_<model>/<model>.c), in the manner of the Reference FMUs: the layer implements every FMI
 * function (lifecycle, checks, logging, variable storage, FMU state); the glue only maps
 * variables to the numerical core and knows nothing of the FMI version.
 *
 * The variables are data: <resources>/spacerobot_variables.txt, generated from
 * spacerobot/interface.py (the one table of every FMU variable) by spacerobot/fmi/native.py,
 * lists each variable's value reference, type, causality, variability, start value, core key
 * and name. The layer keeps every value in an array indexed by value reference; the glue looks
 * the keys it needs up once (sr_key_vr) and reads parameters and inputs, writes outputs there.
 */
#ifndef SR_FMI_MODEL_H
#define SR_FMI_MODEL_H

#include <stddef.h>

typedef enum { SR_REAL, SR_INTEGER } sr_type;
typedef enum { SR_PARAMETER, SR_INPUT, SR_OUTPUT } sr_causality;
typedef enum { SR_FIXED, SR_TUNABLE, SR_CONTINUOUS, SR_DISCRETE } sr_variability;
typedef enum { SR_LOG_EVENTS, SR_LOG_WARNING, SR_LOG_ERROR, SR_LOG_DISCARD, SR_LOG_ALL } sr_log_category;

#define SR_VAR_NAME_MAX 96
#define SR_VAR_KEY_MAX 48

typedef struct sr_var {
    char name[SR_VAR_NAME_MAX];        /* FMI name, e.g. "base.r[1]" */
    char key[SR_VAR_KEY_MAX];          /* core key, e.g. "r_S[0]" */
    sr_type type;
    sr_causality causality;
    sr_variability variability;
    double start;                  /* start value (Integer variables: an exact integer) */
} sr_var;

typedef struct sr_instance sr_instance;

/* ---- what the layer offers the glue ---------------------------------------------------------- */
/* Value reference of the variable with core key `key`, or -1 (logged as an error when `required`). */
int sr_key_vr(sr_instance *inst, const char *key, int required);
/* The value of the Real variable with core key `key`, NaN if there is none (logged as an
   error when `required`). */
double sr_key_real(sr_instance *inst, const char *key, int required);
/* Values by value reference: Real variables in real[], Integer variables in integer[]. */
double *sr_reals(sr_instance *inst);
int *sr_integers(sr_instance *inst);
const sr_var *sr_variable(const sr_instance *inst, int vr);
/* The value of `key` in the resource file <resource_dir><file> (lines "key 0x<IEEE-754 bits>",
   e.g. resources/scenario.txt). 0 ok; else 1, logged as an error. */
int sr_resource_double(sr_instance *inst, const char *resource_dir, const char *file,
                       const char *key, double *out);
/* The instance's log (printf-like; categories as in the model description). */
void sr_log(sr_instance *inst, sr_log_category category, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* ---- what each model's glue implements ----------------------------------------------------- */
/* The model identifier (the binary's file name without suffix). */
extern const char *const SR_MODEL_IDENTIFIER;
/* Read the model's own resources (resource_dir: a local folder path, '/'-terminated); bind keys.
   NULL on failure (logged). */
void *sr_model_new(sr_instance *inst, const char *resource_dir);
void sr_model_free(void *model);
/* Back to the state after sr_model_new (Reset; the layer restores the start values). */
void sr_model_reset(void *model);
/* ExitInitializationMode: check the parameters, build the core, set the initial outputs.
   0 ok; else the reason is logged as an error and nothing changed. */
int sr_model_initialize(void *model, sr_instance *inst);
/* In initialisation mode, outputs read before ExitInitializationMode: the initial outputs for the
   parameters set so far (nothing changes where they are not valid yet). */
void sr_model_preview(void *model, sr_instance *inst);
/* Direct feedthrough: nonzero when outputs depend on the current inputs (the layer then calls
   sr_model_outputs before an output is read after an input, the state or the time changed). */
extern const int SR_MODEL_FEEDTHROUGH;
/* Stepping mode, SR_MODEL_FEEDTHROUGH models: the outputs for the current inputs and state
   (the state does not change). Other models: never called. */
void sr_model_outputs(void *model, sr_instance *inst);
/* The longest communication step the model takes [s] (INFINITY: no limit); the layer refuses
   longer ones with Discard. */
extern const double SR_MODEL_MAX_STEP;
/* One communication step from t by h (checked by the layer: t finite and the instance's time, h
   finite and in (0, SR_MODEL_MAX_STEP]).
   0 ok, 1 discard (reason logged; the state must be as before the call). */
int sr_model_do_step(void *model, sr_instance *inst, double t, double h);
/* The core's state as a flat block of sr_model_state_size bytes (no pointers), and back. */
size_t sr_model_state_size(void *model);
void sr_model_state_save(void *model, void *buf);
/* 0 ok; else logged (e.g. a state of another robot) and nothing changed. */
int sr_model_state_load(void *model, sr_instance *inst, const void *buf, size_t size);

#endif
