/*
 * fmi2_api.c -- the FMI 2.0 co-simulation functions of the native FMUs: thin wrappers over the
 * version-independent layer (fmi_layer.c). Built with -DFMI_VERSION=2 (native/build.py).
 *
 * Every fmi2 function a co-simulation FMU exports is here; what the FMU does not offer (model
 * exchange, Boolean and String variables, input/output derivatives, directional derivatives,
 * asynchronous steps) is refused with fmi2Error and a logged reason.
 */
#include "fmi2.h"
#include "fmi_layer.h"

#if FMI_VERSION != 2
#  error "fmi2_api.c is the FMI 2.0 API: build it with -DFMI_VERSION=2"
#endif

#define MSG_MAX 1024

/* The FMI 2.0 logger takes a printf format: the message is passed as the format with every '%'
   doubled, so that a host that formats it prints the text, and one that cannot read C varargs
   (a ctypes logger, e.g. fmpy's) still gets it. */
static void emit2(const sr_instance *inst, int status, const char *category, const char *msg) {
    char fmt_msg[2 * MSG_MAX];
    size_t i, o = 0;
    fmi2CallbackLogger logger = (fmi2CallbackLogger)inst->logger;
    for (i = 0; msg[i] && o + 2 < sizeof fmt_msg; ++i) {
        if (msg[i] == '%') fmt_msg[o++] = '%';
        fmt_msg[o++] = msg[i];
    }
    fmt_msg[o] = '\0';
    logger(inst->env, inst->name, (fmi2Status)status, category, fmt_msg);
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
    inst = sr_fmi_new(instanceName, loggingOn != fmi2False, emit2,
                      (sr_host_logger)functions->logger, functions->componentEnvironment);
    if (!inst) return NULL;
    if (!instanceName || !instanceName[0]) {
        sr_fmi_refuse(inst, "fmi2Instantiate: an instance name is required");
        sr_fmi_free(inst);
        return NULL;
    }
    if (fmuType != fmi2CoSimulation) {
        sr_fmi_refuse(inst, "fmi2Instantiate: %s implements co-simulation only", SR_MODEL_IDENTIFIER);
        sr_fmi_free(inst);
        return NULL;
    }
    if (sr_fmi_resource_dir(fmuResourceLocation, 0, resources, sizeof resources)) {
        sr_fmi_refuse(inst, "fmi2Instantiate: the resource location %s is not a file URI",
                      fmuResourceLocation ? fmuResourceLocation : "(null)");
        sr_fmi_free(inst);
        return NULL;
    }
    if (sr_fmi_load(inst, fmuGUID, resources)) {
        sr_fmi_free(inst);
        return NULL;
    }
    return inst;
}

void fmi2FreeInstance(fmi2Component c) { sr_fmi_free((sr_instance *)c); }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[]) {
    if (!c) return fmi2Error;
    return (fmi2Status)sr_fmi_set_debug_logging(c, "fmi2SetDebugLogging", loggingOn != fmi2False,
                                                nCategories, categories);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    return c ? (fmi2Status)sr_fmi_setup(c, startTime) : fmi2Error;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    return c ? (fmi2Status)sr_fmi_enter_initialization(c, 0, 0.0) : fmi2Error;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    return c ? (fmi2Status)sr_fmi_exit_initialization(c) : fmi2Error;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    return c ? (fmi2Status)sr_fmi_terminate(c) : fmi2Error;
}

fmi2Status fmi2Reset(fmi2Component c) {
    return c ? (fmi2Status)sr_fmi_reset(c) : fmi2Error;
}

