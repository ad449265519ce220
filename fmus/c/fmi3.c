/*
 * satfmu: the FMI 3.0 co-simulation interface of a model generated from a symbolic definition
 * (fmus/model.py); fmi2_cosim.c is its FMI 2.0 interface. Everything that does not depend on the
 * interface (time, sampling, integration, variable checks, FMU state records) is in
 * satfmu_core.h, which includes the generated model.h, and what FMI 3.0's interfaces share
 * (variable access, the clock's functions, instantiation) in fmi3_common.h; fmi3_me.c is a plant's
 * FMI 3.0 model-exchange interface. This file is the FMU's only translation unit
 * (sources/buildDescription.xml lists it). Written for this project.
 *
 * Variables: value reference 0 is the independent variable time; 1 .. NA the model's variables,
 * its vectors as arrays (ARRAYS in model.h: the first element's row of VARIABLES and the size;
 * satfmu.fmus.arrays groups them), whose values fmi3Get/SetFloat64, Int32 and Boolean read and
 * write in element order, nValues counting every element; CLOCK_VR (NA + 1), for a sampled model
 * (NH > 0), its sample clock.
 *
 * Sample clock: an input, periodic Clock with intervalVariability "fixed" (its period and shift
 * depend on the fixed parameters, so the importer reads them with fmi3GetIntervalDecimal and
 * fmi3GetShiftDecimal in Initialization Mode: the period, and the first instant after the start
 * time minus the start time). An instance instantiated with eventModeUsed is clocked (see
 * satfmu_core.h): the importer ends a step at each instant, enters Event Mode, sets the inputs,
 * activates the clock with fmi3SetClock and calls fmi3UpdateDiscreteStates, which takes the
 * sample and returns the next instant as nextEventTime. Without event mode (eventModeUsed false,
 * which the standard asks of an importer of a clocked FMU but many co-simulation importers
 * cannot do), the instance samples inside its steps as the FMI 2.0 FMU does, with its results.
 *
 * Robustness: as fmi2_cosim.c (call order against the FMI 3.0 co-simulation state machine, value
 * references, types, nValues, finiteness, ranges; a refused call changes nothing; no non-finite
 * output with fmi3OK). Model exchange (a file of its own) and scheduled execution are not provided
 * (their instantiation returns NULL with a message).
 */
#define STEP_STATE_NAME "StepMode"

#include "fmi3_common.h"

/* The event's discrete update (fmi3UpdateDiscreteStates, fmi3EnterStepMode): a due sample is
 * taken from the inputs set so far; the clock is deactivated. */
static int update_discrete(Instance *inst) {
    Data *d = &inst->d;
    if (d->sample_due && !sample(inst)) return STATUS_ERROR;
    d->clock_active = 0;
    d->inputs_stale = 0;
    return STATUS_OK;
}

/* ------------------------------------------------------------------ FMI API: co-simulation */
fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    Instance *inst;
    (void)resourcePath;
    (void)visible;
    (void)requiredIntermediateVariables;
    (void)intermediateUpdate;
    if (nRequiredIntermediateVariables > 0) {
        Instance tmp = logging_only(instanceName, logMessage, instanceEnvironment);
        log_msg(&tmp, STATUS_ERROR, "logStatusError", "fmi3InstantiateCoSimulation: this FMU provides no "
                "intermediate update (providesIntermediateUpdate=false), so no intermediate variables");
        return NULL;
    }
    inst = instantiate("fmi3InstantiateCoSimulation", instanceName, instantiationToken, loggingOn,
                       eventModeUsed && NH > 0, instanceEnvironment, logMessage);
    if (!inst) return NULL;
    inst->event_mode_used = eventModeUsed ? 1 : 0;
    inst->early_return_allowed = earlyReturnAllowed ? 1 : 0;
    return inst;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    Instance tmp = logging_only(instanceName, logMessage, instanceEnvironment);
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn;
    log_msg(&tmp, STATUS_ERROR, "logStatusError", "fmi3InstantiateModelExchange: this FMU supports co-simulation "
            "only (a plant's model-exchange FMU is a file of its own, <plant>_me_fmi3.fmu)");
    return NULL;
}

