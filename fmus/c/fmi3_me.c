/*
 * satfmu: the FMI 3.0 model-exchange interface of a plant generated from a symbolic definition
 * (fmus/model.py); fmi2_me.c is its FMI 2.0 interface, fmi3.c its FMI 3.0 co-simulation one. The
 * importer's solver integrates the continuous states; satfmu_me.h gives it the state, its
 * derivatives and the event indicators (fmus/events.py) and handles the events (modes, hysteresis:
 * described there); fmi3_common.h is what this file shares with fmi3.c (variable access as arrays,
 * instantiation, initialization). This file is the FMU's only translation unit
 * (sources/buildDescription.xml lists it). Written for this project.
 *
 * Variables: those of the co-simulation FMU (value reference 0 time, 1 .. NA the model's), then for
 * each group of states that forms an array (STATE_GROUPS in model.h, satfmu.fmus.arrays.state_arrays)
 * its derivatives der(<array>) at NA + 1 + g and, where no output carries them, the states at
 * NA + 1 + NG + g. The continuous-state vector is the model's state in order, the groups' elements
 * one after the other.
 *
 * Robustness: every call checks the instance pointer, the call order against the FMI 3.0
 * model-exchange state machine, value references, types, nValues, finiteness and declared ranges;
 * a violation returns fmi3Error with a message and changes nothing. A non-finite state,
 * derivative, event indicator or output puts the instance in the error state: never returned with
 * fmi3OK. Co-simulation (the file without _me) and scheduled execution are not provided.
 */
#define STEP_STATE_NAME "ContinuousTimeMode"
#define ST_CONTINUOUS ST_STEP_COMPLETE

/* the co-simulation step functions of satfmu_core.h (integration, sampling, FMU state records)
 * are not used by model exchange */
#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wunused-function"
#endif
#include "fmi3_common.h"

#if NH > 0
#error "a sampled model has no model-exchange FMU"
#endif

/* ------------------------------------------------------------------ FMI API: life cycle */
fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
    (void)resourcePath;
    (void)visible;
    return instantiate("fmi3InstantiateModelExchange", instanceName, instantiationToken, loggingOn, 0,
                       instanceEnvironment, logMessage);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
    Instance tmp = logging_only(instanceName, logMessage, instanceEnvironment);
    (void)instantiationToken; (void)resourcePath; (void)visible; (void)loggingOn; (void)eventModeUsed;
    (void)earlyReturnAllowed; (void)requiredIntermediateVariables; (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    log_msg(&tmp, STATUS_ERROR, "logStatusError", "fmi3InstantiateCoSimulation: this FMU supports model exchange "
            "only (the co-simulation FMU of this model is a file of its own, <plant>_fmi3.fmu)");
    return NULL;
}

/* The initial state from the parameters; the mode is the initial state. Event Mode follows. */
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    CHECK(c, "fmi3ExitInitializationMode", ST_INITIALIZATION);
    if (exit_initialization(inst, "fmi3ExitInitializationMode") != STATUS_OK) return fmi3Error;
    me_start(inst);
    inst->d.state = ST_EVENT;
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance c) {
    CHECK(c, "fmi3EnterEventMode", ST_CONTINUOUS);
    inst->d.state = ST_EVENT;
    return fmi3OK;
}

/* The event: the post-step map with the mode of the last event, then the mode anew (satfmu_me.h). */
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation, fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged, fmi3Boolean *nextEventTimeDefined,
                                    fmi3Float64 *nextEventTime) {
    int moved;
    CHECK(c, "fmi3UpdateDiscreteStates", ST_EVENT);
    if (!discreteStatesNeedUpdate || !terminateSimulation || !nominalsOfContinuousStatesChanged ||
        !valuesOfContinuousStatesChanged || !nextEventTimeDefined || !nextEventTime)
        return ERROR(inst, "fmi3UpdateDiscreteStates: NULL result pointer");
    if (me_event(inst, &moved, "fmi3UpdateDiscreteStates") != STATUS_OK) return fmi3Error;
    *discreteStatesNeedUpdate = false;
    *terminateSimulation = false;
    *nominalsOfContinuousStatesChanged = false;
    *valuesOfContinuousStatesChanged = moved != 0;
    *nextEventTimeDefined = false;
    *nextEventTime = 0.0;
    return fmi3OK;
}

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) {
    CHECK(c, "fmi3EnterContinuousTimeMode", ST_EVENT);
    inst->d.state = ST_CONTINUOUS;
    return fmi3OK;
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode, fmi3Boolean *terminateSimulation) {
    CHECK(c, "fmi3CompletedIntegratorStep", ST_CONTINUOUS);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!enterEventMode || !terminateSimulation) return ERROR(inst, "fmi3CompletedIntegratorStep: NULL argument");
    *enterEventMode = false;
    *terminateSimulation = false;
    return fmi3OK;
}

