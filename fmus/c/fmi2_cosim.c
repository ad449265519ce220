/*
 * satfmu: the FMI 2.0 co-simulation interface of a model generated from a symbolic definition
 * (fmus/model.py). Everything that does not depend on the interface (time, sampling, integration,
 * variable checks, FMU state records; described in satfmu_core.h) is in satfmu_core.h, which
 * includes the generated model.h, and what FMI 2.0's interfaces share (variable access,
 * instantiation, initialization) in fmi2_common.h; this file is the FMU's only translation unit, so
 * a tool may compile every .c file under sources/ or the one <SourceFiles> lists. fmi3.c is the
 * FMI 3.0 interface of the same model. Written for this project.
 *
 * Robustness: every call checks the instance pointer, the call order against the
 * FMI 2.0 co-simulation state machine, value references, types, finiteness and
 * declared ranges; a violation returns fmi2Error with a message naming the
 * variable and never changes the stored values. A step whose state becomes
 * non-finite, a sample with a non-finite value and a non-finite output put the instance in
 * the error state (fmi2SetFMUstate or fmi2Reset recover it): no output is ever non-finite
 * with fmi2OK.
 */
#define FMU_TYPE fmi2CoSimulation
#define FMU_TYPE_ONLY "this FMU supports co-simulation only"
#define GET_MASK (ST_INITIALIZATION | ST_STEP_COMPLETE | ST_TERMINATED | ST_ERROR)
#define SET_MASK (ST_INSTANTIATED | ST_INITIALIZATION | ST_STEP_COMPLETE | ST_TERMINATED | ST_ERROR)

#include "fmi2_common.h"

/* ------------------------------------------------------------------ FMI API */
fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    CHECK(c, "fmi2ExitInitializationMode", ST_INITIALIZATION);
    if (exit_initialization(inst, "fmi2ExitInitializationMode") != STATUS_OK) return fmi2Error;
    inst->d.state = ST_STEP_COMPLETE;
    return fmi2OK;
}

/* FMI 2.0: fmi2Terminate only from stepComplete (or stepFailed, which this FMU never enters):
 * an instance in the error state is reset or freed, not terminated. */
fmi2Status fmi2Terminate(fmi2Component c) {
    CHECK(c, "fmi2Terminate", ST_STEP_COMPLETE);
    inst->d.state = ST_TERMINATED;
    return fmi2OK;
}

/* ------------------------------------------------------------------ FMU state */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    CHECK(c, "fmi2GetFMUstate", STATE_MASK);
    return (fmi2Status)state_get(inst, FMUstate, "fmi2GetFMUstate");
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate) {
    CHECK(c, "fmi2SetFMUstate", STATE_MASK);
    return (fmi2Status)state_set(inst, FMUstate, "fmi2SetFMUstate");
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate) {
    CHECK(c, "fmi2FreeFMUstate", STATE_MASK);
    state_free(FMUstate);
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size) {
    CHECK(c, "fmi2SerializedFMUstateSize", STATE_MASK);
    return (fmi2Status)state_size(inst, FMUstate, size, "fmi2SerializedFMUstateSize");
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate, fmi2Byte serializedState[],
                                 size_t size) {
    CHECK(c, "fmi2SerializeFMUstate", STATE_MASK);
    return (fmi2Status)state_serialize(inst, FMUstate, (unsigned char *)serializedState, size,
                                       "fmi2SerializeFMUstate");
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate) {
    CHECK(c, "fmi2DeSerializeFMUstate", STATE_MASK);
    return (fmi2Status)state_deserialize(inst, (const unsigned char *)serializedState, size, FMUstate,
                                         "fmi2DeSerializeFMUstate");
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
    CHECK(c, "fmi2GetDirectionalDerivative", STATE_MASK);
    (void)vUnknown_ref; (void)nUnknown; (void)vKnown_ref; (void)nKnown; (void)dvKnown; (void)dvUnknown;
    return ERROR(inst, "fmi2GetDirectionalDerivative: not provided (providesDirectionalDerivative=false)");
}

