/*
 * fmi3_api.c -- the FMI 3.0 functions of the native FMUs: thin wrappers over the
 * version-independent layer (fmi_layer.c). Built with -DFMI_VERSION=3 (native/build.py).
 *
 * Co-simulation without event mode: fmi3InstantiateCoSimulation, Float64 and Int32 variables
 * (scalars: nValues must equal nValueReferences), initialisation, fmi3DoStep, FMU state
 * get/set/serialise, reset, terminate. Every other function of the standard is exported too (a
 * host may look them all up) and refuses with fmi3Error and a logged reason: model exchange,
 * scheduled execution, event and configuration mode, clocks, other variable types, derivatives,
 * per-element dependencies. The model description claims none of these.
 */
#include "fmi3.h"
#include "fmi_layer.h"
#include "sr_text.h"

#if FMI_VERSION != 3
#  error "fmi3_api.c is the FMI 3.0 API: build it with -DFMI_VERSION=3"
#endif

static void emit3(const sr_instance *inst, int status, const char *category, const char *msg) {
    fmi3LogMessageCallback host_log = (fmi3LogMessageCallback)inst->logger;
    host_log(inst->env, (fmi3Status)status, category, msg);  /* FMI 3.0: a plain message */
}

#define REFUSE(c, ...) ((c) ? (fmi3Status)sr_fmi_refuse((c), __VA_ARGS__) : fmi3Error)
#define WRAP(c, call) ((c) ? (fmi3Status)(call) : fmi3Error)

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[]) {
    return WRAP(instance, sr_fmi_set_debug_logging(instance, "fmi3SetDebugLogging", loggingOn,
                                                   nCategories, categories));
}