/* Event Mode when the importer uses it (eventModeUsed), else Step Mode. */
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    CHECK(c, "fmi3ExitInitializationMode", ST_INITIALIZATION);
    if (exit_initialization(inst, "fmi3ExitInitializationMode") != STATUS_OK) return fmi3Error;
    inst->d.state = inst->event_mode_used ? ST_EVENT : ST_STEP_COMPLETE;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance c) {
    CHECK(c, "fmi3EnterEventMode", ST_STEP_COMPLETE);
    if (!inst->event_mode_used)
        return ERROR(inst, "fmi3EnterEventMode: the instance was instantiated with eventModeUsed = false");
    inst->d.state = ST_EVENT;
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance c) {
    CHECK(c, "fmi3EnterStepMode", ST_EVENT);
    if (update_discrete(inst) != STATUS_OK) return fmi3Error;
    inst->d.state = ST_STEP_COMPLETE;
    return fmi3OK;
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    CHECK(c, "fmi3UpdateDiscreteStates", ST_EVENT);
    if (!discreteStatesNeedUpdate || !terminateSimulation || !nominalsOfContinuousStatesChanged ||
        !valuesOfContinuousStatesChanged || !nextEventTimeDefined || !nextEventTime)
        return ERROR(inst, "fmi3UpdateDiscreteStates: NULL result pointer");
    if (update_discrete(inst) != STATUS_OK) return fmi3Error;
    *discreteStatesNeedUpdate = false;
    *terminateSimulation = false;
    *nominalsOfContinuousStatesChanged = false;
    *valuesOfContinuousStatesChanged = false;
    *nextEventTimeDefined = inst->d.clocked != 0;
    *nextEventTime = inst->d.clocked ? instant_time(&inst->d, inst->d.next_k) : 0.0;
    return fmi3OK;
}

/* ------------------------------------------------------------------ FMU state */
fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *FMUState) {
    CHECK(c, "fmi3GetFMUState", STATE_MASK);
    return (fmi3Status)state_get(inst, FMUState, "fmi3GetFMUState");
}
fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState FMUState) {
    CHECK(c, "fmi3SetFMUState", STATE_MASK);
    return (fmi3Status)state_set(inst, FMUState, "fmi3SetFMUState");
}
fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *FMUState) {
    CHECK(c, "fmi3FreeFMUState", STATE_MASK);
    state_free(FMUState);
    return fmi3OK;
}
fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState FMUState, size_t *size) {
    CHECK(c, "fmi3SerializedFMUStateSize", STATE_MASK);
    return (fmi3Status)state_size(inst, FMUState, size, "fmi3SerializedFMUStateSize");
}
fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size) {
    CHECK(c, "fmi3SerializeFMUState", STATE_MASK);
    return (fmi3Status)state_serialize(inst, FMUState, serializedState, size, "fmi3SerializeFMUState");
}
fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    CHECK(c, "fmi3DeserializeFMUState", STATE_MASK);
    return (fmi3Status)state_deserialize(inst, serializedState, size, FMUState, "fmi3DeserializeFMUState");
}

/* ------------------------------------------------------------------ co-simulation */
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    int early = 0;
    fmi3Status status;
    CHECK(c, "fmi3DoStep", ST_STEP_COMPLETE);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)
        return ERROR(inst, "fmi3DoStep: NULL result pointer");
    status = (fmi3Status)do_step(inst, currentCommunicationPoint, communicationStepSize,
                                 inst->early_return_allowed, &early, "fmi3DoStep");
    *eventHandlingNeeded = early != 0;
    *terminateSimulation = false;
    *earlyReturn = early != 0;
    *lastSuccessfulTime = inst->d.time;
    return status;
}

/* ------------------------------------------------------------------ not this FMU's interfaces */
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) {
    NOT_PROVIDED(fmi3EnterContinuousTimeMode, "co-simulation only");
}
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    (void)noSetFMUStatePriorToCurrentPoint; (void)enterEventMode; (void)terminateSimulation;
    NOT_PROVIDED(fmi3CompletedIntegratorStep, "co-simulation only");
}
fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 time) {
    (void)time;
    NOT_PROVIDED(fmi3SetTime, "co-simulation only");
}
fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 continuousStates[], size_t nContinuousStates) {
    (void)continuousStates; (void)nContinuousStates;
    NOT_PROVIDED(fmi3SetContinuousStates, "co-simulation only");
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 derivatives[], size_t nContinuousStates) {
    (void)derivatives; (void)nContinuousStates;
    NOT_PROVIDED(fmi3GetContinuousStateDerivatives, "co-simulation only");
}
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    (void)eventIndicators; (void)nEventIndicators;
    NOT_PROVIDED(fmi3GetEventIndicators, "co-simulation only");
}
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 continuousStates[], size_t nContinuousStates) {
    (void)continuousStates; (void)nContinuousStates;
    NOT_PROVIDED(fmi3GetContinuousStates, "co-simulation only");
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 nominals[], size_t nContinuousStates) {
    (void)nominals; (void)nContinuousStates;
    NOT_PROVIDED(fmi3GetNominalsOfContinuousStates, "co-simulation only");
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *nEventIndicators) {
    (void)nEventIndicators;
    NOT_PROVIDED(fmi3GetNumberOfEventIndicators, "co-simulation only");
}
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *nContinuousStates) {
    (void)nContinuousStates;
    NOT_PROVIDED(fmi3GetNumberOfContinuousStates, "co-simulation only");
}