/* ------------------------------------------------------------------ FMI API: the continuous part */
#define READ_MASK (ST_INITIALIZATION | ST_EVENT | ST_CONTINUOUS | ST_TERMINATED | ST_ERROR)

fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 time) {
    CHECK(c, "fmi3SetTime", ST_EVENT | ST_CONTINUOUS);
    return (fmi3Status)me_set_time(inst, time, "fmi3SetTime");
}

fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 continuousStates[], size_t nContinuousStates) {
    CHECK(c, "fmi3SetContinuousStates", ST_CONTINUOUS);
    return (fmi3Status)me_set_states(inst, continuousStates, nContinuousStates, "fmi3SetContinuousStates");
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 derivatives[], size_t nContinuousStates) {
    CHECK(c, "fmi3GetContinuousStateDerivatives", READ_MASK);
    if (inst->d.state == ST_INITIALIZATION) me_initial(inst);
    return (fmi3Status)me_get_derivatives(inst, derivatives, nContinuousStates,
                                          "fmi3GetContinuousStateDerivatives");
}

fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 eventIndicators[], size_t nEventIndicators) {
    CHECK(c, "fmi3GetEventIndicators", READ_MASK);
    if (inst->d.state == ST_INITIALIZATION) me_initial(inst);
    return (fmi3Status)me_get_indicators(inst, eventIndicators, nEventIndicators, "fmi3GetEventIndicators");
}

fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 continuousStates[], size_t nContinuousStates) {
    CHECK(c, "fmi3GetContinuousStates", READ_MASK);
    return (fmi3Status)me_get_states(inst, continuousStates, nContinuousStates, "fmi3GetContinuousStates");
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 nominals[], size_t nContinuousStates) {
    CHECK(c, "fmi3GetNominalsOfContinuousStates", ST_INSTANTIATED | READ_MASK);
    return (fmi3Status)me_get_nominals(inst, nominals, nContinuousStates, "fmi3GetNominalsOfContinuousStates");
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *nEventIndicators) {
    CHECK(c, "fmi3GetNumberOfEventIndicators", ~0);
    if (!nEventIndicators) return ERROR(inst, "fmi3GetNumberOfEventIndicators: NULL argument");
    *nEventIndicators = (size_t)NZ;
    return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *nContinuousStates) {
    CHECK(c, "fmi3GetNumberOfContinuousStates", ~0);
    if (!nContinuousStates) return ERROR(inst, "fmi3GetNumberOfContinuousStates: NULL argument");
    *nContinuousStates = (size_t)NX;
    return fmi3OK;
}

/* ------------------------------------------------------------------ not provided */
fmi3Status fmi3EnterStepMode(fmi3Instance c) {
    NOT_PROVIDED(fmi3EnterStepMode, "model exchange only");
}
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean *eventHandlingNeeded,
                      fmi3Boolean *terminateSimulation, fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime) {
    (void)currentCommunicationPoint; (void)communicationStepSize; (void)noSetFMUStatePriorToCurrentPoint;
    (void)eventHandlingNeeded; (void)terminateSimulation; (void)earlyReturn; (void)lastSuccessfulTime;
    NOT_PROVIDED(fmi3DoStep, "model exchange only");
}
fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *FMUState) {
    (void)FMUState;
    NOT_PROVIDED(fmi3GetFMUState, "canGetAndSetFMUState=false");
}
fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState FMUState) {
    (void)FMUState;
    NOT_PROVIDED(fmi3SetFMUState, "canGetAndSetFMUState=false");
}
fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *FMUState) {
    (void)FMUState;
    NOT_PROVIDED(fmi3FreeFMUState, "canGetAndSetFMUState=false");
}
fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState FMUState, size_t *size) {
    (void)FMUState; (void)size;
    NOT_PROVIDED(fmi3SerializedFMUStateSize, "canSerializeFMUState=false");
}
fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size) {
    (void)FMUState; (void)serializedState; (void)size;
    NOT_PROVIDED(fmi3SerializeFMUState, "canSerializeFMUState=false");
}
fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState *FMUState) {
    (void)serializedState; (void)size; (void)FMUState;
    NOT_PROVIDED(fmi3DeserializeFMUState, "canSerializeFMUState=false");
}