/* a refusal before there is an instance: straight to the host's logger */
static void log_without_instance(fmi3InstanceEnvironment env, fmi3LogMessageCallback logMessage,
                                 const char *call) {
    char msg[256];
    if (!logMessage) return;
    sr_text_format(msg, sizeof msg, "%s: %s implements co-simulation only "
                   "(fmi3InstantiateCoSimulation)", call, SR_MODEL_IDENTIFIER);
    logMessage(env, fmi3Error, "logStatusError", msg);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    log_without_instance(instanceEnvironment, logMessage, "fmi3InstantiateModelExchange");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption) {
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    log_without_instance(instanceEnvironment, logMessage, "fmi3InstantiateScheduledExecution");
    return NULL;
}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate) {
    char resources[4096];
    sr_instance *inst;
    (void)visible; (void)earlyReturnAllowed;   /* steps never return early: allowed or not */
    (void)requiredIntermediateVariables; (void)intermediateUpdate;
    inst = sr_fmi_new(instanceName, loggingOn, logMessage ? emit3 : NULL,
                      (sr_host_logger)logMessage, instanceEnvironment);
    if (!inst) return NULL;
    if (!instanceName || !instanceName[0]) {
        sr_fmi_refuse(inst, "fmi3InstantiateCoSimulation: an instance name is required");
    } else if (eventModeUsed) {
        sr_fmi_refuse(inst, "fmi3InstantiateCoSimulation: eventModeUsed is true, but %s has no "
                      "event mode (hasEventMode is false)", SR_MODEL_IDENTIFIER);
    } else if (nRequiredIntermediateVariables > 0) {
        sr_fmi_refuse(inst, "fmi3InstantiateCoSimulation: %lu required intermediate variables, "
                      "but %s provides no intermediate update (providesIntermediateUpdate is "
                      "false)", (unsigned long)nRequiredIntermediateVariables, SR_MODEL_IDENTIFIER);
    } else if (sr_fmi_resource_dir(resourcePath, 1, resources, sizeof resources)) {
        sr_fmi_refuse(inst, "fmi3InstantiateCoSimulation: the resource path %s is not a folder "
                      "path (%s needs its resources)", resourcePath ? resourcePath : "(null)",
                      SR_MODEL_IDENTIFIER);
    } else if (sr_fmi_load(inst, instantiationToken, resources) == 0) {
        return inst;
    }
    sr_fmi_free(inst);
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) { sr_fmi_free((sr_instance *)instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    return WRAP(instance, sr_fmi_enter_initialization(instance, 1, startTime));
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    return WRAP(instance, sr_fmi_exit_initialization(instance));
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    return REFUSE(instance, "fmi3EnterEventMode: %s has no event mode (hasEventMode is false)",
                  SR_MODEL_IDENTIFIER);
}

fmi3Status fmi3Terminate(fmi3Instance instance) { return WRAP(instance, sr_fmi_terminate(instance)); }

fmi3Status fmi3Reset(fmi3Instance instance) { return WRAP(instance, sr_fmi_reset(instance)); }

/* ---- get / set ------------------------------------------------------------------------------- */
/* The FMU's variables are scalars: nValues must equal nValueReferences. 0 ok. */
static int scalar_counts(sr_instance *inst, const char *call, size_t nvr, size_t nvalues) {
    if (nvr == nvalues) return 0;
    sr_fmi_refuse(inst, "%s: nValues (%lu) differs from nValueReferences (%lu); every variable "
                  "of %s is a scalar", call, (unsigned long)nvalues, (unsigned long)nvr,
                  SR_MODEL_IDENTIFIER);
    return 1;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues) {
    if (!instance) return fmi3Error;
    if (scalar_counts(instance, "fmi3GetFloat64", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)sr_fmi_get_real(instance, "fmi3GetFloat64", valueReferences,
                                       nValueReferences, values);
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues) {
    if (!instance) return fmi3Error;
    if (scalar_counts(instance, "fmi3SetFloat64", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)sr_fmi_set_real(instance, "fmi3SetFloat64", valueReferences,
                                       nValueReferences, values);
}

fmi3Status fmi3GetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Int32 values[], size_t nValues) {
    if (!instance) return fmi3Error;
    if (scalar_counts(instance, "fmi3GetInt32", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)sr_fmi_get_integer(instance, "fmi3GetInt32", valueReferences,
                                          nValueReferences, values);
}

fmi3Status fmi3SetInt32(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Int32 values[], size_t nValues) {
    if (!instance) return fmi3Error;
    if (scalar_counts(instance, "fmi3SetInt32", nValueReferences, nValues)) return fmi3Error;
    return (fmi3Status)sr_fmi_set_integer(instance, "fmi3SetInt32", valueReferences,
                                          nValueReferences, values);
}

/* the types the FMU has no variables of: refused unless nothing is asked */
#define NO_SUCH_TYPE(T)                                                                          \
    fmi3Status fmi3Get##T(fmi3Instance instance, const fmi3ValueReference valueReferences[],     \
                          size_t nValueReferences, fmi3##T values[], size_t nValues) {          \
        (void)valueReferences; (void)values; (void)nValues;                                     \
        return WRAP(instance, sr_fmi_no_such_type(instance, "fmi3Get" #T, nValueReferences));    \
    }                                                                                            \
    fmi3Status fmi3Set##T(fmi3Instance instance, const fmi3ValueReference valueReferences[],     \
                          size_t nValueReferences, const fmi3##T values[], size_t nValues) {    \
        (void)valueReferences; (void)values; (void)nValues;                                     \
        return WRAP(instance, sr_fmi_no_such_type(instance, "fmi3Set" #T, nValueReferences));    \
    }
NO_SUCH_TYPE(Float32)
NO_SUCH_TYPE(Int8)
NO_SUCH_TYPE(UInt8)
NO_SUCH_TYPE(Int16)
NO_SUCH_TYPE(UInt16)
NO_SUCH_TYPE(UInt32)
NO_SUCH_TYPE(Int64)
NO_SUCH_TYPE(UInt64)
NO_SUCH_TYPE(Boolean)
NO_SUCH_TYPE(String)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, size_t valueSizes[], fmi3Binary values[],
                         size_t nValues) {
    (void)valueReferences; (void)valueSizes; (void)values; (void)nValues;
    return WRAP(instance, sr_fmi_no_such_type(instance, "fmi3GetBinary", nValueReferences));
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nValues) {
    (void)valueReferences; (void)valueSizes; (void)values; (void)nValues;
    return WRAP(instance, sr_fmi_no_such_type(instance, "fmi3SetBinary", nValueReferences));
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Clock values[]) {
    (void)valueReferences; (void)values;
    return WRAP(instance, sr_fmi_no_such_type(instance, "fmi3GetClock", nValueReferences));
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Clock values[]) {
    (void)valueReferences; (void)values;
    return WRAP(instance, sr_fmi_no_such_type(instance, "fmi3SetClock", nValueReferences));
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance,
                                               fmi3ValueReference valueReference,
                                               size_t *nDependencies) {
    (void)valueReference; (void)nDependencies;
    return REFUSE(instance, "fmi3GetNumberOfVariableDependencies: providesPerElementDependencies "
                  "is false (the model description lists the dependencies)");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[],
                                       fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[], size_t nDependencies) {
    (void)dependent; (void)elementIndicesOfDependent; (void)independents;
    (void)elementIndicesOfIndependents; (void)dependencyKinds; (void)nDependencies;
    return REFUSE(instance, "fmi3GetVariableDependencies: providesPerElementDependencies is "
                  "false (the model description lists the dependencies)");
}

/* ---- FMU state -------------------------------------------------------------------------------- */
fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    return WRAP(instance, sr_fmi_get_state(instance, "fmi3GetFMUState", FMUState));
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState) {
    return WRAP(instance, sr_fmi_set_state(instance, "fmi3SetFMUState", FMUState));
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState) {
    return WRAP(instance, sr_fmi_free_state(instance, "fmi3FreeFMUState", FMUState));
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size) {
    return WRAP(instance, sr_fmi_serialized_size(instance, "fmi3SerializedFMUStateSize", FMUState,
                                                 size));
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size) {
    return WRAP(instance, sr_fmi_serialize(instance, "fmi3SerializeFMUState", FMUState,
                                           serializedState, size));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState) {
    return WRAP(instance, sr_fmi_deserialize(instance, "fmi3DeserializeFMUState", serializedState,
                                             size, FMUState));
}

/* ---- derivatives, configuration, clocks: not offered --------------------------------------- */
fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[],
                                        size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                        fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed;
    (void)sensitivity; (void)nSensitivity;
    return REFUSE(instance, "fmi3GetDirectionalDerivative: providesDirectionalDerivatives is false");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                    size_t nUnknowns, const fmi3ValueReference knowns[],
                                    size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                    fmi3Float64 sensitivity[], size_t nSensitivity) {
    (void)unknowns; (void)nUnknowns; (void)knowns; (void)nKnowns; (void)seed; (void)nSeed;
    (void)sensitivity; (void)nSensitivity;
    return REFUSE(instance, "fmi3GetAdjointDerivative: providesAdjointDerivatives is false");
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return REFUSE(instance, "fmi3EnterConfigurationMode: %s has no structural parameters",
                  SR_MODEL_IDENTIFIER);
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return REFUSE(instance, "fmi3ExitConfigurationMode: %s has no structural parameters",
                  SR_MODEL_IDENTIFIER);
}

#define NO_CLOCKS(instance, call, n) \
    WRAP(instance, sr_fmi_no_such_type(instance, call " (clocks)", n))

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences; (void)intervals; (void)qualifiers;
    return NO_CLOCKS(instance, "fmi3GetIntervalDecimal", nValueReferences);
}

fmi3Status fmi3GetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, fmi3UInt64 counters[],
                                   fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]) {
    (void)valueReferences; (void)counters; (void)resolutions; (void)qualifiers;
    return NO_CLOCKS(instance, "fmi3GetIntervalFraction", nValueReferences);
}