/* ------------------------------------------------------------------ co-simulation */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
    CHECK(c, "fmi2SetRealInputDerivatives", STATE_MASK);
    (void)vr; (void)nvr; (void)order; (void)value;
    return ERROR(inst, "fmi2SetRealInputDerivatives: inputs are held constant (canInterpolateInputs=false)");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
    CHECK(c, "fmi2GetRealOutputDerivatives", STATE_MASK);
    (void)vr; (void)nvr; (void)order; (void)value;
    return ERROR(inst, "fmi2GetRealOutputDerivatives: not provided (maxOutputDerivativeOrder=0)");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint, fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
    int early;
    CHECK(c, "fmi2DoStep", ST_STEP_COMPLETE);
    (void)noSetFMUStatePriorToCurrentPoint;
    return (fmi2Status)do_step(inst, currentCommunicationPoint, communicationStepSize, 0, &early, "fmi2DoStep");
}

fmi2Status fmi2CancelStep(fmi2Component c) {
    CHECK(c, "fmi2CancelStep", STATE_MASK);
    return ERROR(inst, "fmi2CancelStep: fmi2DoStep is synchronous, there is nothing to cancel");
}

/* ------------------------------------------------------------------ status queries */
/* FMI 2.0 (section 4.2.3 and the co-simulation state table): the status functions may be called
 * in stepComplete, stepInProgress, stepFailed and terminated; elsewhere (Instantiated,
 * InitializationMode, Error) they return fmi2Error. This FMU provides
 *   fmi2GetRealStatus(fmi2LastSuccessfulTime): fmi2OK, the FMU time (the end of the last step),
 *   fmi2GetBooleanStatus(fmi2Terminated): fmi2OK, fmi2False (this FMU never asks to terminate),
 * and no other status: fmi2DoStepStatus and fmi2PendingStatus exist only after fmi2DoStep returned
 * fmi2Pending, which this synchronous FMU never does, so every other (function, kind) pair returns
 * fmi2Discard ("a status ... which cannot be retrieved by the slave") with a message; a kind that
 * is no fmi2StatusKind returns fmi2Error. */
#define STATUS_MASK (ST_STEP_COMPLETE | ST_TERMINATED)

static const char *status_kind_name(fmi2StatusKind s) {
    switch (s) {
    case fmi2DoStepStatus: return "fmi2DoStepStatus";
    case fmi2PendingStatus: return "fmi2PendingStatus";
    case fmi2LastSuccessfulTime: return "fmi2LastSuccessfulTime";
    case fmi2Terminated: return "fmi2Terminated";
    default: return NULL;
    }
}

/* The answer for a status this FMU does not provide: fmi2Discard, or fmi2Error for a NULL
 * value pointer or an unknown kind. */
static fmi2Status no_status(Instance *inst, const char *fn, fmi2StatusKind s, const void *value) {
    const char *kind = status_kind_name(s);
    if (!kind) return ERROR(inst, "%s: %d is no fmi2StatusKind", fn, (int)s);
    if (!value) return ERROR(inst, "%s: NULL value pointer", fn);
    log_msg(inst, fmi2Discard, "logStatusDiscard", "%s: %s is not provided (fmi2DoStep is synchronous; this FMU "
            "provides fmi2GetRealStatus(fmi2LastSuccessfulTime) and fmi2GetBooleanStatus(fmi2Terminated))", fn,
            kind);
    return fmi2Discard;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value) {
    CHECK(c, "fmi2GetStatus", STATUS_MASK);
    return no_status(inst, "fmi2GetStatus", s, value);
}
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value) {
    CHECK(c, "fmi2GetRealStatus", STATUS_MASK);
    if (s == fmi2LastSuccessfulTime && value) {
        *value = inst->d.time;
        return fmi2OK;
    }
    return no_status(inst, "fmi2GetRealStatus", s, value);
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value) {
    CHECK(c, "fmi2GetIntegerStatus", STATUS_MASK);
    return no_status(inst, "fmi2GetIntegerStatus", s, value);
}
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value) {
    CHECK(c, "fmi2GetBooleanStatus", STATUS_MASK);
    if (s == fmi2Terminated && value) {
        *value = fmi2False;
        return fmi2OK;
    }
    return no_status(inst, "fmi2GetBooleanStatus", s, value);
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value) {
    CHECK(c, "fmi2GetStringStatus", STATUS_MASK);
    return no_status(inst, "fmi2GetStringStatus", s, value);
}