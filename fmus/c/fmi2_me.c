/*
 * satfmu: the FMI 2.0 model-exchange interface of a plant generated from a symbolic definition
 * (fmus/model.py). The importer's solver integrates the continuous states; satfmu_me.h gives it the
 * state, its derivatives and the event indicators (fmus/events.py) and handles the events (modes,
 * hysteresis: described there); fmi2_common.h is what this file shares with the co-simulation
 * interface fmi2_cosim.c (variable access, instantiation, initialization); the model's C (model.h)
 * and satfmu_core.h are those of the co-simulation FMU. This file is the FMU's only translation
 * unit. Written for this project.
 *
 * Variables beyond the co-simulation FMU's (value references NV.. in the description): NV + i is
 * the derivative of state i, NV + NX + i state i itself (listed for the states no output carries).
 *
 * Robustness: every call checks the instance pointer, the call order against the FMI 2.0
 * model-exchange state machine, value references, types, finiteness and declared ranges; a
 * violation returns fmi2Error with a message and changes nothing. A non-finite state, derivative,
 * event indicator or output puts the instance in the error state: never returned with fmi2OK.
 */
#define STEP_STATE_NAME "ContinuousTimeMode"
#define ST_CONTINUOUS ST_STEP_COMPLETE
#define FMU_TYPE fmi2ModelExchange
#define FMU_TYPE_ONLY \
    "this FMU supports model exchange only (the co-simulation FMU of this model is a file of its own)"
#define GET_MASK (ST_INITIALIZATION | ST_EVENT | ST_CONTINUOUS | ST_TERMINATED | ST_ERROR)
#define SET_MASK (ST_INSTANTIATED | ST_INITIALIZATION | ST_EVENT | ST_CONTINUOUS | ST_TERMINATED | ST_ERROR)

/* the co-simulation step functions of satfmu_core.h (integration, sampling, FMU state records)
 * are not used by model exchange */
#if defined(__GNUC__)
#pragma GCC diagnostic ignored "-Wunused-function"
#endif
#include "fmi2_common.h"

/* ------------------------------------------------------------------ FMI API: life cycle */
/* The initial state from the parameters; the mode is the initial state. Event Mode follows. */
fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    CHECK(c, "fmi2ExitInitializationMode", ST_INITIALIZATION);
    if (exit_initialization(inst, "fmi2ExitInitializationMode") != STATUS_OK) return fmi2Error;
    me_start(inst);
    inst->d.state = ST_EVENT;
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c) {
    CHECK(c, "fmi2Terminate", ST_EVENT | ST_CONTINUOUS);
    inst->d.state = ST_TERMINATED;
    return fmi2OK;
}

/* ------------------------------------------------------------------ not provided */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    (void)FMUstate;
    NOT_PROVIDED(fmi2GetFMUstate, "canGetAndSetFMUstate=false");
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    (void)FMUstate;
    NOT_PROVIDED(fmi2SetFMUstate, "canGetAndSetFMUstate=false");
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    (void)FMUstate;
    NOT_PROVIDED(fmi2FreeFMUstate, "canGetAndSetFMUstate=false");
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    (void)FMUstate; (void)size;
    NOT_PROVIDED(fmi2SerializedFMUstateSize, "canSerializeFMUstate=false");
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[], size_t size) {
    (void)FMUstate; (void)serializedState; (void)size;
    NOT_PROVIDED(fmi2SerializeFMUstate, "canSerializeFMUstate=false");
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    (void)serializedState; (void)size; (void)FMUstate;
    NOT_PROVIDED(fmi2DeSerializeFMUstate, "canSerializeFMUstate=false");
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    NOT_PROVIDED(fmi2GetDirectionalDerivative, "providesDirectionalDerivative=false");
}

/* ------------------------------------------------------------------ FMI API: model exchange */
fmi2Status fmi2EnterEventMode(fmi2Component c) {
    CHECK(c, "fmi2EnterEventMode", ST_EVENT | ST_CONTINUOUS);
    inst->d.state = ST_EVENT;
    return fmi2OK;
}

/* The event: the post-step map with the mode of the last event, then the mode anew (satfmu_me.h). */
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo) {
    int moved;
    CHECK(c, "fmi2NewDiscreteStates", ST_EVENT);
    if (!eventInfo) return ERROR(inst, "fmi2NewDiscreteStates: NULL eventInfo");
    if (me_event(inst, &moved, "fmi2NewDiscreteStates") != STATUS_OK) return fmi2Error;
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = moved ? fmi2True : fmi2False;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    return fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    CHECK(c, "fmi2EnterContinuousTimeMode", ST_EVENT);
    inst->d.state = ST_CONTINUOUS;
    return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation) {
    CHECK(c, "fmi2CompletedIntegratorStep", ST_CONTINUOUS);
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!enterEventMode || !terminateSimulation) return ERROR(inst, "fmi2CompletedIntegratorStep: NULL argument");
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) {
    CHECK(c, "fmi2SetTime", ST_EVENT | ST_CONTINUOUS);
    return (fmi2Status)me_set_time(inst, time, "fmi2SetTime");
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    CHECK(c, "fmi2SetContinuousStates", ST_CONTINUOUS);
    return (fmi2Status)me_set_states(inst, x, nx, "fmi2SetContinuousStates");
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx) {
    CHECK(c, "fmi2GetDerivatives", ST_EVENT | ST_CONTINUOUS | ST_TERMINATED | ST_ERROR);
    return (fmi2Status)me_get_derivatives(inst, derivatives, nx, "fmi2GetDerivatives");
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni) {
    CHECK(c, "fmi2GetEventIndicators", ST_EVENT | ST_CONTINUOUS | ST_TERMINATED | ST_ERROR);
    return (fmi2Status)me_get_indicators(inst, eventIndicators, ni, "fmi2GetEventIndicators");
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    CHECK(c, "fmi2GetContinuousStates", ST_INITIALIZATION | ST_EVENT | ST_CONTINUOUS | ST_TERMINATED | ST_ERROR);
    return (fmi2Status)me_get_states(inst, x, nx, "fmi2GetContinuousStates");
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx) {
    CHECK(c, "fmi2GetNominalsOfContinuousStates", ST_INSTANTIATED | ST_EVENT | ST_CONTINUOUS | ST_TERMINATED |
          ST_ERROR);
    return (fmi2Status)me_get_nominals(inst, x_nominal, nx, "fmi2GetNominalsOfContinuousStates");
}