fmi3Status fmi3GetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, fmi3Float64 shifts[]) {
    (void)valueReferences; (void)shifts;
    return NO_CLOCKS(instance, "fmi3GetShiftDecimal", nValueReferences);
}

fmi3Status fmi3GetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, fmi3UInt64 counters[],
                                fmi3UInt64 resolutions[]) {
    (void)valueReferences; (void)counters; (void)resolutions;
    return NO_CLOCKS(instance, "fmi3GetShiftFraction", nValueReferences);
}

fmi3Status fmi3SetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, const fmi3Float64 intervals[]) {
    (void)valueReferences; (void)intervals;
    return NO_CLOCKS(instance, "fmi3SetIntervalDecimal", nValueReferences);
}

fmi3Status fmi3SetIntervalFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                   size_t nValueReferences, const fmi3UInt64 counters[],
                                   const fmi3UInt64 resolutions[]) {
    (void)valueReferences; (void)counters; (void)resolutions;
    return NO_CLOCKS(instance, "fmi3SetIntervalFraction", nValueReferences);
}

fmi3Status fmi3SetShiftDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                               size_t nValueReferences, const fmi3Float64 shifts[]) {
    (void)valueReferences; (void)shifts;
    return NO_CLOCKS(instance, "fmi3SetShiftDecimal", nValueReferences);
}