/* ---- get / set ------------------------------------------------------------------------------- */
fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
    return c ? (fmi2Status)sr_fmi_get_real(c, "fmi2GetReal", vr, nvr, value) : fmi2Error;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
    return c ? (fmi2Status)sr_fmi_get_integer(c, "fmi2GetInteger", vr, nvr, value) : fmi2Error;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
    return c ? (fmi2Status)sr_fmi_set_real(c, "fmi2SetReal", vr, nvr, value) : fmi2Error;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
    return c ? (fmi2Status)sr_fmi_set_integer(c, "fmi2SetInteger", vr, nvr, value) : fmi2Error;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
    (void)vr; (void)value;
    return c ? (fmi2Status)sr_fmi_no_such_type(c, "fmi2GetBoolean", nvr) : fmi2Error;
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
    (void)vr; (void)value;
    return c ? (fmi2Status)sr_fmi_no_such_type(c, "fmi2GetString", nvr) : fmi2Error;
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
    (void)vr; (void)value;
    return c ? (fmi2Status)sr_fmi_no_such_type(c, "fmi2SetBoolean", nvr) : fmi2Error;
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
    (void)vr; (void)value;
    return c ? (fmi2Status)sr_fmi_no_such_type(c, "fmi2SetString", nvr) : fmi2Error;
}

/* ---- stepping ------------------------------------------------------------------------------- */
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    (void)noSetFMUStatePriorToCurrentPoint;
    return c ? (fmi2Status)sr_fmi_do_step(c, t, h) : fmi2Error;
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    return c ? (fmi2Status)sr_fmi_refuse(c, "fmi2CancelStep: steps are synchronous "
                                         "(canRunAsynchronuously is false)")
             : fmi2Error;
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    if (!c) return fmi2Error;
    return nvr ? (fmi2Status)sr_fmi_refuse(c, "fmi2SetRealInputDerivatives: canInterpolateInputs "
                                           "is false") : fmi2OK;
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    (void)vr; (void)order; (void)value;
    if (!c) return fmi2Error;
    return nvr ? (fmi2Status)sr_fmi_refuse(c, "fmi2GetRealOutputDerivatives: "
                                           "maxOutputDerivativeOrder is 0") : fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    return c ? (fmi2Status)sr_fmi_refuse(c, "fmi2GetDirectionalDerivative: "
                                         "providesDirectionalDerivative is false")
             : fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    (void)s; (void)value;
    return c ? (fmi2Status)sr_fmi_refuse(c, "fmi2GetStatus: steps are synchronous; there is no "
                                         "pending status")
             : fmi2Error;
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    if (s == fmi2LastSuccessfulTime && value) {
        *value = inst->time;
        return fmi2OK;
    }
    return (fmi2Status)sr_fmi_refuse(inst, "fmi2GetRealStatus: only fmi2LastSuccessfulTime is "
                                     "available");
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    (void)s; (void)value;
    return c ? (fmi2Status)sr_fmi_refuse(c, "fmi2GetIntegerStatus: no integer status is defined")
             : fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    sr_instance *inst = c;
    if (!inst) return fmi2Error;
    if (s == fmi2Terminated && value) {
        *value = fmi2False;                         /* the FMU never asks to stop */
        return fmi2OK;
    }
    return (fmi2Status)sr_fmi_refuse(inst, "fmi2GetBooleanStatus: only fmi2Terminated is "
                                     "available");
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    (void)s; (void)value;
    return c ? (fmi2Status)sr_fmi_refuse(c, "fmi2GetStringStatus: no string status is defined")
             : fmi2Error;
}

/* ---- FMU state -------------------------------------------------------------------------------- */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    return c ? (fmi2Status)sr_fmi_get_state(c, "fmi2GetFMUstate", state) : fmi2Error;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    return c ? (fmi2Status)sr_fmi_set_state(c, "fmi2SetFMUstate", state) : fmi2Error;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    return c ? (fmi2Status)sr_fmi_free_state(c, "fmi2FreeFMUstate", state) : fmi2Error;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    return c ? (fmi2Status)sr_fmi_serialized_size(c, "fmi2SerializedFMUstateSize", state, size)
             : fmi2Error;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[], size_t size) {
    return c ? (fmi2Status)sr_fmi_serialize(c, "fmi2SerializeFMUstate", state, bytes, size)
             : fmi2Error;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size, fmi2FMUstate *state) {
    return c ? (fmi2Status)sr_fmi_deserialize(c, "fmi2DeSerializeFMUstate", bytes, size, state)
             : fmi2Error;
}