fmi3Status fmi3SetShiftFraction(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                size_t nValueReferences, const fmi3UInt64 counters[],
                                const fmi3UInt64 resolutions[]) {
    (void)valueReferences; (void)counters; (void)resolutions;
    return NO_CLOCKS(instance, "fmi3SetShiftFraction", nValueReferences);
}

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance) {
    return REFUSE(instance, "fmi3EvaluateDiscreteStates: providesEvaluateDiscreteStates is false");
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation,
                                    fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged,
                                    fmi3Boolean *nextEventTimeDefined, fmi3Float64 *nextEventTime) {
    (void)discreteStatesNeedUpdate; (void)terminateSimulation;
    (void)nominalsOfContinuousStatesChanged; (void)valuesOfContinuousStatesChanged;
    (void)nextEventTimeDefined; (void)nextEventTime;
    return REFUSE(instance, "fmi3UpdateDiscreteStates: %s has no event mode (hasEventMode is "
                  "false)", SR_MODEL_IDENTIFIER);
}

/* ---- model exchange: not offered (the instance is a co-simulation one) ----------------------- */
#define NO_ME(instance, call) \
    REFUSE(instance, call ": %s implements co-simulation only", SR_MODEL_IDENTIFIER)

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance) {
    return NO_ME(instance, "fmi3EnterContinuousTimeMode");
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance,
                                       fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint; (void)enterEventMode; (void)terminateSimulation;
    return NO_ME(instance, "fmi3CompletedIntegratorStep");
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time) {
    (void)time;
    return NO_ME(instance, "fmi3SetTime");
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    (void)continuousStates; (void)nContinuousStates;
    return NO_ME(instance, "fmi3SetContinuousStates");
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates) {
    (void)derivatives; (void)nContinuousStates;
    return NO_ME(instance, "fmi3GetContinuousStateDerivatives");
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[],
                                  size_t nEventIndicators) {
    (void)eventIndicators; (void)nEventIndicators;
    return NO_ME(instance, "fmi3GetEventIndicators");
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[],
                                   size_t nContinuousStates) {
    (void)continuousStates; (void)nContinuousStates;
    return NO_ME(instance, "fmi3GetContinuousStates");
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates) {
    (void)nominals; (void)nContinuousStates;
    return NO_ME(instance, "fmi3GetNominalsOfContinuousStates");
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators) {
    (void)nEventIndicators;
    return NO_ME(instance, "fmi3GetNumberOfEventIndicators");
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates) {
    (void)nContinuousStates;
    return NO_ME(instance, "fmi3GetNumberOfContinuousStates");
}

/* ---- co-simulation ----------------------------------------------------------------------------- */
fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    return REFUSE(instance, "fmi3EnterStepMode: %s has no event mode (hasEventMode is false): "
                  "fmi3ExitInitializationMode enters step mode", SR_MODEL_IDENTIFIER);
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[],
                                    fmi3Float64 values[], size_t nValues) {
    (void)valueReferences; (void)orders; (void)values; (void)nValues;
    if (!instance) return fmi3Error;
    return nValueReferences ? REFUSE(instance, "fmi3GetOutputDerivatives: "
                                     "maxOutputDerivativeOrder is 0") : fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    sr_instance *inst = instance;
    int status;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!inst) return fmi3Error;
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)
        return REFUSE(inst, "fmi3DoStep: an output argument (eventHandlingNeeded, "
                      "terminateSimulation, earlyReturn, lastSuccessfulTime) is NULL");
    status = sr_fmi_do_step(inst, currentCommunicationPoint, communicationStepSize);
    *eventHandlingNeeded = fmi3False;              /* no events */
    *terminateSimulation = fmi3False;              /* the FMU never asks to stop */
    *earlyReturn = fmi3False;                      /* a step is taken whole or not at all */
    *lastSuccessfulTime = inst->time;              /* t + h, or t where the step was refused */
    return (fmi3Status)status;
}

/* ---- scheduled execution: not offered ------------------------------------------------------ */
fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
    (void)clockReference; (void)activationTime;
    return REFUSE(instance, "fmi3ActivateModelPartition: %s implements co-simulation only",
                  SR_MODEL_IDENTIFIER);
}
